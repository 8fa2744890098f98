//! The Dex1-1 as a registered device kind: its profile keys (`[devices.dds]`: topics, wire
//! variant, open range), their rules, its default rate and table.

use serde::{Deserialize, Serialize};

use super::adapter::Variant;
use super::table::{DEFAULT_RANGE, DEFAULT_RANGE_RAD, SEED_SPEC_RANGE_RAD};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    a, check_topic, ConfigError, ConfigValue, DeviceCtx, DeviceKind, KindConfig, KindFactory, Problem, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::{Side, GRIPPER_JOINTS};
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// Unitree Dex1-1 parallel gripper (through dex1_1_service over DDS).
    #[allow(non_upper_case_globals)]
    pub const Dex1: DeviceKind = DeviceKind::of(&Dex1Factory);
}

/// The Dex1-1's factory.
#[derive(Debug, Clone, Copy)]
pub struct Dex1Factory;

const NAME: &str = "dex1";

/// `[devices.dds]` of a Dex1: topic overrides, wire variant, open position.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<String>,
    /// Wire variant (default `go`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<Variant>,
    /// Open position, rad (default 5.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub range_rad: Option<f64>,
}

/// A Dex1's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Dex1Profile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
}

impl Dex1Profile {
    /// The wire variant (`dds.variant`, default `go`).
    pub fn variant(&self) -> Variant {
        self.dds.as_ref().and_then(|d| d.variant).unwrap_or_default()
    }

    /// The open position (`dds.range_rad`, default 5.4 rad).
    pub fn range_rad(&self) -> f64 {
        self.dds.as_ref().and_then(|d| d.range_rad).unwrap_or(DEFAULT_RANGE)
    }
}

impl KindFactory for Dex1Factory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn joints(&self) -> &'static [&'static str] {
        &GRIPPER_JOINTS
    }

    fn fronts(&self) -> &'static [crate::front::kind::FrontKind] {
        &[crate::front::kind::FrontKind::Dex1]
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Dds, Backend::Emulator]
    }

    /// dex1_1_service's loop ([`super::SERVICE_HZ`]).
    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        Some(super::SERVICE_HZ)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<Dex1Profile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(Dex1Profile::default())
    }

    fn table(&self, side: Side, c: &dyn KindConfig) -> DeviceTable {
        let range = c
            .as_any()
            .downcast_ref::<Dex1Profile>()
            .map_or(DEFAULT_RANGE_RAD, |c| c.range_rad() as f32);
        super::table::table(side, range)
    }

    /// 0 (open) ..= 2π, the widest range in the field (the seed spec's).
    fn hardware_range(&self, _side: Side, joint: &str) -> Option<(f64, f64)> {
        GRIPPER_JOINTS
            .contains(&joint)
            .then_some((0.0, f64::from(SEED_SPEC_RANGE_RAD)))
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

/// (command, state) topics of a Dex1 on backend dds: `dds.cmd_topic` / `dds.state_topic`,
/// else the variant's for the side; `None` where the side (center) gives no default.
pub fn dds_topics(p: &Dex1Profile, side: Side) -> (Option<String>, Option<String>) {
    let dds = p.dds.clone().unwrap_or_default();
    let variant = p.variant();
    let std = (variant == Variant::Actuator || side != Side::Center).then(|| variant.topics(side));
    (
        dds.cmd_topic.or_else(|| std.as_ref().map(|t| t.0.clone())),
        dds.state_topic.or_else(|| std.map(|t| t.1)),
    )
}

impl KindConfig for Dex1Profile {
    fn validate(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(x) = &self.dds {
            for (key, t) in [("cmd_topic", &x.cmd_topic), ("state_topic", &x.state_topic)] {
                if let Some(Err(e)) = t.as_deref().map(check_topic) {
                    out.push(Problem::new(&["dds", key], e));
                }
            }
            if x.variant == Some(Variant::Auto) {
                out.push(Problem::new(
                    &["dds", "variant"],
                    "`auto` is a front's variant (it follows its clients); a device speaks one: go, hg or actuator",
                ));
            }
            if let Some(r) = x.range_rad {
                if !(r.is_finite() && r > 0.0 && r <= f64::from(SEED_SPEC_RANGE_RAD)) {
                    out.push(Problem::new(
                        &["dds", "range_rad"],
                        format!("must be above 0 and at most 2pi rad, got {r}"),
                    ));
                }
            }
        }
        if ctx.backend == Backend::Dds && ctx.side == Side::Center {
            if let Some((cmd, state)) = self.dds_topics(ctx) {
                if cmd.is_none() || state.is_none() {
                    out.push(Problem::new(
                        &["side"],
                        format!(
                            "{} on backend dds with side center needs dds.cmd_topic and dds.state_topic",
                            a(NAME)
                        ),
                    ));
                }
            }
            if self.variant() == Variant::Actuator {
                out.push(Problem::new(
                    &["side"],
                    "the actuator variant addresses element 0 = right, 1 = left: side must be left or right",
                ));
            }
        }
        out
    }

    fn dds_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(dds_topics(self, ctx.side))
    }

    /// The actuator variant's message carries both grippers: element 0 right, 1 left.
    fn dds_command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        (self.variant() == Variant::Actuator && ctx.side != Side::Center)
            .then(|| super::adapter::actuator_index(ctx.side))
    }

    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        if ctx.backend == Backend::Dds {
            format!(" ({})", self.variant())
        } else {
            String::new()
        }
    }

    crate::kind_config_plumbing!();
}
