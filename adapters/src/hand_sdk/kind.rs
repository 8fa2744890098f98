//! The G1's `rt/hand_sdk` interface as a registered device kind: its profile keys
//! (`[devices.hand_sdk]`: topic, blend weight and ramp, publish rate), their rules, its table.

use serde::{Deserialize, Serialize};

use super::adapter::WeightRamp;
use super::TOPIC;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    check_rate, check_topic, ConfigError, ConfigValue, DeviceCtx, DeviceKind, KindConfig, KindFactory, Problem,
    SectionSpec, MAX_RATE_HZ,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// The G1's `rt/hand_sdk` interface to an internally wired hand (4 motors).
    #[allow(non_upper_case_globals)]
    pub const HandSdk: DeviceKind = DeviceKind::of(&HandSdkFactory);
}

/// The `rt/hand_sdk` kind's factory.
#[derive(Debug, Clone, Copy)]
pub struct HandSdkFactory;

const NAME: &str = "hand_sdk";

/// `[devices.hand_sdk]`: the G1 `rt/hand_sdk` blend interface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HandSdkSection {
    pub topic: String,
    /// Target blend weight 0..=1 (sent as `cmds[0].mode = weight * 100`).
    pub weight: f64,
    /// How fast the weight ramps towards its target, per second.
    pub ramp_per_s: f64,
    /// Publish rate, Hz; `None` = the device rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub publish_hz: Option<f64>,
}

impl Default for HandSdkSection {
    fn default() -> Self {
        HandSdkSection {
            topic: TOPIC.into(),
            weight: 1.0,
            ramp_per_s: 0.5,
            publish_hz: None,
        }
    }
}

/// A hand_sdk device's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HandSdkProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hand_sdk: Option<HandSdkSection>,
}

impl HandSdkProfile {
    /// `[devices.hand_sdk]` with its defaults.
    pub fn section(&self) -> HandSdkSection {
        self.hand_sdk.clone().unwrap_or_default()
    }

    /// The weight ramp the adapter runs.
    pub fn ramp(&self) -> WeightRamp {
        let h = self.section();
        WeightRamp {
            target: h.weight as f32,
            per_second: h.ramp_per_s as f32,
        }
    }
}

impl KindFactory for HandSdkFactory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn joints(&self) -> &'static [&'static str] {
        &super::JOINTS
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Dds, Backend::Emulator]
    }

    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        Some(200.0)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[SectionSpec {
            key: "hand_sdk",
            backends: &[Backend::Dds, Backend::Emulator],
        }]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<HandSdkProfile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(HandSdkProfile::default())
    }

    fn table(&self, side: Side, _config: &dyn KindConfig) -> DeviceTable {
        super::table::table(side)
    }

    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn std::fmt::Debug>, DeviceError> {
        Ok(Box::new(super::open::configure(spec)?))
    }

    fn served(&self, spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
        super::open::served(spec)
    }

    /// The emulated ai_sport blend publishes no state and the adapter reads none: no
    /// `[devices.emulator]` key (initial posture, object, noise) could change what handgate
    /// sees, so each one set is refused.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        section
            .keys_set()
            .into_iter()
            .map(|key| {
                Problem::new(
                    &["emulator", key],
                    "has no effect on a hand_sdk: its emulator (the ai_sport blend) publishes no state \
                     (no position, torque or noise to emulate), remove it",
                )
            })
            .collect()
    }

    fn emulate(&self, args: &crate::kind::EmulateArgs) -> Result<(String, crate::kind::Emulation), DeviceError> {
        super::open::emulate(args)
    }

    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(spec, env)
    }
}

impl KindConfig for HandSdkProfile {
    fn validate(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let Some(h) = &self.hand_sdk else { return out };
        if let Err(e) = check_topic(&h.topic) {
            out.push(Problem::new(&["hand_sdk", "topic"], e));
        }
        if !(h.weight.is_finite() && (0.0..=1.0).contains(&h.weight)) {
            out.push(Problem::new(
                &["hand_sdk", "weight"],
                format!("must be between 0 and 1, got {}", h.weight),
            ));
        }
        if !(h.ramp_per_s.is_finite() && h.ramp_per_s > 0.0 && h.ramp_per_s <= 100.0) {
            out.push(Problem::new(
                &["hand_sdk", "ramp_per_s"],
                format!("must be above 0 and at most 100 per second, got {}", h.ramp_per_s),
            ));
        }
        if let Some(Err(e)) = h.publish_hz.map(|r| check_rate(r, MAX_RATE_HZ)) {
            out.push(Problem::new(&["hand_sdk", "publish_hz"], e));
        }
        out
    }

    fn dds_topics(&self, _ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some((Some(self.section().topic), None))
    }

    crate::kind_config_plumbing!();
}
