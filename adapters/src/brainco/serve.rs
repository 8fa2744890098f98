//! The BrainCo service front's registry entry and endpoints (handgate serving
//! `brainco_hand_service`'s own `rt/brainco/{left,right}/{cmd,state}`, docs/sources.md §7), so
//! an unmodified BrainCo client (xr_teleoperate's `Brainco_Controller`) drives any device; its
//! codec is [`super::front`]. One front per hand, as the service runs one per hand: the
//! served side picks the topic pair ([`super::topics`]).

use handgate_idl::unitree_go;

use super::emulator::BRAINCO_DEFAULT_HZ;
use super::front::{decode, encode};
use crate::front::config::{FrontConfig, Silence};
use crate::front::kind::{FrontFactory, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{reader, routed, Bound, Endpoints, FrontIo, Message, Routed};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "brainco"`), the kind's own.
const NAME: &str = "brainco";

/// The BrainCo front's endpoints: `MotorCmds_` (6) in, `MotorStates_` (6) out.
pub struct BraincoIo {
    _reader: crate::dds::Reader<unitree_go::MotorCmds_>,
    state: crate::dds::Writer<unitree_go::MotorStates_>,
}

impl BraincoIo {
    pub fn open(
        node: &crate::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, crate::dds::DdsError> {
        Ok(Self {
            _reader: reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, crate::front::serve::STATE_QOS)?,
        })
    }
}

impl FrontIo for BraincoIo {
    /// The one bound hand's six entries through its route (a bad message is rejected whole by
    /// the codec).
    fn decode(&self, bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
        let (Some(m), Some(b)) = (msg.downcast_ref::<unitree_go::MotorCmds_>(), bound.first()) else {
            return Ok(Vec::new());
        };
        let c = decode(m, &b.route.front)?;
        Ok(vec![(0, routed(b.route, c))])
    }

    /// Six entries in wire order from the bound device's state (in the front's joint order).
    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        let Some(b) = bound.first() else {
            return;
        };
        let msg = encode(&b.route.front, &b.routed_state(), &b.state, std::time::Instant::now());
        let _ = self.state.write(msg);
    }
}

/// `brainco_hand_service`'s interface, one hand per front.
#[derive(Debug)]
pub struct BraincoFront;

impl FrontFactory for BraincoFront {
    fn name(&self) -> &'static str {
        NAME
    }
    fn speaks(&self) -> Option<DeviceKind> {
        Some(DeviceKind::Brainco)
    }
    /// `side`: which hand's topics a device is served on (default: the device's side;
    /// required for a device of side center unless both topics are given).
    fn keys(&self) -> &'static [&'static str] {
        &["side"]
    }
    /// `rt/brainco/{side}/cmd` and `.../state` ([`super::topics`]); none for center.
    fn default_topics(
        &self,
        _f: &FrontConfig,
        lr: Option<Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        let std = lr.and_then(super::topics);
        (std.as_ref().map(|t| Topic(t.0.clone())), std.map(|t| Topic(t.1)), None)
    }
    /// The service publishes state once per loop, 500 Hz (docs/sources.md §7), whatever the
    /// bound device's rate.
    fn default_state_hz(&self, _device_hz: Option<f64>) -> f64 {
        BRAINCO_DEFAULT_HZ
    }
    fn default_name(&self, _f: &FrontConfig, side: &str) -> String {
        format!("{NAME}_{side}")
    }
    /// The service has no command timeout: it re-sends the last command to the hand forever
    /// (docs/sources.md §7), so the device keeps its last target; `watchdog` mode: the
    /// device's watchdog.
    fn silence(&self, mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(&self, f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        if dangling {
            return vec![];
        }
        let given = f.cmd_topic.is_some() && f.state_topic.is_some();
        crate::dex3::serve::side_rule(NAME, served, given, false)
    }
    fn served(&self, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::front::serve::{served_command, served_state};
        let mut out = Vec::new();
        if let Some(cmd) = &f.cmd_topic {
            out.push(served_command::<unitree_go::MotorCmds_>(cmd));
        }
        out.push(served_state::<unitree_go::MotorStates_>(&f.state_topic));
        out
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &FrontPlan,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        Ok(Endpoints::Commands(Box::new(BraincoIo::open(
            &env.node,
            &cmd,
            &f.state_topic,
            tx,
            dropped,
        )?)))
    }
}

impl FrontKind {
    /// `brainco_hand_service`'s DDS interface (`rt/brainco/{side}/*`, one hand per front).
    #[allow(non_upper_case_globals)]
    pub const Brainco: FrontKind = FrontKind::of(&BraincoFront);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn cfg(side: Option<Side>, topics: bool) -> FrontConfig {
        FrontConfig {
            kind: FrontKind::Brainco,
            side,
            cmd_topic: topics.then(|| Topic("my/cmd".into())),
            state_topic: topics.then(|| Topic("my/state".into())),
            ..Default::default()
        }
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        assert_eq!(FrontKind::by_name("brainco"), Some(FrontKind::Brainco));
        assert_eq!(DeviceKind::Brainco.factory().fronts(), &[FrontKind::Brainco]);
        let f = FrontKind::Brainco.factory();
        assert_eq!(f.speaks(), Some(DeviceKind::Brainco));
        assert!(f.takes_commands());
        assert_eq!(f.keys(), &["side"]);
        assert_eq!(f.binds_elements(), None);
        assert_eq!(f.elements(&cfg(None, false)), 1);
    }

    #[test]
    fn the_services_topics_per_side_and_its_100_hz_whatever_the_device() {
        let f = BraincoFront;
        for (side, s) in [(Side::Left, "left"), (Side::Right, "right")] {
            let (c, st, lf) = f.default_topics(&cfg(None, false), Some(side), "x");
            assert_eq!(c, Some(Topic(format!("rt/brainco/{s}/cmd"))));
            assert_eq!(st, Some(Topic(format!("rt/brainco/{s}/state"))));
            assert_eq!(lf, None);
            assert_eq!(f.default_name(&cfg(None, false), s), format!("brainco_{s}"));
        }
        assert_eq!(f.default_topics(&cfg(None, false), None, "x"), (None, None, None));
        assert_eq!(f.default_lf_state_hz(), None);
        for d in [None, Some(1000.0), Some(30.0)] {
            assert_eq!(f.default_state_hz(d), 500.0);
        }
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_service_or_the_devices_watchdog() {
        let f = BraincoFront;
        let dog = (Duration::from_millis(300), SafeAction::Hold);
        let s = f.silence(Silence::Service, dog);
        assert_eq!((s.mode, s.after, s.timeout_bit), (Silence::Service, None, None));
        assert_eq!(s.armed(true), None);
        assert_eq!(s.to_string(), "service: keeps the last target");
        let w = f.silence(Silence::Watchdog, dog);
        assert_eq!((w.mode, w.after, w.timeout_bit), (Silence::Watchdog, Some(dog), None));
        assert_eq!(w.armed(false), Some(dog));
    }

    #[test]
    fn a_center_device_needs_a_side_or_both_topics() {
        let f = BraincoFront;
        let p = f.validate(&cfg(None, false), Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.starts_with("a brainco front serves side left or right") && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        assert!(f.validate(&cfg(None, false), Some(Side::Center), true).is_empty());
        assert!(f.validate(&cfg(None, true), Some(Side::Center), false).is_empty());
        for s in [Side::Left, Side::Right] {
            assert!(f.validate(&cfg(Some(s), false), Some(s), false).is_empty());
        }
    }
}
