//! Rust twin of `idl/handgate.idl`: handgate's canonical messages.

use crate::keyless_topic_type;
use serde::{Deserialize, Serialize};

pub const MODE_JOINTS: u8 = 0;
pub const MODE_CLOSURE: u8 = 1;
pub const MODE_SAFE: u8 = 2;

pub const FRESH: u8 = 0;
pub const STALE: u8 = 1;
pub const COMMANDED_ONLY: u8 = 2;

/// `DeviceStatus_::motion`: whether the device follows its command (docs/adapters.md, "Motion").
/// Following, settled, or not commanded.
pub const MOTION_OK: u8 = 0;
/// State samples keep arriving, identical, while the device is commanded to move.
pub const MOTION_FROZEN: u8 = 1;
/// One joint (`motion_joint`) does not follow while the others do.
pub const MOTION_JOINT_STUCK: u8 = 2;
/// No joint follows the command, though the state still varies.
pub const MOTION_NOT_FOLLOWING: u8 = 3;
/// `DeviceStatus_::motion`: joints stopped short of a closing target in contact: the hand holds
/// an object (not a fault; a value the frozen layout's `octet` carries, an older reader shows it
/// as unknown).
pub const MOTION_HOLDING: u8 = 4;

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointCmd_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub name: String,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub kp: f32,
    pub kd: f32,
}
keyless_topic_type!(JointCmd_, "handgate::msg::dds_::JointCmd_");

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HandCmd_ {
    pub seq: u64,
    pub mode: u8,
    pub closure: f32,
    pub stiffness: f32,
    pub joints: Vec<JointCmd_>,
}
keyless_topic_type!(HandCmd_, "handgate::msg::dds_::HandCmd_");

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub name: String,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub temperature: f32,
}
keyless_topic_type!(JointState_, "handgate::msg::dds_::JointState_");

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HandState_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub device: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub kind: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub side: String,
    pub cmd_seq: u64,
    pub stamp_ns: u64,
    pub freshness: u8,
    pub closure: f32,
    pub joints: Vec<JointState_>,
    pub pressure: Vec<f32>,
    pub accelerometer: [f32; 3],
    pub gyroscope: [f32; 3],
    pub power_v: f32,
    pub power_a: f32,
    pub faults: u32,
}
keyless_topic_type!(HandState_, "handgate::msg::dds_::HandState_");

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DeviceStatus_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub device: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub kind: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub backend: String,
    pub freshness: u8,
    pub safe: bool,
    pub cmd_rate_hz: f32,
    pub state_rate_hz: f32,
    pub crc_errors: u64,
    pub bad_input: u64,
    pub watchdog_trips: u64,
    pub reconnects: u64,
    pub missed_cycles: u64,
    pub age_ms: f32,
    /// Commands refused whole because another client owns the front (`control`).
    pub foreign_cmd: u64,
    /// Commands dropped whole: the same source timestamp as their writer's last accepted one.
    pub duplicate_cmd: u64,
    /// Commands dropped whole: older than their writer's last accepted one.
    pub reordered_cmd: u64,
    /// Commands dropped whole: older than the front's `max_command_age_ms` on arrival.
    pub late_cmd: u64,
    /// Who commands the device: the front and its writer ("" before any command).
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub owner: String,
    /// Commands refused whole: their host is not in `export.allow_commands_from`.
    pub not_allowed_cmd: u64,
    /// Whether the device follows its command: `MOTION_OK`, `MOTION_FROZEN`,
    /// `MOTION_JOINT_STUCK`, `MOTION_NOT_FOLLOWING`, `MOTION_HOLDING`.
    pub motion: u8,
    /// The canonical joint the verdict names ("" when `motion` is `MOTION_OK`).
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub motion_joint: String,
    /// The largest |target in force - measured position| over the joints, canonical rad
    /// (NaN while nothing is commanded, or the state is not fresh).
    pub tracking_error: f32,
    /// The device's fault bits, as [`HandState_::faults`] carries them (motor error, motor
    /// timeout, link down, CRC, hardware, safe state: `handgate_adapters::model::faults`).
    pub faults: u32,
}
keyless_topic_type!(DeviceStatus_, "handgate::msg::dds_::DeviceStatus_");

/// One endpoint a front or a DDS-client device serves, and what matches it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct EndpointStatus_ {
    /// `front NAME` or `device NAME`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub owner: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub topic: String,
    /// `reader` or `writer`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub role: String,
    /// Counterparts matching (type and QoS).
    pub matched: u32,
    /// The first of them, as `process NAME (pid P) on HOST at ADDR`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize_vec")]
    pub who: Vec<String>,
}
keyless_topic_type!(EndpointStatus_, "handgate::msg::dds_::EndpointStatus_");

/// A discovery finding about a served endpoint, with its fix.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Diagnostic_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub owner: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub topic: String,
    /// `type_mismatch`, `qos_mismatch`, `near_miss_topic`, `foreign_writer`, `no_counterpart`, `served_on_demand`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub kind: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub detail: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub fix: String,
}
keyless_topic_type!(Diagnostic_, "handgate::msg::dds_::Diagnostic_");

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GatewayStatus_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub profile: String,
    pub uptime_ms: u64,
    pub devices: Vec<DeviceStatus_>,
    pub endpoints: Vec<EndpointStatus_>,
    pub diagnostics: Vec<Diagnostic_>,
    /// Messages the gateway's `[record]` recorder wrote (0 without one).
    pub record_messages: u64,
    /// Whole messages it dropped because the disk was slower than the stream.
    pub record_dropped: u64,
    /// The devices' DDS side (`[dds]`): domain, and interface ("" when any).
    pub domain: u32,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub interface: String,
    /// The clients' side, where this message is published (`[export]`; the devices' side
    /// when there is none).
    pub export_domain: u32,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub export_interface: String,
    /// ROS namespace of handgate's own topics ("/" for the root).
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub namespace: String,
    /// The host the gateway runs on.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub host: String,
}
keyless_topic_type!(GatewayStatus_, "handgate::msg::dds_::GatewayStatus_");

// ---------------------------------------------------------------------------------------------
// The status extension (`rt/handgate/status_ext`, docs/wire-types.md "Status: frozen, and its
// extension"). `GatewayStatus_` and `DeviceStatus_` above are FROZEN: final XCDR1 types whose
// layout never changes again (readers built against it keep reading every later gateway).
// Everything new goes here: `@appendable` types in XCDR2, which later versions grow by appending
// members at the end of a struct; a reader of an earlier layout skips what it does not know, a
// reader of a later one gives what a sample lacks its default.
// ---------------------------------------------------------------------------------------------

/// The extension layout this build writes ([`GatewayStatusExt_::version`]).
pub const STATUS_EXT_VERSION: u32 = 2;

/// The extension's topic for status topic `status_topic` (`rt/handgate/status` →
/// `rt/handgate/status_ext`).
pub fn status_ext_topic(status_topic: &str) -> String {
    format!("{status_topic}_ext")
}

/// One front, as the extension reports it (`@appendable`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FrontStatus_ {
    /// The front's name in the profile.
    pub name: String,
    /// Its kind (`dex3`, `handgate`, `ros2_joint_state`, ...).
    pub kind: String,
    /// Command samples it received from clients per second (Hz), over the last status period.
    pub cmd_rate_hz: f32,
    /// Publishes of its state topic per second (Hz; its main state topic, not the `rt/lf`
    /// copy; counted whether or not a reader is matched; 0 for a front with no state topic).
    pub state_rate_hz: f32,
}

impl FrontStatus_ {
    fn write(&self, w: &mut crate::xcdr2::Writer) {
        w.delimited(|w| {
            w.string(&self.name);
            w.string(&self.kind);
            w.f32(self.cmd_rate_hz);
            w.f32(self.state_rate_hz);
        });
    }

    fn read(r: &mut crate::xcdr2::Reader<'_>) -> Result<Self, crate::xcdr2::Xcdr2Error> {
        r.delimited(|r| {
            Ok(Self {
                name: r.string()?,
                kind: r.string()?,
                cmd_rate_hz: r.f32()?,
                state_rate_hz: r.f32()?,
            })
        })
    }
}

/// The status extension (`@appendable`, XCDR2), published beside [`GatewayStatus_`] on
/// [`status_ext_topic`] at the same rate.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GatewayStatusExt_ {
    /// The extension layout the writer wrote ([`STATUS_EXT_VERSION`]): a reader of a later
    /// layout knows from it which of its members the writer did not have (they read as 0).
    pub version: u32,
    /// Per front: its name, kind, client command rate and state rate.
    pub fronts: Vec<FrontStatus_>,
    /// Version 2: remote participants the gateway's DDS Security domains refused (distinct
    /// identities, every reason: docs/security.md); 0 without DDS Security, and as read from
    /// a version 1 writer.
    #[serde(default)]
    pub refused_participants: u32,
}

impl GatewayStatusExt_ {
    /// The sample's XCDR2 bytes, encapsulation header first.
    pub fn to_xcdr2(&self) -> Vec<u8> {
        let mut w = crate::xcdr2::Writer::new();
        w.delimited(|w| {
            w.u32(self.version);
            w.sequence(&self.fronts, |w, f| f.write(w));
            w.u32(self.refused_participants);
        });
        w.finish()
    }

    /// A sample from its XCDR2 bytes (header first), of this layout, an earlier or a later one.
    pub fn from_xcdr2(bytes: &[u8]) -> Result<Self, crate::xcdr2::Xcdr2Error> {
        crate::xcdr2::Reader::new(bytes)?.delimited(|r| {
            Ok(Self {
                version: r.u32()?,
                fronts: r.sequence(FrontStatus_::read)?,
                refused_participants: r.u32_or_default()?,
            })
        })
    }
}

keyless_topic_type!(GatewayStatusExt_, "handgate::msg::dds_::GatewayStatusExt_", {
    fn own_encoding() -> bool {
        true
    }
    fn encode_own(&self) -> Option<Vec<u8>> {
        Some(self.to_xcdr2())
    }
    fn decode_own(bytes: &[u8]) -> Option<Self> {
        Self::from_xcdr2(bytes).ok()
    }
});

impl crate::DdsTypeName for FrontStatus_ {
    const DDS_TYPE_NAME: &'static str = "handgate::msg::dds_::FrontStatus_";
}
