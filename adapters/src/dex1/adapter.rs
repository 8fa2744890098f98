//! Dex1-1 over DDS, as a client of dex1_1_service (or of SAKE's EZGripper driver, which
//! presents the same interface). Three wire variants exist in the field (docs/sources.md §4):
//!
//! | variant | cmd / state topics | types | elements |
//! |---|---|---|---|
//! | `Go` (a device's default, real systems) | `rt/dex1/{side}/cmd`, `rt/dex1/{side}/state` | unitree_go MotorCmds_ / MotorStates_ | 1 |
//! | `Hg` (the seed spec) | same topics | unitree_hg HandCmd_ / HandState_ | 1 |
//! | `Actuator` (old xr_teleoperate) | `rt/unitree_actuator/cmd`, `/state` | unitree_go MotorCmds_ / MotorStates_ | 2: index 0 right, 1 left |
//! | `Auto` (fronts only, their default) | `Go` until a client appears, then each client's | | |

use handgate_idl::{unitree_go, unitree_hg};

use crate::control::Active;
use crate::dds_device::{DdsCodec, MessageElement, SharedMessage};
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{faults, HandState, Side};

/// Which Dex1 interface the peer speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// `rt/dex1/{side}/{cmd,state}`, unitree_go MotorCmds_/MotorStates_, 1 element.
    #[default]
    Go,
    /// `rt/dex1/{side}/{cmd,state}`, unitree_hg HandCmd_/HandState_ (the seed spec).
    Hg,
    /// `rt/unitree_actuator/{cmd,state}`, unitree_go, 2 elements (0 = right, 1 = left).
    Actuator,
    /// Fronts only (the fronts' default): `go` on `rt/dex1/{side}/*` until a client appears,
    /// then every variant its clients speak, `rt/unitree_actuator/*` included
    /// (`crate::dex1::follow`). Not a device's variant: a device speaks one.
    Auto,
}

impl std::fmt::Display for Variant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Variant::Go => "go",
            Variant::Hg => "hg",
            Variant::Actuator => "actuator",
            Variant::Auto => "auto",
        })
    }
}

/// Default topics of a variant for a side.
pub fn topics(variant: Variant, side: Side) -> (String, String) {
    variant.topics(side)
}

impl Variant {
    /// (command topic, state topic) for `side` (ignored by [`Variant::Actuator`]).
    pub fn topics(self, side: Side) -> (String, String) {
        match self {
            Variant::Go | Variant::Hg | Variant::Auto => {
                (format!("rt/dex1/{side}/cmd"), format!("rt/dex1/{side}/state"))
            }
            Variant::Actuator => ("rt/unitree_actuator/cmd".into(), "rt/unitree_actuator/state".into()),
        }
    }

    /// Which gripper each message element drives.
    pub fn layout(self, side: Side) -> Vec<Side> {
        match self {
            Variant::Go | Variant::Hg | Variant::Auto => vec![side],
            Variant::Actuator => vec![Side::Right, Side::Left],
        }
    }
}

/// Element index of `side` in the 2-element `rt/unitree_actuator` messages.
pub fn actuator_index(side: Side) -> usize {
    match side {
        Side::Right => 0,
        Side::Left | Side::Center => 1,
    }
}

/// Value the EZGripper driver (and handgate's Dex1 front) put in `lost` on a hardware fault.
pub const LOST_FAULT: u32 = 0xFFFF_FFFF;
/// `mode` the EZGripper driver reports on a hardware fault.
pub const MODE_FAULT: u8 = 255;

/// `mode` 0: dex1_1_service ignores it.
fn go_cmd(w: &WireTarget) -> unitree_go::MotorCmd_ {
    (*w).into()
}

/// Actuator variant: the latest wire command each handgate device on one command topic sent
/// for its own gripper (element [`actuator_index`]). A left and a right device share it, so
/// every message carries both grippers' own targets.
pub type SharedElements = SharedMessage<unitree_go::MotorCmd_, 2>;

/// Codec for the `unitree_go` variants (Go and Actuator).
#[derive(Debug, Clone)]
pub struct Dex1GoCodec {
    pub variant: Variant,
    pub side: Side,
    /// Actuator variant: this gripper's element of the message shared with the other
    /// gripper's device, and the hold of the other gripper (its measured wire q) our messages
    /// carry while no handgate device drives it.
    share: MessageElement<unitree_go::MotorCmd_, f32, 2>,
}

impl Dex1GoCodec {
    pub fn new(variant: Variant, side: Side) -> Self {
        Self::with_shared(variant, side, SharedElements::default())
    }

    /// The codec of `side`'s gripper, sharing `shared` with the other element's device on
    /// the same command topic (actuator variant).
    pub fn with_shared(variant: Variant, side: Side, shared: SharedElements) -> Self {
        Self {
            variant,
            side,
            share: MessageElement::new(shared, actuator_index(side)),
        }
    }

    fn index(&self) -> usize {
        match self.variant {
            Variant::Actuator => self.share.element(),
            _ => 0,
        }
    }
}

/// The wire target of the gripper (wire index 0) for the targets in force.
fn wire_target(active: &Active, table: &DeviceTable) -> Option<WireTarget> {
    match active {
        Active::Idle => None,
        Active::Command(t) | Active::Safe(_, t) => Some(
            table
                .wire_targets(t)
                .find(|(i, _)| *i == 0)
                .map_or(WireTarget::LIMP, |(_, w)| w),
        ),
    }
}

/// The gripper's joint (wire index 0) from its measured (q, dq, tau), into `st`.
fn gripper_joint(table: &DeviceTable, st: &mut HandState, (q, dq, tau): (f32, f32, f32), temperature: f32) {
    table.state_from_wire_into(&mut st.joints, |i| (i == 0).then_some((q, dq, tau)));
    st.joints[0].temperature = Some(temperature);
}

/// Canonical state from one gripper's unitree_go MotorState_, into `st` (its buffers reused).
pub fn decode_go_state(m: &unitree_go::MotorState_, table: &DeviceTable, st: &mut HandState) {
    gripper_joint(table, st, (m.q, m.dq, m.tau_est), m.temperature as f32);
    let mut f = 0;
    if m.mode == MODE_FAULT || m.lost == LOST_FAULT {
        f |= faults::HARDWARE;
    }
    st.faults = f;
    st.mode = m.mode;
}

impl DdsCodec for Dex1GoCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut Self::Cmd) -> bool {
        let Some(w) = wire_target(active, table) else {
            // Our messages stop holding the other gripper: the next one begins a new hold.
            self.share.release();
            return false;
        };
        let own = go_cmd(&w);
        msg.cmds.clear();
        match self.variant {
            Variant::Actuator => {
                // The other gripper: its own device's latest command, else held where it was
                // measured when this hold began; without either we cannot hold it: stay silent.
                let hold = |q| unitree_go::MotorCmd_ {
                    q,
                    kp: table.hold_kp,
                    kd: table.hold_kd,
                    ..Default::default()
                };
                let Some(both) = self.share.compose(Some(own), hold) else {
                    return false;
                };
                msg.cmds.extend(both);
            }
            _ => msg.cmds.push(own),
        }
        true
    }

    fn reconnected(&mut self) {
        self.share.release();
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        let need = if self.variant == Variant::Actuator { 2 } else { 1 };
        if s.states.len() < need {
            return false;
        }
        if self.variant == Variant::Actuator {
            let other = 1 - self.index();
            self.share.measure(other, s.states[other].q);
        }
        decode_go_state(&s.states[self.index()], table, st);
        true
    }
}

/// Codec for the seed spec's `unitree_hg` variant.
#[derive(Debug, Clone, Default)]
pub struct Dex1HgCodec;

impl DdsCodec for Dex1HgCodec {
    type Cmd = unitree_hg::HandCmd_;
    type State = unitree_hg::HandState_;

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut Self::Cmd) -> bool {
        let Some(w) = wire_target(active, table) else {
            return false;
        };
        msg.motor_cmd.clear();
        msg.motor_cmd.push(w.into());
        msg.reserve = [0; 4];
        true
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        let Some(m) = s.motor_state.first() else {
            return false;
        };
        gripper_joint(table, st, (m.q, m.dq, m.tau_est), m.temperature[0] as f32);
        st.faults = if m.motorstate != 0 { faults::MOTOR_ERROR } else { 0 };
        st.mode = m.mode;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn go_variant_encodes_one_element_in_radians() {
        let t = crate::dex1::table::table(Side::Left, 5.4);
        let mut c = Dex1GoCodec::new(Variant::Go, Side::Left);
        let closed = t.closure_targets(1.0, None).unwrap();
        let msg = c.encode(&Active::Command(closed), &t, 0.005).unwrap();
        assert_eq!(msg.cmds.len(), 1);
        assert_eq!(msg.cmds[0].q, 0.0);
        assert_eq!(msg.cmds[0].kp, 5.0);
        let open = t.closure_targets(0.0, None).unwrap();
        assert_eq!(c.encode(&Active::Command(open), &t, 0.005).unwrap().cmds[0].q, 5.4);
        assert!(c.encode(&Active::Idle, &t, 0.005).is_none());
    }

    #[test]
    fn actuator_variant_holds_the_other_gripper_and_uses_index_0_for_right() {
        let t = crate::dex1::table::table(Side::Right, 5.4);
        let mut c = Dex1GoCodec::new(Variant::Actuator, Side::Right);
        let tg = t.closure_targets(0.5, None).unwrap();
        assert!(
            c.encode(&Active::Command(tg.clone()), &t, 0.005).is_none(),
            "silent until the other is measured"
        );
        let mut st = unitree_go::MotorStates_::with_len(2);
        st.states[0].q = 1.0; // right
        st.states[1].q = 4.0; // left
        let s = c.decode(&st, &t).unwrap();
        assert!(
            (s.joints[0].q - 4.4).abs() < 1e-5,
            "right jaw measured from open: 5.4 - 1.0"
        );
        let msg = c.encode(&Active::Command(tg), &t, 0.005).unwrap();
        assert_eq!(msg.cmds.len(), 2);
        assert!((msg.cmds[0].q - 2.7).abs() < 1e-5);
        assert_eq!(msg.cmds[1].q, 4.0);
    }

    /// The other gripper is held where it was measured when the hold began, not re-taken from
    /// every new measurement (docs/adapters.md, "Holds"); a silence or a reconnect begins a
    /// new hold.
    #[test]
    fn actuator_variant_holds_the_other_gripper_where_the_hold_began() {
        let t = crate::dex1::table::table(Side::Right, 5.4);
        let mut c = Dex1GoCodec::new(Variant::Actuator, Side::Right);
        let tg = Active::Command(t.closure_targets(0.5, None).unwrap());
        let mut st = unitree_go::MotorStates_::with_len(2);
        let mut left_at = |c: &mut Dex1GoCodec, q: f32| {
            st.states[1].q = q;
            c.decode(&st, &t).unwrap();
        };
        left_at(&mut c, 4.0);
        assert_eq!(c.encode(&tg, &t, 0.002).unwrap().cmds[1].q, 4.0);
        left_at(&mut c, 3.99);
        left_at(&mut c, 3.98);
        assert_eq!(c.encode(&tg, &t, 0.002).unwrap().cmds[1].q, 4.0, "kept while it sags");
        assert!(c.encode(&Active::Idle, &t, 0.002).is_none());
        assert_eq!(c.encode(&tg, &t, 0.002).unwrap().cmds[1].q, 3.98, "a new hold");
        left_at(&mut c, 3.5);
        c.reconnected();
        assert_eq!(c.encode(&tg, &t, 0.002).unwrap().cmds[1].q, 3.5, "after a reconnect");
    }

    /// Two actuator devices (right and left) sharing the topic: every message carries both
    /// grippers' own commands, whichever device writes last.
    #[test]
    fn actuator_pair_sends_both_grippers_targets() {
        let (tr, tl) = (
            crate::dex1::table::table(Side::Right, 5.4),
            crate::dex1::table::table(Side::Left, 5.4),
        );
        let shared = SharedElements::default();
        let mut r = Dex1GoCodec::with_shared(Variant::Actuator, Side::Right, shared.clone());
        let mut l = Dex1GoCodec::with_shared(Variant::Actuator, Side::Left, shared);
        let mut st = unitree_go::MotorStates_::with_len(2);
        st.states[0].q = 5.0;
        st.states[1].q = 5.0;
        r.decode(&st, &tr).unwrap();
        l.decode(&st, &tl).unwrap();
        // Right closes (wire 0), left half open (2.7); the left writes last.
        r.encode(&Active::Command(tr.closure_targets(1.0, None).unwrap()), &tr, 0.005)
            .unwrap();
        let msg = l
            .encode(&Active::Command(tl.closure_targets(0.5, None).unwrap()), &tl, 0.005)
            .unwrap();
        assert!(
            msg.cmds[0].q.abs() < 1e-5,
            "the right gripper's own target, not its 5.0: {msg:?}"
        );
        assert!((msg.cmds[1].q - 2.7).abs() < 1e-5, "{msg:?}");
    }

    #[test]
    fn fault_markers_become_hardware_fault() {
        let t = crate::dex1::table::table(Side::Left, 5.4);
        let m = unitree_go::MotorState_ {
            mode: MODE_FAULT,
            lost: LOST_FAULT,
            ..Default::default()
        };
        let mut st = HandState::default();
        decode_go_state(&m, &t, &mut st);
        assert_ne!(st.faults & faults::HARDWARE, 0);
    }
}
