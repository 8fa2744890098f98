//! The joint_state front's registry entry and writer; its codec is
//! `crate::front::joint_state`.

use crate::front::joint_state::{append, header, DEFAULT_TOPIC};
use handgate_idl::ros2::JointState_;

use crate::units::Topic;

/// ROS 2 JointState over the bound device, or every device: state only.
#[derive(Debug)]
pub struct JointStateFront;

impl crate::front::kind::FrontFactory for JointStateFront {
    fn name(&self) -> &'static str {
        "joint_state"
    }
    fn takes_commands(&self) -> bool {
        false
    }
    fn keys(&self) -> &'static [&'static str] {
        &["topic", "urdf_names"]
    }
    fn state_topic_key(&self) -> &'static str {
        "topic"
    }
    fn default_topics(
        &self,
        f: &crate::front::config::FrontConfig,
        _lr: Option<crate::model::Side>,
        _device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>) {
        (
            None,
            Some(f.topic.clone().unwrap_or_else(|| Topic::new(DEFAULT_TOPIC))),
            None,
        )
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn default_name(&self, f: &crate::front::config::FrontConfig, _side: &str) -> String {
        match &f.topic {
            Some(t) if t.as_str() != DEFAULT_TOPIC => t.0.clone(),
            _ => "joint_state".into(),
        }
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        vec![crate::front::serve::served_state::<JointState_>(&f.state_topic)]
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        _tx: tokio::sync::mpsc::Sender<crate::front::serve::Message>,
        _dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        Ok(crate::front::serve::Endpoints::StateOnly(Box::new(JointStateIo {
            writer: env.node.writer(&f.state_topic, crate::front::serve::STATE_QOS)?,
            urdf_names: f.config.urdf_names.unwrap_or(true),
        })))
    }
}

/// The joint_state front's writer.
pub struct JointStateIo {
    writer: crate::dds::Writer<JointState_>,
    urdf_names: bool,
}

impl crate::front::serve::StateIo for JointStateIo {
    fn publish(&mut self, devices: &[crate::front::serve::Published<'_>]) {
        let mut msg = header(std::time::SystemTime::now(), "");
        for d in devices {
            append(&mut msg, d.table, &d.state, self.urdf_names, &format!("{}/", d.device));
        }
        let _ = self.writer.write(msg);
    }
}

impl crate::front::kind::FrontKind {
    /// ROS 2 sensor_msgs/JointState.
    #[allow(non_upper_case_globals)]
    pub const JointState: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&JointStateFront);
}
