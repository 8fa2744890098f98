//! DYNAMIXEL Protocol 2.0, shared by every kind that drives Dynamixel servos (the SAKE
//! EZGripper's MX-64, the LEAP Hand's XC330):
//!
//! * [`protocol`]: the packet codec (CRC, byte stuffing, instructions including Sync Read
//!   0x82, Sync Write 0x83 and Fast Sync Read 0x8A, status parsing): pure, fuzzed.
//! * [`control_table`]: the addresses the MX(2.0) and X series share.
//!
//! See docs/sources.md ("Dynamixel Protocol 2.0") for why this is handgate's own codec and not
//! the `dynamixel2` crate.

pub mod control_table;
pub mod protocol;

#[cfg(test)]
mod protocol_tests;
