//! The Inspire DFX service front's registry entry and endpoints (handgate serving
//! DFX_inspire_service's own `rt/inspire/cmd` / `rt/inspire/state`, docs/sources.md §7); its
//! codec is [`super::front`]. ONE front serves both hands: the service's message carries 12
//! entries, 0–5 the right hand (element 0) and 6–11 the left (element 1), bound by element
//! (`devices = { right = "..", left = ".." }`), or one hand with `device` on its side.

use handgate_idl::unitree_go;

use super::front::{decode, encode, UNBOUND_LOST};
use super::{element, CMD_TOPIC, SERVICE_RATE_HZ, STATE_TOPIC};
use crate::front::config::{FrontConfig, Silence};
use crate::front::kind::{FrontFactory, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{reader, routed, Bound, Endpoints, FrontIo, Message, Routed};
use crate::front::Rejection;
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, HandState, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "inspire_dfx"`), the kind's own.
const NAME: &str = "inspire_dfx";

/// The Inspire DFX front's endpoints: `MotorCmds_` (12) in, `MotorStates_` (12) out.
pub struct DfxIo {
    _reader: crate::dds::Reader<unitree_go::MotorCmds_>,
    state: crate::dds::Writer<unitree_go::MotorStates_>,
}

impl DfxIo {
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

impl FrontIo for DfxIo {
    /// The whole message is checked first (12 entries, all finite); then each bound hand gets
    /// its own six entries through its route.
    fn decode(&self, bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
        let Some(m) = msg.downcast_ref::<unitree_go::MotorCmds_>() else {
            return Ok(Vec::new());
        };
        let elems: Vec<(usize, &DeviceTable)> = bound.iter().map(|b| (b.element, &*b.route.front)).collect();
        Ok(decode(m, &elems)?
            .into_iter()
            .zip(bound)
            .enumerate()
            .map(|(i, (c, b))| (i, routed(b.route, c)))
            .collect())
    }

    /// Each bound hand's six entries from its own device's state (in the front's joint order);
    /// an element with no device reads open, never measured.
    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
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
        let _ = self.state.write(encode(&hands, std::time::Instant::now()));
    }
}

/// DFX_inspire_service's interface: both hands on one topic pair.
#[derive(Debug)]
pub struct InspireDfxFront;

impl FrontFactory for InspireDfxFront {
    fn name(&self) -> &'static str {
        NAME
    }
    fn speaks(&self) -> Option<DeviceKind> {
        Some(DeviceKind::InspireDfx)
    }
    /// `side`: which hand (element) a device bound with `device` is served as (default: the
    /// device's side; required for a device of side center).
    fn keys(&self) -> &'static [&'static str] {
        &["side"]
    }
    /// The service's topics whatever the side: one pair carries both hands.
    fn default_topics(
        &self,
        _f: &FrontConfig,
        _lr: Option<Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        (Some(Topic(CMD_TOPIC.into())), Some(Topic(STATE_TOPIC.into())), None)
    }
    /// The service's loop rate (it publishes state once per loop), whatever the device's.
    fn default_state_hz(&self, _device_hz: Option<f64>) -> f64 {
        SERVICE_RATE_HZ
    }
    /// One front serves both hands: named after the interface, not a side.
    fn default_name(&self, _f: &FrontConfig, _side: &str) -> String {
        NAME.into()
    }
    /// The service stops writing targets 1 s after the last command and the hand keeps its
    /// last target (docs/sources.md §7): the device keeps its last target.
    fn silence(&self, mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn elements(&self, _f: &FrontConfig) -> usize {
        2
    }
    fn binds_elements(&self) -> Option<&'static str> {
        Some("an inspire_dfx front")
    }
    /// Element 0 (entries 0–5) right, 1 (6–11) left; a center side has none (refused by
    /// [`Self::validate`]; 0 only so the call is total).
    fn element(&self, _f: &FrontConfig, side: Side) -> usize {
        element(side).unwrap_or(0)
    }
    fn validate(&self, f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
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
    fn describe_unbound(&self, _f: &FrontConfig, bound: &[Side]) -> Vec<String> {
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
    fn clash_hint(&self, f: &FrontConfig, other: &FrontConfig) -> &'static str {
        if other.kind == f.kind {
            ": one inspire_dfx front serves both hands, `devices = { right = \"..\", left = \"..\" }`"
        } else {
            ""
        }
    }
    fn served(&self, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::front::serve::{served_command, served_state};
        vec![
            served_command::<unitree_go::MotorCmds_>(&cmd_topic(f)),
            served_state::<unitree_go::MotorStates_>(&f.state_topic),
        ]
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &FrontPlan,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        Ok(Endpoints::Commands(Box::new(DfxIo::open(
            &env.node,
            &cmd_topic(f),
            &f.state_topic,
            tx,
            dropped,
        )?)))
    }
}

/// The command topic of front `f` (the service's when the plan has none).
fn cmd_topic(f: &FrontPlan) -> String {
    f.cmd_topic.clone().unwrap_or_else(|| CMD_TOPIC.into())
}

impl FrontKind {
    /// DFX_inspire_service's DDS interface (`rt/inspire/*`, both hands in one message).
    #[allow(non_upper_case_globals)]
    pub const InspireDfx: FrontKind = FrontKind::of(&InspireDfxFront);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn cfg(toml_devices: Option<(&str, &str)>, side: Option<Side>) -> FrontConfig {
        FrontConfig {
            kind: FrontKind::InspireDfx,
            devices: toml_devices.map(|(r, l)| {
                crate::front::config::FrontDevices::Elements(crate::front::config::ElementDevices {
                    right: (!r.is_empty()).then(|| crate::units::DeviceName(r.into())),
                    left: (!l.is_empty()).then(|| crate::units::DeviceName(l.into())),
                })
            }),
            side,
            ..Default::default()
        }
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        assert_eq!(FrontKind::by_name("inspire_dfx"), Some(FrontKind::InspireDfx));
        assert!(DeviceKind::InspireDfx
            .factory()
            .fronts()
            .contains(&FrontKind::InspireDfx));
        let f = FrontKind::InspireDfx.factory();
        assert_eq!(f.speaks(), Some(DeviceKind::InspireDfx));
        assert!(f.takes_commands());
        assert_eq!(f.keys(), &["side"]);
        assert_eq!(f.binds_elements(), Some("an inspire_dfx front"));
        assert!(FrontKind::binding_elements().contains("an inspire_dfx front"));
    }

    #[test]
    fn the_services_topics_and_rate_whatever_the_side_or_device() {
        let f = InspireDfxFront;
        for lr in [Some(Side::Left), Some(Side::Right), None] {
            let (c, s, lf) = f.default_topics(&cfg(None, None), lr, "x");
            assert_eq!(c, Some(Topic("rt/inspire/cmd".into())));
            assert_eq!(s, Some(Topic("rt/inspire/state".into())));
            assert_eq!(lf, None);
        }
        assert_eq!(f.default_lf_state_hz(), None);
        // The service publishes once per 10 ms loop, whatever the bound device's rate.
        for d in [None, Some(1000.0), Some(50.0)] {
            assert_eq!(f.default_state_hz(d), 100.0);
        }
        assert_eq!(f.default_name(&cfg(None, None), "left"), "inspire_dfx");
    }

    #[test]
    fn elements_are_right_then_left() {
        let f = InspireDfxFront;
        let c = cfg(Some(("r", "l")), None);
        assert_eq!(f.elements(&c), 2);
        assert_eq!(f.element(&c, Side::Right), 0);
        assert_eq!(f.element(&c, Side::Left), 1);
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_service_or_the_devices_watchdog() {
        let f = InspireDfxFront;
        let dog = (Duration::from_millis(200), SafeAction::Limp);
        let s = f.silence(Silence::Service, dog);
        assert_eq!((s.mode, s.after, s.timeout_bit), (Silence::Service, None, None));
        assert_eq!(s.armed(true), None);
        assert_eq!(s.to_string(), "service: keeps the last target");
        let w = f.silence(Silence::Watchdog, dog);
        assert_eq!((w.mode, w.after, w.timeout_bit), (Silence::Watchdog, Some(dog), None));
        assert_eq!(w.armed(false), Some(dog));
    }

    #[test]
    fn a_center_device_needs_a_side_unless_bound_by_element() {
        let f = InspireDfxFront;
        let p = f.validate(&cfg(None, None), Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.contains("left or a right hand") && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        assert!(
            f.validate(&cfg(None, None), Some(Side::Center), true).is_empty(),
            "dangling: reported already"
        );
        for s in [Side::Left, Side::Right] {
            assert!(f.validate(&cfg(None, Some(s)), Some(s), false).is_empty());
        }
        assert!(f.validate(&cfg(Some(("r", "")), None), None, false).is_empty());
    }

    #[test]
    fn describe_unbound_names_each_missing_hand_and_what_it_reports() {
        let f = InspireDfxFront;
        let both = cfg(Some(("r", "l")), None);
        assert!(f.describe_unbound(&both, &[Side::Right, Side::Left]).is_empty());
        let only_left = cfg(Some(("", "l")), None);
        let lines = f.describe_unbound(&only_left, &[Side::Left]);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("element 0 (right, entries 0-5)"), "{}", lines[0]);
        assert!(
            lines[0].contains("q = 1.0") && lines[0].contains("0xFFFFFFFE"),
            "{}",
            lines[0]
        );
        // One hand bound with `device` (served as the left): the right is unbound.
        let served = cfg(None, Some(Side::Left));
        let lines = f.describe_unbound(&served, &[Side::Left]);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].starts_with("element 0 (right"), "{}", lines[0]);
    }

    #[test]
    fn two_inspire_dfx_fronts_are_told_one_serves_both_hands() {
        let f = InspireDfxFront;
        let a = cfg(None, None);
        assert!(f.clash_hint(&a, &a).contains("one inspire_dfx front serves both hands"));
        let other = FrontConfig::default();
        assert_eq!(f.clash_hint(&a, &other), "");
    }
}
