//! The EZGripper bus driver: one background thread per serial bus that loops
//! "sync-write goals, sync-read present values" as fast as the bus allows, serving every
//! gripper on the bus in the same round, and publishes measured state per gripper.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use super::control_table::{
    reg, EzGripperParams, HardwareError, OperatingMode, Reg, CURRENT_MA_PER_UNIT, GOAL_BLOCK, PRESENT_BLOCK,
    VOLTAGE_V_PER_UNIT,
};
use crate::dynamixel::protocol::{
    le_i16, le_i32, wire_time, CodecError, Decoder, FrameError, Instruction, Request, ServoId, Status, StatusRef,
};
use crate::serial::transport::{Connector, SerialConnector, Transport, TransportError};

pub use crate::model::Side;

/// Default servo id by side: 1 left, 2 right, 3 center (docs/sources.md §5).
pub fn default_id(side: Side) -> ServoId {
    let id = match side {
        Side::Left => 1,
        Side::Right => 2,
        Side::Center => 3,
    };
    ServoId::new(id).unwrap_or_else(|_| unreachable!("1..=3 are valid ids"))
}

/// One gripper on a bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GripperConfig {
    pub id: ServoId,
    /// A known calibration zero (raw ticks at the closed stop), e.g. from a previous run;
    /// used until a calibration replaces it.
    #[serde(default)]
    pub zero_ticks: Option<i32>,
}

impl GripperConfig {
    pub fn new(id: ServoId) -> Self {
        Self { id, zero_ticks: None }
    }
}

/// Everything about one bus. Serde-deserialisable; missing keys take the defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BusConfig {
    pub baud: u32,
    pub grippers: Vec<GripperConfig>,
    /// Grace time for a status beyond its computed wire time (USB adapter latency; an FTDI
    /// chip with its default 16 ms latency timer needs about 20 ms).
    pub response_timeout_ms: u64,
    /// A measurement older than this is stale.
    pub stale_after_ms: u64,
    /// Reconnect backoff after the port disappears: first wait, doubling up to the maximum.
    pub reconnect_min_ms: u64,
    pub reconnect_max_ms: u64,
    /// Run the calibration on every gripper without a `zero_ticks` when the bus opens.
    /// [SAKE `gripper.calibration.auto_on_init` = true; `--no-calibrate` turns it off]
    pub calibrate_on_start: bool,
    /// Fail `open` when no configured servo answers a ping (otherwise keep trying).
    pub require_answer_at_open: bool,
    /// Minimum round period; 0 = as fast as the bus allows.
    pub min_round_period_us: u64,
    /// After this many missed replies in a row a gripper is re-initialised when it answers.
    pub offline_after_misses: u32,
    pub ezgripper: EzGripperParams,
}

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            baud: 1_000_000,
            grippers: vec![GripperConfig::new(default_id(Side::Left))],
            response_timeout_ms: 20,
            stale_after_ms: 100,
            reconnect_min_ms: 50,
            reconnect_max_ms: 2000,
            calibrate_on_start: true,
            require_answer_at_open: true,
            min_round_period_us: 0,
            offline_after_misses: 5,
            ezgripper: EzGripperParams::default(),
        }
    }
}

/// Errors of the driver API.
#[derive(Debug, thiserror::Error)]
pub enum EzError {
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("no answer from servo(s) {ids:?} on {port}")]
    NoAnswer { port: String, ids: Vec<u8> },
    #[error("servo id {0} is not configured on this bus")]
    UnknownGripper(u8),
    #[error("invalid target: {0}")]
    InvalidTarget(String),
    #[error("invalid bus configuration: {0}")]
    Config(String),
    #[error(transparent)]
    Codec(#[from] CodecError),
    #[error("could not start the bus thread: {0}")]
    Thread(std::io::Error),
}

/// Grasp state as the SAKE driver publishes it in MotorState_.mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GraspState {
    Idle = 0,
    Moving = 1,
    Contact = 2,
    Grasping = 3,
}

impl GraspState {
    pub fn code(self) -> u8 {
        self as u8
    }
}

/// Calibration of one gripper.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Calibration {
    /// No zero known: targets are not applied, the servo holds where it is.
    Uncalibrated,
    Running,
    /// Zero known (raw ticks at the closed stop).
    Calibrated {
        zero_ticks: i32,
    },
    Failed {
        reason: String,
    },
}

impl Calibration {
    pub fn zero(&self) -> Option<i32> {
        match self {
            Calibration::Calibrated { zero_ticks } => Some(*zero_ticks),
            _ => None,
        }
    }
}

/// Measured state of one gripper.
#[derive(Debug, Clone, PartialEq)]
pub struct GripperState {
    pub id: ServoId,
    /// 0 = closed at the calibrated zero .. 100 = open, clamped; 0 when uncalibrated.
    pub position_pct: f32,
    /// Raw Present Position.
    pub position_ticks: i32,
    /// Position rate, %/s, positive = opening.
    pub velocity_pct_s: f32,
    /// Present Current, mA (signed). On the MX-64 this is the current the controller
    /// commands, see docs/ezgripper.md.
    pub current_ma: f32,
    /// Present Current as % of the configured current limit; positive = closing/squeezing.
    pub effort_pct: f32,
    pub temperature_c: u8,
    pub voltage_v: f32,
    pub hardware_error: HardwareError,
    pub grasp: GraspState,
    pub calibration: Calibration,
    /// The target being applied (position %, force %), if any.
    pub target: Option<Target>,
    /// The servo answered its last read.
    pub online: bool,
    /// When the values above were read off the bus.
    pub measured_at: Instant,
    /// Bus round that produced the values (grippers read in the same round share it).
    pub round: u64,
    /// No fresh measurement (bus disconnected, servo silent, or older than stale_after).
    pub stale: bool,
    pub last_error: Option<String>,
}

impl GripperState {
    pub(crate) fn initial(id: ServoId) -> Self {
        Self {
            id,
            position_pct: 0.0,
            position_ticks: 0,
            velocity_pct_s: 0.0,
            current_ma: 0.0,
            effort_pct: 0.0,
            temperature_c: 0,
            voltage_v: 0.0,
            hardware_error: HardwareError::NONE,
            grasp: GraspState::Idle,
            calibration: Calibration::Uncalibrated,
            target: None,
            online: false,
            measured_at: Instant::now(),
            round: 0,
            stale: true,
            last_error: None,
        }
    }
}

/// A commanded target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    pub position_pct: f32,
    pub force_pct: f32,
}

/// Per-gripper counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GripperCounters {
    /// Rounds whose sync read included this gripper.
    pub polls: u64,
    /// Polls answered with valid data.
    pub samples: u64,
    pub timeouts: u64,
    pub crc_errors: u64,
    pub status_errors: u64,
    pub hardware_alerts: u64,
    pub inits: u64,
}

/// Bus counters.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BusStats {
    pub connected: bool,
    pub rounds: u64,
    /// Rounds completed in the last full second.
    pub rounds_per_s: f64,
    pub timeouts: u64,
    pub crc_errors: u64,
    /// Malformed frames: an impossible length field, or a body with an unstuffed `FF FF FD`.
    pub bad_length: u64,
    /// Status packets that arrived after their transaction had timed out.
    pub late_replies: u64,
    pub truncated: u64,
    pub garbage_bytes: u64,
    pub disconnects: u64,
    pub reconnects: u64,
    pub last_error: Option<String>,
    /// Keyed by raw servo id.
    pub per_gripper: BTreeMap<u8, GripperCounters>,
}

#[derive(Debug)]
enum Cmd {
    Calibrate(u8),
    Reboot(u8),
}

#[derive(Debug, Default)]
struct Shared {
    targets: HashMap<u8, Target>,
    cmds: VecDeque<Cmd>,
    stats: BusStats,
    /// Round periods, kept only once someone asked for them ([`EzGripperBus::take_round_periods`]:
    /// the benchmark); a gateway never does, so its buses keep none (kept unasked, up to
    /// [`MAX_PERIODS`] of them grew a gateway's memory by about 4 MiB per bus over its first
    /// minutes: docs/reliability.md §6).
    periods: Option<VecDeque<Duration>>,
}

/// Round periods kept between two [`EzGripperBus::take_round_periods`] calls at most.
const MAX_PERIODS: usize = 200_000;
/// Attempts for a unicast request during open and init.
const UNICAST_ATTEMPTS: usize = 3;

/// A running bus.
pub struct EzGripperBus {
    shared: Arc<Mutex<Shared>>,
    states: BTreeMap<u8, watch::Sender<GripperState>>,
    stale_after: Duration,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for EzGripperBus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EzGripperBus")
            .field("ids", &self.states.keys())
            .finish()
    }
}

/// Handle on one gripper of a bus.
#[derive(Debug, Clone, Copy)]
pub struct Gripper<'a> {
    bus: &'a EzGripperBus,
    id: u8,
}

impl Gripper<'_> {
    /// Sets the target: position % (0 closed .. 100 open) and force limit % (of the
    /// configured current limit). Applied from the next bus round on.
    pub fn set_target(&self, position_pct: f32, force_pct: f32) -> Result<(), EzError> {
        if !position_pct.is_finite() || !force_pct.is_finite() {
            return Err(EzError::InvalidTarget(format!(
                "position {position_pct} % / force {force_pct} % must be finite"
            )));
        }
        let t = Target {
            position_pct: position_pct.clamp(0.0, 100.0),
            force_pct: force_pct.clamp(0.0, 100.0),
        };
        self.bus.lock().targets.insert(self.id, t);
        Ok(())
    }

    pub fn latest(&self) -> GripperState {
        self.bus
            .latest_raw(self.id)
            .unwrap_or_else(|_| unreachable!("handle ids are configured"))
    }

    pub fn subscribe(&self) -> watch::Receiver<GripperState> {
        self.bus.states[&self.id].subscribe()
    }

    pub fn calibrate(&self) {
        self.bus.lock().cmds.push_back(Cmd::Calibrate(self.id));
    }

    /// Reboots the servo (clears a latched hardware error) and re-initialises it.
    pub fn reboot(&self) {
        self.bus.lock().cmds.push_back(Cmd::Reboot(self.id));
    }
}

impl EzGripperBus {
    /// Opens the serial device at `path` and starts the bus thread.
    pub fn open(path: impl AsRef<Path>, cfg: BusConfig) -> Result<Self, EzError> {
        let connector = SerialConnector {
            path: PathBuf::from(path.as_ref()),
            baud: cfg.baud,
        };
        Self::with_connector(Box::new(connector), cfg)
    }

    /// Starts a bus over any [`Connector`] (the seam for other transports).
    pub fn with_connector(mut connector: Box<dyn Connector>, cfg: BusConfig) -> Result<Self, EzError> {
        if cfg.grippers.is_empty() {
            return Err(EzError::Config("no grippers configured".into()));
        }
        let mut seen = std::collections::BTreeSet::new();
        for g in &cfg.grippers {
            if !seen.insert(g.id) {
                return Err(EzError::Config(format!("servo id {} configured twice", g.id)));
            }
        }
        if cfg.ezgripper.grip_max_ticks <= 0 || cfg.ezgripper.current_limit_units == 0 {
            return Err(EzError::Config(
                "grip_max_ticks and current_limit_units must be > 0".into(),
            ));
        }
        let transport = connector.connect()?;
        let mut link = Link::new(transport, &cfg);
        if cfg.require_answer_at_open {
            let mut missing = Vec::new();
            for g in &cfg.grippers {
                let req = Request::Ping { id: g.id.get() };
                if link.ask(&req, g.id.get())?.is_none() {
                    missing.push(g.id.get());
                }
            }
            if missing.len() == cfg.grippers.len() {
                return Err(EzError::NoAnswer {
                    port: connector.describe(),
                    ids: missing,
                });
            }
        }
        let shared = Arc::new(Mutex::new(Shared::default()));
        let mut states = BTreeMap::new();
        for g in &cfg.grippers {
            let mut s = GripperState::initial(g.id);
            if let Some(z) = g.zero_ticks {
                s.calibration = Calibration::Calibrated { zero_ticks: z };
            }
            states.insert(g.id.get(), watch::channel(s).0);
        }
        let stop = Arc::new(AtomicBool::new(false));
        let worker = Worker::new(cfg.clone(), connector, shared.clone(), states.clone(), stop.clone());
        let thread = std::thread::Builder::new()
            .name("ezgripper-bus".into())
            .spawn(move || {
                crate::realtime::enter_device_loop(); // [realtime]: this thread only
                worker.run(Some(link))
            })
            .map_err(EzError::Thread)?;
        Ok(Self {
            shared,
            states,
            stale_after: Duration::from_millis(cfg.stale_after_ms),
            stop,
            thread: Some(thread),
        })
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn ids(&self) -> Vec<ServoId> {
        self.states.values().map(|s| s.borrow().id).collect()
    }

    pub fn gripper(&self, id: ServoId) -> Result<Gripper<'_>, EzError> {
        if self.states.contains_key(&id.get()) {
            Ok(Gripper {
                bus: self,
                id: id.get(),
            })
        } else {
            Err(EzError::UnknownGripper(id.get()))
        }
    }

    /// Latest state of gripper `id`, with `stale` recomputed against the current time.
    pub fn latest(&self, id: ServoId) -> Result<GripperState, EzError> {
        self.latest_raw(id.get())
    }

    fn latest_raw(&self, id: u8) -> Result<GripperState, EzError> {
        let tx = self.states.get(&id).ok_or(EzError::UnknownGripper(id))?;
        let mut s = tx.borrow().clone();
        s.stale = s.stale || s.measured_at.elapsed() > self.stale_after;
        Ok(s)
    }

    /// A watch channel that holds the newest state of gripper `id` (updated every round).
    pub fn subscribe(&self, id: ServoId) -> Result<watch::Receiver<GripperState>, EzError> {
        Ok(self.gripper(id)?.subscribe())
    }

    pub fn calibrate(&self, id: ServoId) -> Result<(), EzError> {
        self.gripper(id)?.calibrate();
        Ok(())
    }

    pub fn stats(&self) -> BusStats {
        self.lock().stats.clone()
    }

    /// Drains the recorded round periods (time between the starts of consecutive rounds
    /// that read at least one gripper), oldest first. Recording starts at the first call,
    /// which returns nothing.
    pub fn take_round_periods(&self) -> Vec<Duration> {
        match &mut self.lock().periods {
            Some(p) => p.drain(..).collect(),
            p @ None => {
                *p = Some(VecDeque::new());
                Vec::new()
            }
        }
    }

    /// Stops the bus thread (also done on drop).
    pub fn close(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for EzGripperBus {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// An open transport plus its decoder, and the buffers of its transactions (reused: a bus
/// round allocates nothing once they have grown).
struct Link {
    t: Box<dyn Transport>,
    dec: Decoder,
    baud: u32,
    grace: Duration,
    buf: Vec<u8>,
    /// The encoded request.
    tx: Vec<u8>,
    /// The ids a transaction still waits for.
    waiting: Vec<u8>,
    /// The replies of the last transaction.
    reply: Reply,
    /// Errors of every transaction (rounds, init, open) since the last drain.
    tally: Tally,
}

#[derive(Debug, Default)]
struct Tally {
    crc: BTreeMap<u8, u64>,
    timeouts: BTreeMap<u8, u64>,
    bad_length: u64,
    late: u64,
}

/// The status packets of one transaction. Its buffers stay from one transaction to the next:
/// `statuses[..len]` are this transaction's.
#[derive(Debug, Default)]
struct Reply {
    statuses: Vec<Status>,
    len: usize,
    /// Ids whose reply failed its CRC, with the count.
    bad_crc: Vec<(u8, u64)>,
    bad_length: u64,
}

impl Reply {
    fn clear(&mut self) {
        self.len = 0;
        self.bad_crc.clear();
        self.bad_length = 0;
    }

    fn add(&mut self, st: StatusRef<'_>) {
        match self.statuses.get_mut(self.len) {
            Some(slot) => {
                (slot.id, slot.error) = (st.id, st.error);
                slot.params.clear();
                slot.params.extend_from_slice(st.params);
            }
            None => self.statuses.push(st.to_status()),
        }
        self.len += 1;
    }

    fn get(&self, id: u8) -> Option<&Status> {
        self.statuses[..self.len].iter().find(|s| s.id == id)
    }

    fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn count_bad_crc(&mut self, id: u8) {
        match self.bad_crc.iter_mut().find(|(i, _)| *i == id) {
            Some((_, n)) => *n += 1,
            None => self.bad_crc.push((id, 1)),
        }
    }

    fn had_bad_crc(&self, id: u8) -> bool {
        self.bad_crc.iter().any(|(i, _)| *i == id)
    }
}

impl Link {
    fn new(t: Box<dyn Transport>, cfg: &BusConfig) -> Self {
        Self {
            t,
            dec: Decoder::new(),
            baud: cfg.baud,
            grace: Duration::from_millis(cfg.response_timeout_ms),
            buf: vec![0; 4096],
            tx: Vec::new(),
            waiting: Vec::new(),
            reply: Reply::default(),
            tally: Tally::default(),
        }
    }

    fn send(&mut self, req: &Request) -> Result<usize, TransportError> {
        req.encode_into(&mut self.tx)
            .map_err(|e| TransportError::Io(std::io::Error::other(e.to_string())))?;
        self.t.write_all(&self.tx)?;
        Ok(self.tx.len())
    }

    /// Sends `req` and collects the status packets of `expect` (in any order) into
    /// `self.reply` until all are in or the deadline (wire time of request and replies +
    /// grace) passes.
    fn transact(&mut self, req: &Request, expect: &[u8]) -> Result<(), TransportError> {
        self.drain_late()?;
        let sent = self.send(req)?;
        let reply_len = match req {
            Request::Read { len, .. } | Request::SyncRead { len, .. } => 11 + *len as usize,
            Request::Ping { .. } => 14,
            _ => 11,
        };
        let deadline = Instant::now() + wire_time(sent + reply_len * expect.len(), self.baud) + self.grace;
        let (out, waiting) = (&mut self.reply, &mut self.waiting);
        out.clear();
        waiting.clear();
        waiting.extend_from_slice(expect);
        let mut late_budget: usize = 4096;
        while !waiting.is_empty() {
            while let Some(frame) = self.dec.next_frame_ref() {
                match frame {
                    Ok(pk) if pk.instruction == Instruction::Status as u8 => {
                        if let Ok(st) = StatusRef::from_packet(pk) {
                            if waiting.contains(&st.id) && answers(req, &st) {
                                waiting.retain(|&id| id != st.id);
                                out.add(st);
                            } else {
                                // A late reply to an earlier request (Protocol 2.0 carries
                                // no sequence number; the shape tells them apart).
                                self.tally.late += 1;
                            }
                        }
                    }
                    Ok(_) => {} // our own instruction echoed back by a half-duplex adapter
                    Err(FrameError::BadCrc { id, .. }) => {
                        out.count_bad_crc(id);
                        // A corrupted reply will not be repeated: stop waiting for it.
                        waiting.retain(|&w| w != id);
                    }
                    Err(FrameError::BadLength { .. }) => out.bad_length += 1,
                    Err(FrameError::Unstuffed { id }) => {
                        // Malformed like an impossible length; the reply will not be repeated.
                        out.bad_length += 1;
                        waiting.retain(|&w| w != id);
                    }
                }
            }
            if waiting.is_empty() {
                break;
            }
            // Past the deadline, what has already arrived still counts: a reply the servo sent
            // in time but this thread read late (it was not scheduled: a loaded host) is not a
            // missed reply. Only what is there now is read then, at most `late_budget` bytes.
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() && late_budget == 0 {
                break;
            }
            let n = self.t.read(&mut self.buf, left)?;
            if left.is_zero() {
                if n == 0 {
                    break;
                }
                late_budget = late_budget.saturating_sub(n);
            }
            self.dec.push(&self.buf[..n]);
        }
        for &(id, n) in &out.bad_crc {
            *self.tally.crc.entry(id).or_default() += n;
        }
        for &id in waiting.iter() {
            if !out.had_bad_crc(id) {
                *self.tally.timeouts.entry(id).or_default() += 1;
            }
        }
        self.tally.bad_length += out.bad_length;
        Ok(())
    }

    /// Reads and accounts what arrived after its transaction's deadline (late replies, a
    /// corrupted late reply counts as a CRC error), then starts the decoder afresh.
    fn drain_late(&mut self) -> Result<(), TransportError> {
        let mut budget: usize = 64 * 1024;
        while budget > 0 {
            let n = self.t.read(&mut self.buf, Duration::ZERO)?;
            if n == 0 {
                break;
            }
            budget = budget.saturating_sub(n);
            self.dec.push(&self.buf[..n]);
        }
        while let Some(frame) = self.dec.next_frame() {
            match frame {
                Ok(pk) if pk.instruction == Instruction::Status as u8 => self.tally.late += 1,
                Ok(_) => {}
                Err(FrameError::BadCrc { id, .. }) => *self.tally.crc.entry(id).or_default() += 1,
                Err(FrameError::BadLength { .. } | FrameError::Unstuffed { .. }) => self.tally.bad_length += 1,
            }
        }
        self.dec.reset();
        Ok(())
    }

    /// One unicast request with its status, retried (it must be idempotent) when the reply
    /// is lost: init and open should not fail on a single dropped packet.
    fn ask(&mut self, req: &Request, id: u8) -> Result<Option<Status>, TransportError> {
        for _ in 0..UNICAST_ATTEMPTS {
            self.transact(req, &[id])?;
            if let Some(st) = self.reply.get(id) {
                return Ok(Some(st.clone()));
            }
        }
        Ok(None)
    }

    fn write_reg(&mut self, id: u8, r: Reg, v: i64) -> Result<Result<(), String>, TransportError> {
        let data = v.to_le_bytes()[..r.len as usize].to_vec();
        let rep = self.ask(&Request::Write { id, addr: r.addr, data }, id)?;
        Ok(match rep.as_ref() {
            Some(st) if st.error.number == crate::dynamixel::protocol::ErrorNumber::None => Ok(()),
            Some(st) => Err(format!("write {} -> {:?}", r.addr, st.error.number)),
            None => Err(format!("no answer writing address {}", r.addr)),
        })
    }

    fn read_reg(&mut self, id: u8, r: Reg) -> Result<Result<i64, String>, TransportError> {
        let rep = self.ask(
            &Request::Read {
                id,
                addr: r.addr,
                len: r.len,
            },
            id,
        )?;
        Ok(match rep.as_ref() {
            Some(st) if st.params.len() == r.len as usize => Ok(match r.len {
                1 => st.params[0] as i64,
                2 => le_i16(&st.params).unwrap_or(0) as i64,
                _ => le_i32(&st.params).unwrap_or(0) as i64,
            }),
            Some(st) => Err(format!("read {} -> {:?}", r.addr, st.error.number)),
            None => Err(format!("no answer reading address {}", r.addr)),
        })
    }
}

/// Driver-side runtime state of one gripper.
struct Runtime {
    id: u8,
    state: GripperState,
    initialised: bool,
    /// Initialised at least once (a later initialisation is a re-initialisation).
    ever_initialised: bool,
    misses: u32,
    last_init_try: Option<Instant>,
    /// Goal used while no target applies (present position at init).
    hold_ticks: i32,
    cal: Option<CalRun>,
    cal_requested: bool,
    contact_rounds: u32,
    /// Goal current sent this round (for the contact decision).
    goal_current: u16,
    /// The API's target, read at the start of the round.
    api_target: Option<Target>,
    /// Initialised when this round started: served by its sync write and read.
    in_round: bool,
}

struct CalRun {
    started: Instant,
    goal: i32,
    anchor: i32,
    anchor_since: Instant,
    still_samples: u32,
}

struct Worker {
    cfg: BusConfig,
    p: EzGripperParams,
    connector: Box<dyn Connector>,
    shared: Arc<Mutex<Shared>>,
    tx: BTreeMap<u8, watch::Sender<GripperState>>,
    stop: Arc<AtomicBool>,
    rt: Vec<Runtime>,
    round: u64,
    last_round_start: Option<Instant>,
    rate_window: (Instant, u64),
    requests: RoundRequests,
}

/// The two requests of a bus round, kept from one round to the next: only their values
/// change, their buffers stay.
struct RoundRequests {
    /// Sync write of the round's goals.
    goals: Request,
    /// Sync read of the round's present values.
    present: Request,
}

impl RoundRequests {
    fn new() -> Self {
        Self {
            goals: Request::SyncWrite {
                addr: GOAL_BLOCK.addr,
                len: GOAL_BLOCK.len,
                entries: Vec::new(),
            },
            present: Request::SyncRead {
                addr: PRESENT_BLOCK.addr,
                len: PRESENT_BLOCK.len,
                ids: Vec::new(),
            },
        }
    }

    /// Sizes both requests for `n` grippers.
    fn resize(&mut self, n: usize) {
        if let Request::SyncWrite { entries, .. } = &mut self.goals {
            entries.resize_with(n, Default::default);
        }
        if let Request::SyncRead { ids, .. } = &mut self.present {
            ids.resize(n, 0);
        }
    }

    /// Gripper `k` of the round: servo `id` and its goals.
    fn set(&mut self, k: usize, id: u8, p: &EzGripperParams, current: u16, goal: i32) {
        if let Request::SyncWrite { entries, .. } = &mut self.goals {
            entries[k].0 = id;
            goal_block_into(p, current, goal, &mut entries[k].1);
        }
        if let Request::SyncRead { ids, .. } = &mut self.present {
            ids[k] = id;
        }
    }

    /// The round's servo ids, in order.
    fn ids(&self) -> &[u8] {
        match &self.present {
            Request::SyncRead { ids, .. } => ids,
            _ => &[],
        }
    }
}

impl Worker {
    fn new(
        cfg: BusConfig,
        connector: Box<dyn Connector>,
        shared: Arc<Mutex<Shared>>,
        tx: BTreeMap<u8, watch::Sender<GripperState>>,
        stop: Arc<AtomicBool>,
    ) -> Self {
        let rt = cfg
            .grippers
            .iter()
            .map(|g| Runtime {
                id: g.id.get(),
                state: tx[&g.id.get()].borrow().clone(),
                initialised: false,
                ever_initialised: false,
                misses: 0,
                last_init_try: None,
                hold_ticks: 0,
                cal: None,
                cal_requested: cfg.calibrate_on_start && g.zero_ticks.is_none(),
                contact_rounds: 0,
                goal_current: 0,
                api_target: None,
                in_round: false,
            })
            .collect();
        Self {
            p: cfg.ezgripper.clone(),
            cfg,
            connector,
            shared,
            tx,
            stop,
            rt,
            round: 0,
            last_round_start: None,
            rate_window: (Instant::now(), 0),
            requests: RoundRequests::new(),
        }
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn note_error(&self, e: &str) {
        self.lock().stats.last_error = Some(e.to_string());
    }

    fn run(mut self, mut link: Option<Link>) {
        let mut backoff = Duration::from_millis(self.cfg.reconnect_min_ms);
        let mut was_connected = link.is_some();
        self.lock().stats.connected = link.is_some();
        while !self.stop.load(Ordering::SeqCst) {
            let Some(l) = link.as_mut() else {
                // Reconnect with backoff, in small sleeps so stop stays responsive.
                let until = Instant::now() + backoff;
                while Instant::now() < until && !self.stop.load(Ordering::SeqCst) {
                    std::thread::sleep(Duration::from_millis(5).min(backoff));
                }
                match self.connector.connect() {
                    Ok(t) => {
                        link = Some(Link::new(t, &self.cfg));
                        backoff = Duration::from_millis(self.cfg.reconnect_min_ms);
                        let mut sh = self.lock();
                        sh.stats.connected = true;
                        if was_connected {
                            sh.stats.reconnects += 1;
                        }
                        was_connected = true;
                    }
                    Err(e) => {
                        self.note_error(&e.to_string());
                        backoff = (backoff * 2).min(Duration::from_millis(self.cfg.reconnect_max_ms.max(1)));
                    }
                }
                continue;
            };
            let started = Instant::now();
            let res = self.round(l);
            self.drain_tally(l);
            match res {
                Ok(()) => {}
                Err(e) => {
                    tracing::warn!(error = %e, "Dynamixel bus lost; reconnecting");
                    self.note_error(&e.to_string());
                    link = None;
                    {
                        let mut sh = self.lock();
                        sh.stats.connected = false;
                        sh.stats.disconnects += 1;
                    }
                    for i in 0..self.rt.len() {
                        let r = &mut self.rt[i];
                        r.initialised = false;
                        r.state.online = false;
                        r.state.stale = true;
                        r.state.last_error = Some(e.to_string());
                        self.publish(i);
                    }
                    continue;
                }
            }
            let min = Duration::from_micros(self.cfg.min_round_period_us);
            let el = started.elapsed();
            if el < min {
                std::thread::sleep(min - el);
            }
        }
    }

    /// Moves the link's error counts into the shared stats.
    fn drain_tally(&self, l: &mut Link) {
        let t = std::mem::take(&mut l.tally);
        let mut sh = self.lock();
        let st = &mut sh.stats;
        st.bad_length += t.bad_length;
        st.late_replies += t.late;
        for (id, n) in t.crc {
            st.crc_errors += n;
            st.per_gripper.entry(id).or_default().crc_errors += n;
        }
        for (id, n) in t.timeouts {
            st.timeouts += n;
            st.per_gripper.entry(id).or_default().timeouts += n;
        }
    }

    fn publish(&self, i: usize) {
        let r = &self.rt[i];
        if let Some(tx) = self.tx.get(&r.id) {
            tx.send_replace(r.state.clone());
        }
    }

    /// Brings one servo into current-based position mode and holds its present position.
    fn init_servo(&mut self, l: &mut Link, i: usize) -> Result<(), TransportError> {
        let id = self.rt[i].id;
        self.rt[i].last_init_try = Some(Instant::now());
        self.lock().stats.per_gripper.entry(id).or_default().inits += 1;
        if l.ask(&Request::Ping { id }, id)?.is_none() {
            self.rt[i].state.last_error = Some(format!("servo {id} does not answer ping"));
            return Ok(());
        }
        let p = self.p.clone();
        let steps: [(Reg, i64); 5] = [
            (reg::TORQUE_ENABLE, 0),
            (reg::OPERATING_MODE, OperatingMode::CurrentBasedPosition as i64),
            (reg::RETURN_DELAY_TIME, p.return_delay_units as i64),
            (reg::CURRENT_LIMIT, p.current_limit_units as i64),
            (reg::STATUS_RETURN_LEVEL, 2),
        ];
        for (r, v) in steps {
            if let Err(e) = l.write_reg(id, r, v)? {
                self.rt[i].state.last_error = Some(format!("init servo {id}: {e}"));
                return Ok(());
            }
        }
        let pos = match l.read_reg(id, reg::PRESENT_POSITION)? {
            Ok(v) => v as i32,
            Err(e) => {
                self.rt[i].state.last_error = Some(format!("init servo {id}: {e}"));
                return Ok(());
            }
        };
        let hw = l.read_reg(id, reg::HARDWARE_ERROR_STATUS)?.unwrap_or(0) as u8;
        let rt = &mut self.rt[i];
        rt.hold_ticks = pos;
        rt.state.hardware_error = HardwareError(hw);
        let (goal, cur) = (pos, p.force_to_current(p.idle_force_pct));
        let data = goal_block(&p, cur, goal);
        let rep = l.ask(
            &Request::Write {
                id,
                addr: GOAL_BLOCK.addr,
                data,
            },
            id,
        )?;
        if rep.is_none() {
            self.rt[i].state.last_error = Some(format!("init servo {id}: no answer writing goals"));
            return Ok(());
        }
        if let Err(e) = l.write_reg(id, reg::TORQUE_ENABLE, 1)? {
            self.rt[i].state.last_error = Some(format!("init servo {id}: {e}"));
            return Ok(());
        }
        let rt = &mut self.rt[i];
        rt.initialised = true;
        rt.misses = 0;
        rt.state.last_error = None;
        Ok(())
    }

    fn round(&mut self, l: &mut Link) -> Result<(), TransportError> {
        // Commands and targets from the API.
        let cmds: Vec<Cmd> = {
            let mut sh = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            for r in &mut self.rt {
                r.api_target = sh.targets.get(&r.id).copied();
            }
            sh.cmds.drain(..).collect()
        };
        for c in cmds {
            match c {
                Cmd::Calibrate(id) => {
                    if let Some(r) = self.rt.iter_mut().find(|r| r.id == id) {
                        r.cal_requested = true;
                    }
                }
                Cmd::Reboot(id) => {
                    if let Some(i) = self.rt.iter().position(|r| r.id == id) {
                        l.transact(&Request::Reboot { id }, &[id])?;
                        self.rt[i].initialised = false;
                        self.rt[i].last_init_try = None;
                    }
                }
            }
        }
        // (Re)initialise servos that need it; a silent one is retried every 200 ms.
        for i in 0..self.rt.len() {
            let due = self.rt[i]
                .last_init_try
                .map_or(true, |t| t.elapsed() > Duration::from_millis(200));
            if !self.rt[i].initialised && due {
                self.init_servo(l, i)?;
                if self.rt[i].initialised && self.rt[i].ever_initialised {
                    // Back after an unplug, a silent spell or a reboot: whatever target was
                    // set before or meanwhile is stale. Hold the position just measured
                    // (`hold_ticks`) until the next set_target; never replay.
                    let id = self.rt[i].id;
                    self.rt[i].api_target = None;
                    self.lock().targets.remove(&id);
                    self.rt[i].state.target = None;
                }
                if self.rt[i].initialised {
                    self.rt[i].ever_initialised = true;
                } else {
                    self.rt[i].state.online = false;
                    self.rt[i].state.stale = true;
                    self.publish(i);
                }
            }
        }
        let now = Instant::now();
        // Start calibrations that were asked for.
        for r in self.rt.iter_mut().filter(|r| r.initialised && r.cal_requested) {
            r.cal_requested = false;
            let present = if r.state.online {
                r.state.position_ticks
            } else {
                r.hold_ticks
            };
            r.cal = Some(CalRun {
                started: now,
                goal: self.p.calibration_goal(present),
                anchor: present,
                anchor_since: now,
                still_samples: 0,
            });
            r.state.calibration = Calibration::Running;
            r.contact_rounds = 0;
        }
        for r in &mut self.rt {
            r.in_round = r.initialised;
        }
        let n = self.rt.iter().filter(|r| r.in_round).count();
        if n == 0 {
            std::thread::sleep(Duration::from_millis(5));
            return Ok(());
        }
        // Goals.
        self.requests.resize(n);
        let mut k = 0;
        for i in 0..self.rt.len() {
            if self.rt[i].in_round {
                let (goal, cur) = self.goal_for(i);
                self.rt[i].goal_current = cur;
                self.requests.set(k, self.rt[i].id, &self.p, cur, goal);
                k += 1;
            }
        }
        let round_start = Instant::now();
        l.send(&self.requests.goals)?;
        l.transact(&self.requests.present, self.requests.ids())?;
        let rep = &l.reply;
        let measured_at = Instant::now();
        self.round += 1;
        let round = self.round;
        let mut alerts = Vec::new();
        {
            let mut sh = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            let st = &mut sh.stats;
            st.rounds = round;
            let ds = l.dec.stats();
            st.truncated = ds.truncated;
            st.garbage_bytes = ds.garbage_bytes;
            for &id in self.requests.ids() {
                let c = st.per_gripper.entry(id).or_default();
                c.polls += 1;
                if let Some(s) = rep.get(id) {
                    if s.error.number != crate::dynamixel::protocol::ErrorNumber::None {
                        c.status_errors += 1;
                    } else {
                        c.samples += 1;
                    }
                    if s.error.alert {
                        c.hardware_alerts += 1;
                    }
                }
            }
            if !rep.is_empty() {
                if let (Some(prev), Some(periods)) = (self.last_round_start, sh.periods.as_mut()) {
                    if periods.len() >= MAX_PERIODS {
                        periods.pop_front();
                    }
                    periods.push_back(round_start - prev);
                }
                self.last_round_start = Some(round_start);
            }
            let (t0, r0) = self.rate_window;
            let el = measured_at - t0;
            if el >= Duration::from_secs(1) {
                sh.stats.rounds_per_s = (round - r0) as f64 / el.as_secs_f64();
                self.rate_window = (measured_at, round);
            }
        }
        for i in 0..self.rt.len() {
            if !self.rt[i].in_round {
                continue;
            }
            let id = self.rt[i].id;
            match rep.get(id) {
                Some(s)
                    if s.error.number == crate::dynamixel::protocol::ErrorNumber::None
                        && s.params.len() == PRESENT_BLOCK.len as usize =>
                {
                    self.apply_present(i, &s.params, measured_at, round);
                    if s.error.alert {
                        alerts.push(i);
                    } else {
                        self.rt[i].state.hardware_error = HardwareError::NONE;
                    }
                }
                Some(s) => {
                    self.rt[i].state.last_error = Some(format!("servo {id} status error {:?}", s.error.number));
                    self.miss(i);
                }
                None => {
                    let why = if rep.had_bad_crc(id) { "bad CRC" } else { "no answer" };
                    self.rt[i].state.last_error = Some(format!("servo {id}: {why}"));
                    self.miss(i);
                }
            }
        }
        // Alert bit: fetch the cause.
        for i in alerts {
            let id = self.rt[i].id;
            if let Ok(v) = l.read_reg(id, reg::HARDWARE_ERROR_STATUS)? {
                self.rt[i].state.hardware_error = HardwareError(v as u8);
                self.rt[i].state.last_error = Some(format!(
                    "servo {id} hardware error: {}",
                    HardwareError(v as u8).names().join(", ")
                ));
            }
        }
        for i in 0..self.rt.len() {
            if self.rt[i].in_round {
                self.publish(i);
            }
        }
        Ok(())
    }

    /// Gripper `i` did not answer this round. One missed reply is not a stale measurement:
    /// the last one stays good until it is older than `stale_after` (the device's, as for
    /// every other kind), so a loaded host, whose emulated or USB-latency-bound replies come
    /// late now and then, does not look like an unplug (which would reseed: a hold, the
    /// client's target dropped). `offline_after_misses` misses in a row take the gripper
    /// offline: stale, re-initialised when it answers, never replaying a target.
    fn miss(&mut self, i: usize) {
        let stale_after = Duration::from_millis(self.cfg.stale_after_ms);
        let r = &mut self.rt[i];
        r.misses += 1;
        r.state.stale = r.state.stale || r.state.measured_at.elapsed() > stale_after;
        if r.misses >= self.cfg.offline_after_misses {
            r.state.online = false;
            r.state.stale = true;
            r.initialised = false;
        }
    }

    /// Goal position and goal current for gripper `i` this round.
    fn goal_for(&mut self, i: usize) -> (i32, u16) {
        let p = &self.p;
        let r = &mut self.rt[i];
        if let Some(c) = &r.cal {
            return (c.goal, p.force_to_current(p.calibration_force_pct));
        }
        let Some(zero) = r.state.calibration.zero() else {
            r.state.target = None;
            return (r.hold_ticks, p.force_to_current(p.idle_force_pct));
        };
        let Some(t) = r.api_target.or(r.state.target) else {
            return (r.hold_ticks, p.force_to_current(p.idle_force_pct));
        };
        r.state.target = Some(t);
        let mut force = t.force_pct;
        if r.state.grasp == GraspState::Grasping {
            if let Some(cap) = p.grasp_hold_force_pct {
                force = force.min(cap);
            }
        }
        (p.pct_to_ticks(t.position_pct, zero), p.force_to_current(force))
    }

    fn apply_present(&mut self, i: usize, b: &[u8], at: Instant, round: u64) {
        // Offsets within PRESENT_BLOCK (starts at Moving, 122).
        let off = |r: Reg| (r.addr - PRESENT_BLOCK.addr) as usize;
        let cur = le_i16(&b[off(reg::PRESENT_CURRENT)..]).unwrap_or(0);
        let vel = le_i32(&b[off(reg::PRESENT_VELOCITY)..]).unwrap_or(0);
        let pos = le_i32(&b[off(reg::PRESENT_POSITION)..]).unwrap_or(0);
        let volt = le_i16(&b[off(reg::PRESENT_INPUT_VOLTAGE)..]).unwrap_or(0);
        let temp = b[off(reg::PRESENT_TEMPERATURE)];
        let p = self.p.clone();
        let r = &mut self.rt[i];
        r.misses = 0;
        let s = &mut r.state;
        s.position_ticks = pos;
        s.velocity_pct_s = p.velocity_to_pct_s(vel);
        s.current_ma = cur as f32 * CURRENT_MA_PER_UNIT;
        s.effort_pct = p.current_to_effort_pct(cur);
        s.temperature_c = temp;
        s.voltage_v = volt as f32 * VOLTAGE_V_PER_UNIT;
        s.online = true;
        s.stale = false;
        s.measured_at = at;
        s.round = round;
        s.last_error = None;
        // Calibration progress.
        if let Some(c) = r.cal.as_mut() {
            // At rest against the stop: still, and the loop pushing with the calibration
            // current (a jaw that merely paused, e.g. on a stalled bus, does not count).
            let pushing = (cur.unsigned_abs() as f32) >= p.contact_current_pct / 100.0 * r.goal_current.max(1) as f32;
            // Counting readings as well as time: a reply that sat in a starved driver's
            // queue must not pass for 165 ms of stillness on its own.
            if (pos - c.anchor).abs() > p.calibration_still_ticks || !pushing {
                c.anchor = pos;
                c.anchor_since = at;
                c.still_samples = 0;
            } else {
                c.still_samples += 1;
            }
            let still = Duration::from_millis(p.calibration_still_ms);
            if at - c.anchor_since >= still && at - c.started >= still && c.still_samples >= p.calibration_still_samples
            {
                s.calibration = Calibration::Calibrated { zero_ticks: pos };
                s.target = Some(Target {
                    position_pct: p.calibration_settle_pct,
                    force_pct: p.calibration_settle_force_pct,
                });
                r.cal = None;
                // The settle target replaces an older API target.
                self.shared
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .targets
                    .remove(&r.id);
            } else if at - c.started >= Duration::from_millis(p.calibration_timeout_ms) {
                s.calibration = Calibration::Failed {
                    reason: format!("jaw did not come to rest within {} ms", p.calibration_timeout_ms),
                };
                r.cal = None;
            }
        }
        let raw_pct = s.calibration.zero().map(|z| p.ticks_to_pct(pos, z));
        s.position_pct = raw_pct.map_or(0.0, |v| v.clamp(0.0, 100.0));
        // Grasp state.
        let moving = s.velocity_pct_s.abs() > p.moving_velocity_pct_s;
        let (Some(pct), Some(t)) = (raw_pct, s.target) else {
            r.contact_rounds = 0;
            s.grasp = if moving { GraspState::Moving } else { GraspState::Idle };
            return;
        };
        let want = p.pct_to_ticks(t.position_pct, 0);
        let want_pct = p.ticks_to_pct(want, 0);
        let err = want_pct - pct; // < 0: the jaw should close further
        let pushing = (cur.unsigned_abs() as f32) >= p.contact_current_pct / 100.0 * r.goal_current.max(1) as f32;
        let blocked = err < -p.position_tolerance_pct && pushing;
        if blocked && (!moving || s.grasp == GraspState::Grasping) {
            r.contact_rounds += 1;
            s.grasp = if r.contact_rounds >= p.grasp_confirm_rounds {
                GraspState::Grasping
            } else {
                GraspState::Contact
            };
        } else {
            r.contact_rounds = 0;
            s.grasp = if moving { GraspState::Moving } else { GraspState::Idle };
        }
    }
}

/// Whether `st` has the shape of a reply to `req`: a read returns its length of data (or an
/// error without data), a write or reboot returns no data, a ping returns model + firmware.
fn answers(req: &Request, st: &StatusRef<'_>) -> bool {
    let failed = st.error.number != crate::dynamixel::protocol::ErrorNumber::None;
    match req {
        Request::Read { len, .. } | Request::SyncRead { len, .. } => {
            st.params.len() == *len as usize || (failed && st.params.is_empty())
        }
        Request::Write { .. } | Request::Reboot { .. } => st.params.is_empty(),
        Request::Ping { .. } => st.params.len() == 3,
        // The MX-64 driver never sends these.
        Request::SyncWrite { .. } | Request::FastSyncRead { .. } => false,
    }
}

/// The 18 bytes of [`GOAL_BLOCK`]: goal current, goal velocity (0), profile acceleration,
/// profile velocity, goal position.
fn goal_block(p: &EzGripperParams, current: u16, goal: i32) -> Vec<u8> {
    let mut d = Vec::with_capacity(GOAL_BLOCK.len as usize);
    goal_block_into(p, current, goal, &mut d);
    d
}

/// [`goal_block`] into `d` (cleared; its buffer reused).
fn goal_block_into(p: &EzGripperParams, current: u16, goal: i32, d: &mut Vec<u8>) {
    d.clear();
    d.extend_from_slice(&(current as i16).to_le_bytes());
    d.extend_from_slice(&0i32.to_le_bytes());
    d.extend_from_slice(&p.profile_acceleration.to_le_bytes());
    d.extend_from_slice(&p.profile_velocity.to_le_bytes());
    d.extend_from_slice(&goal.to_le_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goal_block_layout_matches_the_table() {
        let p = EzGripperParams::default();
        let d = goal_block(&p, 480, -12345);
        assert_eq!(d.len(), GOAL_BLOCK.len as usize);
        let at = |r: Reg| (r.addr - GOAL_BLOCK.addr) as usize;
        assert_eq!(le_i16(&d[at(reg::GOAL_CURRENT)..]), Some(480));
        assert_eq!(le_i32(&d[at(reg::GOAL_POSITION)..]), Some(-12345));
        assert_eq!(le_i32(&d[at(reg::PROFILE_VELOCITY)..]), Some(500));
    }

    #[test]
    fn bus_config_deserialises_with_defaults() {
        let c: BusConfig = serde_json::from_str(
            r#"{"grippers": [{"id": 1}, {"id": 2, "zero_ticks": 1040}], "calibrate_on_start": false,
                "ezgripper": {"grip_max_ticks": 2400}}"#,
        )
        .unwrap();
        assert_eq!(c.grippers.len(), 2);
        assert_eq!(c.grippers[1].zero_ticks, Some(1040));
        assert_eq!(c.ezgripper.grip_max_ticks, 2400);
        assert_eq!(c.baud, 1_000_000);
        assert!(serde_json::from_str::<BusConfig>(r#"{"grippers": [{"id": 253}]}"#).is_err());
    }

    /// A transport whose reply is in by the deadline but whose reader is not scheduled until
    /// after it (a loaded host): the first read waits its whole timeout and finds nothing, the
    /// reply is there for the next one.
    struct ReadLate {
        reply: Option<Vec<u8>>,
        waited: bool,
    }

    impl Transport for ReadLate {
        fn write_all(&mut self, _: &[u8]) -> Result<(), TransportError> {
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, TransportError> {
            if !self.waited && !timeout.is_zero() {
                self.waited = true;
                std::thread::sleep(timeout);
                return Ok(0);
            }
            match self.reply.take() {
                Some(r) if self.waited => {
                    buf[..r.len()].copy_from_slice(&r);
                    Ok(r.len())
                }
                r => {
                    self.reply = r;
                    Ok(0)
                }
            }
        }
        fn clear_input(&mut self) -> Result<(), TransportError> {
            Ok(())
        }
    }

    /// A reply that arrived by the deadline is not a missed reply because the bus thread read
    /// it after the deadline (before issue #26 it was: two such rounds on a loaded host made
    /// an emulated gripper stale).
    #[test]
    fn a_reply_read_after_the_deadline_is_not_a_timeout() {
        let pong = crate::dynamixel::protocol::Status {
            id: 1,
            error: crate::dynamixel::protocol::StatusError::OK,
            params: vec![0x24, 0x01, 0x30],
        }
        .encode()
        .unwrap();
        let cfg = BusConfig {
            response_timeout_ms: 5,
            ..Default::default()
        };
        let mut l = Link::new(
            Box::new(ReadLate {
                reply: Some(pong),
                waited: false,
            }),
            &cfg,
        );
        l.transact(&Request::Ping { id: 1 }, &[1]).unwrap();
        assert!(l.reply.get(1).is_some(), "the reply was read");
        assert!(l.tally.timeouts.is_empty(), "{:?}", l.tally.timeouts);
    }

    #[test]
    fn side_default_ids() {
        assert_eq!(default_id(Side::Left).get(), 1);
        assert_eq!(default_id(Side::Right).get(), 2);
        assert_eq!(default_id(Side::Center).get(), 3);
    }
}
