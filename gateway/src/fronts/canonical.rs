//! The canonical front's registry entry and endpoints; its codec is
//! `handgate_adapters::front::canonical`.

pub use handgate_adapters::front::canonical::topics;
use handgate_adapters::front::canonical::{decode_cmd, encode_state};
use handgate_adapters::model::SafeAction;
use handgate_idl::handgate as hg;

use super::Rejection;
use crate::profile::{Silence, Topic};

/// The canonical front's endpoints: handgate's own `HandCmd_` in, `HandState_` out.
pub struct CanonicalIo {
    _reader: handgate_adapters::dds::Reader<hg::HandCmd_>,
    state: handgate_adapters::dds::Writer<hg::HandState_>,
}

impl CanonicalIo {
    pub fn open(
        node: &handgate_adapters::dds::Node,
        cmd_topic: &str,
        state_topic: &str,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<Self, handgate_adapters::dds::DdsError> {
        Ok(Self {
            _reader: super::reader(node, cmd_topic, tx, dropped)?,
            state: node.writer(state_topic, handgate_adapters::dds::Qos::BestEffort)?,
        })
    }
}

impl super::FrontIo for CanonicalIo {
    fn decode(
        &self,
        bound: &[super::Bound<'_>],
        msg: &super::Message,
    ) -> Result<Vec<(usize, super::Routed)>, Rejection> {
        let Some(m) = msg.downcast_ref::<hg::HandCmd_>() else {
            return Ok(Vec::new());
        };
        let b0 = &bound[0];
        // The device's own names and table: no front table in between.
        Ok(vec![(0, (decode_cmd(m, &b0.route.device, b0.safe_action)?, 0, false))])
    }

    fn publish(&mut self, bound: &[super::Bound<'_>], _lf: bool) {
        let b0 = &bound[0];
        let _ = self.state.write(encode_state(b0.device, &b0.route.device, &b0.state));
    }
}

/// handgate's own interface: the bound device's table, its watchdog as silence.
#[derive(Debug)]
pub struct CanonicalFront;

impl super::kind::FrontFactory for CanonicalFront {
    fn name(&self) -> &'static str {
        "canonical"
    }
    fn default_topics(
        &self,
        _f: &crate::profile::FrontConfig,
        _lr: Option<handgate_adapters::model::Side>,
        device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        let (c, s) = topics(device);
        (Some(Topic(c)), Some(Topic(s)), None)
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn default_name(&self, f: &crate::profile::FrontConfig, _side: &str) -> String {
        format!("canonical_{}", f.device.as_ref().map_or("?", |d| d.as_str()))
    }
    fn silence(&self, _mode: Silence, dog: (std::time::Duration, SafeAction)) -> crate::plan::SilencePlan {
        // handgate's own interface: its service semantics are the strict watchdog.
        crate::plan::SilencePlan {
            mode: Silence::Watchdog,
            after: Some(dog),
            timeout_bit: None,
        }
    }
    fn open(
        &self,
        node: &handgate_adapters::dds::Node,
        f: &crate::plan::FrontPlan,
        tx: tokio::sync::mpsc::Sender<super::Message>,
        dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<super::Endpoints, handgate_adapters::dds::DdsError> {
        let cmd = f.cmd_topic.clone().unwrap_or_default();
        Ok(super::Endpoints::Commands(Box::new(CanonicalIo::open(
            node,
            &cmd,
            &f.state_topic,
            tx,
            dropped,
        )?)))
    }
}

impl super::FrontKind {
    /// handgate's own canonical messages (`rt/handgate/{device}/*`).
    #[allow(non_upper_case_globals)]
    pub const Canonical: super::FrontKind = super::FrontKind::of(&CanonicalFront);
}
