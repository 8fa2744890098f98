//! The `rt/hand_sdk` device's own profile keys (`[devices.hand_sdk]`: topic, blend weight
//! and ramp, publish rate) and their rules.

use serde::{Deserialize, Serialize};

use super::adapter::WeightRamp;
use super::TOPIC;
use crate::kind::{check_rate, check_topic, DeviceCtx, Problem, Settings, MAX_RATE_HZ};

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

impl Settings for HandSdkProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
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

    fn peer_topics(&self, _ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some((Some(self.section().topic), None))
    }
}
