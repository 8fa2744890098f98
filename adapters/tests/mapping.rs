//! Properties of the table-driven mapping for every device kind and side.

use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::mapping::{DeviceTable, Limits, WireTarget};
use handgate_adapters::model::{CommandBody, DeviceKind, JointCommand, JointId, JointState, SafeAction, Side};
use proptest::prelude::*;

fn all_tables() -> Vec<DeviceTable> {
    let mut v = Vec::new();
    for kind in DeviceKind::ALL {
        for side in [Side::Left, Side::Right] {
            v.push(kind.table(side, &TableOverrides::default()).unwrap());
        }
    }
    v
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -10.0f32..10.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => any::<f32>(),
    ]
}

#[test]
fn dex3_joint_order_urdf_and_mirror_signs() {
    let l = DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap();
    let r = DeviceKind::Dex3.table(Side::Right, &TableOverrides::default()).unwrap();
    let names: Vec<_> = l.joints.iter().map(|j| j.name).collect();
    assert_eq!(
        names,
        ["thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1"]
    );
    // The left URDF's three/four are the index finger, five/six the middle (docs/sources.md §2).
    let idx0 = l.joint_by_name("index_0").unwrap();
    assert_eq!(l.joint(idx0).unwrap().wire_index, 5);
    assert_eq!(l.joint(idx0).unwrap().urdf, "left_hand_three_joint");
    assert_eq!(
        l.joint(l.joint_by_name("middle_1").unwrap()).unwrap().urdf,
        "left_hand_six_joint"
    );
    assert_eq!(
        r.joint(r.joint_by_name("index_0").unwrap()).unwrap().urdf,
        "right_hand_five_joint"
    );
    assert_eq!(
        r.joint(r.joint_by_name("middle_0").unwrap()).unwrap().urdf,
        "right_hand_three_joint"
    );
    // Closing a finger is negative on the left, positive on the right.
    let close = JointCommand::hold(1.0, 1.5, 0.1);
    assert!(l.joint(idx0).unwrap().to_wire(&close).q < 0.0);
    assert!(r.joint(idx0).unwrap().to_wire(&close).q > 0.0);
    // Wire limits of each hand are the other's mirrored: the URDFs' except thumb_1, which is
    // the manual's −60°..35° on the right (docs/model.md).
    #[allow(clippy::approx_constant)]
    let right_urdf: [(f32, f32); 7] = [
        (-1.0472, 1.0472),
        (-1.0472, 0.6108),
        (-1.7453, 0.0),
        (0.0, 1.5708),
        (0.0, 1.7453),
        (0.0, 1.5708),
        (0.0, 1.7453),
    ];
    for (i, (lo, hi)) in right_urdf.iter().enumerate() {
        let (a, b) = r.wire_limits(JointId(i as u8)).unwrap();
        assert!(
            (a - lo).abs() < 1e-6 && (b - hi).abs() < 1e-6,
            "right joint {i}: {a},{b}"
        );
        let (a, b) = l.wire_limits(JointId(i as u8)).unwrap();
        assert!(
            (a + hi).abs() < 1e-6 && (b + lo).abs() < 1e-6,
            "left joint {i}: {a},{b}"
        );
    }
}

#[test]
fn gripper_ranges_match_the_field() {
    let dex1 = DeviceKind::Dex1.table(Side::Left, &TableOverrides::default()).unwrap();
    let jaw = &dex1.joints[0];
    assert_eq!(jaw.q_to_wire(0.0), 5.4, "canonical open = 5.4 rad on the wire");
    assert_eq!(jaw.q_to_wire(5.4), 0.0, "canonical closed = 0 rad on the wire");
    let closed = dex1.closure_targets(1.0, None).unwrap();
    assert_eq!(dex1.to_wire(&closed)[0].q, 0.0);
    let dex1_seed = handgate_adapters::dex1::table::table(Side::Left, std::f32::consts::TAU);
    assert!((dex1_seed.joints[0].q_to_wire(0.0) - std::f32::consts::TAU).abs() < 1e-6);
    let ez = DeviceKind::Ezgripper
        .table(Side::Right, &TableOverrides::default())
        .unwrap();
    assert!((ez.joints[0].q_to_wire(5.4) - 0.0).abs() < 1e-4, "5.4 rad closed = 0 %");
    assert!(
        (ez.joints[0].q_to_wire(0.0) - 100.0).abs() < 1e-4,
        "open = max_open_percent"
    );
    // A Dex1 wire q maps to the same EZGripper percent the SAKE driver would command.
    let q_wire = 2.7;
    let canon = jaw.q_from_wire(q_wire);
    assert!((ez.joints[0].q_to_wire(canon) - 50.0).abs() < 1e-3);
}

#[test]
fn hand_sdk_closure_is_torque_with_positive_closing() {
    let t = DeviceKind::HandSdk
        .table(Side::Left, &TableOverrides::default())
        .unwrap();
    let c = t.closure_targets(1.0, None).unwrap();
    assert!(c.iter().all(|j| j.tau > 0.0 && j.kp == 0.0));
    let w = t.to_wire(&c);
    assert_eq!(w.len(), 4);
    assert!(w.iter().all(|m| m.tau > 0.0));
}

#[test]
fn nan_and_inf_commands_are_rejected() {
    for t in all_tables() {
        let bad = JointCommand {
            q: f32::NAN,
            ..Default::default()
        };
        let body = CommandBody::Joints(vec![(JointId(0), bad)]);
        assert!(t.resolve(&body, None, &[]).is_err(), "{:?}", t.kind);
        assert!(t.closure_targets(f32::INFINITY, None).is_err());
    }
}

proptest! {
    #[test]
    fn canonical_to_wire_to_canonical_is_identity_inside_limits(
        sel in 0usize..8, frac in proptest::collection::vec(0.0f32..=1.0, 7),
        dq in -5.0f32..5.0, tau in -1.0f32..1.0, kp in 0.0f32..5.0, kd in 0.0f32..0.5,
    ) {
        let t = &all_tables()[sel];
        for (i, j) in t.joints.iter().enumerate() {
            let q = j.limits.min + frac[i] * j.limits.span();
            let c = JointCommand { q, dq, tau, kp, kd };
            let w = j.to_wire(&c);
            let back = j.from_wire(&w);
            let tol = 1e-4 * (1.0 + j.scale.abs());
            prop_assert!((back.q - c.q).abs() <= tol, "{:?} {} q {} -> {}", t.kind, j.name, c.q, back.q);
            prop_assert!((back.dq - c.dq).abs() <= tol);
            prop_assert!((back.tau - c.tau).abs() <= tol);
            prop_assert!((back.kp - c.kp).abs() <= tol);
            prop_assert!((back.kd - c.kd).abs() <= tol);
        }
        let targets: Vec<_> = t.joints.iter().enumerate()
            .map(|(i, j)| JointCommand::hold(j.limits.min + frac[i] * j.limits.span(), kp, kd)).collect();
        let wire: Vec<WireTarget> = t.to_wire(&targets);
        let back = t.from_wire(&wire);
        for (a, b) in targets.iter().zip(back) {
            let b = b.unwrap();
            prop_assert!((a.q - b.q).abs() < 1e-3);
        }
    }

    #[test]
    fn dex3_is_mirror_symmetric(q in proptest::collection::vec(-2.0f32..2.0, 7)) {
        let l = DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap();
        let r = DeviceKind::Dex3.table(Side::Right, &TableOverrides::default()).unwrap();
        for (i, qi) in q.iter().enumerate() {
            let c = JointCommand::hold(*qi, 1.0, 0.1);
            let wl = l.joints[i].to_wire(&c);
            let wr = r.joints[i].to_wire(&c);
            prop_assert_eq!(wl.q, -wr.q);
            prop_assert_eq!(l.joints[i].limits, r.joints[i].limits);
        }
    }

    #[test]
    fn resolve_never_exceeds_limits_or_emits_non_finite(
        sel in 0usize..8,
        vals in proptest::collection::vec((any_f32(), any_f32(), any_f32(), any_f32(), any_f32()), 7),
        measured in proptest::collection::vec(-3.0f32..3.0, 7),
        step in proptest::option::of(0.01f32..0.5),
        closure in any_f32(),
    ) {
        let mut t = all_tables()[sel].clone();
        t.max_step = step;
        let n = t.joint_count();
        let meas: Vec<JointState> = measured.iter().take(n).map(|q| JointState { q: *q, ..Default::default() }).collect();
        let joints: Vec<(JointId, JointCommand)> = vals.iter().take(n).enumerate()
            .map(|(i, v)| (JointId(i as u8), JointCommand { q: v.0, dq: v.1, tau: v.2, kp: v.3, kd: v.4 })).collect();
        for body in [
            CommandBody::Joints(joints),
            CommandBody::Closure { closure, stiffness: None },
            CommandBody::Safe(SafeAction::Hold),
            CommandBody::Safe(SafeAction::Open),
            CommandBody::Safe(SafeAction::Limp),
        ] {
            if let Ok(out) = t.resolve(&body, None, &meas) {
                prop_assert_eq!(out.len(), n);
                for (i, c) in out.iter().enumerate() {
                    prop_assert!(c.is_finite(), "{:?} {:?}", body, c);
                    let l = t.joints[i].limits;
                    prop_assert!(l.contains(c.q) || (matches!(body, CommandBody::Safe(SafeAction::Limp)) && c.kp == 0.0),
                        "{:?} joint {} q {} outside {:?}", t.kind, i, c.q, l);
                    prop_assert!(c.kp >= 0.0 && c.kp <= t.max_kp && c.kd >= 0.0 && c.kd <= t.max_kd);
                    prop_assert!(c.tau.abs() <= t.max_tau);
                    if let (Some(s), CommandBody::Joints(_)) = (step, &body) {
                        let m = l.clamp(meas[i].q);
                        prop_assert!((c.q - meas[i].q).abs() <= s + 1e-5 || (c.q - m).abs() < 1e-5,
                            "step limit: q {} measured {} step {}", c.q, meas[i].q, s);
                    }
                }
                for w in t.to_wire(&out) {
                    prop_assert!(w.q.is_finite() && w.dq.is_finite() && w.tau.is_finite() && w.kp.is_finite() && w.kd.is_finite());
                }
            }
        }
    }
}

#[test]
fn profile_limit_override_applies_and_unknown_joint_errors() {
    let p = TableOverrides {
        limits: vec![("index_0".into(), Limits::new(0.0, 0.5))],
        ..Default::default()
    };
    let t = DeviceKind::Dex3.table(Side::Left, &p).unwrap();
    let id = t.joint_by_name("index_0").unwrap();
    let out = t
        .resolve(
            &CommandBody::Joints(vec![(id, JointCommand::hold(1.5, 1.0, 0.1))]),
            None,
            &[],
        )
        .unwrap();
    assert_eq!(out[id.index()].q, 0.5);
    let bad = TableOverrides {
        limits: vec![("pinky".into(), Limits::new(0.0, 0.5))],
        ..Default::default()
    };
    assert!(DeviceKind::Dex3.table(Side::Left, &bad).is_err());
}

proptest! {
    /// `DeviceTable::check` (what `CommandState::submit` asks, without building targets)
    /// refuses exactly what resolving the command would, with the same error.
    #[test]
    fn check_refuses_exactly_what_resolve_refuses(
        t in 0usize..8,
        entries in prop::collection::vec((0u8..9, any_f32(), any_f32(), any_f32(), any_f32(), any_f32()), 0..9),
        closure in any_f32(),
        as_closure in prop::bool::ANY,
    ) {
        let table = &all_tables()[t];
        let body = if as_closure {
            CommandBody::Closure { closure, stiffness: None }
        } else {
            CommandBody::Joints(
                entries
                    .iter()
                    .map(|&(id, q, dq, tau, kp, kd)| (JointId(id), JointCommand { q, dq, tau, kp, kd }))
                    .collect(),
            )
        };
        // Compared as text: a NaN closure is in the error, and NaN != NaN.
        prop_assert_eq!(
            format!("{:?}", table.check(&body)),
            format!("{:?}", table.resolve(&body, None, &[]).map(|_| ()))
        );
    }
}
