//! Dex1-1 parallel gripper: mapping table, DDS adapter (client of dex1_1_service), emulator.

pub mod adapter;
pub mod emulator;
pub mod table;
