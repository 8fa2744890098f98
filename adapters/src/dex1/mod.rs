//! Dex1-1 parallel gripper: mapping table, DDS adapter (client of dex1_1_service), emulator.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod follow;
pub mod front;
pub mod kind;
pub mod serve;
pub mod table;

/// dex1_1_service brakes (holds the measured position) this long after the last command
/// (docs/sources.md §4: "brakes after 1000 ms without a command").
pub const SERVICE_BRAKE_AFTER: std::time::Duration = std::time::Duration::from_millis(1000);

/// dex1_1_service's loop and state rate, Hz (docs/sources.md §4: "a 500 Hz loop"): the kind's
/// default device rate, the Dex1 front's state rate and the emulated service's loop.
pub const SERVICE_HZ: f64 = 500.0;
