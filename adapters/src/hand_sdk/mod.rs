//! G1 rt/hand_sdk: mapping table, adapter (ramped weight), ai_sport blend emulator.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod kind;
pub mod table;

/// The topic ai_sport reads the user's blend from (docs/sources.md §6); a device's default.
pub const TOPIC: &str = "rt/hand_sdk";
/// Entries in a `rt/hand_sdk` message, the number ai_sport expects (docs/sources.md §6).
pub const MOTORS: usize = 4;

/// `rt/hand_sdk` motors. Which finger or hand each drives is unpublished (docs/sources.md §6),
/// so they are named neutrally.
pub const JOINTS: [&str; MOTORS] = ["motor_0", "motor_1", "motor_2", "motor_3"];
