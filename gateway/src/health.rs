//! The gateway's health in ROS 2's standard messages (docs/fronts.md, "Health messages"):
//! `diagnostic_msgs/msg/DiagnosticArray` on `/diagnostics` and `control_msgs/msg/HardwareStatus`
//! on `<namespace>/hardware_status`, both built from the status snapshot
//! ([`hg::GatewayStatus_`], the one home of the per-device facts).
//!
//! [`judge`] is the one mapping from a device's status to a verdict (diagnostic level, health,
//! connectivity, operational mode, error domains, a sentence); both messages are renderings of
//! it. It is pure: the runtime's health task only moves its results onto DDS.

use std::collections::HashMap;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::ros2::{
    diagnostic_level as level, generic_state as gs, DiagnosticArray_, DiagnosticStatus_, GenericHardwareState_,
    HardwareDeviceStatus_, HardwareStatus_, Header_, KeyValue_, Time_,
};

use crate::plan::Plan;

/// Both writers' QoS: ROS 2's default (reliable, volatile, keep last 10), as
/// `diagnostic_updater` publishes `/diagnostics`.
pub const QOS: Qos = Qos::Reliable { depth: 10 };

/// The health messages' DDS topics and types, when `plan` publishes them (`[dds] ros_node`):
/// `/diagnostics` (global) and `hardware_status` in handgate's namespace.
pub fn topics(plan: &Plan) -> Vec<(String, &'static str)> {
    use handgate_idl::DdsTypeName;
    if !published(plan) {
        return Vec::new();
    }
    vec![
        (
            handgate_idl::ros2::DIAGNOSTICS_TOPIC.to_string(),
            DiagnosticArray_::DDS_TYPE_NAME,
        ),
        (hardware_status_topic(plan), HardwareStatus_::DDS_TYPE_NAME),
    ]
}

/// Whether `plan`'s gateway publishes the health messages: they are part of its ROS presence,
/// on with the ROS node (`[dds] ros_node`).
pub fn published(plan: &Plan) -> bool {
    plan.namespace.is_some()
}

/// The DDS topic of `hardware_status`: `rt/hardware_status` in handgate's namespace.
pub fn hardware_status_topic(plan: &Plan) -> String {
    plan.own_namespace.topic(handgate_idl::ros2::HARDWARE_STATUS_TOPIC)
}

/// A fresh device counts as slow below this many state samples per `stale_after` window on
/// average over one status period: one more missed sample and it would be stale.
pub const SLOW_SAMPLES_PER_STALE_WINDOW: f32 = 2.0;

/// One device's health, as both messages report it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verdict {
    /// `diagnostic_msgs/DiagnosticStatus` level ([`level`]).
    pub level: u8,
    /// `GenericHardwareState.health_status` (`HEALTH_*`).
    pub health: u8,
    /// `GenericHardwareState.connectivity_status` (`CONNECT_*`, `CONNECTION_SLOW`).
    pub connectivity: u8,
    /// `GenericHardwareState.operational_mode` (`MODE_SAFE` or `MODE_AUTO`).
    pub mode: u8,
    /// `GenericHardwareState.error_domain` (`[ERROR_NONE]` when nothing is wrong).
    pub errors: Vec<u8>,
    /// What is wrong, in words (`ok` when nothing is).
    pub message: String,
}

/// One thing found wrong with a device: how bad, in which words.
struct Finding {
    level: u8,
    health: u8,
    error: u8,
    text: String,
}

/// The verdict on device `d`, whose state counts as stale after `stale_after`.
///
/// | fact | level | health | connectivity | error domain |
/// |---|---|---|---|---|
/// | fresh, state rate measured at or above `2 / stale_after` (or not measured yet) | OK | OK | UP | NONE |
/// | fresh, state rate below `2 / stale_after` | WARN | DEGRADED | CONNECTION_SLOW | NONE |
/// | commanded only (the device has no state to judge) | OK | OK | UNKNOWN | NONE |
/// | stale after a state was seen | ERROR | ERROR | DOWN | HW |
/// | stale, no state ever | STALE | UNKNOWN | DOWN | UNKNOWN |
/// | `safe` (a silence action or the device's safe state holds it) | at least WARN | at least WARNING | (as above) | + PROTECTIVE_STOP_SW |
/// | the device reports a motor error, a hardware fault or its link down (`faults`) | ERROR | ERROR | (as above) | + HW |
/// | the device reports a motor's command timeout or CRC failures (`faults`) | at least WARN | at least WARNING | (as above) | + HW |
/// | motion `joint_stuck` (one joint does not follow while the others do) | at least WARN | at least WARNING | (as above) | + HW |
/// | motion `frozen` or `not_following` (the hand reports but does not move) | ERROR | ERROR | (as above) | + HW |
/// | motion `holding` (stopped closing in contact: an object) | OK | OK | (as above) | NONE |
///
/// `safe` sets the mode to `MODE_SAFE` (else `MODE_AUTO`: the gateway drives the device). The
/// levels of several findings combine by their maximum, the texts are joined. A new fact about
/// a device is one more `findings.push(..)` below, with its level, health and error domain.
pub fn judge(d: &hg::DeviceStatus_, stale_after: Duration) -> Verdict {
    let mut findings: Vec<Finding> = Vec::new();
    let min_state_hz = SLOW_SAMPLES_PER_STALE_WINDOW / stale_after.as_secs_f32().max(1e-3);
    let connectivity = match d.freshness {
        hg::FRESH if d.state_rate_hz > 0.0 && d.state_rate_hz < min_state_hz => {
            findings.push(Finding {
                level: level::WARN,
                health: gs::HEALTH_DEGRADED,
                error: gs::ERROR_NONE,
                text: format!("slow: state at {:.1} Hz, below {min_state_hz:.1} Hz", d.state_rate_hz),
            });
            gs::CONNECTION_SLOW
        }
        // A rate of 0 while fresh is the first status period (nothing measured yet).
        hg::FRESH => gs::CONNECT_UP,
        hg::COMMANDED_ONLY => gs::CONNECT_UNKNOWN,
        _ => {
            findings.push(if d.age_ms.is_finite() {
                Finding {
                    level: level::ERROR,
                    health: gs::HEALTH_ERROR,
                    error: gs::ERROR_HW,
                    text: format!("stale: no state for {:.0} ms", d.age_ms),
                }
            } else {
                Finding {
                    level: level::STALE,
                    health: gs::HEALTH_UNKNOWN,
                    error: gs::ERROR_UNKNOWN,
                    text: "stale: no state yet".into(),
                }
            });
            gs::CONNECT_DOWN
        }
    };
    if d.safe {
        findings.push(Finding {
            level: level::WARN,
            health: gs::HEALTH_WARNING,
            error: gs::PROTECTIVE_STOP_SW,
            text: "safe state".into(),
        });
    }
    // The device's own fault bits (the safe state is `safe`, above): a motor error, a hardware
    // fault or a link down is an error; a motor's command timeout or CRC failures a warning.
    use handgate_adapters::model::faults as f;
    let bits = d.faults & !f::SAFE_STATE;
    if bits != 0 {
        let error = bits & (f::MOTOR_ERROR | f::HARDWARE | f::LINK_DOWN) != 0;
        findings.push(Finding {
            level: if error { level::ERROR } else { level::WARN },
            health: if error { gs::HEALTH_ERROR } else { gs::HEALTH_WARNING },
            error: gs::ERROR_HW,
            text: format!("fault: {}", f::names(bits).join(", ")),
        });
    }
    // The motion verdict (docs/adapters.md, "Motion"): one joint that does not follow while
    // the others do leaves a working hand (WARN); a hand whose state repeats or that follows
    // no command does not work (ERROR).
    match d.motion {
        // Holding an object (stopped closing in contact) is what a hand is for: OK, said in
        // the key/values (`motion: holding`).
        hg::MOTION_OK | hg::MOTION_HOLDING => {}
        m => findings.push(Finding {
            level: if m == hg::MOTION_JOINT_STUCK {
                level::WARN
            } else {
                level::ERROR
            },
            health: if m == hg::MOTION_JOINT_STUCK {
                gs::HEALTH_WARNING
            } else {
                gs::HEALTH_ERROR
            },
            error: gs::ERROR_HW,
            text: crate::tools::motion_sentence(d),
        }),
    }
    let mut errors: Vec<u8> = findings
        .iter()
        .map(|f| f.error)
        .filter(|e| *e != gs::ERROR_NONE)
        .collect();
    errors.sort_unstable();
    errors.dedup();
    if errors.is_empty() {
        errors.push(gs::ERROR_NONE);
    }
    Verdict {
        level: findings.iter().map(|f| f.level).max().unwrap_or(level::OK),
        health: findings.iter().map(|f| f.health).max().unwrap_or(gs::HEALTH_OK),
        connectivity,
        mode: if d.safe { gs::MODE_SAFE } else { gs::MODE_AUTO },
        errors,
        message: if findings.is_empty() {
            "ok".into()
        } else {
            findings.iter().map(|f| f.text.as_str()).collect::<Vec<_>>().join("; ")
        },
    }
}

/// A device's status as key/values (both messages carry the same ones).
pub fn values(d: &hg::DeviceStatus_) -> Vec<KeyValue_> {
    let kv = |k: &str, v: String| KeyValue_ {
        key: k.into(),
        value: v,
    };
    let freshness = match d.freshness {
        hg::FRESH => "fresh",
        hg::COMMANDED_ONLY => "commanded-only",
        _ => "stale",
    };
    let age = if d.age_ms.is_finite() {
        format!("{:.0}", d.age_ms)
    } else {
        "none".into()
    };
    vec![
        kv("freshness", freshness.into()),
        kv("safe", d.safe.to_string()),
        kv("kind", d.kind.clone()),
        kv("backend", d.backend.clone()),
        kv("cmd_rate_hz", format!("{:.1}", d.cmd_rate_hz)),
        kv("state_rate_hz", format!("{:.1}", d.state_rate_hz)),
        kv("age_ms", age),
        kv("owner", d.owner.clone()),
        kv("crc_errors", d.crc_errors.to_string()),
        kv("bad_input", d.bad_input.to_string()),
        kv("watchdog_trips", d.watchdog_trips.to_string()),
        kv("reconnects", d.reconnects.to_string()),
        kv("missed_cycles", d.missed_cycles.to_string()),
        kv("foreign_cmd", d.foreign_cmd.to_string()),
        kv("duplicate_cmd", d.duplicate_cmd.to_string()),
        kv("reordered_cmd", d.reordered_cmd.to_string()),
        kv("late_cmd", d.late_cmd.to_string()),
        kv("not_allowed_cmd", d.not_allowed_cmd.to_string()),
        kv("faults", handgate_adapters::model::faults::names(d.faults).join(",")),
        kv("motion", handgate_adapters::motion::Verdict::word(d.motion).to_string()),
        kv("motion_joint", d.motion_joint.clone()),
        kv(
            "tracking_error_rad",
            if d.tracking_error.is_finite() {
                format!("{:.3}", d.tracking_error)
            } else {
                "none".into()
            },
        ),
    ]
}

/// What the health messages need from the plan, decided once at start-up.
#[derive(Debug, Clone, PartialEq)]
pub struct HealthMessages {
    /// The node's name without its leading `/` (`handgate`, `robot1/handgate`):
    /// `HardwareStatus.hardware_id` and the prefix of each diagnostic's name.
    pub hardware_id: String,
    /// Each device's `stale_after` (a device the plan does not name, which the status task
    /// never reports, would get the default).
    stale_after: HashMap<String, Duration>,
}

impl HealthMessages {
    pub fn new(plan: &Plan) -> Self {
        let ns = plan.own_namespace.ros();
        let hardware_id = format!("{}/{}", ns.trim_matches('/'), handgate_adapters::ros::NODE_NAME)
            .trim_start_matches('/')
            .to_string();
        Self {
            hardware_id,
            stale_after: plan.devices.iter().map(|d| (d.name.clone(), d.stale_after)).collect(),
        }
    }

    fn verdict(&self, d: &hg::DeviceStatus_) -> Verdict {
        judge(
            d,
            self.stale_after
                .get(&d.device)
                .copied()
                .unwrap_or(crate::resolve::DEFAULT_STALE_AFTER),
        )
    }

    /// Both messages of one status snapshot, each device judged once: `/diagnostics` (one
    /// status per device, named `<hardware_id>: <device>`) and `<namespace>/hardware_status`
    /// (the gateway as one hardware component, one device status per device).
    pub fn messages(&self, s: &hg::GatewayStatus_, stamp: Time_) -> (DiagnosticArray_, HardwareStatus_) {
        let mut diagnostics = DiagnosticArray_ {
            header: header(stamp),
            status: Vec::with_capacity(s.devices.len()),
        };
        let mut hardware = HardwareStatus_ {
            header: header(stamp),
            hardware_id: self.hardware_id.clone(),
            hardware_device_states: Vec::with_capacity(s.devices.len()),
        };
        for d in &s.devices {
            let v = self.verdict(d);
            let values = values(d);
            hardware.hardware_device_states.push(HardwareDeviceStatus_ {
                header: header(stamp),
                device_id: d.device.clone(),
                hardware_status: vec![GenericHardwareState_ {
                    health_status: v.health,
                    error_domain: v.errors,
                    operational_mode: v.mode,
                    power_state: gs::POWER_UNKNOWN,
                    connectivity_status: v.connectivity,
                    manufacturer: String::new(),
                    model: d.kind.clone(),
                    firmware_version: String::new(),
                    state_details: values.clone(),
                }],
                ..Default::default()
            });
            diagnostics.status.push(DiagnosticStatus_ {
                level: v.level,
                name: format!("{}: {}", self.hardware_id, d.device),
                message: v.message,
                hardware_id: d.device.clone(),
                values,
            });
        }
        (diagnostics, hardware)
    }
}

fn header(stamp: Time_) -> Header_ {
    Header_ {
        stamp,
        frame_id: String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WINDOW: Duration = Duration::from_millis(200);

    fn dev(freshness: u8, state_hz: f32, age_ms: f32, safe: bool) -> hg::DeviceStatus_ {
        hg::DeviceStatus_ {
            device: "left".into(),
            kind: "dex3".into(),
            freshness,
            state_rate_hz: state_hz,
            age_ms,
            safe,
            ..Default::default()
        }
    }

    #[test]
    fn a_fresh_device_at_rate_is_ok_and_up() {
        let v = judge(&dev(hg::FRESH, 100.0, 3.0, false), WINDOW);
        assert_eq!(
            v,
            Verdict {
                level: level::OK,
                health: gs::HEALTH_OK,
                connectivity: gs::CONNECT_UP,
                mode: gs::MODE_AUTO,
                errors: vec![gs::ERROR_NONE],
                message: "ok".into(),
            }
        );
        // Not measured yet (the first status period): no verdict on the rate.
        assert_eq!(
            judge(&dev(hg::FRESH, 0.0, 3.0, false), WINDOW).connectivity,
            gs::CONNECT_UP
        );
    }

    #[test]
    fn the_devices_own_faults_are_errors_or_warnings_and_named() {
        use handgate_adapters::model::faults as f;
        let faulty = |faults: u32| hg::DeviceStatus_ {
            faults,
            ..dev(hg::FRESH, 100.0, 3.0, false)
        };
        for bits in [f::MOTOR_ERROR, f::HARDWARE, f::LINK_DOWN] {
            let v = judge(&faulty(bits), WINDOW);
            assert_eq!(
                (v.level, v.health, v.errors),
                (level::ERROR, gs::HEALTH_ERROR, vec![gs::ERROR_HW])
            );
        }
        let v = judge(&faulty(f::MOTOR_TIMEOUT | f::CRC), WINDOW);
        assert_eq!((v.level, v.health), (level::WARN, gs::HEALTH_WARNING));
        assert_eq!(v.message, "fault: motor_timeout, crc");
        // The safe state bit is `safe`'s: no second finding.
        assert_eq!(judge(&faulty(f::SAFE_STATE), WINDOW).level, level::OK);
        let kv = values(&faulty(f::HARDWARE | f::SAFE_STATE));
        assert_eq!(
            kv.iter().find(|x| x.key == "faults").map(|x| x.value.as_str()),
            Some("hardware,safe_state")
        );
        // A stale device with a hardware fault: one error, both domains once.
        let v = judge(
            &hg::DeviceStatus_ {
                faults: f::HARDWARE,
                ..dev(hg::STALE, 0.0, 900.0, true)
            },
            WINDOW,
        );
        assert_eq!(v.level, level::ERROR);
        assert_eq!(v.errors, vec![gs::ERROR_HW, gs::PROTECTIVE_STOP_SW]);
    }

    #[test]
    fn a_stuck_joint_warns_and_a_hand_that_does_not_move_is_an_error() {
        let moving = |motion: u8| hg::DeviceStatus_ {
            motion,
            motion_joint: "index_0".into(),
            tracking_error: 0.4,
            ..dev(hg::FRESH, 100.0, 3.0, false)
        };
        let v = judge(&moving(hg::MOTION_JOINT_STUCK), WINDOW);
        assert_eq!(
            (v.level, v.health, v.connectivity, v.errors),
            (level::WARN, gs::HEALTH_WARNING, gs::CONNECT_UP, vec![gs::ERROR_HW])
        );
        assert!(v.message.contains("joint index_0 does not follow"), "{}", v.message);
        for m in [hg::MOTION_FROZEN, hg::MOTION_NOT_FOLLOWING] {
            let v = judge(&moving(m), WINDOW);
            assert_eq!(
                (v.level, v.health, v.errors),
                (level::ERROR, gs::HEALTH_ERROR, vec![gs::ERROR_HW])
            );
            assert!(v.message.contains("index_0"), "{}", v.message);
        }
        let kv = values(&moving(hg::MOTION_JOINT_STUCK));
        let get = |k: &str| kv.iter().find(|x| x.key == k).map(|x| x.value.clone());
        assert_eq!(get("motion").as_deref(), Some("joint_stuck"));
        assert_eq!(get("motion_joint").as_deref(), Some("index_0"));
        assert_eq!(get("tracking_error_rad").as_deref(), Some("0.400"));
    }

    #[test]
    fn a_fresh_device_below_two_samples_per_stale_window_is_slow() {
        // 200 ms window: 10 Hz is the limit.
        let v = judge(&dev(hg::FRESH, 9.0, 150.0, false), WINDOW);
        assert_eq!(
            (v.level, v.health, v.connectivity),
            (level::WARN, gs::HEALTH_DEGRADED, gs::CONNECTION_SLOW)
        );
        assert!(
            v.message.starts_with("slow: state at 9.0 Hz, below 10.0 Hz"),
            "{}",
            v.message
        );
        assert_eq!(
            judge(&dev(hg::FRESH, 10.0, 50.0, false), WINDOW).connectivity,
            gs::CONNECT_UP
        );
    }

    #[test]
    fn a_stale_device_is_an_error_and_down_or_stale_before_any_state() {
        let v = judge(&dev(hg::STALE, 0.0, 812.0, false), WINDOW);
        assert_eq!(
            (v.level, v.health, v.connectivity, v.errors.clone()),
            (level::ERROR, gs::HEALTH_ERROR, gs::CONNECT_DOWN, vec![gs::ERROR_HW])
        );
        assert_eq!(v.message, "stale: no state for 812 ms");
        let never = judge(&dev(hg::STALE, 0.0, f32::NAN, false), WINDOW);
        assert_eq!(
            (never.level, never.health, never.connectivity, never.errors),
            (
                level::STALE,
                gs::HEALTH_UNKNOWN,
                gs::CONNECT_DOWN,
                vec![gs::ERROR_UNKNOWN]
            )
        );
    }

    #[test]
    fn safe_is_mode_safe_and_at_least_a_warning() {
        let v = judge(&dev(hg::FRESH, 100.0, 3.0, true), WINDOW);
        assert_eq!(
            (v.level, v.health, v.mode, v.errors.clone()),
            (
                level::WARN,
                gs::HEALTH_WARNING,
                gs::MODE_SAFE,
                vec![gs::PROTECTIVE_STOP_SW]
            )
        );
        // Combined with a stale state, the worse level wins and both are said.
        let v = judge(&dev(hg::STALE, 0.0, 900.0, true), WINDOW);
        assert_eq!(
            (v.level, v.health, v.mode),
            (level::ERROR, gs::HEALTH_ERROR, gs::MODE_SAFE)
        );
        assert_eq!(v.errors, vec![gs::ERROR_HW, gs::PROTECTIVE_STOP_SW]);
        assert_eq!(v.message, "stale: no state for 900 ms; safe state");
    }

    #[test]
    fn commanded_only_is_ok_with_unknown_connectivity() {
        let v = judge(&dev(hg::COMMANDED_ONLY, 0.0, f32::NAN, false), WINDOW);
        assert_eq!((v.level, v.connectivity), (level::OK, gs::CONNECT_UNKNOWN));
        assert_eq!(
            values(&dev(hg::COMMANDED_ONLY, 0.0, f32::NAN, false))[0].value,
            "commanded-only"
        );
    }

    #[test]
    fn the_topics_follow_the_ros_node_and_the_namespace() {
        let mut plan = crate::resolve::default_plan();
        let names = |p: &Plan| topics(p).into_iter().map(|(t, _)| t).collect::<Vec<_>>();
        assert!(published(&plan));
        assert_eq!(names(&plan), ["rt/diagnostics", "rt/hardware_status"]);
        assert_eq!(HealthMessages::new(&plan).hardware_id, "handgate");
        plan.own_namespace = handgate_adapters::ros::Namespace::parse("fleet/robot1").unwrap();
        plan.namespace = Some(plan.own_namespace.clone());
        assert_eq!(names(&plan), ["rt/diagnostics", "rt/fleet/robot1/hardware_status"]);
        assert_eq!(HealthMessages::new(&plan).hardware_id, "fleet/robot1/handgate");
        // `[dds] ros_node = false`: no node, no health messages.
        plan.namespace = None;
        assert!(!published(&plan));
        assert!(names(&plan).is_empty());
    }

    #[test]
    fn both_messages_carry_one_entry_per_device() {
        let h = HealthMessages {
            hardware_id: "robot1/handgate".into(),
            stale_after: [("left".to_string(), WINDOW)].into_iter().collect(),
        };
        let mut right = dev(hg::STALE, 0.0, 700.0, false);
        right.device = "right".into();
        right.crc_errors = 4;
        let s = hg::GatewayStatus_ {
            devices: vec![dev(hg::FRESH, 100.0, 2.0, false), right],
            ..Default::default()
        };
        let t = Time_ { sec: 5, nanosec: 6 };
        let (d, hw) = h.messages(&s, t);
        assert_eq!(d.header.stamp, t);
        let names: Vec<_> = d.status.iter().map(|x| (x.name.as_str(), x.level)).collect();
        assert_eq!(
            names,
            [
                ("robot1/handgate: left", level::OK),
                ("robot1/handgate: right", level::ERROR)
            ]
        );
        assert_eq!(d.status[1].hardware_id, "right");
        let kv: HashMap<_, _> = d.status[1]
            .values
            .iter()
            .map(|k| (k.key.as_str(), k.value.as_str()))
            .collect();
        assert_eq!((kv["freshness"], kv["crc_errors"], kv["age_ms"]), ("stale", "4", "700"));
        assert_eq!(hw.hardware_id, "robot1/handgate");
        let states: Vec<_> = hw
            .hardware_device_states
            .iter()
            .map(|x| (x.device_id.as_str(), x.hardware_status[0].connectivity_status))
            .collect();
        assert_eq!(states, [("left", gs::CONNECT_UP), ("right", gs::CONNECT_DOWN)]);
        assert!(hw.hardware_device_states.iter().all(|x| x.canopen_states.is_empty()));
        assert_eq!(hw.hardware_device_states[0].hardware_status[0].model, "dex3");
    }
}
