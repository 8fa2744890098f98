//! The canonical front's registry entry and endpoints; its codec is
//! `crate::front::canonical`.

pub use crate::front::canonical::topics;
use crate::front::canonical::{decode_cmd, encode_state};
use crate::model::SafeAction;
use handgate_idl::handgate as hg;

use crate::front::config::Silence;
use crate::front::Rejection;
use crate::units::Topic;

/// The canonical front's endpoints: handgate's own `HandCmd_` in, `HandState_` out.
pub struct CanonicalIo {
    _reader: crate::dds::Reader<hg::HandCmd_>,
    state: crate::dds::Writer<hg::HandState_>,
}

impl CanonicalIo {
    pub fn open(
        node: &crate::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        tx: tokio::sync::mpsc::Sender<crate::front::serve::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, crate::dds::DdsError> {
        Ok(Self {
            _reader: crate::front::serve::reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, crate::front::serve::STATE_QOS)?,
        })
    }
}

impl crate::front::serve::FrontIo for CanonicalIo {
    fn decode(
        &self,
        bound: &[crate::front::serve::Bound<'_>],
        msg: &crate::front::serve::Message,
    ) -> Result<Vec<(usize, crate::front::serve::Routed)>, Rejection> {
        let Some(m) = msg.downcast_ref::<hg::HandCmd_>() else {
            return Ok(Vec::new());
        };
        let b0 = &bound[0];
        // The device's own names and table: no front table in between.
        Ok(vec![(0, (decode_cmd(m, &b0.route.device, b0.safe_action)?, 0, false))])
    }

    fn publish(&mut self, bound: &[crate::front::serve::Bound<'_>], _lf: bool) {
        let b0 = &bound[0];
        let _ = self.state.write(encode_state(b0.device, &b0.route.device, &b0.state));
    }
}

/// handgate's own interface: the bound device's table, its watchdog as silence.
#[derive(Debug)]
pub struct CanonicalFront;

impl crate::front::kind::FrontFactory for CanonicalFront {
    fn name(&self) -> &'static str {
        "canonical"
    }
    fn default_topics(
        &self,
        _f: &crate::front::config::FrontConfig,
        _lr: Option<crate::model::Side>,
        device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        let (c, s) = topics(device);
        (Some(Topic(c)), Some(Topic(s)), None)
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn default_name(&self, f: &crate::front::config::FrontConfig, _side: &str) -> String {
        format!("canonical_{}", f.device.as_ref().map_or("?", |d| d.as_str()))
    }
    fn silence(&self, _mode: Silence, dog: (std::time::Duration, SafeAction)) -> crate::front::plan::SilencePlan {
        // handgate's own interface: its service semantics are the strict watchdog.
        crate::front::plan::SilencePlan {
            mode: Silence::Watchdog,
            after: Some(dog),
            timeout_bit: None,
        }
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        use crate::dds::type_name;
        use crate::front::serve::{served_command, served_state};
        use handgate_idl::unitree_hg;
        let mut out = Vec::new();
        if let Some(cmd) = &f.cmd_topic {
            out.push(served_command::<hg::HandCmd_>(cmd).alternative(
                type_name::<unitree_hg::HandCmd_>(),
                format!("the client speaks the Dex3 service interface (unitree_hg HandCmd_): serve it with a dex3 front, or send handgate HandCmd_ to front {}", f.name),
            ));
        }
        out.push(served_state::<hg::HandState_>(&f.state_topic));
        out
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        tx: tokio::sync::mpsc::Sender<crate::front::serve::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        Ok(crate::front::serve::Endpoints::Commands(Box::new(CanonicalIo::open(
            &env.node,
            &cmd,
            &f.state_topic,
            tx,
            dropped,
        )?)))
    }
}

impl crate::front::kind::FrontKind {
    /// handgate's own canonical messages (`rt/handgate/{device}/*`).
    #[allow(non_upper_case_globals)]
    pub const Canonical: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&CanonicalFront);
}
