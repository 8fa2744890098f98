//! The Inspire FTP front's registry entry and endpoints: handgate serving Inspire's DDS driver's
//! own interface for one hand (`rt/inspire_hand/ctrl/{l,r}` in, `rt/inspire_hand/state/{l,r}`
//! and `rt/inspire_hand/touch/{l,r}` out; docs/sources.md §7), so an unmodified client of the
//! driver (xr_teleoperate's `Inspire_Controller_FTP`) drives any device of the fleet. Its codec
//! is [`super::front`]. One front per hand, like the driver (one instance per hand, its `LR`
//! argument): the served side picks the topics.
//!
//! Touch: the third writer publishes `inspire_hand_touch` only when the bound device is an
//! Inspire FTP hand with its tactile pads (its transport carries them); any other device
//! publishes nothing there, as the driver over RS-485 does. Its topic is the served side's
//! standard one unless `touch_topic` sets another.

use handgate_idl::inspire::{InspireHandCtrl, InspireHandState, InspireHandTouch};

use super::emulator::FtpTransport;
use super::front::{decode, encode_state, encode_touch, topics, CTRL_TOPIC_PREFIX, STATE_TOPIC_PREFIX};
use crate::front::config::{FrontConfig, Silence, TopicAt, TopicKey, TopicRole};
use crate::front::endpoint::{DdsFront, FrontCodec, OpenCodec};
use crate::front::kind::{Front, FrontFacts, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{routed, served_state, Bound, FrontEnv, Routed, STATE_QOS};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "inspire_ftp"`), the kind's own.
const NAME: &str = "inspire_ftp";

crate::side_topics_config! {
    /// The Inspire FTP front's own keys: `side` picks the hand's topics (`/l`, `/r`), table
    /// and touch topic (default: the device's side; required for a device of side center).
    pub struct FtpFrontConfig {
        /// Where the touch message goes (default: the served side's
        /// `rt/inspire_hand/touch/{l,r}`).
        pub touch_topic: Option<Topic>,
    }
}

/// The driver's topic of the served side (`which` picks it out of the three); none for a
/// side-less device (refused by validation).
fn driver_topic(at: &TopicAt<'_>, which: fn((String, String, String)) -> String) -> Option<Topic> {
    match at.side {
        Some(s @ (Side::Left | Side::Right)) => Some(Topic(which(topics(s)))),
        _ => None,
    }
}

/// `inspire_hand_ctrl` in, `inspire_hand_state` out for the bound hand, and its
/// `inspire_hand_touch` beside the state.
pub struct FtpCodec {
    touch: crate::dds::Writer<InspireHandTouch>,
}

/// The touch message of a bound device: only an Inspire tactile hand's own pads (an Inspire
/// FTP through its driver, an RH56DFTP driven directly: the same 17 named pads).
fn touch_of(b: &Bound<'_>) -> Option<InspireHandTouch> {
    if b.route.device.kind != DeviceKind::InspireFtp && b.route.device.kind != DeviceKind::InspireRh56 {
        return None;
    }
    encode_touch(&b.state.pads)
}

/// Decodes one `inspire_hand_ctrl` for the bound hand. The driver's no operation (mode 0,
/// force / speed only, every angle −1) is no command at all for the device: an empty list,
/// never a closure 0.
pub fn decode_bound(bound: &[Bound<'_>], m: &InspireHandCtrl) -> Result<Vec<(usize, Routed)>, Rejection> {
    let Some(b0) = bound.first() else {
        return Ok(Vec::new());
    };
    Ok(decode(m, &b0.route.front)?
        .map(|c| vec![(0, routed(b0.route, c))])
        .unwrap_or_default())
}

/// Its touch writer, on the plan's `touch_topic`.
impl OpenCodec for FtpCodec {
    fn open(env: &FrontEnv, plan: &FrontPlan) -> Result<Self, crate::dds::DdsError> {
        let touch = plan.topic("touch_topic").unwrap_or_default();
        Ok(FtpCodec {
            touch: env.node.writer(touch, STATE_QOS)?,
        })
    }
}

impl FrontCodec for FtpCodec {
    type Cmd = InspireHandCtrl;
    type State = InspireHandState;

    fn decode(&self, bound: &[Bound<'_>], m: &InspireHandCtrl) -> Result<Vec<(usize, Routed)>, Rejection> {
        decode_bound(bound, m)
    }

    fn encode(&self, bound: &[Bound<'_>]) -> Option<InspireHandState> {
        let b0 = bound.first()?;
        Some(encode_state(&b0.route.front, &b0.routed_state(), b0.state))
    }

    fn beside(&mut self, bound: &[Bound<'_>]) {
        let _ = self.touch.write_with(|| bound.first().and_then(touch_of));
    }

    /// The command reader and state writer, then the touch writer.
    fn served(plan: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        let mut out = DdsFront::<Self>::endpoints(plan);
        out.extend(plan.topic("touch_topic").map(served_state::<InspireHandTouch>));
        out
    }
}

/// Inspire's DDS driver's interface for one hand.
#[derive(Debug)]
pub struct InspireFtpFront;

impl Front for InspireFtpFront {
    type Config = FtpFrontConfig;
    type Wire = DdsFront<FtpCodec>;
    const KIND: FrontKind = FrontKind::of(&InspireFtpFront);
    const FACTS: FrontFacts = FrontFacts::serving(NAME, Some(DeviceKind::InspireFtp));
    /// The driver's topics of the served side.
    const TOPICS: &'static [TopicKey<FtpFrontConfig>] = &[
        TopicKey::cmd_topic(|c| c.cmd_topic.as_ref(), |_, at| driver_topic(at, |t| t.0)),
        TopicKey::state_topic(|c| c.state_topic.as_ref(), |_, at| driver_topic(at, |t| t.1)),
        TopicKey {
            key: "touch_topic",
            role: TopicRole::Beside,
            set: |c| c.touch_topic.as_ref(),
            default: |_, at| driver_topic(at, |t| t.2),
        },
    ];

    /// The driver's loop over Modbus TCP (assumed 50 Hz, [`FtpTransport::rate`]), whatever
    /// the device's rate.
    fn default_state_hz(_device_hz: Option<f64>) -> f64 {
        FtpTransport::Tcp.rate().0
    }
    fn default_name(_c: &FtpFrontConfig, _f: &FrontConfig, side: &str) -> String {
        format!("{NAME}_{side}")
    }
    /// The driver has no timeout: the hand keeps its last target (docs/sources.md §7).
    fn silence(mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(
        _c: &FtpFrontConfig,
        _f: &FrontConfig,
        served: Option<Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        if dangling || served != Some(Side::Center) {
            return vec![];
        }
        vec![(
            "side",
            format!(
                "an {NAME} front serves a left or a right hand (its topics are {CTRL_TOPIC_PREFIX}/{{l,r}}, {STATE_TOPIC_PREFIX}/{{l,r}}); set `side` (the device's side is center): it picks the topics, the touch topic and the convention"
            ),
        )]
    }
    /// The touch topic (`describe` is given the front's own keys only: with neither
    /// `touch_topic` nor `side`, the served side is the device's, named as `{l,r}`).
    fn describe(c: &FtpFrontConfig) -> Option<String> {
        let touch = match (&c.touch_topic, c.side) {
            (Some(t), _) => t.0.clone(),
            (None, Some(s @ (Side::Left | Side::Right))) => topics(s).2,
            _ => format!("{}/{{l,r}} (the served side)", super::front::TOUCH_TOPIC_PREFIX),
        };
        Some(format!(
            ", touch {touch} from an inspire_ftp or inspire_rh56 device with tactile pads"
        ))
    }
}

impl FrontKind {
    /// Inspire's DDS driver's interface for one hand (`rt/inspire_hand/*/{l,r}`).
    #[allow(non_upper_case_globals)]
    pub const InspireFtp: FrontKind = InspireFtpFront::KIND;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::kind::testing::{assert_keeps_last_target, assert_registered, topics_at};
    use crate::front::kind::{FrontFactory, FrontOwn};
    use std::sync::Arc;
    use std::time::Duration;

    use crate::mapping::TableOverrides;
    use crate::model::{HandState, Pad};
    use crate::route::Route;
    use handgate_idl::inspire::{MODE_ANGLE, MODE_FORCE};

    fn own(c: FtpFrontConfig) -> FrontConfig {
        FrontConfig {
            own: FrontOwn::new::<InspireFtpFront>(c),
            ..Default::default()
        }
    }

    fn cfg(side: Option<Side>) -> FrontConfig {
        own(FtpFrontConfig {
            side,
            ..Default::default()
        })
    }

    fn route(device: DeviceKind, side: Side) -> Route {
        let front = Arc::new(DeviceKind::InspireFtp.table(side, &TableOverrides::default()).unwrap());
        let dev = Arc::new(device.table(side, &TableOverrides::default()).unwrap());
        Route::bind(front, dev)
    }

    fn bound<'a>(route: &'a Route, state: &'a HandState) -> Bound<'a> {
        Bound {
            route,
            element: 0,
            device: "hand",
            safe_action: SafeAction::Limp,
            state,
        }
    }

    fn ctrl(mode: i8, angle: Vec<i16>) -> InspireHandCtrl {
        InspireHandCtrl {
            angle_set: angle,
            mode,
            ..InspireHandCtrl::sdk_default()
        }
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        let keys = ["side", "cmd_topic", "state_topic", "touch_topic"];
        assert_registered(
            FrontKind::InspireFtp,
            "inspire_ftp",
            DeviceKind::InspireFtp,
            &keys,
            None,
        );
        assert_eq!(cfg(None).elements(), 1);
    }

    #[test]
    fn the_drivers_topics_of_the_served_side_and_its_rate() {
        let f = InspireFtpFront;
        let t = |s: &str| Some(Topic(s.into()));
        assert_eq!(
            topics_at(&cfg(None), Some(Side::Left)),
            [
                ("cmd_topic", t("rt/inspire_hand/ctrl/l")),
                ("state_topic", t("rt/inspire_hand/state/l")),
                ("touch_topic", t("rt/inspire_hand/touch/l"))
            ]
        );
        assert_eq!(
            topics_at(&cfg(None), Some(Side::Right)),
            [
                ("cmd_topic", t("rt/inspire_hand/ctrl/r")),
                ("state_topic", t("rt/inspire_hand/state/r")),
                ("touch_topic", t("rt/inspire_hand/touch/r"))
            ]
        );
        let none = [("cmd_topic", None), ("state_topic", None), ("touch_topic", None)];
        assert_eq!(topics_at(&cfg(None), Some(Side::Center)), none);
        assert_eq!(topics_at(&cfg(None), None), none);
        // The touch topic is a key of its own.
        let moved = own(FtpFrontConfig {
            touch_topic: Some(Topic("rt/x/touch".into())),
            ..Default::default()
        });
        assert_eq!(topics_at(&moved, Some(Side::Left))[2], ("touch_topic", t("rt/x/touch")));
        assert_eq!(
            moved.describe().unwrap(),
            ", touch rt/x/touch from an inspire_ftp or inspire_rh56 device with tactile pads"
        );
        assert_eq!(cfg(None).lf_state_hz(), None);
        // The driver publishes once per loop (assumed 50 Hz), whatever the bound device's rate.
        for d in [None, Some(1000.0), Some(20.0)] {
            assert_eq!(f.default_state_hz(d), 50.0);
        }
        assert_eq!(cfg(None).default_name("left"), "inspire_ftp_left");
        let d = cfg(Some(Side::Left)).describe().unwrap();
        assert_eq!(
            d,
            ", touch rt/inspire_hand/touch/l from an inspire_ftp or inspire_rh56 device with tactile pads"
        );
        let d = cfg(None).describe().unwrap();
        assert!(d.contains("rt/inspire_hand/touch/{l,r} (the served side)"), "{d}");
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_driver_or_the_devices_watchdog() {
        assert_keeps_last_target(FrontKind::InspireFtp, (Duration::from_millis(200), SafeAction::Limp));
    }

    #[test]
    fn a_center_device_needs_a_side() {
        let p = cfg(None).validate_own(Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.contains("left or a right hand")
                && p[0].1.contains("rt/inspire_hand/ctrl/{l,r}")
                && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        let given = own(FtpFrontConfig {
            cmd_topic: Some(Topic("rt/x/cmd".into())),
            state_topic: Some(Topic("rt/x/state".into())),
            ..Default::default()
        });
        // Topics given or not: the side still picks the touch topic and the convention.
        let p = given.validate_own(Some(Side::Center), false);
        assert!(p.len() == 1 && p[0].1.contains("touch topic"), "{p:?}");
        assert!(cfg(None).validate_own(Some(Side::Center), true).is_empty(), "dangling");
        for s in [Side::Left, Side::Right] {
            assert!(cfg(Some(s)).validate_own(Some(s), false).is_empty());
        }
    }

    #[test]
    fn decode_routes_angles_and_a_no_operation_commands_nothing() {
        let r = route(DeviceKind::InspireFtp, Side::Left);
        let empty = HandState::empty(6);
        let b = [bound(&r, &empty)];
        // Every finger its own angle; 1000 = open = canonical 0, 0 = closed = the upper limit.
        let out = decode_bound(&b, &ctrl(MODE_ANGLE, vec![0, 250, 500, 750, 1000, 1000])).unwrap();
        assert_eq!(out.len(), 1);
        let (body, tag, bit) = &out[0].1;
        assert_eq!((*tag, *bit), (0, false));
        let crate::model::CommandBody::Joints(js) = body else {
            panic!("{body:?}")
        };
        assert_eq!(js.len(), 6, "{js:?}");
        let want = [1.7, 1.275, 0.85, 0.425, 0.0, -0.1];
        for (id, j) in js {
            assert!((j.q - want[id.index()]).abs() < 1e-4, "{js:?}");
        }
        for m in [
            ctrl(0, vec![0; 6]),
            ctrl(MODE_FORCE, vec![0; 6]),
            ctrl(MODE_ANGLE, vec![-1; 6]),
        ] {
            assert!(decode_bound(&b, &m).unwrap().is_empty(), "no operation");
        }
        assert_eq!(
            decode_bound(&b, &ctrl(MODE_ANGLE, vec![0; 5])).unwrap_err(),
            Rejection::WrongCount { got: 5, want: 6 }
        );
    }

    #[test]
    fn touch_only_from_an_inspire_ftp_device_with_pads() {
        let pad = |name: &str| Pad {
            name: name.into(),
            rows: 3,
            cols: 3,
            pressure: vec![7.0; 9],
            temperature: Vec::new(),
        };
        let ftp = route(DeviceKind::InspireFtp, Side::Left);
        let with = HandState {
            pads: vec![pad("index_tip")],
            ..HandState::empty(6)
        };
        let t = touch_of(&bound(&ftp, &with)).expect("an FTP hand's pads");
        assert_eq!(t.fingerfour_tip_touch, vec![7; 9]);
        assert_eq!(touch_of(&bound(&ftp, &HandState::empty(6))), None, "RS-485: no pads");
        // Another kind, even with a pad of the same name: nothing on touch.
        let dfx = route(DeviceKind::InspireDfx, Side::Left);
        assert_eq!(touch_of(&bound(&dfx, &with)), None);
    }
}
