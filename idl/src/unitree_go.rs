//! `unitree_go::msg::dds_` motor messages, used by Dex1-1 (`rt/dex1/{side}/*`), the SAKE
//! EZGripper driver, the old `rt/unitree_actuator` topics and the G1's `rt/hand_sdk`.

use crate::keyless_topic_type;
use serde::{Deserialize, Serialize};

/// One motor command. Note: THREE reserve words (the hg variant has one).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorCmd_ {
    pub mode: u8,
    pub q: f32,
    pub dq: f32,
    pub tau: f32,
    pub kp: f32,
    pub kd: f32,
    pub reserve: [u32; 3],
}
keyless_topic_type!(MotorCmd_, "unitree_go::msg::dds_::MotorCmd_");

/// A sequence of motor commands.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorCmds_ {
    pub cmds: Vec<MotorCmd_>,
}
keyless_topic_type!(MotorCmds_, "unitree_go::msg::dds_::MotorCmds_");

/// One motor's state.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorState_ {
    pub mode: u8,
    pub q: f32,
    pub dq: f32,
    pub ddq: f32,
    pub tau_est: f32,
    pub q_raw: f32,
    pub dq_raw: f32,
    pub ddq_raw: f32,
    pub temperature: u8,
    pub lost: u32,
    pub reserve: [u32; 2],
}
keyless_topic_type!(MotorState_, "unitree_go::msg::dds_::MotorState_");

/// A sequence of motor states.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MotorStates_ {
    pub states: Vec<MotorState_>,
}
keyless_topic_type!(MotorStates_, "unitree_go::msg::dds_::MotorStates_");

impl MotorCmds_ {
    /// `n` zeroed commands.
    pub fn with_len(n: usize) -> Self {
        Self {
            cmds: vec![MotorCmd_::default(); n],
        }
    }
}

impl MotorStates_ {
    /// `n` zeroed states.
    pub fn with_len(n: usize) -> Self {
        Self {
            states: vec![MotorState_::default(); n],
        }
    }
}
