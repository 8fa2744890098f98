//! handgate's health in ROS 2's standard messages (docs/fronts.md, "Health messages"), read the
//! way a ROS 2 node reads them: CycloneDDS Python with its own declarations of
//! `diagnostic_msgs::msg::dds_::DiagnosticArray_` and `control_msgs::msg::dds_::HardwareStatus_`
//! (tests/python/health_peer.py, ROS 2's default QoS), against the real binary running
//! `profiles/g1-dex3.toml` on two emulated Dex3 services. Stopping one service turns that hand
//! from OK / up to ERROR / down in both messages while the other stays OK.
//!
//! Domains 128 and 43 (a device's own fault bit; docs/development.md; 233 and above are not
//! valid domain ids).

use std::time::Duration;

use handgate_adapters::ezgripper::driver::default_id;
use handgate_adapters::ezgripper::emulator::{EmulatorConfig, Fault, VirtualBus};
use handgate_adapters::model::Side;
use handgate_idl::ros2::{diagnostic_level as level, generic_state as gs};
use handgate_tests::{
    faulty_hand_service, hand_client_profile, health_peer, serial, stream_closure, temp_profile, Emulation, Gateway,
    PyProcess,
};
use serde_json::Value;

const DEADLINE: Duration = Duration::from_secs(30);
const DOMAIN: u32 = 128;

/// Reads the peer's lines until `want` holds for a `DIAG` and then for an `HW` sample (each
/// judged on its own lines); returns the two samples that satisfied it.
fn wait_for(
    py: &PyProcess,
    gw: &Gateway,
    what: &str,
    want_diag: impl Fn(&Value) -> bool,
    want_hw: impl Fn(&Value) -> bool,
) -> (Value, Value) {
    let (mut diag, mut hw) = (None, None);
    let until = std::time::Instant::now() + DEADLINE;
    let mut last = (Value::Null, Value::Null);
    while diag.is_none() || hw.is_none() {
        let left = until.saturating_duration_since(std::time::Instant::now());
        let line = py.wait_line("", left).unwrap_or_else(|e| {
            panic!(
                "{what}: {e}\nlast DIAG {:#}\nlast HW {:#}\n{}\n{}",
                last.0,
                last.1,
                py.transcript(),
                gw.transcript()
            )
        });
        if let Some(j) = line.strip_prefix("DIAG ") {
            let v: Value = serde_json::from_str(j).unwrap();
            if diag.is_none() && want_diag(&v) {
                diag = Some(v.clone());
            }
            last.0 = v;
        } else if let Some(j) = line.strip_prefix("HW ") {
            let v: Value = serde_json::from_str(j).unwrap();
            if hw.is_none() && want_hw(&v) {
                hw = Some(v.clone());
            }
            last.1 = v;
        }
    }
    (diag.unwrap(), hw.unwrap())
}

fn diag_of<'a>(d: &'a Value, device: &str) -> Option<&'a Value> {
    d["status"]
        .as_array()?
        .iter()
        .find(|s| s["name"] == format!("handgate: {device}"))
}

fn hw_of<'a>(h: &'a Value, device: &str) -> Option<&'a Value> {
    h["devices"].as_array()?.iter().find(|s| s["device_id"] == device)
}

#[test]
fn a_stopped_service_turns_its_hand_from_ok_to_error_in_both_messages() {
    let _g = serial();
    let d = DOMAIN.to_string();
    let left = Emulation::start(&["dex3", "--service", "--side", "left", "--domain", &d]);
    let _right = Emulation::start(&["dex3", "--service", "--side", "right", "--domain", &d]);
    let gw = Gateway::start(DOMAIN, &["--profile", "g1-dex3"]);
    let py = health_peer(DOMAIN);

    let ok = |name: &str| {
        let name = name.to_string();
        move |d: &Value| diag_of(d, &name).is_some_and(|s| s["level"] == level::OK)
    };
    let up = |name: &str| {
        let name = name.to_string();
        move |h: &Value| hw_of(h, &name).is_some_and(|s| s["connectivity"] == gs::CONNECT_UP)
    };
    let both = |a: &dyn Fn(&Value) -> bool, b: &dyn Fn(&Value) -> bool, v: &Value| a(v) && b(v);
    let (ok_l, ok_r, up_l, up_r) = (ok("left_hand"), ok("right_hand"), up("left_hand"), up("right_hand"));
    let (diag, hw) = wait_for(
        &py,
        &gw,
        "both hands OK and up",
        |v| both(&ok_l, &ok_r, v),
        |v| both(&up_l, &up_r, v),
    );
    let s = diag_of(&diag, "left_hand").unwrap();
    assert_eq!(s["message"], "ok", "{diag:#}");
    assert_eq!(s["hardware_id"], "left_hand", "{diag:#}");
    assert_eq!(s["values"]["freshness"], "fresh", "{diag:#}");
    assert_eq!(s["values"]["safe"], "false", "{diag:#}");
    for key in [
        "cmd_rate_hz",
        "state_rate_hz",
        "age_ms",
        "owner",
        "crc_errors",
        "watchdog_trips",
        "late_cmd",
    ] {
        assert!(s["values"].get(key).is_some(), "{key} in {diag:#}");
    }
    assert!(
        diag["stamp"][0].as_i64().unwrap() > 1_700_000_000,
        "wall-clock stamp: {diag:#}"
    );
    assert_eq!(hw["hardware_id"], "handgate", "{hw:#}");
    let h = hw_of(&hw, "left_hand").unwrap();
    assert_eq!(
        (h["health"].clone(), h["errors"].clone(), h["generic_states"].clone()),
        (
            Value::from(gs::HEALTH_OK),
            Value::from(vec![gs::ERROR_NONE]),
            Value::from(1)
        ),
        "{hw:#}"
    );
    assert_eq!(h["model"], "dex3", "{hw:#}");
    assert_eq!(
        (h["canopen"].as_u64(), h["ethercat"].as_u64(), h["vda5050"].as_u64()),
        (Some(0), Some(0), Some(0))
    );

    // The left hand's service goes away: its state stops.
    drop(left);
    let err_l = |d: &Value| diag_of(d, "left_hand").is_some_and(|s| s["level"] == level::ERROR);
    let down_l = |h: &Value| hw_of(h, "left_hand").is_some_and(|s| s["connectivity"] == gs::CONNECT_DOWN);
    let (diag, hw) = wait_for(&py, &gw, "the left hand ERROR and down", err_l, down_l);
    let s = diag_of(&diag, "left_hand").unwrap();
    assert!(
        s["message"].as_str().unwrap().starts_with("stale: no state for "),
        "{diag:#}"
    );
    assert_eq!(s["values"]["freshness"], "stale", "{diag:#}");
    assert_eq!(diag_of(&diag, "right_hand").unwrap()["level"], level::OK, "{diag:#}");
    let h = hw_of(&hw, "left_hand").unwrap();
    assert_eq!(
        (h["health"].clone(), h["errors"].clone()),
        (Value::from(gs::HEALTH_ERROR), Value::from(vec![gs::ERROR_HW])),
        "{hw:#}"
    );
    assert_eq!(
        hw_of(&hw, "right_hand").unwrap()["connectivity"],
        gs::CONNECT_UP,
        "{hw:#}"
    );
}

/// A Dex3 service emulated with its index finger stuck (`handgate emulate dex3 --service
/// --fault stuck=index_0`), commanded to close through a canonical front: the hand stays up
/// and fresh but both messages report the stuck joint (WARN / HEALTH_WARNING, `ERROR_HW`, the
/// joint named), within a few status periods of the command that should have moved it.
#[test]
fn a_stuck_joint_is_a_warning_naming_the_joint_in_both_messages() {
    let _g = serial();
    let _left = faulty_hand_service("dex3", DOMAIN, "stuck=index_0");
    let profile = hand_client_profile("health", "dex3");
    let gw = Gateway::start(DOMAIN, &["--profile", profile.to_str().unwrap()]);
    let py = health_peer(DOMAIN);
    let (diag, _) = wait_for(
        &py,
        &gw,
        "the hand OK and up before any command",
        |v| diag_of(v, "hand").is_some_and(|s| s["level"] == level::OK),
        |v| hw_of(v, "hand").is_some_and(|s| s["connectivity"] == gs::CONNECT_UP),
    );
    assert_eq!(diag_of(&diag, "hand").unwrap()["values"]["motion"], "ok", "{diag:#}");

    // Close the hand at 50 Hz (the canonical front's watchdog holds it after 200 ms of
    // silence) until the reports are in.
    let (stop, streaming) = stream_closure(DOMAIN, "hand", 0.8);
    let warn = |v: &Value| diag_of(v, "hand").is_some_and(|s| s["level"] == level::WARN);
    let warning = |v: &Value| hw_of(v, "hand").is_some_and(|s| s["health"] == gs::HEALTH_WARNING);
    let (diag, hw) = wait_for(&py, &gw, "the stuck joint reported", warn, warning);
    let reported = std::time::Instant::now();
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    // Both samples read by the peer: an upper bound on the time from the first command that
    // should have moved the hand to the report (the bound: a second).
    let first = streaming.join().unwrap().expect("a command was written");
    let took = reported.duration_since(first);
    println!(
        "stuck joint in /diagnostics and hardware_status {} ms after the first command",
        took.as_millis()
    );
    assert!(took < Duration::from_secs(1), "reported after {took:?}: {diag:#}");

    let s = diag_of(&diag, "hand").unwrap();
    assert_eq!(s["values"]["motion"], "joint_stuck", "{diag:#}");
    assert_eq!(s["values"]["motion_joint"], "index_0", "{diag:#}");
    assert_eq!(s["values"]["freshness"], "fresh", "{diag:#}");
    assert!(
        s["message"].as_str().unwrap().contains("joint index_0 does not follow"),
        "{diag:#}"
    );
    let h = hw_of(&hw, "hand").unwrap();
    assert_eq!(
        (h["connectivity"].clone(), h["errors"].clone()),
        (Value::from(gs::CONNECT_UP), Value::from(vec![gs::ERROR_HW])),
        "{hw:#}"
    );
    assert_eq!(h["details"]["motion_joint"], "index_0", "{hw:#}");
}

/// A device's own fault bit (`HandState.faults`, judged by the gateway's health mapping) in
/// both messages: an EZGripper whose servo trips its overload protection. The MX-64 bus is
/// emulated in this process behind a pty (`VirtualBus`), the gateway drives it on backend
/// serial; `inject(Fault::Overload)` latches the servo's Hardware Error Status (torque off,
/// the alert bit on every status until a reboot), the driver reads it and the device reports
/// fault `hardware`. The gripper, still up and fresh, turns ERROR / HEALTH_ERROR with
/// `ERROR_HW`, the fault named in the message and in the values.
#[test]
fn a_device_fault_bit_is_an_error_naming_the_fault_in_both_messages() {
    let _g = serial();
    let domain = 43;
    let pty = std::env::temp_dir().join(format!("handgate-health-{}-ezgripper", std::process::id()));
    let id = default_id(Side::Left).get();
    let bus = VirtualBus::start(&pty, EmulatorConfig::with_ids(&[id])).expect("the emulated bus starts");
    let profile = temp_profile(
        "health",
        "ezgripper-overload",
        &format!(
            "name = \"ezgripper-overload\"\n[status]\nrate_hz = 10\n\
             [[devices]]\nname = \"gripper\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"serial\"\n\
             [devices.ezgripper]\nport = \"{}\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"gripper\"\n",
            pty.display()
        ),
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let py = health_peer(domain);
    let (diag, _) = wait_for(
        &py,
        &gw,
        "the gripper OK and up before the fault",
        |v| diag_of(v, "gripper").is_some_and(|s| s["level"] == level::OK),
        |v| hw_of(v, "gripper").is_some_and(|s| s["connectivity"] == gs::CONNECT_UP),
    );
    assert_eq!(diag_of(&diag, "gripper").unwrap()["values"]["faults"], "", "{diag:#}");

    bus.inject(Fault::Overload { id });
    let err = |v: &Value| diag_of(v, "gripper").is_some_and(|s| s["level"] == level::ERROR);
    let error = |v: &Value| hw_of(v, "gripper").is_some_and(|s| s["health"] == gs::HEALTH_ERROR);
    let (diag, hw) = wait_for(&py, &gw, "the overload reported", err, error);
    let s = diag_of(&diag, "gripper").unwrap();
    assert!(s["message"].as_str().unwrap().contains("fault: hardware"), "{diag:#}");
    assert_eq!(s["values"]["faults"], "hardware", "{diag:#}");
    assert_eq!(
        s["values"]["freshness"], "fresh",
        "a fault, not a lost device: {diag:#}"
    );
    let h = hw_of(&hw, "gripper").unwrap();
    assert_eq!(
        (h["connectivity"].clone(), h["errors"].clone()),
        (Value::from(gs::CONNECT_UP), Value::from(vec![gs::ERROR_HW])),
        "{hw:#}"
    );
    assert_eq!(h["details"]["faults"], "hardware", "{hw:#}");
}
