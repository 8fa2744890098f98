//! The 1 kHz device loop: a dedicated thread exchanging one command frame for one state frame
//! per period, on absolute deadlines (`next = start + k·period`: no drift; sleep, then spin the
//! last [`LoopConfig::spin`]).
//!
//! - Latest-command semantics: one slot, never a queue; every cycle sends the newest command.
//! - When the exchange happens is [`LoopConfig::align`]'s ([`super::align`]): on the fixed
//!   grid (`off`), early when a command arrives (`early`, the wait is woken by
//!   [`Dex3UsbHandle::set_command`]), or on a grid whose phase follows the commands (`phase`).
//! - The motor timeout bit is set explicitly on every motor packet ([`LoopConfig::timeout_bit`]).
//! - On (re)connect the old command is never replayed: setpoints are re-seeded from the first
//!   measured state (hold the measured position with [`LoopConfig::hold_kp`]/[`LoopConfig::hold_kd`])
//!   and only a command set after the reconnect moves the hand again. The first exchange after
//!   a connect sends the timeout bit at 0 with pure damping, which clears timeout latches that
//!   tripped while the link was down ([`LoopConfig::clear_timeouts_on_connect`]).
//! - A failed exchange (timeout, bad frame CRC, transport error) keeps the last good values and
//!   marks the measurement `stale`.

use super::align::{Align, Schedule};
use super::codec::{McuToLinuxState, CMD_FRAME_LEN, STATE_FRAME_LEN};
use super::convert::{apply_state, build_command};
use super::scaling::Scalings;
use super::transport::{TransportError, TransportFactory};
use super::wiring::{WiringError, WiringMap};
use crate::dex3::{Dex3Command, Dex3Measurement, MotorCommand, MOTOR_COUNT};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use thiserror::Error;
use tokio::sync::watch;

/// Device loop settings.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopConfig {
    /// Cycle period (manual: 1000 Hz).
    pub period: Duration,
    /// How long one exchange may wait for the reply.
    pub exchange_timeout: Duration,
    /// The motor timeout-protection bit sent on every motor (default on: a motor stops 1 s
    /// after the commands stop).
    pub timeout_bit: bool,
    /// Stiffness of the hold after a (re)connect, N·m/rad.
    pub hold_kp: f32,
    /// Damping of the hold after a (re)connect, N·m·s/rad.
    pub hold_kd: f32,
    /// Busy-wait this long before each deadline (0: sleep only).
    pub spin: Duration,
    /// Put the deadlines on the process-wide grid of [`crate::loops`] (loops of one period
    /// fall due at the same instants, so one timer interrupt wakes them all and the kernel
    /// switches from one loop thread straight to the next instead of in and out of idle for
    /// each) rather than on a grid started at the connect. For emulated hands, many to a
    /// process; a real hand keeps its own phase, so that hands whose loops share a CPU do not
    /// queue their exchanges behind each other (docs/benchmarks.md, "Fleet scale").
    pub shared_grid: bool,
    /// Reopen the transport after this many consecutive failed exchanges.
    pub failures_before_reconnect: u32,
    pub backoff_min: Duration,
    pub backoff_max: Duration,
    /// On every (re)connect, send the first exchange with the timeout bit at 0.
    pub clear_timeouts_on_connect: bool,
    /// How the exchanges follow the commands (default: the fixed grid).
    pub align: Align,
    pub wiring: WiringMap,
    pub scalings: Scalings,
}

impl Default for LoopConfig {
    fn default() -> Self {
        Self {
            period: Duration::from_millis(1),
            exchange_timeout: Duration::from_millis(20),
            timeout_bit: true,
            // unitree_sdk2's Dex3 example sweeps with kp 0.5 / kd 0.1 (docs/sources.md §2).
            hold_kp: 0.5,
            hold_kd: 0.1,
            spin: Duration::from_micros(100),
            shared_grid: false,
            failures_before_reconnect: 100,
            backoff_min: Duration::from_millis(20),
            backoff_max: Duration::from_secs(2),
            clear_timeouts_on_connect: true,
            align: Align::Off,
            wiring: WiringMap::default(),
            scalings: Scalings::default(),
        }
    }
}

#[derive(Debug, Error)]
pub enum LoopError {
    #[error("invalid wiring map: {0}")]
    Wiring(#[from] WiringError),
    #[error("invalid scalings: {0}")]
    Scalings(#[from] super::scaling::ScalingError),
    #[error("invalid loop period {0:?}")]
    Period(Duration),
    #[error("cannot start the device thread: {0}")]
    Thread(#[from] std::io::Error),
}

/// Histogram of cycle-start to cycle-start periods, 5 µs buckets up to 20 ms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PeriodHistogram {
    counts: Vec<u64>,
    overflow: u64,
    max: Duration,
    min: Duration,
    n: u64,
}

impl PeriodHistogram {
    pub const BUCKET: Duration = Duration::from_micros(5);
    const BUCKETS: usize = 4000;

    pub fn new() -> Self {
        Self {
            counts: vec![0; Self::BUCKETS],
            overflow: 0,
            max: Duration::ZERO,
            min: Duration::MAX,
            n: 0,
        }
    }

    pub fn record(&mut self, d: Duration) {
        let b = (d.as_nanos() / Self::BUCKET.as_nanos()) as usize;
        match self.counts.get_mut(b) {
            Some(c) => *c += 1,
            None => self.overflow += 1,
        }
        self.max = self.max.max(d);
        self.min = self.min.min(d);
        self.n += 1;
    }

    pub fn count(&self) -> u64 {
        self.n
    }

    pub fn max(&self) -> Duration {
        self.max
    }

    /// The shortest value recorded; `None` when empty.
    pub fn min(&self) -> Option<Duration> {
        (self.n > 0).then_some(self.min)
    }

    /// The `q` quantile (0..=1), to bucket resolution (upper edge of the bucket); `None` when
    /// empty. Values beyond the last bucket report the maximum.
    pub fn quantile(&self, q: f64) -> Option<Duration> {
        if self.n == 0 {
            return None;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.n as f64).ceil() as u64).max(1);
        let mut acc = 0;
        for (i, c) in self.counts.iter().enumerate() {
            acc += c;
            if acc >= rank {
                return Some(Self::BUCKET * (i as u32 + 1));
            }
        }
        Some(self.max)
    }
}

impl Default for PeriodHistogram {
    fn default() -> Self {
        Self::new()
    }
}

/// Loop counters.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoopStats {
    /// Exchanges that got a reply (good or not).
    pub exchanges: u64,
    /// Replies that passed the frame CRC.
    pub good_frames: u64,
    /// Replies rejected by the frame CRC or length.
    pub frame_crc_errors: u64,
    /// Motor/sensor packets with a bad CRC inside good frames.
    pub packet_crc_errors: u64,
    /// Other packet problems (unknown head, truncation, oversize `state_size`).
    pub packet_format_errors: u64,
    /// Packets from addresses not in the wiring map.
    pub unmapped_packets: u64,
    pub timeouts: u64,
    pub transport_errors: u64,
    /// Successful opens of the transport, including the first.
    pub connects: u64,
    /// Opens after the first.
    pub reconnects: u64,
    pub connect_failures: u64,
    /// Deadlines missed (cycles that started late by at least one period).
    pub misses: u64,
    /// Exchanges started before their deadline for a new command ([`Align::Early`]).
    pub early: u64,
    pub connected: bool,
    pub period: PeriodHistogram,
    /// From a command's [`Dex3UsbHandle::set_command`] to the start of the exchange that
    /// sends it (commands superseded before an exchange are not counted).
    pub cmd_wait: PeriodHistogram,
}

struct Shared {
    stop: AtomicBool,
    cmd_seq: AtomicU64,
    /// The newest command: (seq, command, when it was set).
    cmd: Mutex<Option<(u64, Dex3Command, Instant)>>,
    clear_timeouts: AtomicBool,
    stats: Mutex<LoopStats>,
}

/// The link as the loop sees it, handed to an [`Observer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Link {
    pub connected: bool,
    /// Successful opens of the transport so far.
    pub connects: u64,
}

/// Called on the loop thread after every cycle and after every failed connect attempt, with
/// the newest measurement: derive state there instead of waking another thread per cycle.
/// Must be quick (it runs inside the 1 ms cycle) and must not call back into the handle.
pub type Observer = Box<dyn FnMut(&Dex3Measurement, Link) + Send>;

/// Namespace of the device loop.
#[derive(Debug)]
pub struct Dex3UsbLoop;

impl Dex3UsbLoop {
    /// Starts the loop thread. `factory` opens the transport, now and after every disconnect.
    pub fn spawn(factory: TransportFactory, config: LoopConfig) -> Result<Dex3UsbHandle, LoopError> {
        Self::spawn_observed(factory, config, None)
    }

    /// [`Self::spawn`] with an [`Observer`] of every cycle.
    pub fn spawn_observed(
        factory: TransportFactory,
        config: LoopConfig,
        observer: Option<Observer>,
    ) -> Result<Dex3UsbHandle, LoopError> {
        config.wiring.validate()?;
        config.scalings.validate()?;
        if config.period.is_zero() {
            return Err(LoopError::Period(config.period));
        }
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            cmd_seq: AtomicU64::new(0),
            cmd: Mutex::new(None),
            clear_timeouts: AtomicBool::new(false),
            stats: Mutex::new(LoopStats::default()),
        });
        let (tx, rx) = watch::channel(Dex3Measurement::empty(Instant::now()));
        let wake = config.align.wakes_on_command();
        let thread = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("dex3-usb-loop".into())
                .spawn(move || {
                    crate::realtime::enter_device_loop(); // [realtime]: this thread only
                    run(factory, config, shared, tx, observer)
                })?
        };
        Ok(Dex3UsbHandle {
            shared,
            rx,
            wake,
            thread: Some(thread),
        })
    }
}

/// Control of a running loop. Dropping it stops the loop.
pub struct Dex3UsbHandle {
    shared: Arc<Shared>,
    rx: watch::Receiver<Dex3Measurement>,
    /// Wake the loop on every new command ([`Align::wakes_on_command`]).
    wake: bool,
    thread: Option<JoinHandle<()>>,
}

impl Dex3UsbHandle {
    /// Replaces the command slot (latest wins). A command only takes effect on a connection
    /// that is already up when it is set: commands set before a (re)connect, including while
    /// disconnected, are never sent (the hand holds its measured position until the next
    /// `set_command`). Set the first command once `latest()` shows a fresh measurement.
    ///
    /// Returns the command's sequence number: the measurements of exchanges that sent it carry
    /// it in [`Dex3Measurement::cmd_seq`].
    ///
    /// With [`Align::Early`] it also wakes the loop (one futex wake when the loop sleeps).
    pub fn set_command(&self, cmd: Dex3Command) -> u64 {
        let seq = {
            let mut slot = self.shared.cmd.lock().unwrap_or_else(|e| e.into_inner());
            let seq = self.shared.cmd_seq.fetch_add(1, Ordering::SeqCst) + 1;
            *slot = Some((seq, cmd, Instant::now()));
            seq
        };
        if self.wake {
            if let Some(t) = &self.thread {
                t.thread().unpark();
            }
        }
        seq
    }

    /// Sends the timeout bit at 0 for one exchange, clearing latched timeout trips.
    pub fn clear_timeouts(&self) {
        self.shared.clear_timeouts.store(true, Ordering::SeqCst);
    }

    pub fn latest(&self) -> Dex3Measurement {
        self.rx.borrow().clone()
    }

    pub fn subscribe(&self) -> watch::Receiver<Dex3Measurement> {
        self.rx.clone()
    }

    /// Whether the transport is up, and how many times it was opened: [`Self::stats`] without
    /// copying the period histogram (cheap enough for every cycle).
    pub fn link(&self) -> (bool, u64) {
        let s = self.shared.stats.lock().unwrap_or_else(|e| e.into_inner());
        (s.connected, s.connects)
    }

    pub fn stats(&self) -> LoopStats {
        self.shared.stats.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

impl Drop for Dex3UsbHandle {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Sleeps until `deadline` unless stopped; `false` if stopped.
fn park_until(deadline: Instant, stop: &AtomicBool) -> bool {
    loop {
        if stop.load(Ordering::SeqCst) {
            return false;
        }
        let now = Instant::now();
        if now >= deadline {
            return true;
        }
        std::thread::park_timeout(deadline - now);
    }
}

/// The arrival of the newest command not sent yet: set after `sent_seq` (the last one an
/// exchange sent) and after the connect (`floor_seq`). Locks the slot only when the sequence
/// moved.
fn pending(shared: &Shared, sent_seq: u64, floor_seq: u64) -> Option<Instant> {
    let seq = shared.cmd_seq.load(Ordering::SeqCst);
    if seq <= sent_seq.max(floor_seq) {
        return None;
    }
    let slot = shared.cmd.lock().unwrap_or_else(|e| e.into_inner());
    slot.as_ref()
        .filter(|(s, _, _)| *s > sent_seq.max(floor_seq))
        .map(|(_, _, at)| *at)
}

/// [`wait_until`] the schedule's due time, recomputed whenever a new command wakes the loop
/// (park/unpark; spinning the last `spin`, watching the command sequence); `false` if stopped.
fn wait_for_due(sched: &Schedule, spin: Duration, shared: &Shared, sent_seq: u64, floor_seq: u64) -> bool {
    loop {
        if shared.stop.load(Ordering::SeqCst) {
            return false;
        }
        let due = sched.due(pending(shared, sent_seq, floor_seq));
        let now = Instant::now();
        if now >= due {
            return true;
        }
        if due - now > spin {
            std::thread::park_timeout(due - now - spin);
        } else {
            std::hint::spin_loop();
        }
    }
}

/// Sleeps until `spin` before `deadline`, then spins.
fn wait_until(deadline: Instant, spin: Duration) {
    let now = Instant::now();
    if deadline > now + spin {
        std::thread::sleep(deadline - now - spin);
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}

/// Where a new connection's grid starts: at `now` (the first exchange at once, the next a
/// period later), or with [`LoopConfig::shared_grid`] at the last instant of the process-wide
/// grid at or before `now` (the first exchange still at once, the next on that grid).
fn grid_origin(cfg: &LoopConfig, now: Instant) -> Instant {
    if !cfg.shared_grid {
        return now;
    }
    let next = crate::loops::grid_at_or_after(now, cfg.period);
    if next > now {
        next.checked_sub(cfg.period).unwrap_or(now)
    } else {
        next
    }
}

struct Session {
    /// Commands with a sequence number up to this one predate the connect: never sent.
    floor_seq: u64,
    /// The newest command an exchange of this session sent (0: none yet).
    sent_seq: u64,
    sched: Schedule,
    hold: [Option<MotorCommand>; MOTOR_COUNT],
    first_exchange: bool,
    consecutive_failures: u32,
}

fn run(
    mut factory: TransportFactory,
    cfg: LoopConfig,
    shared: Arc<Shared>,
    tx: watch::Sender<Dex3Measurement>,
    mut observer: Option<Observer>,
) {
    let mut connects: u64 = 0;
    let mut observe = |m: &Dex3Measurement, connected: bool, connects: u64| {
        if let Some(o) = observer.as_mut() {
            o(m, Link { connected, connects });
        }
    };
    let mut meas = Dex3Measurement::empty(Instant::now());
    let mut transport = None;
    let mut session: Option<Session> = None;
    let mut backoff = cfg.backoff_min;
    let mut last_connect_error = String::new();
    let mut cmd_buf = [0u8; CMD_FRAME_LEN];
    let mut st_buf = [0u8; STATE_FRAME_LEN];
    let mut last_start: Option<Instant> = None;
    let stats = |f: &mut dyn FnMut(&mut LoopStats)| f(&mut shared.stats.lock().unwrap_or_else(|e| e.into_inner()));

    while !shared.stop.load(Ordering::SeqCst) {
        let Some(t) = transport.as_mut() else {
            match factory() {
                Ok(t) => {
                    tracing::info!("dex3 usb: connected to {}", t.describe());
                    transport = Some(t);
                    backoff = cfg.backoff_min;
                    last_connect_error.clear();
                    session = Some(Session {
                        floor_seq: shared.cmd_seq.load(Ordering::SeqCst),
                        sent_seq: 0,
                        sched: Schedule::new(cfg.period, cfg.align, grid_origin(&cfg, Instant::now())),
                        hold: [None; MOTOR_COUNT],
                        first_exchange: true,
                        consecutive_failures: 0,
                    });
                    for m in &mut meas.motors {
                        m.present = false;
                    }
                    for p in &mut meas.pads {
                        p.present = false;
                    }
                    stats(&mut |s| {
                        if s.connects > 0 {
                            s.reconnects += 1;
                        }
                        s.connects += 1;
                        s.connected = true;
                    });
                    connects += 1;
                    last_start = None;
                }
                Err(e) => {
                    let msg = e.to_string();
                    if msg != last_connect_error {
                        tracing::warn!("dex3 usb: cannot open the hand: {msg}; retrying");
                        last_connect_error = msg;
                    }
                    stats(&mut |s| s.connect_failures += 1);
                    observe(&meas, false, connects);
                    if !park_until(Instant::now() + backoff, &shared.stop) {
                        break;
                    }
                    backoff = (backoff * 2).min(cfg.backoff_max);
                }
            }
            continue;
        };
        let sess = session.as_mut().expect("session exists while connected");

        let start = Instant::now();
        if let Some(prev) = last_start {
            stats(&mut |s| s.period.record(start - prev));
        }
        last_start = Some(start);

        // Choose what to send.
        let user = {
            let slot = shared.cmd.lock().unwrap_or_else(|e| e.into_inner());
            slot.filter(|(seq, _, _)| *seq > sess.floor_seq)
        };
        let sent_seq = user.filter(|_| !sess.first_exchange).map(|(seq, _, _)| seq);
        // The arrival of the command this exchange sends for the first time.
        let fresh = user
            .filter(|(seq, _, _)| !sess.first_exchange && *seq > sess.sent_seq)
            .map(|(_, _, at)| at);
        let early = start < sess.sched.deadline();
        sess.sched.begin(start, fresh);
        if let Some(seq) = sent_seq {
            sess.sent_seq = seq;
        }
        if let Some(at) = fresh {
            stats(&mut |s| {
                s.cmd_wait.record(start.saturating_duration_since(at));
                s.early += early as u64;
            });
        }
        let cmd = match user.map(|(_, c, _)| c) {
            Some(c) => c,
            None => {
                let mut c = Dex3Command::damping(cfg.hold_kd);
                for (m, h) in c.motors.iter_mut().zip(sess.hold) {
                    if let Some(h) = h {
                        *m = h;
                    }
                }
                c
            }
        };
        let mut timeout_bit = cfg.timeout_bit;
        if (sess.first_exchange && cfg.clear_timeouts_on_connect) || shared.clear_timeouts.swap(false, Ordering::SeqCst)
        {
            timeout_bit = false;
        }
        let cmd = if sess.first_exchange {
            Dex3Command::damping(cfg.hold_kd)
        } else {
            cmd
        };
        build_command(&cmd, &cfg.wiring, &cfg.scalings, timeout_bit).encode_into(&mut cmd_buf);

        let res = t.exchange(&cmd_buf, &mut st_buf, cfg.exchange_timeout);
        let now = Instant::now();
        let mut drop_transport = false;
        match res {
            Ok(()) => {
                sess.first_exchange = false;
                match McuToLinuxState::decode(&st_buf) {
                    Ok(st) => {
                        let rep = apply_state(&mut meas, &st, &cfg.wiring, &cfg.scalings);
                        meas.measured_at = now;
                        meas.stale = false;
                        meas.seq += 1;
                        if let Some(seq) = sent_seq {
                            meas.cmd_seq = seq;
                        }
                        sess.consecutive_failures = 0;
                        for (i, seen) in rep.motors_seen.iter().enumerate() {
                            if *seen && sess.hold[i].is_none() {
                                sess.hold[i] = Some(MotorCommand {
                                    q: meas.motors[i].q,
                                    kp: cfg.hold_kp,
                                    kd: cfg.hold_kd,
                                    ..Default::default()
                                });
                            }
                        }
                        stats(&mut |s| {
                            s.exchanges += 1;
                            s.good_frames += 1;
                            s.packet_crc_errors += rep.counters.bad_crc as u64;
                            s.packet_format_errors +=
                                (rep.counters.unknown_header + rep.counters.truncated + rep.counters.oversize) as u64;
                            s.unmapped_packets += (rep.unmapped_motors + rep.unmapped_sensors) as u64;
                        });
                    }
                    Err(_) => {
                        meas.stale = true;
                        sess.consecutive_failures += 1;
                        stats(&mut |s| {
                            s.exchanges += 1;
                            s.frame_crc_errors += 1;
                        });
                    }
                }
            }
            Err(e) => {
                meas.stale = true;
                sess.consecutive_failures += 1;
                let is_timeout = matches!(e, TransportError::Timeout(_));
                stats(&mut |s| {
                    if is_timeout {
                        s.timeouts += 1;
                    } else {
                        s.transport_errors += 1;
                    }
                });
                if e.needs_reconnect() || sess.consecutive_failures >= cfg.failures_before_reconnect {
                    tracing::warn!("dex3 usb: link lost ({e}); reconnecting");
                    drop_transport = true;
                }
            }
        }
        tx.send_replace(meas.clone());
        if drop_transport {
            transport = None;
            session = None;
            stats(&mut |s| s.connected = false);
            observe(&meas, false, connects);
            continue;
        }
        observe(&meas, true, connects);

        // Absolute deadlines on the schedule's grid (super::align).
        let behind = sess.sched.end(Instant::now());
        if behind > 0 {
            stats(&mut |s| s.misses += behind);
        }
        if shared.stop.load(Ordering::SeqCst) {
            break;
        }
        if cfg.align.wakes_on_command() {
            if !wait_for_due(&sess.sched, cfg.spin, &shared, sess.sent_seq, sess.floor_seq) {
                break;
            }
        } else {
            wait_until(sess.sched.deadline(), cfg.spin);
        }
    }
    stats(&mut |s| s.connected = false);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_origin_on_the_shared_grid_only_when_asked() {
        let period = Duration::from_millis(1);
        let now = Instant::now() + Duration::from_micros(1234);
        let own = LoopConfig::default();
        assert!(!own.shared_grid, "a real hand keeps the phase of its connect");
        assert_eq!(grid_origin(&own, now), now);
        let shared = LoopConfig {
            shared_grid: true,
            ..Default::default()
        };
        let t0 = grid_origin(&shared, now);
        // The last grid instant at or before `now`: the first exchange is not delayed, the
        // next deadline (t0 + period) is the grid's, the one every other loop of this
        // period has.
        assert!(t0 <= now && now - t0 < period, "{:?}", now - t0);
        assert_eq!(crate::loops::grid_at_or_after(t0, period), t0);
        assert_eq!(grid_origin(&shared, now + period), t0 + period);
    }

    #[test]
    fn histogram_quantiles() {
        let mut h = PeriodHistogram::new();
        assert_eq!(h.quantile(0.5), None);
        for _ in 0..90 {
            h.record(Duration::from_micros(1000));
        }
        for _ in 0..9 {
            h.record(Duration::from_micros(1200));
        }
        h.record(Duration::from_millis(50));
        assert_eq!(h.count(), 100);
        assert_eq!(h.quantile(0.5), Some(Duration::from_micros(1005)));
        assert_eq!(h.quantile(0.9), Some(Duration::from_micros(1005)));
        assert_eq!(h.quantile(0.95), Some(Duration::from_micros(1205)));
        assert_eq!(h.quantile(1.0), Some(Duration::from_millis(50)));
        assert_eq!(h.max(), Duration::from_millis(50));
    }
}
