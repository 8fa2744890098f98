//! One RS-485 line of RH56 hands: one thread per port serving every hand on it (the arbiter:
//! only it talks on the line, one request at a time), on deadlines. The line speaks the hand's
//! serial protocol, Modbus RTU, or Modbus TCP to a DFTP's Ethernet port (the kit's codec,
//! [`crate::modbus`]); what it reads and writes is the same byte ranges of the register file.
//!
//! Each round, for every hand in id order: a write of ANGLE_SET when its target changed since
//! the last one written (the hand holds a target: a repeated one needs no bytes), a read of
//! ANGLE_ACT (12 bytes), and every [`BusConfig::slow_every`]-th round (staggered between the
//! hands) a read of FORCE_ACT..TEMP (force, current, error, status, temperature: 42 bytes); a
//! DFTP's tactile cells one batch a round ([`regs::TACTILE_BATCHES`]). A
//! hand that misses its reply is marked offline for that round and the others go on; a
//! transport failure (an unplugged adapter) reconnects with backoff, as the EZGripper's bus.
//! Nothing is allocated per round: every buffer is the thread's, reused.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::config::Protocol;
use super::proto::{self, Reply};
use super::regs::{self, FINGERS};
use crate::modbus::{pdu, rtu, tcp, Regs, Response};
use crate::serial::{Connector, SerialConnector, Transport, TransportError};

/// Wire time of `bytes` at `baud`, 8N1 (10 bits a byte).
pub fn wire_time(bytes: usize, baud: u32) -> Duration {
    Duration::from_secs_f64(bytes as f64 * 10.0 / f64::from(baud.max(1)))
}

/// The line's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BusConfig {
    pub baud: u32,
    /// The hands' ids, in the order each round serves them.
    pub ids: Vec<u8>,
    /// Grace for a reply beyond its wire time (the hand's turnaround, a USB adapter's latency).
    pub response_timeout: Duration,
    /// The round period; `None`: as fast as the line answers.
    pub period: Option<Duration>,
    /// The slow feedback (force, status, error, temperature) every this many rounds per hand.
    pub slow_every: u32,
    /// FORCE_SET and SPEED_SET written once at start (0..1000; `None`: the hand's own).
    pub force_set: Option<i16>,
    pub speed_set: Option<i16>,
    /// A reading older than this is stale.
    pub stale_after: Duration,
    pub protocol: Protocol,
    /// Read the DFTP's tactile cells (one batch a round per hand).
    pub tactile: bool,
}

impl Default for BusConfig {
    fn default() -> Self {
        BusConfig {
            baud: 115_200,
            ids: vec![1],
            response_timeout: Duration::from_millis(20),
            period: None,
            slow_every: 10,
            force_set: None,
            speed_set: None,
            stale_after: Duration::from_millis(500),
            protocol: Protocol::Serial,
            tactile: false,
        }
    }
}

/// What the line last read from one hand.
#[derive(Debug, PartialEq)]
pub struct HandReading {
    pub id: u8,
    /// The hand answered its last request.
    pub online: bool,
    /// Rounds with an ANGLE_ACT read so far.
    pub round: u64,
    pub measured_at: Instant,
    pub angle: [i16; FINGERS],
    pub force: [i16; FINGERS],
    pub current: [i16; FINGERS],
    pub error: [u8; FINGERS],
    pub status: [u8; FINGERS],
    pub temp: [u8; FINGERS],
    /// The slow block was read at least once.
    pub slow_read: bool,
    pub last_error: Option<&'static str>,
    /// A DFTP's tactile cells in address order ([`regs::TACTILE_REGIONS`]); empty when the line
    /// does not read them.
    pub tactile: Vec<u16>,
}

/// `clone_from` reuses the tactile buffer (the device loop copies a reading every round).
impl Clone for HandReading {
    fn clone(&self) -> Self {
        let mut r = HandReading::initial(self.id);
        r.clone_from(self);
        r
    }

    fn clone_from(&mut self, s: &Self) {
        let HandReading {
            id,
            online,
            round,
            measured_at,
            angle,
            force,
            current,
            error,
            status,
            temp,
            slow_read,
            last_error,
            tactile,
        } = s;
        (self.id, self.online, self.round, self.measured_at) = (*id, *online, *round, *measured_at);
        (self.angle, self.force, self.current) = (*angle, *force, *current);
        (self.error, self.status, self.temp) = (*error, *status, *temp);
        (self.slow_read, self.last_error) = (*slow_read, *last_error);
        self.tactile.clone_from(tactile);
    }
}

impl HandReading {
    fn initial(id: u8) -> Self {
        HandReading {
            id,
            online: false,
            round: 0,
            measured_at: Instant::now(),
            angle: [0; FINGERS],
            force: [0; FINGERS],
            current: [0; FINGERS],
            error: [0; FINGERS],
            status: [0; FINGERS],
            temp: [0; FINGERS],
            slow_read: false,
            last_error: None,
            tactile: Vec::new(),
        }
    }
}

/// The line's counters.
#[derive(Debug, Default)]
pub struct Counters {
    pub rounds: AtomicU64,
    pub requests: AtomicU64,
    pub timeouts: AtomicU64,
    pub bad_checksum: AtomicU64,
    /// Replies from another id, for another address, or not a reply to the request.
    pub mismatched: AtomicU64,
    pub refused_writes: AtomicU64,
    pub reconnects: AtomicU64,
    pub writes: AtomicU64,
}

/// A snapshot of [`Counters`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusStats {
    pub rounds: u64,
    pub requests: u64,
    pub timeouts: u64,
    pub bad_checksum: u64,
    pub mismatched: u64,
    pub refused_writes: u64,
    pub reconnects: u64,
    pub writes: u64,
}

impl Counters {
    pub fn snapshot(&self) -> BusStats {
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        BusStats {
            rounds: g(&self.rounds),
            requests: g(&self.requests),
            timeouts: g(&self.timeouts),
            bad_checksum: g(&self.bad_checksum),
            mismatched: g(&self.mismatched),
            refused_writes: g(&self.refused_writes),
            reconnects: g(&self.reconnects),
            writes: g(&self.writes),
        }
    }
}

/// Line failures.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    #[error("no hand with id {0} on this line")]
    UnknownId(u8),
    #[error("hand ids must be distinct (id {0} twice)")]
    DuplicateId(u8),
    #[error("could not start the line's thread: {0}")]
    Thread(#[from] std::io::Error),
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("`{0}` is not a host:port for Modbus TCP")]
    Address(String),
}

/// A DFTP's Ethernet port: a TCP connection per (re)connect.
#[derive(Debug, Clone)]
pub struct TcpConnector {
    pub addr: std::net::SocketAddr,
    pub timeout: Duration,
}

impl Connector for TcpConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(crate::modbus::master::TcpTransport::connect(
            self.addr,
            self.timeout,
        )?))
    }

    fn describe(&self) -> String {
        format!("Modbus TCP {}", self.addr)
    }
}

/// What the device asks of one hand (latest wins).
#[derive(Debug, Clone, Copy, Default)]
struct Pending {
    angle: Option<[i16; FINGERS]>,
    clear_error: bool,
}

struct Slot {
    id: u8,
    pending: Mutex<Pending>,
    tx: watch::Sender<HandReading>,
}

/// One RS-485 line of RH56 hands (one thread).
pub struct Rh56Bus {
    slots: Arc<Vec<Slot>>,
    counters: Arc<Counters>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    describe: String,
}

impl std::fmt::Debug for Rh56Bus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rh56Bus").field("line", &self.describe).finish()
    }
}

impl Rh56Bus {
    /// Opens the serial port at `path` (over Modbus TCP: connects to the address `path`) and
    /// starts the line.
    pub fn open(path: &str, cfg: BusConfig) -> Result<Self, BusError> {
        let c: Box<dyn Connector> = match cfg.protocol {
            Protocol::ModbusTcp => Box::new(TcpConnector {
                addr: path.parse().map_err(|_| BusError::Address(path.to_string()))?,
                timeout: Duration::from_secs(2),
            }),
            _ => Box::new(SerialConnector {
                path: path.into(),
                baud: cfg.baud,
            }),
        };
        Self::with_connector(c, cfg)
    }

    /// Starts the line over `connector` (a serial port, an in-process emulated line).
    pub fn with_connector(connector: Box<dyn Connector>, cfg: BusConfig) -> Result<Self, BusError> {
        let mut seen = Vec::new();
        for id in &cfg.ids {
            if seen.contains(id) {
                return Err(BusError::DuplicateId(*id));
            }
            seen.push(*id);
        }
        let slots: Arc<Vec<Slot>> = Arc::new(
            cfg.ids
                .iter()
                .map(|id| Slot {
                    id: *id,
                    pending: Mutex::new(Pending::default()),
                    tx: watch::channel(HandReading::initial(*id)).0,
                })
                .collect(),
        );
        let counters = Arc::new(Counters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let describe = connector.describe();
        let worker = Worker {
            slots: slots.clone(),
            counters: counters.clone(),
            stop: stop.clone(),
            cfg,
            connector,
            req: Vec::with_capacity(512),
            rx: Vec::with_capacity(2 * proto::MAX_READ),
            pdu: Vec::with_capacity(pdu::MAX_PDU),
            words: Vec::with_capacity(pdu::MAX_WRITE as usize),
            transaction: 0,
            written: Vec::new(),
        };
        let thread = std::thread::Builder::new().name("rh56-line".into()).spawn(move || {
            crate::realtime::enter_device_loop(); // [realtime]: this thread only
            worker.run()
        })?;
        Ok(Rh56Bus {
            slots,
            counters,
            stop,
            thread: Some(thread),
            describe,
        })
    }

    fn slot(&self, id: u8) -> Result<&Slot, BusError> {
        self.slots.iter().find(|s| s.id == id).ok_or(BusError::UnknownId(id))
    }

    /// Sets hand `id`'s angle targets (0..1000, -1 = keep), written at its next turn.
    pub fn set_angles(&self, id: u8, angles: [i16; FINGERS]) -> Result<(), BusError> {
        self.slot(id)?.pending.lock().unwrap_or_else(|p| p.into_inner()).angle = Some(angles);
        Ok(())
    }

    /// Clears hand `id`'s error bits at its next turn.
    pub fn clear_error(&self, id: u8) -> Result<(), BusError> {
        self.slot(id)?
            .pending
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clear_error = true;
        Ok(())
    }

    pub fn subscribe(&self, id: u8) -> Result<watch::Receiver<HandReading>, BusError> {
        Ok(self.slot(id)?.tx.subscribe())
    }

    pub fn ids(&self) -> Vec<u8> {
        self.slots.iter().map(|s| s.id).collect()
    }

    pub fn stats(&self) -> BusStats {
        self.counters.snapshot()
    }

    pub fn describe(&self) -> &str {
        &self.describe
    }
}

impl Drop for Rh56Bus {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Why one exchange failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Miss {
    Timeout,
    BadChecksum,
    Mismatched,
    Refused,
    /// The transport failed: reconnect.
    Link,
}

impl Miss {
    fn text(self) -> &'static str {
        match self {
            Miss::Timeout => "no reply in time",
            Miss::BadChecksum => "reply with a bad checksum",
            Miss::Mismatched => "reply not matching the request (id, command or address)",
            Miss::Refused => "write refused by the hand (result 0)",
            Miss::Link => "serial link failed",
        }
    }
}

struct Worker {
    slots: Arc<Vec<Slot>>,
    counters: Arc<Counters>,
    stop: Arc<AtomicBool>,
    cfg: BusConfig,
    connector: Box<dyn Connector>,
    req: Vec<u8>,
    rx: Vec<u8>,
    /// Modbus: the request PDU, a write's words, the last MBAP transaction id.
    pdu: Vec<u8>,
    words: Vec<u16>,
    transaction: u16,
    /// Per slot, the angles last written.
    written: Vec<Option<[i16; FINGERS]>>,
}

impl Worker {
    fn run(mut self) {
        self.written = vec![None; self.slots.len()];
        let mut link: Option<Box<dyn Transport>> = None;
        let mut backoff = Duration::from_millis(50);
        let mut round: u64 = 0;
        let mut next = Instant::now();
        let mut logged_down = false;
        while !self.stop.load(Ordering::Relaxed) {
            let Some(t) = link.as_mut() else {
                match self.connector.connect() {
                    Ok(t) => {
                        if round > 0 {
                            self.counters.reconnects.fetch_add(1, Ordering::Relaxed);
                            tracing::info!(line = %self.connector.describe(), "RH56 line back");
                        }
                        link = Some(t);
                        backoff = Duration::from_millis(50);
                        logged_down = false;
                        // Settings again after a reconnect (the hands may have been
                        // power-cycled with it), but never a target set before or during the
                        // unplug: the devices hold where they measure the hands until the next
                        // command (tests/tests/bus_replug.rs).
                        self.written.iter_mut().for_each(|w| *w = None);
                        if round > 0 {
                            for s in self.slots.iter() {
                                s.pending.lock().unwrap_or_else(|p| p.into_inner()).angle = None;
                            }
                        }
                        if let Some(t) = link.as_mut() {
                            self.settings(t.as_mut());
                        }
                    }
                    Err(e) => {
                        if !logged_down {
                            tracing::warn!(line = %self.connector.describe(), error = %e, "RH56 line unavailable; retrying");
                            logged_down = true;
                        }
                        self.all_offline(Miss::Link);
                        std::thread::sleep(backoff);
                        backoff = (backoff * 2).min(Duration::from_secs(1));
                        round += 1;
                    }
                }
                continue;
            };
            let mut failed = false;
            for i in 0..self.slots.len() {
                if self.serve(t.as_mut(), i, round) == Err(Miss::Link) {
                    failed = true;
                    break;
                }
            }
            self.counters.rounds.fetch_add(1, Ordering::Relaxed);
            round += 1;
            if failed {
                self.all_offline(Miss::Link);
                link = None;
                continue;
            }
            if let Some(p) = self.cfg.period {
                next += p;
                let now = Instant::now();
                if next > now {
                    std::thread::sleep(next - now);
                } else {
                    next = now;
                }
            }
        }
    }

    fn all_offline(&self, why: Miss) {
        for s in self.slots.iter() {
            s.tx.send_if_modified(|r| {
                let was = r.online;
                r.online = false;
                r.last_error = Some(why.text());
                was
            });
        }
    }

    /// FORCE_SET / SPEED_SET from the profile, to every hand.
    fn settings(&mut self, t: &mut dyn Transport) {
        for (reg, v) in [
            (regs::FORCE_SET, self.cfg.force_set),
            (regs::SPEED_SET, self.cfg.speed_set),
        ] {
            let Some(v) = v else { continue };
            let mut data = [0u8; regs::BLOCK];
            for k in 0..FINGERS {
                data[2 * k..2 * k + 2].copy_from_slice(&v.to_le_bytes());
            }
            for i in 0..self.slots.len() {
                let id = self.slots[i].id;
                if let Err(m) = self.write(t, id, reg, &data) {
                    tracing::warn!(id, register = reg, why = m.text(), "RH56 setting not written");
                }
            }
        }
    }

    /// One hand's turn in round `round`.
    fn serve(&mut self, t: &mut dyn Transport, i: usize, round: u64) -> Result<(), Miss> {
        let id = self.slots[i].id;
        let pending = std::mem::replace(
            &mut self.slots[i]
                .pending
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .clear_error,
            false,
        );
        let angle = self.slots[i].pending.lock().unwrap_or_else(|p| p.into_inner()).angle;
        if pending {
            self.write(t, id, regs::CLEAR_ERROR, &[1])
                .map_err(|m| self.miss(i, m))?;
        }
        if let Some(a) = angle {
            if self.written[i] != Some(a) {
                let mut data = [0u8; regs::BLOCK];
                for k in 0..FINGERS {
                    data[2 * k..2 * k + 2].copy_from_slice(&a[k].to_le_bytes());
                }
                self.write(t, id, regs::ANGLE_SET, &data).map_err(|m| self.miss(i, m))?;
                self.written[i] = Some(a);
            }
        }
        let mut angles = [0u8; regs::BLOCK];
        self.read(t, id, regs::ANGLE_ACT, &mut angles)
            .map_err(|m| self.miss(i, m))?;
        let every = u64::from(self.cfg.slow_every.max(1));
        let slow = !self.slots[i].tx.borrow().slow_read || (round + i as u64) % every == 0;
        let mut block = [0u8; regs::SLOW_BLOCK.1];
        if slow {
            self.read(t, id, regs::SLOW_BLOCK.0, &mut block)
                .map_err(|m| self.miss(i, m))?;
        }
        let mut cells = [0u8; 224];
        let batch = self
            .cfg
            .tactile
            .then(|| regs::TACTILE_BATCHES[((round + i as u64) % 11) as usize]);
        if let Some((addr, n)) = batch {
            self.read(t, id, addr, &mut cells[..n]).map_err(|m| self.miss(i, m))?;
        }
        let now = Instant::now();
        self.slots[i].tx.send_modify(|r| {
            if let Some((addr, n)) = batch {
                r.tactile.resize(regs::TACTILE_CELLS, 0);
                let first = (addr - regs::TACTILE) as usize / 2;
                for k in 0..n / 2 {
                    r.tactile[first + k] = u16::from_le_bytes([cells[2 * k], cells[2 * k + 1]]);
                }
            }
            r.online = true;
            r.round += 1;
            r.measured_at = now;
            r.last_error = None;
            r.angle = shorts(&angles);
            if slow {
                let o = |reg: u16| (reg - regs::SLOW_BLOCK.0) as usize;
                r.force = shorts(&block[o(regs::FORCE_ACT)..o(regs::FORCE_ACT) + regs::BLOCK]);
                r.current = shorts(&block[o(regs::CURRENT)..o(regs::CURRENT) + regs::BLOCK]);
                r.error
                    .copy_from_slice(&block[o(regs::ERROR)..o(regs::ERROR) + FINGERS]);
                r.status
                    .copy_from_slice(&block[o(regs::STATUS)..o(regs::STATUS) + FINGERS]);
                r.temp.copy_from_slice(&block[o(regs::TEMP)..o(regs::TEMP) + FINGERS]);
                r.slow_read = true;
            }
        });
        Ok(())
    }

    /// Counts `m` and marks slot `i` offline (a transport failure is the caller's).
    fn miss(&self, i: usize, m: Miss) -> Miss {
        let c = &self.counters;
        match m {
            Miss::Timeout => &c.timeouts,
            Miss::BadChecksum => &c.bad_checksum,
            Miss::Mismatched => &c.mismatched,
            Miss::Refused => &c.refused_writes,
            Miss::Link => return m,
        }
        .fetch_add(1, Ordering::Relaxed);
        self.slots[i].tx.send_if_modified(|r| {
            let was = r.online;
            r.online = false;
            r.last_error = Some(m.text());
            was
        });
        m
    }

    fn write(&mut self, t: &mut dyn Transport, id: u8, addr: u16, data: &[u8]) -> Result<(), Miss> {
        if self.cfg.protocol != Protocol::Serial {
            return self.modbus_write(t, id, addr, data);
        }
        proto::encode_write(id, addr, data, &mut self.req).map_err(|_| Miss::Mismatched)?;
        self.counters.writes.fetch_add(1, Ordering::Relaxed);
        match self.exchange(t, proto::SHORT_FRAME)? {
            Reply::WriteAck { id: rid, addr: a, ok } if rid == id && a == addr => {
                if ok {
                    Ok(())
                } else {
                    Err(Miss::Refused)
                }
            }
            _ => Err(Miss::Mismatched),
        }
    }

    fn read(&mut self, t: &mut dyn Transport, id: u8, addr: u16, out: &mut [u8]) -> Result<(), Miss> {
        if self.cfg.protocol != Protocol::Serial {
            return self.modbus_read(t, id, addr, out);
        }
        proto::encode_read(id, addr, out.len(), &mut self.req).map_err(|_| Miss::Mismatched)?;
        let (rid, a, n) = match self.exchange(t, out.len() + 8)? {
            Reply::Read { id, addr, data } => (id, addr, data.len()),
            _ => return Err(Miss::Mismatched),
        };
        if rid != id || a != addr || n != out.len() {
            return Err(Miss::Mismatched);
        }
        out.copy_from_slice(&self.rx[7..7 + n]);
        Ok(())
    }

    /// Sends `self.req` and reads one reply of `expect` bytes into `self.rx`, by a deadline of
    /// both frames' wire time plus the response timeout.
    fn exchange(&mut self, t: &mut dyn Transport, expect: usize) -> Result<Reply<'_>, Miss> {
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        t.clear_input().map_err(|_| Miss::Link)?;
        t.write_all(&self.req).map_err(|_| Miss::Link)?;
        let deadline = Instant::now() + wire_time(self.req.len() + expect, self.cfg.baud) + self.cfg.response_timeout;
        self.rx.clear();
        let mut buf = [0u8; 2 * proto::MAX_READ];
        loop {
            // Skip anything before a reply header (an echo, line noise).
            let start = self.rx.windows(2).position(|w| w == proto::REPLY_HEADER);
            match start {
                Some(s) if s > 0 => {
                    self.rx.drain(..s);
                }
                None if self.rx.len() > 1 => {
                    let keep = usize::from(self.rx.last() == Some(&proto::REPLY_HEADER[0]));
                    let cut = self.rx.len() - keep;
                    self.rx.drain(..cut);
                }
                _ => {}
            }
            match proto::decode_reply(&self.rx) {
                Ok(_) => break,
                Err(proto::FrameError::Incomplete { .. }) => {}
                Err(proto::FrameError::BadChecksum { .. }) => return Err(Miss::BadChecksum),
                Err(_) => return Err(Miss::Mismatched),
            }
            // Past the deadline, one last look without waiting: a reply that arrived in time
            // while this thread was not scheduled (a loaded host) is not a missed reply.
            let left = deadline.saturating_duration_since(Instant::now());
            let n = t.read(&mut buf, left).map_err(|_| Miss::Link)?;
            if n == 0 && left.is_zero() {
                return Err(Miss::Timeout);
            }
            self.rx.extend_from_slice(&buf[..n]);
        }
        proto::decode_reply(&self.rx)
            .map(|(r, _)| r)
            .map_err(|_| Miss::Mismatched)
    }
}

impl Worker {
    /// `self.pdu` framed for the line into `self.req` (RTU: slave and CRC; TCP: MBAP with the
    /// next transaction id); the reply's length for a response PDU of `reply_pdu` bytes.
    fn frame_modbus(&mut self, id: u8, reply_pdu: usize) -> usize {
        self.req.clear();
        match self.cfg.protocol {
            Protocol::ModbusTcp => {
                self.transaction = self.transaction.wrapping_add(1);
                tcp::encode(self.transaction, id, &self.pdu, &mut self.req);
                tcp::MBAP_LEN + reply_pdu
            }
            _ => {
                rtu::encode(id, &self.pdu, &mut self.req);
                reply_pdu + 3
            }
        }
    }

    fn modbus_read(&mut self, t: &mut dyn Transport, id: u8, addr: u16, out: &mut [u8]) -> Result<(), Miss> {
        let count = out.len().div_ceil(2) as u16;
        self.pdu.clear();
        pdu::Request::ReadHolding { addr, count }
            .encode(&mut self.pdu)
            .map_err(|_| Miss::Mismatched)?;
        let expect = self.frame_modbus(id, 2 + 2 * count as usize);
        match self.exchange_modbus(t, id, pdu::READ_HOLDING, expect)? {
            Response::ReadHolding(regs) if regs.len() == count as usize => {
                for (k, w) in regs.iter().enumerate() {
                    let b = w.to_le_bytes();
                    out[2 * k] = b[0];
                    if let Some(o) = out.get_mut(2 * k + 1) {
                        *o = b[1];
                    }
                }
                Ok(())
            }
            Response::Exception { .. } => Err(Miss::Refused),
            _ => Err(Miss::Mismatched),
        }
    }

    fn modbus_write(&mut self, t: &mut dyn Transport, id: u8, addr: u16, data: &[u8]) -> Result<(), Miss> {
        self.counters.writes.fetch_add(1, Ordering::Relaxed);
        self.words.clear();
        self.words.extend(
            data.chunks(2)
                .map(|c| u16::from_le_bytes([c[0], c.get(1).copied().unwrap_or(0)])),
        );
        self.pdu.clear();
        let (req, function) = match self.words.as_slice() {
            [value] => (pdu::Request::WriteSingle { addr, value: *value }, pdu::WRITE_SINGLE),
            words => (
                pdu::Request::WriteMultiple {
                    addr,
                    values: Regs::from_words(words),
                },
                pdu::WRITE_MULTIPLE,
            ),
        };
        req.encode(&mut self.pdu).map_err(|_| Miss::Mismatched)?;
        let expect = self.frame_modbus(id, 5);
        match self.exchange_modbus(t, id, function, expect)? {
            Response::WriteSingle { addr: a, .. } | Response::WriteMultiple { addr: a, .. } if a == addr => Ok(()),
            Response::Exception { .. } => Err(Miss::Refused),
            _ => Err(Miss::Mismatched),
        }
    }

    /// Sends `self.req` and reads the Modbus reply of `expect` bytes by its deadline (RTU: both
    /// frames' wire time plus the response timeout; TCP: the response timeout). Over TCP the
    /// transaction id is not checked: the DFTP's server answers with the wrong one
    /// (inspire-rh56dftp's notes); one request is in flight at a time, so nothing is mixed up.
    fn exchange_modbus(
        &mut self,
        t: &mut dyn Transport,
        id: u8,
        function: u8,
        expect: usize,
    ) -> Result<Response<'_>, Miss> {
        self.counters.requests.fetch_add(1, Ordering::Relaxed);
        t.clear_input().map_err(|_| Miss::Link)?;
        t.write_all(&self.req).map_err(|_| Miss::Link)?;
        let tcp = self.cfg.protocol == Protocol::ModbusTcp;
        let wire = if tcp {
            Duration::ZERO
        } else {
            wire_time(self.req.len() + expect, self.cfg.baud)
        };
        let deadline = Instant::now() + wire + self.cfg.response_timeout;
        self.rx.clear();
        let mut buf = [0u8; 512];
        let len = loop {
            let cut = if tcp {
                match tcp::decode(&self.rx) {
                    Ok(adu) if adu.header.unit != id => return Err(Miss::Mismatched),
                    Ok(adu) => Ok((tcp::MBAP_LEN, adu.len)),
                    Err(crate::modbus::TcpError::Incomplete { .. }) => Err(true),
                    Err(_) => return Err(Miss::Mismatched),
                }
            } else {
                match rtu::decode_response(&self.rx, function) {
                    Ok(f) if f.slave != id => return Err(Miss::Mismatched),
                    Ok(f) => Ok((1, f.len - 2)),
                    Err(crate::modbus::RtuError::Incomplete { .. }) => Err(true),
                    Err(crate::modbus::RtuError::BadCrc { .. }) => return Err(Miss::BadChecksum),
                    Err(_) => return Err(Miss::Mismatched),
                }
            };
            if let Ok(range) = cut {
                break range;
            }
            // Past the deadline, one last look without waiting: a reply that arrived in time
            // while this thread was not scheduled (a loaded host) is not a missed reply.
            let left = deadline.saturating_duration_since(Instant::now());
            let n = t.read(&mut buf, left).map_err(|_| Miss::Link)?;
            if n == 0 && left.is_zero() {
                return Err(Miss::Timeout);
            }
            self.rx.extend_from_slice(&buf[..n]);
        };
        Response::decode(&self.rx[len.0..len.1]).map_err(|_| Miss::Mismatched)
    }
}

fn shorts(b: &[u8]) -> [i16; FINGERS] {
    std::array::from_fn(|k| i16::from_le_bytes([b[2 * k], b[2 * k + 1]]))
}

/// An emulated line in-process: the hands answer on the line's own thread, each reply handed
/// over when its wire time at the line's baud has passed (request + reply), so the line runs at
/// the rate a real one would and nothing else must be scheduled for a reply to be on time.
pub struct EmulatedLine {
    pub line: Arc<Mutex<super::emulator::Line>>,
    pub baud: u32,
    /// What the hands answer: the serial protocol, Modbus RTU, or Modbus TCP (no wire time).
    pub protocol: Protocol,
}

impl Connector for EmulatedLine {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(EmulatedPort {
            line: self.line.clone(),
            baud: self.baud,
            protocol: self.protocol,
            inbox: Vec::with_capacity(512),
            reply: Vec::with_capacity(512),
            sent: 0,
            ready_at: Instant::now(),
        }))
    }

    fn describe(&self) -> String {
        format!("emulated RH56 line @ {} baud", self.baud)
    }
}

struct EmulatedPort {
    line: Arc<Mutex<super::emulator::Line>>,
    baud: u32,
    protocol: Protocol,
    inbox: Vec<u8>,
    reply: Vec<u8>,
    sent: usize,
    ready_at: Instant,
}

impl EmulatedPort {
    /// Answers the Modbus requests in the inbox (the hand whose id is the slave / unit id).
    fn answer_modbus(&mut self, start: Instant) {
        use super::modbus::{answer_tcp, HandMap};
        let mut line = self.line.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = std::mem::take(&mut self.reply);
        out.clear();
        let used = match self.protocol {
            Protocol::ModbusTcp => {
                let unit = self.inbox.get(6).copied().unwrap_or(0);
                match line.hand_mut(unit) {
                    Some(h) => {
                        h.step(start);
                        match answer_tcp(&mut HandMap(h), &self.inbox, &mut out) {
                            Ok(n) => n,
                            Err(e) => e.skip.unwrap_or(self.inbox.len()),
                        }
                    }
                    None => match tcp::decode(&self.inbox) {
                        Ok(adu) => adu.len,
                        Err(crate::modbus::TcpError::Incomplete { .. }) => 0,
                        Err(_) => self.inbox.len(),
                    },
                }
            }
            _ => match rtu::decode_request(&self.inbox) {
                Ok(f) => {
                    if let Some(h) = line.hand_mut(f.slave) {
                        h.step(start);
                        let begin = rtu::begin(&mut out, f.slave);
                        let _ = crate::modbus::server::respond(&mut HandMap(h), f.pdu, true, &mut out, &mut |_| {});
                        rtu::finish(&mut out, begin);
                    }
                    f.len
                }
                Err(crate::modbus::RtuError::Incomplete { .. }) => 0,
                Err(_) => self.inbox.len(),
            },
        };
        self.inbox.drain(..used.min(self.inbox.len()));
        if !out.is_empty() {
            let wire = if self.protocol == Protocol::ModbusTcp {
                Duration::ZERO
            } else {
                wire_time(used + out.len(), self.baud)
            };
            self.ready_at = start + wire;
            self.sent = 0;
        }
        self.reply = out;
    }
}

impl Transport for EmulatedPort {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let start = Instant::now();
        self.inbox.extend_from_slice(bytes);
        if self.protocol != Protocol::Serial {
            self.answer_modbus(start);
            return Ok(());
        }
        loop {
            match proto::decode_request(&self.inbox) {
                Ok((req, n)) => {
                    let mut line = self.line.lock().unwrap_or_else(|p| p.into_inner());
                    let mut out = std::mem::take(&mut self.reply);
                    if line.answer(&req, start, &mut out) {
                        self.ready_at = start + wire_time(n + out.len(), self.baud);
                        self.sent = 0;
                    } else {
                        out.clear();
                    }
                    self.reply = out;
                    self.inbox.drain(..n);
                }
                Err(proto::FrameError::Incomplete { .. }) => break,
                Err(_) => {
                    let skip = proto::resync(&self.inbox);
                    self.inbox.drain(..skip);
                }
            }
        }
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
        if self.sent >= self.reply.len() {
            std::thread::sleep(timeout);
            return Ok(0);
        }
        let now = Instant::now();
        if self.ready_at > now {
            let wait = self.ready_at - now;
            if wait > timeout {
                std::thread::sleep(timeout);
                return Ok(0);
            }
            std::thread::sleep(wait);
        }
        let n = (self.reply.len() - self.sent).min(buf.len());
        buf[..n].copy_from_slice(&self.reply[self.sent..self.sent + n]);
        self.sent += n;
        Ok(n)
    }

    fn clear_input(&mut self) -> Result<(), TransportError> {
        self.reply.clear();
        self.sent = 0;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inspire_rh56::emulator::{HandSpec, Line, Rh56Hand};

    fn line(ids: &[u8]) -> Arc<Mutex<Line>> {
        Arc::new(Mutex::new(Line::new(
            ids.iter().map(|id| Rh56Hand::new(HandSpec::new(*id))).collect(),
        )))
    }

    fn wait(rx: &mut watch::Receiver<HandReading>, ok: impl Fn(&HandReading) -> bool) -> HandReading {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let r = rx.borrow_and_update().clone();
            if ok(&r) {
                return r;
            }
            assert!(Instant::now() < deadline, "never: {r:?}");
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    #[test]
    fn two_hands_on_one_line_each_follow_their_own_target() {
        let l = line(&[1, 2]);
        let cfg = BusConfig {
            ids: vec![1, 2],
            speed_set: Some(1000),
            ..BusConfig::default()
        };
        let bus = Rh56Bus::with_connector(
            Box::new(EmulatedLine {
                line: l,
                baud: 115_200,
                protocol: Protocol::Serial,
            }),
            cfg,
        )
        .unwrap();
        bus.set_angles(1, [0, 0, 0, 0, 0, 0]).unwrap();
        bus.set_angles(2, [500, -1, 500, -1, 500, -1]).unwrap();
        let (mut a, mut b) = (bus.subscribe(1).unwrap(), bus.subscribe(2).unwrap());
        let r1 = wait(&mut a, |r| r.online && r.angle == [0; 6]);
        let r2 = wait(&mut b, |r| r.online && r.angle == [500, 1000, 500, 1000, 500, 1000]);
        assert!(r1.slow_read && r1.temp == [35; 6], "{r1:?}");
        assert!(r2
            .status
            .iter()
            .all(|s| *s == regs::status::POSITION_REACHED || *s == 0));
        assert_eq!(bus.stats().timeouts, 0);
        assert!(matches!(bus.set_angles(3, [0; 6]), Err(BusError::UnknownId(3))));
    }

    fn start(l: Arc<Mutex<Line>>, cfg: BusConfig) -> Rh56Bus {
        let protocol = cfg.protocol;
        Rh56Bus::with_connector(
            Box::new(EmulatedLine {
                line: l,
                baud: cfg.baud,
                protocol,
            }),
            cfg,
        )
        .unwrap()
    }

    /// The same line over Modbus RTU: both hands follow their targets, FC16 writes and FC03
    /// reads of the same byte ranges.
    #[test]
    fn two_hands_over_modbus_rtu_follow_their_own_target() {
        let bus = start(
            line(&[1, 2]),
            BusConfig {
                ids: vec![1, 2],
                protocol: Protocol::ModbusRtu,
                ..BusConfig::default()
            },
        );
        bus.set_angles(1, [100, 200, 300, 400, 500, 600]).unwrap();
        bus.set_angles(2, [0, -1, 0, -1, 0, -1]).unwrap();
        let (mut a, mut b) = (bus.subscribe(1).unwrap(), bus.subscribe(2).unwrap());
        let r1 = wait(&mut a, |r| r.online && r.angle == [100, 200, 300, 400, 500, 600]);
        wait(&mut b, |r| r.online && r.angle == [0, 1000, 0, 1000, 0, 1000]);
        assert_eq!(r1.temp, [35; 6]);
        let s = bus.stats();
        assert_eq!((s.timeouts, s.bad_checksum, s.mismatched), (0, 0, 0), "{s:?}");
    }

    /// A DFTP over Modbus TCP: its tactile cells, one batch a round, show the finger pressing
    /// on its object.
    #[test]
    fn a_dftp_over_modbus_tcp_reads_its_tactile_cells() {
        let mut spec = HandSpec::new(1);
        spec.tactile = true;
        spec.object_at[3] = Some(500.0);
        let l = Arc::new(Mutex::new(Line::new(vec![Rh56Hand::new(spec)])));
        let bus = start(
            l,
            BusConfig {
                protocol: Protocol::ModbusTcp,
                tactile: true,
                force_set: Some(1000),
                ..BusConfig::default()
            },
        );
        bus.set_angles(1, [1000, 1000, 1000, 0, 1000, 1000]).unwrap();
        let mut a = bus.subscribe(1).unwrap();
        // The index's pad (cells from byte 4320) at full force reads 4095; the pinky's 0.
        let r = wait(&mut a, |r| {
            r.tactile.len() == regs::TACTILE_CELLS && r.tactile[(4320 - 3000) / 2] == 4095 && r.angle[3] == 500
        });
        assert_eq!(r.tactile[0], 0);
        assert_eq!(r.status[3], regs::status::FORCE_REACHED);
        assert_eq!(r.force[3], 1000);
    }

    /// A hand that never answers is offline (timeouts counted, its reading says why); the other
    /// hand on the line goes on. Fails if a miss stopped the round or went uncounted.
    #[test]
    fn a_silent_hand_times_out_and_the_other_goes_on() {
        let l = line(&[1]);
        let cfg = BusConfig {
            ids: vec![1, 3],
            ..BusConfig::default()
        };
        let bus = Rh56Bus::with_connector(
            Box::new(EmulatedLine {
                line: l,
                baud: 115_200,
                protocol: Protocol::Serial,
            }),
            cfg,
        )
        .unwrap();
        let (mut a, mut c) = (bus.subscribe(1).unwrap(), bus.subscribe(3).unwrap());
        let first = wait(&mut a, |r| r.online && r.round > 0).round;
        wait(&mut a, |r| r.round >= first + 20);
        let r3 = c.borrow_and_update().clone();
        assert!(!r3.online && r3.round == 0, "{r3:?}");
        assert_eq!(r3.last_error, Some("no reply in time"));
        assert!(bus.stats().timeouts >= 20, "{:?}", bus.stats());
    }

    /// Two hands on one line at 115200 baud, as fast as the line answers: each hand's state
    /// rate is at least 100 Hz (what Unitree's DFX service polls) while both hands are
    /// commanded, and at least 80 % of the wire limit computed from the frames' lengths.
    #[test]
    fn two_hands_on_one_line_at_115200_each_read_at_100_hz_or_more() {
        let l = line(&[1, 2]);
        let cfg = BusConfig {
            ids: vec![1, 2],
            ..BusConfig::default()
        };
        let every = cfg.slow_every as f64;
        let bus = Rh56Bus::with_connector(
            Box::new(EmulatedLine {
                line: l,
                baud: 115_200,
                protocol: Protocol::Serial,
            }),
            cfg,
        )
        .unwrap();
        let (mut a, mut b) = (bus.subscribe(1).unwrap(), bus.subscribe(2).unwrap());
        wait(&mut a, |r| r.online);
        wait(&mut b, |r| r.online);
        // Targets changing every 20 ms (a 50 Hz teleoperation stream) on both hands.
        let (r0a, r0b, t0) = (a.borrow().round, b.borrow().round, Instant::now());
        let mut k = 0i16;
        while t0.elapsed() < Duration::from_secs(2) {
            k = (k + 37) % 1000;
            bus.set_angles(1, [k; 6]).unwrap();
            bus.set_angles(2, [1000 - k; 6]).unwrap();
            std::thread::sleep(Duration::from_millis(20));
        }
        let dt = t0.elapsed().as_secs_f64();
        let (ha, hb) = (
            (a.borrow().round - r0a) as f64 / dt,
            (b.borrow().round - r0b) as f64 / dt,
        );
        // The wire limit of this schedule: per hand per round a 9-byte read request and a
        // 20-byte reply, a slow read (9 + 50 bytes) every `every` rounds, and a write (20 + 9
        // bytes) per command, 50 a second.
        let bytes_per_round = 2.0 * (29.0 + 59.0 / every);
        let write_bytes_per_s = 2.0 * 50.0 * 29.0;
        let limit = (11_520.0 - write_bytes_per_s) / bytes_per_round;
        eprintln!("per hand: {ha:.1} Hz and {hb:.1} Hz; wire limit {limit:.1} Hz");
        for hz in [ha, hb] {
            assert!(hz >= 100.0, "{hz:.1} Hz < 100 Hz");
            assert!(hz >= 0.8 * limit, "{hz:.1} Hz < 80 % of the wire limit {limit:.1} Hz");
        }
        assert_eq!(bus.stats().timeouts, 0, "{:?}", bus.stats());
    }
}
