//! The joint_state front's registry entry and writer; its codec is
//! `crate::front::joint_state`.

use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::front::config::{FrontConfig, TopicKey, TopicRole};
use crate::front::joint_state::{append, header, joint_name, DEFAULT_TOPIC};
use crate::front::kind::{Front, FrontFacts, FrontKind, FrontWire};
use crate::front::plan::FrontPlan;
use crate::front::serve::{Endpoints, FrontEnv, Queue};
use crate::units::Topic;
use handgate_idl::ros2::JointState_;

/// The own keys of the fronts that speak ROS 2 JointState: joint_state, and
/// joint_state_command (`crate::front::joint_state_command_serve`), which takes the names the
/// first publishes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointStateConfig {
    /// Default: the kind's (joint_state `rt/joint_states`, joint_state_command
    /// `rt/robot_joint_commands`; in `[dds] namespace`).
    pub topic: Option<Topic>,
    /// Name joints as in the URDF (default true); `false`: `<device>/<joint>`.
    pub urdf_names: Option<bool>,
}

/// No `side`: every device's joints as they are.
impl crate::front::config::ServedSide for JointStateConfig {}

impl JointStateConfig {
    /// Whether joints are named as in the URDF (default true).
    pub fn urdf_names(&self) -> bool {
        self.urdf_names.unwrap_or(true)
    }

    /// The names the joints of `device` (table `table`) carry in this front's messages.
    pub fn joint_names(&self, device: &str, table: &crate::mapping::DeviceTable) -> Vec<String> {
        table
            .joints
            .iter()
            .map(|m| joint_name(m, self.urdf_names(), device))
            .collect()
    }
}

/// ROS 2 JointState over the bound device, or every device: state only.
#[derive(Debug)]
pub struct JointStateFront;

impl Front for JointStateFront {
    type Config = JointStateConfig;
    type Wire = JointStateIo;
    const KIND: FrontKind = FrontKind::of(&JointStateFront);
    const FACTS: FrontFacts = FrontFacts {
        takes_commands: false,
        in_namespace: true,
        ..FrontFacts::serving("joint_state", None)
    };
    const TOPICS: &'static [TopicKey<JointStateConfig>] = &[TopicKey {
        key: "topic",
        role: TopicRole::State,
        set: |c| c.topic.as_ref(),
        default: |_, _| Some(Topic::new(DEFAULT_TOPIC)),
    }];

    fn default_state_hz(device_hz: Option<f64>) -> f64 {
        device_hz.map_or(100.0, |d| d.min(100.0))
    }
    fn joint_names(c: &JointStateConfig, device: &str, table: &crate::mapping::DeviceTable) -> Vec<String> {
        c.joint_names(device, table)
    }
    fn default_name(c: &JointStateConfig, _f: &FrontConfig, _side: &str) -> String {
        match &c.topic {
            Some(t) if t.as_str() != DEFAULT_TOPIC => t.0.clone(),
            _ => "joint_state".into(),
        }
    }
}

/// The QoS of the joint_states writer: ROS 2's default QoS (reliable, volatile) subscribers
/// match a reliable writer; keep-last 1: only the newest state matters (docs/fronts.md, "QoS
/// per topic").
pub const JOINT_STATES_QOS: crate::dds::Qos = crate::dds::Qos::Reliable { depth: 1 };

/// The joint_state front's writer.
pub struct JointStateIo {
    writer: crate::dds::Writer<JointState_>,
    urdf_names: bool,
}

/// Its writer: state only.
impl FrontWire<JointStateConfig> for JointStateIo {
    fn served(_c: &JointStateConfig, f: &FrontPlan) -> Vec<crate::discovery::diagnose::Served> {
        vec![crate::discovery::diagnose::Served::new(
            f.state_topic(),
            crate::dds::type_name::<JointState_>(),
            crate::discovery::Role::Writer,
            JOINT_STATES_QOS.served(),
        )]
    }
    fn open(
        c: &JointStateConfig,
        env: &FrontEnv,
        f: &FrontPlan,
        _tx: Queue,
        _dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, crate::dds::DdsError> {
        Ok(Endpoints::StateOnly(Box::new(JointStateIo {
            writer: env.node.writer_with(
                f.state_topic(),
                JOINT_STATES_QOS,
                &crate::ros::user_data::<JointState_>(),
            )?,
            urdf_names: c.urdf_names(),
        })))
    }
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

impl FrontKind {
    /// ROS 2 sensor_msgs/JointState.
    #[allow(non_upper_case_globals)]
    pub const JointState: FrontKind = JointStateFront::KIND;
}
