//! An Inspire DFX hand's own profile keys (`[devices.dds]`: topic overrides, the service's
//! `--namespace`) and their rules. One device per hand; a left and a right device share the
//! service's one 12-entry message (element 0 = right, 1 = left: `command_element`).

use super::{CMD_TOPIC, STATE_TOPIC};
use crate::device::Backend;
use crate::kind::DeviceCtx;
use crate::model::Side;
use crate::service_client::{DdsProfile, DdsSection};

crate::dds_client_keys! {
    /// `[devices.dds]` of an Inspire DFX: topic overrides (the service's `--namespace`).
    pub struct DdsConfig {}
}

/// An Inspire DFX's own profile keys.
pub type DfxProfile = DdsProfile<DdsConfig>;

impl DdsSection for DdsConfig {
    /// The service's topics, whatever the side: one message carries both hands.
    fn standard(&self, _side: Side) -> Option<(String, String)> {
        Some((CMD_TOPIC.into(), STATE_TOPIC.into()))
    }
    /// The service's message carries both hands: element 0 right (entries 0–5), 1 left (6–11).
    fn command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        super::element(ctx.side)
    }
    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        match super::element(ctx.side) {
            Some(e) if ctx.backend == Backend::Dds => {
                format!(" (entries {}-{})", e * super::HAND_ENTRIES, e * super::HAND_ENTRIES + 5)
            }
            _ => String::new(),
        }
    }
}
