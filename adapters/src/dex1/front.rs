//! The Dex1 service front: what dex1_1_service and SAKE's EZGripper driver serve, so a client
//! written for either (xr_teleoperate included) works unchanged. Variants as in
//! `crate::dex1::adapter::Variant`: `go` (`rt/dex1/{side}/*`, unitree_go
//! MotorCmds_/MotorStates_, 1 element), `hg` (seed spec: HandCmd_/HandState_, 1 motor),
//! `actuator` (`rt/unitree_actuator/*`, 2 elements, index 0 right, 1 left); a front's default
//! `auto` serves each of them as its clients appear (`crate::dex1::follow`, `crate::dex1::serve`).
//!
//! Command rules: exact element count; finite values; `mode` ignored (as dex1_1_service does);
//! q outside [0, range] is clamped by the device table. State: q clamped to [0, range] (a
//! client must never see q > range: docs/sources.md §5's 5.4000001 bug), tau_est, temperature, mode =
//! the device's status byte (EZGripper grasp state), a hardware fault gives mode 255 and
//! lost = 0xFFFFFFFF; while the state is stale, `lost` carries the age of the last
//! measurement in ms (saturating at 0xFFFFFFFE) and `reserve[1]` = 1.

use crate::dex1::adapter::{actuator_index, Variant, LOST_FAULT, MODE_FAULT};
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{faults, Freshness, HandState, JointState, Side};
use handgate_idl::{unitree_go, unitree_hg};

use crate::front::{checked_target, FrontCommand, Rejection};

/// A Dex1 front must publish state at least this fast: xr_teleoperate runs its gripper loop
/// at 200 Hz (docs/sources.md §4).
pub const MIN_STATE_HZ: f64 = 200.0;

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

/// Decodes the `actuator` variant's 2-element MotorCmds_ for the bound elements
/// (`bound[i]` = (element, that gripper's front table)). The message is checked whole first:
/// two elements, every field of both finite (an unbound element included), so a bad
/// message moves neither gripper. Returns one command per bound element, in `bound`'s order.
pub fn decode_actuator(
    msg: &unitree_go::MotorCmds_,
    bound: &[(usize, &DeviceTable)],
) -> Result<Vec<FrontCommand>, Rejection> {
    let targets = crate::front::go_targets(msg, 2)?;
    Ok(bound
        .iter()
        .map(|&(e, table)| one(table, targets[e], msg.cmds[e].reserve[0]))
        .collect())
}

/// An `actuator` element no device is bound to: never measured, so reported as the stale
/// convention says (`reserve[1]` = 1, `lost` = the saturated age 0xFFFFFFFE) at the open
/// position, where a Dex1 powers up; commands for it are ignored.
pub fn unbound_state(front: &DeviceTable) -> unitree_go::MotorState_ {
    let q = front.joints[0].q_to_wire(0.0);
    unitree_go::MotorState_ {
        q,
        q_raw: q,
        lost: UNBOUND_LOST,
        reserve: [0, 1],
        ..Default::default()
    }
}

/// `lost` of an unbound actuator element (the stale age, saturated: never measured).
pub use crate::front::NEVER_MEASURED_LOST as UNBOUND_LOST;

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
    let lost = crate::front::fault_or_stale_lost(st, now);
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
    use crate::mapping::TableOverrides;
    use crate::model::DeviceKind;

    fn t() -> DeviceTable {
        DeviceKind::Dex1.table(Side::Left, &TableOverrides::default()).unwrap()
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
    fn actuator_decodes_both_elements_and_refuses_a_bad_one_whole() {
        let f = t();
        let mut m = unitree_go::MotorCmds_::with_len(2);
        m.cmds[0].q = 1.0;
        m.cmds[1].q = 4.0;
        let both = decode_actuator(&m, &[(0, &f), (1, &f)]).unwrap();
        assert!(
            (both[0].joints[0].unwrap().q - 4.4).abs() < 1e-5,
            "right: 1.0 rad = 4.4 closed"
        );
        assert!(
            (both[1].joints[0].unwrap().q - 1.4).abs() < 1e-5,
            "left: 4.0 rad = 1.4 closed"
        );
        let left_only = decode_actuator(&m, &[(1, &f)]).unwrap();
        assert_eq!(left_only.len(), 1);
        assert!((left_only[0].joints[0].unwrap().q - 1.4).abs() < 1e-5);
        // A NaN in the unbound element still refuses the whole message.
        m.cmds[0].kp = f32::NAN;
        assert_eq!(decode_actuator(&m, &[(1, &f)]), Err(Rejection::NonFinite(0)));
        assert!(decode_actuator(&unitree_go::MotorCmds_::with_len(1), &[(0, &f)]).is_err());
    }

    #[test]
    fn unbound_actuator_element_reports_open_and_never_measured() {
        let s = unbound_state(&t());
        assert!((s.q - 5.4).abs() < 1e-5, "{}", s.q);
        assert_eq!((s.lost, s.reserve[1]), (UNBOUND_LOST, 1));
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
