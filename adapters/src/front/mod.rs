//! The fronts' wire codecs that belong to no device kind (handgate's own `canonical` messages,
//! ROS 2 `joint_state` and `joint_state_command`) and what every front codec shares: the rejection reasons and the
//! decoded command. The Dex3 and Dex1 service fronts' codecs live in their kind folders
//! (`dex3::front`, `dex1::front`). Pure functions (wire message ⇄ canonical, validated by the
//! rules in docs/fronts.md); the gateway's front registry (`handgate_gateway::fronts`) opens
//! their endpoints and runs them.
//!
//! Bad input rule, for every front: a message with the wrong entry count, a non-finite value,
//! an unknown mode/status, a wrong motor id or an unknown joint name is **rejected whole**
//! (nothing moves, it is counted by reason and logged at most once per second per front);
//! finite values outside a joint's limits are **clamped** by the device's table (counted).

pub mod canonical;
pub mod canonical_serve;
pub mod config;
pub mod core;
pub mod endpoint;
pub mod joint_state;
pub mod joint_state_command;
pub mod joint_state_command_serve;
pub mod joint_state_serve;
pub mod kind;
pub mod one_hand;
pub mod plan;
pub mod serve;
pub mod sources;
pub mod stream;

use crate::mapping::WireTarget;
use crate::model::JointCommand;

/// Why a front rejected a message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rejection {
    #[error("expected {want} entries, got {got}")]
    WrongCount { got: usize, want: usize },
    #[error("non-finite value in entry {0}")]
    NonFinite(usize),
    #[error("entry {index} carries motor id {id}")]
    WrongId { index: usize, id: u8 },
    /// A Dex3 command whose mode byte is 0 on an entry other than the first: the SDK's
    /// default, never set by the client. Motor id 0, status 0 (lock): a G1's hand service
    /// would not move that motor either.
    #[error(
        "entry {index} has mode byte 0: motor id 0 and status 0 (lock), so a G1's hand would not \
         move either"
    )]
    ModeUnset { index: usize },
    #[error("entry {index} has unknown motor status {status}")]
    UnknownStatus { index: usize, status: u8 },
    #[error("unknown command mode {0}")]
    UnknownMode(u8),
    #[error("unknown joint {0:?}")]
    UnknownJoint(String),
    /// A message that names one joint twice (which of the two is meant?).
    #[error("joint {0:?} named twice")]
    DuplicateJoint(String),
    /// A message that names no joint (a JointState command with no names).
    #[error("no joint named")]
    NoJoints,
    #[error("closure {0} is not finite")]
    BadClosure(f32),
    /// A message of another type than the front reads (impossible through
    /// [`serve::Inbox`], which only queues the front's own type; counted should it happen).
    #[error("a message of another type than {0}")]
    WrongType(&'static str),
}

impl Rejection {
    /// Whether the rejection is a client's mistake it repeats on every message (a field it
    /// never sets): logged once per client with its fix ([`core::Log::Advice`]), not once a
    /// second.
    pub fn once_per_client(&self) -> bool {
        matches!(self, Rejection::ModeUnset { .. })
    }

    /// The fix of a client's mistake, where it is a known one (said with the rejection).
    pub fn fix(&self) -> Option<&'static str> {
        match self {
            Rejection::ModeUnset { .. } => Some(
                "set each entry's mode to id | 0x10 (motor id = the entry's index, status 1 = FOC), \
                 as unitree_sdk2's Dex3 example does",
            ),
            _ => None,
        }
    }

    /// A short stable reason key for counters and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            Rejection::WrongCount { .. } => "wrong_count",
            Rejection::NonFinite(_) => "non_finite",
            Rejection::WrongId { .. } => "wrong_id",
            Rejection::ModeUnset { .. } => "mode_unset",
            Rejection::UnknownStatus { .. } => "unknown_status",
            Rejection::UnknownMode(_) => "unknown_mode",
            Rejection::UnknownJoint(_) => "unknown_joint",
            Rejection::DuplicateJoint(_) => "duplicate_joint",
            Rejection::NoJoints => "no_joints",
            Rejection::BadClosure(_) => "bad_closure",
            Rejection::WrongType(_) => "wrong_type",
        }
    }
}

/// A decoded front command, in the front table's canonical order.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontCommand {
    pub joints: Vec<Option<JointCommand>>,
    /// The client asked for the motors' 1 s timeout protection (Dex3 RIS bit 7).
    pub timeout_bit: bool,
    /// Client tag echoed back in state (HandCmd_.reserve[0]).
    pub tag: u32,
}

/// unitree_go `MotorState_.lost` of a state in a hardware fault.
pub const FAULT_LOST: u32 = 0xFFFF_FFFF;

/// unitree_go `MotorState_.lost` of state `st` at `now` for the services that mark a fault
/// there (dex1_1_service, DFX_inspire_service): [`FAULT_LOST`] in a hardware fault, else
/// [`stale_lost`].
pub fn fault_or_stale_lost(st: &crate::model::HandState, now: std::time::Instant) -> u32 {
    if st.faults & crate::model::faults::HARDWARE != 0 {
        FAULT_LOST
    } else {
        stale_lost(st, now)
    }
}

/// The targets of a unitree_go `MotorCmds_` that must carry `want` entries, checked whole:
/// the count, then every field of every entry finite (so a bad message moves nothing).
pub fn go_targets(msg: &handgate_idl::unitree_go::MotorCmds_, want: usize) -> Result<Vec<WireTarget>, Rejection> {
    if msg.cmds.len() != want {
        return Err(Rejection::WrongCount {
            got: msg.cmds.len(),
            want,
        });
    }
    msg.cmds
        .iter()
        .enumerate()
        .map(|(i, m)| checked_target(i, [m.q, m.dq, m.tau, m.kp, m.kd]))
        .collect()
}

/// unitree_go `MotorState_.lost` of a state never measured: the stale age in ms, saturated
/// (the services' convention, shared by every front publishing `MotorStates_`).
pub const NEVER_MEASURED_LOST: u32 = 0xFFFF_FFFE;

/// unitree_go `MotorState_.lost` of state `st` at `now`: 0 while fresh, else how long it has
/// gone unmeasured in ms, saturating at [`NEVER_MEASURED_LOST`] (also when never measured).
pub fn stale_lost(st: &crate::model::HandState, now: std::time::Instant) -> u32 {
    if st.freshness != crate::model::Freshness::Stale {
        return 0;
    }
    st.age(now)
        .map(|a| a.as_millis().min(u128::from(NEVER_MEASURED_LOST)) as u32)
        .unwrap_or(NEVER_MEASURED_LOST)
}

/// Entry `index`'s five command fields as a wire target, refused whole when any of them is
/// not finite.
pub fn checked_target(index: usize, [q, dq, tau, kp, kd]: [f32; 5]) -> Result<WireTarget, Rejection> {
    if [q, dq, tau, kp, kd].iter().all(|x| x.is_finite()) {
        Ok(WireTarget { q, dq, tau, kp, kd })
    } else {
        Err(Rejection::NonFinite(index))
    }
}
