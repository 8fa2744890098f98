//! ROS 2 `sensor_msgs/msg/JointState` taken as a command (as `sensor_msgs::msg::dds_::JointState_`
//! on `rt/<topic>`), the way ros2_control's `joint_state_topic_hardware_interface` sends one
//! (docs/sources.md §10): joints by the names `rt/joint_states` publishes
//! ([`super::joint_state::joint_name`]), positions in radians in the URDF's frame (the inverse
//! of [`super::joint_state::append`]), any subset of names per message. Pure functions; the
//! front's registry entry and reader are `crate::front::joint_state_command_serve`.
//!
//! Rules (docs/fronts.md, "joint_state_command front specifics"): a message names at least one
//! joint, each at most once, every name one of the bound devices' joints; `position` carries one
//! entry per name, every one finite. Anything else rejects the message whole. `velocity` and
//! `effort` are not read: that plugin fills them only for joints with a velocity or effort
//! command interface, which a position-controlled hand does not offer. Each position is held with
//! the gains the device's table closes the hand with (a JointState carries no gains).

use std::collections::HashMap;

use crate::mapping::{ClosureMap, DeviceTable, UrdfFrame};
use crate::model::{JointCommand, JointId};
use handgate_idl::ros2::JointState_;

use super::joint_state::joint_name;
use super::{FrontCommand, Rejection};

/// Where each joint name of a front's messages goes: (device index, joint) by name, built once
/// when the front binds its devices. Two devices naming one joint are refused by the profile
/// check (`Front::joint_names`); should they reach here, the first device keeps the name.
#[derive(Debug, Clone, PartialEq)]
pub struct JointIndex {
    by_name: HashMap<String, (usize, JointId)>,
}

impl JointIndex {
    /// The names of `devices` ((device name, its table), in the front's device order), as
    /// [`joint_name`] spells them.
    pub fn new<'a>(devices: impl IntoIterator<Item = (&'a str, &'a DeviceTable)>, urdf_names: bool) -> Self {
        let mut by_name = HashMap::new();
        for (d, (device, table)) in devices.into_iter().enumerate() {
            for (j, m) in table.joints.iter().enumerate() {
                by_name
                    .entry(joint_name(m, urdf_names, device))
                    .or_insert((d, JointId(j as u8)));
            }
        }
        JointIndex { by_name }
    }

    /// Number of names it knows.
    pub fn len(&self) -> usize {
        self.by_name.len()
    }

    pub fn is_empty(&self) -> bool {
        self.by_name.is_empty()
    }
}

/// The gains a position of `table` is held with: the stiffness and damping its closure
/// postures use (what a closure command closes the hand with), else its hold gains.
pub fn position_gains(table: &DeviceTable) -> (f32, f32) {
    match &table.closure {
        ClosureMap::Postures { kp, kd, .. } => (*kp, *kd),
        ClosureMap::Torque { .. } => (table.hold_kp, table.hold_kd),
    }
}

/// The canonical position of a URDF angle `urdf` of joint `j` of `table` (the inverse of what
/// `rt/joint_states` publishes: [`super::joint_state::append`]).
pub fn canonical_q(table: &DeviceTable, j: JointId, urdf: f32) -> f32 {
    match table.urdf_frame {
        UrdfFrame::Wire => table.joints[j.index()].q_from_wire(urdf),
        UrdfFrame::Canonical => urdf,
    }
}

/// Decodes a JointState command against the bound devices' tables (`tables`, in the order
/// `index` was built with): per device the message names, in device order, its command (its
/// joints in the device's canonical order, `None`: not named, the joint keeps its target); or
/// the reason the message is rejected whole. Positions are not clamped here: the device's
/// table clamps them, as for every front.
pub fn decode(
    index: &JointIndex,
    tables: &[&DeviceTable],
    msg: &JointState_,
) -> Result<Vec<(usize, FrontCommand)>, Rejection> {
    if msg.name.is_empty() {
        return Err(Rejection::NoJoints);
    }
    if msg.position.len() != msg.name.len() {
        return Err(Rejection::WrongCount {
            got: msg.position.len(),
            want: msg.name.len(),
        });
    }
    let mut per: Vec<Option<Vec<Option<JointCommand>>>> = vec![None; tables.len()];
    for (i, (name, &pos)) in msg.name.iter().zip(&msg.position).enumerate() {
        let &(d, j) = index
            .by_name
            .get(name)
            .filter(|(d, _)| *d < tables.len())
            .ok_or_else(|| Rejection::UnknownJoint(name.clone()))?;
        let q = pos as f32;
        if !pos.is_finite() || !q.is_finite() {
            return Err(Rejection::NonFinite(i));
        }
        let table = tables[d];
        let joints = per[d].get_or_insert_with(|| vec![None; table.joints.len()]);
        if joints[j.index()].is_some() {
            return Err(Rejection::DuplicateJoint(name.clone()));
        }
        let (kp, kd) = position_gains(table);
        joints[j.index()] = Some(JointCommand::hold(canonical_q(table, j, q), kp, kd));
    }
    Ok(per
        .into_iter()
        .enumerate()
        .filter_map(|(d, j)| {
            j.map(|joints| {
                let c = FrontCommand {
                    joints,
                    timeout_bit: false,
                    tag: 0,
                };
                (d, c)
            })
        })
        .collect())
}

/// A joint_state_command front's topic when `topic` is not set: the plugin's default
/// `joint_commands_topic`, `/robot_joint_commands`, as DDS names it.
pub const DEFAULT_TOPIC: &str = "rt/robot_joint_commands";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::front::joint_state::{append, header};
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, HandState, Side};

    fn table(kind: DeviceKind, side: Side) -> DeviceTable {
        kind.table(side, &TableOverrides::default()).unwrap()
    }

    fn msg(joints: &[(&str, f64)]) -> JointState_ {
        JointState_ {
            name: joints.iter().map(|(n, _)| n.to_string()).collect(),
            position: joints.iter().map(|(_, q)| *q).collect(),
            ..Default::default()
        }
    }

    /// A Dex3 (wire frame), an Inspire DFX hand (canonical frame) and a Dex1 gripper.
    fn three() -> Vec<(&'static str, DeviceTable)> {
        vec![
            ("dex3_left", table(DeviceKind::Dex3, Side::Left)),
            ("inspire_dfx_right", table(DeviceKind::InspireDfx, Side::Right)),
            ("dex1_left", table(DeviceKind::Dex1, Side::Left)),
        ]
    }

    fn index(devs: &[(&'static str, DeviceTable)], urdf: bool) -> JointIndex {
        JointIndex::new(devs.iter().map(|(n, t)| (*n, t)), urdf)
    }

    fn tables<'a>(devs: &'a [(&'static str, DeviceTable)]) -> Vec<&'a DeviceTable> {
        devs.iter().map(|(_, t)| t).collect()
    }

    /// `m` decoded against [`three`] (`urdf`: URDF names).
    fn decode3(urdf: bool, m: &JointState_) -> Result<Vec<(usize, FrontCommand)>, Rejection> {
        let devs = three();
        decode(&index(&devs, urdf), &tables(&devs), m)
    }

    /// The canonical index of the joint of `t` whose URDF name is `urdf`.
    fn at(t: &DeviceTable, urdf: &str) -> usize {
        t.joints.iter().position(|m| m.urdf == urdf).unwrap()
    }

    #[test]
    fn a_subset_of_one_device_sets_those_joints_and_leaves_the_others_unset() {
        let devs = three();
        let got = decode3(true, &msg(&[("left_hand_three_joint", -0.5)])).unwrap();
        assert_eq!(got.len(), 1, "{got:?}");
        let (d, c) = &got[0];
        let joints = &c.joints;
        assert_eq!(*d, 0);
        let t = &devs[0].1;
        let i = t.joint_by_name("index_0").unwrap().index();
        assert_eq!(joints.iter().filter(|j| j.is_some()).count(), 1);
        let c = joints[i].unwrap();
        // Dex3: the URDF angle is the wire value; the canonical value is its inverse.
        assert!((t.joints[i].q_to_wire(c.q) + 0.5).abs() < 1e-6, "{c:?}");
        assert_eq!((c.kp, c.kd), position_gains(t));
        assert_eq!((c.dq, c.tau), (0.0, 0.0));
    }

    /// The positions `rt/joint_states` publishes for a state decode back to that state, for a
    /// wire-frame table (Dex3, Dex1) and a canonical-frame one (Inspire DFX): the command front
    /// reads what the state front writes.
    #[test]
    fn what_joint_states_publishes_decodes_to_the_same_canonical_positions() {
        let devs = three();
        let ix = index(&devs, true);
        let mut out = header(std::time::SystemTime::now(), "");
        let mut want = Vec::new();
        for (name, t) in &devs {
            let mut st = HandState::empty(t.joints.len());
            for (k, (m, j)) in t.joints.iter().zip(st.joints.iter_mut()).enumerate() {
                // A point inside each joint's limits, different per joint.
                j.q = m.limits.min + m.limits.span() * (0.2 + 0.1 * k as f32);
            }
            append(&mut out, t, &st, true, name);
            want.push(st.joints.iter().map(|j| j.q).collect::<Vec<f32>>());
        }
        let got = decode(&ix, &tables(&devs), &out).unwrap();
        assert_eq!(got.iter().map(|(d, _)| *d).collect::<Vec<_>>(), [0, 1, 2]);
        for (d, c) in got {
            let q: Vec<f32> = c.joints.iter().map(|j| j.unwrap().q).collect();
            for (a, b) in q.iter().zip(&want[d]) {
                assert!((a - b).abs() < 1e-5, "{}: {q:?} vs {:?}", devs[d].0, want[d]);
            }
        }
    }

    #[test]
    fn an_inspire_urdf_angle_is_its_canonical_radians_and_a_dex3_one_its_wire_angle() {
        let devs = three();
        let got = decode3(
            true,
            &msg(&[("R_index_proximal_joint", 1.0), ("left_hand_zero_joint", 0.3)]),
        )
        .unwrap();
        let by_dev: HashMap<usize, &Vec<Option<JointCommand>>> = got.iter().map(|(d, c)| (*d, &c.joints)).collect();
        let i = at(&devs[1].1, "R_index_proximal_joint");
        assert_eq!(by_dev[&1][i].unwrap().q, 1.0, "canonical frame: as sent");
        let dex3 = &devs[0].1;
        let k = at(dex3, "left_hand_zero_joint");
        assert_eq!(by_dev[&0][k].unwrap().q, dex3.joints[k].q_from_wire(0.3));
    }

    #[test]
    fn one_message_naming_three_devices_is_one_command_per_device() {
        let got = decode3(
            true,
            &msg(&[
                ("left_gripper_joint", 0.01),
                ("R_pinky_proximal_joint", 0.5),
                ("left_hand_one_joint", 0.2),
                ("R_ring_proximal_joint", 0.5),
            ]),
        )
        .unwrap();
        let named: Vec<(usize, usize)> = got
            .iter()
            .map(|(d, c)| (*d, c.joints.iter().filter(|j| j.is_some()).count()))
            .collect();
        assert_eq!(named, [(0, 1), (1, 2), (2, 1)]);
    }

    #[test]
    fn an_unknown_name_a_non_finite_position_or_a_count_mismatch_rejects_the_whole_message() {
        assert_eq!(
            decode3(true, &msg(&[("left_hand_one_joint", 0.2), ("elbow", 0.1)])),
            Err(Rejection::UnknownJoint("elbow".into()))
        );
        for bad in [f64::NAN, f64::INFINITY, 1e300] {
            assert_eq!(
                decode3(true, &msg(&[("left_hand_one_joint", 0.2), ("left_gripper_joint", bad)])),
                Err(Rejection::NonFinite(1)),
                "{bad}"
            );
        }
        let mut m = msg(&[("left_hand_one_joint", 0.2), ("left_gripper_joint", 0.0)]);
        m.position.pop();
        assert_eq!(decode3(true, &m), Err(Rejection::WrongCount { got: 1, want: 2 }));
        // Velocity and effort are not read (a position-only client leaves them empty; one
        // that fills them does not change what the hand is told).
        m.position.push(0.0);
        m.velocity = vec![f64::NAN];
        assert!(decode3(true, &m).is_ok());
        assert_eq!(decode3(true, &msg(&[])), Err(Rejection::NoJoints));
        assert_eq!(
            decode3(true, &msg(&[("left_gripper_joint", 0.0), ("left_gripper_joint", 0.1)])),
            Err(Rejection::DuplicateJoint("left_gripper_joint".into()))
        );
    }

    #[test]
    fn without_urdf_names_joints_are_device_slash_canonical_name() {
        assert_eq!(index(&three(), false).len(), 7 + 6 + 1);
        let got = decode3(false, &msg(&[("dex1_left/jaw", 0.5)])).unwrap();
        assert_eq!(got[0].0, 2);
        assert_eq!(
            decode3(false, &msg(&[("left_gripper_joint", 0.5)])),
            Err(Rejection::UnknownJoint("left_gripper_joint".into()))
        );
    }
}
