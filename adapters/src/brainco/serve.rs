//! The BrainCo service front's registry entry and endpoints (handgate serving
//! `brainco_hand_service`'s own `rt/brainco/{left,right}/{cmd,state}`, docs/sources.md §7), so
//! an unmodified BrainCo client (xr_teleoperate's `Brainco_Controller`) drives any device; its
//! codec is [`super::front`]. One front per hand, as the service runs one per hand: the
//! served side picks the topic pair ([`super::topics`]).

use handgate_idl::unitree_go;

use super::emulator::BRAINCO_DEFAULT_HZ;
use super::front::{decode, encode};
use crate::front::config::{side_rule, FrontConfig, SideTopics, Silence, TopicKey};
use crate::front::endpoint::{DdsFront, FrontCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::SilencePlan;
use crate::front::serve::{routed, Bound, Routed};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "brainco"`), the kind's own.
const NAME: &str = "brainco";

/// `MotorCmds_` (6) in, `MotorStates_` (6) out, for the one bound hand.
#[derive(Default)]
pub struct BraincoCodec;

impl FrontCodec for BraincoCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    /// The one bound hand's six entries through its route (a bad message is rejected whole by
    /// the codec).
    fn decode(&self, bound: &[Bound<'_>], m: &unitree_go::MotorCmds_) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(b) = bound.first() else {
            return Ok(Vec::new());
        };
        Ok(vec![(0, routed(b.route, decode(m, &b.route.front)?))])
    }

    /// Six entries in wire order from the bound device's state (in the front's joint order).
    fn encode(&self, bound: &[Bound<'_>]) -> Option<unitree_go::MotorStates_> {
        let b = bound.first()?;
        Some(encode(
            &b.route.front,
            &b.routed_state(),
            &b.state,
            std::time::Instant::now(),
        ))
    }
}

/// `brainco_hand_service`'s interface, one hand per front. Its keys: `side`, which hand's
/// topics a device is served on (default: the device's side; required for a device of side
/// center unless both topics are given), and the two topics.
#[derive(Debug)]
pub struct BraincoFront;

impl Front for BraincoFront {
    type Config = SideTopics;
    type Wire = DdsFront<BraincoCodec>;
    const KIND: FrontKind = FrontKind::of(&BraincoFront);
    const FACTS: FrontFacts = FrontFacts::serving(NAME, Some(DeviceKind::Brainco));
    /// `rt/brainco/{side}/cmd` and `.../state` ([`super::topics`]); none for center.
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

    /// The service publishes state once per loop, 500 Hz (docs/sources.md §7), whatever the
    /// bound device's rate.
    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        BRAINCO_DEFAULT_HZ
    }
    fn default_name(_c: &SideTopics, _f: &FrontConfig, side: &str) -> String {
        format!("{NAME}_{side}")
    }
    /// The service has no command timeout: it re-sends the last command to the hand forever
    /// (docs/sources.md §7), so the device keeps its last target; `watchdog` mode: the
    /// device's watchdog.
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
    /// `brainco_hand_service`'s DDS interface (`rt/brainco/{side}/*`, one hand per front).
    #[allow(non_upper_case_globals)]
    pub const Brainco: FrontKind = BraincoFront::KIND;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::kind::testing::{assert_keeps_last_target, assert_registered, topics_at as topics};
    use crate::front::kind::{FrontFactory, FrontOwn};
    use std::time::Duration;

    fn cfg(side: Option<Side>, topics: bool) -> FrontConfig {
        FrontConfig {
            own: FrontOwn::new::<BraincoFront>(SideTopics {
                side,
                cmd_topic: topics.then(|| Topic("my/cmd".into())),
                state_topic: topics.then(|| Topic("my/state".into())),
            }),
            ..Default::default()
        }
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        let keys = ["side", "cmd_topic", "state_topic"];
        assert_registered(FrontKind::Brainco, "brainco", DeviceKind::Brainco, &keys, None);
        assert_eq!(DeviceKind::Brainco.factory().fronts(), &[FrontKind::Brainco]);
        assert_eq!(cfg(None, false).elements(), 1);
    }

    #[test]
    fn the_services_topics_per_side_and_its_100_hz_whatever_the_device() {
        let f = BraincoFront;
        for (side, s) in [(Side::Left, "left"), (Side::Right, "right")] {
            assert_eq!(
                topics(&cfg(None, false), Some(side)),
                [
                    ("cmd_topic", Some(Topic(format!("rt/brainco/{s}/cmd")))),
                    ("state_topic", Some(Topic(format!("rt/brainco/{s}/state"))))
                ]
            );
            assert_eq!(cfg(None, false).default_name(s), format!("brainco_{s}"));
        }
        assert_eq!(
            topics(&cfg(None, false), None),
            [("cmd_topic", None), ("state_topic", None)]
        );
        assert_eq!(
            topics(&cfg(None, true), None),
            [
                ("cmd_topic", Some(Topic("my/cmd".into()))),
                ("state_topic", Some(Topic("my/state".into())))
            ]
        );
        assert_eq!(cfg(None, false).lf_state_hz(), None);
        for d in [None, Some(1000.0), Some(30.0)] {
            assert_eq!(f.default_state_hz(d), 500.0);
        }
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_service_or_the_devices_watchdog() {
        assert_keeps_last_target(FrontKind::Brainco, (Duration::from_millis(300), SafeAction::Hold));
    }

    #[test]
    fn a_center_device_needs_a_side_or_both_topics() {
        let p = cfg(None, false).validate_own(Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.starts_with("a brainco front serves side left or right") && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        assert!(cfg(None, false).validate_own(Some(Side::Center), true).is_empty());
        assert!(cfg(None, true).validate_own(Some(Side::Center), false).is_empty());
        for s in [Side::Left, Side::Right] {
            assert!(cfg(Some(s), false).validate_own(Some(s), false).is_empty());
        }
    }
}
