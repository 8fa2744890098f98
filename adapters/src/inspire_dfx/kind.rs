//! The Inspire DFX as a registered device kind (`inspire_dfx`): its profile keys
//! (`[devices.dds]`: topic overrides), their rules, its default rate and table. One device per
//! hand; a left and a right device share the service's one 12-entry message (element 0 =
//! right, 1 = left: `dds_command_element`).

use serde::{Deserialize, Serialize};

use super::{CMD_TOPIC, STATE_TOPIC};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    a, check_topic, ConfigError, ConfigValue, DeviceCtx, DeviceKind, FleetMember, FleetProblem, KindConfig,
    KindFactory, Problem, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// Inspire DFX (RH56DFX) hand, through DFX_inspire_service over DDS.
    #[allow(non_upper_case_globals)]
    pub const InspireDfx: DeviceKind = DeviceKind::of(&InspireDfxFactory);
}

/// The Inspire DFX's factory.
#[derive(Debug, Clone, Copy)]
pub struct InspireDfxFactory;

const NAME: &str = "inspire_dfx";

/// `[devices.dds]` of an Inspire DFX: topic overrides (the service's `--namespace`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    /// Default `rt/inspire/cmd`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<String>,
    /// Default `rt/inspire/state`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<String>,
}

/// An Inspire DFX's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DfxProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
}

impl DfxProfile {
    /// (command, state) topics: the overrides, else the service's defaults.
    pub fn topics(&self) -> (String, String) {
        let d = self.dds.clone().unwrap_or_default();
        (
            d.cmd_topic.unwrap_or_else(|| CMD_TOPIC.into()),
            d.state_topic.unwrap_or_else(|| STATE_TOPIC.into()),
        )
    }
}

impl KindFactory for InspireDfxFactory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn joints(&self) -> &'static [&'static str] {
        &super::table::JOINTS
    }

    /// DFX_inspire_service's own interface (`rt/inspire/*`, both hands): `super::serve`.
    fn fronts(&self) -> &'static [crate::front::kind::FrontKind] {
        &[crate::front::kind::FrontKind::InspireDfx]
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Dds, Backend::Emulator]
    }

    /// The message holds a right (0–5) and a left (6–11) hand: no center.
    fn check_side(&self, side: Side) -> Result<(), String> {
        match super::element(side) {
            Some(_) => Ok(()),
            None => Err(format!(
                "{} is a left or a right hand (its service's message has entries 0-5 right, 6-11 left)",
                a(NAME)
            )),
        }
    }

    /// 100 Hz: xr_teleoperate's publish rate and the service's nominal loop (docs/sources.md §7).
    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        Some(super::SERVICE_RATE_HZ)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<DfxProfile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(DfxProfile::default())
    }

    fn table(&self, side: Side, _c: &dyn KindConfig) -> DeviceTable {
        super::table::table(side)
    }

    /// The service reports only `q`: velocity and torque noise have nothing to act on.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        section
            .keys_set()
            .into_iter()
            .filter(|k| matches!(*k, "velocity_noise_rad_s" | "torque_noise_nm"))
            .map(|key| {
                Problem::new(
                    &["emulator", key],
                    "has no effect on an inspire_dfx: its service reports only q (no velocity or torque), remove it",
                )
            })
            .collect()
    }

    /// Emulated hands share one emulated service (one per profile): two on one side would
    /// write the same six entries.
    fn validate_fleet(&self, members: &[FleetMember<'_>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut seen: Vec<(Side, usize)> = Vec::new();
        for m in members.iter().filter(|m| m.ctx.backend == Backend::Emulator) {
            match seen.iter().find(|(s, _)| *s == m.ctx.side) {
                Some((_, j)) => out.push((
                    m.index,
                    Problem::new(
                        &["side"],
                        format!(
                            "devices[{j}] is the emulated {} hand already: emulated {NAME} devices share one service, one per side",
                            m.ctx.side
                        ),
                    ),
                )),
                None => seen.push((m.ctx.side, m.index)),
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

impl KindConfig for DfxProfile {
    fn validate(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(x) = &self.dds {
            for (key, t) in [("cmd_topic", &x.cmd_topic), ("state_topic", &x.state_topic)] {
                if let Some(Err(e)) = t.as_deref().map(check_topic) {
                    out.push(Problem::new(&["dds", key], e));
                }
            }
        }
        out
    }

    fn dds_topics(&self, _ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        let (c, s) = self.topics();
        Some((Some(c), Some(s)))
    }

    /// The service's message carries both hands: element 0 right (entries 0–5), 1 left (6–11).
    fn dds_command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        super::element(ctx.side)
    }

    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        match super::element(ctx.side) {
            Some(e) if ctx.backend == Backend::Dds => {
                format!(" (entries {}-{})", e * super::HAND_ENTRIES, e * super::HAND_ENTRIES + 5)
            }
            _ => String::new(),
        }
    }

    crate::kind_config_plumbing!();
}
