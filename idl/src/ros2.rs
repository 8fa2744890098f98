//! ROS 2 messages as they appear on DDS (rmw_cyclonedds): `sensor_msgs/msg/JointState` and its
//! dependencies, and `rmw_dds_common/msg/ParticipantEntitiesInfo` (the `ros_discovery_info`
//! graph message). ROS 2 prefixes topics with `rt/` and types with `::msg::dds_::` and a
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
