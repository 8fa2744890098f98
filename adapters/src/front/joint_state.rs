//! ROS 2 `sensor_msgs/msg/JointState` (as `sensor_msgs::msg::dds_::JointState_` on
//! `rt/<topic>`), with URDF joint names and positions in the URDF (= wire) frame, so
//! robot_state_publisher and rviz see the hands without a bridge.

use crate::mapping::DeviceTable;
use crate::model::HandState;
use handgate_idl::ros2::{Header_, JointState_, Time_};

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

/// A joint_state front's topic when `topic` is not set.
pub const DEFAULT_TOPIC: &str = "rt/joint_states";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, JointState, Side};

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
