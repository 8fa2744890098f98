//! The `inspire_ftp` front (handgate serving Inspire's DDS driver's own
//! `rt/inspire_hand/{ctrl,state,touch}/{l,r}`, one front per hand; docs/fronts.md) through the
//! real `handgate` binary:
//!
//! - xr_teleoperate's `Inspire_Controller_FTP`, written on the official SDK
//!   (tests/python/xr_inspire_ftp_client.py), drives two emulated Inspire FTP hands through it,
//!   every finger of each hand to its own target; the canonical fronts confirm each joint
//!   independently, and the client's touch subscriber sees the emulated object under the left
//!   index;
//! - closure pairing both ways: a Dex1 client (`dex1` front, variant go) closes and opens an
//!   emulated Inspire FTP hand, and this front closes and opens an emulated Dex3 hand (which
//!   has no tactile pads: nothing on the touch topic);
//! - `handgate check` on its rules.
//!
//! Domains 96-99 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline. Needs the binary (`cargo build -p handgate`) and `.venv`.

use std::path::PathBuf;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::inspire::{InspireHandCtrl, InspireHandState, InspireHandTouch, MODE_ANGLE};
use handgate_idl::unitree_go;
use handgate_tests::{
    canonical_q, emulated_device, handgate_check, interop_interface, node, poll, serial, stream_until, temp_profile,
    Gateway, Latest, PyProcess,
};
use serde_json::Value;

const DEADLINE: Duration = Duration::from_secs(30);

/// The driver's joint order within a hand (docs/sources.md §7) and the URDF limits (rad), the
/// oracle written out: pinky, ring, middle, index [0, 1.7], thumb bend [0, 0.5], thumb rotation
/// [-0.1, 1.3].
const NAMES: [&str; 6] = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];
const LOWER: [f64; 6] = [0.0, 0.0, 0.0, 0.0, 0.0, -0.1];
const UPPER: [f64; 6] = [1.7, 1.7, 1.7, 1.7, 0.5, 1.3];

fn write_profile(name: &str, body: &str) -> PathBuf {
    temp_profile(
        "ftp-front",
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

/// The client's normalisation (1 = open): q = clip((max - rad) / (max - min), 0, 1).
fn wire_q(i: usize, rad: f64) -> f64 {
    ((UPPER[i] - rad) / (UPPER[i] - LOWER[i])).clamp(0.0, 1.0)
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// xr_teleoperate's FTP controller on the official SDK drives both hands through their fronts,
/// each finger of each hand to its own target (so a swapped joint order, swapped hands or a
/// flipped direction fail); each hand's canonical front then reads every joint at the URDF
/// radians the client meant, positive = closing. The left index closes onto an emulated object
/// just before its target: the client's touch subscriber sees that finger's pads pressed.
#[test]
fn xr_teleoperate_ftp_controller_drives_both_hands_through_the_sdk() {
    let _serial = serial();
    let profile = write_profile(
        "ftp-front-sdk",
        &format!(
            "{}[devices.emulator]\nobject_at = {{ index = 1.0 }}\n{}\
             [[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"ftp_left\"\n[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"ftp_right\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"ftp_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"ftp_right\"\n",
            device("ftp_left", "inspire_ftp", "left"),
            device("ftp_right", "inspire_ftp", "right"),
        ),
    );
    let gw = Gateway::start(96, &["--profile", profile.to_str().unwrap()]);
    // URDF radians, every one different (hands and fingers), none at a limit. The left index
    // (1.05) goes 0.05 rad past the object at 1.0: it presses, below the force limit.
    let left = [0.2, 0.6, 1.3, 1.05, 0.1, 1.0];
    let right = [1.5, 1.1, 0.7, 0.3, 0.4, 0.2];
    let csv = |v: &[f64; 6]| v.map(|x| x.to_string()).join(",");
    let mut args = vec!["96".to_string(), csv(&left), csv(&right)];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    let py = PyProcess::spawn("xr_inspire_ftp_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let line = py
        .wait_line("DONE ", DEADLINE * 2)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", py.transcript(), gw.transcript()));
    let done: Value = serde_json::from_str(line.trim()).unwrap_or_else(|e| panic!("{e}: {line}"));
    // The oracle: each hand's six angles in the driver's joint order, angle_act / 1000.
    for (hand, rad) in [("left", left), ("right", right)] {
        let q = floats(&done[hand]);
        assert_eq!(q.len(), 6, "{done}");
        for i in 0..6 {
            let want = wire_q(i, rad[i]);
            assert!(
                (q[i] - want).abs() < 0.02,
                "{hand} {} read {} want {want}: {done}",
                NAMES[i],
                q[i]
            );
        }
        // Before the targets the client saw every angle open, as it commanded (1000 = open).
        assert!(
            floats(&done[format!("open_{hand}")]).iter().all(|v| *v > 0.95),
            "{done}"
        );
    }
    // Touch: the left index's fingertip pad pressed (the object), the other fingers' not;
    // the right hand has no object.
    let tl = &done["touch"]["l"];
    let peak = |t: &Value, f: &str| t[f].as_i64().unwrap_or_else(|| panic!("no {f} in {t}"));
    assert!(peak(tl, "fingerfour_top_touch") > 300, "left touch {tl}");
    for f in ["fingerone_top_touch", "fingertwo_top_touch", "fingerthree_top_touch"] {
        assert!(peak(tl, f) < 100, "{f} of the left hand pressed: {tl}");
    }
    let tr = &done["touch"]["r"];
    assert!(peak(tr, "fingerfour_top_touch") < 100, "right touch {tr}");
    // Independently, each device's canonical state: the same radians, closed = positive.
    let n = node(96);
    for (dev, want) in [("ftp_left", left), ("ftp_right", right)] {
        let mut st = Latest::<hg::HandState_>::new(&n, &format!("rt/handgate/{dev}/state"), Qos::BestEffort);
        let s = poll(DEADLINE, || st.update().filter(|s| s.freshness == hg::FRESH).cloned())
            .unwrap_or_else(|| panic!("no fresh {dev} state\n{}", gw.transcript()));
        assert_eq!(s.kind, "inspire_ftp");
        for (i, name) in NAMES.iter().enumerate() {
            let got = joint(&s, name);
            // The client exited: the driver has no timeout, the last target is kept.
            assert!(
                (got - want[i]).abs() < 0.04,
                "{dev} {name} = {got} rad, want {}: {s:?}",
                want[i]
            );
        }
    }
    // The right hand's fingers with a smaller client angle (more closed) are further positive.
    let mut st = Latest::<hg::HandState_>::new(&n, "rt/handgate/ftp_right/state", Qos::BestEffort);
    let s = st.next(DEADLINE).expect("right state");
    assert!(
        joint(&s, "pinky") > joint(&s, "ring") && joint(&s, "ring") > joint(&s, "middle"),
        "{s:?}"
    );
}

/// A Dex1 client (xr_teleoperate's Dex1 controller's interface: `rt/dex1/left/cmd`, unitree_go
/// MotorCmds_ with one entry, q 0 = closed, 5.4 = open) drives an emulated Inspire FTP left
/// hand through closure pairing: it closes when the gripper closes and opens when it opens.
#[test]
fn a_dex1_client_closes_and_opens_an_inspire_ftp_hand() {
    let _serial = serial();
    let profile = write_profile(
        "ftp-front-dex1",
        &format!(
            "{}[[fronts]]\nkind = \"dex1\"\ndevice = \"ftp_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"ftp_left\"\n",
            device("ftp_left", "inspire_ftp", "left"),
        ),
    );
    let gw = Gateway::start(97, &["--profile", profile.to_str().unwrap()]);
    let n = node(97);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/dex1/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/ftp_left/state", Qos::BestEffort);
    let mut grip = Latest::<unitree_go::MotorStates_>::new(&n, "rt/dex1/left/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let s0 = poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    assert!(s0.closure < 0.2, "starts at rest, nearly open: {s0:?}");
    let one = |q: f32| {
        let mut m = unitree_go::MotorCmds_::with_len(1);
        m.cmds[0].q = q;
        m
    };
    // Gripper closed (q 0): the hand's fist (the kind's closure 1): the four fingers at their
    // closed (upper) limit, the thumb kept straight (its lower ends).
    let closed = stream_until(&mut w, &one(0.0), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(closed, "hand did not close: {:?}\n{}", canon.last, gw.transcript());
    let s = canon.last.clone().unwrap();
    for (i, name) in NAMES.iter().enumerate() {
        if i < 4 {
            assert!(joint(&s, name) > UPPER[i] - 0.1, "{name} not closed: {s:?}");
        } else {
            assert!(joint(&s, name) < LOWER[i] + 0.05, "{name} not straight: {s:?}");
        }
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

fn ctrl(angle: [i16; 6]) -> InspireHandCtrl {
    InspireHandCtrl {
        angle_set: angle.to_vec(),
        mode: MODE_ANGLE,
        ..InspireHandCtrl::sdk_default()
    }
}

/// This front drives an emulated Dex3 hand (closure pairing): all angles closed (0) close it,
/// all open (1000) open it, and the front's state follows; a Dex3 has no tactile pads, so
/// nothing is published on the touch topic while the state flows.
#[test]
fn the_inspire_ftp_front_closes_and_opens_a_dex3_hand() {
    let _serial = serial();
    let profile = write_profile(
        "ftp-front-dex3",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"dex3_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"dex3_left\"\n",
            device("dex3_left", "dex3", "left"),
        ),
    );
    let gw = Gateway::start(98, &["--profile", profile.to_str().unwrap()]);
    let n = node(98);
    let mut w = n
        .writer::<InspireHandCtrl>("rt/inspire_hand/ctrl/l", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let mut wire = Latest::<InspireHandState>::new(&n, "rt/inspire_hand/state/l", Qos::BestEffort);
    let mut touch = Latest::<InspireHandTouch>::new(&n, "rt/inspire_hand/touch/l", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let s0 = poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    let closed = stream_until(&mut w, &ctrl([0; 6]), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(
        closed,
        "dex3 did not close from {s0:?}: {:?}\n{}",
        canon.last,
        gw.transcript()
    );
    // The front reports the hand closed from the Dex3's closure: the four fingers' angles near
    // 0 (closed), the thumb straight (its angles near 1000), as this kind's fist.
    let m = poll(DEADLINE, || {
        wire.update()
            .filter(|m| m.angle_act[..4].iter().all(|a| *a < 100) && m.angle_act[4..].iter().all(|a| *a > 900))
            .cloned()
    });
    assert!(m.is_some(), "front state {:?}", wire.last);
    let opened = stream_until(&mut w, &ctrl([1000; 6]), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "dex3 did not open: {:?}\n{}", canon.last, gw.transcript());
    // Many state messages later (the front publishes state and touch in the same tick), no
    // touch message arrived.
    let mut states = 0;
    let seen = poll(DEADLINE, || {
        if wire.update().is_some_and(|m| m.angle_act.iter().all(|a| *a > 900)) {
            states += 1;
        }
        (states >= 50).then_some(())
    });
    assert!(seen.is_some(), "front state {:?}", wire.last);
    assert!(touch.update().is_none(), "touch from a Dex3: {:?}", touch.last);
}

fn check(name: &str, body: &str) -> std::process::Output {
    handgate_check(&write_profile(name, body))
}

/// `handgate check`: the front's topics and touch are described; a center device needs a side;
/// two fronts on one hand's topics clash.
#[test]
fn check_describes_the_front_and_refuses_a_side_less_device() {
    let one = check(
        "ftp-front-check",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"l\"\n",
            device("l", "inspire_ftp", "left")
        ),
    );
    let out = String::from_utf8_lossy(&one.stdout);
    assert!(one.status.success(), "{}", String::from_utf8_lossy(&one.stderr));
    assert!(
        out.contains(
            "cmd rt/inspire_hand/ctrl/l state rt/inspire_hand/state/l at 50 Hz, touch rt/inspire_hand/touch/{l,r}"
        ) && out.contains("silence: service: keeps the last target"),
        "{out}"
    );
    let center = check(
        "ftp-front-check-center",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"g\"\n",
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
        "ftp-front-check-center-sided",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"g\"\nside = \"right\"\n",
            device("g", "ezgripper", "center")
        ),
    );
    let out = String::from_utf8_lossy(&sided.stdout);
    assert!(sided.status.success(), "{}", String::from_utf8_lossy(&sided.stderr));
    assert!(
        out.contains("cmd rt/inspire_hand/ctrl/r") && out.contains("touch rt/inspire_hand/touch/r from"),
        "{out}"
    );
    // On the topics a dds-backed hand uses to reach its driver: refused (it would answer its
    // own commands).
    let own = check(
        "ftp-front-check-own",
        "[[devices]]\nname = \"l\"\nkind = \"inspire_ftp\"\nside = \"left\"\nbackend = \"dds\"\n\
         [[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"l\"\n",
    );
    assert!(!own.status.success());
    assert!(
        String::from_utf8_lossy(&own.stderr).contains("uses to reach the real device"),
        "{}",
        String::from_utf8_lossy(&own.stderr)
    );
    let two = check(
        "ftp-front-check-two",
        &format!(
            "{}[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"l\"\n[[fronts]]\nkind = \"inspire_ftp\"\ndevice = \"l\"\nname = \"again\"\n",
            device("l", "inspire_ftp", "left")
        ),
    );
    assert!(!two.status.success(), "two fronts on rt/inspire_hand/ctrl/l");
    assert!(
        String::from_utf8_lossy(&two.stderr).contains("rt/inspire_hand/ctrl/l"),
        "{}",
        String::from_utf8_lossy(&two.stderr)
    );
}
