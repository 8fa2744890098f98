//! A generic DDS-client device: a device loop thread at a fixed rate that folds the latest
//! canonical command into targets, encodes them with a per-kind [`DdsCodec`], publishes, and
//! turns the peer's state samples back into canonical state. Used by every kind that is a
//! client of a DDS service (Dex3 over DDS, Dex1-1, rt/hand_sdk, Inspire, BrainCo); each kind
//! only supplies its codec.
//!
//! **Forwarding on arrival** (docs/fronts.md, "Latency"): a command a front hands the device
//! wakes the loop thread, which publishes it to the service at once instead of at the next
//! tick; the first state sample that arrives after that publish wakes the loop again and is
//! published as the state reflecting the command. The periodic tick stays: keep-alive, ramps,
//! watchdogs and stale detection run on it. Every publish spends a token of a
//! [`SendBudget`] (`max_send_hz`, default four times the loop rate), so a client flooding a front
//! at 10 kHz cannot flood the service.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant, SystemTime};

use async_trait::async_trait;
use cyclonedds_rs::TopicType;
use tokio::sync::watch;

use crate::control::{Active, CommandState, Counters, MeasuredHold};
use crate::dds::{DdsError, Node, Qos};
use crate::device::{DeviceError, DeviceInfo, DeviceStats, HandDevice};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandCommand, HandState, SafeAction};

/// Per-kind wire encoding for a DDS-client device. The device loop calls the `_into`
/// methods every cycle with buffers it keeps: once those have grown, a cycle allocates
/// nothing (docs/deployment.md, "Real-time").
pub trait DdsCodec: Send + 'static {
    type Cmd: TopicType + Clone + Default + Send + 'static;
    type State: TopicType + Clone + Send + 'static;
    /// The entries (motors) of the messages' sequence, where another count means another
    /// hand on the topics ([`crate::discovery::diagnose::Served::entries`]); `None`: not
    /// fixed by the codec's type.
    const ENTRIES: Option<usize> = None;

    /// Fills `msg` with the message to publish this cycle for the targets in force; `false`
    /// to stay silent. `msg` is the device's message buffer, holding the last message
    /// encoded: every field is set, the sequences' buffers reused. `dt` is the loop period in
    /// seconds.
    fn encode_into(&mut self, active: &Active, table: &DeviceTable, dt: f32, msg: &mut Self::Cmd) -> bool;

    /// Canonical state from one state sample into `st` (joints in canonical order); `false`
    /// if the sample does not carry this device (wrong size, other side). `st` is the
    /// codec's own buffer, holding its last result: every field the codec reports is set,
    /// the others stay as they are (their defaults).
    fn decode_into(&mut self, sample: &Self::State, table: &DeviceTable, st: &mut HandState) -> bool;

    /// For devices without feedback: sets in `st` (the state to publish, empty otherwise)
    /// what is commanded.
    fn commanded_state(&self, _table: &DeviceTable, _st: &mut HandState) {}

    /// [`Self::encode_into`] a new message, or `None` to stay silent.
    fn encode(&mut self, active: &Active, table: &DeviceTable, dt: f32) -> Option<Self::Cmd> {
        let mut msg = Self::Cmd::default();
        self.encode_into(active, table, dt, &mut msg).then_some(msg)
    }

    /// [`Self::decode_into`] a new state, or `None` if the sample does not carry this device.
    fn decode(&mut self, sample: &Self::State, table: &DeviceTable) -> Option<HandState> {
        let mut st = HandState::default();
        self.decode_into(sample, table, &mut st).then_some(st)
    }

    /// The peer's state came back after it went stale (the command state was reseeded to a
    /// hold at the new measurement): a hold the codec keeps of its own
    /// ([`crate::control::MeasuredHold`]) begins again there too.
    fn reconnected(&mut self) {}
}

/// Topics and timing of a DDS-client device.
#[derive(Debug, Clone, PartialEq)]
pub struct DdsDeviceConfig {
    pub cmd_topic: String,
    /// None for devices without a state topic (rt/hand_sdk).
    pub state_topic: Option<String>,
    /// Publish rate, Hz.
    pub rate_hz: f64,
    /// State older than this is stale (and the link is considered down).
    pub stale_after: Duration,
    /// Commands published on arrival, and the bound on what the service receives.
    pub forward: Forwarding,
}

/// How commands reach the service: on arrival (bounded) or only at the loop's ticks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Forwarding {
    /// Publish an accepted command at once (`false`: only at the next tick, as before).
    pub on_arrival: bool,
    /// The most samples a second the service receives from this device, ticks included.
    pub max_send_hz: f64,
}

impl Forwarding {
    /// The default bound: four times the loop rate. A client streaming at twice the loop rate
    /// (a 1 kHz client on a 500 Hz service), whose commands come with their own jitter, then
    /// never waits for a token: at twice the loop rate, commands that came closer together
    /// than their average waited for one, and their latency grew by 0.2 ms at the median
    /// (docs/benchmarks.md §3b). A flood still reaches the service at this bound.
    pub const DEFAULT_FACTOR: f64 = 4.0;

    /// On arrival, bounded at [`Self::DEFAULT_FACTOR`] × `rate_hz`.
    pub fn default_for(rate_hz: f64) -> Self {
        Self {
            on_arrival: true,
            max_send_hz: rate_hz * Self::DEFAULT_FACTOR,
        }
    }
}

/// A token bucket over the samples a device publishes to its service: tokens come back at
/// `rate` a second up to [`SendBudget::BURST`], every publish spends one. Over any window of
/// `T` seconds the service receives at most `BURST + rate·T` samples, whatever the clients
/// send; a command that finds no token waits for the next one (latest wins meanwhile).
#[derive(Debug, Clone)]
pub struct SendBudget {
    rate: f64,
    tokens: f64,
    last: Instant,
}

impl SendBudget {
    /// Tokens the bucket holds at most: a command right after a tick goes out at once.
    pub const BURST: f64 = 2.0;

    pub fn new(rate: f64, now: Instant) -> Self {
        Self {
            rate: rate.max(1.0),
            tokens: Self::BURST,
            last: now,
        }
    }

    fn refill(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.last).as_secs_f64();
        self.tokens = (self.tokens + dt * self.rate).min(Self::BURST);
        self.last = self.last.max(now);
    }

    /// Spends a token when one is there.
    pub fn take(&mut self, now: Instant) -> bool {
        self.refill(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }

    /// When the next token is there (`now` when one is).
    pub fn ready_at(&mut self, now: Instant) -> Instant {
        self.refill(now);
        if self.tokens >= 1.0 {
            now
        } else {
            // Rounded up (and at least 1 ns): a token is there at the instant returned.
            now + Duration::from_nanos((((1.0 - self.tokens) / self.rate) * 1e9).ceil().max(1.0) as u64)
        }
    }
}

/// The QoS of a DDS-client device's command writer.
pub const CMD_QOS: Qos = Qos::Reliable { depth: 1 };
/// The QoS of a DDS-client device's state reader (and any other reader of the peer's state).
pub const STATE_QOS: Qos = Qos::BestEffort;

impl DdsDeviceConfig {
    /// What a device started with this configuration and codec `C` serves on the peer's
    /// topics, for discovery's diagnostics: its command writer and its state reader.
    pub fn served<C: DdsCodec>(&self) -> Vec<crate::discovery::diagnose::Served> {
        use crate::discovery::{diagnose::Served, Role};
        let mut out = vec![Served::new(
            &self.cmd_topic,
            crate::dds::type_name::<C::Cmd>(),
            Role::Writer,
            CMD_QOS.served(),
        )];
        if let Some(t) = &self.state_topic {
            out.push(Served::new(
                t,
                crate::dds::type_name::<C::State>(),
                Role::Reader,
                STATE_QOS.served(),
            ));
        }
        if let Some(n) = C::ENTRIES {
            out = out.into_iter().map(|s| s.with_entries(n)).collect();
        }
        out
    }
}

/// Devices that share one command message, each writing its own element of it (the Dex1
/// `actuator` variant's two grippers, Inspire DFX's two hands: `KindConfig::dds_command_element`):
/// the latest target each device set for its element, `None` while that element's device has
/// sent none (or there is none). The service applies the latest message whoever wrote it, so
/// every message must carry every element's own target: a device that put its measurement of
/// the other element in its messages would hold that element there and starve its own
/// device's targets. The devices of one command topic share one (in `OpenEnv::shared`).
pub struct SharedMessage<T, const N: usize>(Arc<Mutex<[Option<T>; N]>>);

impl<T, const N: usize> Default for SharedMessage<T, N> {
    fn default() -> Self {
        Self(Arc::new(Mutex::new(std::array::from_fn(|_| None))))
    }
}

impl<T, const N: usize> Clone for SharedMessage<T, N> {
    fn clone(&self) -> Self {
        Self(self.0.clone())
    }
}

impl<T: std::fmt::Debug, const N: usize> std::fmt::Debug for SharedMessage<T, N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("SharedMessage").field(&*self.lock()).finish()
    }
}

impl<T, const N: usize> SharedMessage<T, N> {
    fn lock(&self) -> std::sync::MutexGuard<'_, [Option<T>; N]> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// One device's element of a [`SharedMessage`] of `N` elements of type `T`, and its holds of
/// the others (measured as `M`). Each message it composes carries its own target, and for
/// every other element that element's own device's latest target, else a hold of it where it
/// was measured when the hold began (the first message that carries it), kept until that
/// element's device sends targets, our messages stop or the link comes back: never re-taken
/// from each new measurement, which would integrate the element's sag under a load
/// (docs/adapters.md, "Holds"). Nothing is sent while an element has neither.
#[derive(Debug, Clone)]
pub struct MessageElement<T, M: Copy, const N: usize> {
    shared: SharedMessage<T, N>,
    element: usize,
    holds: [MeasuredHold<M>; N],
}

impl<T: Copy, M: Copy + Default, const N: usize> MessageElement<T, M, N> {
    /// Element `element` (< `N`) of the message shared as `shared`.
    pub fn new(shared: SharedMessage<T, N>, element: usize) -> Self {
        Self {
            shared,
            element,
            holds: [MeasuredHold::default(); N],
        }
    }

    /// This device's element.
    pub fn element(&self) -> usize {
        self.element
    }

    /// The other elements.
    pub fn others(&self) -> impl Iterator<Item = usize> {
        let own = self.element;
        (0..N).filter(move |e| *e != own)
    }

    /// A new measurement of element `e` (a hold in force keeps its position).
    pub fn measure(&mut self, e: usize, m: M) {
        if let Some(h) = self.holds.get_mut(e) {
            h.measure(m);
        }
    }

    /// Element `e`'s newest measurement, if any.
    pub fn measured(&self, e: usize) -> Option<M> {
        self.holds.get(e).and_then(|h| h.measured())
    }

    /// Our messages stop (a silence, a reconnect): the next one begins new holds.
    pub fn release(&mut self) {
        for h in &mut self.holds {
            h.release();
        }
    }

    /// Records `own` as this element's latest target (`None`: no valid target) and returns
    /// every element of the next message, or `None` to send nothing: no valid target of
    /// ours, or another element with neither a target of its own device nor a measurement
    /// to hold (`hold` turns a measurement into that element's target).
    pub fn compose(&mut self, own: Option<T>, hold: impl Fn(M) -> T) -> Option<[T; N]> {
        let latest = {
            let mut shared = self.shared.lock();
            if let Some(slot) = shared.get_mut(self.element) {
                *slot = own;
            }
            *shared
        };
        let own = own?;
        if self
            .others()
            .any(|e| latest[e].is_none() && self.holds[e].measured().is_none())
        {
            return None;
        }
        let mut out = [own; N];
        for e in (0..N).filter(|e| *e != self.element) {
            out[e] = match latest[e] {
                Some(t) => {
                    self.holds[e].release();
                    t
                }
                None => hold(self.holds[e].hold()?),
            };
        }
        Some(out)
    }
}

struct Shared<S> {
    /// The newest state sample and when it was taken from the reader.
    latest: Mutex<Option<(S, Instant)>>,
    wake: Arc<Wake>,
}

/// Wakes the device loop between its ticks.
#[derive(Default)]
struct Wake {
    /// Runs the device's loop between its ticks (set once the loop is spawned).
    poker: OnceLock<crate::loops::Poker>,
    /// A command arrived (forwarding on arrival).
    command: AtomicBool,
    /// A forwarded command awaits the first state sample after it: the reader wakes the loop.
    awaiting: AtomicBool,
    /// The loop's state, for the work a command's or a sample's own thread does at once
    /// ([`Inline`]; set once the loop is built, held weakly).
    inline: OnceLock<std::sync::Weak<dyn Inline>>,
}

/// What a DDS-client device's loop does on the thread that brings the work, when the loop
/// is not running (`try_lock`; otherwise the loop is woken, as before): a forwarded command is
/// encoded and published from the caller's thread (a front's DDS listener), and the state
/// sample a forwarded command awaits is decoded and published from the reader's listener.
/// Neither ever waits for the loop.
trait Inline: Send + Sync {
    /// A command arrived: publish it now if the loop is free (`false`: wake the loop).
    fn command(&self, now: Instant) -> bool;
    /// The awaited sample arrived: take it now if the loop is free (`false`: wake the loop).
    fn sample(&self, now: Instant) -> bool;
}

impl Wake {
    /// Runs `f` on the loop's state when it is built and free; `false` otherwise.
    fn inline(&self, f: impl FnOnce(&dyn Inline) -> bool) -> bool {
        match self.inline.get().and_then(std::sync::Weak::upgrade) {
            Some(l) => f(&*l),
            None => false,
        }
    }

    fn unpark(&self) {
        if let Some(p) = self.poker.get() {
            p.poke();
        }
    }
}

/// The seq and tag of a command published at `at` (what a later state sample reflects).
#[derive(Debug, Clone, Copy, Default)]
struct Sent {
    at: Option<Instant>,
    seq: u64,
    tag: u32,
}

/// The last two publishes: a sample reflects the newest one published before it arrived.
#[derive(Debug, Default)]
struct SentLog {
    last: Sent,
    before: Sent,
}

impl SentLog {
    /// A publish of `seq`/`tag` at `at`; a re-publish of the same command keeps its first time.
    /// True when this publish carried a command for the first time.
    fn push(&mut self, seq: u64, tag: u32, at: Instant) -> bool {
        let new = self.last.at.is_none() || (seq, tag) != (self.last.seq, self.last.tag);
        if new {
            self.before = self.last;
            self.last = Sent { at: Some(at), seq, tag };
        }
        new
    }

    /// The command a sample taken at `arrived` reflects.
    fn reflected_by(&self, arrived: Instant) -> Option<Sent> {
        [self.last, self.before]
            .into_iter()
            .find(|s| s.at.is_some_and(|t| t <= arrived))
    }
}

/// The device loop: one [`crate::loops::Task`] iteration per tick, forwarded command or
/// awaited state sample.
struct DdsLoop<C: DdsCodec> {
    span: tracing::Span,
    shared: Arc<Shared<C::State>>,
    writer: crate::dds::Writer<C::Cmd>,
    codec: C,
    table: Arc<DeviceTable>,
    has_state: bool,
    config: DdsDeviceConfig,
    cmd: CommandState,
    state_tx: watch::Sender<HandState>,
    /// Told of each state published, on this loop's thread.
    taps: Arc<crate::device::StateTaps>,
    cycle_tx: watch::Sender<u64>,
    period: Duration,
    start: Instant,
    /// The next tick (`start + k·period`).
    next: Instant,
    k: u64,
    current: HandState,
    /// The codec's decoding buffer.
    decoded: HandState,
    /// The message buffer the codec encodes into.
    msg: C::Cmd,
    link: crate::link::LinkTracker,
    clock: crate::control::CycleClock,
    budget: SendBudget,
    sent: SentLog,
    last_encode: Option<Instant>,
    /// Targets wait for a token of the budget (a tick or a command found none).
    want_send: bool,
    active: Active,
    started: bool,
}

impl<C: DdsCodec> DdsLoop<C> {
    /// Takes the newest state sample, if any: the current state, stamped with the command it
    /// reflects. Whether one was measured.
    fn intake(&mut self, now: Instant) -> bool {
        let sample = self.shared.latest.lock().unwrap_or_else(|p| p.into_inner()).take();
        let Some((s, taken)) = sample else {
            return false;
        };
        let table = &self.table;
        if !self.codec.decode_into(&s, table, &mut self.decoded) {
            return false;
        }
        let st = &mut self.current;
        st.clone_from(&self.decoded);
        st.measured_at = Some(taken);
        st.measured_wall = Some(SystemTime::now() - now.saturating_duration_since(taken));
        st.freshness = Freshness::Fresh;
        st.closure = table.closure_of_state(&st.joints);
        // The command this sample reflects: the newest one published before it came.
        let reflected = self.sent.reflected_by(taken).unwrap_or_default();
        (st.cmd_seq, st.cmd_tag) = (reflected.seq, reflected.tag);
        if self.sent.last.at.is_some_and(|t| t <= taken) {
            self.shared.wake.awaiting.store(false, Ordering::Release);
        }
        if self.link.observe(true, &self.current.joints, &self.cmd) {
            self.codec.reconnected();
            // The peer came back: never replay what was in force before.
            tracing::info!("peer back: holding the measured position until the next command");
        }
        true
    }

    /// Publishes the targets in force when a send is wanted (`command`: one arrived; `tick`:
    /// the keep-alive) and the budget has a token.
    fn send(&mut self, now: Instant, tick: bool, command: bool) {
        let (table, config, loop_cmd) = (&self.table, &self.config, &self.cmd);
        let has_state = self.has_state;
        let period = self.period;
        // A tick is the keep-alive: redundant, and not worth a token of the budget, when a
        // forwarded command went out less than half a period ago (a 1 kHz client on a 500 Hz
        // device would otherwise share the budget with the ticks and wait for tokens).
        let heard_lately = self
            .last_encode
            .is_some_and(|t| now.saturating_duration_since(t) < period / 2);
        if command || (tick && !heard_lately) {
            self.want_send = true;
        }
        if self.want_send || tick {
            // Resolved now, not when the send was wanted: a reseed after the peer came back
            // (a hold at the new measurement) must never be overtaken by the targets in
            // force before it went away.
            loop_cmd.step_into(&self.current.joints, &mut self.active);
        }
        // Never "hold" a position that was never measured.
        if self.want_send && has_state && crate::link::blind_hold(self.link.ever_measured(), &self.active) {
            self.want_send = false; // stay silent
        }
        if self.want_send && self.budget.take(now) {
            self.want_send = false;
            // Ramps advance by the time since the last publish (a forwarded command comes
            // between ticks), at most a few periods after a stall.
            let dt = self
                .last_encode
                .map_or(period, |t| now.saturating_duration_since(t).min(period * 5));
            if self
                .codec
                .encode_into(&self.active, table, dt.as_secs_f32(), &mut self.msg)
            {
                self.last_encode = Some(now);
                if self.writer.write_copy(&self.msg).is_ok() {
                    Counters::inc(&loop_cmd.counters.sent);
                    let (seq, tag) = loop_cmd.applied();
                    // A command out for the first time (forwarded now, or after waiting for a
                    // token, or on a tick): the first sample after it is taken at once.
                    if self.sent.push(seq, tag, Instant::now()) && has_state && config.forward.on_arrival {
                        self.shared.wake.awaiting.store(true, Ordering::Release);
                    }
                }
            }
        }
    }

    /// Publishes the current state (the device's watch channel, then its taps).
    fn publish(&mut self) {
        let has_state = self.has_state;
        let (table, current, codec, safe) = (
            &self.table,
            &self.current,
            &self.codec,
            matches!(self.active, Active::Safe(..)),
        );
        let loop_cmd = &self.cmd;
        // In place: the published state's buffers are reused.
        self.state_tx.send_modify(|out| {
            out.clone_from(current);
            if !has_state {
                codec.commanded_state(table, out);
            }
            let reflected = (out.cmd_seq, out.cmd_tag);
            crate::link::stamp(out, loop_cmd, safe, false);
            if has_state {
                // A state reflects the command published before it was measured, not one
                // applied since.
                (out.cmd_seq, out.cmd_tag) = reflected;
            }
        });
        self.taps.run(&self.state_tx.borrow());
    }

    /// The loop's scope on the thread running it (its own, or one that brings a command or a
    /// sample): its tracing span, and `Within::Device` for what it allocates.
    fn enter(&self) -> (crate::dds::Enter, tracing::span::EnteredSpan) {
        (
            crate::dds::Enter::new(crate::dds::Within::Device),
            self.span.clone().entered(),
        )
    }

    /// When the loop must run next: the next tick, or sooner when targets wait for a token.
    fn next_run(&mut self) -> Instant {
        if self.want_send {
            self.next.min(self.budget.ready_at(Instant::now()))
        } else {
            self.next
        }
    }
}

impl<C: DdsCodec> crate::loops::Task for DdsTask<C> {
    fn run(&mut self, now: Instant) -> Option<Instant> {
        let mut l = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let l = &mut *l;
        let _scope = l.enter();
        if !std::mem::replace(&mut l.started, true) {
            tracing::debug!(rate_hz = l.config.rate_hz, cmd = %l.config.cmd_topic,
                on_arrival = l.config.forward.on_arrival, max_send_hz = l.config.forward.max_send_hz,
                "device loop started");
        }
        let has_state = l.has_state;
        let period = l.period;
        let tick = now >= l.next;
        let command = l.shared.wake.command.swap(false, Ordering::AcqRel);
        if tick {
            l.clock.tick(&l.cmd.counters, now);
        }
        let measured = l.intake(now);
        if tick && has_state {
            let stale = l.current.age(now).map(|a| a > l.config.stale_after).unwrap_or(true);
            if stale {
                if l.link.is_up() {
                    tracing::warn!(
                        stale_after_ms = l.config.stale_after.as_millis() as u64,
                        "peer state stale: link down"
                    );
                }
                l.current.freshness = Freshness::Stale;
                l.current.faults |= faults::LINK_DOWN;
                l.link.observe(false, &l.current.joints, &l.cmd);
            }
        }
        l.send(now, tick, command);
        if tick || measured || (command && !has_state) {
            l.publish();
        }
        if tick {
            l.k += 1;
            let _ = l.cycle_tx.send(l.k);
            l.next = l.start + Duration::from_nanos((period.as_nanos() as u64).saturating_mul(l.k));
            if Instant::now() > l.next + period {
                Counters::inc(&l.cmd.counters.missed_cycles);
            }
        }
        // Run again at the next tick, or when a token comes for waiting targets; a command
        // or (while a forwarded command awaits it) a state sample the loop could not take on
        // its own thread pokes the loop earlier.
        Some(l.next_run())
    }
}

/// The device loop as its loop thread runs it; the same state, behind the same lock, takes a
/// forwarded command or an awaited sample on the thread that brings it ([`Inline`]).
struct DdsTask<C: DdsCodec>(Arc<Mutex<DdsLoop<C>>>);

impl<C: DdsCodec> Inline for Mutex<DdsLoop<C>> {
    fn command(&self, now: Instant) -> bool {
        let Ok(mut l) = self.try_lock() else {
            return false;
        };
        let l = &mut *l;
        // A device without feedback publishes the commanded state on a command: that state
        // goes to the device's taps, which a front's listener (the caller) must not be told
        // of under its own lock; the loop does it.
        if !l.has_state || !l.started {
            return false;
        }
        let _scope = l.enter();
        let command = l.shared.wake.command.swap(false, Ordering::AcqRel);
        l.send(now, false, command);
        // Targets waiting for a token: the loop runs when it comes.
        !l.want_send
    }

    fn sample(&self, now: Instant) -> bool {
        let Ok(mut l) = self.try_lock() else {
            return false;
        };
        let l = &mut *l;
        if !l.started {
            return false;
        }
        let _scope = l.enter();
        if l.intake(now) {
            l.publish();
        }
        true
    }
}

/// A running DDS-client device.
pub struct DdsDevice {
    info: DeviceInfo,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    taps: Arc<crate::device::StateTaps>,
    cycles: watch::Receiver<u64>,
    /// The device loop (crate::loops: on a shared thread, or its own with `loop_threads = 0`).
    handle: crate::loops::Handle,
    /// Wakes the loop for a command to forward.
    wake: Arc<Wake>,
    /// The state reader (its listener takes the samples), deleted before the loop stops
    /// ([`DdsDevice::stop`]): never by its own listener.
    _reader: Mutex<Option<Box<dyn Send>>>,
    /// Commands are forwarded on arrival ([`Forwarding::on_arrival`]).
    on_arrival: bool,
}

impl DdsDevice {
    /// Creates the endpoints on `node` and starts the device loop.
    pub fn start<C: DdsCodec>(
        node: &Node,
        info: DeviceInfo,
        config: DdsDeviceConfig,
        codec: C,
    ) -> Result<Self, DdsError> {
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let config_on_arrival = config.forward.on_arrival;
        let writer = node.writer::<C::Cmd>(&config.cmd_topic, CMD_QOS)?;
        let shared: Arc<Shared<C::State>> = Arc::new(Shared {
            latest: Mutex::new(None),
            wake: Arc::new(Wake::default()),
        });
        let wake = shared.wake.clone();
        let counters = cmd.counters.clone();
        let reader = match &config.state_topic {
            Some(t) => {
                let sh = shared.clone();
                let ctr = counters.clone();
                // The samples of one call, the buffer reused.
                let mut v = Vec::new();
                Some(node.reader_with_callback::<C::State, _>(t, STATE_QOS, move |h| {
                    if h.take_into(&mut v) > 0 {
                        ctr.state_samples.fetch_add(v.len() as u64, Ordering::Relaxed);
                        let taken = Instant::now();
                        *sh.latest.lock().unwrap_or_else(|p| p.into_inner()) = v.pop().map(|s| (s, taken));
                        v.clear();
                        // The sample a forwarded command awaits: taken here, in the listener,
                        // when the loop is free; else the loop is woken for it.
                        if sh.wake.awaiting.load(Ordering::Acquire) && !sh.wake.inline(|l| l.sample(taken)) {
                            sh.wake.unpark();
                        }
                    }
                })?)
            }
            None => None,
        };
        let n = table.joint_count();
        let mut initial = HandState::empty(n);
        if config.state_topic.is_none() {
            // A device without feedback reports what is commanded from the start.
            codec.commanded_state(&table, &mut initial);
        }
        let (state_tx, state_rx) = watch::channel(initial);
        let taps = Arc::new(crate::device::StateTaps::default());
        let (cycle_tx, cycles) = watch::channel(0u64);
        let name = info.name.clone();
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let period = Duration::from_secs_f64(1.0 / config.rate_hz.max(1.0));
        // On the process-wide grid, so that device loops of one rate wake together
        // (crate::loops); the first tick at the next grid instant.
        let start = crate::loops::first_deadline(period);
        let budget = SendBudget::new(config.forward.max_send_hz.max(config.rate_hz), start);
        let task = DdsLoop {
            span,
            shared: shared.clone(),
            writer,
            codec,
            table: table.clone(),
            has_state: config.state_topic.is_some(),
            config,
            cmd: cmd.clone(),
            state_tx,
            taps: taps.clone(),
            cycle_tx,
            period,
            start,
            next: start,
            k: 0,
            current: HandState::empty(n),
            decoded: HandState::default(),
            msg: C::Cmd::default(),
            link: crate::link::LinkTracker::default(),
            clock: crate::control::CycleClock::default(),
            budget,
            sent: SentLog::default(),
            last_encode: None,
            want_send: false,
            active: Active::Idle,
            started: false,
        };
        let task = Arc::new(Mutex::new(task));
        let inline: Arc<dyn Inline> = task.clone();
        let _ = wake.inline.set(Arc::downgrade(&inline));
        let handle = crate::loops::spawn(
            crate::loops::Class::Devices,
            &format!("dev-{name}"),
            start,
            DdsTask(task),
        )
        .map_err(|e| DdsError::Thread(e.to_string()))?;
        let _ = wake.poker.set(handle.poker());
        Ok(Self {
            _reader: Mutex::new(reader.map(|r| Box::new(r) as Box<dyn Send>)),
            info,
            cmd,
            state_rx,
            taps,
            cycles,
            handle,
            wake,
            on_arrival: config_on_arrival,
        })
    }

    /// Publishes the command just submitted (forwarding on arrival): from the caller's thread
    /// when the loop is free, else by waking the loop.
    fn forward(&self) {
        if self.on_arrival {
            self.wake.command.store(true, Ordering::Release);
            if !self.wake.inline(|l| l.command(Instant::now())) {
                self.wake.unpark();
            }
        }
    }

    /// Stops the loop thread (after the caller put the device in a safe state), the state
    /// reader first. Its deletion waits for a listener call in progress, and after it no
    /// listener can reach the loop ([`Wake::inline`] upgrades the loop's weak handle for the
    /// call). Stopped the other way round, a listener call that upgraded it just before holds
    /// the last reference, and the loop, its command writer with it, is dropped inside that
    /// listener: deleting a writer from a listener CycloneDDS runs on a thread it counts as
    /// awake (an in-process writer's, delivering locally) waits for its garbage collector,
    /// which waits for that thread, and the reader's deletion then waits for the listener
    /// forever (adapters/tests/teardown.rs).
    pub fn stop(&self) {
        drop(self._reader.lock().unwrap_or_else(|p| p.into_inner()).take());
        self.handle.stop();
    }

    /// Waits until the loop has run `n` more cycles.
    pub async fn cycles(&self, n: u64) -> Result<(), DeviceError> {
        let mut rx = self.cycles.clone();
        let target = *rx.borrow() + n;
        while *rx.borrow() < target {
            if rx.changed().await.is_err() {
                return Err(DeviceError::Stopped);
            }
        }
        Ok(())
    }
}

impl Drop for DdsDevice {
    fn drop(&mut self) {
        self.stop();
    }
}

#[async_trait]
impl HandDevice for DdsDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn command(&self, cmd: HandCommand) -> Result<(), DeviceError> {
        self.cmd.submit(cmd)?;
        self.forward();
        Ok(())
    }

    fn command_checked(&self, seq: u64, body: crate::mapping::CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.cmd.submit_checked(seq, body, tag);
        self.forward();
        Ok(())
    }

    fn state(&self) -> watch::Receiver<HandState> {
        self.state_rx.clone()
    }

    fn state_taps(&self) -> Option<&crate::device::StateTaps> {
        Some(&self.taps)
    }

    fn commanded(&self) -> Option<Vec<f32>> {
        self.cmd.targets()
    }

    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError> {
        self.cmd.request_safe(action);
        self.forward();
        self.cycles(2).await
    }

    fn stats(&self) -> DeviceStats {
        self.cmd.counters.snapshot()
    }
}

/// Private topics of an in-process emulated peer for `device` (the emulator backend of a
/// DDS-client kind: the peer sits exactly where the robot's service would).
pub fn emulator_topics(device: &str) -> (String, String) {
    (
        format!("rt/handgate/emu/{device}/cmd"),
        format!("rt/handgate/emu/{device}/state"),
    )
}

/// A DDS-client device and the emulated peer it drives; the peer lives as long as the device.
pub struct WithPeer {
    device: DdsDevice,
    _peer: Box<dyn Send + Sync>,
}

impl WithPeer {
    pub fn new(device: DdsDevice, peer: impl Send + Sync + 'static) -> Self {
        Self {
            device,
            _peer: Box::new(peer),
        }
    }
}

#[async_trait]
impl HandDevice for WithPeer {
    fn info(&self) -> &DeviceInfo {
        self.device.info()
    }
    fn command(&self, cmd: HandCommand) -> Result<(), DeviceError> {
        self.device.command(cmd)
    }
    fn command_checked(&self, seq: u64, body: crate::mapping::CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.device.command_checked(seq, body, tag)
    }
    fn state(&self) -> watch::Receiver<HandState> {
        self.device.state()
    }
    fn state_taps(&self) -> Option<&crate::device::StateTaps> {
        self.device.state_taps()
    }
    fn commanded(&self) -> Option<Vec<f32>> {
        self.device.commanded()
    }
    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError> {
        self.device.safe_state(action).await
    }
    fn stats(&self) -> DeviceStats {
        self.device.stats()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two devices on one message: silent until the other element has a target or a
    /// measurement; its own device's target beats a hold and ends it; a hold is taken when it
    /// begins and kept; a release begins a new one.
    #[test]
    fn a_shared_message_carries_every_elements_own_target_else_a_kept_hold() {
        let shared = SharedMessage::<f32, 2>::default();
        let mut a = MessageElement::<f32, f32, 2>::new(shared.clone(), 0);
        let mut b = MessageElement::<f32, f32, 2>::new(shared, 1);
        let held = |m: f32| m + 100.0;
        assert_eq!(
            a.compose(Some(1.0), held),
            None,
            "the other neither driven nor measured"
        );
        a.measure(1, 5.0);
        assert_eq!(a.compose(Some(1.0), held), Some([1.0, 105.0]));
        a.measure(1, 4.0);
        assert_eq!(a.compose(Some(1.5), held), Some([1.5, 105.0]), "the hold is kept");
        assert_eq!(
            b.compose(Some(2.0), held),
            Some([1.5, 2.0]),
            "a's own target, not a hold"
        );
        assert_eq!(a.compose(Some(1.0), held), Some([1.0, 2.0]));
        assert_eq!(b.compose(None, held), None, "no valid target of its own: nothing sent");
        assert_eq!(
            a.compose(Some(1.0), held),
            Some([1.0, 104.0]),
            "b's hold ended: a new one"
        );
        a.measure(1, 3.0);
        a.release();
        assert_eq!(a.compose(Some(1.0), held), Some([1.0, 103.0]), "after a release");
        assert_eq!((a.measured(1), a.measured(0)), (Some(3.0), None));
        assert_eq!(b.others().collect::<Vec<_>>(), [0]);
    }

    /// No hold begins with a message that is not sent.
    #[test]
    fn a_message_that_cannot_be_sent_begins_no_hold() {
        let mut a = MessageElement::<f32, f32, 3>::new(SharedMessage::default(), 0);
        a.measure(1, 5.0);
        assert_eq!(a.compose(Some(1.0), |m| m), None, "element 2 has nothing");
        a.measure(1, 4.0);
        a.measure(2, 7.0);
        assert_eq!(a.compose(Some(1.0), |m| m), Some([1.0, 4.0, 7.0]));
    }

    /// A client at 10 kHz against a budget of 1 kHz: the service receives at most
    /// `BURST + rate·T` samples over any window, and a token is there again when `ready_at` says.
    #[test]
    fn the_send_budget_bounds_what_the_service_receives() {
        let t0 = Instant::now();
        let mut b = SendBudget::new(1000.0, t0);
        let mut sent = Vec::new();
        for i in 0..10_000u64 {
            let now = t0 + Duration::from_micros(100 * i);
            if b.take(now) {
                sent.push(now);
            }
        }
        // One second of 10 kHz: 1000 refilled plus the initial burst.
        assert!(sent.len() <= 1000 + SendBudget::BURST as usize, "{}", sent.len());
        assert!(sent.len() >= 990, "the budget's own rate goes through: {}", sent.len());
        // Any 100 ms window holds at most BURST + 100.
        for (i, t) in sent.iter().enumerate() {
            let in_window = sent[i..]
                .iter()
                .take_while(|u| **u < *t + Duration::from_millis(100))
                .count();
            assert!(in_window <= 102, "{in_window} in the 100 ms from {i}");
        }
        // Drained: the next token is 1 ms of refill away, not now.
        let now = t0 + Duration::from_secs(1);
        while b.take(now) {}
        let ready = b.ready_at(now);
        assert!(
            ready > now && ready <= now + Duration::from_millis(1),
            "{:?}",
            ready - now
        );
        assert!(b.take(ready), "a token at ready_at");
    }

    /// A client slower than the budget is never held back: every command goes out at once.
    #[test]
    fn a_client_under_the_budget_is_forwarded_every_time() {
        let t0 = Instant::now();
        let mut b = SendBudget::new(1000.0, t0);
        // Ticks at 500 Hz plus a client at 400 Hz (900 Hz in all, under the 1 kHz budget).
        let mut events: Vec<(u64, bool)> = (0..500).map(|i| (i * 2000, false)).collect();
        events.extend((0..400).map(|i| (i * 2500 + 700, true)));
        events.sort();
        for (us, is_cmd) in events {
            let ok = b.take(t0 + Duration::from_micros(us));
            if is_cmd {
                assert!(ok, "the command at {us} us waited");
            }
        }
    }

    /// A sample reflects the newest command published before it was taken; a re-publish of a
    /// command (the keep-alive tick) keeps the time it first went out.
    #[test]
    fn a_sample_reflects_the_command_published_before_it() {
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        let mut log = SentLog::default();
        assert!(log.reflected_by(ms(0)).is_none(), "nothing published yet");
        assert!(log.push(1, 11, ms(1)), "a first publish of seq 1");
        assert!(!log.push(1, 11, ms(3)), "a keep-alive is not a new command");
        assert!(log.push(2, 22, ms(5)));
        let r = |t| log.reflected_by(ms(t)).map(|s| (s.seq, s.tag));
        assert_eq!(r(0), None, "taken before anything went out");
        assert_eq!(r(2), Some((1, 11)));
        assert_eq!(r(4), Some((1, 11)), "the keep-alive did not move seq 1's time");
        assert_eq!(r(5), Some((2, 22)));
        assert_eq!(r(9), Some((2, 22)));
    }
}
