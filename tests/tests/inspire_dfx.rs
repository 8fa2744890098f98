//! The Inspire DFX kind end to end through the `handgate` binary (docs/adapters.md, "Inspire
//! DFX"; docs/sources.md §7): a profile with a left and a right hand on the emulator backend
//! (one emulated DFX_inspire_service for both) driven through the canonical fronts; and
//! `handgate emulate inspire_dfx` as a process of its own, driven by the shipped
//! `g1-inspire-dfx` profile (backend dds) on the same domain. Domains 231 and 232 (233 and
//! 234 of the range are unusable: RTPS's default port mapping 7400 + 250·domain passes 65535
//! above domain 232, and the participant fails to start).

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use handgate_adapters::dds::{Qos, Writer};
use handgate_idl::handgate as hg;
use handgate_idl::{ros2, unitree_go};
use handgate_tests::{
    canonical_q, closure_cmd, handgate_bin, node, poll, repo_root, serial, status_device, stream_until, temp_profile,
    Emulation as Emulator, Gateway, Latest,
};

/// Bound on a start, a first state, a match or reaching a target (never a fixed sleep).
const DEADLINE: Duration = Duration::from_secs(30);

/// URDF limits (rad) in the service's order: pinky, ring, middle, index, thumb bend, thumb
/// rotation (docs/sources.md §7 "URDF joint names"), written out here as the oracle.
const LOWER: [f32; 6] = [0.0, 0.0, 0.0, 0.0, 0.0, -0.1];
const UPPER: [f32; 6] = [1.7, 1.7, 1.7, 1.7, 0.5, 1.3];

fn write_profile(name: &str, text: &str) -> PathBuf {
    temp_profile("dfx", name, text)
}

fn joints_cmd(seq: u64, joints: &[(&str, f32)]) -> hg::HandCmd_ {
    hg::HandCmd_ {
        seq,
        mode: hg::MODE_JOINTS,
        joints: joints
            .iter()
            .map(|(name, q)| hg::JointCmd_ {
                name: (*name).into(),
                q: *q,
                kp: 1.0,
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    }
}

fn joint(s: &hg::HandState_, name: &str) -> f32 {
    canonical_q(s, name)
}

/// Streams `cmd` to `w` until the state on `state` satisfies `done`; returns that state.
fn drive(
    w: &mut Writer<hg::HandCmd_>,
    state: &mut Latest<hg::HandState_>,
    cmd: &hg::HandCmd_,
    gw: &Gateway,
    what: &str,
    done: impl Fn(&hg::HandState_) -> bool,
) -> hg::HandState_ {
    let ok = stream_until(w, cmd, DEADLINE, || state.update().is_some_and(&done));
    assert!(ok, "{what}: last state {:?}\n{}", state.last, gw.transcript());
    state.last.clone().unwrap()
}

#[test]
fn two_emulated_hands_share_one_service_and_close_in_the_right_direction() {
    let _g = serial();
    let p = write_profile(
        "dfx-emulated",
        r#"name = "dfx-emulated"
description = "two emulated Inspire DFX hands"
[[devices]]
name = "inspire_left"
kind = "inspire_dfx"
side = "left"
backend = "emulator"
[[devices]]
name = "inspire_right"
kind = "inspire_dfx"
side = "right"
backend = "emulator"
[[fronts]]
kind = "canonical"
device = "inspire_left"
[[fronts]]
kind = "canonical"
device = "inspire_right"
[[fronts]]
kind = "joint_state"
"#,
    );
    let gw = Gateway::start(232, &["--profile", p.to_str().unwrap()]);
    let n = node(232);
    let mut lw = n
        .writer::<hg::HandCmd_>("rt/handgate/inspire_left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut rw = n
        .writer::<hg::HandCmd_>("rt/handgate/inspire_right/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut left = Latest::<hg::HandState_>::new(&n, "rt/handgate/inspire_left/state", Qos::BestEffort);
    let mut right = Latest::<hg::HandState_>::new(&n, "rt/handgate/inspire_right/state", Qos::BestEffort);
    lw.wait_matched(1, DEADLINE).unwrap();
    rw.wait_matched(1, DEADLINE).unwrap();
    let l0 = poll(DEADLINE, || left.update().filter(|s| s.freshness == hg::FRESH).cloned())
        .unwrap_or_else(|| panic!("no fresh left state\n{}", gw.transcript()));
    // Start-up: the rest posture, nearly open (wire q 0.99): near each joint's lower limit.
    assert!(l0.closure < 0.05, "{l0:?}");
    assert_eq!(l0.kind, "inspire_dfx");
    // Left: close fully. Positive = closing: every joint ends at its URDF upper limit.
    let names = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];
    let s = drive(&mut lw, &mut left, &closure_cmd(1, 1.0), &gw, "left closes", |s| {
        names
            .iter()
            .enumerate()
            .all(|(i, n)| (joint(s, n) - UPPER[i]).abs() < 0.01)
    });
    assert!(s.closure > 0.98, "{s:?}");
    // Right: the index half way (0.85 rad), by joint name; the other fingers stay open.
    let s = drive(
        &mut rw,
        &mut right,
        &joints_cmd(2, &[("index", 0.85)]),
        &gw,
        "right index",
        |s| (joint(s, "index") - 0.85).abs() < 0.01,
    );
    for (i, name) in ["pinky", "ring", "middle", "thumb_bend", "thumb_rotate"]
        .iter()
        .enumerate()
    {
        let lower = LOWER[if i < 3 { i } else { i + 1 }];
        let q = joint(&s, name);
        assert!((q - lower).abs() < 0.05, "right {name} moved to {q}");
    }
    // The right hand's commands did not open the left one.
    let l = left.update().cloned().unwrap();
    assert!(l.closure > 0.95, "left disturbed: {l:?}");
    // The joint_state front names both hands' joints as in the Inspire URDFs.
    let mut js = Latest::<ros2::JointState_>::new(&n, "rt/joint_states", Qos::BestEffort);
    let j = js.next(DEADLINE).expect("a JointState");
    for name in [
        "L_pinky_proximal_joint",
        "L_thumb_proximal_yaw_joint",
        "R_index_proximal_joint",
    ] {
        assert!(j.name.iter().any(|n| n == name), "{name} not in {:?}", j.name);
    }
}

#[test]
fn the_g1_inspire_dfx_profile_drives_handgate_emulate_inspire_dfx() {
    let _g = serial();
    let emu = Emulator::start(&["inspire_dfx", "--domain", "231"]);
    assert!(
        emu.line.contains("rt/inspire/cmd") && emu.line.contains("rt/inspire/state"),
        "{}",
        emu.line
    );
    let gw = Gateway::start(231, &["--profile", "g1-inspire-dfx"]);
    let n = node(231);
    let mut status: Latest<hg::GatewayStatus_> = Latest::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let fresh = poll(DEADLINE, || {
        let s = status.update()?;
        ["inspire_left", "inspire_right"]
            .iter()
            .all(|d| status_device(s, d).freshness == hg::FRESH)
            .then_some(())
    });
    assert!(fresh.is_some(), "not fresh: {:?}\n{}", status.last, gw.transcript());
    // Watch the service's own wire state while the canonical front closes the right hand.
    let mut wire = Latest::<unitree_go::MotorStates_>::new(&n, "rt/inspire/state", Qos::BestEffort);
    let mut rw = n
        .writer::<hg::HandCmd_>("rt/handgate/inspire_right/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut right = Latest::<hg::HandState_>::new(&n, "rt/handgate/inspire_right/state", Qos::BestEffort);
    rw.wait_matched(1, DEADLINE).unwrap();
    let s = drive(&mut rw, &mut right, &closure_cmd(1, 1.0), &gw, "right closes", |s| {
        (joint(s, "pinky") - 1.7).abs() < 0.01
    });
    assert!(s.closure > 0.98, "{s:?}");
    // On the wire: the right hand's entries 0-5 at q ≈ 0 (closed, 1 = open), the left hand's
    // 6-11 still near its rest (0.99), held there by the right device's messages.
    let w = poll(DEADLINE, || wire.update().filter(|m| m.states[0].q < 0.01).cloned())
        .unwrap_or_else(|| panic!("wire state {:?}", wire.last));
    assert_eq!(w.states.len(), 12);
    assert!(w.states[..6].iter().all(|m| m.q < 0.01), "{w:?}");
    assert!(w.states[6..].iter().all(|m| m.q > 0.97), "left disturbed: {w:?}");
}

/// `handgate check` (validation through the registry): a left and a right hand may share
/// `rt/inspire/cmd`; two hands on one side may not.
#[test]
fn check_accepts_one_hand_per_side_on_the_service_topic_and_refuses_two_on_one_side() {
    let one = |name: &str, side: &str| {
        format!("[[devices]]\nname = \"{name}\"\nkind = \"inspire_dfx\"\nside = \"{side}\"\nbackend = \"dds\"\n")
    };
    let front = "[[fronts]]\nkind = \"joint_state\"\n";
    let run = |text: String, file: &str| {
        let p = write_profile(file, &format!("name = \"{file}\"\ndescription = \"x\"\n{text}{front}"));
        let mut cmd = Command::new(handgate_bin());
        for (k, _) in std::env::vars() {
            if k.starts_with("HANDGATE_") {
                cmd.env_remove(k);
            }
        }
        cmd.current_dir(repo_root())
            .arg("check")
            .arg(&p)
            .output()
            .expect("handgate check runs")
    };
    let ok = run(one("a", "left") + &one("b", "right"), "dfx-pair");
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let only_right = run(one("b", "right"), "dfx-one");
    assert!(
        only_right.status.success(),
        "{}",
        String::from_utf8_lossy(&only_right.stderr)
    );
    let bad = run(one("a", "right") + &one("b", "right"), "dfx-two-right");
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("rt/inspire/cmd"), "{err}");
    // Emulated hands share one emulated service: one per side there too.
    let emulated = |name: &str, side: &str| one(name, side).replace("\"dds\"", "\"emulator\"");
    let two_emulated = run(emulated("a", "left") + &emulated("b", "left"), "dfx-two-emulated-left");
    assert!(!two_emulated.status.success());
    let err = String::from_utf8_lossy(&two_emulated.stderr);
    assert!(err.contains("devices[1].side") && err.contains("one per side"), "{err}");
    let center = run(one("c", "center"), "dfx-center");
    assert!(!center.status.success(), "a center DFX hand");
}
