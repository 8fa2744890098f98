//! A Robotiq gripper's own profile keys (`[devices.robotiq]`): the variant, where its Modbus
//! RTU line is (a serial port, or RTU over TCP through a UR arm's tool-flange forwarder), its
//! slave id and the speed and force every move uses.

use serde::{Deserialize, Serialize};

use super::regs::{BAUD, SLAVE_ID};
use super::table::Variant;
use crate::device::Backend;
use crate::kind::{DeviceCtx, Problem, Settings};

/// Baud rates handgate opens a Robotiq line at (those of the gripper's settings the serial kit
/// supports); 115200 is the factory setting.
pub const BAUDS: &[u32] = &[9_600, 57_600, 115_200];

/// `[devices.robotiq]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotiqConfig {
    pub variant: Variant,
    /// The serial port of an RS-485 adapter (backend serial), e.g. /dev/ttyUSB0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub port: Option<String>,
    /// RTU over TCP, `host:port` (a UR arm's Tool Communication forwarder listens on 54321).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tcp: Option<String>,
    pub baud: u32,
    /// Modbus slave id (9 from the factory).
    pub slave: u8,
    /// rSP of every move, 0 (slowest) ..= 255.
    pub speed: u8,
    /// rFR of every move, 0 ..= 255 (0: no regrasp, the lightest grip).
    pub force: u8,
    /// Grace for a reply beyond its wire time, ms (USB adapters, the forwarder's latency).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_timeout_ms: Option<u64>,
}

impl Default for RobotiqConfig {
    fn default() -> Self {
        RobotiqConfig {
            variant: Variant::default(),
            port: None,
            tcp: None,
            baud: BAUD,
            slave: SLAVE_ID,
            speed: 255,
            force: 128,
            response_timeout_ms: None,
        }
    }
}

/// A Robotiq's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotiqProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub robotiq: Option<RobotiqConfig>,
}

impl RobotiqProfile {
    /// `[devices.robotiq]` with its defaults.
    pub fn section(&self) -> RobotiqConfig {
        self.robotiq.clone().unwrap_or_default()
    }
}

impl Settings for RobotiqProfile {
    fn check(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let r = self.section();
        if ctx.backend == Backend::Serial {
            match (&r.port, &r.tcp) {
                (None, None) => out.push(Problem::new(
                    &["robotiq"],
                    "needs `port` (an RS-485 adapter, e.g. /dev/ttyUSB0) or `tcp` (RTU over TCP, e.g. 192.168.1.10:54321)",
                )),
                (Some(_), Some(_)) => out.push(Problem::new(
                    &["robotiq", "tcp"],
                    "give `port` or `tcp`, not both: the gripper is on one line",
                )),
                _ => {}
            }
        }
        if let Some(p) = &r.port {
            if p.trim().is_empty() {
                out.push(Problem::new(
                    &["robotiq", "port"],
                    "must name a serial port, e.g. /dev/ttyUSB0",
                ));
            }
        }
        if let Some(t) = &r.tcp {
            if super::open::resolve_tcp(t).is_err() {
                out.push(Problem::new(
                    &["robotiq", "tcp"],
                    format!("`{t}` is not host:port (e.g. 192.168.1.10:54321)"),
                ));
            }
        }
        if !BAUDS.contains(&r.baud) {
            let v: Vec<String> = BAUDS.iter().map(|b| b.to_string()).collect();
            out.push(Problem::new(
                &["robotiq", "baud"],
                format!("{} is not a baud rate the gripper takes ({})", r.baud, v.join(", ")),
            ));
        }
        if !(1..=247).contains(&r.slave) {
            out.push(Problem::new(
                &["robotiq", "slave"],
                format!("must be a Modbus slave id between 1 and 247, got {}", r.slave),
            ));
        }
        out
    }

    fn serial_ports(&self) -> Vec<std::path::PathBuf> {
        self.section().port.into_iter().map(std::path::PathBuf::from).collect()
    }

    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        match &self.robotiq {
            Some(r) => {
                let line = match (&r.port, &r.tcp) {
                    (Some(p), _) => format!("{p} @ {} baud", r.baud),
                    (None, Some(t)) => format!("RTU over TCP {t}"),
                    (None, None) => "emulated".into(),
                };
                format!(", Robotiq {} {line} slave {}", r.variant.name(), r.slave)
            }
            None => String::new(),
        }
    }
}
