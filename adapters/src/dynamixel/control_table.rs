//! The DYNAMIXEL control table shared by the servos handgate drives: the MX(2.0) series (the
//! EZGripper's MX-64) and the X series (the LEAP Hand's XC330) lay out every item below at
//! the same address with the same size.
//!
//! Sources:
//! * **\[MX64\]** ROBOTIS e-Manual, "MX-64(2.0)" control table (Protocol 2.0 firmware).
//! * **\[XC330\]** ROBOTIS e-Manual, "XC330-M288" control table (emanual.robotis.com/docs/en/dxl/x/xc330-m288/).
//!
//! What differs between models (model number, units of current, limits) stays with the kind
//! that drives the model (`ezgripper::control_table`, `leap::control_table`).

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

pub const fn rw(addr: u16, len: u16) -> Reg {
    Reg {
        addr,
        len,
        access: Access::ReadWrite,
    }
}

pub const fn ro(addr: u16, len: u16) -> Reg {
    Reg {
        addr,
        len,
        access: Access::ReadOnly,
    }
}

/// The control table \[MX64\] \[XC330\]. EEPROM items (address < 64) can only be written with
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
/// Operating Mode (11) values \[MX64\] \[XC330\].
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

/// Hardware Error Status (70) bits \[MX64\] \[XC330\], same layout as Shutdown (63).
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
