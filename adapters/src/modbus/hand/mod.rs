//! A register-mapped hand on a Modbus RTU line, written once: what a kind declares
//! ([`RegisterHand`]: its facts, table, the block it reads each round, the block it writes, and
//! the two conversions), and what every such kind gets from it:
//!
//! - [`line`]: one thread per port serving every hand on it (the arbiter), rounds on
//!   deadlines, a target written only when it changed, a silent slave marked stale while the
//!   others go on, reconnect without replaying a stale setpoint;
//! - [`device`]: the generic [`crate::device::HandDevice`] over a line;
//! - [`emulated`]: the emulator backend at the [`crate::serial::Transport`] seam (RTU frames
//!   in, the hands' emulator cores answer at the line's wire time) and the same line on a pty
//!   for `handgate emulate <kind>`;
//! - [`kind`]: the [`crate::kind::Kind`] scaffold (`[devices.<kind>]` keys, fleet rules, one
//!   line per port).
//!
//! A new Modbus hand is then a register table, a codec (`state`, `targets`), an emulator core
//! and one constant (docs/rohand.md, "What adding a Modbus hand took").

use std::fmt;
use std::time::Instant;

use super::server::RegisterMap;
use crate::kind::KindFacts;
use crate::mapping::DeviceTable;
use crate::model::{HandState, Side};

pub mod device;
pub mod emulated;
pub mod kind;
pub mod line;

/// The largest block a round reads or writes (FC03 reads at most 125 registers).
pub const MAX_BLOCK: usize = super::pdu::MAX_READ as usize;

/// An emulated hand: its registers, advanced in time before each request is answered.
pub trait EmulatorCore: RegisterMap + Send + 'static {
    fn step(&mut self, now: Instant);
}

/// Where an emulated hand starts, from the profile's `[devices.emulator]`: the slave id and,
/// per wire index, the wire position at start and where an object stops the finger.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EmuSpec {
    pub slave: u8,
    pub start: Vec<f32>,
    pub object_at: Vec<Option<f32>>,
}

/// What a register-mapped hand kind declares.
pub trait RegisterHand: Copy + Default + PartialEq + fmt::Debug + Send + Sync + 'static {
    /// Name, joints, backends ([`crate::device::Backend::Serial`] and `Emulator`), rate, and
    /// the `[devices.<name>]` section.
    const FACTS: KindFacts;
    /// The slave id and baud rate out of the box.
    const SLAVE: u8;
    const BAUD: u32;
    /// The baud rates the hand takes.
    const BAUDS: &'static [u32];
    /// The block read each round with FC03: (first register, count ≤ [`MAX_BLOCK`]).
    const STATE: (u16, u16);
    /// The block written with FC16 when the target changes: (first register, count).
    const TARGET: (u16, u16);
    /// Written once to every hand after each (re)connect: (register, values).
    const INIT: &'static [(u16, &'static [u16])] = &[];
    type Core: EmulatorCore;

    fn table(side: Side) -> DeviceTable;
    /// The canonical state from the state block `regs` (`STATE.1` words): joints (through
    /// `table`), contact, faults and mode. The glue sets freshness, closure and the stamps.
    fn state(table: &DeviceTable, regs: &[u16], st: &mut HandState);
    /// The target block (`TARGET.1` words) from one wire position per wire index.
    fn targets(wire: &[f32], out: &mut [u16]);
    /// An emulated hand.
    fn core(spec: &EmuSpec) -> Self::Core;
}

#[cfg(test)]
mod hand_tests;
