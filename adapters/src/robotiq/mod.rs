//! Robotiq adaptive grippers (2F-85, 2F-140, Hand-E) over Modbus RTU (docs/robotiq.md).
//!
//! * [`regs`]: the request and status register images, pure encode and decode.
//! * [`table`]: the three variants and their canonical table.
//! * [`emulator`]: the emulated gripper, a pure state machine taking `now`.
//! * [`driver`]: what the device asks each cycle (reset, activate, move), a pure state machine.
//! * [`device`]: the [`device::RobotiqDevice`] loop over a [`device::Link`].

pub mod config;
pub mod device;
pub mod driver;
pub mod emulator;
pub mod front;
#[cfg(test)]
mod front_tests;
pub mod kind;
pub mod open;
pub mod regs;
pub mod rtu;
pub mod table;
pub mod urcap;

pub use table::Variant;
