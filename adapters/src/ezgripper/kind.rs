//! The SAKE EZGripper as a registered device kind: its profile keys (`[devices.ezgripper]`:
//! the Dynamixel bus, the servo, the driver's constants), their rules, its table.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use super::control_table::EzGripperParams;
use super::driver::default_id;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    ConfigError, ConfigValue, DeviceCtx, DeviceKind, FleetMember, FleetProblem, KindConfig, KindFactory, Problem,
    SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::{Side, GRIPPER_JOINTS};
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// SAKE EZGripper (Dynamixel MX-64 over serial).
    #[allow(non_upper_case_globals)]
    pub const Ezgripper: DeviceKind = DeviceKind::of(&EzGripperFactory);
}

/// The EZGripper's factory.
#[derive(Debug, Clone, Copy)]
pub struct EzGripperFactory;

const NAME: &str = "ezgripper";

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

fn config(c: &dyn KindConfig) -> &EzProfile {
    c.as_any()
        .downcast_ref::<EzProfile>()
        .expect("an ezgripper device has an EzProfile")
}

impl KindFactory for EzGripperFactory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn joints(&self) -> &'static [&'static str] {
        &GRIPPER_JOINTS
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Serial, Backend::Emulator]
    }

    /// As fast as the bus answers.
    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        None
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[SectionSpec {
            key: "ezgripper",
            backends: &[Backend::Serial, Backend::Emulator],
        }]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<EzProfile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(EzProfile::default())
    }

    fn table(&self, side: Side, c: &dyn KindConfig) -> DeviceTable {
        let pct = c
            .as_any()
            .downcast_ref::<EzProfile>()
            .map_or(100, |c| c.section().max_open_percent);
        super::table::table(side, super::table::DEFAULT_RANGE_RAD, f32::from(pct))
    }

    /// Grippers on one port share one baud and need distinct servo ids.
    fn validate_fleet(&self, members: &[FleetMember<'_>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut ports: HashMap<String, (usize, u32)> = HashMap::new();
        let mut ids: HashMap<(String, u8), usize> = HashMap::new();
        for m in members.iter().filter(|m| m.ctx.backend == Backend::Serial) {
            let e = config(m.config).section();
            match ports.get(&e.port) {
                Some(&(j, baud)) if baud != e.baud => out.push((
                    m.index,
                    Problem::new(
                        &["ezgripper", "baud"],
                        format!("devices[{j}] uses {} at {baud} baud; one bus has one baud rate", e.port),
                    ),
                )),
                Some(_) => {}
                None => {
                    ports.insert(e.port.clone(), (m.index, e.baud));
                }
            }
            let id = e.servo_id_for(m.ctx.side);
            if let Some(j) = ids.insert((e.port.clone(), id), m.index) {
                out.push((
                    m.index,
                    Problem::new(
                        &["ezgripper", "servo_id"],
                        format!("servo id {id} on {} is also devices[{j}]", e.port),
                    ),
                ));
            }
        }
        out
    }

    fn prepare(&self, devices: &[DeviceSpec<'_>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        super::open::prepare(devices, env)
    }

    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn std::fmt::Debug>, DeviceError> {
        Ok(Box::new(super::open::configure(spec)?))
    }

    fn emulate(&self, args: &crate::kind::EmulateArgs) -> Result<(String, crate::kind::Emulation), DeviceError> {
        super::open::emulate(args)
    }

    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(spec, env)
    }
}

impl KindConfig for EzProfile {
    fn validate(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
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

    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        match &self.ezgripper {
            Some(e) => format!(", {} @ {} baud id {}", e.port, e.baud, e.servo_id_for(ctx.side)),
            None => String::new(),
        }
    }

    crate::kind_config_plumbing!();
}
