//! The Dex5 service front's pure codec: what the robot's Dex5-1 service serves on
//! `rt/dex5/{side}/*` (docs/sources.md §7 "Dex5-1", topics [`super::topics`]), so an
//! unmodified Dex5 client (xr_teleoperate's `Dex5_1_Controller`, a unitree_dds_wrapper or
//! unitree_sdk2 program) drives whatever device is bound: a Dex5 joint for joint, any other
//! kind through closure (`route::Route`: the client's posture → its closure through this
//! table's closure map → the device's posture at that closure; the device's closure back as
//! this table's posture).
//!
//! Command rules (docs/fronts.md "Bad input"): exactly the layout's entry count (20, one per
//! joint; 16 with [`CommandLayout::Motors`]), else rejected whole; a non-finite value in any of
//! an entry's five fields rejects the message; mode byte 1 (enabled) follows q / dq / tau /
//! kp / kd, 0 (disabled) makes that joint limp (zero gains and torque), any other value
//! rejects the message. q through the table (sign); the client's gains become the canonical
//! relative gains divided by the front's ([`WireConfig`]: xr_teleoperate's gains read 1.0). In
//! the motor layout a coupled `Pitch_x4` follows its motor's entry through the coupling.
//! `reserve[0]` is the client's tag.
//!
//! State: 20 entries in wire order, mode 1, q / dq / tau_est through the table (a value never
//! measured reads 0: xr_teleoperate waits for a non-zero state and a NaN would pass that
//! test), the joint's temperature in both of an entry's temperatures, the device's pads raw,
//! IMU and supply. handgate's use of reserved fields, as the Dex3 front's: `reserve[0]` echoes
//! the tag of the applied command, `reserve[1]` is the freshness (0 fresh, 1 stale,
//! 2 commanded only) and `error[1]` is 1 while the state is stale.

use handgate_idl::unitree_hg::{HandCmd_, HandState_, IMUState_, MotorState_, PressSensorState_};

use super::table::{is_coupled, CommandLayout, WireConfig};
use super::{MODE_DISABLED, MODE_ENABLED, WIRE_LEN};
use crate::front::{checked_target, FrontCommand, Rejection};
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{faults, Freshness, HandState, JointCommand, JointState, Pad};

/// Decodes a client's `HandCmd_` for a Dex5 front whose table is `front`, its gains, layout
/// and coupling `wire`.
pub fn decode_cmd(msg: &HandCmd_, front: &DeviceTable, wire: &WireConfig) -> Result<FrontCommand, Rejection> {
    let layout = wire.layout;
    let want = layout.entries();
    if msg.motor_cmd.len() != want {
        return Err(Rejection::WrongCount {
            got: msg.motor_cmd.len(),
            want,
        });
    }
    for (e, m) in msg.motor_cmd.iter().enumerate() {
        checked_target(e, [m.q, m.dq, m.tau, m.kp, m.kd])?;
        if m.mode != MODE_ENABLED && m.mode != MODE_DISABLED {
            return Err(Rejection::UnknownStatus {
                index: e,
                status: m.mode,
            });
        }
    }
    let joints = front
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let m = &msg.motor_cmd[layout.entry(i)];
            if m.mode == MODE_DISABLED {
                return Some(JointCommand::default());
            }
            let mut c = j.from_wire(&WireTarget {
                q: m.q,
                dq: m.dq,
                tau: m.tau,
                kp: m.kp,
                kd: m.kd,
            });
            if layout == CommandLayout::Motors && is_coupled(i) {
                (c.q, c.dq) = (wire.coupled(c.q), wire.coupled(c.dq));
            }
            (c.kp, c.kd) = wire.gains.from_wire(i, m.kp, m.kd);
            Some(c)
        })
        .collect();
    Ok(FrontCommand {
        joints,
        timeout_bit: false,
        tag: msg.reserve[0],
    })
}

/// The state message for the routed canonical state `joints` (front canonical order) of `st`
/// into `out`, its buffers reused.
pub fn encode_state_into(front: &DeviceTable, joints: &[JointState], st: &HandState, out: &mut HandState_) {
    let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
    let vol = st.power.map_or(0.0, |p| p.voltage);
    let motorstate = u32::from(st.faults & faults::MOTOR_ERROR != 0);
    out.motor_state.clear();
    out.motor_state.resize(WIRE_LEN, MotorState_::default());
    for (j, s) in front.joints.iter().zip(joints) {
        let Some(m) = out.motor_state.get_mut(j.wire_index) else {
            continue;
        };
        let t = s.temperature.map_or(0.0, |t| t.round().clamp(-32768.0, 32767.0)) as i16;
        *m = MotorState_ {
            mode: MODE_ENABLED,
            q: finite(j.q_to_wire(s.q)),
            dq: finite(j.rate_to_wire(s.dq)),
            tau_est: finite(j.tau_to_wire(s.tau)),
            temperature: [t, t],
            vol,
            motorstate,
            ..Default::default()
        };
    }
    out.press_sensor_state.clear();
    out.press_sensor_state.extend(st.pads.iter().map(|p| PressSensorState_ {
        pressure: Pad::fixed(&p.pressure, 0.0),
        temperature: Pad::fixed(&p.temperature, 0.0),
        ..Default::default()
    }));
    out.imu_state = match st.imu {
        Some(imu) => IMUState_ {
            quaternion: imu.quaternion,
            gyroscope: imu.gyroscope,
            accelerometer: imu.accelerometer,
            ..Default::default()
        },
        None => IMUState_::default(),
    };
    (out.power_v, out.power_a) = st.power.map_or((0.0, 0.0), |p| (p.voltage, p.current));
    (out.system_v, out.device_v) = (0.0, 0.0);
    let stale = st.freshness == Freshness::Stale;
    out.error = [st.faults & !faults::SAFE_STATE, u32::from(stale)];
    let freshness = match st.freshness {
        Freshness::Fresh => 0,
        Freshness::Stale => 1,
        Freshness::CommandedOnly => 2,
    };
    out.reserve = [st.cmd_tag, freshness];
}

/// [`encode_state_into`] a new message.
pub fn encode_state(front: &DeviceTable, joints: &[JointState], st: &HandState) -> HandState_ {
    let mut out = HandState_::default();
    encode_state_into(front, joints, st, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex5::adapter::encode_hand_cmd;
    use crate::dex5::table::tests::t;
    use crate::dex5::table::{closed_posture, Conventions, GainSource, Gains, COUPLING, LIMITS};
    use crate::mapping::TableOverrides;
    use crate::model::{CommandBody, DeviceKind, Side};
    use crate::route::{Pairing, Route};
    use handgate_idl::unitree_hg::MotorCmd_;
    use std::sync::Arc;

    /// A command as xr_teleoperate's `Dex5_1_Controller` builds it, serialised by the official
    /// Python SDK (unitree_sdk2py 1.0.1 on CycloneDDS Python 0.10.2): left hand, 20 entries,
    /// mode 0x01, kp / kd 0.10 / 0.001 on entries 0..15 and 1.0 / 0.02 on 16..19; q of each long
    /// finger (0.1, 1.5, 1.6, 1.3), of the thumb (0.2, −1.0, 1.2, 1.0).
    const XR_LEFT_CMD: [&str; 13] = [
        "000100001400000001000000cdcccc3d0000000000000000cdcccc3d6f12833a00000000010000000000c03f00000000",
        "00000000cdcccc3d6f12833a0000000001000000cdcccc3f0000000000000000cdcccc3d6f12833a0000000001000000",
        "6666a63f0000000000000000cdcccc3d6f12833a0000000001000000cdcccc3d0000000000000000cdcccc3d6f12833a",
        "00000000010000000000c03f0000000000000000cdcccc3d6f12833a0000000001000000cdcccc3f0000000000000000",
        "cdcccc3d6f12833a00000000010000006666a63f0000000000000000cdcccc3d6f12833a0000000001000000cdcccc3d",
        "0000000000000000cdcccc3d6f12833a00000000010000000000c03f0000000000000000cdcccc3d6f12833a00000000",
        "01000000cdcccc3f0000000000000000cdcccc3d6f12833a00000000010000006666a63f0000000000000000cdcccc3d",
        "6f12833a0000000001000000cdcccc3d0000000000000000cdcccc3d6f12833a00000000010000000000c03f00000000",
        "00000000cdcccc3d6f12833a0000000001000000cdcccc3f0000000000000000cdcccc3d6f12833a0000000001000000",
        "6666a63f0000000000000000cdcccc3d6f12833a0000000001000000cdcc4c3e00000000000000000000803f0ad7a33c",
        "0000000001000000000080bf00000000000000000000803f0ad7a33c00000000010000009a99993f0000000000000000",
        "0000803f0ad7a33c00000000010000000000803f00000000000000000000803f0ad7a33c000000000000000000000000",
        "0000000000000000",
    ];

    fn xr_left_cmd() -> (Vec<u8>, HandCmd_) {
        let hex = XR_LEFT_CMD.concat();
        let bytes: Vec<u8> = (0..hex.len())
            .step_by(2)
            .map(|k| u8::from_str_radix(&hex[k..k + 2], 16).unwrap())
            .collect();
        let msg = handgate_idl::from_cdr(&bytes).unwrap();
        (bytes, msg)
    }

    fn cmd(q: &[f32], gains: &Gains) -> HandCmd_ {
        HandCmd_ {
            motor_cmd: q
                .iter()
                .enumerate()
                .map(|(i, q)| MotorCmd_ {
                    mode: MODE_ENABLED,
                    q: *q,
                    kp: gains.kp[i],
                    kd: gains.kd[i],
                    ..Default::default()
                })
                .collect(),
            reserve: [0; 4],
        }
    }

    fn dex3(side: Side) -> Arc<DeviceTable> {
        Arc::new(DeviceKind::Dex3.table(side, &TableOverrides::default()).unwrap())
    }

    #[test]
    fn the_sdk_bytes_of_an_xr_teleoperate_command_decode_to_canonical_joints() {
        let (bytes, msg) = xr_left_cmd();
        assert_eq!(
            bytes.len(),
            4 + 4 + 20 * 28 + 16,
            "header, count, 20 MotorCmd_, reserve"
        );
        assert_eq!(handgate_idl::to_cdr_le(&msg).unwrap(), bytes, "byte for byte");
        let d = decode_cmd(&msg, &t(Side::Left), &WireConfig::default()).unwrap();
        assert_eq!(d.joints.len(), 20);
        let j = |i: usize| d.joints[i].unwrap();
        assert!((j(1).q - 1.5).abs() < 1e-6 && (j(13).q - 1.5).abs() < 1e-6);
        assert!(
            (j(17).q - 1.0).abs() < 1e-6,
            "left thumb roll −1.0 on the wire closes: canonical +1.0"
        );
        for i in 0..20 {
            assert!(
                (j(i).kp - 1.0).abs() < 1e-6 && (j(i).kd - 1.0).abs() < 1e-5,
                "xr's gains are 1.0"
            );
        }
        assert_eq!((d.tag, d.timeout_bit), (0, false));
    }

    #[test]
    fn bad_commands_are_rejected_whole() {
        let f = t(Side::Right);
        let g = Gains::default();
        let motors = WireConfig {
            layout: CommandLayout::Motors,
            ..Default::default()
        };
        let ok = cmd(&[0.3; 20], &g);
        assert!(decode_cmd(&ok, &f, &WireConfig::default()).is_ok());
        let seven = HandCmd_::sdk_default();
        assert_eq!(
            decode_cmd(&seven, &f, &WireConfig::default()),
            Err(Rejection::WrongCount { got: 7, want: 20 }),
            "a Dex3 client's seven entries"
        );
        assert_eq!(
            decode_cmd(&ok, &f, &motors),
            Err(Rejection::WrongCount { got: 20, want: 16 })
        );
        let mut nan = ok.clone();
        nan.motor_cmd[12].kd = f32::NAN;
        assert_eq!(
            decode_cmd(&nan, &f, &WireConfig::default()),
            Err(Rejection::NonFinite(12))
        );
        let mut mode = ok.clone();
        mode.motor_cmd[4].mode = 0x11;
        assert_eq!(
            decode_cmd(&mode, &f, &WireConfig::default()),
            Err(Rejection::UnknownStatus { index: 4, status: 0x11 })
        );
        let mut off = ok;
        off.motor_cmd[5].mode = MODE_DISABLED;
        off.reserve[0] = 42;
        let d = decode_cmd(&off, &f, &WireConfig::default()).unwrap();
        assert_eq!(d.joints[5], Some(JointCommand::default()), "mode 0: that joint limp");
        assert!((d.joints[6].unwrap().q - 0.3).abs() < 1e-6);
        assert_eq!(d.tag, 42);
    }

    #[test]
    fn the_motor_layout_decodes_coupled_joints_through_the_coupling() {
        let f = t(Side::Left);
        let w = WireConfig::of(&Conventions {
            gains: GainSource::UnitreeDdsWrapper,
            command_layout: CommandLayout::Motors,
            ..Default::default()
        });
        let tb = t(Side::Left);
        let mut msg = HandCmd_::default();
        let targets = tb.closure_targets(1.0, None).unwrap();
        encode_hand_cmd(&tb, &targets, &w, &mut msg);
        let d = decode_cmd(&msg, &f, &w).unwrap();
        for (i, (c, want)) in d.joints.iter().zip(closed_posture(COUPLING)).enumerate() {
            let c = c.unwrap();
            assert!((c.q - want).abs() < 1e-5, "{i}: {} against {want}", c.q);
            assert!((c.kp - 1.0).abs() < 1e-5 && (c.kd - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn state_is_twenty_entries_with_wire_signs_and_freshness_markers() {
        let f = t(Side::Left);
        let mut joints = vec![JointState::default(); 20];
        joints[17].q = 0.7;
        joints[2] = JointState {
            q: 1.2,
            dq: 0.5,
            tau: 0.1,
            temperature: Some(35.4),
        };
        joints[0].q = f32::NAN;
        let st = HandState {
            cmd_tag: 9,
            freshness: Freshness::Stale,
            faults: faults::MOTOR_ERROR | faults::SAFE_STATE,
            pads: vec![Pad::dex3(0, [5.0; 12], [30.0; 12])],
            ..Default::default()
        };
        let mut out = encode_state(&f, &joints, &st);
        assert_eq!(out.motor_state.len(), 20);
        assert!(
            (out.motor_state[17].q + 0.7).abs() < 1e-6,
            "left thumb roll: wire = −canonical"
        );
        let m = &out.motor_state[2];
        assert_eq!(
            (m.q, m.dq, m.tau_est, m.temperature, m.mode),
            (1.2, 0.5, 0.1, [35, 35], 1)
        );
        assert_eq!(m.motorstate, 1);
        assert_eq!(out.motor_state[0].q, 0.0, "never measured reads 0, not NaN");
        assert_eq!(out.press_sensor_state.len(), 1);
        assert_eq!(out.press_sensor_state[0].pressure[11], 5.0);
        assert_eq!(out.reserve, [9, 1]);
        assert_eq!(out.error, [faults::MOTOR_ERROR, 1]);
        let ptr = out.motor_state.as_ptr();
        let fresh = HandState {
            freshness: Freshness::Fresh,
            ..Default::default()
        };
        encode_state_into(&f, &joints, &fresh, &mut out);
        assert_eq!(out.motor_state.as_ptr(), ptr, "buffer reused");
        assert_eq!(
            (out.reserve, out.error, out.press_sensor_state.len()),
            ([0, 0], [0, 0], 0)
        );
    }

    /// A Dex5 client closes a Dex3 hand, and sees the Dex3's closure as its own posture.
    #[test]
    fn a_dex5_client_drives_a_dex3_through_closure() {
        let front = Arc::new(t(Side::Left));
        let route = Route::bind(front.clone(), dex3(Side::Left));
        assert_eq!(route.pairing, Pairing::Closure);
        let g = Gains::default();
        // Everything at its closing end: as closed as the front's posture goes.
        let q: Vec<f32> = (0..20)
            .map(|i| LIMITS[i].1 * crate::dex5::table::wire_sign(Side::Left, i))
            .collect();
        let d = decode_cmd(&cmd(&q, &g), &front, &WireConfig::default()).unwrap();
        let body = route.command(&d.joints);
        assert_eq!(
            body,
            CommandBody::Closure {
                closure: 1.0,
                stiffness: None
            }
        );
        let targets = route.device.resolve(&body, None, &[]).unwrap();
        let wire = route.device.to_wire(&targets);
        assert!(
            (wire[5].q + 1.2).abs() < 1e-6,
            "the Dex3's left index_0 closed (negative)"
        );
        // The open command opens it.
        let d = decode_cmd(&cmd(&[0.0; 20], &g), &front, &WireConfig::default()).unwrap();
        assert!(matches!(route.command(&d.joints), CommandBody::Closure { closure, .. } if closure == 0.0));
        // State back: a half-closed Dex3 reads as a half-closed Dex5.
        let back = route.state(&[JointState::default(); 7], 0.5);
        let out = encode_state(&front, &back, &HandState::default());
        let closed = closed_posture(COUPLING);
        assert!((out.motor_state[2].q - 0.5 * closed[2]).abs() < 1e-5);
        assert!(
            (out.motor_state[17].q + 0.5 * closed[17]).abs() < 1e-5,
            "left thumb roll, wire sign"
        );
    }

    /// A Dex3 client closes a Dex5 hand: the Dex5 device sends its closed posture at the
    /// profile's gains.
    #[test]
    fn a_dex3_client_drives_a_dex5_through_closure() {
        let device = Arc::new(t(Side::Right));
        let front = dex3(Side::Right);
        let route = Route::bind(front.clone(), device.clone());
        assert_eq!(route.pairing, Pairing::Closure);
        let closed = front.closure_targets(1.0, None).unwrap();
        let mut dex3_cmd = HandCmd_::sdk_default();
        for (m, w) in dex3_cmd.motor_cmd.iter_mut().zip(front.to_wire(&closed)) {
            *m = w.into();
        }
        for (i, m) in dex3_cmd.motor_cmd.iter_mut().enumerate() {
            m.mode = 0x10 | i as u8;
        }
        let d = crate::dex3::front::decode_cmd(&dex3_cmd, &front, &[]).unwrap();
        let body = route.command(&d.joints);
        let targets = device.resolve(&body, None, &[]).unwrap();
        let mut msg = HandCmd_::default();
        encode_hand_cmd(&device, &targets, &WireConfig::default(), &mut msg);
        assert_eq!(msg.motor_cmd.len(), 20);
        for (i, (m, want)) in msg.motor_cmd.iter().zip(closed_posture(COUPLING)).enumerate() {
            assert!((m.q - want).abs() < 1e-5, "{i}: {} against {want}", m.q);
        }
        assert_eq!((msg.motor_cmd[9].kp, msg.motor_cmd[19].kp), (0.10, 1.0));
    }

    #[test]
    fn dex5_fronts_pair_joint_for_joint_with_dex5_devices_and_keep_the_gains() {
        let front = Arc::new(t(Side::Left));
        let route = Route::bind(front.clone(), Arc::new(t(Side::Right)));
        assert_eq!(route.pairing, Pairing::JointForJoint);
        let g = Gains::default();
        let mut c = cmd(&[0.3; 20], &g);
        c.motor_cmd[17].q = -0.4; // the left thumb roll, closing
        c.motor_cmd[6].kp = 0.05; // half the profile's finger kp
        let d = decode_cmd(&c, &front, &WireConfig::default()).unwrap();
        let targets = route.device.resolve(&route.command(&d.joints), None, &[]).unwrap();
        let mut msg = HandCmd_::default();
        encode_hand_cmd(&route.device, &targets, &WireConfig::default(), &mut msg);
        assert!((msg.motor_cmd[6].kp - 0.05).abs() < 1e-7);
        assert!((msg.motor_cmd[16].kp - 1.0).abs() < 1e-6);
        assert!(
            (msg.motor_cmd[17].q - 0.4).abs() < 1e-6,
            "the right thumb roll: + on the wire"
        );
    }
}
