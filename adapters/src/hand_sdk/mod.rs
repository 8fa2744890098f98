//! G1 rt/hand_sdk: mapping table, adapter (ramped weight), ai_sport blend emulator.

pub mod adapter;
pub mod config;
pub mod emulator;
pub mod kind;
pub mod table;

/// `rt/hand_sdk` motors. Which finger or hand each drives is unpublished (docs/sources.md §6),
/// so they are named neutrally.
pub const JOINTS: [&str; 4] = ["motor_0", "motor_1", "motor_2", "motor_3"];
