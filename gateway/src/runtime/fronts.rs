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
    self as front_core, Action, Change, Counter, Driven, FrontCore, FrontId, Log, Sample,
};
use handgate_adapters::model::HandState;
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

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
    shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let (tx, rx) = mpsc::channel::<fronts::Incoming>(64);
    let dropped = Arc::new(AtomicU64::new(0));
    // The front kind's endpoints (readers and writers).
    let out = match fronts::open(env, f, tx, dropped.clone())? {
        fronts::Endpoints::Commands(out) => out,
        fronts::Endpoints::StateOnly(out) => return spawn_state_only(out, f, devices, shutdown),
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
    };
    run_front(task, out, rx, dropped, devices, env.discovery.clone(), shutdown)
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
}

/// One device a front task drives: what the core does not decide with (its slot, its
/// element in the front's messages, its state channel) and its silence action in progress.
struct Device {
    slot: Arc<DeviceSlot>,
    element: usize,
    state_rx: watch::Receiver<HandState>,
    /// The silence action, running in its own task.
    pending_safe: Option<tokio::task::JoinHandle<()>>,
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

/// A running front's task: its core (every decision), its devices, its wire side and its
/// publishing grid.
struct Task {
    name: String,
    core: FrontCore,
    devices: Vec<Device>,
    out: Box<dyn fronts::FrontIo>,
    discovery: watch::Receiver<Arc<handgate_adapters::discovery::Snapshot>>,
    state_tick: Ticker,
    /// The core's actions, carried out as they come (kept to reuse its allocation).
    acts: Vec<Action>,
    /// `export.allow_commands_from`, and each writer's verdict once discovery knew its
    /// participant (at most [`MAX_JUDGED`] writers, then all are judged again).
    allow: Option<(Sources, HashMap<WriterHandle, bool>)>,
}

/// Writers whose source verdict a front keeps.
const MAX_JUDGED: usize = 64;

impl Task {
    /// A command sample: the core admits it, the front kind's codec decodes it, and the core
    /// checks and routes its commands. A command for a device waits for the silence action
    /// running on it (`pending_safe`), so the safe state never lands after a newer command.
    async fn sample(&mut self, msg: fronts::Incoming) {
        match self.source_allowed(&msg.writer) {
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
            self.carry_out();
            return;
        };
        let decoded = self.out.decode(&views(&self.core, &self.devices), &msg.msg);
        if let Ok(cmds) = &decoded {
            for (i, _) in cmds {
                if let Some(h) = self.devices[*i].pending_safe.take() {
                    let _ = h.await;
                }
            }
        }
        let devices = &mut Shared(&self.devices);
        self.core
            .decoded(admitted, Instant::now(), &sample, decoded, devices, &mut self.acts);
        self.carry_out();
    }

    /// Whether `writer`'s host may command this front (`export.allow_commands_from`): checked
    /// at the edge, before the core sees the sample, so a refused host neither commands nor
    /// takes the front over. A writer's verdict is kept once discovery knows its participant;
    /// until then (`None`) its commands are refused (fail closed) and it is asked again.
    /// Logged once per writer.
    fn source_allowed(&mut self, writer: &handgate_adapters::dds::WriterInfo) -> Option<bool> {
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

    /// Carries out the core's actions, in order.
    fn carry_out(&mut self) {
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
                    self.out.publish(&views(&self.core, &self.devices), false);
                    self.state_tick.restart();
                }
                Action::Safe { device, action } => {
                    // In a task of its own: the front keeps publishing on its deadlines while
                    // the device confirms its safe state.
                    let dev = self.devices[device].slot.device.clone();
                    self.devices[device].pending_safe = Some(tokio::spawn(async move {
                        let _ = dev.safe_state(action).await;
                    }));
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
                Action::Log(l) => self.log(l),
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

/// Runs a front taking commands: samples from `rx` (a DDS front's readers, or the
/// dashboard's page), decoded by `out`; every decision (ownership, the check against each
/// device's table, silence, prompt state) is the front's core's
/// ([`handgate_adapters::front::core`]); this task moves messages: samples, deadlines and
/// device states to the core, its actions to the devices, the log and `out`.
pub(crate) fn run_front(
    f: FrontTask,
    out: Box<dyn fronts::FrontIo>,
    mut rx: mpsc::Receiver<fronts::Incoming>,
    dropped: Arc<AtomicU64>,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    discovery: watch::Receiver<Arc<handgate_adapters::discovery::Snapshot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
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
            pending_safe: None,
            slot,
        });
    }
    let devices_list = f.bindings.iter().map(|b| b.0.as_str()).collect::<Vec<_>>().join(",");
    let span = tracing::info_span!("front", name = %f.name, devices = %devices_list);
    let lf_hz = out.lf_hz();
    let mut task = Task {
        core: FrontCore::new(f.id, f.control, f.hold, driven).with_max_command_age(f.max_command_age),
        name: f.name,
        devices: bound,
        out,
        discovery,
        state_tick: Ticker::hz(f.state_hz),
        acts: Vec::new(),
        allow: f.allow.map(|s| (s, HashMap::new())),
    };
    Ok(tokio::spawn(tracing::Instrument::instrument(
        async move {
            let mut lf_tick = Ticker::hz(lf_hz);
            loop {
                let deadline = task.core.next_deadline();
                let awaiting = task.core.awaits_state();
                tokio::select! {
                    msg = rx.recv() => {
                        let Some(msg) = msg else { break };
                        task.sample(msg).await;
                    }
                    _ = sleep_until_opt(deadline), if deadline.is_some() => {
                        task.core.deadline(Instant::now(), &mut Shared(&task.devices), &mut task.acts);
                        task.carry_out();
                    }
                    changed = first_change(&mut task.devices, &task.core), if awaiting => {
                        match changed {
                            Some(i) => {
                                let cmd_seq = task.devices[i].state_rx.borrow_and_update().cmd_seq;
                                task.core.state(Instant::now(), i, cmd_seq, &mut task.acts);
                                task.carry_out();
                            }
                            None => task.core.state_closed(),
                        }
                    }
                    _ = task.state_tick.tick() => {
                        task.out.publish(&views(&task.core, &task.devices), false);
                        for (i, d) in task.devices.iter().enumerate() {
                            task.core.published(i, d.state_rx.borrow().cmd_seq);
                        }
                        task.core.queue(Instant::now(), dropped.load(Ordering::Relaxed), &mut task.acts);
                        task.carry_out();
                    }
                    _ = lf_tick.tick(), if lf_hz > 0.0 => {
                        task.out.publish(&views(&task.core, &task.devices), true);
                    }
                    _ = shutdown.changed() => break,
                }
            }
        },
        span,
    )))
}

async fn sleep_until_opt(t: Option<Instant>) {
    if let Some(t) = t {
        tokio::time::sleep_until(t.into()).await;
    }
}

/// Waits until one of the bound devices whose state the core awaits reports a new state;
/// `None` when a device's state channel closed.
async fn first_change(devices: &mut [Device], core: &FrontCore) -> Option<usize> {
    let futs = devices
        .iter_mut()
        .enumerate()
        .filter(|(i, _)| core.awaiting(*i))
        .map(|(i, d)| Box::pin(async move { d.state_rx.changed().await.ok().map(|_| i) }));
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

/// What the front kind's codec sees of the bound devices: each route and latest state.
fn views<'a>(core: &'a FrontCore, devices: &'a [Device]) -> Vec<fronts::Bound<'a>> {
    devices
        .iter()
        .enumerate()
        .map(|(i, d)| fronts::Bound {
            route: core.route(i),
            element: d.element,
            device: &d.slot.plan.name,
            safe_action: d.slot.plan.safe_action,
            state: d.slot.device.state().borrow().clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The deadline branch of the front task sleeps until the core's next deadline (it
    /// would spin the task otherwise: the action itself is guarded per device).
    #[test]
    fn the_silence_wait_sleeps_until_the_deadline() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .unwrap();
        rt.block_on(async {
            let t0 = Instant::now();
            sleep_until_opt(Some(t0 + Duration::from_millis(50))).await;
            assert!(t0.elapsed() >= Duration::from_millis(50), "{:?}", t0.elapsed());
        });
    }
}
