//! Between the hand-level types ([`Dex3Command`], [`Dex3Measurement`]) and the frames, through
//! the [`WiringMap`] and the [`Scalings`] table.

use super::codec::{
    for_each_feedback, Feedback, LinuxToMcuCmd, McuToLinuxState, MotorCmdFrame, ParseCounters, RisMode,
};
use super::scaling::Scalings;
use super::wiring::{BusAddr, WiringMap};
use crate::dex3::{Dex3Command, Dex3Measurement, Imu, Power, MOTOR_COUNT};

/// One motor command frame from a [`crate::dex3::MotorCommand`]. A command with any
/// non-finite field is sent as limp (all zero, status kept) rather than saturated: a NaN
/// position must not become "go to 0 rad".
pub fn motor_frame(m: &crate::dex3::MotorCommand, id: u8, timeout_bit: bool, s: &Scalings) -> MotorCmdFrame {
    let finite = [m.q, m.dq, m.tau, m.kp, m.kd].iter().all(|v| v.is_finite());
    let limp = crate::dex3::MotorCommand {
        status: m.status,
        ..Default::default()
    };
    let m = if finite { m } else { &limp };
    MotorCmdFrame {
        mode: RisMode::new(id, m.status, timeout_bit),
        res: 0,
        tor_des: s.encode_cmd_torque(m.tau),
        spd_des: s.encode_cmd_speed(m.dq),
        pos_des: s.encode_cmd_position(m.q),
        k_pos: s.encode_cmd_kp(m.kp),
        k_spd: s.encode_cmd_kd(m.kd),
    }
}

/// Builds the whole command frame: on each bus, the motor frames of the joints wired to it in
/// motor-id order. `timeout_bit` is set explicitly on every motor.
///
/// The wiring map must be valid ([`WiringMap::validate`]): then every bus fits its buffer.
pub fn build_command(cmd: &Dex3Command, wiring: &WiringMap, s: &Scalings, timeout_bit: bool) -> LinuxToMcuCmd {
    let mut frame = LinuxToMcuCmd::default();
    for (at, joint) in wiring.motors_in_frame_order() {
        let f = motor_frame(&cmd.motors[joint.index()], at.id.get(), timeout_bit, s);
        // Cannot fail for a validated map (at most 12 motors of 20 B per 240 B bus).
        let _ = frame.buses[at.bus.index()].push(&f.encode(), at.bus.index());
    }
    frame
}

/// Supply figures from the raw words (manual formulas via `s`).
pub fn power_from_raw(state: &McuToLinuxState, s: &Scalings) -> Power {
    Power {
        power_v: state.pin_v as f32 * s.pin_v_per_count,
        power_a: state.pin_a as f32 * s.pin_a_per_count,
        system_v: state.vin_v as f32 * s.vin_v_per_count,
        device_v: state.vm_v as f32 * s.vm_v_per_count,
    }
}

/// IMU from `imu_data[6]` (ax ay az gx gy gz, raw / 100 per the manual).
pub fn imu_from_raw(raw: &[i16; 6], s: &Scalings) -> Imu {
    Imu {
        accel: [0, 1, 2].map(|i| raw[i] as f32 * s.imu_accel_per_count),
        gyro: [3, 4, 5].map(|i| raw[i] as f32 * s.imu_gyro_per_count),
    }
}

/// What one state frame contributed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ApplyReport {
    pub counters: ParseCounters,
    /// Motor packets whose address is not in the wiring map.
    pub unmapped_motors: u32,
    /// Sensor packets whose address is not in the wiring map.
    pub unmapped_sensors: u32,
    /// Which joints (IDL order) answered in this frame.
    pub motors_seen: [bool; MOTOR_COUNT],
}

/// Updates `meas` from a CRC-checked state frame. Joints and pads that did not answer keep
/// their previous values. Does not touch `measured_at`, `stale` or `seq`.
pub fn apply_state(
    meas: &mut Dex3Measurement,
    state: &McuToLinuxState,
    wiring: &WiringMap,
    s: &Scalings,
) -> ApplyReport {
    let mut rep = ApplyReport::default();
    rep.counters = for_each_feedback(state, |bus, f| match f {
        Feedback::Motor(f) => {
            let Ok(id) = super::codec::DeviceId::new(f.mode.id) else {
                rep.unmapped_motors += 1;
                return;
            };
            let Some(j) = wiring.joint_at(BusAddr { bus, id }) else {
                rep.unmapped_motors += 1;
                return;
            };
            rep.motors_seen[j.index()] = true;
            let m = &mut meas.motors[j.index()];
            m.present = true;
            m.q = s.decode_fb_position(f.pos);
            m.dq = s.decode_fb_speed(f.speed);
            m.tau = s.decode_fb_torque(f.torque);
            m.temperature_case = f.temp_case as f32;
            m.temperature_winding = f.temp_winding as f32;
            m.voltage = s.decode_fb_voltage(f.vol);
            m.error = f.error;
            m.status = f.mode.status.raw();
            m.timeout = f.mode.timeout;
        }
        Feedback::Sensor(f) => {
            let Ok(id) = super::codec::DeviceId::new(f.id()) else {
                rep.unmapped_sensors += 1;
                return;
            };
            let Some(p) = wiring.pad_at(BusAddr { bus, id }) else {
                rep.unmapped_sensors += 1;
                return;
            };
            let pad = &mut meas.pads[p];
            pad.present = true;
            for i in 0..f.pressure.len() {
                pad.pressure[i] = f.pressure[i] as f32 * s.pressure_pa_per_count;
                pad.temperature[i] = f.temperature[i] as f32;
            }
        }
    });
    meas.imu = imu_from_raw(&state.imu, s);
    meas.power = power_from_raw(state, s);
    meas.error = state.error;
    meas.hand_mode = state.mode;
    rep
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex3::usb::codec::{BusPayload, MotorFeedbackFrame, SensorFrame};
    use crate::dex3::{Joint, MotorCommand, MotorStatus};
    use std::time::Instant;

    #[test]
    fn command_lands_on_wired_bus_in_id_order() {
        let w = WiringMap::default();
        let s = Scalings::default();
        let mut cmd = Dex3Command::default();
        *cmd.motor_mut(Joint::Index1) = MotorCommand {
            q: 1.0,
            dq: 0.5,
            tau: 0.25,
            kp: 1.5,
            kd: 0.1,
            status: MotorStatus::Foc,
        };
        let f = build_command(&cmd, &w, &s, true);
        assert_eq!(f.buses[0].len(), 60);
        assert_eq!(f.buses[1].len(), 40);
        assert_eq!(f.buses[2].len(), 40);
        assert!(f.buses[3].is_empty() && f.buses[4].is_empty());
        let m = MotorCmdFrame::decode(&f.buses[1].bytes()[20..40]).unwrap();
        assert_eq!(m.mode, RisMode::new(1, MotorStatus::Foc, true));
        assert_eq!(m.tor_des, 64);
        assert_eq!(m.spd_des, 64);
        assert_eq!(m.pos_des, 5215);
        assert_eq!(m.k_pos, 49152);
        assert_eq!(m.k_spd, 3277);
        let first = MotorCmdFrame::decode(&f.buses[1].bytes()[..20]).unwrap();
        assert_eq!(first.mode, RisMode::new(0, MotorStatus::Foc, true));
    }

    #[test]
    fn non_finite_command_is_sent_limp() {
        let s = Scalings::default();
        let m = MotorCommand {
            q: f32::NAN,
            kp: 1.5,
            kd: 0.1,
            tau: 0.3,
            ..Default::default()
        };
        let f = motor_frame(&m, 2, true, &s);
        assert_eq!((f.pos_des, f.k_pos, f.k_spd, f.tor_des, f.spd_des), (0, 0, 0, 0, 0));
        assert_eq!(f.mode, RisMode::new(2, MotorStatus::Foc, true));
        let inf = MotorCommand {
            kd: f32::INFINITY,
            q: 0.5,
            ..Default::default()
        };
        assert_eq!(motor_frame(&inf, 0, false, &s).pos_des, 0);
    }

    #[test]
    fn state_maps_to_joints_and_pads() {
        let w = WiringMap::default();
        let s = Scalings::default();
        let mut st = McuToLinuxState {
            pin_v: 22697,
            imu: [0, 0, 981, 100, 0, -100],
            ..Default::default()
        };
        let mut bus2 = BusPayload::default();
        let fb = MotorFeedbackFrame {
            mode: RisMode::new(1, MotorStatus::Foc, true),
            pos: -5215,
            torque: -128,
            vol: 48,
            temp_case: 33,
            ..Default::default()
        };
        bus2.push(&fb.encode(), 2).unwrap();
        bus2.push(&SensorFrame::new(1, 0, [100; 12], [29; 12]).encode(), 2)
            .unwrap();
        // Unmapped motor id 9 on bus 2.
        let stray = MotorFeedbackFrame {
            mode: RisMode::new(9, MotorStatus::Foc, false),
            ..Default::default()
        };
        bus2.push(&stray.encode(), 2).unwrap();
        st.set_bus(2, &bus2);
        let mut meas = Dex3Measurement::empty(Instant::now());
        let rep = apply_state(&mut meas, &st, &w, &s);
        assert_eq!(rep.unmapped_motors, 1);
        assert!(rep.motors_seen[Joint::Middle1.index()]);
        let m = meas.motor(Joint::Middle1);
        assert!(m.present && m.timeout);
        assert!((m.q + 1.0).abs() < 1e-3);
        assert_eq!(m.tau, -0.5);
        assert_eq!(m.voltage, 24.0);
        assert_eq!(m.temperature_case, 33.0);
        assert!(!meas.motor(Joint::Thumb0).present);
        assert!(meas.pads[5].present);
        assert_eq!(meas.pads[5].pressure[0], 800.0);
        assert_eq!(meas.pads[5].temperature[11], 29.0);
        assert!((meas.power.power_v - 24.0).abs() < 0.01);
        assert!((meas.imu.accel[2] - 9.81).abs() < 1e-5);
        assert_eq!(meas.imu.gyro, [1.0, 0.0, -1.0]);
    }
}
