//! The Inspire FTP front codec: what Inspire's DDS driver serves for one hand
//! (`rt/inspire_hand/{ctrl,state,touch}/{l,r}`, docs/sources.md §7), so a client written for it
//! (xr_teleoperate's `Inspire_Controller_FTP`, Inspire's own examples) can drive any device.
//! Pure functions; the front's registry entry and endpoints are [`super::serve`].
//!
//! Command rules (docs/fronts.md, "Bad input"; `inspire_hand_ctrl`):
//! - `mode` bits above 0b1111 (a negative or ≥ 16 `mode`) → rejected whole (`UnknownMode`).
//! - Every array whose bit is set must have exactly 6 entries, else rejected whole
//!   (`WrongCount`); arrays whose bit is clear are not looked at (the driver ignores them).
//! - Bit 1 (`pos_set`) → rejected whole (`UnknownMode`): which end of the actuator stroke is
//!   closed is not established (docs/sources.md §7), so handgate cannot honour it.
//! - Bit 0 (`angle_set`): each angle, 0–1000 with 1000 = open, becomes its joint's canonical
//!   target through the front's table; `-1` leaves that joint's target alone (the Inspire
//!   header's "no change"); values outside 0–1000 land outside the joint's limits and are
//!   clamped by the device's table (counted there), as on every front.
//! - `force_set` / `speed_set` (bits 2, 3) are accepted and not carried: the canonical model has
//!   no force threshold or speed. A command with only these bits, or `mode` 0, is the driver's
//!   "no operation": [`decode`] returns `Ok(None)` and nothing moves.
//!
//! State (`inspire_hand_state`): `angle_act` from the routed joint positions (clamped to
//! 0–1000), `pos_act` = 1000 − angle (the emulator's assumed stroke direction, an assumption),
//! `temperature` from the joints, `err` bit 3 (motor fault) on a motor or hardware fault, bit 4
//! (communication) while the device's state is stale; `status` 2 (stopped at position), 7
//! (actuator fault) on a hardware fault. `force_act` and `current` are 0: the canonical state
//! carries neither.
//!
//! Touch (`inspire_hand_touch`): the 17 tactile segments are the device's canonical pads, one
//! per segment, named as [`SEGMENTS`] (`pinky_tip`, `pinky_top`, `pinky_pad`, …, `thumb_middle`,
//! `thumb_pad`, `palm`) with their rows × cols. [`encode_touch`] rebuilds the message from the
//! pads of a device that has them (values rounded and clamped to int16, a missing segment all
//! zeros) and gives `None` for a device without any of them (nothing to publish).

use handgate_idl::inspire::{
    InspireHandCtrl, InspireHandState, InspireHandTouch, ACTUATORS, MODE_ANGLE, MODE_FORCE, MODE_POS, MODE_SPEED,
    UNITS_MAX,
};

use crate::front::{FrontCommand, Rejection};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandState, JointCommand, JointState, Pad, Side};

/// Command topic of a hand: `{CTRL_TOPIC_PREFIX}/{l,r}` (the driver subscribes).
pub const CTRL_TOPIC_PREFIX: &str = "rt/inspire_hand/ctrl";
/// State topic of a hand: `{STATE_TOPIC_PREFIX}/{l,r}` (the driver publishes).
pub const STATE_TOPIC_PREFIX: &str = "rt/inspire_hand/state";
/// Tactile topic of a hand: `{TOUCH_TOPIC_PREFIX}/{l,r}` (the driver publishes, Modbus TCP only).
pub const TOUCH_TOPIC_PREFIX: &str = "rt/inspire_hand/touch";

/// `err` bit: motor fault (docs/wire-types.md).
pub const ERR_MOTOR_FAULT: u8 = 1 << 3;
/// `err` bit: communication error.
pub const ERR_COMMUNICATION: u8 = 1 << 4;
/// `status`: stopped at position.
pub const STATUS_AT_POSITION: u8 = 2;
/// `status`: actuator fault.
pub const STATUS_ACTUATOR_FAULT: u8 = 7;

/// The 17 tactile segments in `inspire_hand_touch` field order: (canonical pad name, rows,
/// cols). Finger one = pinky … five = thumb; `tip` = fingertip end (3×3), `top` = fingertip pad
/// (12×8), `pad` = the finger pad (the IDL's `*_palm_touch`: 10×8, the thumb's 12×8),
/// `thumb_middle` (3×3), `palm` (14×8): 1062 taxels (docs/sources.md §7, docs/wire-types.md).
pub const SEGMENTS: [(&str, u16, u16); 17] = [
    ("pinky_tip", 3, 3),
    ("pinky_top", 12, 8),
    ("pinky_pad", 10, 8),
    ("ring_tip", 3, 3),
    ("ring_top", 12, 8),
    ("ring_pad", 10, 8),
    ("middle_tip", 3, 3),
    ("middle_top", 12, 8),
    ("middle_pad", 10, 8),
    ("index_tip", 3, 3),
    ("index_top", 12, 8),
    ("index_pad", 10, 8),
    ("thumb_tip", 3, 3),
    ("thumb_top", 12, 8),
    ("thumb_middle", 3, 3),
    ("thumb_pad", 12, 8),
    ("palm", 14, 8),
];

/// The message's 17 arrays in [`SEGMENTS`] order.
pub fn touch_fields(t: &InspireHandTouch) -> [&Vec<i16>; 17] {
    [
        &t.fingerone_tip_touch,
        &t.fingerone_top_touch,
        &t.fingerone_palm_touch,
        &t.fingertwo_tip_touch,
        &t.fingertwo_top_touch,
        &t.fingertwo_palm_touch,
        &t.fingerthree_tip_touch,
        &t.fingerthree_top_touch,
        &t.fingerthree_palm_touch,
        &t.fingerfour_tip_touch,
        &t.fingerfour_top_touch,
        &t.fingerfour_palm_touch,
        &t.fingerfive_tip_touch,
        &t.fingerfive_top_touch,
        &t.fingerfive_middle_touch,
        &t.fingerfive_palm_touch,
        &t.palm_touch,
    ]
}

/// The message's 17 arrays in [`SEGMENTS`] order, to fill.
pub fn touch_fields_mut(t: &mut InspireHandTouch) -> [&mut Vec<i16>; 17] {
    [
        &mut t.fingerone_tip_touch,
        &mut t.fingerone_top_touch,
        &mut t.fingerone_palm_touch,
        &mut t.fingertwo_tip_touch,
        &mut t.fingertwo_top_touch,
        &mut t.fingertwo_palm_touch,
        &mut t.fingerthree_tip_touch,
        &mut t.fingerthree_top_touch,
        &mut t.fingerthree_palm_touch,
        &mut t.fingerfour_tip_touch,
        &mut t.fingerfour_top_touch,
        &mut t.fingerfour_palm_touch,
        &mut t.fingerfive_tip_touch,
        &mut t.fingerfive_top_touch,
        &mut t.fingerfive_middle_touch,
        &mut t.fingerfive_palm_touch,
        &mut t.palm_touch,
    ]
}

/// The canonical pads of a touch message: one per segment, raw values, no temperature.
pub fn pads_from_touch(t: &InspireHandTouch) -> Vec<Pad> {
    let mut pads = Vec::new();
    pads_from_touch_into(t, &mut pads);
    pads
}

/// [`pads_from_touch`] into `pads`, their buffers reused.
pub fn pads_from_touch_into(t: &InspireHandTouch, pads: &mut Vec<Pad>) {
    pads.resize_with(SEGMENTS.len(), Pad::default);
    for (pad, (&(name, rows, cols), v)) in pads.iter_mut().zip(SEGMENTS.iter().zip(touch_fields(t))) {
        pad.name.clear();
        pad.name.push_str(name);
        (pad.rows, pad.cols) = (rows, cols);
        pad.pressure.clear();
        pad.pressure.extend(v.iter().map(|x| f32::from(*x)));
        pad.temperature.clear();
    }
}

/// `inspire_hand_touch` from a device's pads, `None` when it has none of the segments.
pub fn encode_touch(pads: &[Pad]) -> Option<InspireHandTouch> {
    let mut out = InspireHandTouch::sdk_default();
    let mut any = false;
    for ((name, _, _), arr) in SEGMENTS.iter().zip(touch_fields_mut(&mut out)) {
        if let Some(p) = pads.iter().find(|p| p.name == *name) {
            any = true;
            for (slot, v) in arr.iter_mut().zip(&p.pressure) {
                *slot = if v.is_finite() {
                    v.round().clamp(f32::from(i16::MIN), f32::from(i16::MAX)) as i16
                } else {
                    0
                };
            }
        }
    }
    any.then_some(out)
}

/// The driver's `LR` argument: `l` or `r` (its default, also for a side-less device).
pub fn side_suffix(side: Side) -> &'static str {
    match side {
        Side::Left => "l",
        _ => "r",
    }
}

/// (ctrl, state, touch) topics of `side`'s hand.
pub fn topics(side: Side) -> (String, String, String) {
    let lr = side_suffix(side);
    (
        format!("{CTRL_TOPIC_PREFIX}/{lr}"),
        format!("{STATE_TOPIC_PREFIX}/{lr}"),
        format!("{TOUCH_TOPIC_PREFIX}/{lr}"),
    )
}

/// Decodes an `inspire_hand_ctrl` for the front's table: `Ok(None)` for the driver's no
/// operation (nothing to move), else the joints the message sets (the rules above).
pub fn decode(msg: &InspireHandCtrl, front: &DeviceTable) -> Result<Option<FrontCommand>, Rejection> {
    let known = MODE_ANGLE | MODE_POS | MODE_FORCE | MODE_SPEED;
    if msg.mode & !known != 0 {
        return Err(Rejection::UnknownMode(msg.mode as u8));
    }
    for (bit, arr) in [
        (MODE_ANGLE, &msg.angle_set),
        (MODE_POS, &msg.pos_set),
        (MODE_FORCE, &msg.force_set),
        (MODE_SPEED, &msg.speed_set),
    ] {
        if msg.mode & bit != 0 && arr.len() != ACTUATORS {
            return Err(Rejection::WrongCount {
                got: arr.len(),
                want: ACTUATORS,
            });
        }
    }
    if msg.mode & MODE_POS != 0 {
        return Err(Rejection::UnknownMode(msg.mode as u8));
    }
    if msg.mode & MODE_ANGLE == 0 {
        return Ok(None);
    }
    let mut joints = vec![None; front.joint_count()];
    for map in &front.joints {
        let v = msg.angle_set[map.wire_index];
        if v == -1 {
            continue;
        }
        joints[front.joint_by_name(map.name).map(|id| id.index()).unwrap_or(0)] = Some(JointCommand::hold(
            map.q_from_wire(f32::from(v)),
            front.hold_kp,
            front.hold_kd,
        ));
    }
    if joints.iter().all(Option::is_none) {
        return Ok(None);
    }
    Ok(Some(FrontCommand {
        joints,
        timeout_bit: false,
        tag: 0,
    }))
}

/// `inspire_hand_state` from the routed joint state (front order) and the device's state.
pub fn encode_state(front: &DeviceTable, joints: &[JointState], st: &HandState) -> InspireHandState {
    let mut out = InspireHandState::sdk_default();
    let mut err = 0u8;
    if st.faults & (faults::MOTOR_ERROR | faults::HARDWARE) != 0 {
        err |= ERR_MOTOR_FAULT;
    }
    if st.freshness == Freshness::Stale || st.faults & faults::LINK_DOWN != 0 {
        err |= ERR_COMMUNICATION;
    }
    let status = if st.faults & faults::HARDWARE != 0 {
        STATUS_ACTUATOR_FAULT
    } else {
        STATUS_AT_POSITION
    };
    for (map, j) in front.joints.iter().zip(joints) {
        let i = map.wire_index;
        let a = map.q_to_wire(j.q);
        let a = if a.is_finite() {
            a.round().clamp(0.0, f32::from(UNITS_MAX)) as i16
        } else {
            0
        };
        out.angle_act[i] = a;
        out.pos_act[i] = UNITS_MAX - a;
        out.err[i] = err;
        out.status[i] = status;
        out.temperature[i] = j.temperature.unwrap_or(0.0).round().clamp(0.0, 255.0) as u8;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::DeviceKind;

    fn t() -> DeviceTable {
        DeviceKind::InspireFtp
            .table(Side::Left, &TableOverrides::default())
            .unwrap()
    }

    fn ctrl(mode: i8, angle: Vec<i16>) -> InspireHandCtrl {
        InspireHandCtrl {
            angle_set: angle,
            mode,
            ..InspireHandCtrl::sdk_default()
        }
    }

    #[test]
    fn angle_1000_is_open_and_0_closed() {
        let f = t();
        let open = decode(&ctrl(MODE_ANGLE, vec![1000; 6]), &f).unwrap().unwrap();
        let q: Vec<f32> = open.joints.iter().map(|j| j.unwrap().q).collect();
        for (v, want) in q.iter().zip([0.0, 0.0, 0.0, 0.0, 0.0, -0.1]) {
            assert!((v - want).abs() < 1e-5, "{q:?}");
        }
        let fist = decode(&ctrl(MODE_ANGLE, vec![0, 0, 0, 0, 1000, 1000]), &f)
            .unwrap()
            .unwrap();
        assert!((fist.joints[3].unwrap().q - 1.7).abs() < 1e-5);
        assert!(fist.joints[4].unwrap().q.abs() < 1e-5);
    }

    #[test]
    fn bad_input_rules() {
        let f = t();
        assert_eq!(
            decode(&ctrl(MODE_ANGLE, vec![0; 5]), &f),
            Err(Rejection::WrongCount { got: 5, want: 6 })
        );
        assert_eq!(
            decode(&ctrl(MODE_ANGLE, vec![]), &f),
            Err(Rejection::WrongCount { got: 0, want: 6 })
        );
        // A short array whose bit is clear is not looked at.
        let mut m = ctrl(MODE_ANGLE, vec![500; 6]);
        m.force_set = vec![1];
        assert!(decode(&m, &f).unwrap().is_some());
        m.mode |= MODE_FORCE;
        assert!(matches!(decode(&m, &f), Err(Rejection::WrongCount { got: 1, .. })));
        // pos_set cannot be honoured; unknown bits neither.
        assert_eq!(decode(&ctrl(MODE_POS, vec![0; 6]), &f), Err(Rejection::UnknownMode(2)));
        assert_eq!(
            decode(&ctrl(MODE_ANGLE | MODE_POS, vec![0; 6]), &f),
            Err(Rejection::UnknownMode(3))
        );
        assert_eq!(decode(&ctrl(16, vec![0; 6]), &f), Err(Rejection::UnknownMode(16)));
        assert_eq!(decode(&ctrl(-1, vec![0; 6]), &f), Err(Rejection::UnknownMode(255)));
        // No operation: mode 0, or force / speed only, or every angle -1.
        assert_eq!(decode(&ctrl(0, vec![0; 6]), &f), Ok(None));
        assert_eq!(decode(&ctrl(MODE_FORCE | MODE_SPEED, vec![0; 6]), &f), Ok(None));
        assert_eq!(decode(&ctrl(MODE_ANGLE, vec![-1; 6]), &f), Ok(None));
        // -1 leaves one joint alone; out of range is passed on for the table to clamp.
        let d = decode(&ctrl(MODE_ANGLE, vec![-1, 2000, -50, 500, 500, 500]), &f)
            .unwrap()
            .unwrap();
        assert!(d.joints[0].is_none());
        let j1 = d.joints[1].unwrap().q;
        assert!(j1 < 0.0 && !f.joints[1].limits.contains(j1), "{j1}");
        assert!(d.joints[2].unwrap().q > 1.7);
    }

    #[test]
    fn state_angles_faults_and_staleness() {
        let f = t();
        let joints: Vec<JointState> = [0.0, 0.85, 1.7, 2.0, 0.25, -0.1]
            .iter()
            .map(|&q| JointState {
                q,
                temperature: Some(36.4),
                ..Default::default()
            })
            .collect();
        let st = HandState {
            freshness: Freshness::Fresh,
            ..Default::default()
        };
        let s = encode_state(&f, &joints, &st);
        assert_eq!(s.angle_act, vec![1000, 500, 0, 0, 500, 1000]);
        assert_eq!(s.pos_act, vec![0, 500, 1000, 1000, 500, 0]);
        assert_eq!((s.err[0], s.status[0], s.temperature[0]), (0, 2, 36));
        let bad = HandState {
            faults: faults::HARDWARE | faults::LINK_DOWN,
            freshness: Freshness::Stale,
            ..Default::default()
        };
        let s = encode_state(&f, &joints, &bad);
        assert_eq!(s.err[5], ERR_MOTOR_FAULT | ERR_COMMUNICATION);
        assert_eq!(s.status[5], STATUS_ACTUATOR_FAULT);
        assert_eq!(encode_touch(&[]), None);
        assert_eq!(
            topics(Side::Right),
            (
                "rt/inspire_hand/ctrl/r".into(),
                "rt/inspire_hand/state/r".into(),
                "rt/inspire_hand/touch/r".into()
            )
        );
    }

    #[test]
    fn touch_segments_round_trip_as_named_pads() {
        let mut t = InspireHandTouch::sdk_default();
        t.fingerfour_top_touch[10] = 1234;
        t.palm_touch[111] = -7;
        t.fingerfive_middle_touch[8] = 9;
        let pads = pads_from_touch(&t);
        assert_eq!(pads.len(), 17);
        let total: usize = pads.iter().map(|p| p.pressure.len()).sum();
        assert_eq!(total, 1062);
        let top = pads.iter().find(|p| p.name == "index_top").unwrap();
        assert_eq!((top.rows, top.cols, top.pressure[10]), (12, 8, 1234.0));
        for p in &pads {
            assert_eq!(p.pressure.len(), usize::from(p.rows * p.cols), "{}", p.name);
        }
        assert_eq!(encode_touch(&pads), Some(t));
        // Out of int16 range clamps; a missing segment reads zeros.
        let mut one = vec![pads[16].clone()];
        one[0].pressure[0] = 1e9;
        let e = encode_touch(&one).unwrap();
        assert_eq!((e.palm_touch[0], e.fingerone_tip_touch[0]), (i16::MAX, 0));
    }
}
