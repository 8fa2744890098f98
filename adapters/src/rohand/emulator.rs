//! The ROHand emulator core: its register file (1000..1174) behind
//! [`crate::modbus::server::RegisterMap`], advanced by `step(now)`. Each finger moves its
//! logical position toward ROH_FINGER_POS_TARGET at ROH_FINGER_SPEED (logical positions a
//! second), stops at an `object_at` position while closing (STATUS_FORCE_REACHED, FORCE at
//! its FORCE_LIMIT), and reports its angle (deg x100) linearly between the doc's ends.
//! ROH_FINGER_ANGLE_TARGET writes set the position target through the same line. Values the
//! doc does not give are listed in docs/rohand.md.

use std::time::Instant;

use super::{reg, status, ANGLES_DEG, FINGERS, POS_CLOSED};
use crate::modbus::hand::{EmuSpec, EmulatorCore};
use crate::modbus::{Exception, Regs, Table};

/// ROH_PROTOCOL_VERSION the emulator reports (1.0, the doc's title "V1.0").
pub const PROTOCOL_VERSION: u16 = 0x0100;
/// Current drawn by a moving finger, mA (assumed).
pub const MOVING_CURRENT_MA: u16 = 300;

const N: usize = (reg::END - reg::PROTOCOL_VERSION) as usize;

/// Writable registers: (first, one past the last) (the doc's R/W and W rows).
const WRITABLE: &[(u16, u16)] = &[
    (reg::NODE_ID, reg::NODE_ID + 1),
    (1008, 1085),
    (reg::CURRENT_LIMIT, reg::CURRENT_LIMIT + 10),
    (reg::FORCE_LIMIT, reg::FORCE_LIMIT + 5),
    (reg::SPEED, reg::POS),
    (reg::ANGLE_TARGET, reg::ANGLE),
];

/// One emulated ROHand.
#[derive(Debug, Clone)]
pub struct RohandCore {
    regs: [u16; N],
    pos: [f32; FINGERS],
    object_at: [Option<f32>; FINGERS],
    last: Option<Instant>,
}

fn idx(r: u16) -> usize {
    (r - reg::PROTOCOL_VERSION) as usize
}

/// Angle register (deg x100) of finger `i` at logical position `pos`.
pub fn angle_of(i: usize, pos: f32) -> i16 {
    let (open, closed) = ANGLES_DEG[i];
    ((open + (closed - open) * pos / POS_CLOSED) * 100.0).round() as i16
}

/// Logical position of finger `i` at angle register `angle` (deg x100), clamped.
pub fn pos_of(i: usize, angle: i16) -> u16 {
    let (open, closed) = ANGLES_DEG[i];
    let f = (f32::from(angle) / 100.0 - open) / (closed - open);
    (f.clamp(0.0, 1.0) * POS_CLOSED).round() as u16
}

impl RohandCore {
    pub fn new(spec: &EmuSpec) -> Self {
        let mut c = RohandCore {
            regs: [0; N],
            pos: [0.0; FINGERS],
            object_at: [None; FINGERS],
            last: None,
        };
        c.regs[idx(reg::PROTOCOL_VERSION)] = PROTOCOL_VERSION;
        c.regs[idx(reg::NODE_ID)] = u16::from(spec.slave);
        c.regs[idx(1008)] = 1; // self-test on
        c.regs[idx(1009)] = 1; // beep on
        for i in 0..FINGERS {
            let p = spec.start.get(i).copied().unwrap_or(0.0).clamp(0.0, POS_CLOSED);
            c.pos[i] = p;
            c.object_at[i] = spec.object_at.get(i).copied().flatten();
            c.regs[idx(reg::CURRENT_LIMIT) + i] = 1200;
            c.regs[idx(reg::SPEED) + i] = 65535;
            c.regs[idx(reg::POS_TARGET) + i] = p.round() as u16;
            if i < 5 {
                c.regs[idx(reg::FORCE_LIMIT) + i] = 15000;
            }
        }
        c.publish(&[false; FINGERS]);
        c
    }

    /// Logical position of finger `i`.
    pub fn position(&self, i: usize) -> f32 {
        self.pos[i]
    }

    fn publish(&mut self, moving: &[bool; FINGERS]) {
        for (i, &moving) in moving.iter().enumerate() {
            let target = f32::from(self.regs[idx(reg::POS_TARGET) + i]);
            let held = self.object_at[i].is_some_and(|o| self.pos[i] >= o && target > self.pos[i]);
            let st = if held {
                status::FORCE_REACHED
            } else if !moving {
                status::POS_REACHED
            } else if target > self.pos[i] {
                status::CLOSING
            } else {
                status::OPENING
            };
            self.regs[idx(reg::FINGER_STATUS) + i] = st;
            self.regs[idx(reg::CURRENT) + i] = if moving { MOVING_CURRENT_MA } else { 0 };
            if i < 5 {
                self.regs[idx(reg::FORCE) + i] = if held { self.regs[idx(reg::FORCE_LIMIT) + i] } else { 0 };
            }
            self.regs[idx(reg::POS) + i] = self.pos[i].round() as u16;
            self.regs[idx(reg::ANGLE) + i] = angle_of(i, self.pos[i]) as u16;
        }
    }
}

impl EmulatorCore for RohandCore {
    fn step(&mut self, now: Instant) {
        let dt = self
            .last
            .map_or(0.0, |l| now.saturating_duration_since(l).as_secs_f32());
        self.last = Some(now);
        let mut moving = [false; FINGERS];
        for (i, m) in moving.iter_mut().enumerate() {
            let target = f32::from(self.regs[idx(reg::POS_TARGET) + i]);
            let mut goal = target;
            if let Some(o) = self.object_at[i] {
                if target > o && self.pos[i] <= o {
                    goal = o;
                }
            }
            let step = f32::from(self.regs[idx(reg::SPEED) + i]) * dt;
            let d = goal - self.pos[i];
            *m = d.abs() > 0.5;
            self.pos[i] += d.clamp(-step, step);
            *m = *m && (goal - self.pos[i]).abs() > 0.5;
        }
        self.publish(&moving);
    }
}

impl crate::modbus::server::RegisterMap for RohandCore {
    fn read(&mut self, _table: Table, addr: u16, out: &mut [u16]) -> Result<(), Exception> {
        let start = addr
            .checked_sub(reg::PROTOCOL_VERSION)
            .ok_or(Exception::IllegalDataAddress)? as usize;
        let r = self
            .regs
            .get(start..start + out.len())
            .ok_or(Exception::IllegalDataAddress)?;
        out.copy_from_slice(r);
        Ok(())
    }

    fn write(&mut self, addr: u16, values: Regs<'_>) -> Result<(), Exception> {
        let end = addr as usize + values.len();
        if !WRITABLE.iter().any(|(a, b)| addr >= *a && end <= *b as usize) {
            return Err(Exception::IllegalDataAddress);
        }
        for (k, v) in values.iter().enumerate() {
            let r = addr + k as u16;
            self.regs[idx(r)] = v;
            if (reg::ANGLE_TARGET..reg::ANGLE_TARGET + FINGERS as u16).contains(&r) {
                let i = (r - reg::ANGLE_TARGET) as usize;
                self.regs[idx(reg::POS_TARGET) + i] = pos_of(i, v as i16);
            }
        }
        Ok(())
    }
}
