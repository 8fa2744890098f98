//! The BrainCo service front's pure codec: what `brainco_hand_service` serves (docs/sources.md
//! §7), so an unmodified BrainCo client (xr_teleoperate's `Brainco_Controller`) can drive any
//! device. Topics: [`super::topics`] (`rt/brainco/{side}/cmd` in, `.../state` out), the same
//! constants the device side uses. The front's registry entry is not here (it is registered
//! with the other fronts' factories).
//!
//! Command rules (docs/fronts.md "Bad input"): exactly 6 entries in the driver's order
//! (thumb, thumb aux, index, middle, ring, pinky), else rejected whole; a non-finite value in
//! any of an entry's five fields rejects the message whole (the rule of every front, though
//! the service itself only reads `q` and `dq`); `q` and `dq` outside [0, 1] are clamped to it
//! as the service clamps them ([`out_of_range`] counts them for the front's counters);
//! finite `tau`, `kp`, `kd` and `mode` are ignored as the service ignores them. `q` becomes the
//! joint's canonical radians through the front table; the speed `dq` has no canonical
//! counterpart (canonical `dq` is a velocity target) and is not forwarded: the device runs at
//! its own configured speed. `cmds[0].reserve[0]` is the client's tag.
//!
//! State: 6 entries in wire order, `q` the joint's position in [0, 1] (clamped: the hand's
//! register never reads outside it), `dq` its velocity in strokes per second, `tau_est` the
//! joint's `tau` unchanged (a BrainCo device's motor current, A). handgate's use of the fields
//! the service leaves zero: `reserve[0]` echoes the tag of the applied command, `reserve[1]`
//! is 1 while the state is stale and `lost` then carries the age of the last measurement in
//! ms (saturating at 0xFFFFFFFE), as the Dex1 front does.

use handgate_idl::unitree_go;

use super::WIRE_LEN;
use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{Freshness, HandState, JointCommand, JointState};

pub use crate::front::NEVER_MEASURED_LOST;

/// Decodes a client's `MotorCmds_` for a BrainCo front whose table is `front`.
pub fn decode(msg: &unitree_go::MotorCmds_, front: &DeviceTable) -> Result<FrontCommand, Rejection> {
    crate::front::go_targets(msg, WIRE_LEN)?;
    let joints = front
        .joints
        .iter()
        .map(|j| {
            let q = msg.cmds.get(j.wire_index)?.q.clamp(0.0, 1.0);
            Some(JointCommand::hold(j.q_from_wire(q), front.hold_kp, front.hold_kd))
        })
        .collect();
    Ok(FrontCommand {
        joints,
        timeout_bit: false,
        tag: msg.cmds[0].reserve[0],
    })
}

/// How many `q` / `dq` values of `msg` lie outside [0, 1] (what [`decode`] clamps), for the
/// front's clamp counter.
pub fn out_of_range(msg: &unitree_go::MotorCmds_) -> usize {
    msg.cmds
        .iter()
        .flat_map(|c| [c.q, c.dq])
        .filter(|v| v.is_finite() && !(0.0..=1.0).contains(v))
        .count()
}

/// The state message for the routed canonical state `joints` (front canonical order) of `st`.
pub fn encode(
    front: &DeviceTable,
    joints: &[JointState],
    st: &HandState,
    now: std::time::Instant,
) -> unitree_go::MotorStates_ {
    let stale = st.freshness == Freshness::Stale;
    let lost = crate::front::stale_lost(st, now);
    let mut out = unitree_go::MotorStates_::with_len(WIRE_LEN);
    for (j, s) in front.joints.iter().zip(joints) {
        let Some(m) = out.states.get_mut(j.wire_index) else {
            continue;
        };
        let q = j.q_to_wire(s.q);
        let q = if q.is_finite() { q.clamp(0.0, 1.0) } else { 0.0 };
        let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
        *m = unitree_go::MotorState_ {
            q,
            dq: finite(j.rate_to_wire(s.dq)),
            tau_est: finite(j.tau_to_wire(s.tau)),
            lost,
            reserve: [st.cmd_tag, u32::from(stale)],
            ..Default::default()
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, Side};

    fn t(side: Side) -> DeviceTable {
        DeviceKind::Brainco.table(side, &TableOverrides::default()).unwrap()
    }

    fn msg(q: [f32; 6], dq: f32) -> unitree_go::MotorCmds_ {
        unitree_go::MotorCmds_ {
            cmds: q
                .iter()
                .map(|&q| unitree_go::MotorCmd_ {
                    q,
                    dq,
                    ..Default::default()
                })
                .collect(),
        }
    }

    #[test]
    #[allow(clippy::approx_constant)] // the URDF's literal figures
    fn closed_wire_is_the_urdf_upper_limit_and_open_is_zero() {
        let f = t(Side::Left);
        let d = decode(&msg([1.0; 6], 1.0), &f).unwrap();
        let q: Vec<f32> = d.joints.iter().map(|j| j.unwrap().q).collect();
        // docs/sources.md §7: thumb 1.5184, thumb aux 1.0472, fingers 1.4661 rad.
        let want = [1.5184, 1.0472, 1.4661, 1.4661, 1.4661, 1.4661];
        for (a, b) in q.iter().zip(want) {
            assert!((a - b).abs() < 1e-4, "{q:?}");
        }
        let d = decode(&msg([0.0; 6], 1.0), &f).unwrap();
        assert!(d.joints.iter().all(|j| j.unwrap().q == 0.0));
    }

    #[test]
    fn bad_input_is_rejected_whole_and_out_of_range_clamped() {
        let f = t(Side::Right);
        assert_eq!(
            decode(&unitree_go::MotorCmds_::with_len(5), &f),
            Err(Rejection::WrongCount { got: 5, want: 6 })
        );
        assert!(decode(&unitree_go::MotorCmds_::with_len(12), &f).is_err());
        let mut m = msg([0.5; 6], 1.0);
        m.cmds[3].q = f32::NAN;
        assert_eq!(decode(&m, &f), Err(Rejection::NonFinite(3)));
        let mut m = msg([0.5; 6], 1.0);
        m.cmds[4].dq = f32::INFINITY;
        assert_eq!(decode(&m, &f), Err(Rejection::NonFinite(4)));
        // Any field, even one the service ignores (docs/fronts.md: any non-finite value).
        let mut m = msg([0.5; 6], 1.0);
        m.cmds[0].kp = f32::NAN;
        assert_eq!(decode(&m, &f), Err(Rejection::NonFinite(0)));
        // Finite values of the ignored fields change nothing.
        let mut m = msg([0.5; 6], 1.0);
        m.cmds[1].kp = 40.0;
        m.cmds[1].tau = -3.0;
        m.cmds[1].mode = 9;
        assert_eq!(decode(&m, &f), decode(&msg([0.5; 6], 1.0), &f));
        let m = msg([1.7, -0.2, 0.5, 0.5, 0.5, 0.5], 3.0);
        assert_eq!(out_of_range(&m), 2 + 6);
        let d = decode(&m, &f).unwrap();
        assert!((d.joints[0].unwrap().q - 1.5184).abs() < 1e-4);
        assert_eq!(d.joints[1].unwrap().q, 0.0);
    }

    #[test]
    fn state_is_six_entries_in_wire_order_with_stale_markers() {
        let f = t(Side::Left);
        let now = std::time::Instant::now();
        let joints: Vec<JointState> = [1.5184f32, 0.0, 0.73305, 1.4661, 2.0, -0.1]
            .iter()
            .map(|&q| JointState {
                q,
                tau: 0.25,
                ..Default::default()
            })
            .collect();
        let st = HandState {
            freshness: Freshness::Fresh,
            cmd_tag: 7,
            ..Default::default()
        };
        let s = encode(&f, &joints, &st, now);
        assert_eq!(s.states.len(), 6);
        let q: Vec<f32> = s.states.iter().map(|m| m.q).collect();
        for (a, b) in q.iter().zip([1.0, 0.0, 0.5, 1.0, 1.0, 0.0]) {
            assert!((a - b).abs() < 1e-4, "{q:?}");
        }
        assert_eq!(s.states[2].tau_est, 0.25);
        assert_eq!((s.states[0].lost, s.states[0].reserve), (0, [7, 0]));
        let stale = HandState {
            freshness: Freshness::Stale,
            ..Default::default()
        };
        let s = encode(&f, &joints, &stale, now);
        assert_eq!((s.states[5].lost, s.states[5].reserve[1]), (NEVER_MEASURED_LOST, 1));
    }
}
