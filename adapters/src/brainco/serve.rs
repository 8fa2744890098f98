//! The BrainCo service front (handgate serving `brainco_hand_service`'s own
//! `rt/brainco/{left,right}/{cmd,state}`, docs/sources.md §7), so an unmodified BrainCo client
//! (xr_teleoperate's `Brainco_Controller`) drives any device: one front per hand, as the
//! service runs one per hand ([`OneHandFront`]); its codec is [`super::front`].

use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};

use super::emulator::BRAINCO_DEFAULT_HZ;
use crate::front::kind::{Front, FrontKind};
use crate::front::one_hand::{HandService, OneHandFront};
use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, HandState, JointState, Side};

/// `brainco_hand_service`'s interface: `MotorCmds_` (6) in, `MotorStates_` (6) out.
#[derive(Debug, Default)]
pub struct BraincoService;

impl HandService for BraincoService {
    const NAME: &'static str = "brainco";
    const SPEAKS: DeviceKind = DeviceKind::Brainco;
    /// Once per loop, 500 Hz (docs/sources.md §7).
    const STATE_HZ: f64 = BRAINCO_DEFAULT_HZ;
    type Cmd = MotorCmds_;
    type State = MotorStates_;

    fn topics(side: Side) -> Option<(String, String)> {
        super::topics(side)
    }
    fn decode(&self, front: &DeviceTable, cmd: &MotorCmds_) -> Result<FrontCommand, Rejection> {
        super::front::decode(cmd, front)
    }
    fn encode(
        &self,
        front: &DeviceTable,
        joints: &[JointState],
        st: &HandState,
        now: std::time::Instant,
    ) -> MotorStates_ {
        super::front::encode(front, joints, st, now)
    }
}

/// The BrainCo front.
pub type BraincoFront = OneHandFront<BraincoService>;

impl FrontKind {
    /// `brainco_hand_service`'s DDS interface (`rt/brainco/{side}/*`, one hand per front).
    #[allow(non_upper_case_globals)]
    pub const Brainco: FrontKind = BraincoFront::KIND;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::config::{FrontConfig, SideTopics};
    use crate::front::kind::testing::{assert_keeps_last_target, assert_registered, topics_at as topics};
    use crate::front::kind::FrontOwn;
    use crate::model::SafeAction;
    use crate::units::Topic;
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
    fn the_services_topics_per_side_and_its_500_hz_whatever_the_device() {
        let f = FrontKind::Brainco.factory();
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
