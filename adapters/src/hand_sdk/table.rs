//! `rt/hand_sdk` mapping (docs/sources.md §6): 4 motors in a unitree_go MotorCmds_, positive tau closes
//! (the same sign as canonical), units as ai_sport's. Which motor drives which finger or hand,
//! and the position range, are unpublished: the joints are `motor_0..motor_3` and the limits
//! are wide placeholders until checked on a robot (profile-overridable).

use super::JOINTS;
use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side};

/// The unitree_sdk2 example toggles tau between these to close and open.
pub const EXAMPLE_TAU_CLOSE: f32 = 0.3;
pub const EXAMPLE_TAU_OPEN: f32 = -0.3;
/// Placeholder position limits (rad) until the motors' ranges are known.
pub const PLACEHOLDER_LIMIT: f32 = std::f32::consts::PI;

pub fn table(side: Side) -> DeviceTable {
    let joints = JOINTS
        .iter()
        .enumerate()
        .map(|(i, name)| JointMap {
            name,
            wire_index: i,
            urdf: format!("hand_sdk_{name}"),
            sign: 1.0,
            scale: 1.0,
            offset: 0.0,
            limits: Limits::new(-PLACEHOLDER_LIMIT, PLACEHOLDER_LIMIT),
        })
        .collect();
    DeviceTable {
        kind: DeviceKind::HandSdk,
        side,
        joints,
        closure: ClosureMap::Torque {
            open: EXAMPLE_TAU_OPEN,
            closed: EXAMPLE_TAU_CLOSE,
        },
        hold_kp: 0.0,
        hold_kd: 0.0,
        max_step: None,
        max_kp: 10.0,
        max_kd: 1.0,
        max_tau: 1.0,
        urdf_frame: crate::mapping::UrdfFrame::Wire,
        motion: crate::motion::MotionThresholds::HAND,
    }
}
