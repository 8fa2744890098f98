//! The `brainco` front (handgate serving `brainco_hand_service`'s own
//! `rt/brainco/{left,right}/{cmd,state}`, one front per hand; docs/fronts.md) through the real
//! `handgate` binary:
//!
//! - xr_teleoperate's `Brainco_Controller`, written on the official SDK
//!   (tests/python/xr_brainco_client.py), drives two emulated BrainCo hands through two such
//!   fronts, every finger to its own target; the canonical fronts confirm each joint
//!   independently (closed in the client's convention = canonical positive), and with
//!   `silence = "service"` the hands keep their targets after the client is gone;
//! - closure pairing: a BrainCo client closes and opens an emulated Dex3 hand;
//! - `silence = "watchdog"`: a client that stops trips the device's watchdog;
//! - `handgate check` on its side rule.
//!
//! Domains 88-90 (of the front's 88-91, docs/development.md; the `check` test opens none).
//! Tests take turns ([`serial`]); every wait is on readiness with a deadline. Needs the binary
//! (`cargo build -p handgate`) and `.venv`.

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

/// The service's joint order within a hand (docs/sources.md §7) and, the oracle written out,
/// the URDF upper limits (rad; lower 0): thumb 1.5184, thumb aux 1.0472, fingers 1.4661.
const NAMES: [&str; 6] = ["thumb", "thumb_aux", "index", "middle", "ring", "pinky"];
#[allow(clippy::approx_constant)] // the URDF's literal figure
const URDF_MAX: [f64; 6] = [1.5184, 1.0472, 1.4661, 1.4661, 1.4661, 1.4661];
/// The client's normalisation ranges (xr_teleoperate's figures, rad).
const CLIENT_MAX: [f64; 6] = [1.52, 1.05, 1.47, 1.47, 1.47, 1.47];

fn write_profile(name: &str, body: &str) -> PathBuf {
    temp_profile(
        "brainco-front",
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

fn status_of<'a>(s: &'a hg::GatewayStatus_, name: &str) -> &'a hg::DeviceStatus_ {
    s.devices
        .iter()
        .find(|d| d.device == name)
        .unwrap_or_else(|| panic!("no {name} in {s:?}"))
}

fn floats(v: &Value, k: &str) -> Vec<f64> {
    v[k].as_array()
        .unwrap_or_else(|| panic!("{k} in {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The client's normalisation (1 = closed): q = 1 - clip((max - rad) / max, 0, 1).
fn wire_q(i: usize, rad: f64) -> f64 {
    1.0 - ((CLIENT_MAX[i] - rad) / CLIENT_MAX[i]).clamp(0.0, 1.0)
}

/// The service's message for one hand: 6 entries, `q` and `dq = 1` set (as xr_teleoperate).
fn brainco_cmd(q: f32) -> unitree_go::MotorCmds_ {
    let mut m = unitree_go::MotorCmds_::with_len(6);
    for c in &mut m.cmds {
        c.q = q;
        c.dq = 1.0;
    }
    m
}

/// xr_teleoperate's BrainCo controller on the official SDK drives both hands through their
/// fronts, each finger of each hand to its own target (so a swapped joint order, swapped hands
/// or a flipped direction fail); each hand's canonical front then reads every joint at the
/// URDF radians the client meant, positive = closing, kept after the client is gone.
#[test]
fn xr_teleoperate_brainco_controller_drives_both_hands_through_the_sdk() {
    let _serial = serial();
    let profile = write_profile(
        "brainco-front-sdk",
        &format!(
            "{}{}[[fronts]]\nkind = \"brainco\"\ndevice = \"bl\"\n[[fronts]]\nkind = \"brainco\"\ndevice = \"br\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"bl\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"br\"\n",
            device("bl", "brainco", "left"),
            device("br", "brainco", "right"),
        ),
    );
    let gw = Gateway::start(88, &["--profile", profile.to_str().unwrap()]);
    // URDF radians, every one different (hands and fingers), none at a limit.
    let left = [1.2, 0.3, 0.5, 0.9, 1.3, 0.1];
    let right = [0.4, 0.8, 1.4, 0.2, 0.6, 1.0];
    let csv = |v: &[f64; 6]| v.map(|x| x.to_string()).join(",");
    let mut args = vec!["88".to_string(), csv(&left), csv(&right)];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    let py = PyProcess::spawn("xr_brainco_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let line = py
        .wait_line("DONE ", DEADLINE * 2)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", py.transcript(), gw.transcript()));
    let done: Value = serde_json::from_str(line.trim()).unwrap_or_else(|e| panic!("{e}: {line}"));
    // The oracle: each hand's own topic, entries in the service's joint order.
    for (hand, rad) in [("left_q", left), ("right_q", right)] {
        let q = floats(&done, hand);
        assert_eq!(q.len(), 6, "{done}");
        for i in 0..6 {
            let want = wire_q(i, rad[i]);
            assert!(
                (q[i] - want).abs() < 0.02,
                "{hand}[{i}] ({}) read {} want {want}: {done}",
                NAMES[i],
                q[i]
            );
        }
    }
    // Before the targets the client saw every entry open, as it commanded (0 = open).
    assert!(floats(&done, "open_q").iter().all(|v| *v < 0.05), "{done}");
    // Independently, each device's canonical state: closed in the client's convention (q
    // toward 1) is canonical positive, rad = q · URDF max.
    let n = node(88);
    for (dev, rad) in [("bl", left), ("br", right)] {
        let mut st = Latest::<hg::HandState_>::new(&n, &format!("rt/handgate/{dev}/state"), Qos::BestEffort);
        let s = poll(DEADLINE, || st.update().filter(|s| s.freshness == hg::FRESH).cloned())
            .unwrap_or_else(|| panic!("no fresh {dev} state\n{}", gw.transcript()));
        assert_eq!(s.kind, "brainco");
        for (i, name) in NAMES.iter().enumerate() {
            let got = joint(&s, name);
            let want = wire_q(i, rad[i]) * URDF_MAX[i];
            assert!(got > 0.05, "{dev} {name} = {got} rad: closing is positive: {s:?}");
            assert!(
                (got - want).abs() < 0.04,
                "{dev} {name} = {got} rad, want {want}: {s:?}"
            );
        }
    }
    // Silence "service": the client is gone and the hands keep their targets; no silence action
    // ran on either device (status at 1 Hz: the second sample is past the 200 ms watchdog).
    drop(py);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    status.next(DEADLINE).expect("status");
    let s = status.next(DEADLINE).expect("status");
    for dev in ["bl", "br"] {
        let d = status_of(&s, dev);
        assert_eq!((d.watchdog_trips, d.safe), (0, false), "{dev}: {d:?}");
    }
    let mut st = Latest::<hg::HandState_>::new(&n, "rt/handgate/bl/state", Qos::BestEffort);
    let s = st.next(DEADLINE).expect("left state");
    assert!(
        (joint(&s, "ring") - wire_q(4, left[4]) * URDF_MAX[4]).abs() < 0.04,
        "kept: {s:?}"
    );
}

/// A BrainCo client (the service's message on `rt/brainco/left/cmd`, q 1 = closed) drives an
/// emulated Dex3 left hand through closure pairing: it closes when the client closes and opens
/// when it opens; the front reports the Dex3's closure back in the BrainCo convention.
#[test]
fn a_brainco_client_closes_and_opens_a_dex3_hand() {
    let _serial = serial();
    let profile = write_profile(
        "brainco-front-dex3",
        &format!(
            "{}[[fronts]]\nkind = \"brainco\"\ndevice = \"dex3_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"dex3_left\"\n",
            device("dex3_left", "dex3", "left"),
        ),
    );
    let gw = Gateway::start(89, &["--profile", profile.to_str().unwrap()]);
    let n = node(89);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/brainco/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let mut wire = Latest::<unitree_go::MotorStates_>::new(&n, "rt/brainco/left/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let s0 = poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    assert!(s0.closure < 0.5, "starts not closed: {s0:?}");
    let closed = stream_until(&mut w, &brainco_cmd(1.0), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(
        closed,
        "dex3 did not close from {s0:?}: {:?}\n{}",
        canon.last,
        gw.transcript()
    );
    // The front reports the hand closed (every entry near 1), fresh.
    let m = poll(DEADLINE, || {
        wire.update()
            .filter(|m| m.states.len() == 6 && m.states.iter().all(|s| s.q > 0.9))
            .cloned()
    })
    .unwrap_or_else(|| panic!("front state {:?}", wire.last));
    assert!(m.states.iter().all(|s| s.lost == 0 && s.reserve[1] == 0), "{m:?}");
    let opened = stream_until(&mut w, &brainco_cmd(0.0), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "dex3 did not open: {:?}\n{}", canon.last, gw.transcript());
    let m = poll(DEADLINE, || {
        wire.update()
            .filter(|m| m.states.len() == 6 && m.states.iter().all(|s| s.q < 0.1))
            .cloned()
    });
    assert!(m.is_some(), "front state {:?}", wire.last);
}

/// `silence = "watchdog"`: a client that commands and stops trips the device's watchdog (the
/// default `service` keeps the last target, tested above).
#[test]
fn silence_watchdog_trips_when_the_brainco_client_stops() {
    let _serial = serial();
    let profile = write_profile(
        "brainco-front-watchdog",
        &format!(
            "{}[[fronts]]\nkind = \"brainco\"\ndevice = \"br\"\nsilence = \"watchdog\"\n",
            device("br", "brainco", "right"),
        ),
    );
    let gw = Gateway::start(90, &["--profile", profile.to_str().unwrap()]);
    let n = node(90);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/brainco/right/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut wire = Latest::<unitree_go::MotorStates_>::new(&n, "rt/brainco/right/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    w.wait_matched(1, DEADLINE).unwrap();
    let moved = stream_until(&mut w, &brainco_cmd(0.5), DEADLINE, || {
        wire.update()
            .is_some_and(|m| m.states.iter().all(|s| (s.q - 0.5).abs() < 0.05))
    });
    assert!(moved, "half closed: {:?}\n{}", wire.last, gw.transcript());
    let d = poll(DEADLINE, || {
        let s = status.next(Duration::from_millis(50))?;
        let d = status_of(&s, "br").clone();
        (d.watchdog_trips >= 1).then_some(d)
    })
    .unwrap_or_else(|| panic!("no trip: {:?}\n{}", status.last, gw.transcript()));
    assert!(d.safe, "{d:?}");
    assert!(gw.transcript().contains("silence=watchdog"), "{}", gw.transcript());
}

fn check(name: &str, body: &str) -> std::process::Output {
    handgate_check(&write_profile(name, body))
}

/// `handgate check`: a brainco front serves its side's topics; a center device needs a side
/// (or both topics); two brainco fronts on one side clash.
#[test]
fn check_serves_the_sides_topics_and_refuses_a_center_device_without_a_side() {
    let ok = check(
        "brainco-front-check",
        &format!(
            "{}[[fronts]]\nkind = \"brainco\"\ndevice = \"r\"\n",
            device("r", "brainco", "right")
        ),
    );
    let out = String::from_utf8_lossy(&ok.stdout);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(
        out.contains("rt/brainco/right/cmd") && out.contains("rt/brainco/right/state"),
        "{out}"
    );
    let center = check(
        "brainco-front-check-center",
        &format!(
            "{}[[fronts]]\nkind = \"brainco\"\ndevice = \"g\"\n",
            device("g", "ezgripper", "center")
        ),
    );
    let err = String::from_utf8_lossy(&center.stderr);
    assert!(!center.status.success(), "a center device with no side");
    assert!(
        err.contains("fronts[0].side") && err.contains("a brainco front serves side left or right"),
        "{err}"
    );
    let sided = check(
        "brainco-front-check-center-sided",
        &format!(
            "{}[[fronts]]\nkind = \"brainco\"\ndevice = \"g\"\nside = \"left\"\n",
            device("g", "ezgripper", "center")
        ),
    );
    let out = String::from_utf8_lossy(&sided.stdout);
    assert!(sided.status.success(), "{}", String::from_utf8_lossy(&sided.stderr));
    assert!(out.contains("rt/brainco/left/cmd"), "{out}");
    let two = check(
        "brainco-front-check-two",
        &format!(
            "{}{}[[fronts]]\nkind = \"brainco\"\ndevice = \"a\"\n[[fronts]]\nkind = \"brainco\"\ndevice = \"b\"\n",
            device("a", "brainco", "left"),
            device("b", "dex3", "left")
        ),
    );
    assert!(!two.status.success(), "two fronts on rt/brainco/left/cmd");
}
