//! Inspire FTP (RH56DFTP) mapping: six canonical joints, positive = closing, in URDF radians.
//!
//! The wire value is the hand's ANGLE register, 0–1000, **1000 = open (finger straight),
//! 0 = closed** (docs/sources.md §7, "Inspire FTP"). xr_teleoperate and the URDF relate the two
//! by `rad = max − (angle / 1000) · (max − min)` with the URDF range of each joint
//! (docs/sources.md §7, "URDF joint names"), and the URDF closes with positive radians on both
//! hands (no mirror image). So canonical q = URDF rad and, per joint,
//! `angle = 1000 · max / (max − min) − (1000 / (max − min)) · q`: `offset` = 1000·max/span,
//! `sign` = −1, `scale` = 1000/span angle units per rad. The "1 = open" normalisation is this
//! table's, not code's.
//!
//! Wire order = canonical order = the driver's array order: 0 pinky, 1 ring, 2 middle,
//! 3 index, 4 thumb bend, 5 thumb rotation.

use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side};

/// Canonical joints, canonical (= wire) order.
pub const JOINTS: [&str; 6] = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];

/// URDF ranges (rad) of the actuated joints in message order (docs/sources.md §7, "URDF joint
/// names": index 0–3 [0, 1.7], thumb bend [0, 0.5], thumb rotation [−0.1, 1.3]).
pub const URDF_RANGE: [(f32, f32); 6] = [(0.0, 1.7), (0.0, 1.7), (0.0, 1.7), (0.0, 1.7), (0.0, 0.5), (-0.1, 1.3)];

/// URDF actuated joint names without the side prefix (`L_` / `R_`), message order
/// (docs/sources.md §7, "URDF joint names").
pub const URDF_JOINTS: [&str; 6] = [
    "pinky_proximal_joint",
    "ring_proximal_joint",
    "middle_proximal_joint",
    "index_proximal_joint",
    "thumb_proximal_pitch_joint",
    "thumb_proximal_yaw_joint",
];

/// Angle register at the open end (finger straight) and the closed end.
pub const ANGLE_OPEN: f32 = 1000.0;
pub const ANGLE_CLOSED: f32 = 0.0;

/// The closed posture of a hand-level closure of 1: Unitree's FTP page's first example command,
/// angles `[0, 0, 0, 0, 1000, 1000]` ("makes a fist": the four fingers closed, the thumb
/// straight and unrotated, so it never collides with the fingers; docs/sources.md §7), in
/// canonical rad.
pub const CLOSED_POSTURE: [f32; 6] = [1.7, 1.7, 1.7, 1.7, 0.0, -0.1];
/// The open posture: every angle 1000 (what xr_teleoperate starts from).
pub const OPEN_POSTURE: [f32; 6] = [0.0, 0.0, 0.0, 0.0, 0.0, -0.1];

/// The hand runs its own position loop; no gain is on the wire. These only fill the table's
/// gain fields (closure and hold commands carry them; the codec never sends them).
pub const NOMINAL_KP: f32 = 1.0;
pub const NOMINAL_KD: f32 = 0.1;

/// URDF side prefix: `L_` / `R_`.
pub fn urdf_prefix(side: Side) -> &'static str {
    match side {
        Side::Right => "R_",
        _ => "L_",
    }
}

/// The Inspire FTP table for `side` (both hands map the same way: no mirror image).
pub fn table(side: Side) -> DeviceTable {
    let joints = JOINTS
        .iter()
        .zip(URDF_RANGE)
        .zip(URDF_JOINTS)
        .enumerate()
        .map(|(i, ((name, (min, max)), urdf))| {
            let span = max - min;
            JointMap {
                name,
                wire_index: i,
                urdf: format!("{}{urdf}", urdf_prefix(side)),
                sign: -1.0,
                scale: ANGLE_OPEN / span,
                offset: ANGLE_OPEN * max / span,
                limits: Limits::new(min, max),
            }
        })
        .collect();
    DeviceTable {
        kind: DeviceKind::InspireFtp,
        side,
        joints,
        closure: ClosureMap::Postures {
            open: OPEN_POSTURE.to_vec(),
            closed: CLOSED_POSTURE.to_vec(),
            kp: NOMINAL_KP,
            kd: NOMINAL_KD,
        },
        hold_kp: NOMINAL_KP,
        hold_kd: NOMINAL_KD,
        max_step: None,
        max_kp: 10.0,
        max_kd: 1.0,
        max_tau: 1.0,
        urdf_frame: crate::mapping::UrdfFrame::Canonical,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_ends_of_every_joint() {
        for side in [Side::Left, Side::Right] {
            let t = table(side);
            for (j, (min, max)) in t.joints.iter().zip(URDF_RANGE) {
                assert!((j.q_to_wire(min) - 1000.0).abs() < 1e-3, "{} open", j.name);
                assert!(j.q_to_wire(max).abs() < 1e-3, "{} closed", j.name);
            }
        }
        assert_eq!(table(Side::Right).joints[5].urdf, "R_thumb_proximal_yaw_joint");
    }
}
