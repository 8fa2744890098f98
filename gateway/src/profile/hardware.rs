//! Joint names and hardware ranges per device kind, as validation sees them. Everything comes
//! from the adapters' device tables (`handgate_adapters::<kind>::table`), so there is one
//! source: profile limits and postures are in the **canonical frame** (rad, positive =
//! closing, the same on both hands; docs/model.md).

use handgate_adapters::model::{DeviceKind, Side};
use handgate_adapters::tables::{table_for, TableParams};

/// The joint names a device kind has.
pub fn joint_names(kind: DeviceKind) -> &'static [&'static str] {
    kind.joint_names()
}

/// Widest jaw range (rad) a Dex1 profile may configure: the seed spec's 2π (real systems use
/// 5.4; dex1_1_service calibrates 5.62).
pub const DEX1_MAX_RANGE_RAD: f64 = std::f64::consts::TAU;

/// The hardware range `(min, max)` of a joint in canonical rad, or `None` for an unknown
/// joint (or a Dex3 with side `center`, which does not exist).
///
/// - Dex3-1: the device table's limits (xr_teleoperate's URDF, docs/sources.md §2, in canonical sign).
/// - Dex1-1: 0 (open) ..= 2π, the widest range in the field.
/// - EZGripper: 0 ..= 5.4, the SAKE driver's Dex1-equivalent range (docs/sources.md §5).
/// - hand_sdk: the table's placeholder ±π (ASSUMPTION: the motors' ranges are not public).
pub fn joint_range(kind: DeviceKind, side: Side, joint: &str) -> Option<(f64, f64)> {
    if kind == DeviceKind::Dex3 && side == Side::Center {
        return None;
    }
    let id = kind.joint(joint)?;
    if kind == DeviceKind::Dex1 {
        return Some((0.0, DEX1_MAX_RANGE_RAD));
    }
    let t = table_for(kind, side, &TableParams::default()).ok()?;
    let l = t.joints.get(id.index())?.limits;
    Some((l.min as f64, l.max as f64))
}

/// Where a Dex3 joint is at closure 1 when the profile's `closure.closed` does not say: the
/// Dex3 table's default closed posture (canonical).
pub fn dex3_closed_default(joint: &str) -> Option<f64> {
    let id = DeviceKind::Dex3.joint(joint)?;
    Some(handgate_adapters::dex3::table::CLOSED_POSTURE[id.index()] as f64)
}

/// Where a Dex3 joint is at closure 0 when the profile's `closure.open` does not say.
pub fn dex3_open_default(joint: &str) -> Option<f64> {
    let id = DeviceKind::Dex3.joint(joint)?;
    Some(handgate_adapters::dex3::table::OPEN_POSTURE[id.index()] as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dex3_ranges_are_canonical_and_equal_on_both_hands() {
        for j in DeviceKind::Dex3.joint_names() {
            let l = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
            let r = joint_range(DeviceKind::Dex3, Side::Right, j).unwrap();
            assert_eq!(l, r, "{j}");
            assert!(l.0 < l.1, "{j}");
        }
        // Fingers close positive in the canonical frame.
        let (lo, hi) = joint_range(DeviceKind::Dex3, Side::Right, "index_1").unwrap();
        assert!(lo.abs() < 1e-9 && (hi - 1.7453).abs() < 1e-6);
        assert_eq!(joint_range(DeviceKind::Dex3, Side::Center, "index_1"), None);
        assert_eq!(joint_range(DeviceKind::Dex3, Side::Left, "jaw"), None);
    }

    #[test]
    fn closed_default_is_inside_the_range() {
        for j in DeviceKind::Dex3.joint_names() {
            let c = dex3_closed_default(j).unwrap();
            let (lo, hi) = joint_range(DeviceKind::Dex3, Side::Left, j).unwrap();
            assert!(lo <= c && c <= hi, "{j}");
        }
        assert!(dex3_closed_default("index_0").unwrap() > 0.0);
    }
}
