//! Front tasks: each front's endpoints, decoding, silence handling and state publishing.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::model::{HandState, SafeAction};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

use super::control::{Admit, Change, Ownership};
use super::{DeviceSlot, RuntimeError};
use crate::plan::{FrontPlan, SilencePlan};
use crate::ticker::Ticker;
use handgate_adapters::front::serve as fronts;
use handgate_adapters::route as router;

/// Logs at most once per second per key (rejected commands here, refused requests in
/// `crate::http`).
#[derive(Debug, Default)]
pub(crate) struct RateLimitedLog {
    /// Per key: when one was last logged (`None`: never), and the events since.
    last: Mutex<HashMap<&'static str, (Option<Instant>, u64)>>,
}

impl RateLimitedLog {
    fn warn(&self, front: &str, key: &'static str, msg: &dyn std::fmt::Display) {
        if let Some(suppressed) = self.admit(key, Instant::now()) {
            warn!(front, reason = key, suppressed, "rejected command: {msg}");
        }
    }

    /// Whether an event of `key` at `now` is logged: `Some(n)`, the number of events of `key`
    /// suppressed since the last one logged, when a second has passed since then (or none was
    /// logged yet); `None` otherwise.
    pub(crate) fn admit(&self, key: &'static str, now: Instant) -> Option<u64> {
        let mut g = self.last.lock().unwrap_or_else(|p| p.into_inner());
        // Never `now - 2 s`: an Instant is time since boot, and a gateway started in its first
        // seconds (a systemd unit at boot) would panic on the subtraction.
        let e = g.entry(key).or_insert((None, 0));
        e.1 += 1;
        if e.0.map_or(true, |t| now.duration_since(t) >= Duration::from_secs(1)) {
            let suppressed = e.1 - 1;
            *e = (Some(now), 0);
            Some(suppressed)
        } else {
            None
        }
    }
}

/// Identifies the front that sent a device its last command (see [`super::FrontCounters::last_front`]).
static NEXT_FRONT_ID: AtomicU64 = AtomicU64::new(1);

/// A new front id (see [`super::FrontCounters::last_front`]).
pub(crate) fn next_front_id() -> u64 {
    NEXT_FRONT_ID.fetch_add(1, Ordering::Relaxed)
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

/// One device a front drives, with the front's view of its silence.
struct Bound {
    slot: Arc<DeviceSlot>,
    /// The front's table for this device (its wire convention and side).
    /// The front's table and the device's, paired once at bind time.
    route: router::Route,
    element: usize,
    silence: SilencePlan,
    seq: u64,
    /// When this front last had a command for the device accepted.
    last_valid: Option<Instant>,
    /// The silence action the last accepted command armed (timeout, action).
    armed: Option<(Duration, SafeAction)>,
    /// The silence action has run since the last accepted command.
    acted: bool,
    /// Which state this front publishes at once (the prompt publish).
    prompt: Prompt,
    state_rx: watch::Receiver<HandState>,
    /// The silence action, running in its own task.
    pending_safe: Option<tokio::task::JoinHandle<()>>,
}

/// The prompt publish of one bound device: the state reflecting an accepted command goes out
/// at once, not at the next state deadline.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Prompt {
    /// The state reflecting this accepted command (`cmd_seq`) is awaited.
    awaiting: Option<u64>,
    /// `cmd_seq` of the newest state seen while awaiting, and of the newest one published.
    /// A client streaming faster than the device applies never sees a state of its newest
    /// command; a state reflecting a newer command than the last published goes out at once.
    reflected: u64,
    published: u64,
}

impl Prompt {
    /// A state of the device reflecting command `cmd_seq` came: what was awaited has arrived
    /// once a state reflects it or a newer command.
    fn reflect(&mut self, cmd_seq: u64) {
        if self.awaiting.is_some_and(|a| cmd_seq >= a) {
            self.awaiting = None;
        }
        self.reflected = cmd_seq;
    }

    /// This device lets the front publish at once: nothing awaited, or its newest state
    /// reflects a newer command than the last one published.
    fn ready(&self) -> bool {
        self.awaiting.is_none() || self.reflected > self.published
    }

    /// The front published the newest state seen.
    fn mark_published(&mut self) {
        self.published = self.published.max(self.reflected);
    }
}

impl Bound {
    fn silence_due(&self) -> Option<Instant> {
        match (self.last_valid, self.armed, self.acted) {
            (Some(t), Some((after, _)), false) => Some(t + after),
            _ => None,
        }
    }
}

pub(super) fn spawn_front(
    env: &fronts::FrontEnv,
    f: &FrontPlan,
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
        id: next_front_id(),
        name: f.name.clone(),
        control: f.config.control,
        hold: f.hold(),
        state_hz: f.state_hz,
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
    /// Its id ([`next_front_id`]).
    pub id: u64,
    pub name: String,
    pub control: handgate_adapters::front::config::Control,
    pub hold: Duration,
    pub state_hz: f64,
    pub bindings: Vec<(
        String,
        usize,
        SilencePlan,
        Option<Arc<handgate_adapters::mapping::DeviceTable>>,
    )>,
}

/// Runs a front taking commands: samples from `rx` (a DDS front's readers, or the
/// dashboard's page), decoded by `out` and checked against each device's table, under the
/// front's ownership and silence rules; state published through `out`.
pub(crate) fn run_front(
    f: FrontTask,
    mut out: Box<dyn fronts::FrontIo>,
    mut rx: mpsc::Receiver<fronts::Incoming>,
    dropped: Arc<AtomicU64>,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    discovery: watch::Receiver<Arc<handgate_adapters::discovery::Snapshot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let mut bound = Vec::new();
    for (device, element, silence, table) in &f.bindings {
        let slot = devices
            .get(device)
            .cloned()
            .ok_or_else(|| RuntimeError::UnknownDevice(device.clone()))?;
        bound.push(Bound {
            route: router::Route::bind(table.clone().unwrap_or_else(|| slot.table.clone()), slot.table.clone()),
            element: *element,
            silence: *silence,
            seq: 0,
            last_valid: None,
            armed: None,
            acted: false,
            prompt: Prompt::default(),
            state_rx: slot.device.state(),
            pending_safe: None,
            slot,
        });
    }
    let log = RateLimitedLog::default();
    let mut ownership = Ownership::new(f.control, f.hold);
    let front_id = f.id;
    let devices_list = f.bindings.iter().map(|b| b.0.as_str()).collect::<Vec<_>>().join(",");
    let span = tracing::info_span!("front", name = %f.name, devices = %devices_list);
    Ok(tokio::spawn(tracing::Instrument::instrument(
        async move {
            let name = f.name.clone();
            let mut state_tick = Ticker::hz(f.state_hz);
            let lf_hz = out.lf_hz();
            let mut lf_tick = Ticker::hz(lf_hz);
            // Commands dropped because this front's queue was full (reported at most once a
            // second, with the running total, so a flood's losses are visible).
            // (dropped count last reported, when; `None`: never reported)
            let mut dropped_reported: (u64, Option<Instant>) = (0, None);
            // Prompt state: after a command is accepted, the first state that reflects it on
            // every device it went to (`cmd_seq`) is published at once instead of at the next
            // deadline; so is a state reflecting a newer command than the last published
            // (a client streaming faster than the device applies never sees its newest
            // command reflected, and would otherwise wait for every tick). A prompt publish
            // stands in for the periodic one: the next tick comes a full period after it.
            // Each prompt publish needs a state of a command not yet published, so they are
            // never more frequent than the device's measured states; an idle front publishes
            // at `state_hz`.
            let mut prompt_since: Option<Instant> = None;
            // The writer owning the front (`control = "exclusive"`), to name it in the log.
            let mut owner: Option<Arc<handgate_adapters::dds::WriterInfo>> = None;
            let hold_ms = f.hold.as_millis() as u64;
            loop {
                let silence_due = bound.iter().filter_map(Bound::silence_due).min();
                let awaiting = bound.iter().any(|b| b.prompt.awaiting.is_some());
                tokio::select! {
                    msg = rx.recv() => {
                        let Some(msg) = msg else { break };
                        // When the reader took it, not now: a front task that fell behind
                        // must not see its owner as silent because of its own backlog.
                        let received = msg.taken;
                        let writer = msg.writer.handle;
                        if let Admit::Foreign { first, .. } = ownership.admit(writer, msg.force(), received) {
                            for b in &bound {
                                b.slot.counters.foreign_cmd.fetch_add(1, Ordering::Relaxed);
                            }
                            if first {
                                let snap = discovery.borrow().clone();
                                let owner = owner.as_ref().map_or("?".into(), |o| fronts::describe_writer(o, &snap));
                                warn!(front = %name, hold_ms, "refused the commands of {}: {owner} commands this front \
                                    (control = \"exclusive\"; refused until it is silent for {hold_ms} ms; counted in foreign_cmd)",
                                    fronts::describe_writer(&msg.writer, &snap));
                            }
                            continue;
                        }
                        let decoded = out.decode(&views(&bound), &msg.msg);
                        match decoded {
                            Ok(cmds) => {
                                let mut any = false;
                                // Devices this front now commands (another front did before).
                                let mut new_commander: Vec<usize> = Vec::new();
                                for (i, (body, tag, timeout_bit)) in cmds {
                                    let b = &mut bound[i];
                                    if let Some(h) = b.pending_safe.take() {
                                        let _ = h.await;
                                    }
                                    b.seq += 1;
                                    // Checked once, here, against the device's table; the
                                    // device takes the checked body as it is.
                                    let sent = b
                                        .route
                                        .device
                                        .checked(body)
                                        .map_err(handgate_adapters::device::DeviceError::from)
                                        .and_then(|body| b.slot.device.command_checked(b.seq, body, tag));
                                    match sent {
                                        Ok(()) => {
                                            any = true;
                                            let counters = &b.slot.counters;
                                            counters.accepted.fetch_add(1, Ordering::Relaxed);
                                            counters.mark_accepted();
                                            if counters.last_front.swap(front_id, Ordering::Relaxed) != front_id {
                                                new_commander.push(i);
                                            }
                                            b.last_valid = Some(Instant::now());
                                            b.armed = b.silence.armed(timeout_bit);
                                            // No `mark_unchanged` here: a state that came just before
                                            // this command still reflects a newer command than the
                                            // last published (`Prompt::ready`), and dropping it would
                                            // hold it until the tick (a 1 kHz client lost one in two).
                                            b.prompt.awaiting = Some(b.seq);
                                            if counters.tripped.swap(0, Ordering::Relaxed) != 0 {
                                                info!(front = %name, device = %b.slot.plan.name, "commands resumed after the silence action");
                                            }
                                            b.acted = false;
                                        }
                                        Err(e) => {
                                            b.slot.counters.rejected.fetch_add(1, Ordering::Relaxed);
                                            log.warn(&name, "device_rejected", &e);
                                        }
                                    }
                                }
                                if any {
                                    prompt_since = Some(Instant::now());
                                    if let Some(change) = ownership.accepted(writer, received) {
                                        let snap = discovery.borrow().clone();
                                        let new = fronts::describe_writer(&msg.writer, &snap);
                                        let old = owner.as_ref().map_or("?".into(), |o| fronts::describe_writer(o, &snap));
                                        match change {
                                            Change::First => info!(front = %name, "{new} commands this front"),
                                            Change::AfterSilence { silent, .. } => info!(front = %name,
                                                silent_ms = silent.as_millis() as u64,
                                                "{new} commands this front: {old} was silent for {} ms", silent.as_millis()),
                                            Change::Forced => warn!(front = %name,
                                                "{new} took this front over from {old} (forced)"),
                                        }
                                        owner = Some(msg.writer.clone());
                                        new_commander = (0..bound.len()).collect();
                                    }
                                    if !new_commander.is_empty() {
                                        // Who commands the device (status, dashboard): named on change only.
                                        let who = format!("{name}: {}", fronts::describe_writer(&msg.writer, &discovery.borrow()));
                                        for i in new_commander {
                                            bound[i].slot.counters.set_owner(who.clone());
                                        }
                                    }
                                }
                            }
                            Err(r) => {
                                for b in &bound {
                                    b.slot.counters.rejected.fetch_add(1, Ordering::Relaxed);
                                }
                                log.warn(&name, r.reason(), &r);
                            }
                        }
                    }
                    _ = sleep_until_opt(silence_due), if silence_due.is_some() => {
                        let now = Instant::now();
                        for b in bound.iter_mut() {
                            if !b.silence_due().is_some_and(|t| t <= now) {
                                continue;
                            }
                            b.acted = true;
                            let (after, action) = b.armed.expect("armed when due");
                            let counters = &b.slot.counters;
                            // Another front commanded the device since: its silence, not ours.
                            if counters.last_front.load(Ordering::Relaxed) != front_id {
                                continue;
                            }
                            counters.watchdog_trips.fetch_add(1, Ordering::Relaxed);
                            counters.tripped.store(1, Ordering::Relaxed);
                            warn!(front = %name, device = %b.slot.plan.name, silence = %b.silence.mode,
                                timeout_ms = after.as_millis() as u64, action = ?action,
                                "no command: moving the device to its silence action");
                            // In a task of its own: the front keeps publishing on its
                            // deadlines while the device confirms its safe state.
                            // A command for the device waits for it (`pending_safe`), so the
                            // safe state never lands after a newer command.
                            let dev = b.slot.device.clone();
                            b.pending_safe = Some(tokio::spawn(async move {
                                let _ = dev.safe_state(action).await;
                            }));
                        }
                    }
                    changed = first_change(&mut bound), if awaiting => {
                        let Some(i) = changed else {
                            for b in bound.iter_mut() { b.prompt.awaiting = None; }
                            continue;
                        };
                        let b = &mut bound[i];
                        let st = b.state_rx.borrow_and_update().clone();
                        b.prompt.reflect(st.cmd_seq);
                        let expired = prompt_since.is_some_and(|t| t.elapsed() > PROMPT_STATE_WAIT);
                        if expired {
                            // Superseded by another front's command, or never applied.
                            for b in bound.iter_mut() { b.prompt.awaiting = None; }
                        } else if bound.iter().all(|b| b.prompt.ready()) {
                            out.publish(&views(&bound), false);
                            for b in bound.iter_mut() { b.prompt.mark_published(); }
                            state_tick.restart();
                        }
                    }
                    _ = state_tick.tick() => {
                        out.publish(&views(&bound), false);
                        for b in bound.iter_mut() { b.prompt.published = b.state_rx.borrow().cmd_seq; }
                        let d = dropped.load(Ordering::Relaxed);
                        if d > dropped_reported.0
                            && dropped_reported.1.map_or(true, |t| t.elapsed() >= Duration::from_secs(1))
                        {
                            warn!(front = %name, dropped = d - dropped_reported.0,
                                queue_full_total = d, "front queue full: commands dropped unprocessed");
                            dropped_reported = (d, Some(Instant::now()));
                        }
                    }
                    _ = lf_tick.tick(), if lf_hz > 0.0 => {
                        out.publish(&views(&bound), true);
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

/// Waits until one of the bound devices awaiting a prompt publish reports a new state;
/// `None` when a device's state channel closed.
async fn first_change(bound: &mut [Bound]) -> Option<usize> {
    let futs = bound
        .iter_mut()
        .enumerate()
        .filter(|(_, b)| b.prompt.awaiting.is_some())
        .map(|(i, b)| Box::pin(async move { b.state_rx.changed().await.ok().map(|_| i) }));
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

/// How long a front waits for the state reflecting an accepted command before it stops
/// listening for it (the periodic state carries on regardless).
const PROMPT_STATE_WAIT: Duration = Duration::from_millis(100);

/// What the front kind's codec sees of the bound devices: each route and latest state.
fn views(bound: &[Bound]) -> Vec<fronts::Bound<'_>> {
    bound
        .iter()
        .map(|b| fronts::Bound {
            route: &b.route,
            element: b.element,
            device: &b.slot.plan.name,
            safe_action: b.slot.plan.safe_action,
            state: b.slot.device.state().borrow().clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejections_are_logged_once_per_second_per_reason_with_the_suppressed_count() {
        let log = RateLimitedLog::default();
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        assert_eq!(log.admit("non_finite", t0), Some(0), "the first one is logged");
        assert_eq!(log.admit("non_finite", ms(10)), None);
        assert_eq!(log.admit("non_finite", ms(999)), None);
        assert_eq!(
            log.admit("wrong_count", ms(500)),
            Some(0),
            "each reason has its own second"
        );
        assert_eq!(
            log.admit("non_finite", ms(1000)),
            Some(2),
            "a second later, with the two suppressed"
        );
        assert_eq!(log.admit("non_finite", ms(1500)), None);
        assert_eq!(log.admit("non_finite", ms(2100)), Some(1));
    }

    /// The prompt-publish rule on its own: a client streaming faster than the device applies
    /// (each state reflects an older command than the newest accepted) still gets each newer
    /// reflected command published at once, never the same one twice.
    #[test]
    fn a_state_of_a_newer_command_than_published_is_prompt_even_while_a_newer_one_is_awaited() {
        let mut p = Prompt::default();
        assert!(p.ready(), "nothing awaited");
        // A 1 kHz client: command 7 accepted while the device's states reflect older ones.
        p.awaiting = Some(7);
        p.reflect(5);
        assert!(p.ready(), "reflects 5, newer than the last published (0): at once");
        p.mark_published();
        assert!(!p.ready(), "5 is out: the same state again waits");
        p.reflect(5);
        assert!(!p.ready(), "still 5: waits for the tick");
        p.reflect(6);
        assert!(p.ready(), "6 is newer than 5");
        assert_eq!(p.awaiting, Some(7), "6 does not answer 7");
        p.mark_published();
        p.reflect(8);
        assert_eq!(
            p.awaiting, None,
            "a state of a newer command answers the awaited one too"
        );
        assert!(p.ready());
        // Awaiting 9 with nothing newer than published: not ready.
        p.mark_published();
        p.awaiting = Some(9);
        assert!(!p.ready());
        p.reflect(9);
        assert!(p.ready() && p.awaiting.is_none(), "the awaited command's own state");
    }

    /// The silence branch of the front task sleeps until the earliest device's deadline (it
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
