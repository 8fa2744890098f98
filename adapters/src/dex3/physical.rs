//! The Dex3-1 as built, for the emulators: the hardware's joint range (its hard stops), the
//! posture a relaxed hand rests in, and the measurement noise of its motors. Deliberately
//! separate from [`super::table`], the soft limits handgate clamps commands to: an emulator
//! that took its stops from the clamp table could never show a command the table let through
//! by mistake. docs/adapters.md lists these figures and what each rests on.

use super::table::LEFT_SIGNS;
use super::usb::scaling::table::{HG_FB_SPEED_PER_RAD_S, HG_TORQUE_PER_NM, POSITION_PER_RAD};
use crate::model::Side;
use crate::sim::Noise;

/// Joint ranges from the Dex3-1 user manual ("Angle of Joint"), degrees, IDL order (thumb_0,
/// thumb_1, thumb_2, middle_0, middle_1, index_0, index_1), in the LEFT hand's wire
/// direction. The manual gives unsigned finger ranges (0..90°, 0..100°) and thumb_1 as
/// −35°..60°; the signs are the URDF's (left fingers close negative; the larger thumb_1
/// excursion is positive on the left, as in the URDF and the SDK example). That mapping is
/// the one assumption here.
pub const MANUAL_LEFT_RANGE_DEG: [(f32, f32); 7] = [
    (-60.0, 60.0), // thumb_0
    (-35.0, 60.0), // thumb_1
    (0.0, 100.0),  // thumb_2
    (-90.0, 0.0),  // middle_0
    (-100.0, 0.0), // middle_1
    (-90.0, 0.0),  // index_0
    (-100.0, 0.0), // index_1
];

/// The manual's range of IDL joint `i` on `side`, rad (the right hand mirrors the left).
pub fn hard_stops(side: Side, i: usize) -> (f32, f32) {
    let (lo, hi) = MANUAL_LEFT_RANGE_DEG[i];
    let (lo, hi) = (lo.to_radians(), hi.to_radians());
    match side {
        Side::Right => (-hi, -lo),
        Side::Left | Side::Center => (lo, hi),
    }
}

/// Where a relaxed, unpowered hand rests, canonical rad (positive = closing), canonical order.
/// Assumption (no hardware here): fingers and thumb slightly flexed (about 6° to 14°), as a
/// backdrivable hand settles, and the thumb rotation centred. Not all zero: a real hand
/// never reports 0.0 on every joint, and clients such as xr_teleoperate wait for a non-zero
/// state before they start.
pub const REST_POSTURE: [f32; 7] = [0.0, 0.1, 0.15, 0.2, 0.25, 0.2, 0.25];

/// The rest posture of IDL joint `i` on `side`, wire rad.
pub fn rest_wire(side: Side, i: usize) -> f32 {
    let sign = match side {
        Side::Right => -LEFT_SIGNS[i],
        Side::Left | Side::Center => LEFT_SIGNS[i],
    };
    REST_POSTURE[i] * sign
}

/// Measurement noise of a Unitree "HG" motor (the Dex3-1's joints; dex1_1_service drives the
/// same motor frame): one standard deviation = one least significant bit of the motor's
/// feedback frame: position 2π/32768 rad (1.9e-4 rad: the output-side resolution of the rotor
/// encoder through the gear is finer, so the frame's quantisation dominates), velocity
/// 2π/256 rad/s (0.025 rad/s, a speed estimated by differentiating the encoder flickers by a
/// count at rest) and torque 1/256 N·m (0.004 N·m, current-sensor noise). Assumed orders of
/// magnitude, not measured.
pub const HG_MOTOR_NOISE: Noise = Noise {
    q: 1.0 / POSITION_PER_RAD,
    dq: 1.0 / HG_FB_SPEED_PER_RAD_S,
    tau: 1.0 / HG_TORQUE_PER_NM,
    seed: Noise::DEFAULT_SEED,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hard_stops_contain_the_soft_limits_and_the_rest_posture() {
        for side in [Side::Left, Side::Right] {
            for i in 0..7 {
                let (lo, hi) = hard_stops(side, i);
                let (slo, shi) = super::super::table::wire_limits(side, i);
                // 1e-5: the table's 1.0472 is the URDF's 4-decimal rounding of 60° (1.047198).
                assert!(
                    lo <= slo + 1e-5 && shi <= hi + 1e-5,
                    "{side:?} {i}: soft {slo}..{shi} hard {lo}..{hi}"
                );
                let r = rest_wire(side, i);
                assert!(lo <= r && r <= hi, "{side:?} {i}: rest {r}");
            }
        }
        assert!(REST_POSTURE.iter().any(|q| *q != 0.0));
    }

    #[test]
    fn hg_noise_is_valid() {
        assert!(HG_MOTOR_NOISE.validate().is_ok());
        assert!((HG_MOTOR_NOISE.q - 1.917e-4).abs() < 1e-6);
    }

    /// The unitree_sdk2 example `g1_dex3_example.cpp` sweeps each joint between these bounds
    /// (test data, docs/model.md): every pose it asks for is reachable under the default soft
    /// limits wherever the manual's range allows it.
    #[test]
    fn sdk_example_poses_are_reachable_within_the_hardware_range() {
        let sdk_left_max = [1.05, 1.05, 1.75, 0.0, 0.0, 0.0, 0.0];
        let sdk_left_min = [-1.05, -0.724, 0.0, -1.57, -1.75, -1.57, -1.75];
        let sdk_right_max = [1.05, 0.742, 0.0, 1.57, 1.75, 1.57, 1.75];
        let sdk_right_min = [-1.05, -1.05, -1.75, 0.0, 0.0, 0.0, 0.0];
        for (side, lo, hi) in [
            (Side::Left, sdk_left_min, sdk_left_max),
            (Side::Right, sdk_right_min, sdk_right_max),
        ] {
            for i in 0..7 {
                let (hlo, hhi) = hard_stops(side, i);
                let (slo, shi) = super::super::table::wire_limits(side, i);
                // What the example asks, where the hardware allows it.
                let (want_lo, want_hi) = (f32::max(lo[i], hlo), f32::min(hi[i], hhi));
                assert!(
                    slo <= want_lo + 1e-4 && want_hi <= shi + 1e-4,
                    "{side:?} {i}: soft {slo}..{shi}, example within the hardware {want_lo}..{want_hi}"
                );
            }
        }
    }
}
