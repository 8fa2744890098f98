//! The Dex3 service front's registry entry and endpoints; its codec is
//! `handgate_adapters::dex3::front`.

use handgate_adapters::dex3::front::{decode_cmd, encode_state};
use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use super::Rejection;
use crate::profile::Topic;

/// The Dex3 front's endpoints: `HandCmd_` in, `HandState_` out (and its low-frequency copy).
pub struct Dex3Io {
    _reader: handgate_adapters::dds::Reader<HandCmd_>,
    state: handgate_adapters::dds::Writer<HandState_>,
    lf: Option<(handgate_adapters::dds::Writer<HandState_>, f64)>,
}

impl Dex3Io {
    pub fn open(
        node: &handgate_adapters::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        lf: Option<(&str, f64)>,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, handgate_adapters::dds::DdsError> {
        use handgate_adapters::dds::Qos;
        Ok(Self {
            _reader: super::reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, Qos::BestEffort)?,
            lf: lf
                .map(|(t, hz)| node.writer(t, Qos::BestEffort).map(|w| (w, hz)))
                .transpose()?,
        })
    }
}

impl super::FrontIo for Dex3Io {
    fn decode(
        &self,
        bound: &[super::Bound<'_>],
        msg: &super::Message,
    ) -> Result<Vec<(usize, super::Routed)>, Rejection> {
        let Some(m) = msg.downcast_ref::<HandCmd_>() else {
            return Ok(Vec::new());
        };
        let b0 = &bound[0];
        let c = decode_cmd(m, &b0.route.front, &b0.routed_state())?;
        Ok(vec![(0, super::routed(b0.route, c))])
    }

    fn publish(&mut self, bound: &[super::Bound<'_>], lf: bool) {
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
pub(super) fn side_rule(
    kind: &str,
    served: Option<handgate_adapters::model::Side>,
    topics_given: bool,
    actuator: bool,
) -> Vec<(&'static str, String)> {
    if served != Some(handgate_adapters::model::Side::Center) || (!actuator && topics_given) {
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

impl super::kind::FrontFactory for Dex3Front {
    fn name(&self) -> &'static str {
        "dex3"
    }
    fn speaks(&self) -> Option<handgate_adapters::model::DeviceKind> {
        Some(handgate_adapters::model::DeviceKind::Dex3)
    }
    fn keys(&self) -> &'static [&'static str] {
        &["side", "lf_state_topic", "lf_state_hz"]
    }
    fn default_topics(
        &self,
        _f: &crate::profile::FrontConfig,
        lr: Option<handgate_adapters::model::Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        use handgate_adapters::dex3::dds_client::{topics, StateSource};
        let std = lr.map(|s| topics(s, StateSource::State));
        (
            std.as_ref().map(|t| Topic(t.0.clone())),
            std.map(|t| Topic(t.1)),
            lr.map(|s| Topic(topics(s, StateSource::Lf).1)),
        )
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        device_hz.map_or(500.0, |d| d.min(500.0))
    }
    fn default_lf_state_hz(&self) -> Option<f64> {
        Some(50.0)
    }
    fn default_name(&self, _f: &crate::profile::FrontConfig, side: &str) -> String {
        format!("dex3_{side}")
    }
    fn silence(
        &self,
        mode: crate::profile::Silence,
        dog: (std::time::Duration, handgate_adapters::model::SafeAction),
    ) -> crate::plan::SilencePlan {
        use handgate_adapters::dex3::RIS_TIMEOUT;
        let (after, timeout_bit) = match mode {
            // The Dex3 front honours the RIS timeout bit either way: in watchdog mode it
            // shortens the watchdog to at most the motors' own timeout.
            crate::profile::Silence::Watchdog => (Some(dog), Some((dog.0.min(RIS_TIMEOUT), dog.1))),
            // The G1 Dex3 service forwards commands to motors that keep their last target; a
            // motor whose last command set the timeout bit stops (goes limp) 1 s later.
            crate::profile::Silence::Service => (None, Some((RIS_TIMEOUT, handgate_adapters::model::SafeAction::Limp))),
        };
        crate::plan::SilencePlan {
            mode,
            after,
            timeout_bit,
        }
    }
    fn validate(
        &self,
        f: &crate::profile::FrontConfig,
        served: Option<handgate_adapters::model::Side>,
        dangling: bool,
    ) -> Vec<(&'static str, String)> {
        if dangling {
            return vec![];
        }
        let given = f.cmd_topic.is_some() && f.state_topic.is_some() && f.lf_state_topic.is_some();
        side_rule("dex3", served, given, false)
    }
    fn open(
        &self,
        node: &handgate_adapters::dds::Node,
        f: &crate::plan::FrontPlan,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<super::Endpoints, handgate_adapters::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        let lf = f.lf_state.as_ref().map(|(t, hz)| (t.as_str(), *hz));
        Ok(super::Endpoints::Commands(Box::new(Dex3Io::open(
            node,
            &cmd,
            &f.state_topic,
            lf,
            tx,
            dropped,
        )?)))
    }
}

impl super::FrontKind {
    /// The Dex3-1 DDS interface (`rt/dex3/{side}/*`).
    #[allow(non_upper_case_globals)]
    pub const Dex3: super::FrontKind = super::FrontKind::of(&Dex3Front);
}
