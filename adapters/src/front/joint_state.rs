//! ROS 2 `sensor_msgs/msg/JointState` (as `sensor_msgs::msg::dds_::JointState_` on
//! `rt/<topic>`), with URDF joint names and positions in the URDF's frame (the table's wire
//! or canonical frame, `DeviceTable::urdf_frame`), so robot_state_publisher and rviz see the
//! hands without a bridge.

use crate::mapping::{DeviceTable, JointMap, UrdfFrame};
use crate::model::HandState;
use handgate_idl::ros2::{Header_, JointState_};

/// The name joint `m` of device `device` carries in a JointState: its URDF name, or
/// `<device>/<canonical name>` with `urdf_names` off.
pub fn joint_name(m: &JointMap, urdf_names: bool, device: &str) -> String {
    if urdf_names {
        m.urdf.clone()
    } else {
        format!("{device}/{}", m.name)
    }
}

/// Appends the joints of device `device` to `out` (a JointState front may carry several
/// devices; the profile check refuses two that would publish one name,
/// `Front::joint_names`).
pub fn append(out: &mut JointState_, device: &DeviceTable, st: &HandState, urdf_names: bool, name: &str) {
    for (m, j) in device.joints.iter().zip(&st.joints) {
        out.name.push(joint_name(m, urdf_names, name));
        let (q, dq, tau) = match device.urdf_frame {
            UrdfFrame::Wire => (m.q_to_wire(j.q), m.rate_to_wire(j.dq), m.tau_to_wire(j.tau)),
            UrdfFrame::Canonical => (j.q, j.dq, j.tau),
        };
        out.position.push(q as f64);
        out.velocity.push(dq as f64);
        out.effort.push(tau as f64);
    }
}

/// An empty message stamped `now`.
pub fn header(now: std::time::SystemTime, frame_id: &str) -> JointState_ {
    JointState_ {
        header: Header_ {
            stamp: crate::ros::time(now),
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

    /// Hands whose wire is a normalised 0..1 publish URDF radians, not wire values
    /// (docs/sources.md §7: an Inspire finger open at its URDF lower limit, the thumb rotation
    /// at -0.1 rad when open; a BrainCo finger closed at its URDF upper limit, 1.4661 rad).
    #[test]
    fn normalised_hands_publish_urdf_radians() {
        let dfx = crate::inspire_dfx::table::table(Side::Right);
        let mut st = HandState::empty(6);
        for (m, j) in dfx.joints.iter().zip(st.joints.iter_mut()) {
            j.q = m.q_from_wire(1.0); // the service's q = 1: open
        }
        let mut m = header(std::time::SystemTime::now(), "");
        append(&mut m, &dfx, &st, true, "");
        let at = |m: &JointState_, n: &str| m.position[m.name.iter().position(|x| x == n).unwrap()];
        assert!((at(&m, "R_pinky_proximal_joint") - 0.0).abs() < 1e-6, "{m:?}");
        assert!((at(&m, "R_thumb_proximal_yaw_joint") + 0.1).abs() < 1e-6, "{m:?}");

        let bc = crate::brainco::table::table(Side::Left);
        let mut st = HandState::empty(6);
        for (m, j) in bc.joints.iter().zip(st.joints.iter_mut()) {
            j.q = m.q_from_wire(1.0); // the service's q = 1: closed
        }
        let mut m = header(std::time::SystemTime::now(), "");
        append(&mut m, &bc, &st, true, "");
        assert!((at(&m, "left_index_proximal_joint") - 1.4661).abs() < 1e-4, "{m:?}");
        assert!((at(&m, "left_thumb_metacarpal_joint") - 1.5184).abs() < 1e-4, "{m:?}");
    }
}
