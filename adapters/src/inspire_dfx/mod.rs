//! Inspire DFX (RH56DFX) hands on a G1, through `DFX_inspire_service` (docs/sources.md §7
//! "Inspire DFX"): one service, one topic pair, **12 entries for both hands in one message**
//! (0–5 right, 6–11 left), `q` in [0, 1] with 1 = open, only `q` used.
//!
//! - `table`: the canonical ↔ wire mapping per side (URDF radians, positive = closing);
//! - `adapter`: the DDS-client codec (handgate drives the real service as a client);
//! - `emulator`: the service's emulator (both hands, one loop);
//! - `kind` / `open`: the registry entry and how a device opens on each backend;
//! - `front`: the pure codec of the service's own interface (a front serving `rt/inspire/*`);
//! - `serve`: that front's registry entry (`FrontKind::InspireDfx`) and endpoints.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod serve;
pub mod table;

use crate::model::Side;

/// The topic the service subscribes (its `--namespace` default `inspire`; docs/sources.md §7).
pub const CMD_TOPIC: &str = "rt/inspire/cmd";
/// The topic the service publishes its state on (docs/sources.md §7).
pub const STATE_TOPIC: &str = "rt/inspire/state";
/// Entries in every command and state message: both hands (docs/sources.md §7).
pub const ENTRIES: usize = 12;
/// Entries per hand.
pub const HAND_ENTRIES: usize = 6;
/// The service stops writing targets this long after the last command (docs/sources.md §7:
/// the subscription's 1000 ms timeout).
pub const SERVICE_TIMEOUT: std::time::Duration = std::time::Duration::from_millis(1000);
/// The service's loop rate: a `RecurrentThread` with a 10 000 µs period (docs/sources.md §7).
pub const SERVICE_RATE_HZ: f64 = 100.0;

/// The element (hand) of the 12-entry message a side occupies: 0 = right (entries 0–5),
/// 1 = left (entries 6–11). A center side has none.
pub fn element(side: Side) -> Option<usize> {
    match side {
        Side::Right => Some(0),
        Side::Left => Some(1),
        Side::Center => None,
    }
}
