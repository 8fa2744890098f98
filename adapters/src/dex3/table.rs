//! Dex3-1 mapping table: canonical joint ↔ IDL index ↔ URDF joint, sign and limits.
//!
//! Sources (docs/sources.md §2): IDL order 0 thumb_0, 1 thumb_1, 2 thumb_2, 3 middle_0, 4 middle_1,
//! 5 index_0, 6 index_1 on both hands. URDF: left `zero, one, two, five, six, three, four`
//! → IDL 0..6 (the left URDF's three/four are the index finger, five/six the middle);
//! right `zero..six` in order. Limits: the hardware's range from the Dex3-1 manual (see
//! [`LEFT_WIRE_LIMITS`]; docs/model.md compares it with the URDF's and the SDK example's). The hands are
//! mirror images: closing a finger is negative on the left and positive on the right, so
//! the canonical sign (positive = closing) is -1 for left fingers and +1 for right fingers.
//! Thumb: every thumb joint's range is the mirror of the other hand's; handgate takes the
//! larger excursion of thumb_1 and the whole excursion of thumb_2 (toward the fingers) as
//! closing, which is positive on the left and negative on the right; thumb_0 (rotation,
//! symmetric range) follows the same mirror so one canonical posture gives mirror-image
//! motions on both hands (docs/model.md).

use super::JOINTS;
use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side};

/// URDF joint suffix per IDL index, per side.
const URDF_LEFT: [&str; 7] = ["zero", "one", "two", "five", "six", "three", "four"];
const URDF_RIGHT: [&str; 7] = ["zero", "one", "two", "three", "four", "five", "six"];

/// Left-hand wire limits (rad) per IDL index: the soft limits handgate clamps commands to by
/// default (profiles override them with `[devices.limits.joints]`).
///
/// Three sources disagree on thumb_1 only (docs/model.md has the whole table): the Dex3-1
/// manual's −35°..60° (−0.6109..1.0472), the URDF xr_teleoperate uses (−0.7243..0.920) and
/// the unitree_sdk2 example `g1_dex3_example.cpp` (−0.724..1.05, which it sweeps end to end).
/// Every other joint's range is the same in the manual and the URDF (60°, 90°, 100°), and
/// the SDK example's values are those rounded to two decimals. Rule: as far as the official
/// examples ask, but never beyond the hardware's range. So thumb_1 is the manual's
/// −0.6109..1.0472 (rounded inward to −0.6108): the SDK example's 1.05 is reachable to within 0.003 rad (the URDF's 0.920
/// left its thumb 0.13 rad short, xr_teleoperate #229), and its −0.724 stops at the manual's
/// −35°. The values are written out (4 decimals, as the URDF's) rather than taken from
/// [`super::physical`], the emulators' hard stops: the two are separate facts that happen to
/// coincide by default.
#[allow(clippy::approx_constant)]
pub const LEFT_WIRE_LIMITS: [(f32, f32); 7] = [
    (-1.0472, 1.0472), // thumb_0
    (-0.6108, 1.0472), // thumb_1
    (0.0, 1.7453),     // thumb_2
    (-1.5708, 0.0),    // middle_0
    (-1.7453, 0.0),    // middle_1
    (-1.5708, 0.0),    // index_0
    (-1.7453, 0.0),    // index_1
];

/// Canonical sign (wire direction of closing) per IDL index on the LEFT hand; the right
/// hand is the negation (mirror).
pub const LEFT_SIGNS: [f32; 7] = [1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0];

/// Default open and closed postures (canonical rad, canonical order), overridable per profile.
pub const OPEN_POSTURE: [f32; 7] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
pub const CLOSED_POSTURE: [f32; 7] = [0.0, 0.6, 1.0, 1.2, 1.3, 1.2, 1.3];

/// Gains xr_teleoperate uses for Dex3 (docs/sources.md §2).
pub const CLOSURE_KP: f32 = 1.5;
pub const CLOSURE_KD: f32 = 0.2;

/// The Dex3-1 table for one side.
pub fn table(side: Side) -> DeviceTable {
    let joints = (0..7)
        .map(|i| {
            let sign = wire_sign(side, i);
            // Canonical limits are the same on both hands: convert the left wire range.
            let (lo, hi) = LEFT_WIRE_LIMITS[i];
            let (a, b) = (lo * LEFT_SIGNS[i], hi * LEFT_SIGNS[i]);
            let urdf = match side {
                Side::Right => URDF_RIGHT[i],
                _ => URDF_LEFT[i],
            };
            JointMap {
                name: JOINTS[i],
                wire_index: i,
                urdf: format!("{}_hand_{}_joint", side.as_str(), urdf),
                sign,
                scale: 1.0,
                offset: 0.0,
                // The manual's range, the hand's hard stops (`physical::hard_stops`, tested
                // to contain these): a target past one pushes into it.
                limits: Limits::at_stops(a.min(b), a.max(b)),
            }
        })
        .collect();
    DeviceTable {
        kind: DeviceKind::Dex3,
        side,
        joints,
        closure: ClosureMap::Postures {
            open: OPEN_POSTURE.to_vec(),
            closed: CLOSED_POSTURE.to_vec(),
            kp: CLOSURE_KP,
            kd: CLOSURE_KD,
        },
        hold_kp: 1.0,
        hold_kd: 0.1,
        max_step: None,
        max_kp: 10.0,
        max_kd: 1.0,
        max_tau: 1.5,
        urdf_frame: crate::mapping::UrdfFrame::Wire,
        motion: crate::motion::MotionThresholds::HAND,
    }
}

/// Wire limits (rad) of IDL index `i` on `side` ([`LEFT_WIRE_LIMITS`]; the right hand
/// mirrors the left).
pub fn wire_limits(side: Side, i: usize) -> (f32, f32) {
    let (lo, hi) = LEFT_WIRE_LIMITS[i];
    match side {
        Side::Right => (-hi, -lo),
        Side::Left | Side::Center => (lo, hi),
    }
}

/// Wire direction of closing for IDL index `i` on `side`.
pub fn wire_sign(side: Side, i: usize) -> f32 {
    match side {
        Side::Right => -LEFT_SIGNS[i],
        Side::Left | Side::Center => LEFT_SIGNS[i],
    }
}
