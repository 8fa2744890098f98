//! Front tasks: each front's endpoints, and the loop that moves its messages between them,
//! its devices and its core (`handgate_adapters::front::core`, where every decision is:
//! ownership, checks, silence, prompt state); state-only fronts' publishing.

use handgate_adapters::dds::WriterHandle;
use handgate_adapters::front::sources::{Sources, Verdict};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::front::core::{
    self as front_core, Action, Change, Counter, Driven, FrontCore, FrontId, Log, Sample, StateGrid,
};
use handgate_adapters::model::HandState;
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

use super::status::FrontTally;
use super::{DeviceSlot, RuntimeError};
use crate::plan::{FrontPlan, SilencePlan};
use crate::ticker::Ticker;
use handgate_adapters::front::serve as fronts;
use handgate_adapters::route as router;

/// Logs at most once per second per key (refused requests in `crate::http`; a front's
/// rejected commands are its core's): the rule of [`front_core::RateLimit`], shared between tasks.
#[derive(Debug, Default)]
pub(crate) struct RateLimitedLog {
    limit: Mutex<front_core::RateLimit>,
}

impl RateLimitedLog {
    /// Whether an event of `key` at `now` is logged ([`front_core::RateLimit::admit`]).
    pub(crate) fn admit(&self, key: &'static str, now: Instant) -> Option<u64> {
        self.limit.lock().unwrap_or_else(|p| p.into_inner()).admit(key, now)
    }
}

/// A front that publishes state only: its writer over its devices, at its rate.
fn spawn_state_only(
    mut out: Box<dyn fronts::StateIo>,
    f: &FrontPlan,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    tally: Arc<FrontTally>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let slots: Vec<Arc<DeviceSlot>> = f
        .devices
        .iter()
        .map(|n| {
            devices
                .get(n)
                .cloned()
                .ok_or_else(|| RuntimeError::UnknownDevice(n.clone()))
        })
        .collect::<Result<_, _>>()?;
    let mut tick = Ticker::hz(f.state_hz);
    Ok(tokio::spawn(async move {
        loop {
            tokio::select! {
                _ = tick.tick() => {
                    let states: Vec<_> = slots.iter().map(|s| s.device.state().borrow().clone()).collect();
                    let published: Vec<fronts::Published<'_>> = slots
                        .iter()
                        .zip(states)
                        .map(|(s, state)| fronts::Published { device: &s.plan.name, table: &s.table, state })
                        .collect();
                    out.publish(&published);
                    tally.state();
                }
                _ = shutdown.changed() => break,
            }
        }
    }))
}

pub(super) fn spawn_front(
    env: &fronts::FrontEnv,
    f: &FrontPlan,
    allow: Option<&Sources>,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    tally: Arc<FrontTally>,
    shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let (tx, rx) = mpsc::channel::<fronts::Incoming>(64);
    let dropped = Arc::new(AtomicU64::new(0));
    let queue = fronts::Queue::new(tx.clone());
    // The front kind's endpoints (readers and writers).
    let out = match fronts::open(env, f, queue.clone(), dropped.clone())? {
        fronts::Endpoints::Commands(out) => out,
        fronts::Endpoints::StateOnly(out) => return spawn_state_only(out, f, devices, tally, shutdown),
    };
    let task = FrontTask {
        id: FrontId::next(),
        name: f.name.clone(),
        control: f.config.control,
        hold: f.hold(),
        state_hz: f.state_hz,
        max_command_age: f.config.max_command_age_ms.map(|m| m.as_duration()),
        allow: allow.cloned(),
        bindings: f
            .bindings
            .iter()
            .map(|b| (b.device.clone(), b.element, b.silence, b.table.clone()))
            .collect(),
        // A command-only front is not told its devices' states: it would publish nothing.
        publishes: f.publishes_state(),
        tally,
    };
    let (live, handle) = run_front(task, out, (tx, rx), dropped, devices, env.discovery.clone(), shutdown)?;
    // From now on the readers' listeners hand their samples to the front itself.
    let direct: Arc<dyn fronts::Direct> = live;
    queue.set_direct(Arc::downgrade(&direct));
    Ok(handle)
}

/// What the front task needs of a front: its name, who may command it, its state rate and
/// its devices (name, element, silence, the front's table for it).
pub(crate) struct FrontTask {
    /// Its id ([`FrontId::next`]).
    pub id: FrontId,
    pub name: String,
    pub control: handgate_adapters::front::config::Control,
    pub hold: Duration,
    pub state_hz: f64,
    /// Commands older than this on arrival are dropped (`max_command_age_ms`; `None`: none).
    pub max_command_age: Option<Duration>,
    /// Only these hosts' commands are taken (`export.allow_commands_from`; `None`: anyone's).
    pub allow: Option<Sources>,
    pub bindings: Vec<(
        String,
        usize,
        SilencePlan,
        Option<Arc<handgate_adapters::mapping::DeviceTable>>,
    )>,
    /// The front publishes state (a DDS front with a state topic); `false`: it publishes
    /// nothing (a command-only front, the dashboard's page front), so its devices' states are
    /// not told to it.
    pub publishes: bool,
    /// Its command samples and state publishes, counted for the status extension.
    pub tally: Arc<FrontTally>,
}

/// One device a front drives: what the core does not decide with (its slot, its element in
/// the front's messages, its state channel) and its silence action in progress.
struct Device {
    slot: Arc<DeviceSlot>,
    element: usize,
    state_rx: watch::Receiver<HandState>,
    /// The device tells the front its states on its loop thread ([`StateTaps`]); otherwise
    /// the front task waits on `state_rx` for the states it awaits.
    ///
    /// [`StateTaps`]: handgate_adapters::device::StateTaps
    tapped: bool,
    /// The silence action running on it (its own task): `true` once it is done.
    pending_safe: Option<watch::Receiver<bool>>,
}

impl Device {
    fn safe_running(&self) -> bool {
        self.pending_safe.as_ref().is_some_and(|d| !*d.borrow())
    }
}

/// The devices as the front's core sees them: the device itself, and the marks every front
/// on it shares through its counters (which front commanded it last, whether a silence
/// action holds it).
struct Shared<'a>(&'a [Device]);

impl front_core::Devices for Shared<'_> {
    fn command(
        &mut self,
        device: usize,
        seq: u64,
        body: handgate_adapters::mapping::CheckedBody,
        tag: u32,
    ) -> Result<(), handgate_adapters::device::DeviceError> {
        self.0[device].slot.device.command_checked(seq, body, tag)
    }

    fn is_last_front(&self, device: usize, front: FrontId) -> bool {
        self.0[device].slot.counters.last_front.load(Ordering::Relaxed) == front.get()
    }

    fn mark_last_front(&mut self, device: usize, front: FrontId) -> bool {
        self.0[device]
            .slot
            .counters
            .last_front
            .swap(front.get(), Ordering::Relaxed)
            != front.get()
    }

    fn set_tripped(&mut self, device: usize, tripped: bool) -> bool {
        self.0[device]
            .slot
            .counters
            .tripped
            .swap(u64::from(tripped), Ordering::Relaxed)
            != 0
    }
}

/// A running front: its state behind one lock, taken by whichever thread has something for
/// it (docs/fronts.md, "Latency"):
///
/// - a reader's DDS listener, with a command sample ([`fronts::Direct`]): admit, decode,
///   check, hand off to the device (`command_checked` never blocks: it replaces the pending
///   command and wakes the device loop), all in the listener;
/// - a device loop, with a state it just published ([`StateTaps`]): the prompt state of a
///   command and the periodic state go out from there;
/// - the front's task: deadlines (silence, the prompt wait), the periodic state when no
///   device drives it, the low-frequency copy, samples that must wait for a silence action,
///   the dashboard page's commands.
///
/// Nothing holds the lock across a wait, a device's I/O or an await.
///
/// [`StateTaps`]: handgate_adapters::device::StateTaps
pub(crate) struct Live {
    state: Mutex<Task>,
    /// Wakes the task: a deadline moved earlier, a sample was queued for it.
    wake: tokio::sync::Notify,
    /// The task's queue, for samples that must wait (in order behind each other).
    queue: mpsc::Sender<fronts::Incoming>,
    dropped: Arc<AtomicU64>,
    /// Where silence actions run (a listener's thread has no runtime of its own).
    rt: tokio::runtime::Handle,
    span: tracing::Span,
}

/// A running front's state: its core (every decision), its devices, its wire side and its
/// publishing grid.
struct Task {
    name: String,
    core: FrontCore,
    devices: Vec<Device>,
    out: Box<dyn fronts::FrontIo>,
    discovery: watch::Receiver<Arc<handgate_adapters::discovery::Snapshot>>,
    grid: StateGrid,
    /// The core's actions, carried out as they come (kept to reuse its allocation).
    acts: Vec<Action>,
    /// `export.allow_commands_from`, and each writer's verdict once discovery knew its
    /// participant (at most [`MAX_JUDGED`] writers, then all are judged again).
    allow: Option<(Sources, HashMap<WriterHandle, bool>)>,
    /// Samples go to the task's queue, in order, until it is empty: a silence action runs on
    /// a device (a command must not overtake it), or samples queued before the listeners
    /// took over are still there.
    deferring: bool,
    /// Command samples taken and state publishes (the status extension's rates).
    tally: Arc<FrontTally>,
}

/// Writers whose source verdict a front keeps.
const MAX_JUDGED: usize = 64;

impl Live {
    fn lock(&self) -> std::sync::MutexGuard<'_, Task> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Device `device` published `st` (on its loop thread): the prompt state of an awaited
    /// command, and the periodic state when the devices drive it, go out now.
    fn device_state(&self, device: usize, st: &HandState) {
        let now = Instant::now();
        let mut guard = self.lock();
        let t = &mut *guard;
        if t.core.awaiting(device) {
            t.core.state(now, device, st.cmd_seq, &mut t.acts);
        }
        // A prompt publish (an `Action::Publish` the core asked for) is the period's publish
        // sent early, when the grid allows it (`StateGrid::prompt`, in `carry_out`); without
        // one, the device's state is a chance for the periodic publish.
        if !t.acts.iter().any(|a| matches!(a, Action::Publish)) && t.grid.at_state(now) {
            t.publish_periodic(now, Some((device, st)), self.dropped.load(Ordering::Relaxed));
        }
        t.carry_out(self, Some((device, st)));
    }
}

impl fronts::Direct for Live {
    /// A command sample, in the reader's listener: decided and handed off here, unless a
    /// silence action runs on one of the front's devices (or samples wait in the queue), when
    /// it goes to the task's queue behind them.
    fn take(&self, msg: fronts::Incoming) -> bool {
        let mut t = self.lock();
        if t.deferring || t.devices.iter().any(Device::safe_running) {
            t.deferring = true;
            let queued = self.queue.try_send(msg).is_ok();
            drop(t);
            self.wake.notify_one();
            return queued;
        }
        let before = t.wake_at();
        t.sample(self, msg);
        let after = t.wake_at();
        drop(t);
        // The task sleeps until the deadline it last saw: wake it when one came earlier.
        if after.is_some_and(|a| before.map_or(true, |b| a < b)) {
            self.wake.notify_one();
        }
        true
    }
}

impl Task {
    /// When the task must wake for the core: its silence deadlines, and the end of the prompt
    /// wait while a device that tells no states is awaited (the task listens to its channel
    /// until then; a tapped device's state ends the wait itself, and any wake clears it).
    fn wake_at(&self) -> Option<Instant> {
        if self.devices.iter().all(|d| d.tapped) {
            self.core.next_silence()
        } else {
            self.core.next_deadline()
        }
    }

    /// A command sample: the core admits it, the front kind's codec decodes it, and the core
    /// checks and routes its commands. The caller made sure no silence action runs on the
    /// front's devices, so the safe state never lands after a newer command.
    fn sample(&mut self, live: &Live, msg: fronts::Incoming) {
        self.tally.command();
        match self.source_allowed(&msg.writer, live) {
            Some(true) => {}
            Some(false) => {
                for d in &self.devices {
                    d.slot.counters.not_allowed_cmd.fetch_add(1, Ordering::Relaxed);
                }
                return;
            }
            // Its participant not discovered yet: refused, not counted against a host that
            // may be listed.
            None => return,
        }
        let sample = Sample::of(&msg);
        let Some(admitted) = self.core.admit(&sample, &mut self.acts) else {
            self.carry_out(live, None);
            return;
        };
        let out = &self.out;
        let decoded = with_views(&self.core, &self.devices, None, |bound| out.decode(bound, &msg.msg));
        let devices = &mut Shared(&self.devices);
        self.core
            .decoded(admitted, Instant::now(), &sample, decoded, devices, &mut self.acts);
        self.carry_out(live, None);
    }

    /// Whether `writer`'s host may command this front (`export.allow_commands_from`): checked
    /// at the edge, before the core sees the sample, so a refused host neither commands nor
    /// takes the front over. A writer's verdict is kept once discovery knows its participant;
    /// until then (`None`) its commands are refused (fail closed) and it is asked again.
    /// Logged once per writer.
    fn source_allowed(&mut self, writer: &handgate_adapters::dds::WriterInfo, live: &Live) -> Option<bool> {
        let Some((sources, judged)) = &mut self.allow else {
            return Some(true);
        };
        if let Some(ok) = judged.get(&writer.handle) {
            return Some(*ok);
        }
        let snap = self.discovery.borrow().clone();
        let verdict = sources.judge(writer, &snap);
        let ok = verdict == Verdict::Allowed;
        if let Verdict::Refused(ips) = &verdict {
            if judged.len() >= MAX_JUDGED {
                judged.clear();
            }
            judged.insert(writer.handle, false);
            let at: Vec<String> = ips.iter().map(|i| i.to_string()).collect();
            let _span = live.span.enter();
            warn!(front = %self.name, "refused the commands of {}: its host ({}) is not in export.allow_commands_from \
                (counted in not_allowed_cmd; its state still flows)", fronts::describe_writer(writer, &snap), at.join(", "));
        } else if ok {
            if judged.len() >= MAX_JUDGED {
                judged.clear();
            }
            judged.insert(writer.handle, true);
        }
        (verdict != Verdict::Unknown).then_some(ok)
    }

    /// Publishes the bound devices' state (`given`: one device's state, as its loop is
    /// telling it, instead of borrowing its channel; `lf`: the low-frequency copy).
    fn publish(&mut self, given: Option<(usize, &HandState)>, lf: bool) {
        let out = &mut self.out;
        with_views(&self.core, &self.devices, given, |bound| out.publish(bound, lf));
        if !lf {
            self.tally.state();
        }
    }

    /// The periodic publish at `now`, and what the core keeps of it (the state that went out
    /// for each device, the queue's drops).
    fn publish_periodic(&mut self, now: Instant, given: Option<(usize, &HandState)>, dropped: u64) {
        self.publish(given, false);
        for i in 0..self.devices.len() {
            let seq = match given {
                Some((g, st)) if g == i => st.cmd_seq,
                _ => self.devices[i].state_rx.borrow().cmd_seq,
            };
            self.core.published(i, seq);
        }
        self.core.queue(now, dropped, &mut self.acts);
    }

    /// Carries out the core's actions, in order (`given`: the state a device loop is telling,
    /// when it is the caller).
    fn carry_out(&mut self, live: &Live, given: Option<(usize, &HandState)>) {
        let mut acts = std::mem::take(&mut self.acts);
        for a in acts.drain(..) {
            match a {
                Action::Count { device, counter } => {
                    let c = &self.devices[device].slot.counters;
                    match counter {
                        Counter::Accepted => {
                            c.accepted.fetch_add(1, Ordering::Relaxed);
                            c.mark_accepted();
                        }
                        Counter::Rejected => {
                            c.rejected.fetch_add(1, Ordering::Relaxed);
                        }
                        Counter::ForeignCmd => {
                            c.foreign_cmd.fetch_add(1, Ordering::Relaxed);
                        }
                        Counter::WatchdogTrip => {
                            c.watchdog_trips.fetch_add(1, Ordering::Relaxed);
                        }
                        Counter::Duplicate => {
                            c.duplicate_cmd.fetch_add(1, Ordering::Relaxed);
                        }
                        Counter::Reordered => {
                            c.reordered_cmd.fetch_add(1, Ordering::Relaxed);
                        }
                        Counter::Late => {
                            c.late_cmd.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                }
                Action::Publish => {
                    // The period's publish, early; refused when that period's already went
                    // out (the next periodic one then carries this state or a newer one).
                    if self.grid.prompt(Instant::now()) {
                        self.publish(given, false);
                    }
                }
                Action::Safe { device, action } => {
                    // In a task of its own: the front keeps publishing on its deadlines while
                    // the device confirms its safe state. Commands wait for it.
                    let dev = self.devices[device].slot.device.clone();
                    let (done_tx, done) = watch::channel(false);
                    self.devices[device].pending_safe = Some(done);
                    live.rt.spawn(async move {
                        let _ = dev.safe_state(action).await;
                        let _ = done_tx.send(true);
                    });
                }
                Action::Owner { devices, writer } => {
                    // Who commands the device (status, dashboard): named on change only.
                    let who = format!(
                        "{}: {}",
                        self.name,
                        fronts::describe_writer(&writer, &self.discovery.borrow())
                    );
                    for i in devices {
                        self.devices[i].slot.counters.set_owner(who.clone());
                    }
                }
                Action::Log(l) => {
                    let _span = live.span.enter();
                    self.log(l)
                }
            }
        }
        self.acts = acts;
    }
    /// Writes a log line of the core.
    fn log(&self, l: Log) {
        let name = &self.name;
        let describe = |w: &handgate_adapters::dds::WriterInfo| fronts::describe_writer(w, &self.discovery.borrow());
        match l {
            Log::Refused { writer, owner, hold } => {
                let hold_ms = hold.as_millis() as u64;
                let owner = owner.as_deref().map_or("?".into(), describe);
                warn!(front = %name, hold_ms, "refused the commands of {}: {owner} commands this front \
                    (control = \"exclusive\"; refused until it is silent for {hold_ms} ms; counted in foreign_cmd)",
                    describe(&writer));
            }
            Log::Commands {
                writer,
                previous,
                change,
            } => {
                let new = describe(&writer);
                let old = previous.as_deref().map_or("?".into(), describe);
                match change {
                    Change::First => info!(front = %name, "{new} commands this front"),
                    Change::AfterSilence { silent } => info!(front = %name,
                        silent_ms = silent.as_millis() as u64,
                        "{new} commands this front: {old} was silent for {} ms", silent.as_millis()),
                    Change::Forced => warn!(front = %name, "{new} took this front over from {old} (forced)"),
                }
            }
            Log::Rejected { why, suppressed } => {
                // `front` as a string field, as this line always had it.
                warn!(
                    front = name.as_str(),
                    reason = why.reason(),
                    suppressed,
                    "rejected command: {why}"
                );
            }
            Log::Advice { writer, why } => {
                warn!(
                    front = %name,
                    reason = why.reason(),
                    "rejects the commands of {}: {why}; fix: {} (said once per client; each one counted in bad_input)",
                    describe(&writer),
                    why.fix().unwrap_or("see docs/fronts.md, Bad input")
                );
            }
            Log::Silence {
                device,
                mode,
                after,
                action,
            } => {
                warn!(front = %name, device = %self.devices[device].slot.plan.name, silence = %mode,
                    timeout_ms = after.as_millis() as u64, action = ?action,
                    "no command: moving the device to its silence action");
            }
            Log::Resumed { device } => {
                info!(front = %name, device = %self.devices[device].slot.plan.name,
                    "commands resumed after the silence action");
            }
            Log::QueueFull { dropped, total } => {
                warn!(front = %name, dropped, queue_full_total = total,
                    "front queue full: commands dropped unprocessed");
            }
            Log::Dropped {
                writer,
                why,
                suppressed,
            } => {
                warn!(front = %name, reason = why.reason(), suppressed,
                    "dropped a command of {}: {why} (counted in {}_cmd)", describe(&writer), why.reason());
            }
            Log::ClockAhead { writer, ahead } => {
                warn!(front = %name, ahead_ms = ahead.as_secs_f64() * 1e3,
                    "the clock of {} runs {:.1} ms ahead of this host's: its commands' ages are negative, \
                    so max_command_age_ms drops none of them as late (synchronise the clocks: chrony or PTP)",
                    describe(&writer), ahead.as_secs_f64() * 1e3);
            }
            Log::Restarted { writer, behind, after } => {
                warn!(front = %name, behind_ms = behind.as_secs_f64() * 1e3,
                    "the commands of {} were all older than its last accepted one for {} ms (this one by {:.1} ms): \
                    its clock was stepped back; its commands are accepted again from this one",
                    describe(&writer), after.as_millis(), behind.as_secs_f64() * 1e3);
            }
        }
    }
}

/// Runs a front taking commands: samples from its readers' listeners ([`Live`], once the
/// caller set it as their [`fronts::Direct`] handler) or from `queue` (samples that wait, the
/// dashboard's page), decoded by `out`; every decision (ownership, the check against each
/// device's table, silence, prompt state) is the front's core's
/// ([`handgate_adapters::front::core`]). The task moves what no listener or device loop
/// brings: deadlines, the periodic state when no device drives it, queued samples.
pub(crate) fn run_front(
    f: FrontTask,
    out: Box<dyn fronts::FrontIo>,
    queue: (mpsc::Sender<fronts::Incoming>, mpsc::Receiver<fronts::Incoming>),
    dropped: Arc<AtomicU64>,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    discovery: watch::Receiver<Arc<handgate_adapters::discovery::Snapshot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<(Arc<Live>, tokio::task::JoinHandle<()>), RuntimeError> {
    let (tx, mut rx) = queue;
    let mut driven = Vec::new();
    let mut bound = Vec::new();
    for (device, element, silence, table) in &f.bindings {
        let slot = devices
            .get(device)
            .cloned()
            .ok_or_else(|| RuntimeError::UnknownDevice(device.clone()))?;
        driven.push(Driven {
            route: router::Route::bind(table.clone().unwrap_or_else(|| slot.table.clone()), slot.table.clone()),
            silence: *silence,
        });
        bound.push(Device {
            element: *element,
            state_rx: slot.device.state(),
            tapped: f.publishes && slot.device.state_taps().is_some(),
            pending_safe: None,
            slot,
        });
    }
    // Decided once: the devices' states drive the periodic publish when every one tells its
    // states and measures at least as fast as the front publishes.
    let by_device = !bound.is_empty()
        && bound
            .iter()
            .all(|d| d.tapped && d.slot.plan.rate_hz >= f.state_hz * 0.99);
    let devices_list = f.bindings.iter().map(|b| b.0.as_str()).collect::<Vec<_>>().join(",");
    let span = tracing::info_span!("front", name = %f.name, devices = %devices_list);
    let lf_hz = out.lf_hz();
    let period = Duration::from_secs_f64(1.0 / f.state_hz.max(0.1));
    let live = Arc::new(Live {
        state: Mutex::new(Task {
            core: FrontCore::new(f.id, f.control, f.hold, driven).with_max_command_age(f.max_command_age),
            name: f.name,
            devices: bound,
            out,
            discovery,
            grid: StateGrid::new(period, by_device, Instant::now()),
            acts: Vec::new(),
            allow: f.allow.map(|s| (s, HashMap::new())),
            // Until the task found its queue empty (samples queued before the listeners
            // took over go first).
            deferring: true,
            tally: f.tally,
        }),
        wake: tokio::sync::Notify::new(),
        queue: tx,
        dropped,
        rt: tokio::runtime::Handle::current(),
        span: span.clone(),
    });
    // Each tapped device tells the front its states (held weakly: a stopped front is not kept
    // alive by its devices).
    let untapped: Vec<(usize, watch::Receiver<HandState>)> = {
        let t = live.lock();
        for (i, d) in t.devices.iter().enumerate() {
            if let (true, Some(taps)) = (d.tapped, d.slot.device.state_taps()) {
                let weak = Arc::downgrade(&live);
                taps.add(Box::new(move |st: &HandState| {
                    if let Some(live) = weak.upgrade() {
                        live.device_state(i, st);
                    }
                }));
            }
        }
        t.devices
            .iter()
            .enumerate()
            .filter(|(_, d)| !d.tapped)
            .map(|(i, d)| (i, d.state_rx.clone()))
            .collect()
    };
    let task_live = live.clone();
    let handle = tokio::spawn(tracing::Instrument::instrument(
        async move {
            let live = task_live;
            let mut untapped = untapped;
            let mut lf_tick = Ticker::hz(lf_hz);
            // Which untapped devices the core awaits, refilled on each wake.
            let mut awaiting: Vec<bool> = Vec::with_capacity(untapped.len());
            loop {
                let deadline = {
                    let mut t = live.lock();
                    if t.deferring && rx.is_empty() {
                        t.deferring = false;
                    }
                    awaiting.clear();
                    awaiting.extend(untapped.iter().map(|(i, _)| t.core.awaiting(*i)));
                    t.wake_at().map_or(t.grid.deadline(), |c| c.min(t.grid.deadline()))
                };
                let any_awaited = awaiting.iter().any(|a| *a);
                tokio::select! {
                    msg = rx.recv() => {
                        let Some(msg) = msg else { break };
                        // A silence action still running: the command waits for it (outside
                        // the lock), and so does every sample behind it.
                        let running: Vec<watch::Receiver<bool>> = {
                            let mut t = live.lock();
                            t.deferring = true;
                            t.devices.iter().filter(|d| d.safe_running()).filter_map(|d| d.pending_safe.clone()).collect()
                        };
                        for mut done in running {
                            let _ = done.wait_for(|d| *d).await;
                        }
                        let mut t = live.lock();
                        t.sample(&live, msg);
                        if rx.is_empty() {
                            t.deferring = false;
                        }
                    }
                    _ = tokio::time::sleep_until(deadline.into()) => {
                        let now = Instant::now();
                        let mut t = live.lock();
                        let t = &mut *t;
                        t.core.deadline(now, &mut Shared(&t.devices), &mut t.acts);
                        if t.grid.due(now) {
                            t.publish_periodic(now, None, live.dropped.load(Ordering::Relaxed));
                        }
                        t.carry_out(&live, None);
                    }
                    _ = live.wake.notified() => {}
                    changed = first_change(&mut untapped, &awaiting), if any_awaited => {
                        let mut guard = live.lock();
                        let t = &mut *guard;
                        match changed {
                            Some(i) => {
                                let cmd_seq = untapped[i].1.borrow_and_update().cmd_seq;
                                let device = untapped[i].0;
                                t.core.state(Instant::now(), device, cmd_seq, &mut t.acts);
                                t.carry_out(&live, None);
                            }
                            None => t.core.state_closed(),
                        }
                    }
                    _ = lf_tick.tick(), if lf_hz > 0.0 => {
                        live.lock().publish(None, true);
                    }
                    _ = shutdown.changed() => break,
                }
            }
            // The front's readers are deleted here, on its task, outside the lock: never in one
            // of their own listeners (which may hold the last reference to `live`), and never
            // while a listener waits for the lock.
            let endpoints = std::mem::replace(&mut live.lock().out, Box::new(Closed));
            drop(endpoints);
        },
        span,
    ));
    Ok((live, handle))
}

/// A stopped front's wire side: no reader, no writer.
struct Closed;

impl fronts::FrontIo for Closed {
    fn decode(
        &self,
        _bound: &[fronts::Bound<'_>],
        _msg: &fronts::Message,
    ) -> Result<Vec<(usize, fronts::Routed)>, handgate_adapters::front::Rejection> {
        Ok(Vec::new())
    }
    fn publish(&mut self, _bound: &[fronts::Bound<'_>], _lf: bool) {}
}

/// Waits until one of the untapped devices whose state the core awaits (`awaiting`, in
/// `devices`' order) reports a new state: its index in `devices`; `None` when a device's
/// state channel closed.
async fn first_change(devices: &mut [(usize, watch::Receiver<HandState>)], awaiting: &[bool]) -> Option<usize> {
    let futs = devices
        .iter_mut()
        .enumerate()
        .filter(|(i, _)| awaiting[*i])
        .map(|(i, (_, rx))| Box::pin(async move { rx.changed().await.ok().map(|_| i) }));
    futures_select_first(futs.collect()).await
}

/// The output of whichever future finishes first.
async fn futures_select_first<F: std::future::Future<Output = Option<usize>> + Unpin>(
    mut futs: Vec<F>,
) -> Option<usize> {
    std::future::poll_fn(move |cx| {
        for f in futs.iter_mut() {
            if let std::task::Poll::Ready(v) = std::future::Future::poll(std::pin::Pin::new(f), cx) {
                return std::task::Poll::Ready(v);
            }
        }
        std::task::Poll::Pending
    })
    .await
}

/// Runs `f` over what the front kind's codec sees of the bound devices: each route and latest
/// state (`given`: the state a device loop is telling, for that device; the others' borrowed
/// from their channels for the call). Up to four devices, the views are on the stack: a
/// publish from a device's loop thread, or a decode in a reader's listener, allocates nothing
/// for them.
fn with_views<R>(
    core: &FrontCore,
    devices: &[Device],
    given: Option<(usize, &HandState)>,
    f: impl FnOnce(&[fronts::Bound<'_>]) -> R,
) -> R {
    match devices.len() {
        1 => with_views_n::<1, R>(core, devices, given, f),
        2 => with_views_n::<2, R>(core, devices, given, f),
        3 => with_views_n::<3, R>(core, devices, given, f),
        4 => with_views_n::<4, R>(core, devices, given, f),
        n => {
            let states: Vec<_> = (0..n).map(|i| borrowed(devices, given, i)).collect();
            let bound: Vec<_> = (0..n).map(|i| view(core, devices, &states, given, i)).collect();
            f(&bound)
        }
    }
}

/// [`with_views`] for exactly `N` devices.
fn with_views_n<const N: usize, R>(
    core: &FrontCore,
    devices: &[Device],
    given: Option<(usize, &HandState)>,
    f: impl FnOnce(&[fronts::Bound<'_>]) -> R,
) -> R {
    let states: [Option<watch::Ref<'_, HandState>>; N] = std::array::from_fn(|i| borrowed(devices, given, i));
    let bound: [fronts::Bound<'_>; N] = std::array::from_fn(|i| view(core, devices, &states, given, i));
    f(&bound)
}

/// Device `i`'s state, borrowed from its channel unless it is the `given` one.
fn borrowed<'a>(
    devices: &'a [Device],
    given: Option<(usize, &HandState)>,
    i: usize,
) -> Option<watch::Ref<'a, HandState>> {
    (given.map(|(g, _)| g) != Some(i)).then(|| devices[i].state_rx.borrow())
}

/// What the codec sees of device `i`.
fn view<'a>(
    core: &'a FrontCore,
    devices: &'a [Device],
    states: &'a [Option<watch::Ref<'a, HandState>>],
    given: Option<(usize, &'a HandState)>,
    i: usize,
) -> fronts::Bound<'a> {
    let d = &devices[i];
    fronts::Bound {
        route: core.route(i),
        element: d.element,
        device: &d.slot.plan.name,
        safe_action: d.slot.plan.safe_action,
        state: match (&states[i], given) {
            (Some(r), _) => r,
            (None, Some((_, st))) => st,
            (None, None) => unreachable!("a device's state is borrowed or given"),
        },
    }
}
