//! A virtual MX-64(2.0) bus on a pseudo-terminal: one or more servos with ids, each with a
//! control table, Protocol 2.0 instruction handling, a current-limited position servo driving
//! an EZGripper jaw (with a graspable object), 1 Mbaud wire timing and fault injection.
//!
//! Wire timing: bytes written by the driver reach the emulator at once through the pty, so
//! the emulator books them on a virtual line (10 bits per byte at the configured baud) and
//! answers only when the instruction would have fully arrived, plus each servo's Return
//! Delay Time (from its control table), plus the reply's own wire time. Replies of a sync
//! read follow one another on the line. Rates measured against the emulator therefore
//! include the serial line's cost; what they do not include is a USB adapter's latency
//! (configurable, [`EmulatorConfig::usb_latency`], default zero).
//!
//! Realism: the jaw's hard stops are [`ServoSpec`]'s own (closed stop and travel, an
//! assumption: SAKE publishes no tick figures), independent of the 0..5.4 rad range the
//! driver maps to; a servo powers up where the jaw was left ([`ServoSpec::start_ticks`]), and
//! Present Position / Velocity / Current carry measurement noise ([`EmulatorConfig::noise`],
//! default [`MX64_NOISE`]).

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::emu_common::Injected;
use crate::sim::{Contact, JointModel, JointParams, MotorTarget, Noise, Sensor};

use super::control_table::{
    reg, Access, HardwareError, OperatingMode, Reg, BAUD_RATE_1M, CURRENT_MA_PER_UNIT, MX64_2_MODEL_NUMBER,
    MX64_CURRENT_LIMIT_MAX, RETURN_DELAY_US_PER_UNIT, TICKS_PER_REV, VELOCITY_RPM_PER_UNIT,
};
use crate::dynamixel::protocol::{wire_time, Decoder, ErrorNumber, Request, Status, StatusError, BROADCAST_ID};
use crate::serial::pty::{replace_symlink, Pty};
use crate::serial::transport::{Connector, Transport, TransportError};

const RAD_PER_TICK: f32 = std::f32::consts::TAU / TICKS_PER_REV;
/// MX-64 torque constant at the output, N*m/A: 6.0 N*m stall at 4.1 A (12 V) [MX64 spec].
const TORQUE_PER_AMP: f32 = 6.0 / 4.1;

/// Measurement noise of an MX-64(2.0): Present Position half a tick (one standard deviation,
/// 2π/4096/2 = 7.7e-4 rad; after rounding to whole ticks the magnetic encoder's reading
/// flickers by one tick at rest, about a third of the readings off centre, and never by more
/// than two), Present Velocity 1 unit (0.229 rpm = 0.024 rad/s) and Present Current 1 unit
/// (3.36 mA, 0.0049 N*m through [`TORQUE_PER_AMP`]). Assumed orders of magnitude, not measured.
///
/// A full tick of deviation (readings up to ±3 ticks apart from one round to the next) is more
/// than a resting MX-64 shows, and it starved the driver's calibration stillness window
/// (`calibration_still_ticks` = 2): in 6000 simulated readings at rest it reset the window
/// 432 times against once with half a tick, and an emulated gripper could end its start-up
/// calibration "failed", reading closed for good.
pub const MX64_NOISE: Noise = Noise {
    q: RAD_PER_TICK * 0.5,
    dq: VELOCITY_RPM_PER_UNIT * std::f32::consts::TAU / 60.0,
    tau: CURRENT_MA_PER_UNIT / 1000.0 * TORQUE_PER_AMP,
    seed: Noise::DEFAULT_SEED,
};

/// One emulated servo + jaw.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoSpec {
    pub id: u8,
    /// Raw position of the closed hard stop (where calibration should land), ticks.
    pub closed_stop_ticks: i32,
    /// Travel from the closed stop to the open stop, ticks.
    pub travel_ticks: i32,
    /// Raw position at power-up, ticks.
    pub start_ticks: i32,
    /// An object between the fingers, at this many ticks above the closed stop.
    pub object_at_ticks: Option<i32>,
    /// Temperature the servo reports, deg C.
    pub temperature_c: u8,
    /// Faults of a jaw that reports but does not move (`--fault`, docs/adapters.md "Motion"):
    /// stuck, the jaw stays where it is; frozen, Present Position and Present Velocity keep
    /// their power-up reading (Present Current stays live); ignore-commands, Goal Position
    /// writes are acknowledged but not applied.
    pub faults: Injected<1>,
}

impl ServoSpec {
    pub fn new(id: u8) -> Self {
        Self {
            id,
            closed_stop_ticks: 1000,
            travel_ticks: 2700,
            start_ticks: 2200,
            object_at_ticks: None,
            temperature_c: 34,
            faults: Injected::default(),
        }
    }
}

/// Emulator settings.
#[derive(Debug, Clone)]
pub struct EmulatorConfig {
    pub baud: u32,
    pub servos: Vec<ServoSpec>,
    /// Extra delay before any reply reaches the host (a USB-serial adapter's latency).
    pub usb_latency: Duration,
    /// Echo the host's own bytes back, as a half-duplex adapter without echo suppression
    /// does (the driver must skip its instruction packets in the reply stream).
    pub echo: bool,
    /// Measurement noise of Present Position / Velocity / Current ([`Noise::OFF`] for exact
    /// values). Each servo draws from its own stream (the seed mixed with its id).
    pub noise: Noise,
}

impl EmulatorConfig {
    pub fn with_ids(ids: &[u8]) -> Self {
        Self {
            baud: 1_000_000,
            servos: ids.iter().map(|&id| ServoSpec::new(id)).collect(),
            usb_latency: Duration::ZERO,
            echo: false,
            noise: MX64_NOISE,
        }
    }
}

/// Faults to inject.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The servo's next `count` status packets are lost (the instruction is executed, its
    /// reply never reaches the host).
    NoReply { id: u8, count: u32 },
    /// The servo's next `count` status packets carry a wrong CRC.
    BadCrc { id: u8, count: u32 },
    /// The servo trips its overload protection: Hardware Error Status gets the overload bit,
    /// torque goes off, every status carries the alert bit until a reboot.
    Overload { id: u8 },
}

/// What the emulator saw (for tests).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    pub pings: u64,
    pub reads: u64,
    pub writes: u64,
    pub reboots: u64,
    pub sync_reads: u64,
    pub sync_writes: u64,
    /// Sync reads counted by the exact id list each one carried.
    pub sync_reads_by_ids: BTreeMap<Vec<u8>, u64>,
    pub statuses_sent: u64,
    pub bad_frames: u64,
    pub replugs: u64,
}

#[derive(Debug)]
struct ServoSim {
    spec: ServoSpec,
    table: Vec<u8>,
    joint: JointModel,
    sensor: Sensor,
    no_reply: u32,
    bad_crc: u32,
    /// Frozen: the Present Position and Present Velocity it repeats.
    frozen: Option<(i64, i64)>,
}

fn put(table: &mut [u8], r: Reg, v: i64) {
    let b = v.to_le_bytes();
    table[r.addr as usize..(r.addr + r.len) as usize].copy_from_slice(&b[..r.len as usize]);
}

fn get(table: &[u8], r: Reg) -> i64 {
    let s = &table[r.addr as usize..(r.addr + r.len) as usize];
    match r.len {
        1 => s[0] as i64,
        2 => i16::from_le_bytes([s[0], s[1]]) as i64,
        _ => i32::from_le_bytes([s[0], s[1], s[2], s[3]]) as i64,
    }
}

impl ServoSim {
    fn new(spec: ServoSpec, noise: Noise) -> Self {
        let q_min = spec.closed_stop_ticks as f32 * RAD_PER_TICK;
        let q_max = (spec.closed_stop_ticks + spec.travel_ticks) as f32 * RAD_PER_TICK;
        // Output-side figures of an MX-64 with a 200:1 gear: reflected rotor inertia and a
        // viscous loss that caps the speed near the spec's 63 rpm no-load at 6 N*m.
        let params = JointParams {
            inertia: 0.01,
            friction: 0.9,
            tau_max: 0.0,
            q_min,
            q_max,
        };
        let mut joint = JointModel::new(params, spec.start_ticks as f32 * RAD_PER_TICK);
        joint.contact = spec.object_at_ticks.map(|t| Contact {
            at: (spec.closed_stop_ticks + t) as f32 * RAD_PER_TICK,
            dir: -1.0,
            stiffness: 300.0,
        });
        let seed = noise.seed ^ (u64::from(spec.id) << 56);
        let mut s = Self {
            spec,
            table: vec![0; reg::TABLE_END as usize],
            joint,
            sensor: Sensor::new(noise.with_seed(seed)),
            no_reply: 0,
            bad_crc: 0,
            frozen: None,
        };
        s.factory_defaults();
        s.ram_defaults();
        s
    }

    /// EEPROM initial values [MX64].
    fn factory_defaults(&mut self) {
        let t = &mut self.table;
        put(t, reg::MODEL_NUMBER, MX64_2_MODEL_NUMBER as i64);
        put(t, reg::FIRMWARE_VERSION, 41);
        put(t, reg::ID, self.spec.id as i64);
        put(t, reg::BAUD_RATE, BAUD_RATE_1M as i64);
        put(t, reg::RETURN_DELAY_TIME, 250);
        put(t, reg::OPERATING_MODE, OperatingMode::Position as i64);
        put(t, reg::SECONDARY_ID, 255);
        put(t, reg::PROTOCOL_VERSION, 2);
        put(t, reg::MOVING_THRESHOLD, 10);
        put(t, reg::TEMPERATURE_LIMIT, 80);
        put(t, reg::MAX_VOLTAGE_LIMIT, 160);
        put(t, reg::MIN_VOLTAGE_LIMIT, 95);
        put(t, reg::PWM_LIMIT, 885);
        put(t, reg::CURRENT_LIMIT, MX64_CURRENT_LIMIT_MAX as i64);
        put(t, reg::ACCELERATION_LIMIT, 32767);
        put(t, reg::VELOCITY_LIMIT, 435);
        put(t, reg::MAX_POSITION_LIMIT, 4095);
        put(t, reg::MIN_POSITION_LIMIT, 0);
        put(t, reg::SHUTDOWN, 52);
    }

    /// RAM values after power-up or reboot [MX64].
    fn ram_defaults(&mut self) {
        let pos = self.present_ticks();
        let limit = get(&self.table, reg::CURRENT_LIMIT);
        let t = &mut self.table;
        t[reg::RAM_START as usize..].fill(0);
        put(t, reg::STATUS_RETURN_LEVEL, 2);
        put(t, reg::VELOCITY_I_GAIN, 1920);
        put(t, reg::VELOCITY_P_GAIN, 100);
        put(t, reg::POSITION_P_GAIN, 850);
        put(t, reg::GOAL_CURRENT, limit);
        put(t, reg::GOAL_POSITION, pos as i64);
        self.refresh_present();
    }

    fn present_ticks(&self) -> i32 {
        (self.joint.q / RAD_PER_TICK).round() as i32
    }

    fn torque_on(&self) -> bool {
        self.table[reg::TORQUE_ENABLE.addr as usize] != 0
    }

    fn hw_error(&self) -> HardwareError {
        HardwareError(self.table[reg::HARDWARE_ERROR_STATUS.addr as usize])
    }

    fn trip(&mut self, bits: u8) {
        let e = self.hw_error().0 | bits;
        put(&mut self.table, reg::HARDWARE_ERROR_STATUS, e as i64);
        if get(&self.table, reg::SHUTDOWN) as u8 & bits != 0 {
            put(&mut self.table, reg::TORQUE_ENABLE, 0);
        }
    }

    fn step(&mut self, dt: f32) {
        let t = &self.table;
        let mode = get(t, reg::OPERATING_MODE) as u8;
        let limit = get(t, reg::CURRENT_LIMIT).unsigned_abs() as f32;
        let current_cap = if mode == OperatingMode::CurrentBasedPosition as u8 {
            (get(t, reg::GOAL_CURRENT).unsigned_abs() as f32).min(limit)
        } else {
            limit
        };
        let target = if self.torque_on() {
            MotorTarget {
                q: get(t, reg::GOAL_POSITION) as f32 * RAD_PER_TICK,
                dq: 0.0,
                tau: 0.0,
                // Full current at about 200 ticks of error; damping keeps it from ringing.
                kp: 25.0,
                kd: 1.0,
            }
        } else {
            MotorTarget::LIMP
        };
        self.joint.params.tau_max = current_cap * CURRENT_MA_PER_UNIT / 1000.0 * TORQUE_PER_AMP;
        if self.spec.faults.stuck[0] {
            // A stuck jaw stays where it is, whatever the command, and no effort reaches it (a
            // slipping coupling: a stuck jaw is told from a grasp by its effort).
            self.joint.dq = 0.0;
            let q = self.joint.q;
            self.joint.step(&target, dt);
            self.joint.q = q;
            self.joint.dq = 0.0;
            self.joint.tau = 0.0;
        } else {
            self.joint.step(&target, dt);
        }
        self.refresh_present();
    }

    fn refresh_present(&mut self) {
        let r = self.sensor.read(&self.joint);
        let mut ticks = (r.q / RAD_PER_TICK).round() as i64;
        let mut vel_units = (r.dq * 60.0 / std::f32::consts::TAU / VELOCITY_RPM_PER_UNIT).round() as i64;
        if self.spec.faults.frozen {
            (ticks, vel_units) = *self.frozen.get_or_insert((ticks, vel_units));
        }
        let cur_units = (r.tau / TORQUE_PER_AMP * 1000.0 / CURRENT_MA_PER_UNIT).round() as i64;
        let moving = vel_units.abs() > get(&self.table, reg::MOVING_THRESHOLD);
        let temp = self.spec.temperature_c as i64;
        let t = &mut self.table;
        put(t, reg::PRESENT_POSITION, ticks);
        put(t, reg::PRESENT_VELOCITY, vel_units);
        put(t, reg::PRESENT_CURRENT, cur_units);
        put(
            t,
            reg::PRESENT_PWM,
            (cur_units * 885 / MX64_CURRENT_LIMIT_MAX as i64).clamp(-885, 885),
        );
        put(t, reg::MOVING, moving as i64);
        put(t, reg::PRESENT_INPUT_VOLTAGE, 120);
        put(t, reg::PRESENT_TEMPERATURE, temp);
        let goal = get(t, reg::GOAL_POSITION);
        put(t, reg::POSITION_TRAJECTORY, goal);
    }

    fn status(&self, number: ErrorNumber, params: Vec<u8>) -> Status {
        Status {
            id: self.spec.id,
            error: StatusError {
                alert: !self.hw_error().is_empty(),
                number,
            },
            params,
        }
    }

    fn read(&self, addr: u16, len: u16) -> Result<Vec<u8>, ErrorNumber> {
        let end = addr as usize + len as usize;
        if len == 0 || end > self.table.len() {
            return Err(ErrorNumber::AccessError);
        }
        Ok(self.table[addr as usize..end].to_vec())
    }

    /// Applies a write with the control table's rules; Err = status error number.
    fn write(&mut self, addr: u16, data: &[u8]) -> Result<(), ErrorNumber> {
        let start = addr as usize;
        let end = start + data.len();
        if data.is_empty() || end > self.table.len() {
            return Err(ErrorNumber::AccessError);
        }
        // Indirect area (168..) is free-form; the named table must be written whole items.
        let mut covered = vec![false; data.len()];
        for r in reg::ALL {
            let (ra, rb) = (r.addr as usize, (r.addr + r.len) as usize);
            if rb <= start || ra >= end {
                continue;
            }
            if ra < start || rb > end {
                return Err(ErrorNumber::DataLengthError);
            }
            if r.access == Access::ReadOnly {
                return Err(ErrorNumber::AccessError);
            }
            if r.addr < reg::RAM_START && self.torque_on() {
                return Err(ErrorNumber::AccessError);
            }
            for c in &mut covered[ra - start..rb - start] {
                *c = true;
            }
        }
        if start < 168 && covered.iter().enumerate().any(|(i, c)| !c && start + i < 168) {
            return Err(ErrorNumber::AccessError);
        }
        let mut t2 = self.table.clone();
        t2[start..end].copy_from_slice(data);
        let in_range = |r: Reg| (r.addr as usize) >= start && ((r.addr + r.len) as usize) <= end;
        if in_range(reg::OPERATING_MODE) && ![0, 1, 3, 4, 5, 16].contains(&get(&t2, reg::OPERATING_MODE)) {
            return Err(ErrorNumber::DataRangeError);
        }
        if in_range(reg::CURRENT_LIMIT) && get(&t2, reg::CURRENT_LIMIT) > MX64_CURRENT_LIMIT_MAX as i64 {
            return Err(ErrorNumber::DataRangeError);
        }
        if in_range(reg::GOAL_CURRENT) && get(&t2, reg::GOAL_CURRENT).abs() > get(&t2, reg::CURRENT_LIMIT) {
            return Err(ErrorNumber::DataLimitError);
        }
        if in_range(reg::GOAL_POSITION) && get(&t2, reg::OPERATING_MODE) == OperatingMode::Position as i64 {
            let g = get(&t2, reg::GOAL_POSITION);
            if g < get(&t2, reg::MIN_POSITION_LIMIT) || g > get(&t2, reg::MAX_POSITION_LIMIT) {
                return Err(ErrorNumber::DataLimitError);
            }
        }
        if in_range(reg::GOAL_POSITION) && self.spec.faults.ignore_commands {
            // Ignore-commands: the write is acknowledged, the goal stays.
            put(&mut t2, reg::GOAL_POSITION, get(&self.table, reg::GOAL_POSITION));
        }
        if in_range(reg::TORQUE_ENABLE) && !self.hw_error().is_empty() {
            // Torque cannot be enabled while a hardware error is latched; reboot clears it.
            put(&mut t2, reg::TORQUE_ENABLE, 0);
        }
        self.table = t2;
        Ok(())
    }

    fn reboot(&mut self) {
        put(&mut self.table, reg::HARDWARE_ERROR_STATUS, 0);
        self.joint.dq = 0.0;
        self.ram_defaults();
    }

    /// Answers an instruction addressed to this servo (or broadcast); None = no status.
    fn handle(&mut self, req: &Request) -> Option<Status> {
        let level = self.table[reg::STATUS_RETURN_LEVEL.addr as usize];
        match req {
            Request::Ping { .. } => {
                let mut p = (MX64_2_MODEL_NUMBER).to_le_bytes().to_vec();
                p.push(self.table[reg::FIRMWARE_VERSION.addr as usize]);
                Some(self.status(ErrorNumber::None, p))
            }
            Request::Read { addr, len, .. } => {
                let st = match self.read(*addr, *len) {
                    Ok(d) => self.status(ErrorNumber::None, d),
                    Err(e) => self.status(e, vec![]),
                };
                (level >= 1).then_some(st)
            }
            Request::Write { addr, data, id } => {
                let r = self.write(*addr, data);
                let st = self.status(r.err().unwrap_or(ErrorNumber::None), vec![]);
                (level >= 2 && *id != BROADCAST_ID).then_some(st)
            }
            Request::Reboot { id } => {
                self.reboot();
                (*id != BROADCAST_ID).then(|| self.status(ErrorNumber::None, vec![]))
            }
            Request::SyncRead { addr, len, ids } => {
                if !ids.contains(&self.spec.id) {
                    return None;
                }
                Some(match self.read(*addr, *len) {
                    Ok(d) => self.status(ErrorNumber::None, d),
                    Err(e) => self.status(e, vec![]),
                })
            }
            Request::SyncWrite { addr, entries, .. } => {
                if let Some((_, data)) = entries.iter().find(|(id, _)| *id == self.spec.id) {
                    let _ = self.write(*addr, data);
                }
                None
            }
            // The emulated MX-64 does not model Fast Sync Read (the EZGripper driver does not
            // send it): silence, as from a firmware without it.
            Request::FastSyncRead { .. } => None,
        }
    }
}

#[derive(Debug)]
struct Shared {
    servos: Vec<ServoSim>,
    stats: EmulatorStats,
    plugged: bool,
}

impl Shared {
    fn new(cfg: &EmulatorConfig) -> Self {
        Self {
            servos: cfg
                .servos
                .iter()
                .cloned()
                .map(|s| ServoSim::new(s, cfg.noise))
                .collect(),
            stats: EmulatorStats::default(),
            plugged: true,
        }
    }

    /// Answers one frame from the host: its replies, each with its servo's return delay, in
    /// line order; a frame that is not a request is counted and answered by nothing.
    fn answer(
        &mut self,
        frame: Result<crate::dynamixel::protocol::Packet, crate::dynamixel::protocol::FrameError>,
    ) -> Vec<(Vec<u8>, Duration)> {
        match frame.ok().and_then(|pk| Request::from_packet(&pk).ok()) {
            Some(req) => self.dispatch(&req),
            None => {
                self.stats.bad_frames += 1;
                Vec::new()
            }
        }
    }

    /// Executes a request on the addressed servos; returns each reply with its servo's
    /// return delay, in line order.
    fn dispatch(&mut self, req: &Request) -> Vec<(Vec<u8>, Duration)> {
        let sh = self;
        let st = &mut sh.stats;
        match req {
            Request::Ping { .. } => st.pings += 1,
            Request::Read { .. } => st.reads += 1,
            Request::Write { .. } => st.writes += 1,
            Request::Reboot { .. } => st.reboots += 1,
            Request::SyncRead { ids, .. } => {
                st.sync_reads += 1;
                *st.sync_reads_by_ids.entry(ids.clone()).or_default() += 1;
            }
            Request::SyncWrite { .. } => st.sync_writes += 1,
            Request::FastSyncRead { .. } => {}
        }
        let target = req.packet_id();
        // Reply order: sync read in the listed order, broadcast ping by id, else the one id.
        let order: Vec<u8> = match req {
            Request::SyncRead { ids, .. } => ids.clone(),
            _ if target == BROADCAST_ID => {
                let mut v: Vec<u8> = sh.servos.iter().map(|s| s.spec.id).collect();
                v.sort_unstable();
                v
            }
            _ => vec![target],
        };
        let mut out = Vec::new();
        for id in order {
            let Some(s) = sh.servos.iter_mut().find(|s| s.spec.id == id) else {
                continue;
            };
            let reply = s.handle(req);
            let Some(status) = reply else { continue };
            if s.no_reply > 0 {
                s.no_reply -= 1;
                continue;
            }
            let Ok(mut bytes) = status.encode() else { continue };
            if s.bad_crc > 0 {
                s.bad_crc -= 1;
                let n = bytes.len();
                bytes[n - 1] ^= 0x5A;
            }
            let delay = Duration::from_micros(
                s.table[reg::RETURN_DELAY_TIME.addr as usize] as u64 * RETURN_DELAY_US_PER_UNIT as u64,
            );
            out.push((bytes, delay));
        }
        out
    }

    /// Advances every servo to `now` (from `last`); a step is capped at 0.2 s so a starved
    /// caller slows the jaw down rather than teleporting it (JointModel sub-steps keep 0.2 s
    /// stable: 100 steps of 2 ms).
    fn step_to(&mut self, last: &mut Instant, now: Instant) {
        let dt = (now - *last).as_secs_f32().min(0.2);
        *last = now;
        if dt > 0.0 {
            for s in &mut self.servos {
                s.step(dt);
            }
        }
    }
}

/// The virtual line's timing: host->servo and servo->host share it, 10 bits a byte at the
/// bus's baud, and a reply reaches the host its USB latency after it is on the wire.
#[derive(Debug, Clone, Copy)]
struct Line {
    byte_time: Duration,
    usb_latency: Duration,
    /// When the line is next free.
    free: Instant,
}

impl Line {
    fn new(cfg: &EmulatorConfig) -> Self {
        Self {
            byte_time: wire_time(1, cfg.baud),
            usb_latency: cfg.usb_latency,
            free: Instant::now(),
        }
    }

    /// `n` bytes from the host, read at `now`: on the line from when it is free.
    fn receive(&mut self, n: usize, now: Instant) {
        self.free = self.free.max(now) + self.byte_time * n as u32;
    }

    /// A reply of `len` bytes after the servo's return `delay`: when it is all at the host.
    fn reply(&mut self, delay: Duration, len: usize) -> Instant {
        self.free += delay + self.byte_time * len as u32;
        self.free + self.usb_latency
    }
}

/// A running virtual bus. Dropping it stops the thread and removes the link.
#[derive(Debug)]
pub struct VirtualBus {
    link: PathBuf,
    shared: Arc<Mutex<Shared>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl VirtualBus {
    /// Starts the bus; the driver opens `link` like a serial device.
    pub fn start(link: impl AsRef<Path>, cfg: EmulatorConfig) -> io::Result<Self> {
        let link = link.as_ref().to_path_buf();
        let shared = Arc::new(Mutex::new(Shared::new(&cfg)));
        let stop = Arc::new(AtomicBool::new(false));
        let pty = Pty::open()?;
        replace_symlink(pty.slave_path(), &link)?;
        let worker = Worker {
            link: link.clone(),
            shared: shared.clone(),
            stop: stop.clone(),
            line: Line::new(&cfg),
            echo: cfg.echo,
        };
        let thread = std::thread::Builder::new()
            .name("ezgripper-emu".into())
            .spawn(move || worker.run(pty))?;
        Ok(Self {
            link,
            shared,
            stop,
            thread: Some(thread),
        })
    }

    /// The bus in-process: the servos answer on the driver's own thread through the
    /// returned [`Connector`] (`EzGripperBus::with_connector`), at the wire times the line
    /// books, as [`Self::start`]'s thread does over a pty. Nothing else has to be scheduled
    /// for a reply to be on time: on a machine busy with other work a thread of its own is
    /// not run for hundreds of ms now and then, and its replies missed the driver's deadline
    /// (the device went stale, issue #26). The pty form stays for the serial path itself and
    /// for `handgate emulate ezgripper`. [`Self::path`] is empty; faults, unplug and replug
    /// work the same.
    pub fn in_process(cfg: EmulatorConfig) -> (Self, Box<dyn Connector>) {
        let shared = Arc::new(Mutex::new(Shared::new(&cfg)));
        let connector = InProcessConnector {
            shared: shared.clone(),
            line: Line::new(&cfg),
            echo: cfg.echo,
            last_step: Arc::new(Mutex::new(Instant::now())),
        };
        let bus = Self {
            link: PathBuf::new(),
            shared,
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
        };
        (bus, Box::new(connector))
    }

    /// The pty's link ([`Self::start`]); empty for [`Self::in_process`].
    pub fn path(&self) -> &Path {
        &self.link
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn inject(&self, fault: Fault) {
        let mut s = self.lock();
        let find = |s: &mut Shared, id: u8| s.servos.iter_mut().position(|v| v.spec.id == id);
        match fault {
            Fault::NoReply { id, count } => {
                if let Some(i) = find(&mut s, id) {
                    s.servos[i].no_reply += count;
                }
            }
            Fault::BadCrc { id, count } => {
                if let Some(i) = find(&mut s, id) {
                    s.servos[i].bad_crc += count;
                }
            }
            Fault::Overload { id } => {
                if let Some(i) = find(&mut s, id) {
                    s.servos[i].trip(HardwareError::OVERLOAD);
                }
            }
        }
    }

    /// The adapter is pulled: the pty closes and the device path disappears.
    pub fn unplug(&self) {
        self.lock().plugged = false;
    }

    /// The adapter is plugged back in: a new pty appears at the same path.
    pub fn replug(&self) {
        self.lock().plugged = true;
    }

    /// Places (or removes) an object between the fingers of servo `id`, `ticks` above the
    /// closed stop.
    pub fn set_object(&self, id: u8, ticks: Option<i32>) {
        let mut s = self.lock();
        if let Some(v) = s.servos.iter_mut().find(|v| v.spec.id == id) {
            v.spec.object_at_ticks = ticks;
            v.joint.contact = ticks.map(|t| Contact {
                at: (v.spec.closed_stop_ticks + t) as f32 * RAD_PER_TICK,
                dir: -1.0,
                stiffness: 300.0,
            });
        }
    }

    /// Present raw position of servo `id` (ground truth for tests).
    pub fn position_ticks(&self, id: u8) -> Option<i32> {
        self.lock()
            .servos
            .iter()
            .find(|v| v.spec.id == id)
            .map(|v| v.present_ticks())
    }

    /// A control-table value of servo `id` (ground truth for tests).
    pub fn register(&self, id: u8, r: Reg) -> Option<i64> {
        self.lock()
            .servos
            .iter()
            .find(|v| v.spec.id == id)
            .map(|v| get(&v.table, r))
    }

    pub fn stats(&self) -> EmulatorStats {
        self.lock().stats.clone()
    }
}

impl Drop for VirtualBus {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if !self.link.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

struct Worker {
    link: PathBuf,
    shared: Arc<Mutex<Shared>>,
    stop: Arc<AtomicBool>,
    line: Line,
    echo: bool,
}

/// Sleeps until `deadline`. A plain sleep (Linux wakes it some 50-100 µs late, the timer
/// slack): the emulated line books its wire time on the clock, so a late wake-up delays the
/// reply without shortening the next one. No spinning: the emulated servos share the
/// gateway's CPU, and a thread that spins for its last few hundred µs (what this did before
/// issue #26) burns about a tenth of a core and, on a machine busy with other work, is
/// scheduled later for it, which is what made a loaded host's replies miss their deadline.
fn sleep_until(deadline: Instant) {
    let now = Instant::now();
    if deadline > now {
        std::thread::sleep(deadline - now);
    }
}

impl Worker {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn run(mut self, first: Pty) {
        let mut pty = Some(first);
        let mut decoder = Decoder::new();
        let mut last_step = Instant::now();
        let mut buf = [0u8; 4096];
        while !self.stop.load(Ordering::SeqCst) {
            let plugged = self.lock().plugged;
            if !plugged && pty.is_some() {
                pty = None; // closes master and our slave handle
                let _ = std::fs::remove_file(&self.link);
                decoder = Decoder::new();
            } else if plugged && pty.is_none() {
                match Pty::open().and_then(|p| replace_symlink(p.slave_path(), &self.link).map(|_| p)) {
                    Ok(p) => {
                        pty = Some(p);
                        self.lock().stats.replugs += 1;
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
            let Some(p) = pty.as_ref() else {
                std::thread::sleep(Duration::from_millis(1));
                self.step_physics(&mut last_step);
                continue;
            };
            let readable =
                crate::serial::transport::poll_readable(p.master_fd(), Duration::from_millis(1)).unwrap_or(false);
            let n = if readable { p.read(&mut buf).unwrap_or(0) } else { 0 };
            self.step_physics(&mut last_step);
            if n == 0 {
                continue;
            }
            self.line.receive(n, Instant::now());
            if self.echo {
                let _ = p.write_all(&buf[..n]);
            }
            decoder.push(&buf[..n]);
            while let Some(frame) = decoder.next_frame() {
                let replies = self.lock().answer(frame);
                for (bytes, delay) in replies {
                    sleep_until(self.line.reply(delay, bytes.len()));
                    self.step_physics(&mut last_step);
                    if p.write_all(&bytes).is_ok() {
                        self.lock().stats.statuses_sent += 1;
                    }
                }
            }
        }
    }

    fn step_physics(&self, last: &mut Instant) {
        self.lock().step_to(last, Instant::now());
    }
}

/// Opens [`InProcessLink`]s on a [`VirtualBus::in_process`] bus (a new one after an unplug
/// and replug, as a serial adapter is opened again).
struct InProcessConnector {
    shared: Arc<Mutex<Shared>>,
    line: Line,
    echo: bool,
    /// When the servos were last advanced (shared by the links, one after the other).
    last_step: Arc<Mutex<Instant>>,
}

impl Connector for InProcessConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        if !self.shared.lock().unwrap_or_else(|p| p.into_inner()).plugged {
            return Err(TransportError::NotFound {
                path: PathBuf::from("(emulated bus, unplugged)"),
            });
        }
        Ok(Box::new(InProcessLink {
            shared: self.shared.clone(),
            line: Line {
                free: Instant::now(),
                ..self.line
            },
            echo: self.echo,
            last_step: self.last_step.clone(),
            decoder: Decoder::new(),
            pending: std::collections::VecDeque::new(),
            unplugged: false,
        }))
    }

    fn describe(&self) -> String {
        "emulated bus (in-process)".into()
    }
}

/// The virtual line as a [`Transport`] on the driver's thread: what is written is booked on
/// the line and answered by the servos at once; each reply becomes readable when it would
/// have fully arrived (the request's wire time, the servo's Return Delay Time, the reply's
/// own wire time, the USB latency), the same timing as the pty form's thread.
struct InProcessLink {
    shared: Arc<Mutex<Shared>>,
    line: Line,
    echo: bool,
    last_step: Arc<Mutex<Instant>>,
    decoder: Decoder,
    /// Bytes on their way to the host and when they are all in.
    pending: std::collections::VecDeque<(Instant, Vec<u8>)>,
    /// The adapter was pulled while this link was open: it stays dead.
    unplugged: bool,
}

impl InProcessLink {
    /// Advances the servos to now; `Err` once the adapter is pulled.
    fn lock_live(&mut self) -> Result<MutexGuard<'_, Shared>, TransportError> {
        let mut sh = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        if !sh.plugged {
            self.unplugged = true;
        }
        if self.unplugged {
            return Err(TransportError::Disconnected);
        }
        let mut last = self.last_step.lock().unwrap_or_else(|p| p.into_inner());
        sh.step_to(&mut last, Instant::now());
        Ok(sh)
    }
}

impl Transport for InProcessLink {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let now = Instant::now();
        drop(self.lock_live()?);
        self.line.receive(bytes.len(), now);
        if self.echo {
            self.pending.push_back((now, bytes.to_vec()));
        }
        self.decoder.push(bytes);
        while let Some(frame) = self.decoder.next_frame() {
            let mut sh = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            for (reply, delay) in sh.answer(frame) {
                self.pending.push_back((self.line.reply(delay, reply.len()), reply));
                sh.stats.statuses_sent += 1;
            }
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        let deadline = Instant::now() + timeout;
        loop {
            let now = Instant::now();
            drop(self.lock_live()?);
            let mut n = 0;
            while let Some((due, bytes)) = self.pending.front() {
                if *due > now || n + bytes.len() > buf.len() {
                    break;
                }
                buf[n..n + bytes.len()].copy_from_slice(bytes);
                n += bytes.len();
                self.pending.pop_front();
            }
            if n > 0 {
                return Ok(n);
            }
            // Nothing in yet: sleep until the next reply is in, or the timeout.
            let next = self.pending.front().map_or(deadline, |(due, _)| (*due).min(deadline));
            if now >= deadline {
                return Ok(0);
            }
            std::thread::sleep(next.saturating_duration_since(now));
        }
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        let now = Instant::now();
        drop(self.lock_live()?);
        while self.pending.front().is_some_and(|(due, _)| *due <= now) {
            self.pending.pop_front();
        }
        Ok(())
    }
}

#[cfg(test)]
mod realism_tests {
    use super::*;

    fn readings(noise: Noise) -> Vec<[i64; 3]> {
        let mut s = ServoSim::new(ServoSpec::new(1), noise);
        (0..50)
            .map(|_| {
                s.step(0.001);
                [
                    get(&s.table, reg::PRESENT_POSITION),
                    get(&s.table, reg::PRESENT_VELOCITY),
                    get(&s.table, reg::PRESENT_CURRENT),
                ]
            })
            .collect()
    }

    /// A servo with `fault`, torque on, told to go 800 ticks down for 1 s: (its Present
    /// Position readings, the jaw's final ticks, its Goal Position).
    fn driven(fault: crate::emu_common::Fault) -> (Vec<i64>, i32, i64) {
        let spec = ServoSpec {
            faults: Injected::of(Some(fault), "an EZGripper").unwrap(),
            ..ServoSpec::new(1)
        };
        let goal = (spec.start_ticks - 800) as i64;
        let mut s = ServoSim::new(spec, MX64_NOISE);
        s.write(reg::TORQUE_ENABLE.addr, &[1]).unwrap();
        s.write(reg::GOAL_POSITION.addr, &(goal as i32).to_le_bytes()).unwrap();
        let reads = (0..500)
            .map(|_| {
                s.step(0.002);
                get(&s.table, reg::PRESENT_POSITION)
            })
            .collect();
        (reads, s.present_ticks(), get(&s.table, reg::GOAL_POSITION))
    }

    #[test]
    fn injected_faults_keep_the_jaw_or_its_reading_where_it_was() {
        use crate::emu_common::Fault;
        let start = ServoSpec::new(1).start_ticks;
        let (reads, at, _) = driven(Fault::Stuck(0));
        assert_eq!(at, start, "stuck");
        assert!(reads.iter().all(|r| (r - start as i64).abs() <= 3), "stuck: noise only");
        let (reads, at, _) = driven(Fault::Frozen);
        assert!((at - (start - 800)).abs() <= 20, "frozen: the jaw moves ({at})");
        assert!(reads.iter().all(|r| *r == reads[0]), "frozen: one reading repeated");
        let (_, at, goal) = driven(Fault::IgnoreCommands);
        assert_eq!(goal, start as i64, "ignore-commands: the goal stays");
        assert!((at - start).abs() <= 3, "ignore-commands: the jaw stays ({at})");
    }

    #[test]
    fn present_values_are_noisy_not_zero_and_the_same_seed_gives_the_same_noise() {
        let a = readings(MX64_NOISE);
        let start = ServoSpec::new(1).start_ticks as i64;
        assert!(a.iter().all(|r| r[0] != 0 && (r[0] - start).abs() <= 3), "{a:?}");
        assert!(a.iter().any(|r| r[0] != start), "no position noise: {a:?}");
        assert_eq!(a, readings(MX64_NOISE));
        assert_ne!(a, readings(MX64_NOISE.with_seed(MX64_NOISE.seed ^ 1)));
        let exact = readings(Noise::OFF);
        assert!(exact.iter().all(|r| *r == [start, 0, 0]), "{exact:?}");
        assert!(MX64_NOISE.validate().is_ok());
    }
}
