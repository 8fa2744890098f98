//! LEAP Hand mapping (docs/leap.md, "Units").
//!
//! Sixteen canonical joints, one per servo, in motor-id order: `index_0..3` (ids 0-3),
//! `middle_0..3` (4-7), `ring_0..3` (8-11), `thumb_0..3` (12-15); joint 0 of each finger is its
//! MCP side joint. URDF names are the LEAP URDF's, `0`..`15` (LEAP_Hand_Sim
//! `assets/leap_hand/robot.urdf`).
//!
//! Canonical positions are the URDF's angles (the sim frame: 0 = the flat hand, positive =
//! closing, the LEAP convention "applying a positive angle closes the joints more and more").
//! The wire value is the LEAP API's unit, the motor's angle in radians (ticks × 2π/4096), where
//! 180° is flat: `wire = π + q` (`leap_hand_utils.LEAPsim_to_LEAPhand`), so sign +1, scale 1,
//! offset π. Limits are the URDF's (= `LEAPsim_limits`).

use crate::mapping::{DeviceTable, JointMap, Limits, UrdfFrame};
use crate::model::{DeviceKind, Side};

/// Canonical joint names, canonical order (= motor ids 0..15).
pub const JOINTS: [&str; 16] = [
    "index_0", "index_1", "index_2", "index_3", "middle_0", "middle_1", "middle_2", "middle_3", "ring_0", "ring_1",
    "ring_2", "ring_3", "thumb_0", "thumb_1", "thumb_2", "thumb_3",
];

/// URDF limits (rad, sim frame) per joint: LEAP_Hand_Sim's `robot.urdf` (the same numbers as
/// `leap_hand_utils.LEAPsim_limits("regular")`).
pub const URDF_LIMITS: [(f32, f32); 16] = [
    (-1.047, 1.047),
    (-0.314, 2.23),
    (-0.506, 1.885),
    (-0.366, 2.042),
    (-1.047, 1.047),
    (-0.314, 2.23),
    (-0.506, 1.885),
    (-0.366, 2.042),
    (-1.047, 1.047),
    (-0.314, 2.23),
    (-0.506, 1.885),
    (-0.366, 2.042),
    (-0.349, 2.094),
    (-0.47, 2.443),
    (-1.20, 1.90),
    (-1.34, 1.88),
];

/// The wire position of canonical 0 (the flat hand): 180° \[LEAP\].
pub const WIRE_OFFSET: f32 = std::f32::consts::PI;

/// Closure 1: a fist inside the URDF limits (handgate's choice: the LEAP sources define
/// none). Side joints stay at 0; each finger's MCP, PIP and DIP at about 3/4 of their range;
/// the thumb folded across the palm.
pub const CLOSED: [f32; 16] = [
    0.0, 1.6, 1.4, 1.5, 0.0, 1.6, 1.4, 1.5, 0.0, 1.6, 1.4, 1.5, 1.4, 0.6, 0.6, 1.2,
];

/// Stiffness and damping a canonical hold carries. The servos' own PID (P 600 / D 200) does
/// the holding; these only fill the canonical commands the closure map and holds produce.
pub const NOMINAL_KP: f32 = 1.0;
pub const NOMINAL_KD: f32 = 0.05;

/// The LEAP Hand's table (the same for both sides: the LEAP Hand v1 is a right hand, a left
/// one is its mirror build with the same motor ids and directions).
pub fn table(side: Side) -> DeviceTable {
    let joints = JOINTS
        .iter()
        .zip(URDF_LIMITS)
        .enumerate()
        .map(|(i, (name, (min, max)))| JointMap {
            name,
            wire_index: i,
            urdf: i.to_string(),
            sign: 1.0,
            scale: 1.0,
            offset: WIRE_OFFSET,
            limits: Limits::at_stops(min, max),
        })
        .collect();
    DeviceTable {
        max_tau: 1.0,
        ..DeviceTable::with_postures(
            DeviceKind::Leap,
            side,
            joints,
            (vec![0.0; 16], CLOSED.to_vec()),
            (NOMINAL_KP, NOMINAL_KD),
            UrdfFrame::Canonical,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_is_180_degrees_and_closing_is_positive() {
        let t = table(Side::Right);
        assert_eq!(t.joints.len(), 16);
        for (i, j) in t.joints.iter().enumerate() {
            assert_eq!(j.urdf, i.to_string());
            assert!((j.q_to_wire(0.0) - std::f32::consts::PI).abs() < 1e-6);
            assert!(j.q_to_wire(0.5) > j.q_to_wire(0.0), "{}", j.name);
            assert!(j.limits.contains(CLOSED[i]), "{} closed {}", j.name, CLOSED[i]);
            assert!(j.limits.contains(0.0));
        }
        // leap_hand_utils: LEAP = sim + π.
        assert!((t.joints[13].q_from_wire(std::f32::consts::PI + 1.0) - 1.0).abs() < 1e-6);
        assert_eq!(t.closure_of(&[0.0; 16]), 0.0);
        assert!((t.closure_of(&CLOSED) - 1.0).abs() < 1e-6);
    }
}
