//! The Modbus kit: what every Modbus hand (Robotiq 2F/Hand-E, Inspire RH56 over RTU and the
//! DFTP's Modbus TCP, and the next one) shares.
//!
//! * [`pdu`]: request and response PDUs for FC03, FC04, FC06, FC16 and FC23, exceptions.
//! * [`rtu`]: RTU framing (slave id, CRC-16/MODBUS), cut from a byte stream by length; the
//!   3.5-character frame gap.
//! * [`tcp`]: the MBAP header of Modbus TCP.
//! * [`server`]: a device's registers ([`server::RegisterMap`]) and the answer to a request,
//!   with or without exception responses.
//! * [`master`]: blocking masters: RTU on a serial line (the line's arbiter, per-slave
//!   counters), RTU over TCP, Modbus TCP.
//! * [`session`]: RTU and Modbus TCP served over a byte stream ([`crate::front::stream`]):
//!   the sessions a Modbus front or a pty emulator runs.
//!
//! Sans-IO and allocation-free on the hot path: decoders borrow from the caller's buffer,
//! encoders append to a caller-owned `Vec` that is reused. Why our own codec and not a crate:
//! docs/sources.md "Modbus".

pub mod master;
pub mod pdu;
pub mod rtu;
pub mod server;
pub mod session;
pub mod tcp;

#[cfg(test)]
mod codec_tests;
#[cfg(test)]
mod master_tests;
#[cfg(test)]
mod server_tests;
#[cfg(test)]
mod session_tests;

pub use pdu::{Exception, PduError, Regs, Request, Response, Table};
pub use rtu::{Frame, RtuError};
pub use tcp::{Mbap, TcpError};
