//! A SAKE EZGripper's own profile keys (`[devices.ezgripper]`: the Dynamixel bus, the servo,
//! the driver's constants) and their rules.

use serde::{Deserialize, Serialize};

use super::control_table::EzGripperParams;
use super::driver::default_id;
use crate::kind::{DeviceCtx, Problem, Settings};
use crate::model::Side;

/// Dynamixel baud rates an MX-64 accepts under Protocol 2.0 (ROBOTIS e-manual, Baud Rate(8)).
pub const DYNAMIXEL_BAUDS: &[u32] = &[
    9_600, 57_600, 115_200, 1_000_000, 2_000_000, 3_000_000, 4_000_000, 4_500_000,
];

/// `[devices.ezgripper]`: a SAKE EZGripper on a Dynamixel bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EzGripperConfig {
    pub port: String,
    pub baud: u32,
    /// Servo id on the bus; `None` = by side ([`default_id`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo_id: Option<u8>,
    /// Opening at 5.4 rad (Dex1 "open"), percent, 1..=100.
    pub max_open_percent: u8,
    /// Grip force limit, percent 1..=100; `None` = leave the servo's current limit alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_limit_percent: Option<u8>,
    /// Run the closing calibration at start (moves the gripper).
    pub calibrate_on_start: bool,
    /// A known calibration zero (raw ticks at the closed stop); a calibration replaces it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_ticks: Option<i32>,
    /// Grace for a reply beyond its wire time, ms (USB-serial adapter latency).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_timeout_ms: Option<u64>,
    /// The driver's constants (docs/ezgripper.md), every key optional.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub params: Option<EzGripperParams>,
}

impl Default for EzGripperConfig {
    fn default() -> Self {
        EzGripperConfig {
            port: "/dev/ttyUSB0".into(),
            baud: 1_000_000,
            servo_id: None,
            max_open_percent: 100,
            force_limit_percent: None,
            calibrate_on_start: false,
            zero_ticks: None,
            response_timeout_ms: None,
            params: None,
        }
    }
}

impl EzGripperConfig {
    /// The servo id: `servo_id`, or the SAKE driver's by side.
    pub fn servo_id_for(&self, side: Side) -> u8 {
        self.servo_id.unwrap_or_else(|| default_id(side).get())
    }
}

/// An EZGripper's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EzProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ezgripper: Option<EzGripperConfig>,
}

impl EzProfile {
    /// `[devices.ezgripper]` with its defaults.
    pub fn section(&self) -> EzGripperConfig {
        self.ezgripper.clone().unwrap_or_default()
    }
}

impl Settings for EzProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let Some(e) = &self.ezgripper else { return out };
        if e.port.trim().is_empty() {
            out.push(Problem::new(
                &["ezgripper", "port"],
                "must name a serial port, e.g. /dev/ttyUSB0",
            ));
        }
        if !DYNAMIXEL_BAUDS.contains(&e.baud) {
            let v: Vec<String> = DYNAMIXEL_BAUDS.iter().map(|b| b.to_string()).collect();
            out.push(Problem::new(
                &["ezgripper", "baud"],
                format!("{} is not a Dynamixel baud rate ({})", e.baud, v.join(", ")),
            ));
        }
        if let Some(id) = e.servo_id {
            if id > 252 {
                out.push(Problem::new(
                    &["ezgripper", "servo_id"],
                    format!("must be between 0 and 252 (253+ are reserved/broadcast), got {id}"),
                ));
            }
        }
        if !(1..=100).contains(&e.max_open_percent) {
            out.push(Problem::new(
                &["ezgripper", "max_open_percent"],
                format!("must be between 1 and 100, got {}", e.max_open_percent),
            ));
        }
        if let Some(f) = e.force_limit_percent {
            if !(1..=100).contains(&f) {
                out.push(Problem::new(
                    &["ezgripper", "force_limit_percent"],
                    format!("must be between 1 and 100, got {f}"),
                ));
            }
        }
        out
    }

    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        match &self.ezgripper {
            Some(e) => format!(", {} @ {} baud id {}", e.port, e.baud, e.servo_id_for(ctx.side)),
            None => String::new(),
        }
    }

    fn serial_ports(&self) -> Vec<std::path::PathBuf> {
        vec![self.section().port.into()]
    }
}
