//! The Inspire FTP front's registry entry and endpoints: handgate serving Inspire's DDS driver's
//! own interface for one hand (`rt/inspire_hand/ctrl/{l,r}` in, `rt/inspire_hand/state/{l,r}`
//! and `rt/inspire_hand/touch/{l,r}` out; docs/sources.md §7), so an unmodified client of the
//! driver (xr_teleoperate's `Inspire_Controller_FTP`) drives any device of the fleet. Its codec
//! is [`super::front`]. One front per hand, like the driver (one instance per hand, its `LR`
//! argument): the served side picks the topics.
//!
//! Touch: the third writer publishes `inspire_hand_touch` only when the bound device is an
//! Inspire FTP hand with its tactile pads (its transport carries them); any other device
//! publishes nothing there, as the driver over RS-485 does. Its topic is always the served
//! side's standard one (the front registry has no key for a third topic).

use handgate_idl::inspire::{InspireHandCtrl, InspireHandState, InspireHandTouch};

use super::emulator::FtpTransport;
use super::front::{decode, encode_state, encode_touch, topics, CTRL_TOPIC_PREFIX, STATE_TOPIC_PREFIX};
use crate::front::config::{FrontConfig, Silence};
use crate::front::kind::{FrontFactory, FrontKind};
use crate::front::plan::{FrontPlan, SilencePlan};
use crate::front::serve::{reader, routed, Bound, Endpoints, FrontIo, Message, Routed};
use crate::front::Rejection;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

/// The front's name (profile `kind = "inspire_ftp"`), the kind's own.
const NAME: &str = "inspire_ftp";

/// The Inspire FTP front's endpoints: `inspire_hand_ctrl` in, `inspire_hand_state` and
/// `inspire_hand_touch` out.
pub struct FtpIo {
    _reader: crate::dds::Reader<InspireHandCtrl>,
    state: crate::dds::Writer<InspireHandState>,
    touch: crate::dds::Writer<InspireHandTouch>,
}

impl FtpIo {
    pub fn open(
        node: &crate::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        touch_topic: &str,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, crate::dds::DdsError> {
        use crate::front::serve::STATE_QOS;
        Ok(Self {
            _reader: reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, STATE_QOS)?,
            touch: node.writer(touch_topic, STATE_QOS)?,
        })
    }
}

/// The touch message of a bound device: only an Inspire FTP hand's own tactile pads.
fn touch_of(b: &Bound<'_>) -> Option<InspireHandTouch> {
    if b.route.device.kind != DeviceKind::InspireFtp {
        return None;
    }
    encode_touch(&b.state.pads)
}

/// Decodes one `inspire_hand_ctrl` for the bound hand. The driver's no operation (mode 0,
/// force / speed only, every angle −1) is no command at all for the device: an empty list,
/// never a closure 0.
pub fn decode_bound(bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
    let (Some(m), Some(b0)) = (msg.downcast_ref::<InspireHandCtrl>(), bound.first()) else {
        return Ok(Vec::new());
    };
    Ok(decode(m, &b0.route.front)?
        .map(|c| vec![(0, routed(b0.route, c))])
        .unwrap_or_default())
}

impl FrontIo for FtpIo {
    fn decode(&self, bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
        decode_bound(bound, msg)
    }

    fn publish(&mut self, bound: &[Bound<'_>], _lf: bool) {
        let Some(b0) = bound.first() else {
            return;
        };
        let _ = self
            .state
            .write(encode_state(&b0.route.front, &b0.routed_state(), &b0.state));
        if let Some(t) = touch_of(b0) {
            let _ = self.touch.write(t);
        }
    }
}

/// Inspire's DDS driver's interface for one hand.
#[derive(Debug)]
pub struct InspireFtpFront;

impl FrontFactory for InspireFtpFront {
    fn name(&self) -> &'static str {
        NAME
    }
    fn speaks(&self) -> Option<DeviceKind> {
        Some(DeviceKind::InspireFtp)
    }
    /// `side`: which hand's topics (`/l`, `/r`) and table the front serves (default: the
    /// device's side; required for a device of side center).
    fn keys(&self) -> &'static [&'static str] {
        &["side"]
    }
    /// The driver's topics of the served side (none for a side-less device: refused by
    /// [`Self::validate`]).
    fn default_topics(
        &self,
        _f: &FrontConfig,
        lr: Option<Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        match lr {
            Some(s @ (Side::Left | Side::Right)) => {
                let (cmd, state, _touch) = topics(s);
                (Some(Topic(cmd)), Some(Topic(state)), None)
            }
            _ => (None, None, None),
        }
    }
    /// The driver's loop over Modbus TCP (assumed 50 Hz, [`FtpTransport::rate`]), whatever
    /// the device's rate.
    fn default_state_hz(&self, _device_hz: Option<f64>) -> f64 {
        FtpTransport::Tcp.rate().0
    }
    fn default_name(&self, _f: &FrontConfig, side: &str) -> String {
        format!("{NAME}_{side}")
    }
    /// The driver has no timeout: the hand keeps its last target (docs/sources.md §7).
    fn silence(&self, mode: Silence, dog: (std::time::Duration, SafeAction)) -> SilencePlan {
        SilencePlan::keeps_last_target(mode, dog)
    }
    fn validate(&self, _f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
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
    /// The touch topic (`describe` is given the front's table only: with no `side` key, the
    /// served side is the device's, named as `{l,r}`).
    fn describe(&self, f: &FrontConfig) -> Option<String> {
        let touch = match f.side {
            Some(s @ (Side::Left | Side::Right)) => topics(s).2,
            _ => format!("{}/{{l,r}} (the served side)", super::front::TOUCH_TOPIC_PREFIX),
        };
        Some(format!(", touch {touch} from an inspire_ftp device with tactile pads"))
    }
    fn served(&self, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::front::serve::{served_command, served_state};
        let (cmd, touch) = cmd_touch_topics(f);
        vec![
            served_command::<InspireHandCtrl>(&cmd),
            served_state::<InspireHandState>(&f.state_topic),
            served_state::<InspireHandTouch>(&touch),
        ]
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &FrontPlan,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        let (cmd, touch) = cmd_touch_topics(f);
        Ok(Endpoints::Commands(Box::new(FtpIo::open(
            &env.node,
            &cmd,
            &f.state_topic,
            &touch,
            tx,
            dropped,
        )?)))
    }
}

/// The command and touch topics of front `f`: the served side's (the plan's command topic
/// when it has one).
fn cmd_touch_topics(f: &FrontPlan) -> (String, String) {
    let side = f.bindings.first().map_or(Side::Right, |b| b.side);
    let (ctrl, _, touch) = topics(side);
    (f.cmd_topic.clone().unwrap_or(ctrl), touch)
}

impl FrontKind {
    /// Inspire's DDS driver's interface for one hand (`rt/inspire_hand/*/{l,r}`).
    #[allow(non_upper_case_globals)]
    pub const InspireFtp: FrontKind = FrontKind::of(&InspireFtpFront);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Duration;

    use crate::mapping::TableOverrides;
    use crate::model::{HandState, Pad};
    use crate::route::Route;
    use handgate_idl::inspire::{MODE_ANGLE, MODE_FORCE};

    fn cfg(side: Option<Side>) -> FrontConfig {
        FrontConfig {
            kind: FrontKind::InspireFtp,
            side,
            ..Default::default()
        }
    }

    fn route(device: DeviceKind, side: Side) -> Route {
        let front = Arc::new(DeviceKind::InspireFtp.table(side, &TableOverrides::default()).unwrap());
        let dev = Arc::new(device.table(side, &TableOverrides::default()).unwrap());
        Route::bind(front, dev)
    }

    fn bound(route: &Route, state: HandState) -> Bound<'_> {
        Bound {
            route,
            element: 0,
            device: "hand",
            safe_action: SafeAction::Limp,
            state,
        }
    }

    fn ctrl(mode: i8, angle: Vec<i16>) -> Message {
        Box::new(InspireHandCtrl {
            angle_set: angle,
            mode,
            ..InspireHandCtrl::sdk_default()
        })
    }

    #[test]
    fn registered_by_its_kind_under_its_name() {
        assert_eq!(FrontKind::by_name("inspire_ftp"), Some(FrontKind::InspireFtp));
        assert!(DeviceKind::InspireFtp
            .factory()
            .fronts()
            .contains(&FrontKind::InspireFtp));
        let f = FrontKind::InspireFtp.factory();
        assert_eq!(f.speaks(), Some(DeviceKind::InspireFtp));
        assert!(f.takes_commands());
        assert_eq!(f.keys(), &["side"]);
        assert_eq!(f.binds_elements(), None);
        assert_eq!(f.elements(&cfg(None)), 1);
    }

    #[test]
    fn the_drivers_topics_of_the_served_side_and_its_rate() {
        let f = InspireFtpFront;
        let (c, s, lf) = f.default_topics(&cfg(None), Some(Side::Left), "x");
        assert_eq!(c, Some(Topic("rt/inspire_hand/ctrl/l".into())));
        assert_eq!(s, Some(Topic("rt/inspire_hand/state/l".into())));
        assert_eq!(lf, None);
        let (c, s, _) = f.default_topics(&cfg(None), Some(Side::Right), "x");
        assert_eq!(c, Some(Topic("rt/inspire_hand/ctrl/r".into())));
        assert_eq!(s, Some(Topic("rt/inspire_hand/state/r".into())));
        assert_eq!(
            f.default_topics(&cfg(None), Some(Side::Center), "x"),
            (None, None, None)
        );
        assert_eq!(f.default_topics(&cfg(None), None, "x"), (None, None, None));
        assert_eq!(f.default_lf_state_hz(), None);
        // The driver publishes once per loop (assumed 50 Hz), whatever the bound device's rate.
        for d in [None, Some(1000.0), Some(20.0)] {
            assert_eq!(f.default_state_hz(d), 50.0);
        }
        assert_eq!(f.default_name(&cfg(None), "left"), "inspire_ftp_left");
        let d = f.describe(&cfg(Some(Side::Left))).unwrap();
        assert_eq!(
            d,
            ", touch rt/inspire_hand/touch/l from an inspire_ftp device with tactile pads"
        );
        let d = f.describe(&cfg(None)).unwrap();
        assert!(d.contains("rt/inspire_hand/touch/{l,r} (the served side)"), "{d}");
    }

    #[test]
    fn silence_keeps_the_last_target_as_the_driver_or_the_devices_watchdog() {
        let f = InspireFtpFront;
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
    fn a_center_device_needs_a_side() {
        let f = InspireFtpFront;
        let p = f.validate(&cfg(None), Some(Side::Center), false);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].0, "side");
        assert!(
            p[0].1.contains("left or a right hand")
                && p[0].1.contains("rt/inspire_hand/ctrl/{l,r}")
                && p[0].1.contains("set `side`"),
            "{}",
            p[0].1
        );
        let given = FrontConfig {
            cmd_topic: Some(Topic("rt/x/cmd".into())),
            state_topic: Some(Topic("rt/x/state".into())),
            ..cfg(None)
        };
        // Topics given or not: the side still picks the touch topic and the convention.
        let p = f.validate(&given, Some(Side::Center), false);
        assert!(p.len() == 1 && p[0].1.contains("touch topic"), "{p:?}");
        assert!(f.validate(&cfg(None), Some(Side::Center), true).is_empty(), "dangling");
        for s in [Side::Left, Side::Right] {
            assert!(f.validate(&cfg(Some(s)), Some(s), false).is_empty());
        }
    }

    #[test]
    fn decode_routes_angles_and_a_no_operation_commands_nothing() {
        let r = route(DeviceKind::InspireFtp, Side::Left);
        let b = [bound(&r, HandState::empty(6))];
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
        let t = touch_of(&bound(&ftp, with.clone())).expect("an FTP hand's pads");
        assert_eq!(t.fingerfour_tip_touch, vec![7; 9]);
        assert_eq!(touch_of(&bound(&ftp, HandState::empty(6))), None, "RS-485: no pads");
        // Another kind, even with a pad of the same name: nothing on touch.
        let dfx = route(DeviceKind::InspireDfx, Side::Left);
        assert_eq!(touch_of(&bound(&dfx, with)), None);
    }
}
