//! The joint_state front's registry entry and writer; its codec is
//! `crate::front::joint_state`.

use crate::front::joint_state::{append, header, joint_name, DEFAULT_TOPIC};
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
    fn in_namespace(&self) -> bool {
        true
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
    fn joint_names(
        &self,
        f: &crate::front::config::FrontConfig,
        device: &str,
        table: &crate::mapping::DeviceTable,
    ) -> Vec<String> {
        let urdf = f.urdf_names.unwrap_or(true);
        table.joints.iter().map(|m| joint_name(m, urdf, device)).collect()
    }
    fn default_name(&self, f: &crate::front::config::FrontConfig, _side: &str) -> String {
        match &f.topic {
            Some(t) if t.as_str() != DEFAULT_TOPIC => t.0.clone(),
            _ => "joint_state".into(),
        }
    }
    fn served(&self, f: &crate::front::plan::FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        vec![crate::discovery::diagnose::Served::new(
            &f.state_topic,
            crate::dds::type_name::<JointState_>(),
            crate::discovery::Role::Writer,
            JOINT_STATES_QOS.served(),
        )]
    }
    fn open(
        &self,
        env: &crate::front::serve::FrontEnv,
        f: &crate::front::plan::FrontPlan,
        _tx: crate::front::serve::Queue,
        _dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<crate::front::serve::Endpoints, crate::dds::DdsError> {
        Ok(crate::front::serve::Endpoints::StateOnly(Box::new(JointStateIo {
            // ROS 2's default QoS (reliable, volatile) subscribers match a reliable writer;
            // keep-last 1: only the newest state matters (docs/fronts.md, "QoS per topic").
            writer: env.node.writer_with(
                &f.state_topic,
                JOINT_STATES_QOS,
                &crate::ros::user_data::<JointState_>(),
            )?,
            urdf_names: f.config.urdf_names.unwrap_or(true), // as `joint_names` says
        })))
    }
}

/// The joint_state front's writer.
/// The QoS of the joint_states writer: ROS 2's default QoS (reliable, volatile) subscribers
/// match a reliable writer; keep-last 1: only the newest state matters (docs/fronts.md, "QoS
/// per topic").
pub const JOINT_STATES_QOS: crate::dds::Qos = crate::dds::Qos::Reliable { depth: 1 };

pub struct JointStateIo {
    writer: crate::dds::Writer<JointState_>,
    urdf_names: bool,
}

impl crate::front::serve::StateIo for JointStateIo {
    fn publish(&mut self, devices: &[crate::front::serve::Published<'_>]) {
        let mut msg = header(std::time::SystemTime::now(), "");
        for d in devices {
            append(&mut msg, d.table, &d.state, self.urdf_names, d.device);
        }
        let _ = self.writer.write(msg);
    }
}

impl crate::front::kind::FrontKind {
    /// ROS 2 sensor_msgs/JointState.
    #[allow(non_upper_case_globals)]
    pub const JointState: crate::front::kind::FrontKind = crate::front::kind::FrontKind::of(&JointStateFront);
}
