//! The Inspire DFX kind (docs/sources.md §7 "Inspire DFX"): (a) its table against an
//! independent oracle written out from the source, (b) the DDS-client codec (layout, the other
//! hand held where it was measured when the hold began, silent until measured, lost/stale
//! rules), (c) the emulated DFX_inspire_service over real CycloneDDS (domain 230: the three
//! DDS tests use different topics, so they never see each other; the range's 233 and 234 are
//! unusable,
//! since RTPS's default port mapping 7400 + 250·domain leaves 0..65535 above domain 232).

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::control::Active;
use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_device::{DdsCodec, DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::inspire_dfx::adapter::DfxCodec;
use handgate_adapters::inspire_dfx::emulator::{DfxConfig, DfxEmulator, DFX_REST_Q};
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{faults, DeviceKind, Freshness, HandCommand, JointCommand, SafeAction, Side};
use handgate_adapters::sim::Noise;
use handgate_idl::unitree_go::{MotorCmd_, MotorCmds_, MotorStates_};

const DEADLINE: Duration = Duration::from_secs(20);

fn table(side: Side) -> DeviceTable {
    DeviceKind::InspireDfx.table(side, &TableOverrides::default()).unwrap()
}

fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + DEADLINE;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Makes DDS domain `id` private to this process (a Discovery/Tag unique to it), so two runs
/// of these tests at once (two worktrees) never see each other's services.
fn isolated_domain(id: u32) {
    static CREATED: std::sync::Mutex<Vec<u32>> = std::sync::Mutex::new(Vec::new());
    let mut created = CREATED.lock().unwrap_or_else(|e| e.into_inner());
    if created.contains(&id) {
        return;
    }
    created.push(id);
    let cfg = format!(
        "<CycloneDDS><Domain Id=\"any\"><Discovery><Tag>handgate-dfx-test-{}-{id}</Tag></Discovery></Domain></CycloneDDS>",
        std::process::id()
    );
    let domain = cyclonedds_rs::dds_domain::DdsDomain::create(id, Some(&cfg)).expect("create an isolated domain");
    std::mem::forget(domain);
}

// ---- (a) the table against docs/sources.md §7, literal numbers ----

/// (canonical joint, URDF suffix, URDF min, URDF max), in the service's order within a hand:
/// 0 pinky, 1 ring, 2 middle, 3 index, 4 thumb bend, 5 thumb rotation (docs/sources.md §7).
const ORACLE: [(&str, &str, f32, f32); 6] = [
    ("pinky", "pinky_proximal_joint", 0.0, 1.7),
    ("ring", "ring_proximal_joint", 0.0, 1.7),
    ("middle", "middle_proximal_joint", 0.0, 1.7),
    ("index", "index_proximal_joint", 0.0, 1.7),
    ("thumb_bend", "thumb_proximal_pitch_joint", 0.0, 0.5),
    ("thumb_rotate", "thumb_proximal_yaw_joint", -0.1, 1.3),
];

#[test]
fn a_table_names_order_limits_and_urdf_joints_per_side() {
    for (side, prefix) in [(Side::Right, "R_"), (Side::Left, "L_")] {
        let t = table(side);
        assert_eq!(t.joints.len(), 6);
        for (i, (name, urdf, min, max)) in ORACLE.iter().enumerate() {
            let j = &t.joints[i];
            assert_eq!(j.name, *name);
            assert_eq!(j.wire_index, i, "{side} {name}: the service's order within a hand");
            assert_eq!(j.urdf, format!("{prefix}{urdf}"));
            assert_eq!((j.limits.min, j.limits.max), (*min, *max), "{side} {name}");
        }
    }
}

#[test]
fn a_xr_teleoperate_sends_1_for_open_and_0_for_closed_on_every_finger_of_both_hands() {
    // xr_teleoperate starts from all q = 1.0 (open); q = clip((max − rad) / (max − min), 0, 1)
    // (docs/sources.md §7). Canonical closure 0 → wire 1.0, closure 1 → wire 0.0.
    for side in [Side::Right, Side::Left] {
        let t = table(side);
        let open = t.to_wire(&t.closure_targets(0.0, None).unwrap());
        let closed = t.to_wire(&t.closure_targets(1.0, None).unwrap());
        for i in 0..6 {
            assert!((open[i].q - 1.0).abs() < 1e-6, "{side} entry {i} open: {}", open[i].q);
            assert!(closed[i].q.abs() < 1e-6, "{side} entry {i} closed: {}", closed[i].q);
        }
    }
}

#[test]
fn a_positive_canonical_closes_every_joint_to_the_documented_wire_values() {
    // (joint index, canonical rad, wire q): rad = max − q·(max − min), worked by hand.
    let cases: [(usize, f32, f32); 9] = [
        (0, 0.85, 0.5), // pinky half way
        (1, 1.7, 0.0),  // ring fully bent
        (2, 0.0, 1.0),  // middle straight
        (3, 0.425, 0.75),
        (4, 0.25, 0.5), // thumb bend half way of [0, 0.5]
        (4, 0.5, 0.0),
        (5, -0.1, 1.0), // thumb rotation at q = 1 sits at −0.1 rad
        (5, 0.6, 0.5),
        (5, 1.3, 0.0),
    ];
    for side in [Side::Right, Side::Left] {
        let t = table(side);
        for (i, rad, wire) in cases {
            let j = &t.joints[i];
            assert!((j.q_to_wire(rad) - wire).abs() < 1e-5, "{side} {} {rad} rad", j.name);
            assert!(
                (j.q_from_wire(wire) - rad).abs() < 1e-5,
                "{side} {} wire {wire}",
                j.name
            );
            // Closing (more canonical) is a smaller wire q, on both hands: no mirror image.
            assert!(j.q_to_wire(rad + 0.01) < j.q_to_wire(rad), "{side} {}", j.name);
        }
    }
}

// ---- (b) the DDS-client codec ----

fn targets(t: &DeviceTable, closure: f32) -> Active {
    Active::Command(t.closure_targets(closure, None).unwrap())
}

fn state12(q: [f32; 12]) -> MotorStates_ {
    let mut s = MotorStates_::with_len(12);
    for (m, q) in s.states.iter_mut().zip(q) {
        m.q = q;
    }
    s
}

#[test]
fn b_silent_until_the_other_hand_is_measured_then_holds_it_at_its_measurement() {
    let r = table(Side::Right);
    let mut c = DfxCodec::new(Side::Right).unwrap();
    assert!(c.encode(&Active::Idle, &r, 0.01).is_none());
    assert!(
        c.encode(&targets(&r, 1.0), &r, 0.01).is_none(),
        "other hand never measured"
    );
    // Right entries 0-5 at 0.9, left 6-11 at 0.1 .. 0.6.
    let s = c
        .decode(
            &state12([0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]),
            &r,
        )
        .unwrap();
    // The right hand's own entries: wire 0.9 → pinky 1.7 − 0.9·1.7 = 0.17 rad.
    assert!((s.joints[0].q - 0.17).abs() < 1e-5, "{}", s.joints[0].q);
    assert!((s.joints[5].q - 0.04).abs() < 1e-5, "thumb rotate 1.3 − 0.9·1.4");
    assert_eq!(s.faults, 0);
    let msg = c.encode(&targets(&r, 1.0), &r, 0.01).unwrap();
    assert_eq!(msg.cmds.len(), 12);
    for i in 0..6 {
        assert!(msg.cmds[i].q.abs() < 1e-6, "right entry {i} closed: {}", msg.cmds[i].q);
        let m = &msg.cmds[i];
        assert_eq!(
            (m.dq, m.tau, m.kp, m.kd, m.mode),
            (0.0, 0.0, 0.0, 0.0, 0),
            "only q is set"
        );
    }
    let left: Vec<f32> = msg.cmds[6..].iter().map(|m| m.q).collect();
    assert_eq!(left, vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6], "left held where measured");
    // A limp safe state cannot be expressed to the service: it stays silent.
    let limp = Active::Safe(SafeAction::Limp, vec![JointCommand::default(); 6]);
    assert!(c.encode(&limp, &r, 0.01).is_none());
    let open = Active::Safe(SafeAction::Open, r.closure_targets(0.0, None).unwrap());
    assert!((c.encode(&open, &r, 0.01).unwrap().cmds[0].q - 1.0).abs() < 1e-6);
}

/// The other hand (no device of ours drives it) is held where it was measured when the hold
/// began, whatever it measures afterwards: re-taken every cycle, a measurement that sags
/// under a load would walk it away (docs/adapters.md, "Holds"). A new hold begins after our
/// messages stopped (idle, limp) and after a reconnect; the other device's own targets end it.
#[test]
fn b_the_other_hand_is_held_where_it_was_measured_when_the_hold_began() {
    let r = table(Side::Right);
    let shared = handgate_adapters::inspire_dfx::adapter::SharedTargets::default();
    let mut c = DfxCodec::with_shared(Side::Right, shared.clone()).unwrap();
    let left = |c: &mut DfxCodec| -> Vec<f32> {
        let msg = c.encode(&targets(&r, 0.5), &r, 0.01).unwrap();
        msg.cmds[6..].iter().map(|m| m.q).collect()
    };
    c.decode(&state12([0.5; 12]), &r).unwrap();
    assert_eq!(left(&mut c), vec![0.5; 6], "the hold begins");
    c.decode(&state12([0.499; 12]), &r).unwrap();
    c.decode(&state12([0.498; 12]), &r).unwrap();
    assert_eq!(left(&mut c), vec![0.5; 6], "kept while the measurement sags");
    assert_eq!(c.other_q(), Some([0.498; 6]));
    // Silent (limp: the service cannot express it), then sending again: a new hold.
    let limp = Active::Safe(SafeAction::Limp, vec![JointCommand::default(); 6]);
    assert!(c.encode(&limp, &r, 0.01).is_none());
    assert_eq!(left(&mut c), vec![0.498; 6], "a new hold after a silence");
    c.decode(&state12([0.45; 12]), &r).unwrap();
    assert_eq!(left(&mut c), vec![0.498; 6]);
    c.reconnected();
    assert_eq!(left(&mut c), vec![0.45; 6], "a new hold after a reconnect");
    // The left hand's own device sends targets: they replace the hold.
    let l = table(Side::Left);
    let mut cl = DfxCodec::with_shared(Side::Left, shared).unwrap();
    cl.decode(&state12([0.45; 12]), &l).unwrap();
    cl.encode(&targets(&l, 0.0), &l, 0.01).unwrap();
    assert!(
        left(&mut c).iter().all(|q| (q - 1.0).abs() < 1e-6),
        "the left's own targets"
    );
}

#[test]
fn b_the_left_hand_writes_entries_6_to_11() {
    let l = table(Side::Left);
    let mut c = DfxCodec::new(Side::Left).unwrap();
    assert!(DfxCodec::new(Side::Center).is_none());
    c.decode(&state12([0.25; 12]), &l).unwrap();
    let msg = c.encode(&targets(&l, 0.0), &l, 0.01).unwrap();
    assert!(msg.cmds[..6].iter().all(|m| m.q == 0.25), "right held");
    assert!(msg.cmds[6..].iter().all(|m| (m.q - 1.0).abs() < 1e-6), "left open");
}

/// A left and a right device on one service: every message either sends carries both
/// hands' own latest targets, so the service (latest message wins per loop) never applies
/// one hand's stale measurement over the other device's target, whichever writes last.
#[test]
fn b_two_devices_on_one_service_each_send_both_hands_targets() {
    let (r, l) = (table(Side::Right), table(Side::Left));
    let shared = handgate_adapters::inspire_dfx::adapter::SharedTargets::default();
    let mut cr = DfxCodec::with_shared(Side::Right, shared.clone()).unwrap();
    let mut cl = DfxCodec::with_shared(Side::Left, shared).unwrap();
    let rest = state12([0.9; 12]);
    cr.decode(&rest, &r).unwrap();
    cl.decode(&rest, &l).unwrap();
    // Right closes (wire 0), left opens (wire 1); the left device writes last.
    cr.encode(&targets(&r, 1.0), &r, 0.01).unwrap();
    let msg = cl.encode(&targets(&l, 0.0), &l, 0.01).unwrap();
    assert!(
        msg.cmds[..6].iter().all(|m| m.q.abs() < 1e-6),
        "right's target, not its 0.9: {msg:?}"
    );
    assert!(
        msg.cmds[6..].iter().all(|m| (m.q - 1.0).abs() < 1e-6),
        "left's target: {msg:?}"
    );
    // And the right device's next message carries the left's target.
    let msg = cr.encode(&targets(&r, 1.0), &r, 0.01).unwrap();
    assert!(msg.cmds[6..].iter().all(|m| (m.q - 1.0).abs() < 1e-6), "{msg:?}");
}

#[test]
fn b_wrong_sizes_are_not_this_hand_and_a_growing_lost_count_is_a_fault() {
    let r = table(Side::Right);
    let mut c = DfxCodec::new(Side::Right).unwrap();
    assert!(c.decode(&MotorStates_::with_len(6), &r).is_none());
    assert!(c.decode(&MotorStates_::with_len(13), &r).is_none());
    assert!(c.other_q().is_none());
    let mut s = state12([0.5; 12]);
    s.states[2].lost = 4;
    assert_eq!(c.decode(&s, &r).unwrap().faults, 0, "first sample: nothing to compare");
    assert_eq!(c.decode(&s, &r).unwrap().faults, 0, "count unchanged");
    s.states[2].lost = 5;
    assert_ne!(c.decode(&s, &r).unwrap().faults & faults::HARDWARE, 0, "a read failed");
    // The other hand's failed reads are not this hand's fault.
    s.states[8].lost = 9;
    assert_eq!(c.decode(&s, &r).unwrap().faults, 0);
}

// ---- (c) over DDS: the emulated service, and devices driving it ----

fn cmd12(q: [f32; 12]) -> MotorCmds_ {
    MotorCmds_ {
        cmds: q
            .iter()
            .map(|&q| MotorCmd_ {
                q,
                ..MotorCmd_::default()
            })
            .collect(),
    }
}

#[test]
fn c_service_starts_at_rest_follows_a_client_stops_at_hard_stops_and_goes_quiet_after_1_s() {
    isolated_domain(230);
    let emu_node = Node::new(230, None).unwrap();
    let emu = DfxEmulator::start(
        &emu_node,
        DfxConfig {
            noise: Noise::OFF,
            ..DfxConfig::default()
        },
    )
    .unwrap();
    let node = Node::new(230, None).unwrap();
    let mut w = node
        .writer::<MotorCmds_>("rt/inspire/cmd", Qos::Reliable { depth: 4 })
        .unwrap();
    let r = node
        .reader::<MotorStates_>("rt/inspire/state", Qos::BestEffort)
        .unwrap();
    w.wait_matched(1, DEADLINE).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    // Start-up: 12 entries at the rest posture, nothing commanded.
    let s = r.wait_take(DEADLINE).unwrap().pop().unwrap();
    assert_eq!(s.states.len(), 12);
    assert!(s.states.iter().all(|m| m.q == DFX_REST_Q), "{s:?}");
    let snap = emu.snapshot();
    assert!(snap.timed_out && snap.angle_set_writes == 0);
    // Right hand toward 0.3 (closing), left past both stops: -1 closes fully, 2 opens fully.
    let q = [0.3, 0.3, 0.3, 0.3, 0.3, 0.3, -1.0, -1.0, -1.0, 2.0, 2.0, 2.0];
    let mut seen_between = false;
    let end = Instant::now() + DEADLINE;
    let last_write = loop {
        let written = Instant::now();
        w.write(cmd12(q)).unwrap();
        let s = r.wait_take(DEADLINE).unwrap().pop().unwrap();
        let right = s.states[0].q;
        seen_between |= right < DFX_REST_Q && right > 0.3 + 1e-3;
        if (right - 0.3).abs() < 1e-6 && s.states[6].q == 0.0 && s.states[9].q == 1.0 {
            break written;
        }
        assert!(Instant::now() < end, "never reached the targets: {s:?}");
    };
    assert!(seen_between, "the fingers move through intermediate positions");
    let snap = emu.snapshot();
    assert!(!snap.timed_out && snap.angle_set_writes > 0);
    assert_eq!(snap.fingers[6].target, Some(0.0), "a negative q is the closed end");
    // Silence: the service stops writing after 1 s and keeps publishing; the hand holds.
    let writes = wait_for("the service's timeout", || {
        let s = emu.snapshot();
        s.timed_out.then_some(s.angle_set_writes)
    });
    assert!(last_write.elapsed() >= Duration::from_secs(1));
    let published = emu.snapshot().states_published;
    let s = wait_for("more state after the timeout", || {
        let s = r.take().pop()?;
        (emu.snapshot().states_published > published + 5).then_some(s)
    });
    assert_eq!(emu.snapshot().angle_set_writes, writes, "no writes while timed out");
    assert_eq!(s.states[0].q, 0.3);
    assert_eq!((s.states[6].q, s.states[9].q), (0.0, 1.0), "hard stops hold");
    // A malformed command is ignored and counted; it does not end the silence.
    w.write(MotorCmds_::with_len(6)).unwrap();
    wait_for("the rejection", || (emu.snapshot().rejected >= 1).then_some(()));
    assert!(emu.snapshot().timed_out);
}

/// The second DDS test's private topics (it shares domain 230 with the first).
const PAIR_TOPICS: (&str, &str) = ("rt/test_dfx_pair/cmd", "rt/test_dfx_pair/state");

fn device(node: &Node, side: Side, name: &str) -> DdsDevice {
    device_on(node, side, name, PAIR_TOPICS)
}

fn device_on(node: &Node, side: Side, name: &str, topics: (&str, &str)) -> DdsDevice {
    let info = DeviceInfo {
        name: name.into(),
        kind: DeviceKind::InspireDfx,
        side,
        backend: Backend::Dds,
        table: Arc::new(table(side)),
    };
    let cfg = DdsDeviceConfig {
        cmd_topic: topics.0.into(),
        state_topic: Some(topics.1.into()),
        rate_hz: 100.0,
        stale_after: Duration::from_millis(200),
        forward: handgate_adapters::dds_device::Forwarding::default_for(100.0),
    };
    DdsDevice::start(node, info, cfg, DfxCodec::new(side).unwrap()).unwrap()
}

#[test]
fn c_a_left_and_a_right_device_share_the_service_without_disturbing_each_other() {
    isolated_domain(230);
    let emu_node = Node::new(230, None).unwrap();
    let emu = DfxEmulator::start(
        &emu_node,
        DfxConfig {
            topics: Some((PAIR_TOPICS.0.into(), PAIR_TOPICS.1.into())),
            ..DfxConfig::default()
        },
    )
    .unwrap();
    let node = Node::new(230, None).unwrap();
    let right = device(&node, Side::Right, "right");
    let left = device(&node, Side::Left, "left");
    let rs = right.state();
    wait_for("a fresh right state", || {
        (rs.borrow().freshness == Freshness::Fresh).then_some(())
    });
    // Left closes half way; the right device has no command and sends nothing.
    left.command(HandCommand::closure(1, 0.5)).unwrap();
    wait_for("left at half closure", || {
        let f = emu.snapshot().fingers;
        f[6..].iter().all(|f| (f.q - 0.5).abs() < 2e-3).then_some(())
    });
    // The left device holds the right hand at its last measurement: within the measurement
    // noise (a few register counts) of where it rests.
    for f in &emu.snapshot().fingers[..6] {
        assert!((f.q - DFX_REST_Q).abs() < 6e-3, "the right hand moved: {f:?}");
    }
    // Now the right hand closes; the left device goes away (no more left commands).
    drop(left);
    right.command(HandCommand::closure(2, 1.0)).unwrap();
    wait_for("right closed", || {
        let f = emu.snapshot().fingers;
        f[..6].iter().all(|f| f.q < 2e-3).then_some(())
    });
    // The right device held the left hand at its last measurement (noise: a few counts).
    let snap = emu.snapshot();
    for f in &snap.fingers[6..] {
        assert!((f.q - 0.5).abs() < 6e-3, "left hand disturbed: {f:?}");
        assert!((f.target.unwrap() - 0.5).abs() < 6e-3, "left target {f:?}");
    }
    let st = rs.borrow().clone();
    assert!(st.joints[0].q > 1.69, "canonical pinky closed: {}", st.joints[0].q);
    assert!(st.closure > 0.99);
    // The service goes away: the device's state turns stale with the link-down fault.
    drop(emu);
    wait_for("stale state", || {
        let s = rs.borrow().clone();
        (s.freshness == Freshness::Stale && s.faults & faults::LINK_DOWN != 0).then_some(())
    });
}

/// The third DDS test's private topics (domain 230 too).
const HOLD_TOPICS: (&str, &str) = ("rt/test_dfx_hold/cmd", "rt/test_dfx_hold/state");

/// The right hand's six targets as the emulated service last wrote them (all or none).
fn right_targets(emu: &DfxEmulator) -> Option<Vec<f32>> {
    emu.snapshot().fingers[..6].iter().map(|f| f.target).collect()
}

/// Through `DdsDevice`'s loop: the hand no device drives is held at ONE target while the other
/// hand moves (a measurement flickering by a register count never moves it), and after the
/// service came back it is held where it is measured then (a new hold: never the old target
/// replayed onto a hand that may have moved meanwhile).
#[test]
fn c_the_untouched_hand_is_held_at_one_target_and_taken_again_after_a_reconnect() {
    isolated_domain(230);
    let emu_node = Node::new(230, None).unwrap();
    let service = |right_at: f32, max_speed: f32| {
        let mut cfg = DfxConfig {
            topics: Some((HOLD_TOPICS.0.into(), HOLD_TOPICS.1.into())),
            ..DfxConfig::default()
        };
        cfg.initial[..6].copy_from_slice(&[right_at; 6]);
        cfg.tuning.max_speed = max_speed;
        DfxEmulator::start(&emu_node, cfg).unwrap()
    };
    let emu = service(DFX_REST_Q, DfxConfig::default().tuning.max_speed);
    let node = Node::new(230, None).unwrap();
    let left = device_on(&node, Side::Left, "left", HOLD_TOPICS);
    let ls = left.state();
    let fresh = || (ls.borrow().freshness == Freshness::Fresh).then_some(());
    wait_for("a fresh left state", fresh);
    let held = (1..=4u64)
        .map(|seq| {
            // The left hand moves; the right hand's target never changes.
            let c = [0.5, 0.2, 0.7, 0.4][seq as usize - 1];
            left.command(HandCommand::closure(seq, c)).unwrap();
            let wire = 1.0 - c;
            wait_for("the left hand at its closure", || {
                let f = emu.snapshot().fingers;
                f[6..10].iter().all(|f| (f.q - wire).abs() < 3e-3).then_some(())
            });
            right_targets(&emu).expect("the right hand is held")
        })
        .collect::<Vec<_>>();
    assert!(held.iter().all(|t| *t == held[0]), "one hold: {held:?}");
    assert!(
        held[0].iter().all(|q| (q - DFX_REST_Q).abs() < 4e-3),
        "held where it rested: {:?}",
        held[0]
    );
    // The service goes away, then comes back with the right hand moved meanwhile.
    drop(emu);
    wait_for("the left device's link down", || {
        (ls.borrow().freshness == Freshness::Stale).then_some(())
    });
    // Messages sent while the link was down (the old hold) may reach the new service before
    // the device reads its first state: its fingers are slow (at most 1e-4 of the range per
    // second), so the hand is still where it came back when the device measures it. From the
    // reseed on, every message holds the right hand there.
    let emu = service(0.6, 1e-4);
    wait_for("the left device's reseed", || (left.stats().reseeds == 1).then_some(()));
    let right_sent = |emu: &DfxEmulator| -> Option<Vec<f32>> {
        let c = emu.snapshot().last_command?;
        Some(c.cmds[..6].iter().map(|m| m.q).collect())
    };
    let again = wait_for("the right hand held where it is now", || {
        right_sent(&emu).filter(|q| q.iter().all(|q| (q - 0.6).abs() < 4e-3))
    });
    let n = emu.snapshot().commands;
    wait_for("20 more commands", || (emu.snapshot().commands >= n + 20).then_some(()));
    assert_eq!(
        right_sent(&emu),
        Some(again.clone()),
        "one hold again, not {:?}",
        held[0]
    );
    assert_eq!(left.stats().reseeds, 1);
}
