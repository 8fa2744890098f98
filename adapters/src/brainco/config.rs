//! A BrainCo hand's own profile keys (`[devices.dds]`: topic overrides and the finger speed)
//! and their rules.

use crate::device::Backend;
use crate::kind::{DeviceCtx, Problem};
use crate::model::Side;
use crate::service_client::{DdsProfile, DdsSection};

crate::dds_client_keys! {
    /// `[devices.dds]` of a BrainCo hand: topic overrides and the speed sent in every entry.
    pub struct DdsConfig {
        /// Finger speed, `dq` of every entry, in (0, 1] (default 1.0, as xr_teleoperate sends).
        pub speed: f64,
    }
}

/// A BrainCo hand's own profile keys.
pub type BraincoProfile = DdsProfile<DdsConfig>;

impl DdsConfig {
    /// `speed`, default 1.0.
    pub fn speed(&self) -> f32 {
        self.speed.map_or(super::DEFAULT_SPEED, |s| s as f32)
    }
}

impl DdsSection for DdsConfig {
    fn standard(&self, side: Side) -> Option<(String, String)> {
        super::topics(side)
    }
    fn problems(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let bad = self.speed.filter(|s| !(s.is_finite() && *s > 0.0 && *s <= 1.0));
        let why = |s| format!("must be above 0 and at most 1 (1 = the hand's fastest), got {s}");
        bad.map(|s| Problem::new(&["dds", "speed"], why(s)))
            .into_iter()
            .collect()
    }
    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        match ctx.backend {
            Backend::Dds => format!(" (speed {})", self.speed()),
            _ => String::new(),
        }
    }
}
