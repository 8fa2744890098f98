//! G1 rt/hand_sdk: mapping table, adapter (ramped weight), ai_sport blend emulator.

pub mod adapter;
pub mod emulator;
pub mod table;
