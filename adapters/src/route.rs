//! The router: maps what a front received (in the front's own device layout, already turned
//! canonical through the front's table) onto the bound device, and the device's canonical
//! state back into the front's layout. Any front can drive any device:
//!
//! - **joint-for-joint** when the front's and the device's tables name the same joints with
//!   the same limits (Dex3 front → Dex3 device on either transport, Dex1 front → EZGripper);
//! - **through closure** otherwise (Dex1 front → Dex3 hand: the jaw's closure closes the hand;
//!   Dex3 front → gripper: the mean closure of the hand's joints closes the gripper), and the
//!   device's estimated closure comes back as the front's posture at that closure.

use std::sync::Arc;

use crate::mapping::DeviceTable;
use crate::model::{CommandBody, JointCommand, JointId, JointState};

/// A front bound to a device, decided once at bind time: the front's table (the wire
/// convention it speaks), the device's table and how the two are paired.
#[derive(Debug, Clone)]
pub struct Route {
    pub front: Arc<DeviceTable>,
    pub device: Arc<DeviceTable>,
    pub pairing: Pairing,
}

impl Route {
    /// Binds `front` to `device`.
    pub fn bind(front: Arc<DeviceTable>, device: Arc<DeviceTable>) -> Self {
        let pairing = pairing(&front, &device);
        Self { front, device, pairing }
    }

    /// A command the front decoded (the FRONT's canonical order) as the device's.
    pub fn command(&self, cmds: &[Option<JointCommand>]) -> CommandBody {
        command_for(self.pairing, &self.front, cmds)
    }

    /// The device's state in the FRONT's canonical joint order.
    pub fn state(&self, joints: &[JointState], closure: f32) -> Vec<JointState> {
        state_for(self.pairing, &self.front, joints, closure)
    }
}

/// How a front and a device are paired.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pairing {
    JointForJoint,
    Closure,
}

/// Decides the pairing of two tables.
pub fn pairing(front: &DeviceTable, device: &DeviceTable) -> Pairing {
    let same = front.joints.len() == device.joints.len()
        && front
            .joints
            .iter()
            .zip(&device.joints)
            .all(|(a, b)| a.name == b.name && a.limits == b.limits);
    if same {
        Pairing::JointForJoint
    } else {
        Pairing::Closure
    }
}

/// A command the front decoded: canonical commands in the FRONT's canonical order
/// (None = the front message did not set that joint).
pub fn route_command(front: &DeviceTable, device: &DeviceTable, cmds: &[Option<JointCommand>]) -> CommandBody {
    command_for(pairing(front, device), front, cmds)
}

fn command_for(pairing: Pairing, front: &DeviceTable, cmds: &[Option<JointCommand>]) -> CommandBody {
    match pairing {
        Pairing::JointForJoint => CommandBody::Joints(
            cmds.iter()
                .enumerate()
                .filter_map(|(i, c)| c.map(|c| (JointId(i as u8), c)))
                .collect(),
        ),
        Pairing::Closure => {
            let q: Vec<f32> = cmds.iter().map(|c| c.map(|c| c.q).unwrap_or(f32::NAN)).collect();
            CommandBody::Closure {
                closure: front.closure_of(&q),
                stiffness: None,
            }
        }
    }
}

/// The device's state in the FRONT's canonical joint order.
pub fn route_state(front: &DeviceTable, device: &DeviceTable, joints: &[JointState], closure: f32) -> Vec<JointState> {
    state_for(pairing(front, device), front, joints, closure)
}

fn state_for(pairing: Pairing, front: &DeviceTable, joints: &[JointState], closure: f32) -> Vec<JointState> {
    match pairing {
        Pairing::JointForJoint => joints.to_vec(),
        Pairing::Closure => {
            let temp = joints
                .iter()
                .filter_map(|j| j.temperature)
                .fold(None, |m: Option<f32>, t| Some(m.map_or(t, |m| m.max(t))));
            let posture = front.closure_targets(closure, None).unwrap_or_default();
            front
                .joints
                .iter()
                .enumerate()
                .map(|(i, _)| JointState {
                    q: posture.get(i).map(|c| c.q).unwrap_or(0.0),
                    dq: 0.0,
                    tau: 0.0,
                    temperature: temp,
                })
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, Side};

    fn t(kind: DeviceKind, side: Side) -> DeviceTable {
        kind.table(side, &TableOverrides::default()).unwrap()
    }

    #[test]
    fn dex1_front_drives_ezgripper_joint_for_joint() {
        let f = t(DeviceKind::Dex1, Side::Left);
        let d = t(DeviceKind::Ezgripper, Side::Left);
        assert_eq!(pairing(&f, &d), Pairing::JointForJoint);
        // A Dex1 client sends q = 2.7 rad (half open): canonical jaw = 2.7, EZGripper 50 %.
        let c = f.joints[0].from_wire(&crate::mapping::WireTarget {
            q: 2.7,
            kp: 5.0,
            ..Default::default()
        });
        let body = route_command(&f, &d, &[Some(c)]);
        let targets = d.resolve(&body, None, &[]).unwrap();
        assert!((d.to_wire(&targets)[0].q - 50.0).abs() < 1e-3);
    }

    #[test]
    fn dex1_front_closes_a_dex3_hand_through_closure() {
        let f = t(DeviceKind::Dex1, Side::Right);
        let d = t(DeviceKind::Dex3, Side::Right);
        assert_eq!(pairing(&f, &d), Pairing::Closure);
        let closed = f.joints[0].from_wire(&crate::mapping::WireTarget {
            q: 0.0,
            ..Default::default()
        });
        match route_command(&f, &d, &[Some(closed)]) {
            CommandBody::Closure { closure, .. } => assert!((closure - 1.0).abs() < 1e-6),
            b => panic!("{b:?}"),
        }
        // State back: a half-closed hand shows as a half-closed gripper.
        let s = route_state(&f, &d, &[JointState::default(); 7], 0.5);
        assert!((f.joints[0].q_to_wire(s[0].q) - 2.7).abs() < 1e-4);
    }

    #[test]
    fn dex3_fronts_of_either_side_pair_joint_for_joint_with_dex3() {
        for (a, b) in [(Side::Left, Side::Left), (Side::Left, Side::Right)] {
            assert_eq!(
                pairing(&t(DeviceKind::Dex3, a), &t(DeviceKind::Dex3, b)),
                Pairing::JointForJoint
            );
        }
    }
}
