//! One RS-485 line of register-mapped hands: one thread per port (the arbiter: only it talks
//! on the line, one request at a time through the kit's [`RtuMaster`]), on deadlines.
//!
//! Each round, for every hand in slave order: an FC16 write of its target block when the
//! target changed since the last one written (a hand holds its target), then an FC03 read of
//! its state block. A hand that misses its reply (or answers an exception, a bad CRC...) is
//! marked offline for that round and the others go on. A transport failure (an unplugged
//! adapter) marks every hand offline and reconnects with backoff through the
//! [`Connector`]; the pending targets are dropped then, never replayed (the EZGripper's
//! rule: after a reconnect the hand holds where it is until the next command). Nothing is
//! allocated per round: the master's buffers and the thread's arrays are reused.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::MAX_BLOCK;
use crate::modbus::master::{MasterError, RtuMaster, RtuTiming};
use crate::serial::Connector;

/// The line's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct LineConfig {
    pub baud: u32,
    /// The hands' slave ids, in the order each round serves them.
    pub slaves: Vec<u8>,
    /// Grace for a reply beyond its wire time.
    pub response_timeout: Duration,
    /// The round period; `None`: as fast as the line answers.
    pub period: Option<Duration>,
    /// The state block (FC03) and the target block (FC16): (first register, count).
    pub state: (u16, u16),
    pub target: (u16, u16),
    pub init: &'static [(u16, &'static [u16])],
    /// RTU frames over TCP (no inter-frame gap, no wire time).
    pub over_tcp: bool,
}

/// A block of registers (a reading or a target) without allocation.
pub type Block = [u16; MAX_BLOCK];

/// What the line last read from one hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub slave: u8,
    /// The hand answered its last request.
    pub online: bool,
    /// Rounds with a state block read so far.
    pub round: u64,
    pub measured_at: Instant,
    regs: Block,
    len: usize,
    pub last_error: Option<&'static str>,
}

impl Reading {
    fn initial(slave: u8) -> Self {
        Reading {
            slave,
            online: false,
            round: 0,
            measured_at: Instant::now(),
            regs: [0; MAX_BLOCK],
            len: 0,
            last_error: None,
        }
    }

    /// The state block last read (empty before the first).
    pub fn regs(&self) -> &[u16] {
        &self.regs[..self.len]
    }
}

/// The line's counters.
#[derive(Debug, Default)]
pub struct LineCounters {
    pub rounds: AtomicU64,
    pub writes: AtomicU64,
    /// Replies missed: timeouts, bad CRC, wrong slave, exceptions, malformed.
    pub misses: AtomicU64,
    pub bad_crc: AtomicU64,
    pub reconnects: AtomicU64,
}

/// Line failures.
#[derive(Debug, thiserror::Error)]
pub enum LineError {
    #[error("no hand with slave id {0} on this line")]
    UnknownSlave(u8),
    #[error("slave ids must be distinct (id {0} twice)")]
    DuplicateSlave(u8),
    #[error("target of {got} registers, the hand takes {want}")]
    TargetLength { got: usize, want: usize },
    #[error("could not start the line's thread: {0}")]
    Thread(#[from] std::io::Error),
}

struct Slot {
    slave: u8,
    pending: Mutex<Option<Block>>,
    tx: watch::Sender<Reading>,
}

/// One line of hands (one thread); stops when dropped.
pub struct HandLine {
    slots: Arc<Vec<Slot>>,
    pub counters: Arc<LineCounters>,
    target_len: usize,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    describe: String,
}

impl std::fmt::Debug for HandLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HandLine").field("line", &self.describe).finish()
    }
}

impl HandLine {
    /// Starts the line over `connector` (a serial port, RTU over TCP, an emulated line).
    pub fn start(connector: Box<dyn Connector>, cfg: LineConfig) -> Result<Self, LineError> {
        for (i, s) in cfg.slaves.iter().enumerate() {
            if cfg.slaves[..i].contains(s) {
                return Err(LineError::DuplicateSlave(*s));
            }
        }
        let slots: Arc<Vec<Slot>> = Arc::new(
            cfg.slaves
                .iter()
                .map(|s| Slot {
                    slave: *s,
                    pending: Mutex::new(None),
                    tx: watch::channel(Reading::initial(*s)).0,
                })
                .collect(),
        );
        let counters = Arc::new(LineCounters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let describe = connector.describe();
        let target_len = cfg.target.1 as usize;
        let worker = Worker {
            slots: slots.clone(),
            counters: counters.clone(),
            stop: stop.clone(),
            written: vec![None; cfg.slaves.len()],
            cfg,
            connector,
        };
        let thread = std::thread::Builder::new().name("mb-hand-line".into()).spawn(move || {
            crate::realtime::enter_device_loop(); // [realtime]: this thread only
            worker.run()
        })?;
        Ok(HandLine {
            slots,
            counters,
            target_len,
            stop,
            thread: Some(thread),
            describe,
        })
    }

    fn slot(&self, slave: u8) -> Result<&Slot, LineError> {
        self.slots
            .iter()
            .find(|s| s.slave == slave)
            .ok_or(LineError::UnknownSlave(slave))
    }

    /// Sets hand `slave`'s target block, written at its next turn if it changed.
    pub fn set_target(&self, slave: u8, target: &[u16]) -> Result<(), LineError> {
        if target.len() != self.target_len {
            return Err(LineError::TargetLength {
                got: target.len(),
                want: self.target_len,
            });
        }
        let mut b = [0u16; MAX_BLOCK];
        b[..target.len()].copy_from_slice(target);
        *self.slot(slave)?.pending.lock().unwrap_or_else(|p| p.into_inner()) = Some(b);
        Ok(())
    }

    pub fn subscribe(&self, slave: u8) -> Result<watch::Receiver<Reading>, LineError> {
        Ok(self.slot(slave)?.tx.subscribe())
    }

    pub fn describe(&self) -> &str {
        &self.describe
    }
}

impl Drop for HandLine {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

struct Worker {
    slots: Arc<Vec<Slot>>,
    counters: Arc<LineCounters>,
    stop: Arc<AtomicBool>,
    cfg: LineConfig,
    connector: Box<dyn Connector>,
    /// Per slot, the target block last written.
    written: Vec<Option<Block>>,
}

/// The transport failed: reconnect.
struct LinkDown;

impl Worker {
    fn timing(&self) -> RtuTiming {
        let mut t = if self.cfg.over_tcp {
            RtuTiming::over_tcp()
        } else {
            RtuTiming::serial(self.cfg.baud)
        };
        t.response_timeout = self.cfg.response_timeout;
        t
    }

    fn run(mut self) {
        let mut master: Option<RtuMaster> = None;
        let mut up = false;
        let mut backoff = Duration::from_millis(50);
        let mut logged_down = false;
        let mut next = Instant::now();
        while !self.stop.load(Ordering::Relaxed) {
            if !up {
                match self.connector.connect() {
                    Ok(t) => {
                        match master.as_mut() {
                            Some(m) => {
                                m.replace_transport(t);
                                self.counters.reconnects.fetch_add(1, Ordering::Relaxed);
                                tracing::info!(line = %self.connector.describe(), "Modbus hand line back");
                                // Never replay a target set before the link went down.
                                for (s, w) in self.slots.iter().zip(self.written.iter_mut()) {
                                    *s.pending.lock().unwrap_or_else(|p| p.into_inner()) = None;
                                    *w = None;
                                }
                            }
                            None => master = Some(RtuMaster::new(t, self.timing())),
                        }
                        up = true;
                        backoff = Duration::from_millis(50);
                        logged_down = false;
                        if let Some(m) = master.as_mut() {
                            self.init(m);
                        }
                    }
                    Err(e) => {
                        if !logged_down {
                            tracing::warn!(line = %self.connector.describe(), error = %e, "Modbus hand line unavailable; retrying");
                            logged_down = true;
                        }
                        self.all_offline("serial link down");
                        std::thread::sleep(backoff);
                        backoff = (backoff * 2).min(Duration::from_secs(1));
                    }
                }
                continue;
            }
            let Some(m) = master.as_mut() else { break };
            for i in 0..self.slots.len() {
                if self.serve(m, i).is_err() {
                    up = false;
                    break;
                }
            }
            self.counters.rounds.fetch_add(1, Ordering::Relaxed);
            if !up {
                self.all_offline("serial link failed");
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

    fn init(&mut self, m: &mut RtuMaster) {
        for (addr, values) in self.cfg.init {
            for s in self.slots.iter() {
                if let Err(e) = m.write_multiple(s.slave, *addr, values) {
                    tracing::warn!(slave = s.slave, register = addr, error = %e, "Modbus hand setting not written");
                }
            }
        }
    }

    fn all_offline(&self, why: &'static str) {
        for s in self.slots.iter() {
            s.tx.send_if_modified(|r| {
                let was = r.online;
                r.online = false;
                r.last_error = Some(why);
                was
            });
        }
    }

    /// Counts a failed exchange with slot `i` and marks it offline; `Err` when the link
    /// itself failed.
    fn miss(&self, i: usize, e: &MasterError) -> Result<(), LinkDown> {
        if e.is_link_error() {
            return Err(LinkDown);
        }
        self.counters.misses.fetch_add(1, Ordering::Relaxed);
        if matches!(e, MasterError::BadCrc { .. }) {
            self.counters.bad_crc.fetch_add(1, Ordering::Relaxed);
        }
        let why = e.reason();
        self.slots[i].tx.send_if_modified(|r| {
            let was = r.online;
            r.online = false;
            r.last_error = Some(why);
            was
        });
        Ok(())
    }

    /// One hand's turn: its target if it changed, then its state block.
    fn serve(&mut self, m: &mut RtuMaster, i: usize) -> Result<(), LinkDown> {
        let slave = self.slots[i].slave;
        let pending = *self.slots[i].pending.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(target) = pending {
            if self.written[i] != Some(target) {
                let (addr, n) = self.cfg.target;
                match m.write_multiple(slave, addr, &target[..n as usize]) {
                    Ok(()) => {
                        self.written[i] = Some(target);
                        self.counters.writes.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(e) => return self.miss(i, &e),
                }
            }
        }
        let (addr, n) = self.cfg.state;
        let mut block = [0u16; MAX_BLOCK];
        if let Err(e) = m.read_holding(slave, addr, &mut block[..n as usize]) {
            return self.miss(i, &e);
        }
        let now = Instant::now();
        self.slots[i].tx.send_modify(|r| {
            r.online = true;
            r.round += 1;
            r.measured_at = now;
            r.regs = block;
            r.len = n as usize;
            r.last_error = None;
        });
        Ok(())
    }
}
