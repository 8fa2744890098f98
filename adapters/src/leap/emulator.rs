//! An emulated LEAP Hand: 16 XC330 servos on one bus, as a pure core ([`LeapEmulator`]:
//! bytes and `now` in, status bytes out) served in-process ([`in_process`], a
//! [`Connector`] the device opens like a port, replies readable at their wire time) or on a
//! pseudo-terminal ([`VirtualLeap`], what `handgate emulate leap` prints).
//!
//! Each servo's control table is [`ServoBus`]'s; its joint is a [`JointModel`] in LEAP radians
//! (the motor's angle). With torque on it follows Goal Position through a PD whose stiffness
//! and damping scale with the Position P and D gains, its torque capped by Goal Current
//! (current-based position control, operating mode 5, the LEAP's); Present Position,
//! Velocity and Current are its position, velocity and torque (through
//! [`TORQUE_PER_AMP`]) as the servo reports them, with the kind's measurement noise. An
//! object (`[devices.emulator] object_at`) stops a joint where it is placed, the servo pushing
//! into it at its current limit. Figures marked "assumed" in docs/leap.md.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::control_table::{ticks_to_rad, MA_PER_CURRENT_UNIT, RAD_PER_TICK, RAD_S_PER_VELOCITY_UNIT, TORQUE_PER_AMP};
use super::servos::{BusCounters, ServoBus};
use super::table::{URDF_LIMITS, WIRE_OFFSET};
use crate::dynamixel::control_table::reg;
use crate::dynamixel::protocol::{wire_time, Decoder, DecoderStats};
use crate::serial::pty::{replace_symlink, Pty};
use crate::serial::transport::{Connector, Transport, TransportError};
use crate::sim::{Contact, JointModel, JointParams, MotorTarget, Noise, Sensor};

/// Measurement noise of an XC330: Present Position half a tick, Present Velocity one unit,
/// Present Current 2 mA (as torque through [`TORQUE_PER_AMP`]). Assumed orders of magnitude,
/// not measured (as the EZGripper's MX-64 figures).
pub const XC330_NOISE: Noise = Noise {
    q: RAD_PER_TICK * 0.5,
    dq: RAD_S_PER_VELOCITY_UNIT,
    tau: 0.002 * TORQUE_PER_AMP,
    seed: Noise::DEFAULT_SEED,
};

/// Stiffness per unit of Position P gain, N·m/rad (assumed: P 600 gives 4.7 N·m/rad, so a
/// 0.1 rad error asks for more than the 350 mA goal current gives and the current limit
/// shapes a large move, as on the real hand).
const KP_PER_GAIN: f32 = 1.0 / 128.0;
/// Damping per unit of Position D gain, N·m·s/rad (assumed).
const KD_PER_GAIN: f32 = 1.0e-4;
/// Stiffness of an emulated object, N·m/rad.
const OBJECT_STIFFNESS: f32 = 20.0;

/// One emulated servo's setup.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoSetup {
    pub id: u8,
    /// Position at power-up, LEAP rad.
    pub start_rad: f32,
    /// An object that stops the joint when it closes past this position, LEAP rad.
    pub object_at_rad: Option<f32>,
}

/// What the emulated hand is built with.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorConfig {
    /// In joint order (16 for a LEAP Hand).
    pub servos: Vec<ServoSetup>,
    pub baud: u32,
    pub noise: Noise,
    /// USB adapter latency added to every reply (the pty and in-process forms: 0 by default,
    /// an FTDI at latency timer 1 ms adds about 1 ms on real hardware).
    pub usb_latency: Duration,
}

impl EmulatorConfig {
    /// A LEAP Hand on `ids` (joint order), flat (every motor at 180°), no objects.
    pub fn with_ids(ids: &[u8]) -> Self {
        Self {
            servos: ids
                .iter()
                .map(|&id| ServoSetup {
                    id,
                    start_rad: WIRE_OFFSET,
                    object_at_rad: None,
                })
                .collect(),
            baud: super::control_table::BAUD,
            noise: XC330_NOISE,
            usb_latency: Duration::ZERO,
        }
    }
}

/// Counters of the emulated bus.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    pub bus: BusCounters,
    pub decoder: DecoderStats,
    /// Bytes of status the servos sent.
    pub status_bytes: u64,
}

/// The emulated hand: pure, driven by the bytes written to it and `now`.
#[derive(Debug)]
pub struct LeapEmulator {
    bus: ServoBus,
    joints: Vec<JointModel>,
    sensor: Sensor,
    decoder: Decoder,
    last: Option<Instant>,
    status_bytes: u64,
}

impl LeapEmulator {
    pub fn new(cfg: &EmulatorConfig) -> Self {
        let ids: Vec<u8> = cfg.servos.iter().map(|s| s.id).collect();
        let joints = cfg
            .servos
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let (lo, hi) = URDF_LIMITS.get(i).copied().unwrap_or((-1.0, 1.0));
                let params = JointParams {
                    inertia: 2.0e-5,
                    friction: 0.03,
                    tau_max: 0.0,
                    q_min: WIRE_OFFSET + lo,
                    q_max: WIRE_OFFSET + hi,
                };
                let mut j = JointModel::new(params, s.start_rad);
                j.contact = s.object_at_rad.map(|at| Contact {
                    at,
                    dir: 1.0,
                    stiffness: OBJECT_STIFFNESS,
                });
                j
            })
            .collect();
        let mut emu = Self {
            bus: ServoBus::new(&ids),
            joints,
            sensor: Sensor::new(cfg.noise),
            decoder: Decoder::new(),
            last: None,
            status_bytes: 0,
        };
        emu.refresh();
        // A powered servo's goal is where it stands.
        for (s, j) in emu.bus.servos.iter_mut().zip(&emu.joints) {
            s.put(reg::GOAL_POSITION, i64::from((j.q / RAD_PER_TICK).round() as i32));
        }
        emu
    }

    /// The servos' control tables.
    pub fn bus(&self) -> &ServoBus {
        &self.bus
    }

    /// Joint `i`'s true position, LEAP rad (ground truth for tests).
    pub fn position(&self, i: usize) -> Option<f32> {
        self.joints.get(i).map(|j| j.q)
    }

    /// Places (or removes) an object in joint `i`'s way at `at` (LEAP rad).
    pub fn set_object(&mut self, i: usize, at: Option<f32>) {
        if let Some(j) = self.joints.get_mut(i) {
            j.contact = at.map(|at| Contact {
                at,
                dir: 1.0,
                stiffness: OBJECT_STIFFNESS,
            });
        }
    }

    pub fn stats(&self) -> EmulatorStats {
        EmulatorStats {
            bus: self.bus.counters,
            decoder: self.decoder.stats(),
            status_bytes: self.status_bytes,
        }
    }

    /// Advances every joint to `now` (a step is capped at 0.2 s) and refreshes the present
    /// values.
    pub fn step_to(&mut self, now: Instant) {
        let dt = match self.last.replace(now) {
            Some(l) => now.saturating_duration_since(l).as_secs_f32().min(0.2),
            None => 0.0,
        };
        if dt > 0.0 {
            for (s, j) in self.bus.servos.iter().zip(self.joints.iter_mut()) {
                let target = if s.torque_on() {
                    let goal_ma = s.get(reg::GOAL_CURRENT).unsigned_abs() as f32 * MA_PER_CURRENT_UNIT;
                    let limit_ma = s.get(reg::CURRENT_LIMIT).unsigned_abs() as f32 * MA_PER_CURRENT_UNIT;
                    j.params.tau_max = goal_ma.min(limit_ma) / 1000.0 * TORQUE_PER_AMP;
                    MotorTarget {
                        q: ticks_to_rad(s.get(reg::GOAL_POSITION) as i32),
                        dq: 0.0,
                        tau: 0.0,
                        kp: s.get(reg::POSITION_P_GAIN) as f32 * KP_PER_GAIN,
                        kd: s.get(reg::POSITION_D_GAIN) as f32 * KD_PER_GAIN,
                    }
                } else {
                    MotorTarget::LIMP
                };
                j.step(&target, dt);
            }
        }
        self.refresh();
    }

    /// Present Current / Velocity / Position / Moving from the joints, with noise.
    fn refresh(&mut self) {
        for (s, j) in self.bus.servos.iter_mut().zip(&self.joints) {
            let r = self.sensor.read(j);
            let cur = (r.tau / TORQUE_PER_AMP * 1000.0 / MA_PER_CURRENT_UNIT).round();
            s.put(reg::PRESENT_CURRENT, cur.clamp(-32768.0, 32767.0) as i64);
            s.put(reg::PRESENT_VELOCITY, (r.dq / RAD_S_PER_VELOCITY_UNIT).round() as i64);
            s.put(reg::PRESENT_POSITION, (r.q / RAD_PER_TICK).round() as i64);
            s.put(reg::MOVING, i64::from(j.dq.abs() > 0.05));
        }
    }

    /// Takes `bytes` from the host at `now`: every complete instruction packet is answered
    /// into `out` (appended), the joints advanced to `now` first.
    pub fn feed(&mut self, bytes: &[u8], now: Instant, out: &mut Vec<u8>) {
        self.decoder.push(bytes);
        self.step_to(now);
        let before = out.len();
        while let Some(frame) = self.decoder.next_frame_ref() {
            if let Ok(pk) = frame {
                self.bus.answer(pk, out);
            }
        }
        self.status_bytes += (out.len() - before) as u64;
    }

    /// Drops a partial packet (the host stopped mid-packet).
    pub fn reset_input(&mut self) {
        if self.decoder.pending() > 0 {
            self.decoder.reset();
        }
    }
}

// ------------------------------------------------------------------ in-process transport

/// An emulated hand answering on the caller's thread through a [`Connector`] (the device
/// opens it like a port): a write is answered at once, its replies readable when they would
/// have fully arrived (request and replies at the bus's baud, 10 bits a byte, Return Delay
/// Time 0, the USB latency).
pub fn in_process(cfg: EmulatorConfig) -> (Arc<Mutex<LeapEmulator>>, Box<dyn Connector>) {
    let emu = Arc::new(Mutex::new(LeapEmulator::new(&cfg)));
    let connector = InProcessConnector {
        emu: emu.clone(),
        baud: cfg.baud,
        usb_latency: cfg.usb_latency,
    };
    (emu, Box::new(connector))
}

fn lock(emu: &Mutex<LeapEmulator>) -> MutexGuard<'_, LeapEmulator> {
    emu.lock().unwrap_or_else(|p| p.into_inner())
}

struct InProcessConnector {
    emu: Arc<Mutex<LeapEmulator>>,
    baud: u32,
    usb_latency: Duration,
}

impl Connector for InProcessConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(InProcessLink {
            emu: self.emu.clone(),
            baud: self.baud,
            usb_latency: self.usb_latency,
            pending: Vec::with_capacity(1024),
            read_at: 0,
            due: Instant::now(),
            free: Instant::now(),
        }))
    }

    fn describe(&self) -> String {
        "emulated LEAP Hand (in-process)".into()
    }
}

struct InProcessLink {
    emu: Arc<Mutex<LeapEmulator>>,
    baud: u32,
    usb_latency: Duration,
    /// Replies not read yet (from `read_at`), all in at `due`.
    pending: Vec<u8>,
    /// When the line is next free.
    free: Instant,
    read_at: usize,
    due: Instant,
}

impl Transport for InProcessLink {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let now = Instant::now();
        if self.read_at >= self.pending.len() {
            self.pending.clear();
            self.read_at = 0;
        }
        let before = self.pending.len();
        lock(&self.emu).feed(bytes, now, &mut self.pending);
        let replies = self.pending.len() - before;
        // The half-duplex line: the request from when it is free, then the replies (Return
        // Delay Time 0, the LEAP's).
        self.free = self.free.max(now) + wire_time(bytes.len() + replies, self.baud);
        if replies > 0 {
            self.due = self.free + self.usb_latency;
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        let now = Instant::now();
        let left = self.pending.len() - self.read_at;
        if left == 0 || self.due > now + timeout {
            std::thread::sleep(timeout);
            return Ok(0);
        }
        if self.due > now {
            std::thread::sleep(self.due - now);
        }
        let n = left.min(buf.len());
        buf[..n].copy_from_slice(&self.pending[self.read_at..self.read_at + n]);
        self.read_at += n;
        Ok(n)
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        self.pending.clear();
        self.read_at = 0;
        Ok(())
    }
}

// ------------------------------------------------------------------ pseudo-terminal

/// An emulated hand behind a pseudo-terminal: a client opens [`Self::path`] like the U2D2's
/// port. Dropping it stops the thread and removes the link.
#[derive(Debug)]
pub struct VirtualLeap {
    link: PathBuf,
    emu: Arc<Mutex<LeapEmulator>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl VirtualLeap {
    /// Starts the hand on a new pty linked at `link`.
    pub fn start(link: impl AsRef<Path>, cfg: EmulatorConfig) -> std::io::Result<Self> {
        let link = link.as_ref().to_path_buf();
        let pty = Pty::open()?;
        replace_symlink(pty.slave_path(), &link)?;
        let emu = Arc::new(Mutex::new(LeapEmulator::new(&cfg)));
        let stop = Arc::new(AtomicBool::new(false));
        let (e, s, baud) = (emu.clone(), stop.clone(), cfg.baud);
        let latency = cfg.usb_latency;
        let thread = std::thread::Builder::new()
            .name("leap-emu".into())
            .spawn(move || serve(pty, e, s, baud, latency))?;
        Ok(Self {
            link,
            emu,
            stop,
            thread: Some(thread),
        })
    }

    pub fn path(&self) -> &Path {
        &self.link
    }

    /// The emulated hand (ground truth, objects).
    pub fn emulator(&self) -> MutexGuard<'_, LeapEmulator> {
        lock(&self.emu)
    }
}

impl Drop for VirtualLeap {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let _ = std::fs::remove_file(&self.link);
    }
}

fn serve(pty: Pty, emu: Arc<Mutex<LeapEmulator>>, stop: Arc<AtomicBool>, baud: u32, latency: Duration) {
    let mut buf = [0u8; 4096];
    let mut out = Vec::with_capacity(4096);
    let mut last_byte = Instant::now();
    while !stop.load(Ordering::SeqCst) {
        let readable =
            crate::serial::transport::poll_readable(pty.master_fd(), Duration::from_millis(2)).unwrap_or(false);
        let n = if readable { pty.read(&mut buf).unwrap_or(0) } else { 0 };
        let now = Instant::now();
        if n == 0 {
            let mut e = lock(&emu);
            e.step_to(now);
            // A half packet followed by silence: dropped, counted as truncated.
            if now.duration_since(last_byte) > Duration::from_millis(50) {
                e.reset_input();
            }
            continue;
        }
        last_byte = now;
        out.clear();
        lock(&emu).feed(&buf[..n], now, &mut out);
        if !out.is_empty() {
            let due = now + wire_time(out.len(), baud) + latency;
            let wait = due.saturating_duration_since(Instant::now());
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
            let _ = pty.write_all(&out);
        }
    }
}
