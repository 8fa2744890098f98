//! The BrainCo Revo2 over DDS, as a client of `brainco_hand_service` (docs/sources.md §7):
//! publishes unitree_go `MotorCmds_` with 6 entries on `rt/brainco/{side}/cmd` and reads
//! `MotorStates_` from `rt/brainco/{side}/state`.
//!
//! Command: every entry carries the joint's normalised position `q` in [0, 1] (1 = closed,
//! from the table) and the profile's speed in `dq` (0..1, default 1.0 as xr_teleoperate
//! sends); `tau`, `kp`, `kd` and `mode` are 0 (the service ignores them). The service holds its
//! last command forever (no timeout), so a safe "limp" cannot be expressed: it is sent as a
//! hold of the position measured when the limp began (the fingers stop where they are), kept
//! until it ends (never re-taken from each new measurement: docs/adapters.md, "Holds"), and
//! nothing is sent before a position was measured. State: `q` = position, `dq` = speed, `tau_est` = motor current (A,
//! an inference of §7; reported as the joint's `tau` unchanged). A sample that is not 6
//! entries or has a non-finite `q` is not this hand's state and is dropped; stale/lost
//! handling is `DdsDevice`'s (no sample for `stale_after` → stale, link down).

use handgate_idl::unitree_go;

use super::WIRE_LEN;
use crate::control::{Active, MeasuredHold};
use crate::dds_device::DdsCodec;
use crate::mapping::{DeviceTable, WireTarget};
use crate::model::{HandState, SafeAction};

/// Codec of one BrainCo hand.
#[derive(Debug, Clone, PartialEq)]
pub struct BraincoCodec {
    /// `dq` of every entry: the fingers' speed, (0, 1].
    pub speed: f32,
    /// The measured wire positions, and the hold of them the "limp" safe state sends.
    limp: MeasuredHold<[f32; WIRE_LEN]>,
}

impl BraincoCodec {
    /// A codec sending `speed` (clamped to [0, 1] as the service does) in every entry's `dq`.
    pub fn new(speed: f32) -> Self {
        Self {
            speed: if speed.is_finite() { speed.clamp(0.0, 1.0) } else { 1.0 },
            limp: MeasuredHold::default(),
        }
    }

    /// Fills `msg` with one entry per wire position in `q` (its buffer reused).
    fn message(&self, q: impl Iterator<Item = f32>, msg: &mut unitree_go::MotorCmds_) {
        msg.cmds.clear();
        msg.cmds.extend(q.map(|q| unitree_go::MotorCmd_ {
            q: if q.is_finite() { q.clamp(0.0, 1.0) } else { 0.0 },
            dq: self.speed,
            ..Default::default()
        }));
    }
}

impl Default for BraincoCodec {
    fn default() -> Self {
        Self::new(super::DEFAULT_SPEED)
    }
}

/// Canonical state from one hand's `MotorStates_` into `st` (its buffers reused); `false` if
/// it is not 6 entries with finite positions.
pub fn decode_state(s: &unitree_go::MotorStates_, table: &DeviceTable, st: &mut HandState) -> bool {
    if s.states.len() != WIRE_LEN || s.states.iter().any(|m| !m.q.is_finite()) {
        return false;
    }
    table.state_from_wire_into(&mut st.joints, |i| s.states.get(i).map(|m| (m.q, m.dq, m.tau_est)));
    true
}

impl DdsCodec for BraincoCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;
    /// Six entries per message, so `handgate doctor` tells another hand on these topics.
    const ENTRIES: Option<usize> = Some(WIRE_LEN);

    fn encode_into(&mut self, active: &Active, table: &DeviceTable, _dt: f32, msg: &mut Self::Cmd) -> bool {
        if !matches!(active, Active::Safe(SafeAction::Limp, _)) {
            self.limp.release();
        }
        match active {
            Active::Idle => false,
            Active::Safe(SafeAction::Limp, _) => match self.limp.hold() {
                Some(m) => {
                    self.message(m.into_iter(), msg);
                    true
                }
                None => false,
            },
            Active::Command(t) | Active::Safe(_, t) => {
                if table.wire_len() != WIRE_LEN {
                    return false;
                }
                let mut q = [WireTarget::LIMP.q; WIRE_LEN];
                for (i, w) in table.wire_targets(t) {
                    q[i] = w.q;
                }
                self.message(q.into_iter(), msg);
                true
            }
        }
    }

    fn decode_into(&mut self, s: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool {
        if !decode_state(s, table, st) {
            return false;
        }
        let mut m = [0.0; WIRE_LEN];
        for (m, s) in m.iter_mut().zip(&s.states) {
            *m = s.q;
        }
        self.limp.measure(m);
        true
    }
}
