//! BrainCo Revo2 dexterous hand (G1 / H1), reached over DDS as a client of
//! `brainco_hand_service` (docs/sources.md §7 "BrainCo Revo2"): mapping table, DDS-client
//! codec, service emulator, pure front codec, the front serving its interface (`serve`),
//! and its registry entry.
//!
//! Everything about the kind lives in this folder; the interface's standard topics live here
//! once ([`topics`]) and both the device side (`adapter`, `emulator`) and the front side
//! (`front`) use them.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod serve;
pub mod table;

use crate::model::Side;

/// Entries per hand in the service's `MotorCmds_` / `MotorStates_` (docs/sources.md §7).
pub const WIRE_LEN: usize = 6;

/// The service's (command, state) topics for `side`: `rt/brainco/{left,right}/{cmd,state}`
/// (docs/sources.md §7). `None` for a side the hand does not have (center).
pub fn topics(side: Side) -> Option<(String, String)> {
    match side {
        Side::Left | Side::Right => Some((format!("rt/brainco/{side}/cmd"), format!("rt/brainco/{side}/state"))),
        Side::Center => None,
    }
}

/// The speed (`dq`, 0..1, 1 = fastest) xr_teleoperate sends and the service's README
/// recommends (docs/sources.md §7); the device codec's default.
pub const DEFAULT_SPEED: f32 = 1.0;
