//! The Dex5-1 over DDS, as a client of the robot's hand service (docs/sources.md §7 "Dex5-1"):
//! publishes unitree_hg `HandCmd_` on `rt/dex5/{side}/cmd`, reads `HandState_` from
//! `rt/dex5/{side}/state` ([`super::topics`]).
//!
//! Command: as xr_teleoperate's controller builds it, one entry per joint in wire order
//! ([`super::table::CommandLayout::Joints`], 20 entries; `Motors`: 16, one per motor, its
//! driving joint's target), every entry's mode byte [`MODE_ENABLED`], q / dq / tau through the
//! table (sign), kp / kd the canonical relative gains times the profile's gains
//! ([`WireConfig`]). A coupled
//! `Pitch_x4` entry carries its own canonical target unchanged: what the service does with
//! the two entries of one motor is not public, so handgate passes on what it was given. A
//! "limp" safe state is zero gains and torque (the PD law then applies nothing). Nothing is
//! sent before the first command, so the robot's own use of the hand is not overridden at
//! start-up.
//!
//! State: exactly 20 entries, else the sample is not this hand's (a Dex3-1 answers with 7) and
//! is dropped. q, dq, tau_est per entry through the table; the hotter of an entry's two
//! temperatures; a non-zero `motorstate` → fault `MOTOR_ERROR`, a non-zero `error` word →
//! `HARDWARE`; pressure pads passed on raw (`pad_i`, 12 taxels each: no source says how many a
//! Dex5 reports or what they read), IMU and supply as the message carries them.

use handgate_idl::unitree_hg::{HandCmd_, HandState_, MotorCmd_};

use super::table::WireConfig;
use super::{MODE_ENABLED, WIRE_LEN};
use crate::control::Active;
use crate::dds_device::DdsCodec;
use crate::mapping::DeviceTable;
use crate::model::{faults, HandState, Imu, JointCommand, Pad, Power};

/// Codec of one Dex5-1 hand.
#[derive(Debug, Clone, PartialEq)]
pub struct Dex5Codec {
    /// What a canonical gain of 1.0 becomes on each entry, and the command layout.
    pub wire: WireConfig,
}

impl Dex5Codec {
    pub fn new(wire: WireConfig) -> Self {
        Self { wire }
    }
}

impl Default for Dex5Codec {
    /// xr_teleoperate's gains and layout.
    fn default() -> Self {
        Self::new(WireConfig::default())
    }
}

/// Fills `msg` (its buffer reused) with the command for canonical `targets` (canonical order).
pub fn encode_hand_cmd(table: &DeviceTable, targets: &[JointCommand], wire: &WireConfig, msg: &mut HandCmd_) {
    let layout = wire.layout;
    let off = MotorCmd_ {
        mode: MODE_ENABLED,
        ..Default::default()
    };
    msg.motor_cmd.clear();
    msg.motor_cmd.resize(layout.entries(), off);
    for (i, w) in table.wire_targets(targets) {
        let e = layout.entry(i);
        if layout.joint(e) != Some(i) {
            continue; // a coupled joint in the motor layout: its motor's entry is its driver's
        }
        let (kp, kd) = wire.gains.to_wire(i, w.kp, w.kd);
        msg.motor_cmd[e] = MotorCmd_ {
            mode: MODE_ENABLED,
            q: w.q,
            dq: w.dq,
            tau: w.tau,
            kp,
            kd,
            reserve: 0,
        };
    }
    msg.reserve = [0; 4];
}

/// Canonical state from a `HandState_` into `st` (its buffers reused); `false` unless it has
/// exactly 20 entries.
pub fn decode_hand_state(s: &HandState_, table: &DeviceTable, st: &mut HandState) -> bool {
    if s.motor_state.len() != WIRE_LEN {
        return false;
    }
    table.state_from_wire_into(&mut st.joints, |i| s.motor_state.get(i).map(|m| (m.q, m.dq, m.tau_est)));
    let mut bits = 0;
    for (j, m) in st.joints.iter_mut().zip(&s.motor_state) {
        j.temperature = Some(f32::from(m.temperature[0].max(m.temperature[1])));
        if m.motorstate != 0 {
            bits |= faults::MOTOR_ERROR;
        }
    }
    if s.error.iter().any(|e| *e != 0) {
        bits |= faults::HARDWARE;
    }
    st.faults = bits;
    st.pads.resize_with(s.press_sensor_state.len(), Pad::default);
    for (i, (pad, p)) in st.pads.iter_mut().zip(&s.press_sensor_state).enumerate() {
        pad.set_dex3(i, p.pressure, p.temperature);
    }
    let imu = &s.imu_state;
    st.imu = Some(Imu {
        quaternion: imu.quaternion,
        gyroscope: imu.gyroscope,
        accelerometer: imu.accelerometer,
    });
    st.power = Some(Power {
        voltage: s.power_v,
        current: s.power_a,
    });
    true
}

impl DdsCodec for Dex5Codec {
    type Cmd = HandCmd_;
    type State = HandState_;
    /// 20 entries per message (a Dex3-1's are 7).
    const ENTRIES: Option<usize> = Some(WIRE_LEN);

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut HandCmd_) -> bool {
        let (Active::Command(t) | Active::Safe(_, t)) = active else {
            return false; // nothing commanded yet: silent
        };
        encode_hand_cmd(table, t, &self.wire, msg);
        true
    }

    fn decode_into(&mut self, sample: &HandState_, table: &DeviceTable, st: &mut HandState) -> bool {
        decode_hand_state(sample, table, st)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex5::table::tests::t;
    use crate::dex5::table::{CommandLayout, Conventions, GainSource};
    use crate::model::{SafeAction, Side};
    use handgate_idl::unitree_hg::{MotorState_, PressSensorState_};

    fn closed(side: Side) -> (DeviceTable, Vec<JointCommand>) {
        let tb = t(side);
        let targets = tb.closure_targets(1.0, None).unwrap();
        (tb, targets)
    }

    #[test]
    fn joints_layout_is_twenty_entries_in_wire_order_with_the_profiles_gains() {
        let (tb, targets) = closed(Side::Left);
        let mut msg = HandCmd_::default();
        encode_hand_cmd(&tb, &targets, &WireConfig::default(), &mut msg);
        assert_eq!(msg.motor_cmd.len(), 20);
        assert!(msg.motor_cmd.iter().all(|m| m.mode == 0x01));
        assert!(msg.motor_cmd[17].q < -0.5, "the left thumb roll closes negative");
        assert!((msg.motor_cmd[2].q - 0.9 * 1.6842).abs() < 1e-4, "index Pitch_23");
        assert!((msg.motor_cmd[3].q - 0.9 * 1.3963).abs() < 1e-4, "its coupled Pitch_24");
        assert_eq!((msg.motor_cmd[5].kp, msg.motor_cmd[5].kd), (0.10, 0.001));
        assert_eq!((msg.motor_cmd[18].kp, msg.motor_cmd[18].kd), (1.0, 0.02));
        assert_eq!(msg.reserve, [0; 4]);
        let limp = tb.safe_targets(SafeAction::Limp, &[]);
        encode_hand_cmd(&tb, &limp, &WireConfig::default(), &mut msg);
        assert!(msg
            .motor_cmd
            .iter()
            .all(|m| m.mode == 0x01 && m.kp == 0.0 && m.kd == 0.0 && m.tau == 0.0));
    }

    #[test]
    fn motors_layout_is_sixteen_entries_thumb_first_from_the_driving_joints() {
        let (tb, mut targets) = closed(Side::Right);
        targets[3].q = 0.2; // a coupled Pitch_24 the motor layout cannot carry
        let wire = WireConfig::of(&Conventions {
            gains: GainSource::UnitreeDdsWrapper,
            command_layout: CommandLayout::Motors,
            ..Default::default()
        });
        let mut msg = HandCmd_::default();
        encode_hand_cmd(&tb, &targets, &wire, &mut msg);
        assert_eq!(msg.motor_cmd.len(), 16);
        assert_eq!(msg.motor_cmd[0].q, 0.0, "motor 0: thumb yaw");
        assert_eq!((msg.motor_cmd[0].kp, msg.motor_cmd[0].kd), (10.0, 0.9));
        assert!(
            (msg.motor_cmd[1].q - 0.9).abs() < 1e-6,
            "motor 1: right thumb roll, positive"
        );
        assert!(
            (msg.motor_cmd[6].q - 0.9 * 1.6842).abs() < 1e-4,
            "motor 6: index Pitch_23, not Pitch_24"
        );
        assert_eq!((msg.motor_cmd[6].kp, msg.motor_cmd[6].kd), (0.02, 0.0004));
    }

    #[test]
    fn the_codec_is_silent_until_commanded_and_reuses_its_buffers() {
        let (tb, targets) = closed(Side::Right);
        let mut codec = Dex5Codec::default();
        let mut msg = HandCmd_::default();
        assert!(!codec.encode_into(&Active::Idle, &tb, 0.002, &mut msg));
        assert!(codec.encode_into(&Active::Command(targets.clone()), &tb, 0.002, &mut msg));
        let (ptr, cap) = (msg.motor_cmd.as_ptr(), msg.motor_cmd.capacity());
        assert!(codec.encode_into(&Active::Safe(SafeAction::Hold, targets), &tb, 0.002, &mut msg));
        assert_eq!((msg.motor_cmd.as_ptr(), msg.motor_cmd.capacity()), (ptr, cap));

        let sample = HandState_::with_sizes(20, 2);
        let mut st = HandState::default();
        assert!(codec.decode_into(&sample, &tb, &mut st));
        let (jp, pp) = (st.joints.as_ptr(), st.pads.as_ptr());
        assert!(codec.decode_into(&sample, &tb, &mut st));
        assert_eq!((st.joints.as_ptr(), st.pads.as_ptr()), (jp, pp));
    }

    #[test]
    fn state_of_twenty_entries_decodes_and_a_dex3_sized_one_does_not() {
        let tb = t(Side::Left);
        let mut st = HandState::default();
        assert!(!decode_hand_state(&HandState_::with_sizes(7, 9), &tb, &mut st));
        assert!(!decode_hand_state(&HandState_::with_sizes(21, 0), &tb, &mut st));

        let mut s = HandState_::with_sizes(20, 1);
        s.motor_state[17] = MotorState_ {
            q: -0.5,
            dq: -1.0,
            tau_est: -0.2,
            temperature: [31, 36],
            ..Default::default()
        };
        s.motor_state[9].motorstate = 0x10;
        s.press_sensor_state[0] = PressSensorState_ {
            pressure: [7.0; 12],
            ..Default::default()
        };
        s.power_v = 24.5;
        assert!(decode_hand_state(&s, &tb, &mut st));
        assert_eq!(st.joints.len(), 20);
        let roll = st.joints[17];
        assert_eq!(
            (roll.q, roll.dq, roll.tau),
            (0.5, 1.0, 0.2),
            "left thumb roll: canonical = −wire"
        );
        assert_eq!(roll.temperature, Some(36.0), "the hotter of the two");
        assert_eq!(st.faults, faults::MOTOR_ERROR);
        assert_eq!((st.pads.len(), st.pads[0].pressure[3]), (1, 7.0));
        assert_eq!(st.power.unwrap().voltage, 24.5);
        s.error[0] = 1;
        assert!(decode_hand_state(&s, &tb, &mut st));
        assert_eq!(st.faults, faults::MOTOR_ERROR | faults::HARDWARE);
    }
}
