//! The RH56 emulator core: one hand's register file and fingers as a pure state machine
//! ([`Rh56Hand::step`] takes `now`), answering the serial protocol ([`Rh56Hand::answer`]) and
//! Modbus's word view of the same file ([`Rh56Hand::read_words`] / [`Rh56Hand::write_words`]).
//! Several hands on one RS-485 line are a [`Line`]: a request reaches the hand with its id, the
//! others stay silent as slaves on a shared line do.
//!
//! What it emulates (docs/inspire-rh56.md, "Emulated and assumed"):
//! - each finger follows its ANGLE_SET target (0..1000, 1000 = open; -1 keeps that finger's
//!   target) at SPEED_SET (1000 = the full stroke in [`FULL_STROKE_S`], an assumption);
//! - a finger closing onto an object (`object_at`, an angle) stops there and squeezes at its
//!   FORCE_SET threshold: FORCE_ACT = FORCE_SET (grams, an assumption), STATUS 3 (force
//!   reached); otherwise FORCE_ACT 0 and STATUS 1 grasping / 0 releasing / 2 reached;
//! - ERROR bits injected per finger stop that finger (STATUS 7) until a write of 1 to
//!   CLEAR_ERROR; TEMP reads [`TEMP_C`]; HAND_ID the hand's id;
//! - POS_ACT = 2 × (1000 − angle) (the actuator's 0..2000 stroke, direction assumed);
//! - the DFTP's tactile cells: a finger in contact reads FORCE_ACT scaled to 0..4095 on its
//!   tip, nail and pad cells; every other cell 0.
//!   CURRENT and VOLTAGE read 0 (not emulated).

use std::time::Instant;

pub use super::file::Refused;
use super::file::{touches, words_to_bytes, RegisterFile};
use super::proto::{self, Request};
use super::regs::{self, FINGERS};

/// Seconds the full 0..1000 stroke takes at SPEED_SET 1000 (assumed: the manuals give no
/// finger speed in these units).
pub const FULL_STROKE_S: f32 = 0.8;
/// The temperature every finger reads, °C.
pub const TEMP_C: u8 = 35;
/// Default FORCE_SET at power-up (assumed), grams.
pub const DEFAULT_FORCE: i16 = 500;
/// Default SPEED_SET at power-up (assumed).
pub const DEFAULT_SPEED: i16 = 1000;
/// Within this many units of its target a finger has reached it.
const AT_TARGET: f32 = 0.5;

/// One emulated hand's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct HandSpec {
    /// Its id on the bus (HAND_ID).
    pub id: u8,
    /// Angles at power-up (0..1000).
    pub start: [f32; FINGERS],
    /// Per finger, the angle at which closing meets an object (`None`: nothing there).
    pub object_at: [Option<f32>; FINGERS],
    /// A DFTP: its tactile cells read contact.
    pub tactile: bool,
}

impl HandSpec {
    /// A hand with id `id`, open (every angle 1000), nothing in it, no tactile cells.
    pub fn new(id: u8) -> Self {
        HandSpec {
            id,
            start: [1000.0; FINGERS],
            object_at: [None; FINGERS],
            tactile: false,
        }
    }
}

/// One emulated RH56 hand.
#[derive(Debug, Clone)]
pub struct Rh56Hand {
    spec: HandSpec,
    file: RegisterFile,
    angle: [f32; FINGERS],
    target: [f32; FINGERS],
    errors: [u8; FINGERS],
    last: Option<Instant>,
}

impl Rh56Hand {
    pub fn new(spec: HandSpec) -> Self {
        let mut h = Rh56Hand {
            file: RegisterFile::default(),
            angle: spec.start.map(|a| a.clamp(0.0, 1000.0)),
            target: spec.start.map(|a| a.clamp(0.0, 1000.0)),
            errors: [0; FINGERS],
            last: None,
            spec,
        };
        h.file.put_byte(regs::HAND_ID, h.spec.id);
        for i in 0..FINGERS {
            h.put_short(regs::ANGLE_SET, i, h.target[i].round() as i16);
            h.put_short(regs::FORCE_SET, i, DEFAULT_FORCE);
            h.put_short(regs::SPEED_SET, i, DEFAULT_SPEED);
        }
        h.publish();
        h
    }

    pub fn id(&self) -> u8 {
        self.spec.id
    }

    pub fn spec(&self) -> &HandSpec {
        &self.spec
    }

    /// The fingers' angles now (0..1000).
    pub fn angles(&self) -> [f32; FINGERS] {
        self.angle
    }

    /// Sets error bits on `finger` (a fault; CLEAR_ERROR clears them).
    pub fn inject_error(&mut self, finger: usize, bits: u8) {
        if let Some(e) = self.errors.get_mut(finger) {
            *e |= bits;
        }
        self.publish();
    }

    fn short(&self, block: u16, i: usize) -> i16 {
        self.file.short(block, i)
    }

    fn put_short(&mut self, block: u16, i: usize, v: i16) {
        self.file.put_short(block, i, v)
    }

    /// The register file (what a read answers).
    pub fn file(&self) -> &RegisterFile {
        &self.file
    }

    /// Moves the fingers to `now` and refreshes the measured registers.
    pub fn step(&mut self, now: Instant) {
        let dt = self
            .last
            .map_or(0.0, |l| now.saturating_duration_since(l).as_secs_f32());
        self.last = Some(self.last.map_or(now, |l| l.max(now)));
        for i in 0..FINGERS {
            if self.errors[i] != 0 {
                continue;
            }
            let speed = f32::from(self.short(regs::SPEED_SET, i).clamp(0, 1000));
            let max_step = 1000.0 / FULL_STROKE_S * speed / 1000.0 * dt;
            // Closing lowers the angle: an object stops the finger at its angle.
            let goal = match self.spec.object_at[i] {
                Some(obj) if self.target[i] < obj && self.angle[i] >= obj => obj,
                _ => self.target[i],
            };
            let d = goal - self.angle[i];
            self.angle[i] += d.clamp(-max_step, max_step);
        }
        self.publish();
    }

    /// Whether finger `i` presses on its object.
    fn in_contact(&self, i: usize) -> bool {
        matches!(self.spec.object_at[i], Some(obj)
            if self.target[i] < obj && (self.angle[i] - obj).abs() <= AT_TARGET)
    }

    /// Writes the measured registers from the fingers.
    fn publish(&mut self) {
        for i in 0..FINGERS {
            let a = self.angle[i];
            self.put_short(regs::ANGLE_ACT, i, a.round() as i16);
            self.put_short(regs::POS_ACT, i, (2.0 * (1000.0 - a)).round() as i16);
            let contact = self.in_contact(i);
            let force = if contact {
                self.short(regs::FORCE_SET, i).clamp(0, 1000)
            } else {
                0
            };
            self.put_short(regs::FORCE_ACT, i, force);
            let status = if self.errors[i] != 0 {
                regs::status::ACTUATOR_FAULT
            } else if contact {
                regs::status::FORCE_REACHED
            } else if (self.target[i] - a).abs() <= AT_TARGET {
                regs::status::POSITION_REACHED
            } else if self.target[i] < a {
                regs::status::GRASPING
            } else {
                regs::status::RELEASING
            };
            self.file.put_byte(regs::ERROR + i as u16, self.errors[i]);
            self.file.put_byte(regs::STATUS + i as u16, status);
            self.file.put_byte(regs::TEMP + i as u16, TEMP_C);
        }
        if self.spec.tactile {
            self.touch();
        }
    }

    /// The tactile cells from the fingers' contact forces.
    fn touch(&mut self) {
        let finger_of = |name: &str| match name.split('_').next() {
            Some("pinky") => Some(0),
            Some("ring") => Some(1),
            Some("middle") => Some(2),
            Some("index") => Some(3),
            Some("thumb") => Some(4),
            _ => None,
        };
        for (name, addr, r, c) in regs::TACTILE_REGIONS {
            let v = finger_of(name).map_or(0, |f| {
                let force = self.short(regs::FORCE_ACT, f).clamp(0, 1000) as u32;
                (force * u32::from(regs::TACTILE_MAX) / 1000) as u16
            });
            for k in 0..r * c {
                self.file.put(addr + 2 * k, &v.to_le_bytes());
            }
        }
    }

    /// Reads `out.len()` bytes from `addr`.
    pub fn read(&self, addr: u16, out: &mut [u8]) -> Result<(), Refused> {
        self.file.read(addr, out)
    }

    /// Writes `data` at `addr` (parameters and targets only), then applies it: an ANGLE_SET
    /// entry of -1 keeps that finger's target, others are clamped to 0..1000 as FORCE_SET and
    /// SPEED_SET are; CLEAR_ERROR 1 clears the error bits.
    pub fn write(&mut self, addr: u16, data: &[u8]) -> Result<(), Refused> {
        self.file.write(addr, data)?;
        let touches = |reg: u16, len: usize| touches(addr, data.len(), reg, len);
        if touches(regs::ANGLE_SET, regs::BLOCK) {
            for i in 0..FINGERS {
                let v = self.short(regs::ANGLE_SET, i);
                if v == -1 {
                    self.put_short(regs::ANGLE_SET, i, self.target[i].round() as i16);
                } else {
                    let v = v.clamp(0, 1000);
                    self.target[i] = f32::from(v);
                    self.put_short(regs::ANGLE_SET, i, v);
                }
            }
        }
        for reg in [regs::FORCE_SET, regs::SPEED_SET] {
            if touches(reg, regs::BLOCK) {
                for i in 0..FINGERS {
                    let v = self.short(reg, i).clamp(0, 1000);
                    self.put_short(reg, i, v);
                }
            }
        }
        if touches(regs::CLEAR_ERROR, 1) && self.file.byte(regs::CLEAR_ERROR) == 1 {
            self.errors = [0; FINGERS];
            self.file.put_byte(regs::CLEAR_ERROR, 0);
        }
        self.publish();
        Ok(())
    }

    /// Modbus's view (docs at [`regs`]): register `addr + k` is the little-endian short at
    /// bytes `addr + 2k`.
    pub fn read_words(&self, addr: u16, out: &mut [u16]) -> Result<(), Refused> {
        self.file.read_words(addr, out)
    }

    /// Writes Modbus registers from `addr` (each the next two bytes, little-endian in the file).
    pub fn write_words(&mut self, addr: u16, values: impl Iterator<Item = u16>) -> Result<(), Refused> {
        let mut buf = [0u8; 2 * 123];
        let n = words_to_bytes(values, &mut buf);
        self.write(addr, &buf[..n])
    }

    /// Answers `req` at `now` into `out` (cleared). `false`: the request is for another id and
    /// this hand stays silent. A read outside the file stays silent too (what the hand does is
    /// not documented: silence is what a master times out on); a refused write is acknowledged
    /// with result 0.
    pub fn answer(&mut self, req: &Request<'_>, now: Instant, out: &mut Vec<u8>) -> bool {
        out.clear();
        if req.id() != self.spec.id {
            return false;
        }
        self.step(now);
        match *req {
            Request::Read { id, addr, count } => {
                let mut data = [0u8; proto::MAX_READ];
                let data = &mut data[..count as usize];
                if self.read(addr, data).is_err() {
                    return false;
                }
                proto::encode_read_reply(id, addr, data, out).is_ok()
            }
            Request::Write { id, addr, data } => {
                let ok = self.write(addr, data).is_ok();
                proto::encode_write_ack(id, addr, ok, out);
                true
            }
        }
    }
}

/// Hands sharing one RS-485 line.
#[derive(Debug, Clone, Default)]
pub struct Line {
    pub hands: Vec<Rh56Hand>,
}

impl Line {
    pub fn new(hands: Vec<Rh56Hand>) -> Self {
        Line { hands }
    }

    pub fn hand_mut(&mut self, id: u8) -> Option<&mut Rh56Hand> {
        self.hands.iter_mut().find(|h| h.id() == id)
    }

    /// Answers the request at `req` (one decoded frame) into `out`; `false`: nobody answers.
    pub fn answer(&mut self, req: &Request<'_>, now: Instant, out: &mut Vec<u8>) -> bool {
        out.clear();
        match self.hand_mut(req.id()) {
            Some(h) => h.answer(req, now, out),
            None => false,
        }
    }

    /// Steps every hand to `now`.
    pub fn step(&mut self, now: Instant) {
        for h in &mut self.hands {
            h.step(now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inspire_rh56::proto::{decode_reply, encode_read, encode_write, Reply};
    use std::time::Duration;

    fn shorts(v: &[i16]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn read_shorts(h: &Rh56Hand, addr: u16) -> [i16; 6] {
        let mut b = [0u8; 12];
        h.read(addr, &mut b).unwrap();
        std::array::from_fn(|i| i16::from_le_bytes([b[2 * i], b[2 * i + 1]]))
    }

    #[test]
    fn fingers_follow_the_target_at_the_set_speed_and_minus_one_keeps() {
        let t0 = Instant::now();
        let mut h = Rh56Hand::new(HandSpec::new(1));
        h.step(t0);
        h.write(regs::SPEED_SET, &shorts(&[500; 6])).unwrap();
        h.write(regs::ANGLE_SET, &shorts(&[0, -1, 0, 0, 0, 0])).unwrap();
        // Speed 500: half the full stroke a FULL_STROKE_S.
        h.step(t0 + Duration::from_secs_f32(FULL_STROKE_S / 2.0));
        let a = read_shorts(&h, regs::ANGLE_ACT);
        assert_eq!(a[0], 750, "{a:?}");
        assert_eq!(a[1], 1000, "-1 keeps the ring finger where it was told: open");
        assert_eq!(h.file.byte(regs::STATUS), regs::status::GRASPING);
        assert_eq!(
            read_shorts(&h, regs::ANGLE_SET)[1],
            1000,
            "-1 reads back as the kept target"
        );
        h.step(t0 + Duration::from_secs(10));
        let a = read_shorts(&h, regs::ANGLE_ACT);
        assert_eq!(a, [0, 1000, 0, 0, 0, 0]);
        assert_eq!(h.file.byte(regs::STATUS), regs::status::POSITION_REACHED);
        assert_eq!(read_shorts(&h, regs::POS_ACT)[0], 2000);
        // Out-of-range targets are clamped.
        h.write(regs::ANGLE_SET, &shorts(&[1500, -7, -1, -1, -1, -1])).unwrap();
        assert_eq!(read_shorts(&h, regs::ANGLE_SET)[..2], [1000, 0]);
    }

    #[test]
    fn an_object_stops_the_finger_at_the_force_threshold() {
        let t0 = Instant::now();
        let mut spec = HandSpec::new(2);
        spec.object_at[3] = Some(400.0);
        spec.tactile = true;
        let mut h = Rh56Hand::new(spec);
        h.step(t0);
        h.write(regs::FORCE_SET, &shorts(&[300; 6])).unwrap();
        h.write(regs::ANGLE_SET, &shorts(&[0; 6])).unwrap();
        h.step(t0 + Duration::from_secs(5));
        let a = read_shorts(&h, regs::ANGLE_ACT);
        assert_eq!(a, [0, 0, 0, 400, 0, 0]);
        assert_eq!(read_shorts(&h, regs::FORCE_ACT), [0, 0, 0, 300, 0, 0]);
        assert_eq!(h.file.byte(regs::STATUS + 3), regs::status::FORCE_REACHED);
        // The index's tactile cells read the force; the middle's do not.
        let mut w = [0u16; 2];
        h.read_words(4320, &mut w).unwrap();
        assert_eq!(w, [1228, 1228]);
        h.read_words(3950, &mut w).unwrap();
        assert_eq!(w, [0, 0]);
        // Opening leaves the object: no force.
        h.write(regs::ANGLE_SET, &shorts(&[1000; 6])).unwrap();
        h.step(t0 + Duration::from_secs(10));
        assert_eq!(read_shorts(&h, regs::FORCE_ACT), [0; 6]);
    }

    #[test]
    fn errors_stop_a_finger_until_cleared() {
        let t0 = Instant::now();
        let mut h = Rh56Hand::new(HandSpec::new(1));
        h.step(t0);
        h.inject_error(0, regs::error_bits::STALL);
        h.write(regs::ANGLE_SET, &shorts(&[0; 6])).unwrap();
        h.step(t0 + Duration::from_secs(5));
        assert_eq!(read_shorts(&h, regs::ANGLE_ACT)[..2], [1000, 0]);
        assert_eq!(h.file.byte(regs::ERROR), regs::error_bits::STALL);
        assert_eq!(h.file.byte(regs::STATUS), regs::status::ACTUATOR_FAULT);
        h.write(regs::CLEAR_ERROR, &[1]).unwrap();
        assert_eq!(h.file.byte(regs::ERROR), 0);
        h.step(t0 + Duration::from_secs(10));
        assert_eq!(read_shorts(&h, regs::ANGLE_ACT)[0], 0);
    }

    #[test]
    fn measured_registers_are_read_only_and_the_file_bounded() {
        let mut h = Rh56Hand::new(HandSpec::new(1));
        assert_eq!(
            h.write(regs::ANGLE_ACT, &[0; 12]),
            Err(Refused::ReadOnly {
                addr: regs::ANGLE_ACT,
                len: 12
            })
        );
        assert!(matches!(h.read(5120, &mut [0; 8]), Err(Refused::OutOfRange { .. })));
        let mut b = [0u8; 1];
        h.read(regs::HAND_ID, &mut b).unwrap();
        assert_eq!(b, [1]);
        h.read(regs::TEMP, &mut b).unwrap();
        assert_eq!(b, [TEMP_C]);
    }

    #[test]
    fn the_line_answers_by_id_and_the_others_stay_silent() {
        let now = Instant::now();
        let mut line = Line::new(vec![Rh56Hand::new(HandSpec::new(1)), Rh56Hand::new(HandSpec::new(2))]);
        let (mut req, mut out) = (Vec::new(), Vec::new());
        encode_write(2, regs::ANGLE_SET, &shorts(&[0; 6]), &mut req).unwrap();
        let (r, _) = proto::decode_request(&req).unwrap();
        assert!(line.answer(&r, now, &mut out));
        assert_eq!(
            decode_reply(&out).unwrap().0,
            Reply::WriteAck {
                id: 2,
                addr: regs::ANGLE_SET,
                ok: true
            }
        );
        encode_read(3, regs::ANGLE_ACT, 12, &mut req).unwrap();
        let (r, _) = proto::decode_request(&req).unwrap();
        assert!(!line.answer(&r, now, &mut out), "no hand 3");
        assert!(out.is_empty());
        // A refused write is acknowledged with 0.
        encode_write(1, regs::ANGLE_ACT, &[0; 2], &mut req).unwrap();
        let (r, _) = proto::decode_request(&req).unwrap();
        assert!(line.answer(&r, now, &mut out));
        assert_eq!(
            decode_reply(&out).unwrap().0,
            Reply::WriteAck {
                id: 1,
                addr: regs::ANGLE_ACT,
                ok: false
            }
        );
        encode_read(1, regs::ANGLE_ACT, 12, &mut req).unwrap();
        let (r, _) = proto::decode_request(&req).unwrap();
        assert!(line.answer(&r, now, &mut out));
        match decode_reply(&out).unwrap().0 {
            Reply::Read { id: 1, data, .. } => assert_eq!(data, shorts(&[1000; 6])),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn modbus_words_are_the_byte_file_two_bytes_a_register() {
        let mut h = Rh56Hand::new(HandSpec::new(1));
        h.write_words(regs::ANGLE_SET, [100u16, 200, 0xFFFF, 300, 400, 500].into_iter())
            .unwrap();
        assert_eq!(read_shorts(&h, regs::ANGLE_SET), [100, 200, 1000, 300, 400, 500]);
        let mut w = [0u16; 6];
        h.read_words(regs::ANGLE_SET, &mut w).unwrap();
        assert_eq!(w, [100, 200, 1000, 300, 400, 500]);
        // ERROR/STATUS/TEMP as words: two fingers' bytes a register, finger 0 the low byte.
        let mut w = [0u16; 3];
        h.read_words(regs::TEMP, &mut w).unwrap();
        assert_eq!(w, [u16::from_le_bytes([TEMP_C, TEMP_C]); 3]);
    }
}
