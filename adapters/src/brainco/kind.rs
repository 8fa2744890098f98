//! The BrainCo Revo2 as a registered device kind: its profile keys (`[devices.dds]`: topic
//! overrides and the finger speed), their rules, its default rate and table.

use serde::{Deserialize, Serialize};

use super::table::JOINTS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    check_topic, ConfigError, ConfigValue, DeviceCtx, DeviceKind, KindConfig, KindFactory, Problem, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// BrainCo Revo2 hand (through `brainco_hand_service` over DDS).
    #[allow(non_upper_case_globals)]
    pub const Brainco: DeviceKind = DeviceKind::of(&BraincoFactory);
}

/// The BrainCo Revo2's factory.
#[derive(Debug, Clone, Copy)]
pub struct BraincoFactory;

const NAME: &str = "brainco";

/// `[devices.dds]` of a BrainCo hand: topic overrides and the speed sent in every entry.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<String>,
    /// Finger speed, `dq` of every entry, in (0, 1] (default 1.0, as xr_teleoperate sends).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed: Option<f64>,
}

/// A BrainCo hand's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BraincoProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
}

impl BraincoProfile {
    /// `dds.speed`, default 1.0.
    pub fn speed(&self) -> f32 {
        self.dds
            .as_ref()
            .and_then(|d| d.speed)
            .map_or(super::DEFAULT_SPEED, |s| s as f32)
    }
}

/// (command, state) topics of a BrainCo hand on backend dds: the overrides, else the side's.
pub fn dds_topics(p: &BraincoProfile, side: Side) -> (Option<String>, Option<String>) {
    let dds = p.dds.clone().unwrap_or_default();
    let std = super::topics(side);
    (
        dds.cmd_topic.or_else(|| std.as_ref().map(|t| t.0.clone())),
        dds.state_topic.or_else(|| std.map(|t| t.1)),
    )
}

impl KindFactory for BraincoFactory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn joints(&self) -> &'static [&'static str] {
        &JOINTS
    }

    /// `brainco_hand_service`'s own interface (`rt/brainco/{side}/*`): `super::serve`.
    fn fronts(&self) -> &'static [crate::front::kind::FrontKind] {
        &[crate::front::kind::FrontKind::Brainco]
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Dds, Backend::Emulator]
    }

    fn check_side(&self, side: Side) -> Result<(), String> {
        match side {
            Side::Left | Side::Right => Ok(()),
            Side::Center => Err(format!("{} is a left or a right hand", a_brainco())),
        }
    }

    /// 500 Hz: the service's loop (docs/sources.md §7); the emulated service runs at the
    /// device's rate.
    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        Some(super::emulator::BRAINCO_DEFAULT_HZ)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<BraincoProfile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(BraincoProfile::default())
    }

    fn table(&self, side: Side, _c: &dyn KindConfig) -> DeviceTable {
        super::table::table(side)
    }

    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn std::fmt::Debug>, DeviceError> {
        Ok(Box::new(super::open::configure(spec)?))
    }

    fn served(&self, spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
        super::open::served(spec)
    }

    fn emulate(&self, args: &crate::kind::EmulateArgs) -> Result<(String, crate::kind::Emulation), DeviceError> {
        super::open::emulate(args)
    }

    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(spec, env)
    }
}

fn a_brainco() -> String {
    crate::kind::a(NAME)
}

impl KindConfig for BraincoProfile {
    fn validate(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(x) = &self.dds {
            for (key, t) in [("cmd_topic", &x.cmd_topic), ("state_topic", &x.state_topic)] {
                if let Some(Err(e)) = t.as_deref().map(check_topic) {
                    out.push(Problem::new(&["dds", key], e));
                }
            }
            if let Some(s) = x.speed {
                if !(s.is_finite() && s > 0.0 && s <= 1.0) {
                    out.push(Problem::new(
                        &["dds", "speed"],
                        format!("must be above 0 and at most 1 (1 = the hand's fastest), got {s}"),
                    ));
                }
            }
        }
        out
    }

    fn dds_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(dds_topics(self, ctx.side))
    }

    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        if ctx.backend == Backend::Dds {
            format!(" (speed {})", self.speed())
        } else {
            String::new()
        }
    }

    crate::kind_config_plumbing!();
}
