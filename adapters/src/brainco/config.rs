//! A BrainCo hand's own profile keys (`[devices.dds]`: topic overrides and the finger speed)
//! and their rules.

use serde::{Deserialize, Serialize};

use crate::device::Backend;
use crate::kind::{DeviceCtx, Problem, Settings};
use crate::model::Side;

crate::dds_client_keys! {
    /// `[devices.dds]` of a BrainCo hand: topic overrides and the speed sent in every entry.
    pub struct DdsConfig {
        /// Finger speed, `dq` of every entry, in (0, 1] (default 1.0, as xr_teleoperate sends).
        pub speed: f64,
    }
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

    /// (command, state) topics on backend dds: the overrides, else the side's.
    pub fn topics(&self, side: Side) -> (Option<String>, Option<String>) {
        self.dds.clone().unwrap_or_default().topics_or(super::topics(side))
    }
}

impl Settings for BraincoProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let Some(x) = &self.dds else { return Vec::new() };
        let mut out = x.topic_problems();
        if let Some(s) = x.speed.filter(|s| !(s.is_finite() && *s > 0.0 && *s <= 1.0)) {
            out.push(Problem::new(
                &["dds", "speed"],
                format!("must be above 0 and at most 1 (1 = the hand's fastest), got {s}"),
            ));
        }
        out
    }

    fn peer_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(self.topics(ctx.side))
    }

    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        if ctx.backend == Backend::Dds {
            format!(" (speed {})", self.speed())
        } else {
            String::new()
        }
    }
}
