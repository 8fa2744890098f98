//! The resolved fleet the runtime starts: what a validated profile turns into. Kept separate
//! from the profile schema (user-facing, layered, validated) so the runtime only ever sees
//! complete, typed values.

use std::time::Duration;

use handgate_adapters::device::Backend;
use handgate_adapters::dex1::adapter::Variant;
use handgate_adapters::dex3::dds_client::StateSource;
use handgate_adapters::hand_sdk::adapter::WeightRamp;
use handgate_adapters::model::{DeviceKind, SafeAction, Side};
use handgate_adapters::tables::TableParams;

/// How a device is reached.
#[derive(Debug, Clone, PartialEq)]
pub enum Transport {
    /// Dex3-1 through a G1's resident service.
    Dex3Dds {
        cmd_topic: String,
        state_topic: String,
        timeout_bit: bool,
    },
    /// Dex1-1 through dex1_1_service / the EZGripper driver.
    Dex1Dds {
        variant: Variant,
        cmd_topic: String,
        state_topic: String,
    },
    /// Dex3-1 over USB (a real hand, or the MCU emulator at the transport seam).
    Dex3Usb {
        source: handgate_adapters::dex3::usb::adapter::UsbSource,
        timeout_bit: bool,
        wiring: handgate_adapters::dex3::usb::WiringMap,
        scalings: handgate_adapters::dex3::usb::Scalings,
    },
    /// An EZGripper on a Dynamixel bus (`port` is shared by every gripper on it).
    EzGripper {
        /// Serial port, or for an emulated bus the key grippers on the same virtual bus share.
        port: String,
        emulated: bool,
        baud: u32,
        servo_id: u8,
        force_pct: f32,
        calibrate_on_start: bool,
        /// Measurement noise of an emulated bus (the first emulated gripper's on a shared bus).
        emulator_noise: handgate_adapters::sim::Noise,
        zero_ticks: Option<i32>,
        response_timeout_ms: Option<u64>,
        params: handgate_adapters::ezgripper::EzGripperParams,
    },
    /// G1 rt/hand_sdk.
    HandSdk {
        topic: String,
        ramp: WeightRamp,
        publish_hz: f64,
    },
    /// A DDS peer emulator started in-process on private topics
    /// ([`emulator_topics`]), driven by the same DDS adapter a real peer would get: the
    /// emulator sits exactly where the robot's service would.
    EmulatedDds(EmulatedPeer),
}

/// Which peer to emulate, with its initial state (wire units).
#[derive(Debug, Clone, PartialEq)]
pub enum EmulatedPeer {
    /// A G1's resident Dex3 service.
    Dex3Service {
        initial_q: [f32; 7],
        timeout_bit: bool,
        noise: handgate_adapters::sim::Noise,
    },
    /// dex1_1_service.
    Dex1Service {
        initial_q: f32,
        object_q: Option<f32>,
        noise: handgate_adapters::sim::Noise,
    },
    /// ai_sport's rt/hand_sdk blend.
    AiSport { ramp: WeightRamp, publish_hz: f64 },
}

/// One device.
#[derive(Debug, Clone, PartialEq)]
pub struct DevicePlan {
    pub name: String,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    pub table: TableParams,
    pub rate_hz: f64,
    pub stale_after: Duration,
    pub safe_action: SafeAction,
    pub transport: Transport,
}

/// What a front speaks.
#[derive(Debug, Clone, PartialEq)]
pub enum FrontKind {
    Dex3 {
        lf_state_topic: Option<String>,
        lf_state_hz: f64,
    },
    Dex1 {
        variant: Variant,
        range_rad: f32,
    },
    Canonical,
    JointState {
        devices: Vec<String>,
        urdf_names: bool,
    },
}

/// What a front does when its client goes silent, resolved for one bound device
/// (docs/fronts.md, "Silence").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SilencePlan {
    /// The semantics in effect (for logs and `handgate check`): the profile's choice, except
    /// that a canonical front's service semantics are the watchdog's.
    pub mode: crate::profile::Silence,
    /// After this long without a command, this action; `None`: the last target is kept.
    pub after: Option<(Duration, SafeAction)>,
    /// After a command that set the Dex3 RIS timeout bit (bit 7): this long, this action.
    pub timeout_bit: Option<(Duration, SafeAction)>,
}

impl SilencePlan {
    /// The silence action armed by a command (whether it set the RIS timeout bit): the
    /// earlier of the two, or `None` when silence keeps the last target.
    pub fn armed(&self, timeout_bit: bool) -> Option<(Duration, SafeAction)> {
        let bit = self.timeout_bit.filter(|_| timeout_bit);
        match (self.after, bit) {
            (Some(a), Some(b)) => Some(if b.0 < a.0 { b } else { a }),
            (a, b) => a.or(b),
        }
    }
}

impl std::fmt::Display for SilencePlan {
    /// E.g. `service: keeps the last target (limp 1000 ms after a command with the RIS
    /// timeout bit)`, `watchdog: hold after 200 ms`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: ", self.mode)?;
        match (self.after, self.timeout_bit) {
            (Some((t, a)), None) => write!(f, "{a} after {} ms", t.as_millis()),
            (Some((t, a)), Some((tb, ab))) => write!(
                f,
                "{a} after {} ms ({ab} after {} ms after a command with the RIS timeout bit)",
                t.as_millis(),
                tb.min(t).as_millis()
            ),
            (None, Some((tb, ab))) => write!(
                f,
                "keeps the last target ({ab} {} ms after a command with the RIS timeout bit)",
                tb.as_millis()
            ),
            (None, None) => f.write_str("keeps the last target"),
        }
    }
}

/// One device a front drives.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    pub device: String,
    /// The side whose wire convention the front speaks for this device.
    pub side: Side,
    /// Element of the front's messages that carries this device (actuator: 0 right, 1 left;
    /// otherwise 0).
    pub element: usize,
    pub silence: SilencePlan,
}

/// One front, bound to its devices (one, except an actuator front's two grippers; a
/// JointState front lists its devices in its kind instead).
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPlan {
    /// The name logs use (profile `name`, or derived).
    pub name: String,
    pub kind: FrontKind,
    pub bindings: Vec<Binding>,
    pub cmd_topic: Option<String>,
    pub state_topic: String,
    pub state_hz: f64,
}

impl FrontPlan {
    /// Number of elements in this front's messages that carry a device (2 for an actuator
    /// front, else 1).
    pub fn elements(&self) -> usize {
        match self.kind {
            FrontKind::Dex1 {
                variant: Variant::Actuator,
                ..
            } => 2,
            _ => 1,
        }
    }
}

/// The whole fleet.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub profile: String,
    pub domain: u32,
    pub interface: Option<String>,
    pub status_topic: String,
    pub status_hz: f64,
    pub devices: Vec<DevicePlan>,
    pub fronts: Vec<FrontPlan>,
}

/// Standard topics.
pub fn dex3_topics(side: Side) -> (String, String, String) {
    let s = side.as_str();
    (
        format!("rt/dex3/{s}/cmd"),
        format!("rt/dex3/{s}/state"),
        format!("rt/lf/dex3/{s}/state"),
    )
}

/// Standard Dex1 topics for a variant.
pub fn dex1_topics(variant: Variant, side: Side) -> (String, String) {
    handgate_adapters::dex1::adapter::topics(variant, side)
}

/// The canonical front's topics for a device.
pub fn canonical_topics(device: &str) -> (String, String) {
    (
        format!("rt/handgate/{device}/cmd"),
        format!("rt/handgate/{device}/state"),
    )
}

/// Private topics of an in-process emulated peer for `device`.
pub fn emulator_topics(device: &str) -> (String, String) {
    (
        format!("rt/handgate/emu/{device}/cmd"),
        format!("rt/handgate/emu/{device}/state"),
    )
}

/// The Dex3 resident service's state source → topic.
pub fn dex3_state_topic(side: Side, source: StateSource) -> String {
    handgate_adapters::dex3::dds_client::topics(side, source).1
}
