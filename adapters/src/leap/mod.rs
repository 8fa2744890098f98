//! LEAP Hand v1: 16 Dynamixel XC330 on one U2D2 at 4 Mbaud, Protocol 2.0
//! ([`crate::dynamixel`]).
//!
//! * [`control_table`]: the XC330 units and every LEAP constant, with sources.
//! * [`table`]: the canonical joints (`index_0` .. `thumb_3`, URDF `0`..`15`), LEAP radians.
//! * [`device`]: [`device::LeapDevice`], the device loop (sync write goals, sync read present).
//! * [`servos`]: 16 servos' control tables answering instruction packets (the emulator's and
//!   the virtual bus front's).
//! * [`emulator`]: the emulated hand, in-process and on a pty.
//!
//! See docs/leap.md.

pub mod config;
pub mod control_table;
pub mod device;
pub mod emulator;
pub mod front;
pub mod kind;
pub mod servos;
pub mod table;

#[cfg(test)]
mod tests;
