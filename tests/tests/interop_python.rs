//! Live interop with the official Python SDK (unitree_sdk2py 1.0.1 on CycloneDDS 0.10.2) over
//! real DDS, both directions, for the four messages handgate exchanges with Unitree systems:
//! HandCmd_ and HandState_ (Dex3-1, unitree_hg) and MotorCmds_ / MotorStates_ (Dex1-1, the
//! EZGripper driver and rt/hand_sdk, unitree_go).
//!
//! * Rust -> Python: `tests/python/interop_sub.py` subscribes through `ChannelSubscriber` and
//!   prints READY; the Rust writer (handgate_adapters::dds) waits for the match, then writes
//!   until the script prints the sample it received as JSON, which must equal what Rust sent.
//! * Python -> Rust: `tests/python/interop_pub.py` publishes a fixture's value through
//!   `ChannelPublisher`; the Rust reader must receive exactly that value.
//!
//! Values come from the golden fixtures (tests/fixtures/golden), so both sides build them from
//! the same JSON. Each test has its own DDS domain (10..29, see docs/development.md), so the
//! tests run in parallel. Every wait is on readiness with a deadline; nothing sleeps blindly.
//! Needs `.venv` (scripts/setup.sh); without it the tests fail with that instruction.
//! `HANDGATE_INTEROP_IFACE=lo` pins both sides to one network interface.
//!
//! The Inspire FTP hand's `inspire::inspire_hand_ctrl` / `inspire_hand_state` go the same way
//! (domains 200..203): the Python side is unitree_sdk2py's ChannelPublisher/Subscriber with the
//! classes `idlc -l py` generated from idl/inspire.idl, as the Inspire driver and
//! xr_teleoperate's FTP controller use them.

use std::fmt::Debug;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::{inspire, to_cdr_le, unitree_go, unitree_hg, TopicType};
use handgate_tests::{fixture, from_plain_json, interop_interface, FromPlain, PyError, PyProcess};
use serde::Serialize;

/// Upper bound for any single readiness wait (Python start-up + DDS discovery).
const DEADLINE: Duration = Duration::from_secs(45);
/// How long the writer waits for the subscriber's report before writing again.
const REPORT_POLL: Duration = Duration::from_millis(20);

/// Equality that also holds for NaN payloads: compare the little-endian encodings.
fn assert_same<T: Serialize + PartialEq + Debug>(got: &T, want: &T, what: &str) {
    let (g, w) = (to_cdr_le(got).unwrap(), to_cdr_le(want).unwrap());
    if g != w {
        assert_eq!(got, want, "{what}");
        panic!("{what}: values equal but bits differ");
    }
}

fn split_key(key: &str) -> (&str, &str) {
    key.split_once('/').expect("key is module/Type")
}

fn base_args(domain: u32, topic: &str, key: &str) -> Vec<String> {
    let mut args = vec![
        "--domain".into(),
        domain.to_string(),
        "--topic".into(),
        topic.into(),
        "--type".into(),
        key.into(),
        "--timeout".into(),
        "60".into(),
    ];
    if let Some(iface) = interop_interface() {
        args.extend(["--interface".to_string(), iface]);
    }
    args
}

fn node(domain: u32) -> Node {
    Node::new(domain, interop_interface().as_deref()).expect("DDS participant")
}

/// Rust writer -> unitree_sdk2py ChannelSubscriber.
fn rust_to_python<T>(domain: u32, topic: &str, key: &str, case: &str)
where
    T: FromPlain + TopicType + Serialize + Clone + PartialEq + Debug,
{
    let (module, ty) = split_key(key);
    let value: T = fixture(module, ty, case).unwrap().value_as().unwrap();

    let py = PyProcess::spawn("interop_sub.py", &base_args(domain, topic, key)).unwrap();
    py.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));

    let node = node(domain);
    let mut w = node.writer::<T>(topic, Qos::Reliable { depth: 10 }).unwrap();
    w.wait_matched(1, DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));

    let deadline = Instant::now() + DEADLINE;
    let line = loop {
        w.write(value.clone()).unwrap();
        match py.wait_line("SAMPLE ", REPORT_POLL) {
            Ok(line) => break line,
            Err(PyError::Timeout { .. }) if Instant::now() < deadline => continue,
            Err(e) => panic!("{key}: Python never reported a sample: {e}"),
        }
    };
    let got: T = from_plain_json(&line).unwrap_or_else(|e| panic!("{key}: {e}\nline: {line}"));
    assert_same(&got, &value, &format!("{key} {case}: what unitree_sdk2py received"));
}

/// unitree_sdk2py ChannelPublisher -> Rust reader.
fn python_to_rust<T>(domain: u32, topic: &str, key: &str, case: &str)
where
    T: FromPlain + TopicType + Serialize + Clone + PartialEq + Debug,
{
    let (module, ty) = split_key(key);
    let fx = fixture(module, ty, case).unwrap();
    let value: T = fx.value_as().unwrap();

    let node = node(domain);
    let r = node.reader::<T>(topic, Qos::Reliable { depth: 10 }).unwrap();

    let mut args = base_args(domain, topic, key);
    args.extend(["--fixture".to_string(), fx.path.display().to_string()]);
    let py = PyProcess::spawn("interop_pub.py", &args).unwrap();
    let sent = py.wait_line("SENT ", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    let sent: T = from_plain_json(&sent).unwrap();
    assert_same(&sent, &value, &format!("{key} {case}: what the SDK object holds"));
    py.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));

    r.wait_matched(1, DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    let got = r
        .wait_take(DEADLINE)
        .unwrap_or_else(|e| panic!("{key}: no sample from Python: {e}\n{}", py.transcript()));
    for sample in &got {
        assert_same(sample, &value, &format!("{key} {case}: what the Rust reader received"));
    }
}

const HAND_CMD: (&str, &str) = ("rt/dex3/left/cmd", "unitree_hg/HandCmd_");
const HAND_STATE: (&str, &str) = ("rt/dex3/left/state", "unitree_hg/HandState_");
const MOTOR_CMDS: (&str, &str) = ("rt/dex1/left/cmd", "unitree_go/MotorCmds_");
const MOTOR_STATES: (&str, &str) = ("rt/dex1/left/state", "unitree_go/MotorStates_");

// Typical values: 7 Dex3-1 motors with RIS mode bytes; HandState_ with 9 pressure pads and IMU.

#[test]
fn hand_cmd_rust_to_python() {
    rust_to_python::<unitree_hg::HandCmd_>(10, HAND_CMD.0, HAND_CMD.1, "typical");
}

#[test]
fn hand_cmd_python_to_rust() {
    python_to_rust::<unitree_hg::HandCmd_>(11, HAND_CMD.0, HAND_CMD.1, "typical");
}

#[test]
fn hand_state_rust_to_python() {
    rust_to_python::<unitree_hg::HandState_>(12, HAND_STATE.0, HAND_STATE.1, "typical");
}

#[test]
fn hand_state_python_to_rust() {
    python_to_rust::<unitree_hg::HandState_>(13, HAND_STATE.0, HAND_STATE.1, "typical");
}

#[test]
fn motor_cmds_rust_to_python() {
    rust_to_python::<unitree_go::MotorCmds_>(14, MOTOR_CMDS.0, MOTOR_CMDS.1, "typical");
}

#[test]
fn motor_cmds_python_to_rust() {
    python_to_rust::<unitree_go::MotorCmds_>(15, MOTOR_CMDS.0, MOTOR_CMDS.1, "typical");
}

#[test]
fn motor_states_rust_to_python() {
    rust_to_python::<unitree_go::MotorStates_>(16, MOTOR_STATES.0, MOTOR_STATES.1, "typical");
}

#[test]
fn motor_states_python_to_rust() {
    python_to_rust::<unitree_go::MotorStates_>(17, MOTOR_STATES.0, MOTOR_STATES.1, "typical");
}

// Extreme values over the wire: 32-element sequences, f32 max/subnormal/-0.0/inf, u32 max,
// i16 min/max, u8 255.

#[test]
fn hand_cmd_extreme_rust_to_python() {
    rust_to_python::<unitree_hg::HandCmd_>(18, HAND_CMD.0, HAND_CMD.1, "extreme");
}

#[test]
fn hand_cmd_extreme_python_to_rust() {
    python_to_rust::<unitree_hg::HandCmd_>(19, HAND_CMD.0, HAND_CMD.1, "extreme");
}

#[test]
fn hand_state_extreme_rust_to_python() {
    rust_to_python::<unitree_hg::HandState_>(20, HAND_STATE.0, HAND_STATE.1, "extreme");
}

#[test]
fn hand_state_extreme_python_to_rust() {
    python_to_rust::<unitree_hg::HandState_>(21, HAND_STATE.0, HAND_STATE.1, "extreme");
}

#[test]
fn motor_cmds_extreme_rust_to_python() {
    rust_to_python::<unitree_go::MotorCmds_>(22, MOTOR_CMDS.0, MOTOR_CMDS.1, "extreme");
}

#[test]
fn motor_cmds_extreme_python_to_rust() {
    python_to_rust::<unitree_go::MotorCmds_>(23, MOTOR_CMDS.0, MOTOR_CMDS.1, "extreme");
}

#[test]
fn motor_states_extreme_rust_to_python() {
    rust_to_python::<unitree_go::MotorStates_>(24, MOTOR_STATES.0, MOTOR_STATES.1, "extreme");
}

#[test]
fn motor_states_extreme_python_to_rust() {
    python_to_rust::<unitree_go::MotorStates_>(25, MOTOR_STATES.0, MOTOR_STATES.1, "extreme");
}

// Inspire FTP (its own IDL, module `inspire`): typical values, right hand.

const INSPIRE_CTRL: (&str, &str) = ("rt/inspire_hand/ctrl/r", "inspire/inspire_hand_ctrl");
const INSPIRE_STATE: (&str, &str) = ("rt/inspire_hand/state/r", "inspire/inspire_hand_state");

#[test]
fn inspire_ctrl_python_to_rust() {
    python_to_rust::<inspire::InspireHandCtrl>(200, INSPIRE_CTRL.0, INSPIRE_CTRL.1, "typical");
}

#[test]
fn inspire_ctrl_rust_to_python() {
    rust_to_python::<inspire::InspireHandCtrl>(201, INSPIRE_CTRL.0, INSPIRE_CTRL.1, "typical");
}

#[test]
fn inspire_state_python_to_rust() {
    python_to_rust::<inspire::InspireHandState>(202, INSPIRE_STATE.0, INSPIRE_STATE.1, "typical");
}

#[test]
fn inspire_state_rust_to_python() {
    rust_to_python::<inspire::InspireHandState>(203, INSPIRE_STATE.0, INSPIRE_STATE.1, "typical");
}
