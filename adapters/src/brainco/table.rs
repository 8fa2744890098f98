//! BrainCo Revo2 mapping (docs/sources.md §7 "BrainCo Revo2" and "URDF joint names").
//!
//! Wire: 6 entries per hand in the Revo2 driver's motor order 0 thumb, 1 thumb auxiliary,
//! 2 index, 3 middle, 4 ring, 5 pinky; `q` in [0, 1] with **1 = closed, 0 = open** on both
//! hands. Canonical: the URDF joint each entry drives, in radians, `rad = min + q·(max − min)`
//! with `min = 0` on every joint, so canonical positive = closing = wire positive (no mirror
//! image between the hands). The normalisation lives in the table alone:
//! `wire_q = offset + sign·scale·rad` with offset 0, sign +1, scale `1 / max`.
//!
//! Canonical order is the wire order (names are the driver's: `thumb`, `thumb_aux`, `index`,
//! `middle`, `ring`, `pinky`). Which physical motion the thumb's two motors make is not
//! asserted here: §7 only pins each entry to its URDF joint (`thumb_metacarpal_joint`,
//! `thumb_proximal_joint`).

use crate::mapping::{DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side};

/// Canonical joint names, canonical order (= wire order).
pub const JOINTS: [&str; 6] = ["thumb", "thumb_aux", "index", "middle", "ring", "pinky"];

/// The URDF joint each entry drives, without the `left_` / `right_` prefix (docs/sources.md
/// §7 "URDF joint names"; the right hand's names are the left's with `right_`, an inference
/// recorded there).
pub const URDF_JOINTS: [&str; 6] = [
    "thumb_metacarpal_joint",
    "thumb_proximal_joint",
    "index_proximal_joint",
    "middle_proximal_joint",
    "ring_proximal_joint",
    "pinky_proximal_joint",
];

/// Upper URDF limit of each entry's joint, rad (lower limit 0 for all; docs/sources.md §7:
/// thumb [0, 1.5184], thumb aux [0, 1.0472], fingers [0, 1.4661]).
/// The URDF's literal figures (1.0472 is its value, not π/3).
#[allow(clippy::approx_constant)]
pub const URDF_MAX_RAD: [f32; 6] = [1.5184, 1.0472, 1.4661, 1.4661, 1.4661, 1.4661];

/// Gains of closure and hold targets. `brainco_hand_service` ignores kp and kd (docs/sources.md
/// §7): these only keep canonical commands well-formed; the position is what moves the hand.
pub const KP: f32 = 1.0;
pub const KD: f32 = 0.0;

/// The BrainCo Revo2 table for one side.
pub fn table(side: Side) -> DeviceTable {
    let joints = JOINTS
        .iter()
        .zip(URDF_JOINTS)
        .zip(URDF_MAX_RAD)
        .enumerate()
        .map(|(i, ((name, urdf), max))| JointMap {
            name,
            wire_index: i,
            urdf: format!("{}_{urdf}", side.as_str()),
            sign: 1.0,
            scale: 1.0 / max,
            offset: 0.0,
            limits: Limits::new(0.0, max),
        })
        .collect();
    let mut t = DeviceTable::with_postures(
        DeviceKind::Brainco,
        side,
        joints,
        (vec![0.0; JOINTS.len()], URDF_MAX_RAD.to_vec()),
        (KP, KD),
        crate::mapping::UrdfFrame::Canonical,
    );
    t.motion = t.motion.with_contact(crate::motion::Contact::Effort(CONTACT_CURRENT_A));
    t
}

/// The motor current (A, the state's `tau_est`) from which a finger that stopped closing counts
/// as pressing on an object. Assumption: twice an idle finger's current (the emulator's 0.02 A,
/// noise 5 mA) is contact; a finger closing freely is judged only once it stops.
pub const CONTACT_CURRENT_A: f32 = 0.04;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_is_wire_one_and_open_wire_zero_on_both_sides() {
        for side in [Side::Left, Side::Right] {
            let t = table(side);
            let w = t.to_wire(&t.closure_targets(1.0, None).unwrap());
            assert!(w.iter().all(|w| (w.q - 1.0).abs() < 1e-6), "{w:?}");
            let w = t.to_wire(&t.closure_targets(0.0, None).unwrap());
            assert!(w.iter().all(|w| w.q == 0.0), "{w:?}");
            assert_eq!(t.joints[0].urdf, format!("{side}_thumb_metacarpal_joint"));
        }
    }
}
