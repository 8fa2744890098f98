//! The Dex3 service front's registry entry and endpoints; its codec is
//! `crate::dex3::front`.

use crate::dex3::front::{decode_cmd, encode_state};
use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use crate::front::Rejection;
use crate::units::Topic;

/// The Dex3 front's endpoints: `HandCmd_` in, `HandState_` out (and its low-frequency copy).
pub struct Dex3Io {
    _reader: crate::dds::Reader<HandCmd_>,
    state: crate::dds::Writer<HandState_>,
    lf: Option<(crate::dds::Writer<HandState_>, f64)>,
}

impl Dex3Io {
    pub fn open(
        node: &crate::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        lf: Option<(&str, f64)>,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, crate::dds::DdsError> {
        use crate::front::serve::STATE_QOS;
        Ok(Self {
            _reader: crate::front::serve::reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, STATE_QOS)?,
            lf: lf
                .map(|(t, hz)| node.writer(t, STATE_QOS).map(|w| (w, hz)))
                .transpose()?,
        })
    }
}

impl crate::front::serve::FrontIo for Dex3Io {
    fn decode(
        &self,
        bound: &[crate::front::serve::Bound<'_>],
        msg: &crate::front::serve::Message,
    ) -> Result<Vec<(usize, crate::front::serve::Routed)>, Rejection> {
        let Some(m) = msg.downcast_ref::<HandCmd_>() else {
            return Ok(Vec::new());
        };
        let b0 = &bound[0];
        let c = decode_cmd(m, &b0.route.front, &b0.routed_state())?;
        Ok(vec![(0, crate::front::serve::routed(b0.route, c))])
    }

    fn publish(&mut self, bound: &[crate::front::serve::Bound<'_>], lf: bool) {
        let b0 = &bound[0];
        let msg = encode_state(&b0.route.front, &b0.routed_state(), &b0.state);
        let _ = match (lf, &mut self.lf) {
            (true, Some((w, _))) => w.write(msg),
            (true, None) => Ok(()),
            (false, _) => self.state.write(msg),
        };
    }

    fn lf_hz(&self) -> f64 {
        self.lf.as_ref().map_or(0.0, |(_, hz)| *hz)
    }
}

/// The side rule shared by the fronts serving `rt/.../{left,right}/...`: a device of side
/// center is served on a side given explicitly, unless every topic is overridden.
pub(crate) fn side_rule(
    kind: &str,
    served: Option<crate::model::Side>,
    topics_given: bool,
    actuator: bool,
) -> Vec<(&'static str, String)> {
    if served != Some(crate::model::Side::Center) || (!actuator && topics_given) {
        return vec![];
    }
    let why = if actuator {
        "the actuator variant addresses element 0 = right, 1 = left"
    } else {
        "its topics are rt/.../{left,right}/...; set the topics explicitly to serve another"
    };
    vec![(
        "side",
        format!("a {kind} front serves side left or right ({why}); set `side` (the device's side is center)"),
    )]
}

/// The Dex3-1 service interface.
#[derive(Debug)]
pub struct Dex3Front;

impl crate::front::kind::FrontFactory for Dex3Front {
    fn name(&self) -> &'static str {
        "dex3"
    }
    fn speaks(&self) -> Option<crate::model::DeviceKind> {
        Some(crate::model::DeviceKind::Dex3)
    }
    fn keys(&self) -> &'static [&'static str] {
        &["side", "lf_state_topic", "lf_state_hz"]
    }
    fn default_topics(
        &self,
        _f: &crate::front::config::FrontConfig,
        lr: Option<crate::model::Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        use crate::dex3::dds_client::{topics, StateSource};
        let std = lr.map(|s| topics(s, StateSource::State));
        (
            std.as_ref().map(|t| Topic(t.0.clone())),
            std.map(|t| Topic(t.1)),
            lr.map(|s| Topic(topics(s, StateSource::Lf).1)),
        )
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        device_hz.map_or(super::SERVICE_HZ, |d| d.min(super::SERVICE_HZ))
    }
    fn default_lf_state_hz(&self) -> Option<f64> {
        Some(super::SERVICE_LF_HZ)
    }
    fn default_name(&self, _f: &crate::front::config::FrontConfig, side: &str) -> String {
        format!("dex3_{side}")
    }
    fn silence(
        &self,
        mode: crate::front::config::Silence,
        dog: (std::time::Duration, crate::model::SafeAction),
    ) -> crate::front::plan::SilencePlan {
        use crate::dex3::RIS_TIMEOUT;
        let (after, timeout_bit) = match mode {
            // The Dex3 front honours the RIS timeout bit either way: in watchdog mode it
            // shortens the watchdog to at most the motors' own timeout.
            crate::front::config::Silence::Watchdog => (Some(dog), Some((dog.0.min(RIS_TIMEOUT), dog.1))),
            // The G1 Dex3 service forwards commands to motors that keep their last target; a
            // motor whose last command set the timeout bit stops (goes limp) 1 s later.
            crate::front::config::Silence::Service => (None, Some((RIS_TIMEOUT, crate::model::SafeAction::Limp))),
        };
        crate::front::plan::SilencePlan {
            mode,
            after,
            timeout_bit,
        }
    }
    fn validate(
        &self,
        f: &crate::front::config::FrontConfig,
        served: Option<crate::model::Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        if dangling {
            return vec![];
        }
        let given = f.cmd_topic.is_some() && f.state_topic.is_some() && f.lf_state_topic.is_some();
        side_rule("dex3", served, given, false)
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::dds::type_name;
        use crate::front::serve::{served_command, served_state};
        use handgate_idl::{handgate, unitree_go};
        let mut out = Vec::new();
        if let Some(cmd) = &f.cmd_topic {
            out.push(
                served_command::<HandCmd_>(cmd)
                    .alternative(
                        type_name::<unitree_go::MotorCmds_>(),
                        format!("the client speaks the Dex1 / hand-service interface (unitree_go MotorCmds_), not the Dex3 service's unitree_hg HandCmd_: point it at a dex1 front, or send HandCmd_ to front {}", f.name),
                    )
                    .alternative(
                        type_name::<handgate::HandCmd_>(),
                        format!("the client speaks handgate's canonical interface: send it to a canonical front, or send unitree_hg HandCmd_ to front {}", f.name),
                    ),
            );
        }
        let state_alt = |s: crate::discovery::diagnose::Served| {
            s.alternative(
                type_name::<unitree_go::MotorStates_>(),
                format!("the client reads unitree_go MotorStates_ (Dex1 / hand-service interface); front {} publishes the Dex3 service's unitree_hg HandState_", f.name),
            )
        };
        out.push(state_alt(served_state::<HandState_>(&f.state_topic)));
        if let Some((lf, _)) = &f.lf_state {
            out.push(state_alt(served_state::<HandState_>(lf)));
        }
        out
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        tx: crate::front::serve::Queue,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        let lf = f.lf_state.as_ref().map(|(t, hz)| (t.as_str(), *hz));
        Ok(crate::front::serve::Endpoints::Commands(Box::new(Dex3Io::open(
            &env.node,
            &cmd,
            &f.state_topic,
            lf,
            tx,
            dropped,
        )?)))
    }
}

impl crate::front::kind::FrontKind {
    /// The Dex3-1 DDS interface (`rt/dex3/{side}/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex3: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&Dex3Front);
}
