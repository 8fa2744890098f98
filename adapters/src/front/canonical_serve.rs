//! The canonical front's registry entry and codec glue; its codec is
//! `crate::front::canonical`.

use serde::{Deserialize, Serialize};

pub use crate::front::canonical::topics;
use crate::front::canonical::{decode_cmd, encode_state};
use crate::front::config::{Silence, TopicKey, TopicRole};
use crate::front::endpoint::{DdsFront, FrontCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{Bound, Routed};
use crate::front::Rejection;
use crate::model::SafeAction;
use crate::units::Topic;
use handgate_idl::handgate as hg;

/// The canonical front's own keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CanonicalConfig {
    /// Default `rt/handgate/{device}/cmd` (in `[dds] namespace`).
    pub cmd_topic: Option<Topic>,
    /// Default `rt/handgate/{device}/state` (in `[dds] namespace`).
    pub state_topic: Option<Topic>,
}

/// No `side`: the device's own table, whatever its side.
impl crate::front::config::ServedSide for CanonicalConfig {}

/// handgate's own `HandCmd_` in, `HandState_` out, in the bound device's own table.
#[derive(Default)]
pub struct CanonicalCodec;

impl FrontCodec for CanonicalCodec {
    type Cmd = hg::HandCmd_;
    type State = hg::HandState_;

    fn decode(&self, bound: &[Bound<'_>], m: &hg::HandCmd_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let b0 = &bound[0];
        // The device's own names and table: no front table in between.
        Ok(vec![(0, (decode_cmd(m, &b0.route.device, b0.safe_action)?, 0, false))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<hg::HandState_> {
        let b0 = bound.first()?;
        Some(encode_state(b0.device, &b0.route.device, b0.state))
    }

    /// Its endpoints; a Dex3 client's command type named with the front that serves it.
    fn served(f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::dds::type_name;
        use handgate_idl::unitree_hg;
        DdsFront::<Self>::endpoints(f)
            .into_iter()
            .map(|s| match s.role {
                crate::discovery::Role::Reader => s.alternative(
                    type_name::<unitree_hg::HandCmd_>(),
                    format!("the client speaks the Dex3 service interface (unitree_hg HandCmd_): serve it with a dex3 front, or send handgate HandCmd_ to front {}", f.name),
                ),
                crate::discovery::Role::Writer => s,
            })
            .collect()
    }
}

/// handgate's own interface: the bound device's table, its watchdog as silence.
#[derive(Debug)]
pub struct CanonicalFront;

impl Front for CanonicalFront {
    type Config = CanonicalConfig;
    type Wire = DdsFront<CanonicalCodec>;
    const KIND: FrontKind = FrontKind::of(&CanonicalFront);
    const FACTS: FrontFacts = FrontFacts {
        in_namespace: true,
        ..FrontFacts::serving("canonical", None)
    };
    const TOPICS: &'static [TopicKey<CanonicalConfig>] = &[
        TopicKey {
            key: "cmd_topic",
            role: TopicRole::Command,
            set: |c| c.cmd_topic.as_ref(),
            default: |_, at| Some(Topic(topics(at.device).0)),
        },
        TopicKey {
            key: "state_topic",
            role: TopicRole::State,
            set: |c| c.state_topic.as_ref(),
            default: |_, at| Some(Topic(topics(at.device).1)),
        },
    ];

    fn default_state_hz(device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn default_name(_c: &CanonicalConfig, f: &crate::front::config::FrontConfig, _side: &str) -> String {
        format!("canonical_{}", f.device.as_ref().map_or("?", |d| d.as_str()))
    }
    fn silence(_mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        // handgate's own interface: its service semantics are the strict watchdog.
        SilencePlan {
            mode: Silence::Watchdog,
            after: Some(dog),
            timeout_bit: None,
        }
    }
}

impl FrontKind {
    /// handgate's own canonical messages (`rt/handgate/{device}/*`).
    #[allow(non_upper_case_globals)]
    pub const Canonical: FrontKind = CanonicalFront::KIND;
}
