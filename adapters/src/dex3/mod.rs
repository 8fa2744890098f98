//! Unitree Dex3-1 three-finger hand: constants and the command/measurement types shared by the
//! USB adapter ([`usb`]) and the DDS adapter.
//!
//! All values are in the hand's own sign convention and SI units (rad, rad/s, N·m, N·m/rad,
//! N·m·s/rad). Joint order is the IDL order of `HandCmd_`/`HandState_` (shared FACTS §2).

pub mod usb;

use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Number of motors (joints) of one hand.
pub const MOTOR_COUNT: usize = 7;
/// Number of pressure pads of one hand (FACTS §2: the SDK example sizes press_sensor_state to 9).
pub const PAD_COUNT: usize = 9;
/// Taxels per pressure pad (`PressSensorState_.pressure[12]`, `SensorState_t.pressure[12]`).
pub const TAXELS_PER_PAD: usize = 12;

/// Which hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Left,
    Right,
}

impl Side {
    pub fn as_str(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
        }
    }
}

impl std::str::FromStr for Side {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "left" | "l" => Ok(Side::Left),
            "right" | "r" => Ok(Side::Right),
            other => Err(format!("unknown side {other:?} (expected left or right)")),
        }
    }
}

/// A joint, by its index in the IDL messages (0 thumb_0 .. 6 index_1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Joint {
    Thumb0 = 0,
    Thumb1 = 1,
    Thumb2 = 2,
    Middle0 = 3,
    Middle1 = 4,
    Index0 = 5,
    Index1 = 6,
}

impl Joint {
    pub const ALL: [Joint; MOTOR_COUNT] = [
        Joint::Thumb0,
        Joint::Thumb1,
        Joint::Thumb2,
        Joint::Middle0,
        Joint::Middle1,
        Joint::Index0,
        Joint::Index1,
    ];

    /// IDL index.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn from_index(i: usize) -> Option<Joint> {
        Self::ALL.get(i).copied()
    }

    pub fn name(self) -> &'static str {
        match self {
            Joint::Thumb0 => "thumb_0",
            Joint::Thumb1 => "thumb_1",
            Joint::Thumb2 => "thumb_2",
            Joint::Middle0 => "middle_0",
            Joint::Middle1 => "middle_1",
            Joint::Index0 => "index_0",
            Joint::Index1 => "index_1",
        }
    }

    /// Joint limits (rad) from the URDFs xr_teleoperate uses (FACTS §2). The hands are
    /// mirror images: closing is negative on the left, positive on the right. The URDF's
    /// decimal figures are kept as written (not replaced by π fractions).
    #[allow(clippy::approx_constant)]
    pub fn limits(self, side: Side) -> (f32, f32) {
        match (side, self) {
            (Side::Left, Joint::Thumb0) => (-1.0472, 1.0472),
            (Side::Left, Joint::Thumb1) => (-0.7243, 0.920),
            (Side::Left, Joint::Thumb2) => (0.0, 1.7453),
            (Side::Left, Joint::Middle0) => (-1.5708, 0.0),
            (Side::Left, Joint::Middle1) => (-1.7453, 0.0),
            (Side::Left, Joint::Index0) => (-1.5708, 0.0),
            (Side::Left, Joint::Index1) => (-1.7453, 0.0),
            (Side::Right, Joint::Thumb0) => (-1.0472, 1.0472),
            (Side::Right, Joint::Thumb1) => (-0.920, 0.7243),
            (Side::Right, Joint::Thumb2) => (-1.7453, 0.0),
            (Side::Right, Joint::Middle0) => (0.0, 1.5708),
            (Side::Right, Joint::Middle1) => (0.0, 1.7453),
            (Side::Right, Joint::Index0) => (0.0, 1.5708),
            (Side::Right, Joint::Index1) => (0.0, 1.7453),
        }
    }
}

/// Motor working mode (RIS mode `status`, 3 bits). Only 0 and 1 are documented.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotorStatus {
    /// 0: "Lock" in the manual, "stop (power-on default)" in motor_msg_HG.h.
    Lock,
    /// 1: field-oriented control, the motor runs `kp*(q-q_des) + kd*(dq-dq_des) + tau`.
    #[default]
    Foc,
}

impl MotorStatus {
    pub fn raw(self) -> u8 {
        match self {
            MotorStatus::Lock => 0,
            MotorStatus::Foc => 1,
        }
    }
}

/// One motor's setpoint.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorCommand {
    /// Position, rad.
    pub q: f32,
    /// Velocity, rad/s.
    pub dq: f32,
    /// Feed-forward torque, N·m.
    pub tau: f32,
    /// Stiffness, N·m/rad.
    pub kp: f32,
    /// Damping, N·m·s/rad.
    pub kd: f32,
    pub status: MotorStatus,
}

/// A command for the whole hand, motors in IDL order.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Dex3Command {
    pub motors: [MotorCommand; MOTOR_COUNT],
}

impl Dex3Command {
    /// Hold `q` (IDL order) with the given gains.
    pub fn hold(q: [f32; MOTOR_COUNT], kp: f32, kd: f32) -> Self {
        let mut c = Self::default();
        for (m, q) in c.motors.iter_mut().zip(q) {
            *m = MotorCommand {
                q,
                kp,
                kd,
                ..Default::default()
            };
        }
        c
    }

    /// Pure damping: no stiffness, no torque.
    pub fn damping(kd: f32) -> Self {
        Self::hold([0.0; MOTOR_COUNT], 0.0, kd)
    }

    pub fn motor(&self, j: Joint) -> &MotorCommand {
        &self.motors[j.index()]
    }

    pub fn motor_mut(&mut self, j: Joint) -> &mut MotorCommand {
        &mut self.motors[j.index()]
    }
}

/// One motor's measured state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct MotorMeasurement {
    /// True once this motor has answered since the transport (re)connected.
    pub present: bool,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    /// Case temperature, °C.
    pub temperature_case: f32,
    /// Winding temperature, °C.
    pub temperature_winding: f32,
    /// Motor terminal voltage, V.
    pub voltage: f32,
    /// `MError` bits (0 = normal).
    pub error: u32,
    /// The RIS mode status the motor reports (3 bits).
    pub status: u8,
    /// Timeout protection has tripped (latched until a command with the timeout bit at 0).
    pub timeout: bool,
}

/// One pressure pad.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct PadMeasurement {
    /// True once this pad has answered since the transport (re)connected.
    pub present: bool,
    /// Pressure per taxel, Pa (USB). The DDS adapter fills the service's raw values.
    pub pressure: [f32; TAXELS_PER_PAD],
    /// Temperature per taxel, °C.
    pub temperature: [f32; TAXELS_PER_PAD],
}

/// IMU of the hand (manual: ax ay az gx gy gz, raw / 100; units not stated).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Imu {
    pub accel: [f32; 3],
    pub gyro: [f32; 3],
}

/// Supply figures.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Power {
    /// Total supply voltage, V (`pin_v`; DDS `power_v`).
    pub power_v: f32,
    /// Total supply current, A (`pin_a`; DDS `power_a`).
    pub power_a: f32,
    /// Internal supply (`vin_v`; DDS `system_v`).
    pub system_v: f32,
    /// Buck output voltage (`vm_v`; DDS `device_v`).
    pub device_v: f32,
}

/// The latest measured state of a hand.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Dex3Measurement {
    pub motors: [MotorMeasurement; MOTOR_COUNT],
    pub pads: [PadMeasurement; PAD_COUNT],
    pub imu: Imu,
    pub power: Power,
    /// Hand-level error word.
    pub error: u32,
    /// Hand-level mode bytes (USB: `mode[0]` model of the hand, `mode[1]` timeout protection).
    pub hand_mode: [u8; 2],
    /// When the values were measured (receipt of the last good frame).
    #[serde(skip)]
    pub measured_at: Instant,
    /// The last exchange failed: the values are from an earlier exchange.
    pub stale: bool,
    /// Number of good frames since start.
    pub seq: u64,
}

impl Dex3Measurement {
    /// No data yet (stale, nothing present).
    pub fn empty(now: Instant) -> Self {
        Self {
            motors: Default::default(),
            pads: Default::default(),
            imu: Imu::default(),
            power: Power::default(),
            error: 0,
            hand_mode: [0; 2],
            measured_at: now,
            stale: true,
            seq: 0,
        }
    }

    pub fn motor(&self, j: Joint) -> &MotorMeasurement {
        &self.motors[j.index()]
    }

    /// Measured positions in IDL order.
    pub fn positions(&self) -> [f32; MOTOR_COUNT] {
        self.motors.map(|m| m.q)
    }
}
