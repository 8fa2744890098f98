//! The typed profile: what a TOML profile file deserializes into.
//!
//! Every struct denies unknown keys and has a `Default`. Values whose default depends on
//! other keys (a device's rate depends on its kind and backend, a front's topics on its
//! kind, side and variant) are `Option`s here and resolved by the methods below, so the
//! runtime asks the config instead of re-deriving the rules.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use serde::{Deserialize, Serialize};

/// Highest DDS domain id the standard RTPS port mapping allows (7400 + 250 * 232 + 1 < 65535).
pub const MAX_DOMAIN_ID: u32 = 232;
/// Highest rate any loop or publisher may be configured to, Hz.
pub const MAX_RATE_HZ: f64 = 2000.0;
/// Highest status publish rate, Hz (the status topic is a slow heartbeat).
pub const MAX_STATUS_RATE_HZ: f64 = 10.0;
/// Watchdog timeouts must lie in this range, ms.
pub const WATCHDOG_MS_RANGE: (u32, u32) = (10, 10_000);
/// A Dex1 front must publish state at least this fast: xr_teleoperate runs its gripper loop
/// at 200 Hz (docs/sources.md §4).
pub const DEX1_MIN_STATE_HZ: f64 = 200.0;

/// A DDS domain id (0..=232).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct DomainId(pub u32);

/// A rate in Hz.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(transparent)]
pub struct RateHz(pub f64);

impl RateHz {
    /// The period of one cycle (`None` for a non-positive or non-finite rate).
    pub fn period(self) -> Option<Duration> {
        (self.0.is_finite() && self.0 > 0.0).then(|| Duration::from_secs_f64(1.0 / self.0))
    }
}

impl fmt::Display for RateHz {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} Hz", self.0)
    }
}

/// A duration in milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Millis(pub u32);

impl Millis {
    pub fn as_duration(self) -> Duration {
        Duration::from_millis(u64::from(self.0))
    }
}

impl fmt::Display for Millis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ms", self.0)
    }
}

/// An angle in radians.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Radians(pub f64);

impl fmt::Display for Radians {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} rad", self.0)
    }
}

/// A DDS topic name, e.g. `rt/dex3/left/cmd`.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Topic(pub String);

impl Topic {
    pub fn new(s: impl Into<String>) -> Self {
        Topic(s.into())
    }
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Topic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// A device's name in the profile (`[a-z0-9_-]+`, unique in the fleet).
#[derive(Debug, Clone, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct DeviceName(pub String);

impl DeviceName {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for DeviceName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

pub use handgate_adapters::device::Backend;
pub use handgate_adapters::dex1::adapter::Variant as Dex1Variant;
pub use handgate_adapters::dex3::dds_client::StateSource;
pub use handgate_adapters::model::{DeviceKind, SafeAction, Side};

macro_rules! snake_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident => $s:literal),+ $(,)? } default $d:ident) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum $name { $($(#[$vm])* $v),+ }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$v),+];
            /// The spelling used in profile files.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$v => $s),+ }
            }
        }

        impl Default for $name {
            fn default() -> Self { $name::$d }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

snake_enum!(
    /// How log lines are printed.
    LogFormat { Human => "human", Json => "json" } default Human
);

snake_enum!(
    /// What a front does when its client goes silent (docs/fronts.md, "Silence").
    Silence {
        /// What the served interface's real service does: the Dex3 service keeps the last
        /// target (the motors stop 1 s after the last command only when it set the RIS
        /// timeout bit), dex1_1_service brakes (holds the measured position) after 1 s, and
        /// handgate's canonical interface is the strict watchdog below.
        Service => "service",
        /// After the bound device's `watchdog.timeout_ms`, its `watchdog.safe_action`.
        Watchdog => "watchdog",
    } default Service
);

snake_enum!(
    /// Which interface a front serves to clients.
    FrontKind {
        /// The Dex3-1 DDS interface (`rt/dex3/{side}/*`).
        Dex3 => "dex3",
        /// The Dex1-1 DDS interface (`rt/dex1/{side}/*` or `rt/unitree_actuator/*`).
        Dex1 => "dex1",
        /// handgate's own canonical messages (`rt/handgate/{device}/*`).
        Canonical => "canonical",
        /// ROS 2 sensor_msgs/JointState.
        JointState => "joint_state",
    } default Canonical
);

/// The whole profile.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Profile {
    /// Short name, shown by `handgate check`.
    pub name: String,
    /// One line saying what setup this profile is for.
    pub description: String,
    pub dds: DdsConfig,
    pub log: LogConfig,
    pub status: StatusConfig,
    pub devices: Vec<DeviceConfig>,
    pub fronts: Vec<FrontConfig>,
}

/// DDS participant settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    pub domain: DomainId,
    /// Network interface to bind, like unitree_sdk2's `ChannelFactoryInitialize(0, "eth0")`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface: Option<String>,
}

impl Default for DdsConfig {
    /// Domain 1, as Unitree's simulators use, so a default run cannot move a robot on 0.
    fn default() -> Self {
        DdsConfig {
            domain: DomainId(1),
            interface: None,
        }
    }
}

/// Logging.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LogConfig {
    pub format: LogFormat,
    /// A tracing `EnvFilter` directive: `info`, `debug`, `handgate=debug,warn`, ...
    pub level: String,
}

impl Default for LogConfig {
    fn default() -> Self {
        LogConfig {
            format: LogFormat::Human,
            level: "info".into(),
        }
    }
}

/// The gateway's own status heartbeat.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StatusConfig {
    pub topic: Topic,
    pub rate_hz: RateHz,
}

impl Default for StatusConfig {
    fn default() -> Self {
        StatusConfig {
            topic: Topic::new("rt/handgate/status"),
            rate_hz: RateHz(1.0),
        }
    }
}

/// How fast a device loop runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DeviceRate {
    /// A fixed loop rate.
    Hz(RateHz),
    /// As fast as the bus answers (EZGripper on a serial Dynamixel bus).
    AsFastAsBus,
}

impl fmt::Display for DeviceRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceRate::Hz(r) => r.fmt(f),
            DeviceRate::AsFastAsBus => f.write_str("as fast as the bus"),
        }
    }
}

/// One device of the fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceConfig {
    pub name: DeviceName,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    /// Device loop / publish rate; `None` = the kind's default (see [`DeviceConfig::rate`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<RateHz>,
    #[serde(default)]
    pub limits: LimitsConfig,
    #[serde(default)]
    pub watchdog: WatchdogConfig,
    #[serde(default)]
    pub closure: ClosureConfig,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub usb: Option<UsbConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dds: Option<DeviceDdsConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hand_sdk: Option<HandSdkConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ezgripper: Option<EzGripperConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emulator: Option<EmulatorConfig>,
}

impl Default for DeviceConfig {
    /// An emulated left Dex3 called `hand`.
    fn default() -> Self {
        DeviceConfig {
            name: DeviceName("hand".into()),
            kind: DeviceKind::Dex3,
            side: Side::Left,
            backend: Backend::Emulator,
            rate_hz: None,
            limits: LimitsConfig::default(),
            watchdog: WatchdogConfig::default(),
            closure: ClosureConfig::default(),
            usb: None,
            dds: None,
            hand_sdk: None,
            ezgripper: None,
            emulator: None,
        }
    }
}

impl DeviceConfig {
    /// The device loop rate: `rate_hz` if set, else the kind's default:
    /// Dex3 1000 Hz over USB (and its emulator), 500 Hz over DDS; Dex1 500 Hz
    /// (dex1_1_service's loop); EZGripper as fast as the bus; hand_sdk 200 Hz.
    pub fn rate(&self) -> DeviceRate {
        if let Some(r) = self.rate_hz {
            return DeviceRate::Hz(r);
        }
        match (self.kind, self.backend) {
            (DeviceKind::Dex3, Backend::Dds) => DeviceRate::Hz(RateHz(500.0)),
            (DeviceKind::Dex3, _) => DeviceRate::Hz(RateHz(1000.0)),
            (DeviceKind::Dex1, _) => DeviceRate::Hz(RateHz(500.0)),
            (DeviceKind::Ezgripper, _) => DeviceRate::AsFastAsBus,
            (DeviceKind::HandSdk, _) => DeviceRate::Hz(RateHz(200.0)),
        }
    }

    /// The Dex1 wire variant of a DDS-backed Dex1 (default `go`).
    pub fn dex1_variant(&self) -> Dex1Variant {
        self.dds.as_ref().and_then(|d| d.variant).unwrap_or_default()
    }

    /// The Dex1 open position (`dds.range_rad`, default 5.4 rad).
    pub fn dex1_range(&self) -> Radians {
        self.dds
            .as_ref()
            .and_then(|d| d.range_rad)
            .unwrap_or(Radians(DEX1_DEFAULT_RANGE_RAD))
    }

    /// The topics handgate uses to reach a DDS-backed device: (command topic it publishes,
    /// state topic it subscribes). `None` for other backends, or where the default cannot be
    /// derived (a Dex3/Dex1 with side `center` and no override).
    pub fn dds_topics(&self) -> Option<(Option<Topic>, Option<Topic>)> {
        if self.backend != Backend::Dds {
            return None;
        }
        let dds = self.dds.clone().unwrap_or_default();
        let lr = side_lr(self.side);
        let (cmd, state) = match self.kind {
            DeviceKind::Dex3 => (
                lr.map(|s| Topic(format!("rt/dex3/{s}/cmd"))),
                lr.map(|s| match dds.state_source.unwrap_or_default() {
                    StateSource::State => Topic(format!("rt/dex3/{s}/state")),
                    StateSource::Lf => Topic(format!("rt/lf/dex3/{s}/state")),
                }),
            ),
            DeviceKind::Dex1 => match self.dex1_variant() {
                Dex1Variant::Actuator => (
                    Some(Topic::new("rt/unitree_actuator/cmd")),
                    Some(Topic::new("rt/unitree_actuator/state")),
                ),
                Dex1Variant::Go | Dex1Variant::Hg => (
                    lr.map(|s| Topic(format!("rt/dex1/{s}/cmd"))),
                    lr.map(|s| Topic(format!("rt/dex1/{s}/state"))),
                ),
            },
            DeviceKind::HandSdk => (Some(self.hand_sdk.clone().unwrap_or_default().topic), None),
            DeviceKind::Ezgripper => (None, None),
        };
        Some((dds.cmd_topic.or(cmd), dds.state_topic.or(state)))
    }
}

/// A joint_state front's topic when `topic` is not set.
pub const DEFAULT_JOINT_STATE_TOPIC: &str = "rt/joint_states";

/// Dex1 open position when `dds.range_rad` is not set (xr_teleoperate, EZGripper driver).
pub const DEX1_DEFAULT_RANGE_RAD: f64 = 5.4;

fn side_lr(side: Side) -> Option<&'static str> {
    match side {
        Side::Left => Some("left"),
        Side::Right => Some("right"),
        Side::Center => None,
    }
}

/// Per-joint limit overrides and the per-command step limit.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest allowed distance, per command, between the commanded and the measured position.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_step: Option<Radians>,
    /// Joint name -> bounds, narrowing the device's hardware range.
    pub joints: BTreeMap<String, JointLimit>,
}

/// Bounds of one joint; an omitted bound keeps the hardware bound.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointLimit {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min: Option<Radians>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max: Option<Radians>,
}

/// Device watchdog: what happens when no command arrives in time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WatchdogConfig {
    pub timeout_ms: Millis,
    pub safe_action: SafeAction,
}

impl Default for WatchdogConfig {
    fn default() -> Self {
        WatchdogConfig {
            timeout_ms: Millis(200),
            safe_action: SafeAction::Hold,
        }
    }
}

/// How the scalar "closure" (0 = open, 1 = closed) maps to the device.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClosureConfig {
    /// Dex3: joint -> rad at closure 0 (omitted joints: 0 rad).
    pub open: BTreeMap<String, Radians>,
    /// Dex3: joint -> rad at closure 1 (omitted joints: the Dex3 table's default posture, `hardware::dex3_closed_default`).
    pub closed: BTreeMap<String, Radians>,
    /// hand_sdk: feed-forward torque at closure 0 (negative opens), N*m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tau_open: Option<f64>,
    /// hand_sdk: feed-forward torque at closure 1 (positive closes), N*m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tau_closed: Option<f64>,
}

/// Dex3 over USB (also read by the Dex3 emulator, which speaks the same protocol).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UsbConfig {
    /// USB serial number, to tell two hands of the same side apart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    /// Talk to a Dex3-1 MCU emulator process (`handgate emulate dex3 --socket PATH`) over this
    /// Unix socket instead of USB (backend `usb` only): tests kill and restart "the hand".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub socket: Option<std::path::PathBuf>,
    /// Set the motors' timeout-protection bit (motor stops after 1 s without commands).
    pub timeout_bit: bool,
    /// Which bus and id each joint and pressure pad sits on; not public (docs/sources.md §3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wiring: Option<WiringConfig>,
    /// Overrides of the motor-frame scalings (docs/sources.md §3 "scaling conflict").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scalings: Option<Scalings>,
}

impl Default for UsbConfig {
    fn default() -> Self {
        UsbConfig {
            serial: None,
            socket: None,
            timeout_bit: true,
            wiring: None,
            scalings: None,
        }
    }
}

/// Number of buses in a Dex3-1 USB frame (docs/sources.md §3).
pub const DEX3_USB_BUSES: u8 = 5;
/// Pressure pads on a Dex3-1 (user manual: 9 sensors).
pub const DEX3_PADS: usize = 9;

/// Where a motor or a pressure pad sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusSlot {
    /// Bus index, 0..=4.
    pub bus: u8,
    /// Id on that bus: motors 0..=15, sensors 0..=14 (15 is broadcast).
    pub id: u8,
}

/// Dex3 USB wiring: joint -> slot and pad (`pad_0`..`pad_8`) -> slot.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WiringConfig {
    pub joints: BTreeMap<String, BusSlot>,
    pub pads: BTreeMap<String, BusSlot>,
}

/// Motor-frame scalings: the USB adapter's one table (`handgate_adapters::dex3::usb::Scalings`,
/// docs/dex3-usb.md); every key a profile leaves out keeps its built-in value.
pub use handgate_adapters::dex3::usb::Scalings;

/// A DDS-backed device: topic overrides and wire variant.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeviceDdsConfig {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<Topic>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<Topic>,
    /// Dex3 only: read `rt/dex3/{side}/state` (`state`) or `rt/lf/dex3/{side}/state` (`lf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_source: Option<StateSource>,
    /// Dex1 only: wire variant (default `go`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<Dex1Variant>,
    /// Dex1 only: open position, rad (default 5.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub range_rad: Option<Radians>,
}

/// The G1 `rt/hand_sdk` blend interface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HandSdkConfig {
    pub topic: Topic,
    /// Target blend weight 0..=1 (sent as `cmds[0].mode = weight * 100`).
    pub weight: f64,
    /// How fast the weight ramps towards its target, per second.
    pub ramp_per_s: f64,
    /// Publish rate; `None` = the device rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub publish_hz: Option<RateHz>,
}

impl Default for HandSdkConfig {
    fn default() -> Self {
        HandSdkConfig {
            topic: Topic::new("rt/hand_sdk"),
            weight: 1.0,
            ramp_per_s: 0.5,
            publish_hz: None,
        }
    }
}

/// Dynamixel baud rates an MX-64 accepts under Protocol 2.0 (ROBOTIS e-manual, Baud Rate(8)).
pub const DYNAMIXEL_BAUDS: &[u32] = &[
    9_600, 57_600, 115_200, 1_000_000, 2_000_000, 3_000_000, 4_000_000, 4_500_000,
];

/// A SAKE EZGripper on a Dynamixel bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EzGripperConfig {
    pub port: String,
    pub baud: u32,
    /// Servo id on the bus; `None` = by side: 1 left, 2 right, 3 center (SAKE driver).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo_id: Option<u8>,
    /// Opening at 5.4 rad (Dex1 "open"), percent, 1..=100.
    pub max_open_percent: u8,
    /// Grip force limit, percent 1..=100; `None` = leave the servo's current limit alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_limit_percent: Option<u8>,
    /// Run the closing calibration at start (moves the gripper).
    pub calibrate_on_start: bool,
    /// A known calibration zero (raw ticks at the closed stop), e.g. from a previous run
    /// (SAKE's `/tmp/ezgripper_device_config.json`); a calibration replaces it at run time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_ticks: Option<i32>,
    /// Grace for a reply beyond its wire time, ms (USB-serial adapter latency; SAKE's
    /// `communication.timeout`). Default 20.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_timeout_ms: Option<u64>,
    /// The driver's constants (MX-64 settings, calibration, grasp detection; docs/ezgripper.md),
    /// every key optional.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub params: Option<EzGripperParams>,
}

/// The EZGripper driver's constants: the adapter's one table.
pub use handgate_adapters::ezgripper::EzGripperParams;

impl Default for EzGripperConfig {
    fn default() -> Self {
        EzGripperConfig {
            port: "/dev/ttyUSB0".into(),
            baud: 1_000_000,
            servo_id: None,
            max_open_percent: 100,
            force_limit_percent: None,
            calibrate_on_start: false,
            zero_ticks: None,
            response_timeout_ms: None,
            params: None,
        }
    }
}

impl EzGripperConfig {
    /// The servo id: `servo_id` or 1 left / 2 right / 3 center.
    pub fn servo_id_for(&self, side: Side) -> u8 {
        self.servo_id.unwrap_or(match side {
            Side::Left => 1,
            Side::Right => 2,
            Side::Center => 3,
        })
    }
}

/// Options for an emulated device.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EmulatorConfig {
    /// Joint -> initial position, rad (omitted joints start at the kind's rest posture,
    /// docs/adapters.md).
    pub initial: BTreeMap<String, Radians>,
    /// Joint -> position where an emulated object blocks the closing joint, rad.
    pub object_at: BTreeMap<String, Radians>,
    /// Measurement noise on the emulated state (default true: the kind's figures,
    /// docs/adapters.md). `false`: exact values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<bool>,
    /// Seed of the noise (default fixed: runs repeat exactly). Mixed with the device name, so
    /// two devices never share a stream.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Overrides of the kind's standard deviations, in the device's wire units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_noise_rad: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity_noise_rad_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_noise_nm: Option<f64>,
}

impl EmulatorConfig {
    /// The noise to emulate, given the kind's default figures: off, or the defaults with
    /// this profile's overrides and seed (mixed with `device`, FNV-1a).
    pub fn noise_for(
        &self,
        device: &str,
        kind_default: handgate_adapters::sim::Noise,
    ) -> handgate_adapters::sim::Noise {
        use handgate_adapters::sim::Noise;
        if self.noise == Some(false) {
            return Noise::OFF;
        }
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in device.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        Noise {
            q: self.position_noise_rad.map(|v| v as f32).unwrap_or(kind_default.q),
            dq: self.velocity_noise_rad_s.map(|v| v as f32).unwrap_or(kind_default.dq),
            tau: self.torque_noise_nm.map(|v| v as f32).unwrap_or(kind_default.tau),
            seed: self.seed.unwrap_or(Noise::DEFAULT_SEED) ^ h,
        }
    }
}

/// The grippers of an `actuator` Dex1 front, by message element (0 = right, 1 = left).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ElementDevices {
    /// Element 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub right: Option<DeviceName>,
    /// Element 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left: Option<DeviceName>,
}

impl ElementDevices {
    /// (side, device) for every bound element, in element order.
    pub fn bound(&self) -> Vec<(Side, &DeviceName)> {
        [(Side::Right, &self.right), (Side::Left, &self.left)]
            .into_iter()
            .filter_map(|(s, d)| d.as_ref().map(|d| (s, d)))
            .collect()
    }
}

/// One front: an interface handgate serves to clients, bound to a device.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontConfig {
    pub kind: FrontKind,
    /// Name used in logs (`[a-z0-9_-]+`, unique among fronts); default derived from the kind
    /// and what it serves ([`FrontConfig::display_name`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The device this front drives. Required, except for `joint_state` where omitting it
    /// publishes every device, and for an `actuator` dex1 front bound with `devices`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<DeviceName>,
    /// `actuator` dex1 fronts: the gripper of each element, `{ right = "..", left = ".." }`;
    /// an element left out is not driven and reports no measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub devices: Option<ElementDevices>,
    /// dex3/dex1 fronts: which topic side to serve (default: the device's side).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<Side>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<Topic>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<Topic>,
    /// dex3 fronts: the low-frequency state copy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_state_topic: Option<Topic>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_hz: Option<RateHz>,
    /// dex3 fronts: rate of the low-frequency copy (default 50).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_state_hz: Option<RateHz>,
    /// dex1 fronts: wire variant (default `go`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<Dex1Variant>,
    /// What silence from the client means (default `service`).
    #[serde(default)]
    pub silence: Silence,
    /// `silence = "watchdog"`: a per-front timeout, shorter than the device's
    /// `watchdog.timeout_ms` (the smaller of the two applies); default: the device's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub watchdog_ms: Option<Millis>,
    /// joint_state fronts: topic (default `rt/joint_states`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic: Option<Topic>,
    /// joint_state fronts: name joints as in the URDF (default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub urdf_names: Option<bool>,
}

impl Default for FrontConfig {
    /// A canonical front with no device (a profile must name one).
    fn default() -> Self {
        FrontConfig {
            kind: FrontKind::Canonical,
            name: None,
            device: None,
            devices: None,
            side: None,
            cmd_topic: None,
            state_topic: None,
            lf_state_topic: None,
            state_hz: None,
            lf_state_hz: None,
            variant: None,
            silence: Silence::default(),
            watchdog_ms: None,
            topic: None,
            urdf_names: None,
        }
    }
}

/// A front's topics and rates after defaults are applied.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontTopics {
    /// Topic the front takes commands on (`None` for joint_state).
    pub cmd: Option<Topic>,
    /// Topic the front publishes state on.
    pub state: Option<Topic>,
    /// dex3: the low-frequency state copy.
    pub lf_state: Option<Topic>,
    pub state_hz: RateHz,
    pub lf_state_hz: Option<RateHz>,
}

impl FrontConfig {
    /// The topic side this dex3/dex1 front serves: `side` or the bound device's.
    pub fn served_side(&self, device: Option<&DeviceConfig>) -> Option<Side> {
        self.side.or(device.map(|d| d.side))
    }

    /// The Dex1 variant (dex1 fronts; default `go`).
    pub fn dex1_variant(&self) -> Dex1Variant {
        self.variant.unwrap_or_default()
    }

    /// An `actuator` dex1 front (one topic pair, element 0 right, 1 left).
    pub fn is_actuator(&self) -> bool {
        self.kind == FrontKind::Dex1 && self.dex1_variant() == Dex1Variant::Actuator
    }

    /// The devices this front drives, with the side whose wire convention each is served in:
    /// an actuator front's elements (`devices`, or `device` on the served side), otherwise
    /// `device` on the served side. Names only; `lookup` finds a device's config.
    pub fn bindings<'a>(
        &'a self,
        lookup: impl Fn(&DeviceName) -> Option<&'a DeviceConfig>,
    ) -> Vec<(Side, &'a DeviceName)> {
        if let Some(d) = &self.devices {
            return d.bound();
        }
        match &self.device {
            Some(n) => vec![(self.served_side(lookup(n)).unwrap_or_default(), n)],
            None => vec![],
        }
    }

    /// The name logs use: `name`, else derived from what the front serves: an overridden
    /// command topic as it is, else `dex3_<side>` / `dex1_<side>` (the served side),
    /// `dex1_actuator`, `canonical_<device>`, `joint_state` (or its topic when not the
    /// default). Two fronts cannot derive the same name: they would serve the same topic.
    pub fn display_name(&self, device: Option<&DeviceConfig>) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        if let (Some(t), false) = (&self.cmd_topic, self.kind == FrontKind::JointState) {
            return t.0.clone();
        }
        let side = self.served_side(device).map_or("?", |s| s.as_str());
        match self.kind {
            FrontKind::Dex1 if self.is_actuator() => "dex1_actuator".into(),
            FrontKind::Dex3 | FrontKind::Dex1 => format!("{}_{side}", self.kind.as_str()),
            FrontKind::Canonical => format!("canonical_{}", self.device.as_ref().map_or("?", |d| d.as_str())),
            FrontKind::JointState => match &self.topic {
                Some(t) if t.as_str() != DEFAULT_JOINT_STATE_TOPIC => t.0.clone(),
                _ => "joint_state".into(),
            },
        }
    }

    /// Topics and rates with defaults applied. `device` is the bound device (`None` for a
    /// joint_state front over every device). A default that cannot be derived (a dex3 front
    /// serving side `center`) is `None`; validation reports it.
    pub fn topics(&self, device: Option<&DeviceConfig>) -> FrontTopics {
        let lr = self.served_side(device).and_then(side_lr);
        let dev_name = device.map(|d| d.name.as_str()).unwrap_or("all");
        let (cmd, state, lf_state) = match self.kind {
            FrontKind::Dex3 => (
                lr.map(|s| Topic(format!("rt/dex3/{s}/cmd"))),
                lr.map(|s| Topic(format!("rt/dex3/{s}/state"))),
                lr.map(|s| Topic(format!("rt/lf/dex3/{s}/state"))),
            ),
            FrontKind::Dex1 => match self.dex1_variant() {
                Dex1Variant::Actuator => (
                    Some(Topic::new("rt/unitree_actuator/cmd")),
                    Some(Topic::new("rt/unitree_actuator/state")),
                    None,
                ),
                Dex1Variant::Go | Dex1Variant::Hg => (
                    lr.map(|s| Topic(format!("rt/dex1/{s}/cmd"))),
                    lr.map(|s| Topic(format!("rt/dex1/{s}/state"))),
                    None,
                ),
            },
            FrontKind::Canonical => (
                Some(Topic(format!("rt/handgate/{dev_name}/cmd"))),
                Some(Topic(format!("rt/handgate/{dev_name}/state"))),
                None,
            ),
            FrontKind::JointState => (
                None,
                Some(
                    self.topic
                        .clone()
                        .unwrap_or_else(|| Topic::new(DEFAULT_JOINT_STATE_TOPIC)),
                ),
                None,
            ),
        };
        let device_hz = device.and_then(|d| match d.rate() {
            DeviceRate::Hz(r) => Some(r.0),
            DeviceRate::AsFastAsBus => None,
        });
        let default_state_hz = match self.kind {
            FrontKind::Dex3 => device_hz.map_or(500.0, |d| d.min(500.0)),
            FrontKind::Dex1 => 500.0,
            FrontKind::Canonical | FrontKind::JointState => device_hz.map_or(100.0, |d| d.min(100.0)),
        };
        let is_dex3 = self.kind == FrontKind::Dex3;
        FrontTopics {
            cmd: if self.kind == FrontKind::JointState {
                None
            } else {
                self.cmd_topic.clone().or(cmd)
            },
            state: if self.kind == FrontKind::JointState {
                state
            } else {
                self.state_topic.clone().or(state)
            },
            lf_state: if is_dex3 {
                self.lf_state_topic.clone().or(lf_state)
            } else {
                None
            },
            state_hz: self.state_hz.unwrap_or(RateHz(default_state_hz)),
            lf_state_hz: is_dex3.then(|| self.lf_state_hz.unwrap_or(RateHz(50.0))),
        }
    }
}
