//! The Dex5-1 service front's registry entry (handgate serving the hand service's own
//! `rt/dex5/{left,right}/{cmd,state}`, docs/sources.md §7 "Dex5-1"), so an unmodified Dex5
//! client (xr_teleoperate's `Dex5_1_Controller`, the official SDK) drives any device; its codec
//! is [`super::front`]. One front per hand: the served side picks the topic pair
//! ([`super::topics`]).

use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use super::front::{decode_cmd, encode_state};
use super::table::{Conventions, WireConfig};
use crate::front::config::{side_rule, FrontConfig, SideTopics, Silence, TopicKey};
use crate::front::endpoint::{DdsFront, FrontCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::SilencePlan;
use crate::front::serve::{routed, Bound, Routed};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

const NAME: &str = "dex5";

/// unitree_hg `HandCmd_` (20 entries) in, `HandState_` out, for the one bound hand, in the
/// conventions a Dex5 client uses (docs/profiles.md, "Assumptions").
pub struct Dex5FrontCodec(WireConfig);

impl Default for Dex5FrontCodec {
    /// The conventions a Dex5 client uses by default (xr_teleoperate's).
    fn default() -> Self {
        Dex5FrontCodec(WireConfig::of(&Conventions::default()))
    }
}

impl FrontCodec for Dex5FrontCodec {
    type Cmd = HandCmd_;
    type State = HandState_;

    fn decode(&self, bound: &[Bound<'_>], m: &HandCmd_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        Ok(vec![(0, routed(b.route, decode_cmd(m, &b.route.front, &self.0)?))])
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<HandState_> {
        let b = bound.first()?;
        Some(encode_state(&b.route.front, &b.routed_state(), &b.state))
    }
}

/// The Dex5-1 hand service's interface, one hand per front. Its keys: `side` (which hand's
/// topics; default the device's) and the two topics.
#[derive(Debug)]
pub struct Dex5Front;

impl Front for Dex5Front {
    type Config = SideTopics;
    type Wire = DdsFront<Dex5FrontCodec>;
    const KIND: FrontKind = FrontKind::of(&Dex5Front);
    const FACTS: FrontFacts = FrontFacts::serving(NAME, Some(DeviceKind::Dex5));
    /// `rt/dex5/{side}/cmd` and `.../state` ([`super::topics`]); none for center.
    const TOPICS: &'static [TopicKey<SideTopics>] = &[
        TopicKey::cmd_topic(
            |c| c.cmd_topic.as_ref(),
            |_, at| at.side.and_then(super::topics).map(|t| Topic(t.0)),
        ),
        TopicKey::state_topic(
            |c| c.state_topic.as_ref(),
            |_, at| at.side.and_then(super::topics).map(|t| Topic(t.1)),
        ),
    ];

    /// The service's loop (an assumption, docs/profiles.md), whatever the device's rate.
    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        super::SERVICE_HZ
    }
    fn default_name(_c: &SideTopics, _f: &FrontConfig, side: &str) -> String {
        format!("{NAME}_{side}")
    }
    /// Assumed to hold its last command (no timeout: docs/profiles.md, "Assumptions");
    /// `watchdog` mode: the device's watchdog.
    fn silence(mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(c: &SideTopics, _f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        if dangling {
            return vec![];
        }
        side_rule(NAME, served, c.cmd_topic.is_some() && c.state_topic.is_some(), false)
    }
}

impl FrontKind {
    /// The Dex5-1 hand service's DDS interface (`rt/dex5/{side}/*`, one hand per front).
    #[allow(non_upper_case_globals)]
    pub const Dex5: FrontKind = Dex5Front::KIND;
}
