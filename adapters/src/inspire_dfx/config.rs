//! An Inspire DFX hand's own profile keys (`[devices.dds]`: topic overrides, the service's
//! `--namespace`) and their rules. One device per hand; a left and a right device share the
//! service's one 12-entry message (element 0 = right, 1 = left: `command_element`).

use serde::{Deserialize, Serialize};

use super::{CMD_TOPIC, STATE_TOPIC};
use crate::device::Backend;
use crate::kind::{DeviceCtx, Problem, Settings};

crate::dds_client_keys! {
    /// `[devices.dds]` of an Inspire DFX: topic overrides (the service's `--namespace`).
    pub struct DdsConfig {}
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
        let (c, s) = self
            .dds
            .clone()
            .unwrap_or_default()
            .topics_or(Some((CMD_TOPIC.into(), STATE_TOPIC.into())));
        (c.unwrap_or_default(), s.unwrap_or_default())
    }
}

impl Settings for DfxProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let Some(x) = &self.dds else { return Vec::new() };
        x.topic_problems()
    }

    fn peer_topics(&self, _ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        let (c, s) = self.topics();
        Some((Some(c), Some(s)))
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
