//! The Dex3 service front: `unitree_hg::HandCmd_` in on `rt/dex3/{side}/cmd`, `HandState_`
//! out on `rt/dex3/{side}/state` and `rt/lf/dex3/{side}/state`, exactly as a G1's resident
//! service, so a unitree_sdk2 program written for a G1's hand works unchanged.
//!
//! Command rules: exactly 7 entries (IDL order); every value finite; RIS mode byte per entry:
//! id must equal the entry index, status 1 (FOC) follows q/dq/tau/kp/kd, status 0 (lock)
//! holds the joint where it is measured, any other status rejects the message; a mode byte
//! of 0 past the first entry (the SDK's default, left unset) rejects it as `mode_unset`, whose
//! fix (`mode = id | 0x10`) the log gives once per client; bit 7
//! (timeout protection) is honoured by the front's watchdog (at most 1 s).
//! State extras (handgate's use of reserved fields): `reserve[0]` echoes the tag a client put
//! in `HandCmd_.reserve[0]` of the last applied command; `reserve[1]` is the freshness
//! (0 fresh, 1 stale, 2 commanded only); `error[1]` bit 0 is set while the state is stale.

use crate::dex3::{MotorStatus, RisMode, PRESS_NO_READING};
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{faults, Freshness, HandState, JointCommand, JointState};
use handgate_idl::unitree_hg::{HandCmd_, HandState_, IMUState_, MotorState_, PressSensorState_, DEX3_PRESS_SENSORS};

use crate::front::{checked_target, FrontCommand, Rejection};

/// Decodes a HandCmd_ for a Dex3 front whose table is `front` (its side). `measured` is the
/// bound device's state in the front's canonical order (for "lock" = hold where measured).
pub fn decode_cmd(msg: &HandCmd_, front: &DeviceTable, measured: &[JointState]) -> Result<FrontCommand, Rejection> {
    let want = front.wire_len();
    if msg.motor_cmd.len() != want {
        return Err(Rejection::WrongCount {
            got: msg.motor_cmd.len(),
            want,
        });
    }
    if let Some(r) = mode_unset(msg) {
        return Err(r);
    }
    let mut timeout_bit = false;
    for (i, m) in msg.motor_cmd.iter().enumerate() {
        checked_target(i, [m.q, m.dq, m.tau, m.kp, m.kd])?;
        let mode = RisMode::decode(m.mode);
        if mode.id as usize != i {
            return Err(Rejection::WrongId { index: i, id: mode.id });
        }
        if let MotorStatus::Undefined(status) = mode.status {
            return Err(Rejection::UnknownStatus { index: i, status });
        }
        timeout_bit |= mode.timeout;
    }
    let joints = front
        .joints
        .iter()
        .enumerate()
        .map(|(ci, j)| {
            let m = &msg.motor_cmd[j.wire_index];
            if RisMode::decode(m.mode).status == MotorStatus::Lock {
                let q = measured.get(ci).map(|s| s.q).filter(|q| q.is_finite()).unwrap_or(0.0);
                Some(JointCommand::hold(q, front.hold_kp, front.hold_kd))
            } else {
                Some(j.from_wire(&WireTarget {
                    q: m.q,
                    dq: m.dq,
                    tau: m.tau,
                    kp: m.kp,
                    kd: m.kd,
                }))
            }
        })
        .collect();
    Ok(FrontCommand {
        joints,
        timeout_bit,
        tag: msg.reserve[0],
    })
}

/// A client's HandCmd_ sample (its bytes after the encapsulation header, either byte order)
/// that this front rejects for a mistake the client repeats on every message: the rejection,
/// whose `fix` says what to change (`handgate doctor` runs it on what clients write). Only the mode
/// byte is checked: a sample in another layout is the layout check's business.
pub fn sample_mistake(body: &[u8]) -> Option<Rejection> {
    handgate_idl::from_cdr_body::<HandCmd_>(body)
        .next()
        .and_then(|msg| mode_unset(&msg))
}

/// The first entry past the first whose mode byte is 0 (the SDK's default, never set): the
/// rejection [`decode_cmd`] gives for it.
fn mode_unset(msg: &HandCmd_) -> Option<Rejection> {
    msg.motor_cmd
        .iter()
        .enumerate()
        .skip(1)
        .find(|(_, m)| m.mode == 0)
        .map(|(index, _)| Rejection::ModeUnset { index })
}

fn freshness_code(f: Freshness) -> u32 {
    match f {
        Freshness::Fresh => 0,
        Freshness::Stale => 1,
        Freshness::CommandedOnly => 2,
    }
}

/// Encodes the device state (joints already routed into the front's canonical order) as a
/// HandState_ in the front side's wire convention.
pub fn encode_state(front: &DeviceTable, joints: &[JointState], st: &HandState) -> HandState_ {
    let mut out = HandState_::with_sizes(front.wire_len(), 0);
    let wire = front.state_to_wire(joints);
    let timeout = st.faults & faults::MOTOR_TIMEOUT != 0;
    for (j, map) in front.joints.iter().enumerate() {
        let w = wire[map.wire_index];
        let t = joints
            .get(j)
            .and_then(|s| s.temperature)
            .unwrap_or(0.0)
            .round()
            .clamp(-32768.0, 32767.0) as i16;
        out.motor_state[map.wire_index] = MotorState_ {
            mode: RisMode::foc(map.wire_index as u8, timeout).encode(),
            q: w.0,
            dq: w.1,
            ddq: 0.0,
            tau_est: w.2,
            temperature: [t, t],
            vol: st.power.map(|p| p.voltage).unwrap_or(0.0),
            sensor: [0; 2],
            motorstate: u32::from(st.faults & faults::MOTOR_ERROR != 0),
            reserve: [0; 4],
        };
    }
    let mut pads: Vec<PressSensorState_> = st
        .pads
        .iter()
        .take(DEX3_PRESS_SENSORS)
        .map(|p| PressSensorState_ {
            pressure: crate::model::Pad::fixed(&p.pressure, PRESS_NO_READING),
            temperature: crate::model::Pad::fixed(&p.temperature, 0.0),
            lost: 0,
            reserve: 0,
        })
        .collect();
    while pads.len() < DEX3_PRESS_SENSORS {
        pads.push(PressSensorState_ {
            pressure: [PRESS_NO_READING; 12],
            ..Default::default()
        });
    }
    out.press_sensor_state = pads;
    if let Some(imu) = st.imu {
        out.imu_state = IMUState_ {
            quaternion: imu.quaternion,
            gyroscope: imu.gyroscope,
            accelerometer: imu.accelerometer,
            rpy: [0.0; 3],
            temperature: 0,
        };
    }
    if let Some(p) = st.power {
        out.power_v = p.voltage;
        out.power_a = p.current;
    }
    out.error = [
        st.faults & !faults::SAFE_STATE,
        u32::from(st.freshness == Freshness::Stale),
    ];
    out.reserve = [st.cmd_tag, freshness_code(st.freshness)];
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, Side};
    use handgate_idl::unitree_hg::MotorCmd_;

    fn left() -> DeviceTable {
        DeviceKind::Dex3.table(Side::Left, &TableOverrides::default()).unwrap()
    }

    fn cmd() -> HandCmd_ {
        let mut c = HandCmd_::sdk_default();
        for (i, m) in c.motor_cmd.iter_mut().enumerate() {
            *m = MotorCmd_ {
                mode: 0x10 | i as u8,
                q: 0.0,
                kp: 1.5,
                kd: 0.1,
                ..Default::default()
            };
        }
        c
    }

    #[test]
    fn decodes_a_valid_command_into_canonical_order_and_sign() {
        let mut c = cmd();
        c.motor_cmd[5].q = -1.0; // left index_0 closing
        c.reserve[0] = 77;
        let d = decode_cmd(&c, &left(), &[]).unwrap();
        let t = left();
        let idx = t.joint_by_name("index_0").unwrap().index();
        assert!((d.joints[idx].unwrap().q - 1.0).abs() < 1e-6);
        assert_eq!(d.tag, 77);
        assert!(!d.timeout_bit);
    }

    #[test]
    fn rejects_bad_messages_whole() {
        let t = left();
        let mut short = cmd();
        short.motor_cmd.pop();
        assert_eq!(
            decode_cmd(&short, &t, &[]),
            Err(Rejection::WrongCount { got: 6, want: 7 })
        );
        let mut nan = cmd();
        nan.motor_cmd[2].kd = f32::NAN;
        assert_eq!(decode_cmd(&nan, &t, &[]), Err(Rejection::NonFinite(2)));
        let mut id = cmd();
        id.motor_cmd[3].mode = 0x10 | 4;
        assert_eq!(decode_cmd(&id, &t, &[]), Err(Rejection::WrongId { index: 3, id: 4 }));
        // The SDK's default mode byte, never set (issue #37): the lock status is the reason,
        // not the motor id, and the fix is said.
        let mut unset = cmd();
        for m in &mut unset.motor_cmd {
            m.mode = 0;
        }
        let r = decode_cmd(&unset, &t, &[]).unwrap_err();
        assert_eq!(r, Rejection::ModeUnset { index: 1 });
        assert!(r.to_string().contains("status 0 (lock)") && r.once_per_client(), "{r}");
        assert!(r.fix().unwrap().contains("id | 0x10"));
        let body = handgate_idl::cdr_codec::to_cdr_be(&unset).unwrap();
        assert_eq!(sample_mistake(&body[4..]), Some(Rejection::ModeUnset { index: 1 }));
        assert_eq!(
            sample_mistake(&handgate_idl::cdr_codec::to_cdr_le(&cmd()).unwrap()[4..]),
            None
        );
        // A lock on motor 0 alone is a valid command.
        let mut lock0 = cmd();
        lock0.motor_cmd[0].mode = 0;
        assert!(decode_cmd(&lock0, &t, &[]).is_ok());
        let mut st = cmd();
        st.motor_cmd[1].mode = 0x60 | 1;
        assert_eq!(
            decode_cmd(&st, &t, &[]),
            Err(Rejection::UnknownStatus { index: 1, status: 6 })
        );
    }

    #[test]
    fn lock_status_holds_where_measured_and_timeout_bit_is_reported() {
        let t = left();
        let mut c = cmd();
        c.motor_cmd[0].mode = 0x80; // id 0, lock, timeout
        c.motor_cmd[0].q = 0.9;
        let measured = vec![
            JointState {
                q: 0.25,
                ..Default::default()
            };
            7
        ];
        let d = decode_cmd(&c, &t, &measured).unwrap();
        assert_eq!(d.joints[0].unwrap().q, 0.25);
        assert!(d.timeout_bit);
    }

    #[test]
    fn state_has_seven_motors_nine_pads_and_wire_signs() {
        let t = left();
        let mut joints = vec![JointState::default(); 7];
        joints[t.joint_by_name("middle_0").unwrap().index()].q = 1.0;
        let st = HandState {
            cmd_tag: 9,
            freshness: Freshness::Stale,
            ..Default::default()
        };
        let out = encode_state(&t, &joints, &st);
        assert_eq!(out.motor_state.len(), 7);
        assert_eq!(out.press_sensor_state.len(), 9);
        assert_eq!(out.motor_state[3].q, -1.0, "left middle_0 closed = negative, IDL 3");
        assert_eq!(out.motor_state[3].mode, 0x13);
        assert_eq!(out.reserve, [9, 1]);
        assert_eq!(out.error[1], 1);
    }
}
