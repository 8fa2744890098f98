//! Inspire RH56DFX / RH56E2 / RH56DFTP hands driven directly (docs/inspire-rh56.md), as labs
//! run them on non-Unitree arms: the hand's own serial protocol on RS-485, several hands on
//! one line (ids 1 and 2) served by one thread.
//!
//! - [`regs`]: the register map (byte addresses, with sources);
//! - [`proto`]: the serial protocol's codec (pure, fuzzed);
//! - [`emulator`]: the hand as a pure state machine taking `now`, and a line of hands;
//! - [`bus`]: one line's thread (the arbiter) and the in-process emulated line;
//! - [`adapter`]: the `HandDevice`; [`kind`] / [`config`]: the registry entry and its keys;
//! - [`pty`]: an emulated line on a pseudo-terminal (`handgate emulate inspire_rh56`).

pub mod adapter;
pub mod bus;
pub mod config;
pub mod emulator;
pub mod file;
pub mod front;
pub mod kind;
pub mod modbus;
pub mod proto;
pub mod pty;
pub mod regs;
pub mod serve;
