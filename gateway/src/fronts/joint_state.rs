//! ROS 2 `sensor_msgs/msg/JointState` (as `sensor_msgs::msg::dds_::JointState_` on
//! `rt/<topic>`), with URDF joint names and positions in the URDF (= wire) frame, so
//! robot_state_publisher and rviz see the hands without a bridge.

use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::model::HandState;
use handgate_idl::ros2::{Header_, JointState_, Time_};

use crate::profile::Topic;

/// Appends one device's joints to `out` (a JointState front may carry several devices).
pub fn append(out: &mut JointState_, device: &DeviceTable, st: &HandState, urdf_names: bool, prefix: &str) {
    for (m, j) in device.joints.iter().zip(&st.joints) {
        out.name.push(if urdf_names {
            m.urdf.clone()
        } else {
            format!("{prefix}{}", m.name)
        });
        out.position.push(m.q_to_wire(j.q) as f64);
        out.velocity.push(m.rate_to_wire(j.dq) as f64);
        out.effort.push(m.tau_to_wire(j.tau) as f64);
    }
}

/// An empty message stamped `now`.
pub fn header(now: std::time::SystemTime, frame_id: &str) -> JointState_ {
    let d = now.duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    JointState_ {
        header: Header_ {
            stamp: Time_ {
                sec: d.as_secs().min(i32::MAX as u64) as i32,
                nanosec: d.subsec_nanos(),
            },
            frame_id: frame_id.to_string(),
        },
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_adapters::mapping::TableOverrides;
    use handgate_adapters::model::{DeviceKind, JointState, Side};

    #[test]
    fn urdf_names_and_wire_frame() {
        let t = DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap();
        let mut st = HandState::empty(7);
        st.joints[t.joint_by_name("index_0").unwrap().index()] = JointState {
            q: 1.0,
            ..Default::default()
        };
        let mut m = header(std::time::SystemTime::now(), "");
        append(&mut m, &t, &st, true, "");
        let i = m.name.iter().position(|n| n == "left_hand_three_joint").unwrap();
        assert_eq!(m.position[i], -1.0);
        assert_eq!(m.name.len(), 7);
    }
}

/// A joint_state front's topic when `topic` is not set.
pub const DEFAULT_TOPIC: &str = "rt/joint_states";

/// ROS 2 JointState over the bound device, or every device: state only.
#[derive(Debug)]
pub struct JointStateFront;

impl super::kind::FrontFactory for JointStateFront {
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
        f: &crate::profile::FrontConfig,
        _lr: Option<handgate_adapters::model::Side>,
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
    fn default_name(&self, f: &crate::profile::FrontConfig, _side: &str) -> String {
        match &f.topic {
            Some(t) if t.as_str() != DEFAULT_TOPIC => t.0.clone(),
            _ => "joint_state".into(),
        }
    }
    fn open(
        &self,
        node: &handgate_adapters::dds::Node,
        f: &crate::plan::FrontPlan,
        _tx: tokio::sync::mpsc::Sender<super::Message>,
        _dropped: std::sync::Arc<std::sync::atomic::AtomicU64>,
    ) -> Result<super::Endpoints, handgate_adapters::dds::DdsError> {
        Ok(super::Endpoints::StateOnly(Box::new(JointStateIo {
            writer: node.writer(&f.state_topic, handgate_adapters::dds::Qos::BestEffort)?,
            urdf_names: f.config.urdf_names.unwrap_or(true),
        })))
    }
}

/// The joint_state front's writer.
pub struct JointStateIo {
    writer: handgate_adapters::dds::Writer<JointState_>,
    urdf_names: bool,
}

impl super::StateIo for JointStateIo {
    fn publish(&mut self, devices: &[super::Published<'_>]) {
        let mut msg = header(std::time::SystemTime::now(), "");
        for d in devices {
            append(&mut msg, d.table, &d.state, self.urdf_names, &format!("{}/", d.device));
        }
        let _ = self.writer.write(msg);
    }
}

impl super::FrontKind {
    /// ROS 2 sensor_msgs/JointState.
    #[allow(non_upper_case_globals)]
    pub const JointState: super::FrontKind = super::FrontKind::of(&JointStateFront);
}
