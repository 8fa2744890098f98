//! The Dex1 service front: what dex1_1_service and SAKE's EZGripper driver serve, so a client
//! written for either (xr_teleoperate included) works unchanged. Variants as in
//! `handgate_adapters::dex1::adapter::Variant`: `go` (default: `rt/dex1/{side}/*`, unitree_go
//! MotorCmds_/MotorStates_, 1 element), `hg` (seed spec: HandCmd_/HandState_, 1 motor),
//! `actuator` (`rt/unitree_actuator/*`, 2 elements, index 0 right, 1 left).
//!
//! Command rules: exact element count; finite values; `mode` ignored (as dex1_1_service does);
//! q outside [0, range] is clamped by the device table. State: q clamped to [0, range] (a
//! client must never see q > range: FACTS §5's 5.4000001 bug), tau_est, temperature, mode =
//! the device's status byte (EZGripper grasp state), a hardware fault gives mode 255 and
//! lost = 0xFFFFFFFF; while the state is stale, `lost` carries the age of the last
//! measurement in ms (saturating at 0xFFFFFFFE) and `reserve[1]` = 1.

use handgate_adapters::dex1::adapter::{actuator_index, Variant, LOST_FAULT, MODE_FAULT};
use handgate_adapters::mapping::{DeviceTable, WireTarget};
use handgate_adapters::model::{faults, Freshness, HandState, JointState, Side};
use handgate_idl::{unitree_go, unitree_hg};

use super::{checked_target, FrontCommand, Rejection};

fn one(front: &DeviceTable, w: WireTarget, tag: u32) -> FrontCommand {
    FrontCommand {
        joints: vec![Some(front.joints[0].from_wire(&w))],
        timeout_bit: false,
        tag,
    }
}

/// Decodes unitree_go MotorCmds_ for the `go` or `actuator` variant.
pub fn decode_go(
    msg: &unitree_go::MotorCmds_,
    variant: Variant,
    side: Side,
    front: &DeviceTable,
) -> Result<FrontCommand, Rejection> {
    let (want, idx) = match variant {
        Variant::Actuator => (2, actuator_index(side)),
        _ => (1, 0),
    };
    if msg.cmds.len() != want {
        return Err(Rejection::WrongCount {
            got: msg.cmds.len(),
            want,
        });
    }
    let m = &msg.cmds[idx];
    Ok(one(
        front,
        checked_target(idx, [m.q, m.dq, m.tau, m.kp, m.kd])?,
        m.reserve[0],
    ))
}

/// Decodes the seed spec's HandCmd_ (1 motor).
pub fn decode_hg(msg: &unitree_hg::HandCmd_, front: &DeviceTable) -> Result<FrontCommand, Rejection> {
    if msg.motor_cmd.len() != 1 {
        return Err(Rejection::WrongCount {
            got: msg.motor_cmd.len(),
            want: 1,
        });
    }
    let m = &msg.motor_cmd[0];
    Ok(one(
        front,
        checked_target(0, [m.q, m.dq, m.tau, m.kp, m.kd])?,
        msg.reserve[0],
    ))
}

/// One gripper's unitree_go MotorState_ from the routed joint state.
pub fn go_state(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_go::MotorState_ {
    let j = &front.joints[0];
    let range = j.limits.max.max(j.limits.min);
    let q = j.q_to_wire(joint.q);
    let q = if q.is_finite() {
        q.clamp(0.0, j.q_to_wire(0.0).max(j.q_to_wire(range)))
    } else {
        0.0
    };
    let fault = st.faults & faults::HARDWARE != 0;
    let stale = st.freshness == Freshness::Stale;
    let lost = if fault {
        LOST_FAULT
    } else if stale {
        st.age(now)
            .map(|a| a.as_millis().min(0xFFFF_FFFE) as u32)
            .unwrap_or(0xFFFF_FFFE)
    } else {
        0
    };
    unitree_go::MotorState_ {
        mode: if fault { MODE_FAULT } else { st.mode },
        q,
        dq: j.rate_to_wire(joint.dq),
        ddq: 0.0,
        tau_est: j.tau_to_wire(joint.tau),
        q_raw: q,
        dq_raw: 0.0,
        ddq_raw: 0.0,
        temperature: joint.temperature.unwrap_or(0.0).round().clamp(0.0, 255.0) as u8,
        lost,
        reserve: [st.cmd_tag, u32::from(stale)],
    }
}

/// MotorStates_ for the `go` (1 element) variant.
pub fn encode_go(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_go::MotorStates_ {
    unitree_go::MotorStates_ {
        states: vec![go_state(front, joint, st, now)],
    }
}

/// HandState_ for the `hg` variant.
pub fn encode_hg(
    front: &DeviceTable,
    joint: &JointState,
    st: &HandState,
    now: std::time::Instant,
) -> unitree_hg::HandState_ {
    let g = go_state(front, joint, st, now);
    let mut out = unitree_hg::HandState_::with_sizes(1, 0);
    let t = g.temperature as i16;
    out.motor_state[0] = unitree_hg::MotorState_ {
        mode: g.mode,
        q: g.q,
        dq: g.dq,
        tau_est: g.tau_est,
        temperature: [t, t],
        motorstate: u32::from(g.lost == LOST_FAULT),
        ..Default::default()
    };
    out.reserve = [st.cmd_tag, u32::from(st.freshness == Freshness::Stale)];
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use handgate_adapters::model::DeviceKind;
    use handgate_adapters::tables::{table_for, TableParams};

    fn t() -> DeviceTable {
        table_for(DeviceKind::Dex1, Side::Left, &TableParams::default()).unwrap()
    }

    #[test]
    fn go_counts_and_finiteness() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(1);
        m.cmds[0].q = 5.4;
        let d = decode_go(&m, Variant::Go, Side::Left, &f).unwrap();
        assert!(
            (d.joints[0].unwrap().q - 0.0).abs() < 1e-6,
            "5.4 rad = open = canonical 0"
        );
        assert!(decode_go(&unitree_go::MotorCmds_::with_len(2), Variant::Go, Side::Left, &f).is_err());
        assert!(decode_go(&unitree_go::MotorCmds_::default(), Variant::Go, Side::Left, &f).is_err());
        m.cmds[0].q = f32::INFINITY;
        assert_eq!(decode_go(&m, Variant::Go, Side::Left, &f), Err(Rejection::NonFinite(0)));
    }

    #[test]
    fn actuator_reads_its_side_index() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(2);
        m.cmds[0].q = 1.0;
        m.cmds[1].q = 4.0;
        let d = decode_go(&m, Variant::Actuator, Side::Left, &f).unwrap();
        assert!((d.joints[0].unwrap().q - 1.4).abs() < 1e-5);
    }

    #[test]
    fn state_q_never_exceeds_range_and_fault_markers() {
        let f = t();
        let now = std::time::Instant::now();
        let st = HandState {
            freshness: Freshness::Fresh,
            ..Default::default()
        };
        let s = go_state(
            &f,
            &JointState {
                q: -0.0001,
                ..Default::default()
            },
            &st,
            now,
        );
        assert!(s.q <= 5.4, "{}", s.q);
        let bad = HandState {
            faults: faults::HARDWARE,
            ..Default::default()
        };
        let s = go_state(&f, &JointState::default(), &bad, now);
        assert_eq!((s.mode, s.lost), (255, 0xFFFF_FFFF));
    }
}
