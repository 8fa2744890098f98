//! SAKE EZGripper over DYNAMIXEL Protocol 2.0 (MX-64 servos on a 1 Mbaud serial bus).
//!
//! * [`crate::dynamixel`]: the Protocol 2.0 codec (pure, fuzzed), shared with the LEAP Hand.
//! * [`control_table`]: MX-64(2.0) addresses, units and every EZGripper constant, with sources.
//! * [`crate::serial`]: the byte-pipe seam ([`crate::serial::Transport`]), the raw-termios serial port and the pty.
//! * [`driver`]: [`driver::EzGripperBus`], one thread per bus serving all its grippers.
//! * [`emulator`]: a virtual MX-64 bus on a pseudo-terminal, with wire timing and faults.
//!
//! See docs/ezgripper.md.

pub mod adapter;
pub mod config;
pub mod control_table;
pub mod driver;
pub mod emulator;
pub mod kind;
pub mod open;
pub mod table;

#[cfg(test)]
mod bus_tests;

pub use crate::dynamixel::protocol::ServoId;
pub use control_table::{EzGripperParams, HardwareError};
pub use driver::{
    BusConfig, BusStats, Calibration, EzError, EzGripperBus, GraspState, Gripper, GripperConfig, GripperCounters,
    GripperState, Side, Target,
};
