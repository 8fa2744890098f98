//! Dex3-1 over DDS, as a client of a G1's resident hand service: publishes
//! `unitree_hg::HandCmd_` (7 motors, IDL order) on `rt/dex3/{side}/cmd` with the RIS mode
//! byte set explicitly on every motor, reads `HandState_` from `rt/dex3/{side}/state` (or the
//! low-frequency copy `rt/lf/dex3/{side}/state`, by profile). docs/sources.md §2.

use handgate_idl::unitree_hg::{HandCmd_, HandState_, MotorCmd_};

use super::RisMode;
use crate::control::Active;
use crate::dds_device::DdsCodec;
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, Imu, JointState, Pad, Power, SafeAction, Side};

/// Which state topic to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateSource {
    /// `rt/dex3/{side}/state` (xr_teleoperate, docs).
    #[default]
    State,
    /// `rt/lf/dex3/{side}/state` (the SDK's C++ and ROS 2 examples).
    Lf,
}

impl std::fmt::Display for StateSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StateSource::State => "state",
            StateSource::Lf => "lf",
        })
    }
}

/// Default topics for a side.
pub fn topics(side: Side, source: StateSource) -> (String, String) {
    let s = side.as_str();
    let state = match source {
        StateSource::State => format!("rt/dex3/{s}/state"),
        StateSource::Lf => format!("rt/lf/dex3/{s}/state"),
    };
    (format!("rt/dex3/{s}/cmd"), state)
}

/// Encoder/decoder for the resident service's messages.
#[derive(Debug, Clone)]
pub struct Dex3DdsCodec {
    /// Set the motors' timeout protection bit (motor stops after 1 s without commands).
    pub timeout_bit: bool,
}

impl Default for Dex3DdsCodec {
    fn default() -> Self {
        Self { timeout_bit: true }
    }
}

/// Builds the HandCmd_ for wire targets (IDL order).
pub fn encode_hand_cmd(table: &DeviceTable, targets: &[crate::model::JointCommand], timeout_bit: bool) -> HandCmd_ {
    let wire = table.to_wire(targets);
    let mut msg = HandCmd_::with_motors(wire.len());
    for (i, (m, w)) in msg.motor_cmd.iter_mut().zip(&wire).enumerate() {
        *m = MotorCmd_ {
            mode: RisMode::foc(i as u8, timeout_bit).encode(),
            ..MotorCmd_::from(*w)
        };
    }
    msg
}

/// Canonical state from a HandState_ (None unless it has all 7 motors).
pub fn decode_hand_state(s: &HandState_, table: &DeviceTable) -> Option<HandState> {
    if s.motor_state.len() < table.wire_len() {
        return None;
    }
    let q: Vec<f32> = s.motor_state.iter().map(|m| m.q).collect();
    let dq: Vec<f32> = s.motor_state.iter().map(|m| m.dq).collect();
    let tau: Vec<f32> = s.motor_state.iter().map(|m| m.tau_est).collect();
    let mut joints: Vec<JointState> = table.state_from_wire(&q, &dq, &tau);
    let mut fault_bits = 0;
    for (j, map) in joints.iter_mut().zip(&table.joints) {
        let m = &s.motor_state[map.wire_index];
        j.temperature = Some(m.temperature[0] as f32);
        if RisMode::decode(m.mode).timeout {
            fault_bits |= faults::MOTOR_TIMEOUT;
        }
        if m.motorstate != 0 {
            fault_bits |= faults::MOTOR_ERROR;
        }
    }
    if s.error.iter().any(|e| *e != 0) {
        fault_bits |= faults::HARDWARE;
    }
    let pads = s
        .press_sensor_state
        .iter()
        .enumerate()
        .map(|(i, p)| Pad::dex3(i, p.pressure, p.temperature))
        .collect();
    Some(HandState {
        joints,
        pads,
        imu: Some(Imu {
            quaternion: s.imu_state.quaternion,
            gyroscope: s.imu_state.gyroscope,
            accelerometer: s.imu_state.accelerometer,
        }),
        power: Some(Power {
            voltage: s.power_v,
            current: s.power_a,
        }),
        faults: fault_bits,
        ..Default::default()
    })
}

impl DdsCodec for Dex3DdsCodec {
    type Cmd = HandCmd_;
    type State = HandState_;

    fn encode(&mut self, active: &Active, table: &DeviceTable, _dt: f32) -> Option<HandCmd_> {
        match active {
            Active::Idle => None,
            Active::Command(t) | Active::Safe(_, t) => Some(encode_hand_cmd(table, t, self.timeout_bit)),
        }
    }

    fn decode(&mut self, sample: &HandState_, table: &DeviceTable) -> Option<HandState> {
        decode_hand_state(sample, table)
    }
}

/// For docs/tests: what a limp safe state sends (zero gains, FOC).
pub fn limp_targets(table: &DeviceTable) -> Vec<crate::model::JointCommand> {
    table.safe_targets(SafeAction::Limp, &[])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::JointCommand;

    #[test]
    fn encode_sets_mode_order_and_signs() {
        let t = crate::dex3::table::table(Side::Left);
        let mut targets = vec![JointCommand::hold(0.0, 1.5, 0.1); 7];
        let idx0 = t.joint_by_name("index_0").unwrap();
        targets[idx0.index()].q = 1.0;
        let msg = encode_hand_cmd(&t, &targets, true);
        assert_eq!(msg.motor_cmd.len(), 7);
        for (i, m) in msg.motor_cmd.iter().enumerate() {
            assert_eq!(m.mode, 0x90 | i as u8);
        }
        assert_eq!(msg.motor_cmd[5].q, -1.0, "left index closes negative, IDL index 5");
    }
}
