//! The Inspire DFX service front's registry entry and endpoints (handgate serving
//! DFX_inspire_service's own `rt/inspire/cmd` / `rt/inspire/state`, docs/sources.md §7); its
//! codec is [`super::front`]. ONE front serves both hands: the service's message carries 12
//! entries, 0–5 the right hand (element 0) and 6–11 the left (element 1), bound by element
//! (`devices = { right = "..", left = ".." }`), or one hand with `device` on its side.

use handgate_idl::unitree_go;

use super::front::{decode, encode, UNBOUND_LOST};
use super::{element, CMD_TOPIC, SERVICE_RATE_HZ, STATE_TOPIC};
use crate::front::config::{FrontConfig, SideTopics, Silence, TopicKey};
use crate::front::endpoint::{DdsFront, FrontCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::SilencePlan;
use crate::front::serve::{elements, routed_each, Bound, Routed};
use crate::front::Rejection;
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, HandState, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "inspire_dfx"`), the kind's own.
const NAME: &str = "inspire_dfx";

/// `MotorCmds_` (12) in, `MotorStates_` (12) out, each bound hand on its element.
#[derive(Default)]
pub struct DfxCodec;

impl FrontCodec for DfxCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    /// The whole message is checked first (12 entries, all finite); then each bound hand gets
    /// its own six entries through its route.
    fn decode(&self, bound: &[Bound<'_>], m: &unitree_go::MotorCmds_) -> Result<Vec<(usize, Routed)>, Rejection> {
        Ok(routed_each(bound, decode(m, &elements(bound))?))
    }

    /// Each bound hand's six entries from its own device's state (in the front's joint order);
    /// an element with no device reads open, never measured.
    fn encode(&self, bound: &[Bound<'_>]) -> Option<unitree_go::MotorStates_> {
        let states: Vec<HandState> = bound
            .iter()
            .map(|b| HandState {
                joints: b.routed_state(),
                ..b.state.clone()
            })
            .collect();
        let hands: Vec<(usize, &DeviceTable, &HandState)> = bound
            .iter()
            .zip(&states)
            .map(|(b, s)| (b.element, &*b.route.front, s))
            .collect();
        Some(encode(&hands, std::time::Instant::now()))
    }
}

/// DFX_inspire_service's interface: both hands on one topic pair. Its keys: `side`, which
/// hand (element) a device bound with `device` is served as (default: the device's side;
/// required for a device of side center), and the two topics.
#[derive(Debug)]
pub struct InspireDfxFront;

impl Front for InspireDfxFront {
    type Config = SideTopics;
    type Wire = DdsFront<DfxCodec>;
    const KIND: FrontKind = FrontKind::of(&InspireDfxFront);
    const FACTS: FrontFacts = FrontFacts {
        binds_elements: Some("an inspire_dfx front"),
        ..FrontFacts::serving(NAME, Some(DeviceKind::InspireDfx))
    };
    /// The service's topics whatever the side: one pair carries both hands.
    const TOPICS: &'static [TopicKey<SideTopics>] = &[
        TopicKey::cmd_topic(|c| c.cmd_topic.as_ref(), |_, _| Some(Topic(CMD_TOPIC.into()))),
        TopicKey::state_topic(|c| c.state_topic.as_ref(), |_, _| Some(Topic(STATE_TOPIC.into()))),
    ];

    /// The service's loop rate (it publishes state once per loop), whatever the device's.
    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        SERVICE_RATE_HZ
    }
    /// One front serves both hands: named after the interface, not a side.
    fn default_name(_c: &SideTopics, _f: &FrontConfig, _side: &str) -> String {
        NAME.into()
    }
    /// The service stops writing targets 1 s after the last command and the hand keeps its
    /// last target (docs/sources.md §7): the device keeps its last target.
    fn silence(mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn elements(_c: &SideTopics) -> usize {
        2
    }
    /// Element 0 (entries 0–5) right, 1 (6–11) left; a center side has none (refused by
    /// [`Front::validate`]; 0 only so the call is total).
    fn element(_c: &SideTopics, side: Side) -> usize {
        element(side).unwrap_or(0)
    }
    fn validate(_c: &SideTopics, f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        if dangling || f.devices.is_some() || served != Some(Side::Center) {
            return vec![];
        }
        vec![(
            "side",
            format!(
                "an {NAME} front serves a left or a right hand (its message has entries 0-5 right, 6-11 left); set `side` (the device's side is center), or bind with `devices = {{ right = \"..\", left = \"..\" }}`"
            ),
        )]
    }
    /// `bound`: the served sides of the bound devices (a `device` binding's is its `side`).
    fn describe_unbound(_c: &SideTopics, bound: &[Side]) -> Vec<String> {
        [(0, Side::Right), (1, Side::Left)]
            .into_iter()
            .filter(|(_, side)| !bound.contains(side))
            .map(|(e, side)| {
                let first = e * super::HAND_ENTRIES;
                format!(
                    "element {e} ({side}, entries {first}-{}): no device bound; reported open (q = 1.0) and never measured (lost {UNBOUND_LOST:#X}, reserve[1] = 1), its commands ignored",
                    first + super::HAND_ENTRIES - 1
                )
            })
            .collect()
    }
    fn clash_hint(_c: &SideTopics, other: Option<&SideTopics>) -> &'static str {
        match other {
            Some(_) => ": one inspire_dfx front serves both hands, `devices = { right = \"..\", left = \"..\" }`",
            None => "",
        }
    }
}

impl FrontKind {
    /// DFX_inspire_service's DDS interface (`rt/inspire/*`, both hands in one message).
    #[allow(non_upper_case_globals)]
    pub const InspireDfx: FrontKind = InspireDfxFront::KIND;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::config::{TopicAt, TopicRole};
    use crate::front::kind::testing::{assert_keeps_last_target, assert_registered};
    use crate::front::kind::{FrontFactory, FrontOwn};
    use std::time::Duration;

    fn cfg(toml_devices: Option<(&str, &str)>, side: Option<Side>) -> FrontConfig {
        FrontConfig {
            own: FrontOwn::new::<InspireDfxFront>(SideTopics {
                side,
                ..Default::default()
            }),
            devices: toml_devices.map(|(r, l)| {
                crate::front::config::FrontDevices::Elements(crate::front::config::ElementDevices {
                    right: (!r.is_empty()).then(|| crate::units::DeviceName(r.into())),
                    left: (!l.is_empty()).then(|| crate::units::DeviceName(l.into())),
                })
            }),
            ..Default::default()
        }
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        let keys = ["side", "cmd_topic", "state_topic"];
        let binds = Some("an inspire_dfx front");
        assert_registered(
            FrontKind::InspireDfx,
            "inspire_dfx",
            DeviceKind::InspireDfx,
            &keys,
            binds,
        );
        assert!(FrontKind::binding_elements().contains("an inspire_dfx front"));
    }

    #[test]
    fn the_services_topics_and_rate_whatever_the_side_or_device() {
        let f = InspireDfxFront;
        for lr in [Some(Side::Left), Some(Side::Right), None] {
            let t: Vec<_> = cfg(None, None)
                .kind_topics(&TopicAt { side: lr, device: "x" })
                .into_iter()
                .map(|t| (t.role, t.topic))
                .collect();
            assert_eq!(
                t,
                [
                    (TopicRole::Command, Some(Topic("rt/inspire/cmd".into()))),
                    (TopicRole::State, Some(Topic("rt/inspire/state".into())))
                ]
            );
        }
        assert_eq!(cfg(None, None).lf_state_hz(), None);
        // The service publishes once per 10 ms loop, whatever the bound device's rate.
        for d in [None, Some(1000.0), Some(50.0)] {
            assert_eq!(f.default_state_hz(d), 100.0);
        }
        assert_eq!(cfg(None, None).default_name("left"), "inspire_dfx");
    }

    #[test]
    fn elements_are_right_then_left() {
        let c = cfg(Some(("r", "l")), None);
        assert_eq!(c.elements(), 2);
        assert_eq!(c.element(Side::Right), 0);
        assert_eq!(c.element(Side::Left), 1);
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_service_or_the_devices_watchdog() {
        assert_keeps_last_target(FrontKind::InspireDfx, (Duration::from_millis(200), SafeAction::Limp));
    }

    #[test]
    fn a_center_device_needs_a_side_unless_bound_by_element() {
        let p = cfg(None, None).validate_own(Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.contains("left or a right hand") && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        assert!(
            cfg(None, None).validate_own(Some(Side::Center), true).is_empty(),
            "dangling: reported already"
        );
        for s in [Side::Left, Side::Right] {
            assert!(cfg(None, Some(s)).validate_own(Some(s), false).is_empty());
        }
        assert!(cfg(Some(("r", "")), None).validate_own(None, false).is_empty());
    }

    #[test]
    fn describe_unbound_names_each_missing_hand_and_what_it_reports() {
        let both = cfg(Some(("r", "l")), None);
        assert!(both.describe_unbound(&[Side::Right, Side::Left]).is_empty());
        let only_left = cfg(Some(("", "l")), None);
        let lines = only_left.describe_unbound(&[Side::Left]);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("element 0 (right, entries 0-5)"), "{}", lines[0]);
        assert!(
            lines[0].contains("q = 1.0") && lines[0].contains("0xFFFFFFFE"),
            "{}",
            lines[0]
        );
        // One hand bound with `device` (served as the left): the right is unbound.
        let served = cfg(None, Some(Side::Left));
        let lines = served.describe_unbound(&[Side::Left]);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("element 0 (right"), "{}", lines[0]);
    }

    #[test]
    fn two_inspire_dfx_fronts_are_told_one_serves_both_hands() {
        let a = cfg(None, None);
        assert!(a.clash_hint(&a).contains("one inspire_dfx front serves both hands"));
        let other = FrontConfig::default();
        assert_eq!(a.clash_hint(&other), "");
    }
}
