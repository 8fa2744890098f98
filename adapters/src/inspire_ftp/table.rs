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

use crate::mapping::{ClosureMap, DeviceTable};
use crate::model::{DeviceKind, Side};

/// The Inspire hand's joints and its URDF (names, ranges): the FTP is the DFX's hand with
/// tactile sensors, one model (docs/sources.md §7, "URDF joint names"), kept once in the DFX
/// table. Canonical (= wire) order: the driver's array order.
pub use crate::inspire_dfx::table::{urdf_prefix, JOINTS, URDF};

/// URDF ranges (rad) of the actuated joints in message order, from [`URDF`].
pub const URDF_RANGE: [(f32, f32); 6] = {
    let mut r = [(0.0, 0.0); 6];
    let mut i = 0;
    while i < 6 {
        r[i] = (URDF[i].1, URDF[i].2);
        i += 1;
    }
    r
};

/// Angle register at the open end (finger straight) and the closed end (docs/sources.md §7).
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

/// The Inspire FTP table for `side` (both hands map the same way: no mirror image).
pub fn table(side: Side) -> DeviceTable {
    let joints = crate::inspire_dfx::table::joints(side, ANGLE_OPEN);
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
        // Contact is what the hand reports: an actuator stopped at its force limit or pressing
        // (the adapter's `HandState::contact`).
        motion: crate::motion::MotionThresholds::HAND.with_contact(crate::motion::Contact::Reported),
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
