//! ROS 2 messages as they appear on DDS (rmw_cyclonedds): `sensor_msgs/msg/JointState` and its
//! dependencies, the health messages (`diagnostic_msgs/msg/DiagnosticArray`,
//! `control_msgs/msg/HardwareStatus`), and `rmw_dds_common/msg/ParticipantEntitiesInfo` (the
//! `ros_discovery_info` graph message). ROS 2 prefixes topics with `rt/` and types with `::msg::dds_::` and a
//! trailing underscore.
//!
//! Each type's REP-2011 description (its one home) sits next to it as a
//! [`TypeDescription`] constant; [`crate::type_hash`] turns it into the `RIHS01_` hash.
//! The rmw_dds_common types are the ROS 2 Iron / Jazzy / Kilted layout (a 16-byte `Gid`);
//! Humble's `Gid` has 24 bytes and is not spoken (docs/fronts.md, "ROS 2").

use crate::keyless_topic_type;
use crate::type_hash::{field_type as ft, Field, TypeDescription};
use serde::{Deserialize, Serialize};

/// The ROS 2 interface types handgate writes that have a type description (and so a hash).
pub trait RosType {
    const DESCRIPTION: &'static TypeDescription;
}

/// `builtin_interfaces::msg::dds_::Time_`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time_ {
    pub sec: i32,
    pub nanosec: u32,
}
keyless_topic_type!(Time_, "builtin_interfaces::msg::dds_::Time_");

/// `builtin_interfaces/msg/Time`: `int32 sec`, `uint32 nanosec`.
pub static TIME: TypeDescription = TypeDescription {
    type_name: "builtin_interfaces/msg/Time",
    fields: &[Field::basic("sec", ft::INT32), Field::basic("nanosec", ft::UINT32)],
};
impl RosType for Time_ {
    const DESCRIPTION: &'static TypeDescription = &TIME;
}

/// `std_msgs::msg::dds_::Header_`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header_ {
    pub stamp: Time_,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub frame_id: String,
}
keyless_topic_type!(Header_, "std_msgs::msg::dds_::Header_");

/// `std_msgs/msg/Header`: `builtin_interfaces/Time stamp`, `string frame_id`.
pub static HEADER: TypeDescription = TypeDescription {
    type_name: "std_msgs/msg/Header",
    fields: &[Field::nested("stamp", &TIME), Field::basic("frame_id", ft::STRING)],
};
impl RosType for Header_ {
    const DESCRIPTION: &'static TypeDescription = &HEADER;
}

/// `sensor_msgs::msg::dds_::JointState_`: names are URDF joint names.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointState_ {
    pub header: Header_,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize_vec")]
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
keyless_topic_type!(JointState_, "sensor_msgs::msg::dds_::JointState_");

/// `sensor_msgs/msg/JointState`: `std_msgs/Header header`, `string[] name`, `float64[]
/// position`, `float64[] velocity`, `float64[] effort`.
pub static JOINT_STATE: TypeDescription = TypeDescription {
    type_name: "sensor_msgs/msg/JointState",
    fields: &[
        Field::nested("header", &HEADER),
        Field::basic("name", ft::STRING + ft::UNBOUNDED_SEQUENCE),
        Field::basic("position", ft::DOUBLE + ft::UNBOUNDED_SEQUENCE),
        Field::basic("velocity", ft::DOUBLE + ft::UNBOUNDED_SEQUENCE),
        Field::basic("effort", ft::DOUBLE + ft::UNBOUNDED_SEQUENCE),
    ],
};
impl RosType for JointState_ {
    const DESCRIPTION: &'static TypeDescription = &JOINT_STATE;
}

/// `rmw_dds_common::msg::dds_::Gid_`: an entity's DDS GUID (Iron and later: 16 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Gid_ {
    pub data: [u8; 16],
}
keyless_topic_type!(Gid_, "rmw_dds_common::msg::dds_::Gid_");

/// `rmw_dds_common/msg/Gid`: `char[16] data` (`char` is `uint8` in ROS 2 .msg files).
pub static GID: TypeDescription = TypeDescription {
    type_name: "rmw_dds_common/msg/Gid",
    fields: &[Field::array("data", ft::UINT8, 16)],
};
impl RosType for Gid_ {
    const DESCRIPTION: &'static TypeDescription = &GID;
}

/// `rmw_dds_common::msg::dds_::NodeEntitiesInfo_`: one node and its readers and writers.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct NodeEntitiesInfo_ {
    /// `string<=256`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub node_namespace: String,
    /// `string<=256`.
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub node_name: String,
    pub reader_gid_seq: Vec<Gid_>,
    pub writer_gid_seq: Vec<Gid_>,
}
keyless_topic_type!(NodeEntitiesInfo_, "rmw_dds_common::msg::dds_::NodeEntitiesInfo_");

/// The bound of `NodeEntitiesInfo`'s name and namespace strings.
pub const NODE_NAME_MAX: usize = 256;

/// `rmw_dds_common/msg/NodeEntitiesInfo`: `string<=256 node_namespace`, `string<=256
/// node_name`, `Gid[] reader_gid_seq`, `Gid[] writer_gid_seq`.
pub static NODE_ENTITIES_INFO: TypeDescription = TypeDescription {
    type_name: "rmw_dds_common/msg/NodeEntitiesInfo",
    fields: &[
        Field::bounded_string("node_namespace", NODE_NAME_MAX as u64),
        Field::bounded_string("node_name", NODE_NAME_MAX as u64),
        Field::nested_sequence("reader_gid_seq", &GID),
        Field::nested_sequence("writer_gid_seq", &GID),
    ],
};
impl RosType for NodeEntitiesInfo_ {
    const DESCRIPTION: &'static TypeDescription = &NODE_ENTITIES_INFO;
}

/// `rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_`: what a participant announces on
/// `ros_discovery_info` (its GUID, its nodes).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ParticipantEntitiesInfo_ {
    pub gid: Gid_,
    pub node_entities_info_seq: Vec<NodeEntitiesInfo_>,
}
keyless_topic_type!(
    ParticipantEntitiesInfo_,
    "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
);

/// `rmw_dds_common/msg/ParticipantEntitiesInfo`: `Gid gid`, `NodeEntitiesInfo[]
/// node_entities_info_seq`.
pub static PARTICIPANT_ENTITIES_INFO: TypeDescription = TypeDescription {
    type_name: "rmw_dds_common/msg/ParticipantEntitiesInfo",
    fields: &[
        Field::nested("gid", &GID),
        Field::nested_sequence("node_entities_info_seq", &NODE_ENTITIES_INFO),
    ],
};
impl RosType for ParticipantEntitiesInfo_ {
    const DESCRIPTION: &'static TypeDescription = &PARTICIPANT_ENTITIES_INFO;
}

/// The DDS topic of the ROS 2 graph (no `rt/` prefix: rmw creates it with
/// `avoid_ros_namespace_conventions`).
pub const DISCOVERY_INFO_TOPIC: &str = "ros_discovery_info";

// --- diagnostic_msgs (ros2/common_interfaces) -----------------------------------------------

/// `diagnostic_msgs::msg::dds_::KeyValue_`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub key: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub value: String,
}
keyless_topic_type!(KeyValue_, "diagnostic_msgs::msg::dds_::KeyValue_");

/// `diagnostic_msgs/msg/KeyValue`: `string key`, `string value`.
pub static KEY_VALUE: TypeDescription = TypeDescription {
    type_name: "diagnostic_msgs/msg/KeyValue",
    fields: &[Field::basic("key", ft::STRING), Field::basic("value", ft::STRING)],
};
impl RosType for KeyValue_ {
    const DESCRIPTION: &'static TypeDescription = &KEY_VALUE;
}

/// `diagnostic_msgs::msg::dds_::DiagnosticStatus_`: one component's level and values.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus_ {
    /// One of [`diagnostic_level`].
    pub level: u8,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub name: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub message: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub hardware_id: String,
    pub values: Vec<KeyValue_>,
}
keyless_topic_type!(DiagnosticStatus_, "diagnostic_msgs::msg::dds_::DiagnosticStatus_");

/// `diagnostic_msgs/msg/DiagnosticStatus` constants (`byte level`).
pub mod diagnostic_level {
    pub const OK: u8 = 0;
    pub const WARN: u8 = 1;
    pub const ERROR: u8 = 2;
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticStatus`: `byte level`, `string name`, `string message`,
/// `string hardware_id`, `KeyValue[] values`.
pub static DIAGNOSTIC_STATUS: TypeDescription = TypeDescription {
    type_name: "diagnostic_msgs/msg/DiagnosticStatus",
    fields: &[
        Field::basic("level", ft::BYTE),
        Field::basic("name", ft::STRING),
        Field::basic("message", ft::STRING),
        Field::basic("hardware_id", ft::STRING),
        Field::nested_sequence("values", &KEY_VALUE),
    ],
};
impl RosType for DiagnosticStatus_ {
    const DESCRIPTION: &'static TypeDescription = &DIAGNOSTIC_STATUS;
}

/// `diagnostic_msgs::msg::dds_::DiagnosticArray_`: what `/diagnostics` carries.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray_ {
    pub header: Header_,
    pub status: Vec<DiagnosticStatus_>,
}
keyless_topic_type!(DiagnosticArray_, "diagnostic_msgs::msg::dds_::DiagnosticArray_");

/// `diagnostic_msgs/msg/DiagnosticArray`: `std_msgs/Header header`, `DiagnosticStatus[] status`.
pub static DIAGNOSTIC_ARRAY: TypeDescription = TypeDescription {
    type_name: "diagnostic_msgs/msg/DiagnosticArray",
    fields: &[
        Field::nested("header", &HEADER),
        Field::nested_sequence("status", &DIAGNOSTIC_STATUS),
    ],
};
impl RosType for DiagnosticArray_ {
    const DESCRIPTION: &'static TypeDescription = &DIAGNOSTIC_ARRAY;
}

/// The DDS topic of `/diagnostics` (global: ROS's diagnostic aggregator reads it there).
pub const DIAGNOSTICS_TOPIC: &str = "rt/diagnostics";

// --- control_msgs 6.8.0 (ros-controls/control_msgs, docs/sources.md) ------------------------
//
// The field names are those of control_msgs 6.5.0 to 6.8.0 (identical in that range; 6.5.0
// introduced the messages, after `GenericState` was renamed `GenericHardwareState`). Only
// `GenericHardwareState` is filled; the CANopen, EtherCAT and VDA5050 sequences stay empty but
// are part of the wire layout and the hash.

/// `control_msgs::msg::dds_::GenericHardwareState_`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GenericHardwareState_ {
    /// One of [`generic_state`]'s `HEALTH_*`.
    pub health_status: u8,
    /// [`generic_state`]'s `ERROR_*` / `*_STOP_*` categories.
    pub error_domain: Vec<u8>,
    /// One of [`generic_state`]'s `MODE_*`.
    pub operational_mode: u8,
    /// One of [`generic_state`]'s `POWER_*`.
    pub power_state: u8,
    /// One of [`generic_state`]'s `CONNECT_*` / `CONNECTION_SLOW`.
    pub connectivity_status: u8,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub manufacturer: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub model: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub firmware_version: String,
    pub state_details: Vec<KeyValue_>,
}
keyless_topic_type!(GenericHardwareState_, "control_msgs::msg::dds_::GenericHardwareState_");

/// `control_msgs/msg/GenericHardwareState` constants (the ones handgate uses and their
/// neighbours; control_msgs 6.8.0).
pub mod generic_state {
    pub const HEALTH_UNKNOWN: u8 = 0;
    pub const HEALTH_OK: u8 = 1;
    pub const HEALTH_DEGRADED: u8 = 2;
    pub const HEALTH_WARNING: u8 = 3;
    pub const HEALTH_ERROR: u8 = 4;
    pub const HEALTH_FATAL: u8 = 5;

    pub const ERROR_NONE: u8 = 0;
    pub const ERROR_UNKNOWN: u8 = 1;
    pub const ERROR_HW: u8 = 2;
    pub const ERROR_SW: u8 = 3;
    pub const PROTECTIVE_STOP_SW: u8 = 8;

    pub const MODE_UNKNOWN: u8 = 0;
    pub const MODE_AUTO: u8 = 2;
    pub const MODE_SAFE: u8 = 3;

    pub const POWER_UNKNOWN: u8 = 0;

    pub const CONNECT_UNKNOWN: u8 = 0;
    pub const CONNECT_UP: u8 = 1;
    pub const CONNECT_DOWN: u8 = 2;
    pub const CONNECT_FAILURE: u8 = 3;
    pub const CONNECTION_SLOW: u8 = 4;
}

/// `control_msgs/msg/GenericHardwareState`.
pub static GENERIC_HARDWARE_STATE: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/GenericHardwareState",
    fields: &[
        Field::basic("health_status", ft::UINT8),
        Field::basic("error_domain", ft::UINT8 + ft::UNBOUNDED_SEQUENCE),
        Field::basic("operational_mode", ft::UINT8),
        Field::basic("power_state", ft::UINT8),
        Field::basic("connectivity_status", ft::UINT8),
        Field::basic("manufacturer", ft::STRING),
        Field::basic("model", ft::STRING),
        Field::basic("firmware_version", ft::STRING),
        Field::nested_sequence("state_details", &KEY_VALUE),
    ],
};
impl RosType for GenericHardwareState_ {
    const DESCRIPTION: &'static TypeDescription = &GENERIC_HARDWARE_STATE;
}

/// `control_msgs::msg::dds_::CANopenState_` (sent empty).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CANopenState_ {
    pub node_id: u8,
    pub nmt_state: u8,
    pub dsp_402_state: u8,
    pub last_emcy_code: u32,
}
keyless_topic_type!(CANopenState_, "control_msgs::msg::dds_::CANopenState_");

/// `control_msgs/msg/CANopenState`.
pub static CANOPEN_STATE: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/CANopenState",
    fields: &[
        Field::basic("node_id", ft::UINT8),
        Field::basic("nmt_state", ft::UINT8),
        Field::basic("dsp_402_state", ft::UINT8),
        Field::basic("last_emcy_code", ft::UINT32),
    ],
};
impl RosType for CANopenState_ {
    const DESCRIPTION: &'static TypeDescription = &CANOPEN_STATE;
}

/// `control_msgs::msg::dds_::EtherCATState_` (sent empty).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct EtherCATState_ {
    pub slave_position: u16,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub vendor_id: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub product_code: String,
    pub al_state: u8,
    pub has_error: bool,
    pub al_status_code: u16,
}
keyless_topic_type!(EtherCATState_, "control_msgs::msg::dds_::EtherCATState_");

/// `control_msgs/msg/EtherCATState`.
pub static ETHERCAT_STATE: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/EtherCATState",
    fields: &[
        Field::basic("slave_position", ft::UINT16),
        Field::basic("vendor_id", ft::STRING),
        Field::basic("product_code", ft::STRING),
        Field::basic("al_state", ft::UINT8),
        Field::basic("has_error", ft::BOOLEAN),
        Field::basic("al_status_code", ft::UINT16),
    ],
};
impl RosType for EtherCATState_ {
    const DESCRIPTION: &'static TypeDescription = &ETHERCAT_STATE;
}

/// `control_msgs::msg::dds_::VDA5050State_` (sent empty).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VDA5050State_ {
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub order_id: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub action_status: String,
    pub last_node_id: u32,
    pub driving: bool,
    pub battery_charge: f64,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub operating_mode: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub error_type: String,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub error_description: String,
}
keyless_topic_type!(VDA5050State_, "control_msgs::msg::dds_::VDA5050State_");

/// `control_msgs/msg/VDA5050State`.
pub static VDA5050_STATE: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/VDA5050State",
    fields: &[
        Field::basic("order_id", ft::STRING),
        Field::basic("action_status", ft::STRING),
        Field::basic("last_node_id", ft::UINT32),
        Field::basic("driving", ft::BOOLEAN),
        Field::basic("battery_charge", ft::DOUBLE),
        Field::basic("operating_mode", ft::STRING),
        Field::basic("error_type", ft::STRING),
        Field::basic("error_description", ft::STRING),
    ],
};
impl RosType for VDA5050State_ {
    const DESCRIPTION: &'static TypeDescription = &VDA5050_STATE;
}

/// `control_msgs::msg::dds_::HardwareDeviceStatus_`: one device of a hardware component.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HardwareDeviceStatus_ {
    pub header: Header_,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub device_id: String,
    pub hardware_status: Vec<GenericHardwareState_>,
    pub canopen_states: Vec<CANopenState_>,
    pub ethercat_states: Vec<EtherCATState_>,
    pub vda5050_states: Vec<VDA5050State_>,
}
keyless_topic_type!(HardwareDeviceStatus_, "control_msgs::msg::dds_::HardwareDeviceStatus_");

/// `control_msgs/msg/HardwareDeviceStatus`.
pub static HARDWARE_DEVICE_STATUS: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/HardwareDeviceStatus",
    fields: &[
        Field::nested("header", &HEADER),
        Field::basic("device_id", ft::STRING),
        Field::nested_sequence("hardware_status", &GENERIC_HARDWARE_STATE),
        Field::nested_sequence("canopen_states", &CANOPEN_STATE),
        Field::nested_sequence("ethercat_states", &ETHERCAT_STATE),
        Field::nested_sequence("vda5050_states", &VDA5050_STATE),
    ],
};
impl RosType for HardwareDeviceStatus_ {
    const DESCRIPTION: &'static TypeDescription = &HARDWARE_DEVICE_STATUS;
}

/// `control_msgs::msg::dds_::HardwareStatus_`: one hardware component and its devices.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HardwareStatus_ {
    pub header: Header_,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub hardware_id: String,
    pub hardware_device_states: Vec<HardwareDeviceStatus_>,
}
keyless_topic_type!(HardwareStatus_, "control_msgs::msg::dds_::HardwareStatus_");

/// `control_msgs/msg/HardwareStatus`: `std_msgs/Header header`, `string hardware_id`,
/// `HardwareDeviceStatus[] hardware_device_states`.
pub static HARDWARE_STATUS: TypeDescription = TypeDescription {
    type_name: "control_msgs/msg/HardwareStatus",
    fields: &[
        Field::nested("header", &HEADER),
        Field::basic("hardware_id", ft::STRING),
        Field::nested_sequence("hardware_device_states", &HARDWARE_DEVICE_STATUS),
    ],
};
impl RosType for HardwareStatus_ {
    const DESCRIPTION: &'static TypeDescription = &HARDWARE_STATUS;
}

/// The DDS topic of `hardware_status`, relative to handgate's namespace (`rt/<ns>/hardware_status`
/// once resolved): `ros2 control view_hardware_status` lists every topic whose name ends in
/// `/hardware_status` with type `control_msgs/msg/HardwareStatus`.
pub const HARDWARE_STATUS_TOPIC: &str = "rt/hardware_status";
