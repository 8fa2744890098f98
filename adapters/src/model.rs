//! The canonical model: one way to command and observe any hand.
//!
//! - Joints are named per device kind ([`DeviceKind::joint_names`], from its folder) and addressed by
//!   [`JointId`] (an index into that list).
//! - Units are SI: rad, rad/s, N*m, N*m/rad, N*m*s/rad.
//! - Sign: **positive = closing** for every joint of every hand, left or right
//!   (docs/model.md explains the thumb).
//! - Every device also accepts a hand-level [`CommandBody::Closure`] in [0, 1] (0 open,
//!   1 closed), mapped through the device table's closure map.

use std::fmt;
use std::time::{Duration, Instant, SystemTime};

use serde::{Deserialize, Serialize};

pub use crate::kind::DeviceKind;

/// A parallel gripper's single joint (the Dex1-1's and the EZGripper's: a gripper front
/// drives any gripper joint-for-joint).
pub const GRIPPER_JOINTS: [&str; 1] = ["jaw"];

/// Which hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    #[default]
    Left,
    Right,
    /// A single gripper with no side (EZGripper servo id 3).
    Center,
}

impl Side {
    pub const ALL: [Side; 3] = [Side::Left, Side::Right, Side::Center];

    pub fn as_str(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
            Side::Center => "center",
        }
    }
}

impl std::str::FromStr for Side {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "left" | "l" => Ok(Side::Left),
            "right" | "r" => Ok(Side::Right),
            "center" | "c" => Ok(Side::Center),
            other => Err(format!("unknown side {other:?} (expected left, right or center)")),
        }
    }
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Index of a joint in its kind's canonical joint list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub u8);

impl JointId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// One joint's command in canonical units and sign.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct JointCommand {
    /// Position, rad (positive = closing).
    pub q: f32,
    /// Velocity, rad/s.
    pub dq: f32,
    /// Feed-forward torque, N*m (positive = closing).
    pub tau: f32,
    /// Stiffness, N*m/rad.
    pub kp: f32,
    /// Damping, N*m*s/rad.
    pub kd: f32,
}

impl JointCommand {
    pub fn is_finite(&self) -> bool {
        [self.q, self.dq, self.tau, self.kp, self.kd]
            .iter()
            .all(|v| v.is_finite())
    }

    /// Hold `q` with the given gains and no feed-forward.
    pub fn hold(q: f32, kp: f32, kd: f32) -> Self {
        Self {
            q,
            dq: 0.0,
            tau: 0.0,
            kp,
            kd,
        }
    }
}

/// What the device should do when commands stop or the gateway shuts down.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SafeAction {
    /// Hold the measured position with damping (gains from the device table).
    #[default]
    Hold,
    /// Zero gains and torque.
    Limp,
    /// Move to the open posture (closure 0).
    Open,
}

impl SafeAction {
    pub const ALL: [SafeAction; 3] = [SafeAction::Hold, SafeAction::Limp, SafeAction::Open];

    pub fn as_str(self) -> &'static str {
        match self {
            SafeAction::Hold => "hold",
            SafeAction::Limp => "limp",
            SafeAction::Open => "open",
        }
    }
}

impl fmt::Display for SafeAction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The body of a canonical command.
#[derive(Debug, Clone, PartialEq)]
pub enum CommandBody {
    /// Per-joint targets; joints not listed keep their previous target (or hold where
    /// measured if they never had one).
    Joints(Vec<(JointId, JointCommand)>),
    /// Hand-level closure in [0, 1]; `stiffness` None = the table's default gains.
    Closure { closure: f32, stiffness: Option<f32> },
    /// Go to a safe state.
    Safe(SafeAction),
}

/// A canonical command. Devices keep only the latest (never a queue).
#[derive(Debug, Clone, PartialEq)]
pub struct HandCommand {
    /// Client sequence number, echoed in [`HandState::cmd_seq`].
    pub seq: u64,
    pub body: CommandBody,
    /// A client tag echoed in state (used to measure end-to-end latency).
    pub tag: u32,
}

impl HandCommand {
    pub fn joints(seq: u64, joints: Vec<(JointId, JointCommand)>) -> Self {
        Self {
            seq,
            body: CommandBody::Joints(joints),
            tag: 0,
        }
    }
    pub fn closure(seq: u64, closure: f32) -> Self {
        Self {
            seq,
            body: CommandBody::Closure {
                closure,
                stiffness: None,
            },
            tag: 0,
        }
    }
}

/// One joint's state in canonical units and sign.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointState {
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    /// deg C, when the device reports it.
    pub temperature: Option<f32>,
}

/// How current the state is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Freshness {
    /// Measured within the device's freshness bound.
    Fresh,
    /// The last measured sample is older than the bound (or the link is down).
    #[default]
    Stale,
    /// The device has no feedback: the joint values are what was commanded (hand_sdk).
    CommandedOnly,
}

/// IMU reading (hand frame).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Imu {
    /// w, x, y, z
    pub quaternion: [f32; 4],
    /// rad/s
    pub gyroscope: [f32; 3],
    /// m/s^2
    pub accelerometer: [f32; 3],
}

/// Supply measurements.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Power {
    pub voltage: f32,
    pub current: f32,
}

/// One tactile pad of any size: a name, a rows × cols shape and its taxels row by row.
#[derive(Debug, PartialEq, Default)]
pub struct Pad {
    /// The device's name for the pad (`pad_0` … on a Dex3; `index_top` … on an Inspire FTP).
    pub name: String,
    /// Shape: `rows × cols` taxels (a Dex3 pad is 1 × 12: twelve slots, geometry unpublished).
    pub rows: u16,
    pub cols: u16,
    /// Raw taxel values as the device reports them, row by row (Dex3: 30000 = no reading).
    pub pressure: Vec<f32>,
    /// Per-taxel temperature where the device reports one (Dex3), else empty.
    pub temperature: Vec<f32>,
}

/// `Clone` whose `clone_from` reuses every buffer, field by field (a device loop copies its
/// state every cycle); `clone` goes through it. The list must name every field: a forgotten
/// one does not compile.
macro_rules! clone_reusing_buffers {
    ($t:ident { $($field:ident),* $(,)? }) => {
        impl Clone for $t {
            fn clone(&self) -> Self {
                let mut c = Self::default();
                c.clone_from(self);
                c
            }

            fn clone_from(&mut self, src: &Self) {
                let $t { $($field),* } = src;
                $(self.$field.clone_from($field);)*
            }
        }
    };
}

clone_reusing_buffers!(Pad {
    name,
    rows,
    cols,
    pressure,
    temperature
});

impl Pad {
    /// A Dex3 pad (`pad_{index}`, 1 × 12 taxels with their temperatures).
    pub fn dex3(index: usize, pressure: [f32; 12], temperature: [f32; 12]) -> Self {
        let mut p = Self::default();
        p.set_dex3(index, pressure, temperature);
        p
    }

    /// Makes this pad Dex3 pad `index` with these taxels, reusing its buffers.
    pub fn set_dex3(&mut self, index: usize, pressure: [f32; 12], temperature: [f32; 12]) {
        use std::fmt::Write;
        // A device loop does this for every pad every cycle: rewrite the name only when it
        // changes (never, after the first cycle).
        let digits = index.checked_ilog10().unwrap_or(0) as usize + 1;
        let same = self
            .name
            .strip_prefix("pad_")
            .is_some_and(|n| n.len() == digits && n.parse::<usize>() == Ok(index));
        if !same {
            self.name.clear();
            let _ = write!(self.name, "pad_{index}");
        }
        (self.rows, self.cols) = (1, 12);
        self.pressure.clear();
        self.pressure.extend_from_slice(&pressure);
        self.temperature.clear();
        self.temperature.extend_from_slice(&temperature);
    }

    /// The first `N` values of `v`, `fill` where `v` is shorter (a fixed-size wire array).
    pub fn fixed<const N: usize>(v: &[f32], fill: f32) -> [f32; N] {
        std::array::from_fn(|i| v.get(i).copied().unwrap_or(fill))
    }
}

/// Fault bits in [`HandState::faults`].
pub mod faults {
    /// A motor reports an error (over-current, over-temperature, ...).
    pub const MOTOR_ERROR: u32 = 1 << 0;
    /// A motor's command timeout protection tripped.
    pub const MOTOR_TIMEOUT: u32 = 1 << 1;
    /// The link to the device is down.
    pub const LINK_DOWN: u32 = 1 << 2;
    /// Frames failed their CRC in the last cycle.
    pub const CRC: u32 = 1 << 3;
    /// The device reports a hardware error (EZGripper) or overload.
    pub const HARDWARE: u32 = 1 << 4;
    /// The device is in its safe state (watchdog or shutdown).
    pub const SAFE_STATE: u32 = 1 << 5;

    /// Each bit's name, as the dashboard and the health messages show it.
    pub const NAMES: [(u32, &str); 6] = [
        (MOTOR_ERROR, "motor_error"),
        (MOTOR_TIMEOUT, "motor_timeout"),
        (LINK_DOWN, "link_down"),
        (CRC, "crc"),
        (HARDWARE, "hardware"),
        (SAFE_STATE, "safe_state"),
    ];

    /// The names of the bits set in `bits`, in [`NAMES`] order.
    pub fn names(bits: u32) -> Vec<&'static str> {
        NAMES.iter().filter(|(b, _)| bits & b != 0).map(|(_, n)| *n).collect()
    }
}

/// Canonical state of one device.
#[derive(Debug, PartialEq, Default)]
pub struct HandState {
    /// Joints in canonical order.
    pub joints: Vec<JointState>,
    pub pads: Vec<Pad>,
    pub imu: Option<Imu>,
    pub power: Option<Power>,
    /// Estimated closure [0, 1] (through the table's closure map).
    pub closure: f32,
    /// Bit set of [`faults`].
    pub faults: u32,
    pub freshness: Freshness,
    /// When the last measured sample arrived (monotonic).
    pub measured_at: Option<Instant>,
    /// The same, as wall-clock time (for messages).
    pub measured_wall: Option<SystemTime>,
    /// seq of the last command applied.
    pub cmd_seq: u64,
    /// tag of the last command applied.
    pub cmd_tag: u32,
    /// Device-specific status byte (EZGripper grasp state, Dex1 service mode...).
    pub mode: u8,
    /// Tracking error and the "reports but does not move" verdict for this state
    /// ([`crate::motion`]; set by `link::stamp` on every state a device loop publishes).
    pub motion: crate::motion::MotionReport,
    /// Per joint (canonical order), whether the device itself reports contact (an Inspire FTP
    /// actuator stopped at its force limit): the kinds whose table says
    /// [`crate::motion::Contact::Reported`]; empty elsewhere.
    pub contact: Vec<bool>,
}

clone_reusing_buffers!(HandState {
    joints,
    pads,
    imu,
    power,
    closure,
    faults,
    freshness,
    measured_at,
    measured_wall,
    cmd_seq,
    cmd_tag,
    mode,
    motion,
    contact,
});

impl HandState {
    /// A state with `n` zero joints, stale.
    pub fn empty(n: usize) -> Self {
        Self {
            joints: vec![JointState::default(); n],
            ..Default::default()
        }
    }

    /// Age of the last measured sample.
    pub fn age(&self, now: Instant) -> Option<Duration> {
        self.measured_at.map(|t| now.saturating_duration_since(t))
    }
}
