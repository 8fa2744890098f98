//! Dex3-1 over DDS, as a client of a G1's resident hand service: publishes
//! `unitree_hg::HandCmd_` (7 motors, IDL order) on `rt/dex3/{side}/cmd` with the RIS mode
//! byte set explicitly on every motor, reads `HandState_` from `rt/dex3/{side}/state` (or the
//! low-frequency copy `rt/lf/dex3/{side}/state`, by profile). docs/sources.md §2.

use handgate_idl::unitree_hg::{HandCmd_, HandState_};

use super::RisMode;
use crate::control::Active;
use crate::dds_device::DdsCodec;
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{faults, HandState, Imu, Pad, Power, Side};

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

/// Default (command, state) topics for a side, the state read from `source`.
pub fn topics(side: Side, source: StateSource) -> (String, String) {
    let state = match source {
        StateSource::State => super::state_topic(side),
        StateSource::Lf => super::lf_state_topic(side),
    };
    (super::cmd_topic(side), state)
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

/// Fills `msg` with the HandCmd_ for canonical targets: IDL order, the RIS mode byte on every
/// motor (its buffer reused).
pub fn encode_hand_cmd(
    table: &DeviceTable,
    targets: &[crate::model::JointCommand],
    timeout_bit: bool,
    msg: &mut HandCmd_,
) {
    msg.motor_cmd.clear();
    msg.motor_cmd.resize(table.wire_len(), WireTarget::LIMP.into());
    for (i, w) in table.wire_targets(targets) {
        msg.motor_cmd[i] = w.into();
    }
    for (i, m) in msg.motor_cmd.iter_mut().enumerate() {
        m.mode = RisMode::foc(i as u8, timeout_bit).encode();
    }
    msg.reserve = [0; 4];
}

/// Canonical state from a HandState_ into `st` (its buffers reused); `false` unless it has
/// all 7 motors.
pub fn decode_hand_state(s: &HandState_, table: &DeviceTable, st: &mut HandState) -> bool {
    if s.motor_state.len() < table.wire_len() {
        return false;
    }
    table.state_from_wire_into(&mut st.joints, |i| s.motor_state.get(i).map(|m| (m.q, m.dq, m.tau_est)));
    let mut fault_bits = 0;
    for (j, map) in st.joints.iter_mut().zip(&table.joints) {
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
    st.pads.resize_with(s.press_sensor_state.len(), Pad::default);
    for (i, (pad, p)) in st.pads.iter_mut().zip(&s.press_sensor_state).enumerate() {
        pad.set_dex3(i, p.pressure, p.temperature);
    }
    st.imu = Some(Imu {
        quaternion: s.imu_state.quaternion,
        gyroscope: s.imu_state.gyroscope,
        accelerometer: s.imu_state.accelerometer,
    });
    st.power = Some(Power {
        voltage: s.power_v,
        current: s.power_a,
    });
    st.faults = fault_bits;
    true
}

impl DdsCodec for Dex3DdsCodec {
    type Cmd = HandCmd_;
    type State = HandState_;
    const ENTRIES: Option<usize> = Some(super::MOTOR_COUNT);

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut HandCmd_) -> bool {
        match active {
            Active::Idle => false,
            Active::Command(t) | Active::Safe(_, t) => {
                encode_hand_cmd(table, t, self.timeout_bit, msg);
                true
            }
        }
    }

    fn decode_into(&mut self, sample: &HandState_, table: &DeviceTable, st: &mut HandState) -> bool {
        decode_hand_state(sample, table, st)
    }
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
        let mut msg = HandCmd_::default();
        encode_hand_cmd(&t, &targets, true, &mut msg);
        assert_eq!(msg.motor_cmd.len(), 7);
        for (i, m) in msg.motor_cmd.iter().enumerate() {
            assert_eq!(m.mode, 0x90 | i as u8);
        }
        assert_eq!(msg.motor_cmd[5].q, -1.0, "left index closes negative, IDL index 5");
    }
}
