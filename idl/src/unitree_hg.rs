//! `unitree_hg::msg::dds_` (humanoid: G1, H1-2): the Dex3-1 hand messages.
//! Layout as in unitree_sdk2 since Dec 2024 / Feb 2025 (docs/sources.md §1), not the older seed page.

use crate::keyless_topic_type;
use serde::{Deserialize, Serialize};

/// One motor command. `mode` packs the RIS mode byte for Dex3 (bits 0-3 id, 4-6 status,
/// bit 7 timeout). Note: ONE reserve word (the go variant has three).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorCmd_ {
    pub mode: u8,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub kp: f32,
    pub kd: f32,
    pub reserve: u32,
}
keyless_topic_type!(MotorCmd_, "unitree_hg::msg::dds_::MotorCmd_");

/// One motor's measured state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorState_ {
    pub mode: u8,
    pub q: f32,
    pub dq: f32,
    pub ddq: f32,
    pub tau_est: f32,
    pub temperature: [i16; 2],
    pub vol: f32,
    pub sensor: [u32; 2],
    pub motorstate: u32,
    pub reserve: [u32; 4],
}
keyless_topic_type!(MotorState_, "unitree_hg::msg::dds_::MotorState_");

/// One tactile pad: 12 taxels. Raw pressure 30000 = no reading; valid readings >= 100000.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PressSensorState_ {
    pub pressure: [f32; 12],
    pub temperature: [f32; 12],
    pub lost: u32,
    pub reserve: u32,
}
keyless_topic_type!(PressSensorState_, "unitree_hg::msg::dds_::PressSensorState_");

/// IMU block (quaternion w,x,y,z).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct IMUState_ {
    pub quaternion: [f32; 4],
    pub gyroscope: [f32; 3],
    pub accelerometer: [f32; 3],
    pub rpy: [f32; 3],
    pub temperature: i16,
}
keyless_topic_type!(IMUState_, "unitree_hg::msg::dds_::IMUState_");

/// Dex3-1 command: 7 motors in IDL order (thumb_0..2, middle_0..1, index_0..1).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HandCmd_ {
    pub motor_cmd: Vec<MotorCmd_>,
    pub reserve: [u32; 4],
}
keyless_topic_type!(HandCmd_, "unitree_hg::msg::dds_::HandCmd_");

/// Dex3-1 state.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HandState_ {
    pub motor_state: Vec<MotorState_>,
    pub press_sensor_state: Vec<PressSensorState_>,
    pub imu_state: IMUState_,
    pub power_v: f32,
    pub power_a: f32,
    pub system_v: f32,
    pub device_v: f32,
    pub error: [u32; 2],
    pub reserve: [u32; 2],
}
keyless_topic_type!(HandState_, "unitree_hg::msg::dds_::HandState_");

/// Number of motors in a Dex3-1.
pub const DEX3_MOTORS: usize = 7;
/// Number of pressure pads a Dex3-1 reports (the SDK C++ example sizes it so; the Python
/// default factory uses 7, see [`PYTHON_DEFAULT_PRESS_SENSORS`]).
pub const DEX3_PRESS_SENSORS: usize = 9;
/// Pads in unitree_sdk2py's default HandState_ factory.
pub const PYTHON_DEFAULT_PRESS_SENSORS: usize = 7;

impl HandCmd_ {
    /// What unitree_sdk2py's `unitree_hg_msg_dds__HandCmd_()` builds: 7 zeroed motors.
    pub fn sdk_default() -> Self {
        Self::with_motors(DEX3_MOTORS)
    }

    /// `n` zeroed motor commands, reserve zero (what the Python SDK's default factory builds
    /// for a sized command).
    pub fn with_motors(n: usize) -> Self {
        Self {
            motor_cmd: vec![MotorCmd_::default(); n],
            reserve: [0; 4],
        }
    }
}

impl HandState_ {
    /// What unitree_sdk2py's `unitree_hg_msg_dds__HandState_()` builds: 7 motors, 7 pads.
    pub fn sdk_default() -> Self {
        Self::with_sizes(DEX3_MOTORS, PYTHON_DEFAULT_PRESS_SENSORS)
    }

    /// `motors` zeroed motor states and `pads` zeroed pressure pads.
    pub fn with_sizes(motors: usize, pads: usize) -> Self {
        Self {
            motor_state: vec![MotorState_::default(); motors],
            press_sensor_state: vec![PressSensorState_::default(); pads],
            ..Self::default()
        }
    }
}
