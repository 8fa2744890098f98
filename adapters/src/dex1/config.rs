//! A Dex1-1's own profile keys (`[devices.dds]`: topics, wire variant, open range) and their
//! rules.

use super::adapter::Variant;
use super::table::{DEFAULT_RANGE, SEED_SPEC_RANGE_RAD};
use crate::device::Backend;
use crate::kind::{center_needs_topics, DdsTopicKeys, DeviceCtx, Problem};
use crate::model::Side;
use crate::service_client::{DdsProfile, DdsSection};

crate::dds_client_keys! {
    /// `[devices.dds]` of a Dex1: topic overrides, wire variant, open position.
    pub struct DdsConfig {
        /// Wire variant (default `go`).
        pub variant: Variant,
        /// Open position, rad (default 5.4).
        pub range_rad: f64,
    }
}

/// A Dex1's own profile keys.
pub type Dex1Profile = DdsProfile<DdsConfig>;

impl Dex1Profile {
    /// The wire variant (`dds.variant`, default `go`).
    pub fn variant(&self) -> Variant {
        self.keys().variant()
    }

    /// The open position (`dds.range_rad`, default 5.4 rad).
    pub fn range_rad(&self) -> f64 {
        self.keys().range_rad.unwrap_or(DEFAULT_RANGE)
    }
}

impl DdsConfig {
    fn variant(&self) -> Variant {
        self.variant.unwrap_or_default()
    }
}

impl DdsSection for DdsConfig {
    /// The variant's for the side; none for a center device but on the actuator variant.
    fn standard(&self, side: Side) -> Option<(String, String)> {
        let variant = self.variant();
        (variant == Variant::Actuator || side != Side::Center).then(|| variant.topics(side))
    }

    fn problems(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if self.variant == Some(Variant::Auto) {
            out.push(Problem::new(
                &["dds", "variant"],
                "`auto` is a front's variant (it follows its clients); a device speaks one: go, hg or actuator",
            ));
        }
        if let Some(r) = self.range_rad {
            if !(r.is_finite() && r > 0.0 && r <= f64::from(SEED_SPEC_RANGE_RAD)) {
                out.push(Problem::new(
                    &["dds", "range_rad"],
                    format!("must be above 0 and at most 2pi rad, got {r}"),
                ));
            }
        }
        out.extend(center_needs_topics(
            "dex1",
            ctx,
            self.topics_or(self.standard(ctx.side)),
        ));
        if ctx.backend == Backend::Dds && ctx.side == Side::Center && self.variant() == Variant::Actuator {
            out.push(Problem::new(
                &["side"],
                "the actuator variant addresses element 0 = right, 1 = left: side must be left or right",
            ));
        }
        out
    }

    /// The actuator variant's message carries both grippers: element 0 right, 1 left.
    fn command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        (self.variant() == Variant::Actuator && ctx.side != Side::Center)
            .then(|| super::adapter::actuator_index(ctx.side))
    }

    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        if ctx.backend == Backend::Dds {
            format!(" ({})", self.variant())
        } else {
            String::new()
        }
    }
}
