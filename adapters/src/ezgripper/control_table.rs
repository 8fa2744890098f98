//! Every number the EZGripper adapter relies on, in one place, with its source.
//!
//! Sources:
//! * **\[MX64\]** ROBOTIS e-Manual, "MX-64(2.0)" control table (Protocol 2.0 firmware,
//!   model number 311): addresses, sizes, access, initial values and units.
//! * **\[P2\]** ROBOTIS e-Manual, "Protocol 2.0" (packet layout, status error field).
//! * **\[SAKE\]** SAKErobotics/unitree-dex1-ezgripper-driver: `config_default.json`
//!   (`gripper.grip_max`, `servo.dynamixel_settings.*`, `servo.force_management.*`,
//!   `servo.collision_detection.*`) and `libezgripper/ezgripper_base_clean.py` (position and
//!   current scaling, calibration procedure).
//!
//! The device constants are fixed by the servo. Everything that is a choice (SAKE's tuning,
//! handgate's thresholds) lives in [`EzGripperParams`], which deserialises from a profile and
//! defaults to the values below.

use serde::{Deserialize, Serialize};

pub use crate::dynamixel::control_table::{reg, ro, rw, Access, HardwareError, OperatingMode, Reg};

/// Model number of the MX-64(2.0) \[MX64\].
pub const MX64_2_MODEL_NUMBER: u16 = 311;
/// Initial Current Limit (38) of the MX-64(2.0) \[MX64\]; also its maximum.
pub const MX64_CURRENT_LIMIT_MAX: u16 = 1941;
/// Current unit of Goal/Present Current and Current Limit, mA \[MX64\] ("about 3.36 mA").
pub const CURRENT_MA_PER_UNIT: f32 = 3.36;
/// Velocity unit of Present Velocity, rev/min \[MX64\] (0.229 rpm).
pub const VELOCITY_RPM_PER_UNIT: f32 = 0.229;
/// Encoder ticks per output revolution \[MX64\] (12-bit absolute encoder, 0.088 deg).
pub const TICKS_PER_REV: f32 = 4096.0;
/// Return Delay Time unit, microseconds \[MX64\] (initial value 250 = 500 us).
pub const RETURN_DELAY_US_PER_UNIT: u32 = 2;
/// Present Input Voltage unit, volts \[MX64\] (0.1 V).
pub const VOLTAGE_V_PER_UNIT: f32 = 0.1;
/// Baud Rate (8) register value for 1 Mbps \[MX64\].
pub const BAUD_RATE_1M: u8 = 3;

/// The block the driver sync-reads every round: Moving (122) through Present Temperature
/// (146), 25 bytes, one contiguous read.
pub const PRESENT_BLOCK: Reg = ro(122, 25);
/// The block the driver sync-writes every round: Goal Current (102) through Goal Position
/// (116..119), 18 bytes (goal current, goal velocity, profile acceleration, profile
/// velocity, goal position) in one contiguous write.
pub const GOAL_BLOCK: Reg = rw(102, 18);

/// Tunable EZGripper parameters. Defaults are the SAKE driver's values where it has one
/// (source named per field), handgate's choice otherwise. Deserialises from a profile
/// (`devices[].ezgripper.*`); missing keys keep their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EzGripperParams {
    /// Servo ticks from closed (0 %) to fully open (100 %). [SAKE `gripper.grip_max` = 2500]
    pub grip_max_ticks: i32,
    /// Ticks increase when the gripper opens. [SAKE: raw = zero + pct * grip_max / 100]
    /// Set false for a servo mounted the other way.
    pub open_is_positive: bool,
    /// Largest opening a command may ask for, % of the range.
    /// [SAKE `gripper.position_scaling.max_open_percent` = 100]
    pub max_open_pct: f32,
    /// Current Limit (38) written at init; 100 % force = this many current units.
    /// [SAKE `servo.dynamixel_settings.current_limit` = 1600; the MX-64 allows 1941]
    pub current_limit_units: u16,
    /// Return Delay Time (9) written at init, in 2 us units.
    /// [SAKE `servo.dynamixel_settings.return_delay_time` = 2; the factory value is 250]
    pub return_delay_units: u8,
    /// Profile Velocity (112) sent with every goal. [SAKE `profile_velocity` = 500]
    pub profile_velocity: u32,
    /// Profile Acceleration (108) sent with every goal. [SAKE `profile_acceleration` = 800]
    pub profile_acceleration: u32,
    /// Force used while calibrating, % of `current_limit_units`.
    /// [SAKE `ezgripper_base_clean.calibrate`: 30 % of the current limit]
    pub calibration_force_pct: f32,
    /// How far past the present position the calibration goal is set, in ticks, in the
    /// closing direction. [SAKE `calibrate`: present - 15000]
    pub calibration_overtravel_ticks: i32,
    /// Calibration ends when the position stays within this many ticks...
    /// [SAKE `calibrate`: position_threshold = 2]
    pub calibration_still_ticks: i32,
    /// ...for this long... [SAKE: 5 consecutive readings 33 ms apart = 165 ms]
    pub calibration_still_ms: u64,
    /// ...and for at least this many consecutive readings. [SAKE `stable_required` = 5]
    pub calibration_still_samples: u32,
    /// Calibration fails after this long. [SAKE: 200 cycles x 33 ms = 6.6 s]
    pub calibration_timeout_ms: u64,
    /// Position commanded after calibration, %. [SAKE `calibrate`: 50 % of grip_max]
    pub calibration_settle_pct: f32,
    /// Force used to go to the settle position, %. [SAKE `calibrate`: 40 % current]
    pub calibration_settle_force_pct: f32,
    /// Force applied before the first command, % (holds the present position).
    /// [SAKE `force_management.idle_force_pct` = 10]
    pub idle_force_pct: f32,
    /// Grasp state: moving when |velocity| exceeds this, %/s. handgate's choice.
    pub moving_velocity_pct_s: f32,
    /// Grasp state: at target when within this, %. [SAKE `stall_tolerance_pct` = 2.0]
    pub position_tolerance_pct: f32,
    /// Grasp state: contact when stopped short of the target with |current| at or above this
    /// fraction of the goal current, %. handgate's choice.
    pub contact_current_pct: f32,
    /// Grasp state: contact becomes grasping after this many consecutive rounds.
    /// [SAKE `collision_detection.consecutive_samples_required` = 3]
    pub grasp_confirm_rounds: u32,
    /// While grasping, cap the goal current at this force %, to keep a held object from
    /// overheating the servo. `None` applies the commanded force unchanged.
    /// [SAKE `force_management.grasping_force_pct` = 15; off by default here]
    pub grasp_hold_force_pct: Option<f32>,
}

impl Default for EzGripperParams {
    fn default() -> Self {
        Self {
            grip_max_ticks: 2500,
            open_is_positive: true,
            max_open_pct: 100.0,
            current_limit_units: 1600,
            return_delay_units: 2,
            profile_velocity: 500,
            profile_acceleration: 800,
            calibration_force_pct: 30.0,
            calibration_overtravel_ticks: 15000,
            calibration_still_ticks: 2,
            calibration_still_ms: 165,
            calibration_still_samples: 5,
            calibration_timeout_ms: 6600,
            calibration_settle_pct: 50.0,
            calibration_settle_force_pct: 40.0,
            idle_force_pct: 10.0,
            moving_velocity_pct_s: 5.0,
            position_tolerance_pct: 2.0,
            contact_current_pct: 60.0,
            grasp_confirm_rounds: 3,
            grasp_hold_force_pct: None,
        }
    }
}

impl EzGripperParams {
    fn dir(&self) -> i32 {
        if self.open_is_positive {
            1
        } else {
            -1
        }
    }

    /// Position % (0 closed .. 100 open) of a raw position, relative to the calibrated zero.
    /// Not clamped.
    pub fn ticks_to_pct(&self, raw: i32, zero: i32) -> f32 {
        let span = self.grip_max_ticks.max(1) as f32;
        (raw.wrapping_sub(zero) * self.dir()) as f32 / span * 100.0
    }

    /// Goal position for a position %, clamped to 0..=`max_open_pct`.
    pub fn pct_to_ticks(&self, pct: f32, zero: i32) -> i32 {
        let pct = if pct.is_finite() { pct } else { 0.0 };
        let pct = pct.clamp(0.0, self.max_open_pct.clamp(0.0, 100.0));
        zero + self.dir() * (pct / 100.0 * self.grip_max_ticks as f32).round() as i32
    }

    /// Goal current units for a force %, clamped to 0..=100 %.
    pub fn force_to_current(&self, force_pct: f32) -> u16 {
        let f = if force_pct.is_finite() { force_pct } else { 0.0 };
        (f.clamp(0.0, 100.0) / 100.0 * self.current_limit_units as f32).round() as u16
    }

    /// Present current units as % of the configured current limit, signed so that a
    /// closing (squeezing) current is positive.
    pub fn current_to_effort_pct(&self, units: i16) -> f32 {
        -(self.dir() as f32) * units as f32 / self.current_limit_units.max(1) as f32 * 100.0
    }

    /// Present Velocity units as position %/s (positive = opening).
    pub fn velocity_to_pct_s(&self, units: i32) -> f32 {
        let ticks_per_s = units as f32 * VELOCITY_RPM_PER_UNIT / 60.0 * TICKS_PER_REV;
        ticks_per_s * self.dir() as f32 / self.grip_max_ticks.max(1) as f32 * 100.0
    }

    /// Goal position far past the closed stop, used while calibrating.
    pub fn calibration_goal(&self, present: i32) -> i32 {
        present - self.dir() * self.calibration_overtravel_ticks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_are_contiguous_in_the_table() {
        assert_eq!(PRESENT_BLOCK.addr, reg::MOVING.addr);
        assert_eq!(
            PRESENT_BLOCK.addr + PRESENT_BLOCK.len,
            reg::PRESENT_TEMPERATURE.addr + reg::PRESENT_TEMPERATURE.len
        );
        assert_eq!(GOAL_BLOCK.addr, reg::GOAL_CURRENT.addr);
        assert_eq!(
            GOAL_BLOCK.addr + GOAL_BLOCK.len,
            reg::GOAL_POSITION.addr + reg::GOAL_POSITION.len
        );
    }

    #[test]
    fn scaling_round_trips_and_clamps() {
        let p = EzGripperParams::default();
        assert_eq!(p.pct_to_ticks(0.0, 1000), 1000);
        assert_eq!(p.pct_to_ticks(100.0, 1000), 3500);
        assert_eq!(p.pct_to_ticks(150.0, 1000), 3500);
        assert_eq!(p.pct_to_ticks(f32::NAN, 1000), 1000);
        assert!((p.ticks_to_pct(2250, 1000) - 50.0).abs() < 1e-4);
        assert_eq!(p.force_to_current(100.0), 1600);
        assert_eq!(p.force_to_current(30.0), 480);
        assert_eq!(p.force_to_current(-5.0), 0);
        let inv = EzGripperParams {
            open_is_positive: false,
            ..Default::default()
        };
        assert_eq!(inv.pct_to_ticks(100.0, 0), -2500);
        assert!((inv.ticks_to_pct(-1250, 0) - 50.0).abs() < 1e-4);
    }

    #[test]
    fn params_deserialise_partially() {
        let p: EzGripperParams =
            serde_json::from_str(r#"{"grip_max_ticks": 2000, "grasp_hold_force_pct": 15}"#).unwrap();
        assert_eq!(p.grip_max_ticks, 2000);
        assert_eq!(p.grasp_hold_force_pct, Some(15.0));
        assert_eq!(p.current_limit_units, 1600);
        assert!(serde_json::from_str::<EzGripperParams>(r#"{"nope": 1}"#).is_err());
    }
}
