//! The emulated Robotiq gripper: a pure state machine over its register images that takes
//! `now` ([`Gripper`]). What it does, and what is assumed where the manual is silent, is
//! docs/robotiq.md's "Emulated and assumed" table:
//!
//! - activation: rACT 0 resets (gACT 0, gSTA 0); a rising edge of rACT starts the activation
//!   (gACT 1, gSTA 1) which completes ([`Tuning::activation`] later) with gSTA 3;
//! - motion: with gSTA 3 and rGTO 1 (gGTO 1) the fingers go to rPR at the variant's speed for
//!   rSP; gOBJ 0 while moving, 3 at the position, 2 stopped by the object while closing
//!   (`object_at`), 1 stopped by it while opening (an object the fingers started past:
//!   an internal grip); gOBJ is 0 while gGTO is 0 (the manual: "ignore if gGTO = 0");
//! - current gCU: [`Tuning::moving_current`] while moving, a grip current growing with rFR
//!   when stopped on the object, 0 at rest;
//! - faults gFLT: 0x05 rGTO during the activation, 0x07 rGTO without rACT, 0x09 after one
//!   second without any request (cleared by the next one);
//! - the 5 ms gap: a write less than [`MIN_COMMAND_GAP`] after the last applied one is held
//!   and applied when the gap is over, the latest write winning (assumed: the manual only
//!   asks for the gap); every read is answered at once;
//! - reads: 0x07D0-0x07D2 by FC03 or FC04 alike, the request image 0x03E8-0x03EA by FC03;
//!   writes: 0x03E8-0x03EA only; any other address is refused.

use std::time::{Duration, Instant};

use super::regs::{
    fault, words_to_bytes, Activation, Object, Request, Status, MIN_COMMAND_GAP, NO_COMMUNICATION_AFTER, REQUEST_ADDR,
    STATUS_ADDR, WORDS,
};
use super::table::VariantSpec;
use crate::sim::Prng;

/// Which register table a read addresses (Modbus FC03 holding, FC04 input).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Table {
    Holding,
    Input,
}

/// An address outside the gripper's registers (a Modbus "illegal data address"; the gripper
/// itself answers nothing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("register {addr:#06x} (+{count}) is not a Robotiq register")]
pub struct BadAddress {
    pub addr: u16,
    pub count: usize,
}

/// The emulator's figures, all assumptions (docs/robotiq.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuning {
    /// From the rising edge of rACT to gSTA 3. The real gripper opens and closes its fingers
    /// during activation (a few seconds on a 2F-85); assumed 1.5 s, fingers not moved.
    pub activation: Duration,
    /// gCU while moving, counts (10 mA each).
    pub moving_current: u8,
    /// gCU holding an object at rFR 0 and at rFR 255, counts.
    pub grip_current: (u8, u8),
    /// gPO jitter: one standard deviation, position counts (0: exact); the encoder's last
    /// count flickers while the fingers hold or rest.
    pub position_noise: f32,
    /// Seed of the jitter.
    pub seed: u64,
    /// Writes closer than this to the last applied one wait for its end ([`MIN_COMMAND_GAP`]
    /// on the emulated gripper; zero on the fronts, which drive another device).
    pub min_gap: Duration,
}

impl Default for Tuning {
    fn default() -> Self {
        Tuning {
            activation: Duration::from_millis(1500),
            moving_current: 15,
            grip_current: (10, 60),
            position_noise: 0.4,
            seed: crate::sim::Noise::DEFAULT_SEED,
            min_gap: MIN_COMMAND_GAP,
        }
    }
}

/// What the fingers do when they are another device's (a front serving the Robotiq
/// interface for a bound hand): its measured position and whether it reports contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Position, counts (0 open .. 255 closed): the hand's closure × 255.
    pub position: f32,
    /// The hand reports contact (its motion verdict "holding", or its own contact flag).
    pub contact: bool,
}

/// What a client's request asks of the fingers, when it changes (a front turns it into a
/// command for the bound hand).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// Go to rPR (0 open .. 255 closed) at rSP with rFR.
    Go { position: u8, speed: u8, force: u8 },
    /// rGTO fell (or a reset): stop where the fingers are.
    Stop,
}

/// Position counts within which the fingers are "at the requested position" when they are
/// another device's (its own tolerance: a hand rarely lands on the exact count).
pub const AT_POSITION_COUNTS: f32 = 4.0;

/// What the emulator counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counters {
    pub reads: u64,
    pub writes: u64,
    /// Writes that came less than 5 ms after the last applied one (held until the gap ended).
    pub early_writes: u64,
    pub refused: u64,
}

/// One emulated gripper.
#[derive(Debug, Clone)]
pub struct Gripper {
    spec: VariantSpec,
    tuning: Tuning,
    /// The request registers as last written.
    written: [u16; WORDS],
    /// The request in force.
    applied: Request,
    /// A write held by the 5 ms rule: applied at this instant.
    pending_at: Option<Instant>,
    last_applied_at: Option<Instant>,
    last_traffic: Instant,
    last_step: Instant,
    activation: Activation,
    activation_done_at: Option<Instant>,
    gto: bool,
    object: Object,
    fault: u8,
    /// Finger position, counts (0 open .. 255 closed).
    position: f32,
    current: u8,
    /// The object, position counts, and whether the fingers are past it (an internal grip:
    /// it blocks opening rather than closing).
    object_at: Option<(f32, bool)>,
    rng: Prng,
    jitter: i16,
    counters: Counters,
    /// `Some`: the fingers are another device's ([`Self::external`]).
    measured: Option<Measured>,
    /// The last motion asked of the fingers, not yet taken ([`Self::take_motion`]).
    motion: Option<Motion>,
}

impl Gripper {
    /// A powered-up gripper (reset, not activated) of `spec`, fingers at `position` counts,
    /// an object at `object_at` counts (or none), at `now`.
    pub fn new(spec: VariantSpec, tuning: Tuning, position: f32, object_at: Option<f32>, now: Instant) -> Self {
        let position = position.clamp(0.0, 255.0);
        Gripper {
            spec,
            tuning,
            written: [0; WORDS],
            applied: Request::default(),
            pending_at: None,
            last_applied_at: None,
            last_traffic: now,
            last_step: now,
            activation: Activation::Reset,
            activation_done_at: None,
            gto: false,
            object: Object::Moving,
            fault: fault::NONE,
            position,
            current: 0,
            object_at: object_at.map(|o| (o.clamp(0.0, 255.0), position > o)),
            rng: Prng::new(tuning.seed),
            jitter: 0,
            counters: Counters::default(),
            measured: None,
            motion: None,
        }
    }

    /// A gripper whose fingers are another device's: the registers, activation and faults of
    /// a Robotiq, the position and contact what [`Self::set_measured`] says, every change of
    /// the motion asked for told by [`Self::take_motion`].
    pub fn external(tuning: Tuning, now: Instant) -> Self {
        let mut g = Self::new(super::table::Variant::TwoF85.spec(), tuning, 0.0, None, now);
        g.measured = Some(Measured {
            position: 0.0,
            contact: false,
        });
        g
    }

    /// The other device's latest measurement (external grippers only).
    pub fn set_measured(&mut self, m: Measured) {
        if self.measured.is_some() {
            self.measured = Some(m);
        }
    }

    /// The motion asked for since the last call, if it changed.
    pub fn take_motion(&mut self) -> Option<Motion> {
        self.motion.take()
    }

    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The request in force.
    pub fn applied(&self) -> Request {
        self.applied
    }

    /// The fingers' position, counts (exact, without the encoder's jitter).
    pub fn position(&self) -> f32 {
        self.position
    }

    /// Reads `out.len()` registers from `addr` of `table` at `now`.
    pub fn read(&mut self, table: Table, addr: u16, out: &mut [u16], now: Instant) -> Result<(), BadAddress> {
        let status = in_block(STATUS_ADDR, addr, out.len());
        let request = table == Table::Holding && in_block(REQUEST_ADDR, addr, out.len());
        if !(status || request) {
            self.counters.refused += 1;
            return Err(BadAddress { addr, count: out.len() });
        }
        self.traffic(now);
        self.step(now);
        let image = if status { self.status().to_words() } else { self.written };
        self.counters.reads += 1;
        let base = if addr >= STATUS_ADDR { STATUS_ADDR } else { REQUEST_ADDR };
        let from = usize::from(addr - base);
        out.copy_from_slice(&image[from..from + out.len()]);
        Ok(())
    }

    /// Writes `values` from `addr` (request registers only) at `now`.
    pub fn write(&mut self, addr: u16, values: impl IntoIterator<Item = u16>, now: Instant) -> Result<(), BadAddress> {
        let mut image = self.written;
        let mut n = 0usize;
        for v in values {
            let i = usize::from(addr.wrapping_sub(REQUEST_ADDR)) + n;
            if addr < REQUEST_ADDR || i >= WORDS {
                self.counters.refused += 1;
                return Err(BadAddress { addr, count: n + 1 });
            }
            image[i] = v;
            n += 1;
        }
        if n == 0 {
            self.counters.refused += 1;
            return Err(BadAddress { addr, count: 0 });
        }
        self.traffic(now);
        self.step(now);
        self.counters.writes += 1;
        self.written = image;
        match self.last_applied_at {
            Some(t) if now.saturating_duration_since(t) < self.tuning.min_gap => {
                self.counters.early_writes += 1;
                self.pending_at.get_or_insert(t + self.tuning.min_gap);
            }
            _ => self.apply(now),
        }
        Ok(())
    }

    /// The status registers now (after [`Self::step`]).
    pub fn status(&self) -> Status {
        let position = (self.position.round() as i16 + self.jitter).clamp(0, 255) as u8;
        Status {
            act: self.applied.act,
            gto: self.gto,
            activation: self.activation,
            object: if self.gto { self.object } else { Object::Moving },
            fault: self.fault_now(),
            controller_fault: 0,
            requested: self.applied.position,
            position,
            current: self.current,
        }
    }

    /// Advances the gripper to `now`: the held write, the activation, the fingers.
    pub fn step(&mut self, now: Instant) {
        if let Some(at) = self.pending_at {
            if now >= at {
                self.advance(at);
                self.pending_at = None;
                self.apply(at);
            }
        }
        self.advance(now);
    }

    fn traffic(&mut self, now: Instant) {
        self.last_traffic = now;
    }

    /// gFLT: a major fault stays; else no communication; else the priority faults.
    fn fault_now(&self) -> u8 {
        if self.fault >= fault::MAJOR {
            return self.fault;
        }
        if self.last_step.saturating_duration_since(self.last_traffic) >= NO_COMMUNICATION_AFTER {
            return fault::NO_COMMUNICATION;
        }
        self.fault
    }

    /// The written request takes effect at `now`.
    fn apply(&mut self, now: Instant) {
        let r = Request::from_bytes(&words_to_bytes(&self.written));
        let was = self.applied;
        self.applied = r;
        self.last_applied_at = Some(now);
        if !r.act {
            // Reset: everything but the fingers' position.
            self.activation = Activation::Reset;
            self.activation_done_at = None;
            if self.gto {
                self.motion = Some(Motion::Stop);
            }
            self.gto = false;
            self.current = 0;
            self.fault = if r.gto { fault::NOT_ACTIVATED } else { fault::NONE };
            return;
        }
        if !was.act && self.activation == Activation::Reset {
            self.activation = Activation::InProgress;
            self.activation_done_at = Some(now + self.tuning.activation);
            self.fault = fault::NONE;
        }
        self.fault = match self.activation {
            Activation::InProgress if r.gto => fault::ACTION_DELAYED,
            _ if self.fault >= fault::MAJOR => self.fault,
            _ => fault::NONE,
        };
        self.update_gto(was);
    }

    fn update_gto(&mut self, was: Request) {
        let go = self.applied.act && self.applied.gto && self.activation == Activation::Completed;
        if go && !self.gto {
            self.object = Object::Moving;
        }
        let r = self.applied;
        if go && (!self.gto || (r.position, r.speed, r.force) != (was.position, was.speed, was.force)) {
            self.motion = Some(Motion::Go {
                position: r.position,
                speed: r.speed,
                force: r.force,
            });
        } else if !go && self.gto {
            self.motion = Some(Motion::Stop);
        }
        self.gto = go;
    }

    /// Physics from `last_step` to `now`.
    fn advance(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.last_step).as_secs_f32();
        if now <= self.last_step {
            return;
        }
        self.last_step = now;
        if let Some(done) = self.activation_done_at {
            if now >= done && self.activation == Activation::InProgress {
                self.activation = Activation::Completed;
                self.activation_done_at = None;
                if self.fault == fault::ACTION_DELAYED {
                    self.fault = fault::NONE;
                }
                self.update_gto(Request::default());
            }
        }
        if let Some(m) = self.measured {
            self.follow(m);
            return;
        }
        if !self.gto {
            self.current = 0;
            self.dither();
            return;
        }
        let target = f32::from(self.applied.position);
        let dir = (target - self.position).signum();
        // Where the object stops the fingers on their way, if it is in the way.
        let block = self.object_at.and_then(|(o, inside)| {
            let closing_onto = !inside && dir > 0.0 && self.position <= o && target > o;
            let opening_onto = inside && dir < 0.0 && self.position >= o && target < o;
            (closing_onto || opening_onto).then_some(o)
        });
        let stop = block.unwrap_or(target);
        let step = self.spec.counts_per_s(self.applied.speed) * dt;
        if (stop - self.position).abs() <= step {
            self.position = stop;
            match block {
                Some(_) => {
                    self.object = if dir > 0.0 {
                        Object::ContactClosing
                    } else {
                        Object::ContactOpening
                    };
                    let (lo, hi) = self.tuning.grip_current;
                    let f = f32::from(self.applied.force) / 255.0;
                    self.current = (f32::from(lo) + f * f32::from(hi.saturating_sub(lo))).round() as u8;
                }
                None => {
                    // Reached the position; once stopped by the object, the object stays
                    // reported until a new motion away from it.
                    if !self.object.contact() {
                        self.object = Object::AtPosition;
                    }
                    self.current = 0;
                }
            }
            self.dither();
        } else {
            self.position += step * dir;
            self.object = Object::Moving;
            self.current = self.tuning.moving_current;
            self.jitter = 0;
        }
    }

    /// The fingers are another device's: gPO its position, gOBJ from its contact and the
    /// distance to rPR, gCU as the emulated gripper's for the same situation.
    fn follow(&mut self, m: Measured) {
        self.position = m.position.clamp(0.0, 255.0);
        self.jitter = 0;
        if !self.gto {
            self.current = 0;
            return;
        }
        let target = f32::from(self.applied.position);
        let (lo, hi) = self.tuning.grip_current;
        // Contact counts while closing onto it: a device that still reports the grasp it is
        // asked to open from has not moved yet (its contact is a closing one: the motion
        // verdict "holding"; gOBJ 1 is never reported for another device).
        if m.contact && target - self.position > AT_POSITION_COUNTS {
            self.object = Object::ContactClosing;
            let f = f32::from(self.applied.force) / 255.0;
            self.current = (f32::from(lo) + f * f32::from(hi.saturating_sub(lo))).round() as u8;
        } else if (target - self.position).abs() <= AT_POSITION_COUNTS {
            self.object = Object::AtPosition;
            self.current = 0;
        } else {
            self.object = Object::Moving;
            self.current = self.tuning.moving_current;
        }
    }

    /// The encoder's last count flickering at rest.
    fn dither(&mut self) {
        let sd = self.tuning.position_noise;
        self.jitter = if sd > 0.0 {
            (sd * self.rng.normalish()).round() as i16
        } else {
            0
        };
    }
}

/// Whether `count` registers from `addr` lie inside the 3-register block at `base`.
fn in_block(base: u16, addr: u16, count: usize) -> bool {
    count > 0 && addr >= base && usize::from(addr - base) + count <= WORDS
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robotiq::table::Variant;

    fn exact() -> Tuning {
        Tuning {
            position_noise: 0.0,
            ..Tuning::default()
        }
    }

    fn status(g: &mut Gripper, now: Instant) -> Status {
        let mut w = [0u16; 3];
        g.read(Table::Input, STATUS_ADDR, &mut w, now).unwrap();
        Status::from_words(&w)
    }

    fn write(g: &mut Gripper, r: Request, now: Instant) {
        g.write(REQUEST_ADDR, r.to_words(), now).unwrap();
    }

    /// Reset, then rACT = 1: gSTA 1 for the activation time, then 3; rGTO during it is
    /// fault 0x05, rGTO without rACT 0x07.
    #[test]
    fn activation_goes_through_in_progress_to_completed() {
        let t0 = Instant::now();
        let mut g = Gripper::new(Variant::TwoF85.spec(), exact(), 0.0, None, t0);
        let s = status(&mut g, t0);
        assert_eq!((s.act, s.activation, s.fault), (false, Activation::Reset, 0));
        write(
            &mut g,
            Request {
                gto: true,
                ..Request::default()
            },
            t0,
        );
        assert_eq!(status(&mut g, t0).fault, fault::NOT_ACTIVATED);
        write(&mut g, Request::default(), t0 + Duration::from_millis(10));
        assert_eq!(status(&mut g, t0 + Duration::from_millis(10)).fault, 0);
        let t1 = t0 + Duration::from_millis(20);
        write(&mut g, Request::go(0, 255, 255), t1);
        let s = status(&mut g, t1 + Duration::from_millis(1));
        assert_eq!((s.act, s.activation, s.gto), (true, Activation::InProgress, false));
        assert_eq!(s.fault, fault::ACTION_DELAYED);
        let s = status(&mut g, t1 + Duration::from_millis(1499));
        assert_eq!(s.activation, Activation::InProgress);
        let s = status(&mut g, t1 + Duration::from_millis(1500));
        assert_eq!((s.activation, s.gto, s.fault), (Activation::Completed, true, 0));
        // A reset clears it.
        write(&mut g, Request::default(), t1 + Duration::from_millis(1600));
        let s = status(&mut g, t1 + Duration::from_millis(1600));
        assert_eq!((s.act, s.activation, s.gto), (false, Activation::Reset, false));
    }

    fn activated(object_at: Option<f32>, position: f32) -> (Gripper, Instant) {
        let t0 = Instant::now();
        let mut g = Gripper::new(Variant::TwoF85.spec(), exact(), position, object_at, t0);
        write(
            &mut g,
            Request {
                act: true,
                ..Request::default()
            },
            t0,
        );
        let t = t0 + Duration::from_millis(1500);
        assert!(status(&mut g, t).activated());
        (g, t)
    }

    /// Closing from open at full speed: 450 counts/s on a 2F-85, so 255 counts in about
    /// 567 ms; gOBJ 0 on the way, 3 at the position, current only while moving.
    #[test]
    fn fingers_follow_rpr_at_the_speed_of_rsp() {
        let (mut g, t) = activated(None, 0.0);
        write(&mut g, Request::go(255, 255, 0), t);
        let s = status(&mut g, t + Duration::from_millis(100));
        assert_eq!(s.position, 45, "{s:?}");
        assert_eq!((s.object, s.current, s.requested), (Object::Moving, 15, 255));
        let s = status(&mut g, t + Duration::from_millis(560));
        assert_eq!(s.object, Object::Moving);
        let s = status(&mut g, t + Duration::from_millis(570));
        assert_eq!((s.position, s.object, s.current), (255, Object::AtPosition, 0));
        // Slowest speed: 60 counts/s.
        let t2 = t + Duration::from_millis(600);
        write(&mut g, Request::go(195, 0, 0), t2);
        let s = status(&mut g, t2 + Duration::from_millis(500));
        assert_eq!(s.position, 225, "{s:?}");
    }

    /// An object at 128 counts: closing stops there with gOBJ 2 and a grip current that grows
    /// with rFR; opening leaves it (gOBJ 0 then 3).
    #[test]
    fn an_object_stops_the_closing_fingers_with_gobj_2() {
        let (mut g, t) = activated(Some(128.0), 0.0);
        write(&mut g, Request::go(255, 255, 255), t);
        let s = status(&mut g, t + Duration::from_millis(1000));
        assert_eq!((s.position, s.object, s.current), (128, Object::ContactClosing, 60));
        let t2 = t + Duration::from_millis(1010);
        write(&mut g, Request::go(255, 255, 0), t2);
        assert_eq!(status(&mut g, t2 + Duration::from_millis(5)).current, 10);
        let t3 = t2 + Duration::from_millis(10);
        write(&mut g, Request::go(0, 255, 0), t3);
        let s = status(&mut g, t3 + Duration::from_millis(50));
        assert_eq!(s.object, Object::Moving);
        let s = status(&mut g, t3 + Duration::from_millis(400));
        assert_eq!((s.position, s.object), (0, Object::AtPosition));
        // Fingers past the object (an internal grip) are stopped opening: gOBJ 1.
        let (mut g, t) = activated(Some(100.0), 200.0);
        write(&mut g, Request::go(0, 255, 255), t);
        let s = status(&mut g, t + Duration::from_millis(500));
        assert_eq!((s.position, s.object), (100, Object::ContactOpening));
    }

    /// Fingers that are another device's: gOBJ 2 while it reports contact short of a closing
    /// target; asked to open from that grasp, gOBJ 0 (moving) until it has opened, not an
    /// "object while opening" from the grasp it still reports.
    #[test]
    fn another_devices_contact_is_an_object_only_while_closing_onto_it() {
        let t = Instant::now();
        let mut g = Gripper::external(
            Tuning {
                activation: Duration::ZERO,
                min_gap: Duration::ZERO,
                ..exact()
            },
            t,
        );
        write(
            &mut g,
            Request {
                act: true,
                ..Request::default()
            },
            t,
        );
        let t = t + Duration::from_millis(1);
        write(&mut g, Request::go(255, 255, 255), t);
        g.set_measured(Measured {
            position: 150.0,
            contact: true,
        });
        let s = status(&mut g, t + Duration::from_millis(2));
        assert_eq!((s.position, s.object), (150, Object::ContactClosing));
        write(&mut g, Request::go(0, 255, 255), t + Duration::from_millis(3));
        let s = status(&mut g, t + Duration::from_millis(4));
        assert_eq!((s.position, s.object), (150, Object::Moving));
        g.set_measured(Measured {
            position: 1.0,
            contact: false,
        });
        let s = status(&mut g, t + Duration::from_millis(5));
        assert_eq!((s.position, s.object), (1, Object::AtPosition));
    }

    /// A second without any request is gFLT 0x09; the next request clears it.
    #[test]
    fn a_second_without_communication_is_fault_9() {
        let (mut g, t) = activated(None, 0.0);
        g.step(t + Duration::from_millis(999));
        assert_eq!(g.status().fault, 0);
        g.step(t + Duration::from_millis(1000));
        assert_eq!(g.status().fault, fault::NO_COMMUNICATION);
        assert_eq!(status(&mut g, t + Duration::from_millis(1001)).fault, 0);
    }

    /// A write within 5 ms of the last applied one waits for the gap's end; the latest wins.
    #[test]
    fn writes_closer_than_5_ms_take_effect_when_the_gap_ends() {
        let (mut g, t) = activated(None, 0.0);
        write(&mut g, Request::go(10, 255, 0), t);
        write(&mut g, Request::go(20, 255, 0), t + Duration::from_millis(1));
        write(&mut g, Request::go(30, 255, 0), t + Duration::from_millis(2));
        assert_eq!(status(&mut g, t + Duration::from_millis(3)).requested, 10);
        assert_eq!(status(&mut g, t + Duration::from_millis(5)).requested, 30);
        assert_eq!(g.counters().early_writes, 2);
        assert_eq!(g.counters().writes, 4, "the activation's and these three");
    }

    /// FC03 and FC04 read the same status; FC03 reads the request back; other addresses and
    /// writes outside the request block are refused.
    #[test]
    fn addresses_outside_the_two_blocks_are_refused() {
        let (mut g, t) = activated(None, 0.0);
        let (mut a, mut b) = ([0u16; 3], [0u16; 3]);
        g.read(Table::Holding, STATUS_ADDR, &mut a, t).unwrap();
        g.read(Table::Input, STATUS_ADDR, &mut b, t).unwrap();
        assert_eq!(a, b);
        let mut one = [0u16; 1];
        g.read(Table::Input, STATUS_ADDR + 2, &mut one, t).unwrap();
        assert_eq!(one[0], a[2]);
        g.read(Table::Holding, REQUEST_ADDR, &mut a, t).unwrap();
        assert_eq!(a, [0x0100, 0, 0]);
        assert!(g.read(Table::Input, REQUEST_ADDR, &mut a, t).is_err());
        assert!(g.read(Table::Input, STATUS_ADDR + 1, &mut a, t).is_err());
        assert!(g.read(Table::Input, 0, &mut a, t).is_err());
        assert!(g.write(STATUS_ADDR, [1u16], t).is_err());
        assert!(g.write(REQUEST_ADDR + 2, [1u16, 2], t).is_err());
        assert!(g.write(REQUEST_ADDR, [0u16; 4], t).is_err());
        assert_eq!(g.counters().refused, 6);
        g.write(REQUEST_ADDR + 1, [0x00FFu16], t + Duration::from_millis(10))
            .unwrap();
        assert_eq!(g.applied().position, 255);
    }
}
