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
use crate::mapping::DeviceTable;
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

    fn message(&self, q: impl Iterator<Item = f32>) -> unitree_go::MotorCmds_ {
        unitree_go::MotorCmds_ {
            cmds: q
                .map(|q| unitree_go::MotorCmd_ {
                    q: if q.is_finite() { q.clamp(0.0, 1.0) } else { 0.0 },
                    dq: self.speed,
                    ..Default::default()
                })
                .collect(),
        }
    }
}

impl Default for BraincoCodec {
    fn default() -> Self {
        Self::new(super::DEFAULT_SPEED)
    }
}

/// Canonical state from one hand's `MotorStates_`, or `None` if it is not 6 entries with
/// finite positions.
pub fn decode_state(s: &unitree_go::MotorStates_, table: &DeviceTable) -> Option<HandState> {
    if s.states.len() != WIRE_LEN || s.states.iter().any(|m| !m.q.is_finite()) {
        return None;
    }
    let q: Vec<f32> = s.states.iter().map(|m| m.q).collect();
    let dq: Vec<f32> = s.states.iter().map(|m| m.dq).collect();
    let tau: Vec<f32> = s.states.iter().map(|m| m.tau_est).collect();
    Some(HandState {
        joints: table.state_from_wire(&q, &dq, &tau),
        ..Default::default()
    })
}

impl DdsCodec for BraincoCodec {
    type Cmd = unitree_go::MotorCmds_;
    type State = unitree_go::MotorStates_;

    fn encode(&mut self, active: &Active, table: &DeviceTable, _dt: f32) -> Option<Self::Cmd> {
        if !matches!(active, Active::Safe(SafeAction::Limp, _)) {
            self.limp.release();
        }
        match active {
            Active::Idle => None,
            Active::Safe(SafeAction::Limp, _) => {
                let m = self.limp.hold()?;
                Some(self.message(m.into_iter()))
            }
            Active::Command(t) | Active::Safe(_, t) => {
                let w = table.to_wire(t);
                if w.len() != WIRE_LEN {
                    return None;
                }
                Some(self.message(w.iter().map(|w| w.q)))
            }
        }
    }

    fn decode(&mut self, s: &Self::State, table: &DeviceTable) -> Option<HandState> {
        let st = decode_state(s, table)?;
        let mut m = [0.0; WIRE_LEN];
        for (m, s) in m.iter_mut().zip(&s.states) {
            *m = s.q;
        }
        self.limp.measure(m);
        Some(st)
    }
}
