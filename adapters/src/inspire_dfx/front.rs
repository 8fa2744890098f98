//! The Inspire DFX service front's pure codec: what DFX_inspire_service serves
//! (docs/sources.md §7 "Inspire DFX"), so an unmodified client of it (xr_teleoperate's
//! `Inspire_Controller_DFX`) can drive any device. The topics are the device side's own
//! constants ([`super::CMD_TOPIC`], [`super::STATE_TOPIC`]): one home per fact.
//!
//! Command rules (docs/fronts.md "Bad input"): exactly 12 entries, every field of every entry
//! finite, else the message is rejected whole (neither hand moves). Only `q` is used, as the
//! service does; each hand's six `q` become canonical positions through the front's table,
//! held with that table's hold gains. A finite `q` outside [0, 1] passes through to the
//! device table, whose limits are exactly the service's [0, 1] clamp (the URDF range), so it
//! is clamped there and counted, as every front's out-of-range values are.
//!
//! State: a 12-entry `MotorStates_`; each bound element's six `q` from its own device's
//! measured state (clamped to [0, 1]: a client never sees a value the service could not
//! report), `lost` 0 when fresh; while stale `lost` carries the age of the last measurement in
//! ms (saturating at [`UNBOUND_LOST`]) and `reserve[1]` = 1; a hardware fault gives
//! [`LOST_FAULT`]; `reserve[0]` echoes the client tag (`cmds[0].reserve[0]`). An element no
//! device is bound to reads open (q = 1.0) and never measured (`lost` = [`UNBOUND_LOST`],
//! `reserve[1]` = 1), as the Dex1 actuator front marks its unbound gripper.

use handgate_idl::unitree_go;

use super::{ENTRIES, HAND_ENTRIES};
use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{Freshness, HandState, JointCommand};

/// `lost` of a hand in a hardware fault.
pub use crate::front::FAULT_LOST as LOST_FAULT;
/// `lost` of an element no device is bound to (the stale age, saturated: never measured).
pub use crate::front::NEVER_MEASURED_LOST as UNBOUND_LOST;

/// Decodes a 12-entry `MotorCmds_` for the bound elements (`bound[i]` = (element 0 right /
/// 1 left, that hand's front table)). Checked whole first: 12 entries, every field finite
/// (the unbound hand's entries included). Returns one command per bound element, in
/// `bound`'s order.
pub fn decode(msg: &unitree_go::MotorCmds_, bound: &[(usize, &DeviceTable)]) -> Result<Vec<FrontCommand>, Rejection> {
    crate::front::go_targets(msg, ENTRIES)?;
    Ok(bound
        .iter()
        .map(|&(e, table)| FrontCommand {
            joints: table
                .joints
                .iter()
                .map(|j| {
                    msg.cmds
                        .get(e * HAND_ENTRIES + j.wire_index)
                        .map(|m| JointCommand::hold(j.q_from_wire(m.q), table.hold_kp, table.hold_kd))
                })
                .collect(),
            timeout_bit: false,
            tag: msg.cmds[0].reserve[0],
        })
        .collect())
}

/// One hand's six entries from its routed state.
fn hand(front: &DeviceTable, st: &HandState, now: std::time::Instant) -> [unitree_go::MotorState_; HAND_ENTRIES] {
    let stale = st.freshness == Freshness::Stale;
    let lost = crate::front::fault_or_stale_lost(st, now);
    let mut out = [unitree_go::MotorState_::default(); HAND_ENTRIES];
    for (j, s) in front.joints.iter().zip(&st.joints) {
        let q = j.q_to_wire(s.q);
        let q = if q.is_finite() { q.clamp(0.0, 1.0) } else { 1.0 };
        if let Some(m) = out.get_mut(j.wire_index) {
            *m = unitree_go::MotorState_ {
                q,
                lost,
                reserve: [st.cmd_tag, u32::from(stale)],
                ..Default::default()
            };
        }
    }
    out
}

/// An element no device is bound to: open, never measured.
pub fn unbound_state() -> unitree_go::MotorState_ {
    unitree_go::MotorState_ {
        q: 1.0,
        lost: UNBOUND_LOST,
        reserve: [0, 1],
        ..Default::default()
    }
}

/// The 12-entry `MotorStates_` from the bound hands (`bound[i]` = (element, its front table,
/// its routed state)); an element not in `bound` reads [`unbound_state`].
pub fn encode(bound: &[(usize, &DeviceTable, &HandState)], now: std::time::Instant) -> unitree_go::MotorStates_ {
    let mut msg = unitree_go::MotorStates_ {
        states: vec![unbound_state(); ENTRIES],
    };
    for &(e, table, st) in bound {
        if e < 2 {
            msg.states[e * HAND_ENTRIES..(e + 1) * HAND_ENTRIES].copy_from_slice(&hand(table, st, now));
        }
    }
    msg
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::faults;
    use crate::model::{DeviceKind, JointState, Side};

    fn t(side: Side) -> DeviceTable {
        DeviceKind::InspireDfx.table(side, &TableOverrides::default()).unwrap()
    }

    fn cmds(q: [f32; 12]) -> unitree_go::MotorCmds_ {
        let mut m = unitree_go::MotorCmds_::with_len(12);
        for (c, q) in m.cmds.iter_mut().zip(q) {
            c.q = q;
        }
        m
    }

    #[test]
    fn decodes_each_element_from_its_own_entries() {
        let (r, l) = (t(Side::Right), t(Side::Left));
        // Right hand all open (1.0), left hand all closed (0.0).
        let m = cmds([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let d = decode(&m, &[(0, &r), (1, &l)]).unwrap();
        assert_eq!(d.len(), 2);
        let right: Vec<f32> = d[0].joints.iter().map(|j| j.unwrap().q).collect();
        let left: Vec<f32> = d[1].joints.iter().map(|j| j.unwrap().q).collect();
        // Open = URDF lower limits, closed = upper (docs/sources.md §7).
        let lower = [0.0, 0.0, 0.0, 0.0, 0.0, -0.1];
        let upper = [1.7, 1.7, 1.7, 1.7, 0.5, 1.3];
        for i in 0..6 {
            assert!((right[i] - lower[i]).abs() < 1e-5, "right {i}: {}", right[i]);
            assert!((left[i] - upper[i]).abs() < 1e-5, "left {i}: {}", left[i]);
        }
        let only_left = decode(&m, &[(1, &l)]).unwrap();
        assert_eq!(only_left.len(), 1);
        assert!((only_left[0].joints[3].unwrap().q - 1.7).abs() < 1e-5);
    }

    #[test]
    fn wrong_count_or_any_non_finite_rejects_the_whole_message() {
        let (r, l) = (t(Side::Right), t(Side::Left));
        assert_eq!(
            decode(&unitree_go::MotorCmds_::with_len(6), &[(0, &r)]),
            Err(Rejection::WrongCount { got: 6, want: 12 })
        );
        assert!(decode(&unitree_go::MotorCmds_::default(), &[(0, &r)]).is_err());
        assert!(decode(&unitree_go::MotorCmds_::with_len(13), &[(0, &r)]).is_err());
        let mut m = cmds([0.5; 12]);
        // A NaN in the left hand's entries refuses the message for the right hand too.
        m.cmds[8].q = f32::NAN;
        assert_eq!(decode(&m, &[(0, &r)]), Err(Rejection::NonFinite(8)));
        let mut m = cmds([0.5; 12]);
        m.cmds[2].kp = f32::INFINITY;
        assert_eq!(decode(&m, &[(0, &r), (1, &l)]), Err(Rejection::NonFinite(2)));
    }

    #[test]
    fn out_of_range_q_is_clamped_by_the_table_as_the_service_clamps() {
        let r = t(Side::Right);
        let m = cmds([-0.5, 1.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
        let d = decode(&m, &[(0, &r)]).unwrap();
        let pinky = d[0].joints[0].unwrap();
        let ring = d[0].joints[1].unwrap();
        // -0.5 is past closed, 1.5 past open: the table clamps both to the URDF range, which
        // is the service's [0, 1].
        let p = r.sanitize(crate::model::JointId(0), &pinky, None).unwrap();
        let g = r.sanitize(crate::model::JointId(1), &ring, None).unwrap();
        assert!((p.q - 1.7).abs() < 1e-6 && (r.joints[0].q_to_wire(p.q) - 0.0).abs() < 1e-6);
        assert!((g.q - 0.0).abs() < 1e-6 && (r.joints[1].q_to_wire(g.q) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn encode_fills_each_element_from_its_device_and_marks_the_unbound_one() {
        let l = t(Side::Left);
        let now = std::time::Instant::now();
        let st = HandState {
            joints: [1.7, 0.85, 0.0, 1.7, 0.5, -0.1]
                .iter()
                .map(|&q| JointState {
                    q,
                    ..Default::default()
                })
                .collect(),
            freshness: Freshness::Fresh,
            cmd_tag: 7,
            ..Default::default()
        };
        let msg = encode(&[(1, &l, &st)], now);
        assert_eq!(msg.states.len(), 12);
        let want = [0.0, 0.5, 1.0, 0.0, 0.0, 1.0];
        for (i, w) in want.iter().enumerate() {
            let s = msg.states[6 + i];
            assert!((s.q - w).abs() < 1e-5, "left entry {i}: {}", s.q);
            assert_eq!((s.lost, s.reserve), (0, [7, 0]));
        }
        for s in &msg.states[0..6] {
            assert_eq!((s.q, s.lost, s.reserve[1]), (1.0, UNBOUND_LOST, 1));
        }
    }

    #[test]
    fn encode_clamps_q_and_marks_stale_and_faulted_hands() {
        let r = t(Side::Right);
        let now = std::time::Instant::now();
        let mut st = HandState {
            joints: vec![
                JointState {
                    q: -0.01,
                    ..Default::default()
                };
                6
            ],
            freshness: Freshness::Stale,
            ..Default::default()
        };
        let msg = encode(&[(0, &r, &st)], now);
        assert!(msg.states[..6].iter().all(|s| s.q <= 1.0), "never past open");
        assert_eq!((msg.states[0].lost, msg.states[0].reserve[1]), (UNBOUND_LOST, 1));
        st.faults = faults::HARDWARE;
        assert_eq!(encode(&[(0, &r, &st)], now).states[0].lost, LOST_FAULT);
    }
}
