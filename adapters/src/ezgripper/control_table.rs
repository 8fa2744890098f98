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

/// A control-table item: address and size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reg {
    pub addr: u16,
    pub len: u16,
    pub access: Access,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    ReadOnly,
    ReadWrite,
}

const fn rw(addr: u16, len: u16) -> Reg {
    Reg {
        addr,
        len,
        access: Access::ReadWrite,
    }
}

const fn ro(addr: u16, len: u16) -> Reg {
    Reg {
        addr,
        len,
        access: Access::ReadOnly,
    }
}

/// MX-64(2.0) control table \[MX64\]. EEPROM items (address < 64) can only be written with
/// torque off.
pub mod reg {
    use super::{ro, rw, Reg};
    pub const MODEL_NUMBER: Reg = ro(0, 2);
    pub const MODEL_INFORMATION: Reg = ro(2, 4);
    pub const FIRMWARE_VERSION: Reg = ro(6, 1);
    pub const ID: Reg = rw(7, 1);
    pub const BAUD_RATE: Reg = rw(8, 1);
    pub const RETURN_DELAY_TIME: Reg = rw(9, 1);
    pub const DRIVE_MODE: Reg = rw(10, 1);
    pub const OPERATING_MODE: Reg = rw(11, 1);
    pub const SECONDARY_ID: Reg = rw(12, 1);
    pub const PROTOCOL_VERSION: Reg = rw(13, 1);
    pub const HOMING_OFFSET: Reg = rw(20, 4);
    pub const MOVING_THRESHOLD: Reg = rw(24, 4);
    pub const TEMPERATURE_LIMIT: Reg = rw(31, 1);
    pub const MAX_VOLTAGE_LIMIT: Reg = rw(32, 2);
    pub const MIN_VOLTAGE_LIMIT: Reg = rw(34, 2);
    pub const PWM_LIMIT: Reg = rw(36, 2);
    pub const CURRENT_LIMIT: Reg = rw(38, 2);
    pub const ACCELERATION_LIMIT: Reg = rw(40, 4);
    pub const VELOCITY_LIMIT: Reg = rw(44, 4);
    pub const MAX_POSITION_LIMIT: Reg = rw(48, 4);
    pub const MIN_POSITION_LIMIT: Reg = rw(52, 4);
    pub const SHUTDOWN: Reg = rw(63, 1);
    /// First RAM address; everything below is EEPROM.
    pub const RAM_START: u16 = 64;
    pub const TORQUE_ENABLE: Reg = rw(64, 1);
    pub const LED: Reg = rw(65, 1);
    pub const STATUS_RETURN_LEVEL: Reg = rw(68, 1);
    pub const REGISTERED_INSTRUCTION: Reg = ro(69, 1);
    pub const HARDWARE_ERROR_STATUS: Reg = ro(70, 1);
    pub const VELOCITY_I_GAIN: Reg = rw(76, 2);
    pub const VELOCITY_P_GAIN: Reg = rw(78, 2);
    pub const POSITION_D_GAIN: Reg = rw(80, 2);
    pub const POSITION_I_GAIN: Reg = rw(82, 2);
    pub const POSITION_P_GAIN: Reg = rw(84, 2);
    pub const BUS_WATCHDOG: Reg = rw(98, 1);
    pub const GOAL_PWM: Reg = rw(100, 2);
    pub const GOAL_CURRENT: Reg = rw(102, 2);
    pub const GOAL_VELOCITY: Reg = rw(104, 4);
    pub const PROFILE_ACCELERATION: Reg = rw(108, 4);
    pub const PROFILE_VELOCITY: Reg = rw(112, 4);
    pub const GOAL_POSITION: Reg = rw(116, 4);
    pub const REALTIME_TICK: Reg = ro(120, 2);
    pub const MOVING: Reg = ro(122, 1);
    pub const MOVING_STATUS: Reg = ro(123, 1);
    pub const PRESENT_PWM: Reg = ro(124, 2);
    pub const PRESENT_CURRENT: Reg = ro(126, 2);
    pub const PRESENT_VELOCITY: Reg = ro(128, 4);
    pub const PRESENT_POSITION: Reg = ro(132, 4);
    pub const VELOCITY_TRAJECTORY: Reg = ro(136, 4);
    pub const POSITION_TRAJECTORY: Reg = ro(140, 4);
    pub const PRESENT_INPUT_VOLTAGE: Reg = ro(144, 2);
    pub const PRESENT_TEMPERATURE: Reg = ro(146, 1);
    /// One past the last byte of the table the emulator models (indirect data 56 is 661).
    pub const TABLE_END: u16 = 662;

    /// Every named item, for access checks in the emulator.
    pub const ALL: &[Reg] = &[
        MODEL_NUMBER,
        MODEL_INFORMATION,
        FIRMWARE_VERSION,
        ID,
        BAUD_RATE,
        RETURN_DELAY_TIME,
        DRIVE_MODE,
        OPERATING_MODE,
        SECONDARY_ID,
        PROTOCOL_VERSION,
        HOMING_OFFSET,
        MOVING_THRESHOLD,
        TEMPERATURE_LIMIT,
        MAX_VOLTAGE_LIMIT,
        MIN_VOLTAGE_LIMIT,
        PWM_LIMIT,
        CURRENT_LIMIT,
        ACCELERATION_LIMIT,
        VELOCITY_LIMIT,
        MAX_POSITION_LIMIT,
        MIN_POSITION_LIMIT,
        SHUTDOWN,
        TORQUE_ENABLE,
        LED,
        STATUS_RETURN_LEVEL,
        REGISTERED_INSTRUCTION,
        HARDWARE_ERROR_STATUS,
        VELOCITY_I_GAIN,
        VELOCITY_P_GAIN,
        POSITION_D_GAIN,
        POSITION_I_GAIN,
        POSITION_P_GAIN,
        BUS_WATCHDOG,
        GOAL_PWM,
        GOAL_CURRENT,
        GOAL_VELOCITY,
        PROFILE_ACCELERATION,
        PROFILE_VELOCITY,
        GOAL_POSITION,
        REALTIME_TICK,
        MOVING,
        MOVING_STATUS,
        PRESENT_PWM,
        PRESENT_CURRENT,
        PRESENT_VELOCITY,
        PRESENT_POSITION,
        VELOCITY_TRAJECTORY,
        POSITION_TRAJECTORY,
        PRESENT_INPUT_VOLTAGE,
        PRESENT_TEMPERATURE,
    ];
}

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

/// Operating Mode (11) values \[MX64\].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum OperatingMode {
    Current = 0,
    Velocity = 1,
    Position = 3,
    ExtendedPosition = 4,
    /// Current-based position control: position PID whose output current is limited by Goal
    /// Current. What the SAKE driver uses [SAKE `dynamixel_settings.operating_mode` = 5].
    CurrentBasedPosition = 5,
    Pwm = 16,
}

/// Hardware Error Status (70) bits \[MX64\], same layout as Shutdown (63).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
pub struct HardwareError(pub u8);

impl HardwareError {
    pub const NONE: HardwareError = HardwareError(0);
    pub const INPUT_VOLTAGE: u8 = 0x01;
    pub const OVERHEATING: u8 = 0x04;
    pub const MOTOR_ENCODER: u8 = 0x08;
    pub const ELECTRICAL_SHOCK: u8 = 0x10;
    pub const OVERLOAD: u8 = 0x20;

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
    pub fn contains(self, bit: u8) -> bool {
        self.0 & bit != 0
    }
    /// Names of the bits set, for logs and reports.
    pub fn names(self) -> Vec<&'static str> {
        [
            (Self::INPUT_VOLTAGE, "input voltage"),
            (Self::OVERHEATING, "overheating"),
            (Self::MOTOR_ENCODER, "motor encoder"),
            (Self::ELECTRICAL_SHOCK, "electrical shock"),
            (Self::OVERLOAD, "overload"),
        ]
        .iter()
        .filter(|(b, _)| self.0 & b != 0)
        .map(|(_, n)| *n)
        .collect()
    }
}

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
