//! Joint names and hardware ranges per device kind: the one table validation checks limits,
//! postures and emulator positions against. Sources are named per row; rows marked
//! ASSUMPTION have no public source.

use std::f64::consts::{PI, TAU};

use super::schema::{DeviceKind, Side};

/// Dex3-1 joint names, in handgate's naming (the DDS message order differs: FACTS §2).
pub const DEX3_JOINTS: &[&str] = &[
    "thumb_0", "thumb_1", "thumb_2", "index_0", "index_1", "middle_0", "middle_1",
];
/// Gripper kinds (Dex1, EZGripper) have one joint.
pub const GRIPPER_JOINTS: &[&str] = &["jaw"];
/// The 4 motors behind `rt/hand_sdk` (which motor is which finger is not public: FACTS §6).
pub const HAND_SDK_JOINTS: &[&str] = &["motor_0", "motor_1", "motor_2", "motor_3"];

/// The joint names a device kind has.
pub fn joint_names(kind: DeviceKind) -> &'static [&'static str] {
    match kind {
        DeviceKind::Dex3 => DEX3_JOINTS,
        DeviceKind::Dex1 | DeviceKind::Ezgripper => GRIPPER_JOINTS,
        DeviceKind::HandSdk => HAND_SDK_JOINTS,
    }
}

/// The hardware range `(min, max)` of a joint in rad, or `None` for an unknown joint (or a
/// Dex3 with side `center`, which does not exist).
///
/// - Dex3-1: xr_teleoperate's URDF limits (FACTS §2); the hands are mirror images.
/// - Dex1-1: 0 (closed) ..= 2pi, the widest range in the field (seed spec 0..2pi;
///   dex1_1_service calibrates 5.62 rad; open is 5.4 by default).
/// - EZGripper: 0 ..= 5.4, the SAKE driver's Dex1-equivalent clamp (FACTS §5).
/// - hand_sdk: ASSUMPTION -pi ..= pi; the motors' ranges are not public.
// The Dex3 values are the URDF's 4-decimal literals, kept exactly as published.
#[allow(clippy::approx_constant)]
pub fn joint_range(kind: DeviceKind, side: Side, joint: &str) -> Option<(f64, f64)> {
    match kind {
        DeviceKind::Dex3 => {
            let left = match joint {
                "thumb_0" => (-1.0472, 1.0472),
                "thumb_1" => (-0.7243, 0.920),
                "thumb_2" => (0.0, 1.7453),
                "middle_0" | "index_0" => (-1.5708, 0.0),
                "middle_1" | "index_1" => (-1.7453, 0.0),
                _ => return None,
            };
            match side {
                Side::Left => Some(left),
                // The right hand mirrors the left: [a, b] becomes [-b, -a].
                Side::Right => Some((-left.1, -left.0)),
                Side::Center => None,
            }
        }
        DeviceKind::Dex1 => (joint == "jaw").then_some((0.0, TAU)),
        DeviceKind::Ezgripper => (joint == "jaw").then_some((0.0, 5.4)),
        DeviceKind::HandSdk => HAND_SDK_JOINTS.contains(&joint).then_some((-PI, PI)),
    }
}

/// Where a Dex3 joint is when the hand is closed, when the profile's `closure.closed` does
/// not say: 90 % of the way to the closing end of its range (thumb_0 stays at 0).
/// ASSUMPTION: no public "closed" posture exists; tune it per profile.
pub fn dex3_closed_default(side: Side, joint: &str) -> Option<f64> {
    let (lo, hi) = joint_range(DeviceKind::Dex3, side, joint)?;
    if joint == "thumb_0" {
        return Some(0.0);
    }
    // Closing is the end of the range away from 0 (fingers), thumb_1/2 likewise.
    let end = if hi.abs() > lo.abs() { hi } else { lo };
    Some(0.9 * end)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dex3_right_mirrors_left() {
        for j in DEX3_JOINTS {
            let (l0, l1) = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
            let (r0, r1) = joint_range(DeviceKind::Dex3, Side::Right, j).unwrap();
            assert_eq!((r0, r1), (-l1, -l0), "{j}");
            assert!(l0 < l1 && r0 < r1, "{j}");
        }
        assert_eq!(
            joint_range(DeviceKind::Dex3, Side::Right, "index_1"),
            Some((0.0, 1.7453))
        );
        assert_eq!(joint_range(DeviceKind::Dex3, Side::Center, "index_1"), None);
        assert_eq!(joint_range(DeviceKind::Dex3, Side::Left, "jaw"), None);
    }

    #[test]
    fn closed_default_is_inside_the_range_and_mirrored() {
        for j in DEX3_JOINTS {
            let l = dex3_closed_default(Side::Left, j).unwrap();
            let r = dex3_closed_default(Side::Right, j).unwrap();
            let (lo, hi) = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
            assert!(lo <= l && l <= hi, "{j}");
            assert_eq!(l, -r, "{j}");
        }
        // Fingers close negative on the left (FACTS §2).
        assert!(dex3_closed_default(Side::Left, "index_0").unwrap() < 0.0);
    }
}
