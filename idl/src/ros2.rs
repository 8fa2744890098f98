//! ROS 2 messages as they appear on DDS (rmw_cyclonedds): `sensor_msgs/msg/JointState`.
//! ROS 2 prefixes topics with `rt/` and types with `::msg::dds_::` and a trailing underscore.

use crate::keyless_topic_type;
use serde::{Deserialize, Serialize};

/// `builtin_interfaces::msg::dds_::Time_`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Time_ {
    pub sec: i32,
    pub nanosec: u32,
}
keyless_topic_type!(Time_, "builtin_interfaces::msg::dds_::Time_");

/// `std_msgs::msg::dds_::Header_`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header_ {
    pub stamp: Time_,
    #[serde(deserialize_with = "crate::cdr_codec::cdr_string::deserialize")]
    pub frame_id: String,
}
keyless_topic_type!(Header_, "std_msgs::msg::dds_::Header_");

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
