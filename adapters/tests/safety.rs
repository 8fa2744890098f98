//! Safety properties checked against oracles written out here from the sources, never derived
//! from the tables under test (issue 18):
//!
//! * Dex3-1 closing direction and wire limits per joint and side, including the thumb.
//! * The per-step and joint limits on every accepted command, and rejection exactly when a
//!   command holds a non-finite number.
//! * What the watchdog's safe actions command: `hold` holds the *measured* position, not the
//!   last target; `limp` zero gains; `open` the open posture.

use handgate_adapters::control::{Active, CommandState};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::mapping::{DeviceTable, Limits};
use handgate_adapters::model::{
    CommandBody, DeviceKind, HandCommand, JointCommand, JointId, JointState, SafeAction, Side,
};
use proptest::prelude::*;
use std::sync::Arc;

/// One Dex3-1 joint as the sources give it: IDL index, name, the URDF's wire limits (rad) and
/// the wire direction in which the joint closes (flexes toward the palm), per side.
struct Dex3Joint {
    idl: usize,
    name: &'static str,
    left: (f32, f32),
    left_closing: f32,
    right: (f32, f32),
    right_closing: f32,
}

/// Written out from the sources, not from `dex3::table`:
///
/// * Limits: the URDFs xr_teleoperate uses (`assets/unitree_hand/unitree_dex3_{left,right}.urdf`,
///   docs/sources.md §2), literally to their 4 decimals. thumb_1 is the exception: handgate's default is the Dex3-1 manual's −35°…60°
///   (rounded inward to [−0.6108, 1.0472] on the left, mirrored on the right), not the URDF's
///   [−0.7243, 0.920], so the SDK example's 1.05 pose is reachable (docs/model.md, "Joint limits").
/// * Closing direction: the Dex3-1 user manual's "Angle of Joint" gives each joint's travel as
///   flexion from straight: thumb joint 1 −35°…60°, thumb joint 2 0…100°, index/middle
///   joint 0 0…90°, joint 1 0…100°. The URDF ranges place that flexion on the wire: left
///   fingers [−1.5708, 0] / [−1.7453, 0] (closing negative), right fingers [0, 1.5708] /
///   [0, 1.7453] (closing positive); left thumb_2 [0, 1.7453] (closing positive), right
///   [−1.7453, 0] (closing negative); thumb_1's larger excursion (the manual's 60°) is +0.920 on
///   the left and −0.920 on the right.
/// * thumb_0 is a rotation with a symmetric ±60° range (manual, URDF ±1.0472): it has no
///   flexion. handgate's convention (docs/model.md) mirrors it like the rest of the thumb:
///   canonical positive = wire positive on the left, wire negative on the right.
#[allow(clippy::approx_constant)]
const DEX3: [Dex3Joint; 7] = [
    Dex3Joint {
        idl: 0,
        name: "thumb_0",
        left: (-1.0472, 1.0472),
        left_closing: 1.0,
        right: (-1.0472, 1.0472),
        right_closing: -1.0,
    },
    Dex3Joint {
        idl: 1,
        name: "thumb_1",
        left: (-0.6108, 1.0472),
        left_closing: 1.0,
        right: (-1.0472, 0.6108),
        right_closing: -1.0,
    },
    Dex3Joint {
        idl: 2,
        name: "thumb_2",
        left: (0.0, 1.7453),
        left_closing: 1.0,
        right: (-1.7453, 0.0),
        right_closing: -1.0,
    },
    Dex3Joint {
        idl: 3,
        name: "middle_0",
        left: (-1.5708, 0.0),
        left_closing: -1.0,
        right: (0.0, 1.5708),
        right_closing: 1.0,
    },
    Dex3Joint {
        idl: 4,
        name: "middle_1",
        left: (-1.7453, 0.0),
        left_closing: -1.0,
        right: (0.0, 1.7453),
        right_closing: 1.0,
    },
    Dex3Joint {
        idl: 5,
        name: "index_0",
        left: (-1.5708, 0.0),
        left_closing: -1.0,
        right: (0.0, 1.5708),
        right_closing: 1.0,
    },
    Dex3Joint {
        idl: 6,
        name: "index_1",
        left: (-1.7453, 0.0),
        left_closing: -1.0,
        right: (0.0, 1.7453),
        right_closing: 1.0,
    },
];

fn dex3(side: Side) -> DeviceTable {
    DeviceKind::Dex3.table(side, &TableOverrides::default()).unwrap()
}

/// The wire targets a full-hand command resolves to.
fn wire_of(t: &DeviceTable, canonical_q: &[f32]) -> Vec<f32> {
    let body = CommandBody::Joints(
        canonical_q
            .iter()
            .enumerate()
            .map(|(i, q)| (JointId(i as u8), JointCommand::hold(*q, 1.0, 0.1)))
            .collect(),
    );
    let out = t.resolve(&body, None, &[]).unwrap();
    t.to_wire(&out).iter().map(|w| w.q).collect()
}

#[test]
fn dex3_closing_direction_per_joint_and_side_matches_the_sources() {
    for side in [Side::Left, Side::Right] {
        let t = dex3(side);
        for j in &DEX3 {
            let id = t.joint_by_name(j.name).unwrap();
            assert_eq!(t.joint(id).unwrap().wire_index, j.idl, "{side:?} {}", j.name);
            let closing = if side == Side::Left {
                j.left_closing
            } else {
                j.right_closing
            };
            // A small canonical closing step (+0.2 rad) moves the wire target in the closing
            // direction; an opening step the other way. Starting from the middle of the range
            // so neither is clamped away.
            let (lo, hi) = if side == Side::Left { j.left } else { j.right };
            let mid_wire = 0.5 * (lo + hi);
            let mid = t.joint(id).unwrap().q_from_wire(mid_wire);
            let mut q = vec![0.0f32; 7];
            q[id.index()] = mid + 0.2;
            let w_close = wire_of(&t, &q)[j.idl];
            q[id.index()] = mid - 0.2;
            let w_open = wire_of(&t, &q)[j.idl];
            assert!(
                (w_close - mid_wire) * closing > 0.15 && (w_open - mid_wire) * closing < -0.15,
                "{side:?} {}: canonical closing moved the wire from {mid_wire} to {w_close} (opening to \
                 {w_open}); the sources close this joint toward {closing:+}",
                j.name
            );
        }
        // The default closed posture closes every joint it moves, in the sources' direction.
        let closed = t.closure_targets(1.0, None).unwrap();
        let wire = t.to_wire(&closed);
        for j in &DEX3 {
            let closing = if side == Side::Left {
                j.left_closing
            } else {
                j.right_closing
            };
            let w = wire[j.idl].q;
            assert!(w * closing >= 0.0, "{side:?} {}: closed posture at wire {w}", j.name);
        }
    }
}

#[test]
fn dex3_commands_far_outside_are_clamped_to_the_urdf_limits_on_the_wire() {
    for side in [Side::Left, Side::Right] {
        let t = dex3(side);
        for far in [50.0f32, -50.0] {
            let wire = wire_of(&t, &[far; 7]);
            for j in &DEX3 {
                let (lo, hi) = if side == Side::Left { j.left } else { j.right };
                let closing = if side == Side::Left {
                    j.left_closing
                } else {
                    j.right_closing
                };
                // Canonical +50 is far closed: the wire limit on the closing side.
                let expect = if (far > 0.0) == (closing > 0.0) { hi } else { lo };
                let w = wire[j.idl];
                assert!(
                    (w - expect).abs() < 1e-4,
                    "{side:?} {} canonical {far}: wire {w}, URDF range [{lo}, {hi}] says {expect}",
                    j.name
                );
            }
        }
        for j in &DEX3 {
            let (lo, hi) = if side == Side::Left { j.left } else { j.right };
            let (a, b) = t.wire_limits(t.joint_by_name(j.name).unwrap()).unwrap();
            assert!(
                (a - lo).abs() < 1e-4 && (b - hi).abs() < 1e-4,
                "{side:?} {}: [{a}, {b}]",
                j.name
            );
        }
    }
}

/// A Dex3 target past the hand's range (its limits are the hard stops of the manual) is the
/// stop as position and the stiffness's pull past it as feed-forward torque, in the wire's
/// sign: the motor law then gives what the unclamped target would, up to max_tau (issue #37: a
/// calibration that pushes thumb_0 towards 2.09 rad and reads where it stops). A soft limit
/// a profile sets stays a plain clamp.
#[test]
fn a_dex3_target_past_a_hard_stop_pushes_into_it_and_a_profile_limit_clamps() {
    for side in [Side::Left, Side::Right] {
        let t = dex3(side);
        let id = t.joint_by_name("thumb_0").unwrap();
        let stop = t.joints[id.index()].limits.max;
        let cmd = |q: f32| JointCommand::hold(q, 1.5, 0.1);
        let c = t.sanitize(id, &cmd(stop + 0.5), None).unwrap();
        assert_eq!(c.q, stop, "{side:?}");
        assert!((c.tau - 0.75).abs() < 1e-5, "{side:?}: 1.5 * 0.5 past the stop: {c:?}");
        let w = t.joints[id.index()].to_wire(&c);
        assert!(
            w.tau * w.q > 0.0,
            "{side:?}: the push is towards the stop on the wire: {w:?}"
        );
        let c = t.sanitize(id, &cmd(stop + 10.0), None).unwrap();
        assert_eq!((c.q, c.tau), (stop, t.max_tau), "{side:?}: within max_tau");
        let c = t.sanitize(id, &cmd(-stop - 0.2), None).unwrap();
        assert!(
            (c.q + stop).abs() < 1e-6 && (c.tau + 0.3).abs() < 1e-5,
            "{side:?}: {c:?}"
        );
        let c = t.sanitize(id, &cmd(stop - 0.1), None).unwrap();
        assert_eq!(c.tau, 0.0, "inside the range nothing is added");
        // A profile's narrower limit is a soft limit: clamped, no push.
        let o = TableOverrides {
            limits: [("thumb_0".to_string(), Limits::new(-0.5, 0.5))].into_iter().collect(),
            ..Default::default()
        };
        let t = DeviceKind::Dex3.table(side, &o).unwrap();
        let c = t.sanitize(id, &cmd(2.0), None).unwrap();
        assert_eq!((c.q, c.tau), (0.5, 0.0), "{side:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// The per-step and joint limits on every accepted command.

fn any_table() -> impl Strategy<Value = DeviceTable> {
    (0usize..4, prop::bool::ANY, prop::option::of(0.01f32..0.5)).prop_map(|(k, right, step)| {
        let side = if right { Side::Right } else { Side::Left };
        let mut t = DeviceKind::ALL[k].table(side, &TableOverrides::default()).unwrap();
        t.max_step = step;
        t
    })
}

fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -10.0f32..10.0,
        1 => -1.0e30f32..1.0e30,
        1 => Just(f32::MAX),
        1 => Just(f32::MIN),
        1 => Just(0.0f32),
    ]
}

fn non_finite() -> impl Strategy<Value = f32> {
    prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)]
}

fn finite_cmd() -> impl Strategy<Value = JointCommand> {
    (finite(), finite(), finite(), finite(), finite()).prop_map(|(q, dq, tau, kp, kd)| JointCommand {
        q,
        dq,
        tau,
        kp,
        kd,
    })
}

/// A table, measured positions inside its limits (fractions of each joint's span), and a
/// full-hand body of finite commands.
fn finite_case() -> impl Strategy<Value = (DeviceTable, Vec<f32>, Vec<JointCommand>)> {
    any_table().prop_flat_map(|t| {
        let n = t.joint_count();
        (
            Just(t),
            prop::collection::vec(0.0f32..=1.0, n),
            prop::collection::vec(finite_cmd(), n),
        )
    })
}

/// As [`finite_case`] with exactly one field of one joint replaced by a non-finite value.
fn non_finite_case() -> impl Strategy<Value = (DeviceTable, Vec<f32>, Vec<JointCommand>)> {
    finite_case().prop_flat_map(|(t, frac, cmds)| {
        let n = cmds.len();
        (Just(t), Just(frac), Just(cmds), 0..n, 0usize..5, non_finite()).prop_map(
            |(t, frac, mut cmds, j, field, bad)| {
                let c = &mut cmds[j];
                *[&mut c.q, &mut c.dq, &mut c.tau, &mut c.kp, &mut c.kd][field] = bad;
                (t, frac, cmds)
            },
        )
    })
}

fn measured_of(t: &DeviceTable, frac: &[f32]) -> Vec<JointState> {
    t.joints
        .iter()
        .zip(frac)
        .map(|(j, f)| JointState {
            q: j.limits.min + f * j.limits.span(),
            ..Default::default()
        })
        .collect()
}

fn body_of(cmds: &[JointCommand]) -> CommandBody {
    CommandBody::Joints(cmds.iter().enumerate().map(|(i, c)| (JointId(i as u8), *c)).collect())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Every finite command is accepted, and what it resolves to is inside the joint limits,
    /// within `max_step` of the measured position, and equal to the request wherever the
    /// request already was inside every bound.
    #[test]
    fn finite_commands_are_accepted_and_bounded((t, frac, cmds) in finite_case()) {
        let meas = measured_of(&t, &frac);
        let out = t.resolve(&body_of(&cmds), None, &meas);
        prop_assert!(out.is_ok(), "{:?}: finite command rejected: {:?} ({:?})", t.kind, cmds, out);
        let out = out.unwrap();
        prop_assert_eq!(out.len(), t.joint_count());
        for (i, (c, req)) in out.iter().zip(&cmds).enumerate() {
            let l = t.joints[i].limits;
            let m = meas[i].q;
            prop_assert!(c.is_finite(), "{:?}", c);
            prop_assert!(l.contains(c.q), "{:?} joint {} q {} outside {:?}", t.kind, i, c.q, l);
            if let Some(s) = t.max_step {
                prop_assert!((c.q - m).abs() <= s * (1.0 + 1e-5) + 1e-6,
                    "{:?} joint {}: q {} is more than max_step {} from measured {}", t.kind, i, c.q, s, m);
            }
            let step_ok = match t.max_step { Some(s) => (req.q - m).abs() <= s, None => true };
            if l.contains(req.q) && step_ok {
                prop_assert_eq!(c.q, req.q, "joint {} clamped although inside every bound", i);
            } else {
                // Clamped, toward the request: never past it, never the other way.
                prop_assert!((c.q - m) * (req.q - m) >= 0.0 || (c.q - m).abs() <= 1e-6,
                    "joint {}: request {} from {} became {}", i, req.q, m, c.q);
            }
            prop_assert!(c.kp >= 0.0 && c.kp <= t.max_kp && c.kd >= 0.0 && c.kd <= t.max_kd, "{:?}", c);
            prop_assert!(c.tau.abs() <= t.max_tau, "{:?}", c);
            prop_assert!(c.dq.abs() <= 100.0, "{:?}", c);
            if (0.0..=t.max_kp).contains(&req.kp) { prop_assert_eq!(c.kp, req.kp); }
            if (0.0..=t.max_kd).contains(&req.kd) { prop_assert_eq!(c.kd, req.kd); }
            // Past a hard stop, the pull beyond it is feed-forward torque into the stop.
            let push = if l.stops && c.q == l.clamp(req.q) { c.kp * (req.q - c.q) } else { 0.0 };
            if push == 0.0 {
                if req.tau.abs() <= t.max_tau { prop_assert_eq!(c.tau, req.tau); }
            } else {
                prop_assert_eq!(c.tau, (req.tau + push).clamp(-t.max_tau, t.max_tau));
            }
            if req.dq.abs() <= 100.0 { prop_assert_eq!(c.dq, req.dq); }
        }
        for w in t.to_wire(&out) {
            prop_assert!(w.q.is_finite() && w.dq.is_finite() && w.tau.is_finite() && w.kp.is_finite() && w.kd.is_finite());
        }
        // The same through the command slot the device loops use: accepted, and what is in
        // force after a step obeys the same bounds.
        let cs = CommandState::new(Arc::new(t.clone()));
        let accepted = cs.submit(HandCommand { seq: 1, body: body_of(&cmds), tag: 0 }).is_ok();
        prop_assert!(accepted);
        match cs.step(&meas) {
            Active::Command(v) => prop_assert_eq!(v, out),
            other => prop_assert!(false, "not in force: {:?}", other),
        }
    }

    /// A command holding any non-finite number is rejected, and nothing changes.
    #[test]
    fn non_finite_commands_are_rejected((t, frac, cmds) in non_finite_case()) {
        let meas = measured_of(&t, &frac);
        prop_assert!(t.resolve(&body_of(&cmds), None, &meas).is_err(), "{:?} accepted {:?}", t.kind, cmds);
        let cs = CommandState::new(Arc::new(t.clone()));
        let rejected = cs.submit(HandCommand { seq: 1, body: body_of(&cmds), tag: 0 }).is_err();
        prop_assert!(rejected);
        prop_assert_eq!(cs.step(&meas), Active::Idle);
    }

    /// Closures: finite → accepted and inside the limits; non-finite → rejected.
    #[test]
    fn closures_are_bounded_or_rejected(t in any_table(), c in finite(), bad in non_finite()) {
        let out = t.resolve(&CommandBody::Closure { closure: c, stiffness: None }, None, &[]);
        prop_assert!(out.is_ok());
        for (i, j) in out.unwrap().iter().enumerate() {
            prop_assert!(t.joints[i].limits.contains(j.q) && j.is_finite());
        }
        let rejected = t.resolve(&CommandBody::Closure { closure: bad, stiffness: None }, None, &[]).is_err();
        prop_assert!(rejected);
    }
}

// ---------------------------------------------------------------------------------------------
// What the watchdog's safe actions command, through the command slot every device loop uses.

/// A Dex3 left hand commanded toward index_0 far closed, tripped while index_0 is on its way.
fn tripped_on_the_way(action: SafeAction) -> (DeviceTable, Vec<JointCommand>, Vec<JointState>) {
    let t = dex3(Side::Left);
    let cs = CommandState::new(Arc::new(t.clone()));
    let ix = t.joint_by_name("index_0").unwrap().index();
    let mut far = vec![JointCommand::hold(0.0, 1.5, 0.1); 7];
    far[ix].q = 1.5; // canonical: far closed
    let start = vec![JointState::default(); 7];
    cs.submit(HandCommand {
        seq: 1,
        body: body_of(&far),
        tag: 0,
    })
    .unwrap();
    match cs.step(&start) {
        Active::Command(v) => assert_eq!(v[ix].q, 1.5),
        other => panic!("{other:?}"),
    }
    // On its way: index_0 measured at 0.4, the rest where they were.
    let mut moving = start.clone();
    moving[ix].q = 0.4;
    moving[ix].dq = 2.0;
    cs.step(&moving);
    cs.request_safe(action);
    let Active::Safe(a, targets) = cs.step(&moving) else {
        panic!("no safe state")
    };
    assert_eq!(a, action);
    // Later steps keep the safe targets (the joint does not creep on to the old target).
    let mut later = moving.clone();
    later[ix].q = 0.45;
    assert_eq!(cs.step(&later), Active::Safe(action, targets.clone()));
    assert!(cs.is_safe());
    (t, targets, moving)
}

#[test]
fn watchdog_hold_holds_the_measured_position_not_the_last_target() {
    let (t, targets, measured) = tripped_on_the_way(SafeAction::Hold);
    for (i, c) in targets.iter().enumerate() {
        assert_eq!(
            c.q, measured[i].q,
            "joint {i}: hold at {} instead of measured {}",
            c.q, measured[i].q
        );
        assert!(c.kp > 0.0, "a hold needs stiffness: {c:?}");
        assert_eq!((c.dq, c.tau), (0.0, 0.0));
    }
    assert_eq!((targets[0].kp, targets[0].kd), (t.hold_kp, t.hold_kd));
}

#[test]
fn watchdog_limp_zeroes_every_gain_and_torque() {
    let (_, targets, _) = tripped_on_the_way(SafeAction::Limp);
    for c in &targets {
        assert_eq!((c.kp, c.kd, c.tau, c.dq), (0.0, 0.0, 0.0, 0.0), "{c:?}");
    }
}

#[test]
fn watchdog_open_drives_every_joint_to_the_open_posture() {
    let (t, targets, _) = tripped_on_the_way(SafeAction::Open);
    // Dex3-1 open: the hand straight, wire 0 on every joint (docs/model.md).
    for (i, w) in t.to_wire(&targets).iter().enumerate() {
        assert_eq!(w.q, 0.0, "joint {i}: {w:?}");
        assert!(w.kp > 0.0);
    }
}

#[test]
fn a_client_command_after_the_trip_is_resolved_against_the_measured_state() {
    let (t, _, measured) = tripped_on_the_way(SafeAction::Hold);
    let mut t = t;
    t.max_step = Some(0.1);
    let cs = CommandState::new(Arc::new(t.clone()));
    let ix = t.joint_by_name("index_0").unwrap().index();
    let mut far = vec![JointCommand::hold(0.0, 1.5, 0.1); 7];
    far[ix].q = 1.5;
    cs.submit(HandCommand {
        seq: 7,
        body: body_of(&far),
        tag: 9,
    })
    .unwrap();
    let Active::Command(v) = cs.step(&measured) else {
        panic!()
    };
    assert!((v[ix].q - (measured[ix].q + 0.1)).abs() < 1e-6, "{}", v[ix].q);
    assert_eq!(cs.applied(), (7, 9));
}

// ---------------------------------------------------------------------------------------------
// The command slot's bookkeeping the status table and the reconnect logic rely on.

#[test]
fn counters_count_accepted_and_rejected_commands_and_report_the_link() {
    use std::sync::atomic::Ordering;
    let t = dex3(Side::Left);
    let cs = CommandState::new(Arc::new(t));
    let s = cs.counters.snapshot();
    assert_eq!((s.commands, s.rejected, s.link_up), (0, 0, false));
    let good = vec![JointCommand::hold(0.2, 1.0, 0.1); 7];
    let mut bad = good.clone();
    bad[3].kd = f32::NAN;
    cs.submit(HandCommand {
        seq: 1,
        body: body_of(&good),
        tag: 0,
    })
    .unwrap();
    cs.submit(HandCommand {
        seq: 2,
        body: body_of(&good),
        tag: 0,
    })
    .unwrap();
    assert!(cs
        .submit(HandCommand {
            seq: 3,
            body: body_of(&bad),
            tag: 0,
        })
        .is_err());
    cs.counters.link_up.store(1, Ordering::Relaxed);
    cs.counters.sent.store(7, Ordering::Relaxed);
    let s = cs.counters.snapshot();
    assert_eq!((s.commands, s.rejected, s.sent, s.link_up), (2, 1, 7, true));
    cs.counters.link_up.store(0, Ordering::Relaxed);
    assert!(!cs.counters.snapshot().link_up);
}

#[test]
fn reseed_replaces_what_was_in_force_by_a_hold_at_the_measured_state() {
    let t = dex3(Side::Left);
    let cs = CommandState::new(Arc::new(t.clone()));
    let ix = t.joint_by_name("index_0").unwrap().index();
    // Nothing commanded yet: nothing to hold, nothing counted.
    cs.reseed(&[JointState::default(); 7]);
    assert_eq!(cs.step(&[JointState::default(); 7]), Active::Idle);
    assert!(!cs.is_safe());
    assert_eq!(cs.counters.snapshot().reseeds, 0);
    let mut far = vec![JointCommand::hold(0.0, 1.5, 0.1); 7];
    far[ix].q = 1.5;
    cs.submit(HandCommand {
        seq: 1,
        body: body_of(&far),
        tag: 0,
    })
    .unwrap();
    assert!(matches!(cs.step(&[JointState::default(); 7]), Active::Command(_)));
    assert!(!cs.is_safe(), "a client command is not a safe state");
    // A command submitted while the link was down is dropped by the reseed too.
    far[ix].q = 1.0;
    cs.submit(HandCommand {
        seq: 2,
        body: body_of(&far),
        tag: 0,
    })
    .unwrap();
    let mut back = vec![JointState::default(); 7];
    back[ix].q = 0.3;
    cs.reseed(&back);
    let expect = t.hold_measured(&back);
    assert_eq!(cs.step(&back), Active::Safe(SafeAction::Hold, expect.clone()));
    assert_eq!(expect[ix].q, 0.3);
    assert!(cs.is_safe());
    assert_eq!(cs.counters.snapshot().reseeds, 1);
}

#[test]
fn limits_span_is_max_minus_min() {
    use handgate_adapters::mapping::Limits;
    assert_eq!(Limits::new(-1.0, 2.5).span(), 3.5);
    assert_eq!(Limits::new(0.25, 0.25).span(), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Closures: hand-level targets and the closure estimate the state reports.

#[test]
fn closure_targets_interpolate_between_the_postures() {
    // A profile-overridden open posture that is not all zero (the defaults are, which hides
    // the interpolation's form).
    let params = TableOverrides {
        open_posture: Some(vec![0.1, 0.1, 0.2, 0.2, 0.2, 0.2, 0.2]),
        closed_posture: Some(vec![0.5, 0.5, 1.0, 1.0, 1.2, 1.0, 1.2]),
        ..Default::default()
    };
    let t = DeviceKind::Dex3.table(Side::Left, &params).unwrap();
    let half = t.closure_targets(0.5, None).unwrap();
    let expect = [0.3, 0.3, 0.6, 0.6, 0.7, 0.6, 0.7];
    for (i, (c, e)) in half.iter().zip(expect).enumerate() {
        assert!(
            (c.q - e).abs() < 1e-6,
            "joint {i}: {} for closure 0.5, expected {e}",
            c.q
        );
    }
    assert!((t.closure_of(&expect) - 0.5).abs() < 1e-6);
    // Out of range closures clamp to the postures.
    assert!((t.closure_targets(3.0, None).unwrap()[2].q - 1.0).abs() < 1e-6);
    assert!((t.closure_targets(-3.0, None).unwrap()[2].q - 0.2).abs() < 1e-6);
    // A posture of the wrong length is refused.
    let mut bad = t.clone();
    if let handgate_adapters::mapping::ClosureMap::Postures { closed, .. } = &mut bad.closure {
        closed.pop();
    }
    assert!(bad.closure_targets(0.5, None).is_err());
    let mut bad = t.clone();
    if let handgate_adapters::mapping::ClosureMap::Postures { open, .. } = &mut bad.closure {
        open.pop();
    }
    assert!(bad.closure_targets(0.5, None).is_err());
}

#[test]
fn hand_sdk_closure_torque_interpolates_from_open_to_closed() {
    // rt/hand_sdk: -0.3 N*m opens, +0.3 closes (the unitree_sdk2 example, docs/sources.md §6).
    let t = DeviceKind::HandSdk
        .table(Side::Left, &TableOverrides::default())
        .unwrap();
    for (c, tau) in [(0.0, -0.3), (0.25, -0.15), (0.5, 0.0), (1.0, 0.3)] {
        let out = t.closure_targets(c, None).unwrap();
        assert!(
            out.iter().all(|j| (j.tau - tau).abs() < 1e-6 && j.kp == 0.0),
            "closure {c}: {out:?}"
        );
    }
    assert_eq!(
        t.closure_of(&[1.0, 1.0, 1.0, 1.0]),
        0.0,
        "torque-mapped: no closure from q"
    );
}

#[test]
fn closure_of_estimates_the_mean_closure_of_the_moving_joints() {
    let t = dex3(Side::Left);
    // Default postures: open all 0, closed [0, 0.6, 1.0, 1.2, 1.3, 1.2, 1.3] (thumb_0 does not
    // move, so it does not count).
    assert_eq!(t.closure_of(&[0.0; 7]), 0.0);
    assert!((t.closure_of(&[0.0, 0.6, 1.0, 1.2, 1.3, 1.2, 1.3]) - 1.0).abs() < 1e-6);
    assert!((t.closure_of(&[5.0, 0.3, 0.5, 0.6, 0.65, 0.6, 0.65]) - 0.5).abs() < 1e-6);
    // Half the joints closed, half open: 3 of 6.
    assert!((t.closure_of(&[0.0, 0.6, 1.0, 1.2, 0.0, 0.0, 0.0]) - 0.5).abs() < 1e-6);
    // Past the postures clamps per joint; a NaN joint is left out of the mean.
    assert!((t.closure_of(&[0.0, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0]) - 1.0).abs() < 1e-6);
    assert!((t.closure_of(&[0.0, -9.0, 1.0, 1.2, 1.3, 1.2, 1.3]) - 5.0 / 6.0).abs() < 1e-6);
    assert!((t.closure_of(&[0.0, f32::NAN, 1.0, 1.2, 1.3, 1.2, 1.3]) - 1.0).abs() < 1e-6);
    // Dex1: jaw measured from open, closed at 5.4 rad.
    let g = DeviceKind::Dex1.table(Side::Left, &TableOverrides::default()).unwrap();
    assert!((g.closure_of(&[2.7]) - 0.5).abs() < 1e-6);
    assert_eq!(g.closure_of(&[]), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Partial commands, state conversion, profile postures.

#[test]
fn a_partial_command_keeps_the_other_joints_previous_targets() {
    let t = dex3(Side::Left);
    let ix = t.joint_by_name("index_0").unwrap();
    let prev: Vec<JointCommand> = (0..7).map(|i| JointCommand::hold(0.1 * i as f32, 1.0, 0.1)).collect();
    let meas = vec![
        JointState {
            q: 0.05,
            ..Default::default()
        };
        7
    ];
    let body = CommandBody::Joints(vec![(ix, JointCommand::hold(0.9, 1.0, 0.1))]);
    let out = t.resolve(&body, Some(&prev), &meas).unwrap();
    for (i, c) in out.iter().enumerate() {
        let want = if i == ix.index() {
            0.9
        } else {
            t.joints[i].limits.clamp(prev[i].q)
        };
        assert!((c.q - want).abs() < 1e-6, "joint {i}: {} (previous {})", c.q, prev[i].q);
    }
    // No (or a wrong-length) previous: the others hold where measured.
    for p in [None, Some(&prev[..3])] {
        let out = t.resolve(&body, p, &meas).unwrap();
        for (i, c) in out.iter().enumerate() {
            let want = if i == ix.index() {
                0.9
            } else {
                t.joints[i].limits.clamp(0.05)
            };
            assert!((c.q - want).abs() < 1e-6, "joint {i}: {}", c.q);
            if i != ix.index() {
                assert_eq!((c.kp, c.kd), (t.hold_kp, t.hold_kd));
            }
        }
    }
}

#[test]
fn wire_state_and_commands_convert_per_joint_with_the_sources_sign() {
    for side in [Side::Left, Side::Right] {
        let t = dex3(side);
        // Wire q = closing direction * 0.4 on every joint (the sources' direction, above).
        let wire_q: Vec<f32> = DEX3
            .iter()
            .map(|j| {
                0.4 * if side == Side::Left {
                    j.left_closing
                } else {
                    j.right_closing
                }
            })
            .collect();
        let wire_dq: Vec<f32> = wire_q.iter().map(|q| 2.0 * q).collect();
        let wire_tau: Vec<f32> = wire_q.iter().map(|q| -q).collect();
        let st = t.state_from_wire(&wire_q, &wire_dq, &wire_tau);
        assert_eq!(st.len(), 7);
        for (i, s) in st.iter().enumerate() {
            assert!((s.q - 0.4).abs() < 1e-6, "{side:?} joint {i}: canonical {}", s.q);
            assert!((s.dq - 0.8).abs() < 1e-6 && (s.tau + 0.4).abs() < 1e-6, "{s:?}");
        }
        let back = t.state_to_wire(&st);
        assert_eq!(back.len(), 7);
        for (i, (q, dq, tau)) in back.iter().enumerate() {
            assert!((q - wire_q[i]).abs() < 1e-6 && (dq - wire_dq[i]).abs() < 1e-6 && (tau - wire_tau[i]).abs() < 1e-6);
        }
        // Missing wire entries: NaN position (unknown), never a made-up 0.
        let short = t.state_from_wire(&wire_q[..2], &[], &[]);
        assert!(short[2].q.is_nan() && short[0].q.is_finite());
        let wire: Vec<_> = wire_q
            .iter()
            .map(|q| handgate_adapters::mapping::WireTarget {
                q: *q,
                kp: 1.0,
                ..Default::default()
            })
            .collect();
        let cmds = t.from_wire(&wire);
        assert_eq!(cmds.len(), 7);
        for c in &cmds {
            assert!((c.unwrap().q - 0.4).abs() < 1e-6);
        }
        assert!(t.from_wire(&wire[..3])[5].is_none());
    }
}

#[test]
fn a_profile_posture_of_the_wrong_length_is_refused() {
    for (open, closed) in [(Some(vec![0.0; 6]), None), (None, Some(vec![0.5; 8]))] {
        let p = TableOverrides {
            open_posture: open,
            closed_posture: closed,
            ..Default::default()
        };
        assert!(DeviceKind::Dex3.table(Side::Left, &p).is_err(), "{p:?}");
    }
}

/// `dex3::table::wire_limits` / `wire_sign` (what the emulated hand and `Joint::closing_dir`
/// use) agree with the sources: the soft limits (URDF; thumb_1 the manual) and the closing
/// direction per side.
#[test]
fn dex3_table_wire_limits_and_signs_match_the_sources() {
    use handgate_adapters::dex3::table::{wire_limits, wire_sign};
    for side in [Side::Left, Side::Right] {
        for j in &DEX3 {
            let (lo, hi) = if side == Side::Left { j.left } else { j.right };
            let closing = if side == Side::Left {
                j.left_closing
            } else {
                j.right_closing
            };
            let (a, b) = wire_limits(side, j.idl);
            assert!(
                (a - lo).abs() < 1e-4 && (b - hi).abs() < 1e-4,
                "{side:?} {}: [{a}, {b}]",
                j.name
            );
            assert_eq!(wire_sign(side, j.idl), closing, "{side:?} {}", j.name);
        }
    }
}
