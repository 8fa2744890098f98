//! The Dex1 front's `variant = "auto"` (the default) through the real `handgate` binary, with
//! the official Python SDK as the client (tests/python/dex1_variant_client.py,
//! xr_actuator_client.py):
//!
//! - an hg client is served: its commands move the gripper, it receives HandState_;
//! - a go client likewise (served from the start: nothing to add, nothing logged);
//! - a go and an hg client on one front at once: each gets states in its own type, both move
//!   the one gripper (the hg client sees the go client's target in HandState_);
//! - an rt/unitree_actuator client on two per-side auto fronts: one writer, one 2-element
//!   message at the front's rate, each element from its side's gripper; with one side's front
//!   only, the other element is reported unbound as the actuator variant does;
//! - `handgate check` describes `auto`; a device refuses it.
//!
//! Domains 130-134 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline. Needs `.venv` (scripts/setup.sh).

use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::unitree_go;
use handgate_tests::{
    actuator_cmd, handgate_bin, interop_interface, node, poll, repo_root, serial, stream_until, temp_profile, Gateway,
    Latest, PyProcess,
};
use serde_json::Value;

const DEADLINE: Duration = Duration::from_secs(30);
const TOL: f64 = 0.05;

/// `dex1_variant_client.py DOMAIN VARIANT SIDE TARGET [IFACE]`, READY awaited.
fn client(domain: u32, variant: &str, side: &str, target: f64, gw: &Gateway) -> PyProcess {
    client_with(domain, variant, side, target, &[], gw)
}

/// [`client`] with more arguments (`--watch W`).
fn client_with(domain: u32, variant: &str, side: &str, target: f64, more: &[&str], gw: &Gateway) -> PyProcess {
    let mut args = vec![domain.to_string(), variant.into(), side.into(), target.to_string()];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    args.extend(more.iter().map(|s| s.to_string()));
    let py = PyProcess::spawn("dex1_variant_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    py
}

/// The JSON of `py`'s DONE line.
fn done(py: &PyProcess, gw: &Gateway) -> Value {
    let line = py
        .wait_line("DONE ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", py.transcript(), gw.transcript()));
    serde_json::from_str(line.trim_start_matches("DONE ")).unwrap()
}

/// Lines of the gateway's output containing `what`.
fn count_lines(gw: &Gateway, what: &str) -> usize {
    gw.transcript().lines().filter(|l| l.contains(what)).count()
}

#[test]
fn an_hg_client_is_served_by_the_default_auto_front() {
    let _serial = serial();
    // The embedded default profile: its Dex1 fronts set no variant.
    let gw = Gateway::start(130, &[]);
    // From the emulator's rest (wire q 5.0) to 2.0: the client's commands move the gripper.
    let py = client(130, "hg", "left", 2.0, &gw);
    let d = done(&py, &gw);
    assert_eq!(d["type"], "HandState_", "{d}");
    assert!((d["q"].as_f64().unwrap() - 2.0).abs() < TOL, "{d}");
    // The addition is logged once, naming the client's type.
    let added = "dex1 front dex1_left serves hg clients too";
    gw.wait_stdout(added, DEADLINE).unwrap();
    assert_eq!(count_lines(&gw, added), 1, "{}", gw.transcript());
    assert!(
        gw.transcript().contains("unitree_hg::msg::dds_::Hand"),
        "{}",
        gw.transcript()
    );
    // The right front saw no client of its own.
    assert_eq!(
        count_lines(&gw, "dex1 front dex1_right serves"),
        0,
        "{}",
        gw.transcript()
    );
}

#[test]
fn a_go_client_is_served_by_the_default_auto_front() {
    let _serial = serial();
    let gw = Gateway::start(131, &[]);
    let py = client(131, "go", "right", 2.5, &gw);
    let d = done(&py, &gw);
    assert_eq!(d["type"], "MotorStates_", "{d}");
    assert!((d["q"].as_f64().unwrap() - 2.5).abs() < TOL, "{d}");
    // Go is served from the start: nothing was added.
    assert_eq!(count_lines(&gw, "serves go clients"), 0, "{}", gw.transcript());
}

#[test]
fn a_go_and_an_hg_client_on_one_auto_front_are_served_at_once() {
    let _serial = serial();
    let gw = Gateway::start(132, &[]);
    // The hg client moves the left gripper to 1.5 and stays, reading HandState_; the go
    // client, on the same front meanwhile, moves it to 3.5 reading MotorStates_; the hg client
    // sees that in its own type.
    let hg = client_with(132, "hg", "left", 1.5, &["--watch", "3.5"], &gw);
    let dh = done(&hg, &gw);
    assert_eq!(dh["type"], "HandState_", "{dh}");
    assert!((dh["q"].as_f64().unwrap() - 1.5).abs() < TOL, "{dh}");
    assert!(dh["commands"].as_u64().unwrap() > 0, "the hg client moved it: {dh}");
    let go = client(132, "go", "left", 3.5, &gw);
    let dg = done(&go, &gw);
    assert_eq!(dg["type"], "MotorStates_", "{dg}");
    assert!((dg["q"].as_f64().unwrap() - 3.5).abs() < TOL, "{dg}");
    assert!(dg["commands"].as_u64().unwrap() > 0, "the go client moved it: {dg}");
    let line = hg
        .wait_line("SAW ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", hg.transcript(), gw.transcript()));
    let saw: Value = serde_json::from_str(line.trim_start_matches("SAW ")).unwrap();
    assert_eq!(saw["type"], "HandState_", "{saw}");
    assert_eq!(
        count_lines(&gw, "dex1 front dex1_left serves hg clients too"),
        1,
        "{}",
        gw.transcript()
    );
}

/// Dex1 grippers on emulators, one auto front per listed side (`right`, `left`).
fn per_side_profile(name: &str, sides: &[&str]) -> std::path::PathBuf {
    let mut text = format!("name = \"{name}\"\n");
    for side in sides {
        text.push_str(&format!(
            "[[devices]]\nname = \"grip_{side}\"\nkind = \"dex1\"\nside = \"{side}\"\nbackend = \"emulator\"\n"
        ));
    }
    for side in sides {
        text.push_str(&format!("[[fronts]]\nkind = \"dex1\"\ndevice = \"grip_{side}\"\n"));
    }
    temp_profile("dex1-auto", name, &text)
}

#[test]
fn an_actuator_client_is_served_by_two_per_side_auto_fronts_as_one_pair() {
    let _serial = serial();
    let profile = per_side_profile("dex1-auto-pair", &["right", "left"]);
    let gw = Gateway::start(133, &["--profile", profile.to_str().unwrap()]);
    // The legacy controller through the SDK: different targets per element, so a swapped
    // order fails; it steps around each element's measured q.
    let (right, left) = (1.0, 4.0);
    let mut args = vec!["133".to_string(), right.to_string(), left.to_string()];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    let py = PyProcess::spawn("xr_actuator_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let d = done(&py, &gw);
    let q: Vec<f64> = d["q"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((q[0] - right).abs() < TOL && (q[1] - left).abs() < TOL, "{d}");
    // Each element came from its own gripper all along: the left one, near its target from
    // the start, never read as the other's (or an unbound) position.
    let min_left = d["min_q_seen"][1].as_f64().unwrap();
    assert!(min_left > left - 0.5, "left element read {min_left}: {d}");
    for side in ["right", "left"] {
        let added = format!("dex1 front dex1_{side} serves actuator clients too");
        assert_eq!(count_lines(&gw, &added), 1, "{}", gw.transcript());
    }
    // One writer of the pair's state (not one per front), both elements measured and fresh,
    // at the fronts' rate (500 Hz).
    let n = node(133);
    let mut state = Latest::<unitree_go::MotorStates_>::new(&n, "rt/unitree_actuator/state", Qos::BestEffort);
    state.next(DEADLINE).expect("pair state");
    assert_eq!(state.reader.matched(), 1, "writers of the pair's state");
    let s = state.last.clone().unwrap();
    assert_eq!(s.states.len(), 2, "{s:?}");
    for (i, e) in s.states.iter().enumerate() {
        assert_eq!((e.lost, e.reserve[1]), (0, 0), "element {i} measured and fresh: {s:?}");
    }
    // Counted as they arrive (a polled best-effort reader keeps only the newest).
    let count = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let c = count.clone();
    let _counter = n
        .reader_with_callback::<unitree_go::MotorStates_, _>("rt/unitree_actuator/state", Qos::BestEffort, move |h| {
            let mut v = Vec::new();
            h.take_into(&mut v);
            c.fetch_add(v.len() as u64, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
    poll(DEADLINE, || {
        (count.load(std::sync::atomic::Ordering::Relaxed) > 0).then_some(())
    })
    .expect("counted samples");
    // A measuring window, not a wait for readiness.
    let (before, t0) = (count.load(std::sync::atomic::Ordering::Relaxed), Instant::now());
    std::thread::sleep(Duration::from_secs(2));
    let got = count.load(std::sync::atomic::Ordering::Relaxed) - before;
    let hz = got as f64 / t0.elapsed().as_secs_f64();
    let r = handgate_tests::RateCheck {
        measured: hz,
        nominal: 500.0,
        tol: 0.1,
    };
    println!("pair state rate: {}", r.line());
    assert!(!r.fails(), "pair state {}", r.line());
}

#[test]
fn an_actuator_client_with_one_side_served_sees_the_other_element_unbound() {
    let _serial = serial();
    let profile = per_side_profile("dex1-auto-left", &["left"]);
    let gw = Gateway::start(134, &["--profile", profile.to_str().unwrap()]);
    let n = node(134);
    let mut w = n
        .writer::<unitree_go::MotorCmds_>("rt/unitree_actuator/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut state = Latest::<unitree_go::MotorStates_>::new(&n, "rt/unitree_actuator/state", Qos::BestEffort);
    // The front opens its reader of the pair once discovery shows this writer.
    w.wait_matched(1, DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let reached = stream_until(&mut w, &actuator_cmd(0.5, 2.0), DEADLINE, || {
        state
            .update()
            .is_some_and(|s| s.states.len() == 2 && (s.states[1].q - 2.0).abs() < TOL as f32)
    });
    assert!(reached, "state {:?}\n{}", state.last, gw.transcript());
    let s = state.last.clone().unwrap();
    // Element 0 (right) has no front: the open position, never measured, not commanded.
    assert!((s.states[0].q - 5.4).abs() < 1e-4, "{s:?}");
    assert_eq!((s.states[0].lost, s.states[0].reserve[1]), (0xFFFF_FFFE, 1), "{s:?}");
    assert_eq!((s.states[1].lost, s.states[1].reserve[1]), (0, 0), "{s:?}");
}

fn handgate(args: &[&str]) -> std::process::Output {
    let mut c = std::process::Command::new(handgate_bin());
    c.args(args).current_dir(repo_root());
    for (k, _) in std::env::vars() {
        if k.starts_with("HANDGATE_") {
            c.env_remove(k);
        }
    }
    c.output().expect("handgate runs")
}

#[test]
fn check_describes_auto_and_a_device_refuses_it() {
    let o = handgate(&["check", "default"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let line = out
        .lines()
        .find(|l| l.trim_start().starts_with("dex1_left ") && l.contains("rt/dex1/left/cmd"))
        .unwrap_or_else(|| panic!("no dex1_left front line:\n{out}"));
    assert!(line.contains("(auto: go until a client appears"), "{line}");
    // An explicit variant is described as before.
    let go = temp_profile(
        "dex1-auto",
        "explicit-go",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n[[fronts]]\nkind = \"dex1\"\ndevice = \"g\"\nvariant = \"go\"\n",
    );
    let o = handgate(&["check", go.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("at 500 Hz (go)"), "{out}");
    // `auto` is a front's: a device speaks one variant.
    let dev = temp_profile(
        "dex1-auto",
        "device-auto",
        "[[devices]]\nname = \"g\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"dds\"\n[devices.dds]\nvariant = \"auto\"\n",
    );
    let o = handgate(&["check", dev.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("devices[0].dds.variant"), "{err}");
}
