//! Inspire DFX mapping (docs/sources.md §7 "Inspire DFX" and "URDF joint names"; docs/model.md).
//!
//! Six canonical joints per hand, in the service's order within a hand (wire index = position
//! in the hand's six entries; the hand's element puts them at 0–5 right or 6–11 left, see
//! `adapter`): pinky, ring, middle, index, thumb bend, thumb rotation. Canonical positions are
//! the URDF joints' radians, positive = closing on both hands (no mirror image). The wire
//! value is xr_teleoperate's normalisation `q = (max − rad) / (max − min)`: **1 = open** at the
//! URDF lower limit, 0 = closed at the upper limit. In `mapping`'s affine form
//! `wire = offset + sign · scale · rad` that is sign −1, scale `1 / (max − min)`, offset
//! `max / (max − min)`: the "1 = open" convention lives here, not in code.

use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side};

/// Canonical joint names, canonical order (= the service's order within a hand).
pub const JOINTS: [&str; 6] = ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"];

/// URDF actuated joint (without the `L_` / `R_` prefix) and its limits (min, max) in rad, per
/// canonical joint (docs/sources.md §7 "URDF joint names": fingers [0, 1.7], thumb bend
/// [0, 0.5], thumb rotation [−0.1, 1.3]).
pub const URDF: [(&str, f32, f32); 6] = [
    ("pinky_proximal_joint", 0.0, 1.7),
    ("ring_proximal_joint", 0.0, 1.7),
    ("middle_proximal_joint", 0.0, 1.7),
    ("index_proximal_joint", 0.0, 1.7),
    ("thumb_proximal_pitch_joint", 0.0, 0.5),
    ("thumb_proximal_yaw_joint", -0.1, 1.3),
];

/// Gains a canonical hold carries. The service uses only `q` (docs/sources.md §7: dq, tau,
/// kp, kd and mode are ignored), so these never reach the wire; they only fill the canonical
/// commands the closure map and holds produce.
pub const NOMINAL_KP: f32 = 1.0;
pub const NOMINAL_KD: f32 = 0.0;

/// The URDF prefix of a side (`L_` / `R_`; a center hand has no URDF, it gets `C_`).
pub fn urdf_prefix(side: Side) -> &'static str {
    match side {
        Side::Left => "L_",
        Side::Right => "R_",
        Side::Center => "C_",
    }
}

/// The six joints of an Inspire hand on `side` (its URDF names and ranges), the wire reading
/// `full` at the open end of each range and 0 at the closed end (the DFX service's 0..1, the FTP
/// driver's 0..1000 register): one home for both Inspire kinds' joint maps.
pub fn joints(side: Side, full: f32) -> Vec<JointMap> {
    JOINTS
        .iter()
        .zip(URDF)
        .enumerate()
        .map(|(i, (name, (urdf, min, max)))| {
            let span = max - min;
            JointMap {
                name,
                wire_index: i,
                urdf: format!("{}{urdf}", urdf_prefix(side)),
                sign: -1.0,
                scale: full / span,
                offset: full * max / span,
                limits: Limits::new(min, max),
            }
        })
        .collect()
}

/// The Inspire DFX table for one hand.
pub fn table(side: Side) -> DeviceTable {
    let joints = joints(side, 1.0);
    DeviceTable {
        kind: DeviceKind::InspireDfx,
        side,
        joints,
        // Open = every joint at its URDF lower limit (wire 1.0), closed = the upper (wire 0.0).
        closure: ClosureMap::Postures {
            open: URDF.iter().map(|u| u.1).collect(),
            closed: URDF.iter().map(|u| u.2).collect(),
            kp: NOMINAL_KP,
            kd: NOMINAL_KD,
        },
        hold_kp: NOMINAL_KP,
        hold_kd: NOMINAL_KD,
        max_step: None,
        max_kp: 50.0,
        max_kd: 5.0,
        max_tau: 1.0,
        urdf_frame: crate::mapping::UrdfFrame::Canonical,
        // DFX_inspire_service publishes positions only (no effort: tau is 0), so nothing tells
        // an object from a stuck finger and a closing finger stopped short stays a fault by
        // default; `[devices.motion] contact = "unmeasured"` takes it as holding instead
        // (docs/adapters.md, "Motion").
        motion: crate::motion::MotionThresholds::HAND,
    }
}
