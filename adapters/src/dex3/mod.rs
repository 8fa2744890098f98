//! Unitree Dex3-1 three-finger hand. What both transports share: the RIS mode byte, the
//! pressure encoding, and the command/measurement types of the USB device loop (in the hand's
//! own sign convention and SI units, IDL joint order, docs/sources.md §2); the mapping table; the USB
//! adapter ([`usb`]); the DDS client of a G1's resident service and that service's emulator.

pub mod config;
pub mod dds_client;
pub mod dds_service_emulator;
pub mod front;
pub mod kind;
pub mod open;
pub mod physical;
pub mod serve;
pub mod table;
pub mod usb;

/// The G1 service's loop and state rate, Hz: not published (docs/sources.md §2 names none);
/// 500 Hz is an assumption, what xr_teleoperate reads (docs/adapters.md, "Dex3-1 service").
/// The default rate of a Dex3 on backend dds, the cap of the Dex3 front's state rate and the
/// emulated service's loop.
pub const SERVICE_HZ: f64 = 500.0;
/// The G1 service's rate of the low-frequency state copy ([`lf_state_topic`]), Hz: an
/// assumption, docs/sources.md §2 names no rate. The Dex3 front's and the emulated service's.
pub const SERVICE_LF_HZ: f64 = 50.0;

/// The G1 service's command topic for `side`: `rt/dex3/{side}/cmd` (docs/sources.md §2).
pub fn cmd_topic(side: Side) -> String {
    format!("rt/dex3/{side}/cmd")
}

/// The G1 service's state topic for `side`: `rt/dex3/{side}/state` (docs/sources.md §2;
/// xr_teleoperate reads it).
pub fn state_topic(side: Side) -> String {
    format!("rt/dex3/{side}/state")
}

/// The G1 service's low-frequency copy of the state for `side`: `rt/lf/dex3/{side}/state`
/// (docs/sources.md §2; the SDK's C++ and ROS 2 examples read it).
pub fn lf_state_topic(side: Side) -> String {
    format!("rt/lf/dex3/{side}/state")
}

/// Dex3-1 joint names, canonical order (= the IDL order of `HandCmd_.motor_cmd`).
pub const JOINTS: [&str; 7] = [
    "thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1",
];

use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Raw pressure meaning "no reading" (manual; docs/sources.md §2).
pub const PRESS_NO_READING: f32 = 30_000.0;
/// Smallest raw value of a valid reading (docs/sources.md §2: valid readings are >= 100000).
pub const PRESS_VALID_MIN: f32 = 100_000.0;
/// RIS mode: bit 7, the timeout flag.
pub const RIS_TIMEOUT_BIT: u8 = 0x80;
/// A motor whose last command set [`RIS_TIMEOUT_BIT`] stops this long after that command
/// (docs/sources.md §2: "motor stops after 1 s without commands").
pub const RIS_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1);

/// Status field (bits 4-6) of the RIS mode byte (manual: 0 lock, 1 FOC).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotorStatus {
    /// 0: "Lock" in the manual, "stop (power-on default)" in motor_msg_HG.h.
    Lock,
    /// 1: field-oriented control: the motor runs `kp*(q-q_des) + kd*(dq-dq_des) + tau`.
    #[default]
    Foc,
    /// A value the manual does not define (2..=7).
    Undefined(u8),
}

/// The RIS mode byte of a Dex3 motor (manual "RIS_Mode_t"; docs/sources.md §2): bits 0-3 id, 4-6
/// status, 7 timeout (GCC bit-field order on little-endian targets).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct RisMode {
    /// Motor id, bits 0-3.
    pub id: u8,
    pub status: MotorStatus,
    /// Bit 7: in a command, enable the 1 s timeout; in feedback, the timeout tripped.
    pub timeout: bool,
}

impl MotorStatus {
    /// The 3-bit field value.
    pub fn raw(self) -> u8 {
        match self {
            MotorStatus::Lock => 0,
            MotorStatus::Foc => 1,
            MotorStatus::Undefined(s) => s & 0x7,
        }
    }

    pub fn from_raw(s: u8) -> Self {
        match s & 0x7 {
            0 => MotorStatus::Lock,
            1 => MotorStatus::Foc,
            s => MotorStatus::Undefined(s),
        }
    }
}

impl RisMode {
    /// `id` is masked to 4 bits.
    pub fn new(id: u8, status: MotorStatus, timeout: bool) -> Self {
        Self {
            id: id & 0x0F,
            status,
            timeout,
        }
    }

    pub fn decode(byte: u8) -> Self {
        let status = MotorStatus::from_raw(byte >> 4);
        Self {
            id: byte & 0x0F,
            status,
            timeout: byte & RIS_TIMEOUT_BIT != 0,
        }
    }

    pub fn encode(self) -> u8 {
        (self.id & 0x0F) | (self.status.raw() << 4) | if self.timeout { RIS_TIMEOUT_BIT } else { 0 }
    }

    /// FOC mode for motor `id`, timeout protection as given (typical: `0x10 | id`).
    pub fn foc(id: u8, timeout: bool) -> Self {
        Self {
            id,
            status: MotorStatus::Foc,
            timeout,
        }
    }
}

/// Number of motors (joints) of one hand.
pub const MOTOR_COUNT: usize = 7;
/// Number of pressure pads of one hand (docs/sources.md §2: the SDK example sizes press_sensor_state to 9).
pub const PAD_COUNT: usize = 9;
/// Taxels per pressure pad (`PressSensorState_.pressure[12]`, `SensorState_t.pressure[12]`).
pub const TAXELS_PER_PAD: usize = 12;

pub use crate::model::Side;

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

    /// The finger this joint belongs to.
    pub fn finger(self) -> dds_service_emulator::Finger {
        use dds_service_emulator::Finger;
        match self {
            Joint::Thumb0 | Joint::Thumb1 | Joint::Thumb2 => Finger::Thumb,
            Joint::Middle0 | Joint::Middle1 => Finger::Middle,
            Joint::Index0 | Joint::Index1 => Finger::Index,
        }
    }

    /// Wire direction of this joint's closing motion (the Dex3 table's sign); `None` for
    /// thumb_0 (a rotation that does not close on an object).
    pub fn closing_dir(self, side: Side) -> Option<f32> {
        match self {
            Joint::Thumb0 => None,
            _ => Some(table::wire_sign(side, self.index())),
        }
    }

    /// Default soft limits (rad, wire frame) handgate clamps to, from the Dex3 table: the
    /// hands are mirror images.
    pub fn limits(self, side: Side) -> (f32, f32) {
        table::wire_limits(side, self.index())
    }

    /// The hardware's range (rad, wire frame): the emulators' hard stops
    /// ([`physical::hard_stops`], the manual's figures).
    pub fn hard_stops(self, side: Side) -> (f32, f32) {
        physical::hard_stops(side, self.index())
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

/// A wire target's five fields under field-oriented control (status FOC).
impl From<crate::mapping::WireTarget> for MotorCommand {
    fn from(w: crate::mapping::WireTarget) -> Self {
        Self {
            q: w.q,
            dq: w.dq,
            tau: w.tau,
            kp: w.kp,
            kd: w.kd,
            status: MotorStatus::Foc,
        }
    }
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
    /// The loop's sequence number (from `Dex3UsbHandle::set_command`) of the client command
    /// sent in the exchange that produced these values; 0 until one was sent. Lets a state be
    /// tagged with the command it reflects, not one still in flight.
    pub cmd_seq: u64,
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
            cmd_seq: 0,
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
