//! The `inspire_dfx` front (handgate serving DFX_inspire_service's own `rt/inspire/cmd` /
//! `rt/inspire/state`, both hands in one 12-entry message; docs/fronts.md) through the real
//! `handgate` binary:
//!
//! - xr_teleoperate's `Inspire_Controller_DFX`, written on the official SDK
//!   (tests/python/xr_inspire_dfx_client.py), drives two emulated Inspire DFX hands through it,
//!   every finger to its own target; the canonical fronts confirm each joint independently;
//! - closure pairing both ways: a Dex1 client (`dex1` front, variant go) closes and opens an
//!   emulated Inspire DFX hand, and this front closes and opens an emulated Dex3 hand;
//! - `handgate check` on its binding rules.
//!
//! Domains 80-82 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline. Needs the binary (`cargo build -p handgate`) and `.venv`.

use std::path::PathBuf;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_go;
use handgate_tests::{
    canonical_q, emulated_device, handgate_check, interop_interface, node, poll, serial, stream_until, temp_profile,
    Gateway, Latest, PyProcess,
};
use serde_json::Value;

const DEADLINE: Duration = Duration::from_secs(30);

/// The service's joint order within a hand (docs/sources.md §7) and the URDF limits (rad), the
/// oracle written out: pinky, ring, middle, index [0, 1.7], thumb bend [0, 0.5], thumb rotation
/// [-0.1, 1.3].
const NAMES: [&str; 6] = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];
const LOWER: [f64; 6] = [0.0, 0.0, 0.0, 0.0, 0.0, -0.1];
const UPPER: [f64; 6] = [1.7, 1.7, 1.7, 1.7, 0.5, 1.3];

fn write_profile(name: &str, body: &str) -> PathBuf {
    temp_profile(
        "dfx-front",
        name,
        &format!("name = \"{name}\"\ndescription = \"test\"\n{body}"),
    )
}

fn device(name: &str, kind: &str, side: &str) -> String {
    emulated_device(name, kind, side)
}

fn joint(s: &hg::HandState_, name: &str) -> f64 {
    f64::from(canonical_q(s, name))
}

/// The service's message: 12 entries, only `q` set (as xr_teleoperate sends it).
fn dfx_cmd(right: [f32; 6], left: [f32; 6]) -> unitree_go::MotorCmds_ {
    let mut m = unitree_go::MotorCmds_::with_len(12);
    for (c, q) in m.cmds.iter_mut().zip(right.iter().chain(&left)) {
        c.q = *q;
    }
    m
}

/// The client's normalisation (1 = open): q = clip((max - rad) / (max - min), 0, 1).
fn wire_q(i: usize, rad: f64) -> f64 {
    ((UPPER[i] - rad) / (UPPER[i] - LOWER[i])).clamp(0.0, 1.0)
}

/// xr_teleoperate's DFX controller on the official SDK drives both hands through the front,
/// each finger of each hand to its own target (so a swapped joint order, swapped hands or a
/// flipped direction fail); each hand's canonical front then reads every joint at the URDF
/// radians the client meant, positive = closing.
#[test]
fn xr_teleoperate_dfx_controller_drives_both_hands_through_the_sdk() {
    let _serial = serial();
    let profile = write_profile(
        "dfx-front-sdk",
        &format!(
            "{}{}[[fronts]]\nkind = \"inspire_dfx\"\ndevices = {{ right = \"inspire_right\", left = \"inspire_left\" }}\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"inspire_right\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"inspire_left\"\n",
            device("inspire_right", "inspire_dfx", "right"),
            device("inspire_left", "inspire_dfx", "left"),
        ),
    );
    let gw = Gateway::start(80, &["--profile", profile.to_str().unwrap()]);
    // URDF radians, every one different (hands and fingers), none at a limit.
    let right = [1.5, 1.1, 0.7, 0.3, 0.4, 0.2];
    let left = [0.2, 0.6, 1.0, 1.4, 0.1, 1.0];
    let csv = |v: &[f64; 6]| v.map(|x| x.to_string()).join(",");
    let mut args = vec!["80".to_string(), csv(&right), csv(&left)];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    let py = PyProcess::spawn("xr_inspire_dfx_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let line = py
        .wait_line("DONE ", DEADLINE * 2)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", py.transcript(), gw.transcript()));
    let done: Value = serde_json::from_str(line.trim()).unwrap_or_else(|e| panic!("{e}: {line}"));
    let q: Vec<f64> = done["q"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(q.len(), 12, "{done}");
    // The oracle: entries 0-5 the right hand, 6-11 the left, in the service's joint order.
    for i in 0..6 {
        for (e, rad) in [(i, right[i]), (6 + i, left[i])] {
            let want = wire_q(i, rad);
            assert!(
                (q[e] - want).abs() < 0.02,
                "entry {e} ({}) read {} want {want}: {done}",
                NAMES[i],
                q[e]
            );
        }
    }
    // Before the targets the client saw every entry open, as it commanded (1 = open).
    assert!(
        done["open_q"]
            .as_array()
            .unwrap()
            .iter()
            .all(|v| v.as_f64().unwrap() > 0.95),
        "{done}"
    );
    // Independently, each device's canonical state: the same radians, closed = positive.
    let n = node(80);
    for (dev, want) in [("inspire_right", right), ("inspire_left", left)] {
        let mut st = Latest::<hg::HandState_>::new(&n, &format!("rt/handgate/{dev}/state"), Qos::BestEffort);
        let s = poll(DEADLINE, || st.update().filter(|s| s.freshness == hg::FRESH).cloned())
            .unwrap_or_else(|| panic!("no fresh {dev} state\n{}", gw.transcript()));
        assert_eq!(s.kind, "inspire_dfx");
        for (i, name) in NAMES.iter().enumerate() {
            let got = joint(&s, name);
            // The client still streams nothing now (it exited): the last target is kept.
            assert!(
                (got - want[i]).abs() < 0.04,
                "{dev} {name} = {got} rad, want {}: {s:?}",
                want[i]
            );
        }
    }
    // The fingers with a larger client "closed" (smaller q) are further positive.
    let mut st = Latest::<hg::HandState_>::new(&n, "rt/handgate/inspire_right/state", Qos::BestEffort);
    let s = st.next(DEADLINE).expect("right state");
    assert!(
        joint(&s, "pinky") > joint(&s, "ring") && joint(&s, "ring") > joint(&s, "middle"),
        "{s:?}"
    );
}

/// A Dex1 client (xr_teleoperate's Dex1 controller's interface: `rt/dex1/left/cmd`, unitree_go
/// MotorCmds_ with one entry, q 0 = closed, 5.4 = open) drives an emulated Inspire DFX left
/// hand through closure pairing: it closes when the gripper closes and opens when it opens.
#[test]
fn a_dex1_client_closes_and_opens_an_inspire_dfx_hand() {
    let _serial = serial();
    let profile = write_profile(
        "dfx-front-dex1",
        &format!(
            "{}[[fronts]]\nkind = \"dex1\"\ndevice = \"inspire_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"inspire_left\"\n",
            device("inspire_left", "inspire_dfx", "left"),
        ),
    );
    let gw = Gateway::start(81, &["--profile", profile.to_str().unwrap()]);
    let n = node(81);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/dex1/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/inspire_left/state", Qos::BestEffort);
    let mut grip = Latest::<unitree_go::MotorStates_>::new(&n, "rt/dex1/left/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let s0 = poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    assert!(s0.closure < 0.1, "starts nearly open: {s0:?}");
    let one = |q: f32| {
        let mut m = unitree_go::MotorCmds_::with_len(1);
        m.cmds[0].q = q;
        m
    };
    // Gripper closed (q 0): every finger of the hand at its closed (upper) limit.
    let closed = stream_until(&mut w, &one(0.0), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(closed, "hand did not close: {:?}\n{}", canon.last, gw.transcript());
    let s = canon.last.clone().unwrap();
    for (i, name) in NAMES.iter().enumerate() {
        assert!(joint(&s, name) > UPPER[i] - 0.1, "{name} not closed: {s:?}");
    }
    // The gripper's own state reads closed too (q near 0 of 5.4).
    let g = poll(DEADLINE, || grip.update().filter(|m| m.states[0].q < 0.3).cloned());
    assert!(g.is_some(), "dex1 state {:?}", grip.last);
    // Gripper open (5.4): the hand opens.
    let opened = stream_until(&mut w, &one(5.4), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "hand did not open: {:?}\n{}", canon.last, gw.transcript());
    let s = canon.last.clone().unwrap();
    for (i, name) in NAMES.iter().enumerate() {
        assert!(joint(&s, name) < LOWER[i] + 0.1, "{name} not open: {s:?}");
    }
}

/// This front drives an emulated Dex3 hand (closure pairing), bound as the left hand: the
/// left entries all closed (q 0) close the Dex3, all open (q 1) open it; the right element,
/// with no device, reads open and never measured.
#[test]
fn the_inspire_dfx_front_closes_and_opens_a_dex3_hand() {
    let _serial = serial();
    let profile = write_profile(
        "dfx-front-dex3",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_dfx\"\ndevices = {{ left = \"dex3_left\" }}\n[[fronts]]\nkind = \"canonical\"\ndevice = \"dex3_left\"\n",
            device("dex3_left", "dex3", "left"),
        ),
    );
    let gw = Gateway::start(82, &["--profile", profile.to_str().unwrap()]);
    let n = node(82);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/inspire/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let mut wire = Latest::<unitree_go::MotorStates_>::new(&n, "rt/inspire/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let s0 = poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    // Right entries open (they go to no device), left entries closed.
    let closed = stream_until(&mut w, &dfx_cmd([1.0; 6], [0.0; 6]), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(
        closed,
        "dex3 did not close from {s0:?}: {:?}\n{}",
        canon.last,
        gw.transcript()
    );
    // The front reports the left hand closed (q near 0) from the Dex3's closure, the right as
    // unbound: open, never measured.
    let m = poll(DEADLINE, || {
        wire.update()
            .filter(|m| m.states.len() == 12 && m.states[6..].iter().all(|s| s.q < 0.1))
            .cloned()
    })
    .unwrap_or_else(|| panic!("front state {:?}", wire.last));
    for s in &m.states[..6] {
        assert_eq!((s.q, s.lost, s.reserve[1]), (1.0, 0xFFFF_FFFE, 1), "{m:?}");
    }
    assert!(m.states[6..].iter().all(|s| s.lost == 0), "{m:?}");
    // All open: the Dex3 opens.
    let opened = stream_until(&mut w, &dfx_cmd([0.0; 6], [1.0; 6]), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "dex3 did not open: {:?}\n{}", canon.last, gw.transcript());
    let m = poll(DEADLINE, || {
        wire.update()
            .filter(|m| m.states.len() == 12 && m.states[6..].iter().all(|s| s.q > 0.9))
            .cloned()
    });
    assert!(m.is_some(), "front state {:?}", wire.last);
}

fn check(name: &str, body: &str) -> std::process::Output {
    handgate_check(&write_profile(name, body))
}

/// `handgate check`: the unbound hand is described; a center device needs a side; two
/// inspire_dfx fronts on the one topic are told that one serves both hands.
#[test]
fn check_describes_the_unbound_hand_and_refuses_what_the_message_cannot_carry() {
    let one = check(
        "dfx-front-check-left",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_dfx\"\ndevices = {{ left = \"l\" }}\n",
            device("l", "inspire_dfx", "left")
        ),
    );
    let out = String::from_utf8_lossy(&one.stdout);
    assert!(one.status.success(), "{}", String::from_utf8_lossy(&one.stderr));
    assert!(
        out.contains("rt/inspire/cmd") && out.contains("element 0 (right, entries 0-5): no device bound"),
        "{out}"
    );
    let center = check(
        "dfx-front-check-center",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_dfx\"\ndevice = \"g\"\n",
            device("g", "ezgripper", "center")
        ),
    );
    let err = String::from_utf8_lossy(&center.stderr);
    assert!(!center.status.success(), "a center device with no side");
    assert!(
        err.contains("fronts[0].side") && err.contains("left or a right hand"),
        "{err}"
    );
    let sided = check(
        "dfx-front-check-center-sided",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_dfx\"\ndevice = \"g\"\nside = \"left\"\n",
            device("g", "ezgripper", "center")
        ),
    );
    assert!(sided.status.success(), "{}", String::from_utf8_lossy(&sided.stderr));
    let two = check(
        "dfx-front-check-two",
        &format!(
            "{}{}[[fronts]]\nkind = \"inspire_dfx\"\ndevice = \"l\"\n[[fronts]]\nkind = \"inspire_dfx\"\ndevice = \"r\"\n",
            device("l", "inspire_dfx", "left"),
            device("r", "inspire_dfx", "right")
        ),
    );
    let err = String::from_utf8_lossy(&two.stderr);
    assert!(!two.status.success());
    assert!(err.contains("one inspire_dfx front serves both hands"), "{err}");
}
