//! Front tasks: each front's endpoints, decoding, silence handling and state publishing.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::dds::{DdsError, Node, Qos};
use handgate_adapters::dex1::adapter::Variant;
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::model::{HandCommand, HandState, SafeAction, Side};
use handgate_idl::handgate as hgmsg;
use handgate_idl::{ros2, unitree_go, unitree_hg};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

use super::{DeviceSlot, RuntimeError};
use crate::fronts::{self, FrontCommand, Rejection};
use crate::plan::{FrontKind, FrontPlan, SilencePlan};
use crate::router;
use crate::ticker::Ticker;

/// Logs at most once per second per key.
#[derive(Debug, Default)]
struct RateLimitedLog {
    last: Mutex<HashMap<&'static str, (Instant, u64)>>,
}

impl RateLimitedLog {
    fn warn(&self, front: &str, key: &'static str, msg: &dyn std::fmt::Display) {
        let mut g = self.last.lock().unwrap_or_else(|p| p.into_inner());
        let now = Instant::now();
        let e = g.entry(key).or_insert((now - Duration::from_secs(2), 0));
        e.1 += 1;
        if now.duration_since(e.0) >= Duration::from_secs(1) {
            warn!(front, reason = key, suppressed = e.1 - 1, "rejected command: {msg}");
            *e = (now, 0);
        }
    }
}

/// What a front's reader hands its task.
enum Incoming {
    Dex3(unitree_hg::HandCmd_),
    Dex1Go(unitree_go::MotorCmds_),
    Dex1Hg(unitree_hg::HandCmd_),
    Canonical(hgmsg::HandCmd_),
}

fn forward<T: Clone + handgate_idl::TopicType + 'static>(
    node: &Node,
    topic: &str,
    tx: mpsc::Sender<Incoming>,
    wrap: fn(T) -> Incoming,
    dropped: Arc<AtomicU64>,
) -> Result<handgate_adapters::dds::Reader<T>, DdsError> {
    node.reader_with_callback::<T, _>(topic, Qos::Reliable { depth: 16 }, move |h| {
        let mut v = Vec::new();
        h.take_into(&mut v);
        for s in v {
            if tx.try_send(wrap(s)).is_err() {
                dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    })
}

/// Identifies the front that sent a device its last command (see [`FrontCounters::last_front`]).
static NEXT_FRONT_ID: AtomicU64 = AtomicU64::new(1);

fn spawn_joint_state(
    node: &Node,
    f: &FrontPlan,
    names: &[String],
    urdf: bool,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let slots: Vec<Arc<DeviceSlot>> = names
        .iter()
        .map(|n| {
            devices
                .get(n)
                .cloned()
                .ok_or_else(|| RuntimeError::UnknownDevice(n.clone()))
        })
        .collect::<Result<_, _>>()?;
    let mut writer = node.writer::<ros2::JointState_>(&f.state_topic, Qos::BestEffort)?;
    let mut tick = Ticker::hz(f.state_hz);
    Ok(tokio::spawn(async move {
        loop {
            tokio::select! {
                _ = tick.tick() => {
                    let mut msg = fronts::joint_state::header(std::time::SystemTime::now(), "");
                    for s in &slots {
                        let st = s.device.state().borrow().clone();
                        fronts::joint_state::append(&mut msg, &s.table, &st, urdf, &format!("{}/", s.plan.name));
                    }
                    let _ = writer.write(msg);
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
    /// The state reflecting this accepted command (`cmd_seq`) is awaited for a prompt publish.
    awaiting: Option<u64>,
    state_rx: watch::Receiver<HandState>,
    /// The silence action, running in its own task.
    pending_safe: Option<tokio::task::JoinHandle<()>>,
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
    node: &Node,
    f: &FrontPlan,
    devices: &HashMap<String, Arc<DeviceSlot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    if let FrontKind::JointState {
        devices: names,
        urdf_names,
    } = &f.kind
    {
        return spawn_joint_state(node, f, names, *urdf_names, devices, shutdown);
    }
    let mut bound = Vec::new();
    for b in &f.bindings {
        let slot = devices
            .get(&b.device)
            .cloned()
            .ok_or_else(|| RuntimeError::UnknownDevice(b.device.clone()))?;
        bound.push(Bound {
            route: router::Route::bind(
                b.table.clone().unwrap_or_else(|| slot.table.clone()),
                slot.table.clone(),
            ),
            element: b.element,
            silence: b.silence,
            seq: 0,
            last_valid: None,
            armed: None,
            acted: false,
            awaiting: None,
            state_rx: slot.device.state(),
            pending_safe: None,
            slot,
        });
    }
    let (tx, mut rx) = mpsc::channel::<Incoming>(64);
    let dropped = Arc::new(AtomicU64::new(0));
    let cmd_topic = f.cmd_topic.clone().unwrap_or_default();
    // Readers and writers for this front.
    let reader_keep: Box<dyn Send> = match &f.kind {
        FrontKind::Dex3 { .. } => Box::new(forward(node, &cmd_topic, tx, Incoming::Dex3, dropped.clone())?),
        FrontKind::Dex1 {
            variant: Variant::Hg, ..
        } => Box::new(forward(node, &cmd_topic, tx, Incoming::Dex1Hg, dropped.clone())?),
        FrontKind::Dex1 { .. } => Box::new(forward(node, &cmd_topic, tx, Incoming::Dex1Go, dropped.clone())?),
        FrontKind::Canonical => Box::new(forward(node, &cmd_topic, tx, Incoming::Canonical, dropped.clone())?),
        FrontKind::JointState { .. } => unreachable!("JointState fronts returned above"),
    };
    let mut out = FrontWriters::new(node, f)?;
    let f = f.clone();
    let log = RateLimitedLog::default();
    let front_id = NEXT_FRONT_ID.fetch_add(1, Ordering::Relaxed);
    let devices_list = f
        .bindings
        .iter()
        .map(|b| b.device.as_str())
        .collect::<Vec<_>>()
        .join(",");
    let span = tracing::info_span!("front", name = %f.name, devices = %devices_list);
    Ok(tokio::spawn(tracing::Instrument::instrument(
        async move {
            let _reader = reader_keep;
            let name = f.name.clone();
            let mut state_tick = Ticker::hz(f.state_hz);
            let lf_hz = match &f.kind {
                FrontKind::Dex3 {
                    lf_state_topic: Some(_),
                    lf_state_hz,
                } => *lf_state_hz,
                _ => 0.0,
            };
            let mut lf_tick = Ticker::hz(lf_hz);
            // Commands dropped because this front's queue was full (reported at most once a
            // second, with the running total, so a flood's losses are visible).
            let mut dropped_reported = (0u64, Instant::now() - Duration::from_secs(2));
            // Prompt state: after a command is accepted, the first state that reflects it on
            // every device it went to (`cmd_seq`) is published at once instead of at the next
            // deadline. Each period carries one publish: a prompt one stands in for the
            // periodic one due at the end of its period, so the rate stays the nominal one.
            let mut prompt_since: Option<Instant> = None;
            let mut slot_used = false;
            loop {
                let silence_due = bound.iter().filter_map(Bound::silence_due).min();
                let awaiting = bound.iter().any(|b| b.awaiting.is_some());
                tokio::select! {
                    msg = rx.recv() => {
                        let Some(msg) = msg else { break };
                        let decoded = decode(&f, &bound, &msg);
                        match decoded {
                            Ok(cmds) => {
                                let mut any = false;
                                for (i, (body, tag, timeout_bit)) in cmds {
                                    let b = &mut bound[i];
                                    if let Some(h) = b.pending_safe.take() {
                                        let _ = h.await;
                                    }
                                    b.seq += 1;
                                    match b.slot.device.command(HandCommand { seq: b.seq, body, tag }) {
                                        Ok(()) => {
                                            any = true;
                                            let counters = &b.slot.counters;
                                            counters.accepted.fetch_add(1, Ordering::Relaxed);
                                            counters.last_front.store(front_id, Ordering::Relaxed);
                                            b.last_valid = Some(Instant::now());
                                            b.armed = b.silence.armed(timeout_bit);
                                            b.state_rx.mark_unchanged();
                                            b.awaiting = Some(b.seq);
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
                            for b in bound.iter_mut() { b.awaiting = None; }
                            continue;
                        };
                        let b = &mut bound[i];
                        let st = b.state_rx.borrow_and_update().clone();
                        if b.awaiting == Some(st.cmd_seq) {
                            b.awaiting = None;
                        }
                        let expired = prompt_since.is_some_and(|t| t.elapsed() > PROMPT_STATE_WAIT);
                        if expired {
                            // Superseded by another front's command, or never applied.
                            for b in bound.iter_mut() { b.awaiting = None; }
                        } else if bound.iter().all(|b| b.awaiting.is_none()) && !slot_used {
                            out.publish(&f, &bound, false);
                            slot_used = true;
                        }
                    }
                    _ = state_tick.tick() => {
                        if std::mem::take(&mut slot_used) {
                            // This period's sample went out promptly.
                        } else {
                            out.publish(&f, &bound, false);
                        }
                        let d = dropped.load(Ordering::Relaxed);
                        if d > dropped_reported.0 && dropped_reported.1.elapsed() >= Duration::from_secs(1) {
                            warn!(front = %name, dropped = d - dropped_reported.0,
                                queue_full_total = d, "front queue full: commands dropped unprocessed");
                            dropped_reported = (d, Instant::now());
                        }
                    }
                    _ = lf_tick.tick(), if lf_hz > 0.0 => {
                        out.publish(&f, &bound, true);
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
        .filter(|(_, b)| b.awaiting.is_some())
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

type Routed = (handgate_adapters::model::CommandBody, u32, bool);

/// Decodes a front message into commands per bound device (index into `bound`).
fn decode(f: &FrontPlan, bound: &[Bound], msg: &Incoming) -> Result<Vec<(usize, Routed)>, Rejection> {
    let measured = |b: &Bound| {
        let st = b.slot.device.state().borrow().clone();
        b.route.state(&st.joints, st.closure)
    };
    let only = |r: Routed| vec![(0, r)];
    let b0 = &bound[0];
    Ok(match msg {
        Incoming::Dex3(m) => {
            only(fronts::dex3::decode_cmd(m, &b0.route.front, &measured(b0)).map(|c| routed(&b0.route, c))?)
        }
        Incoming::Dex1Go(m) => match &f.kind {
            FrontKind::Dex1 {
                variant: Variant::Actuator,
                ..
            } => {
                let elems: Vec<(usize, &DeviceTable)> = bound.iter().map(|b| (b.element, &*b.route.front)).collect();
                fronts::dex1::decode_actuator(m, &elems)?
                    .into_iter()
                    .zip(bound)
                    .enumerate()
                    .map(|(i, (c, b))| (i, routed(&b.route, c)))
                    .collect()
            }
            _ => only(
                fronts::dex1::decode_go(m, Variant::Go, Side::Left, &b0.route.front).map(|c| routed(&b0.route, c))?,
            ),
        },
        Incoming::Dex1Hg(m) => only(fronts::dex1::decode_hg(m, &b0.route.front).map(|c| routed(&b0.route, c))?),
        Incoming::Canonical(m) => {
            only(fronts::canonical::decode_cmd(m, &b0.slot.table, b0.slot.plan.safe_action).map(|b| (b, 0, false))?)
        }
    })
}

/// How long a front waits for the state reflecting an accepted command before it stops
/// listening for it (the periodic state carries on regardless).
const PROMPT_STATE_WAIT: Duration = Duration::from_millis(100);

fn routed(route: &router::Route, c: FrontCommand) -> Routed {
    (route.command(&c.joints), c.tag, c.timeout_bit)
}

/// A front's state writers.
enum FrontWriters {
    Dex3 {
        state: handgate_adapters::dds::Writer<unitree_hg::HandState_>,
        lf: Option<handgate_adapters::dds::Writer<unitree_hg::HandState_>>,
    },
    Dex1Go(handgate_adapters::dds::Writer<unitree_go::MotorStates_>),
    Dex1Hg(handgate_adapters::dds::Writer<unitree_hg::HandState_>),
    Canonical(handgate_adapters::dds::Writer<hgmsg::HandState_>),
}

impl FrontWriters {
    fn new(node: &Node, f: &FrontPlan) -> Result<Self, DdsError> {
        Ok(match &f.kind {
            FrontKind::Dex3 { lf_state_topic, .. } => FrontWriters::Dex3 {
                state: node.writer(&f.state_topic, Qos::BestEffort)?,
                lf: lf_state_topic
                    .as_deref()
                    .map(|t| node.writer(t, Qos::BestEffort))
                    .transpose()?,
            },
            FrontKind::Dex1 {
                variant: Variant::Hg, ..
            } => FrontWriters::Dex1Hg(node.writer(&f.state_topic, Qos::BestEffort)?),
            FrontKind::Dex1 { .. } => FrontWriters::Dex1Go(node.writer(&f.state_topic, Qos::BestEffort)?),
            FrontKind::Canonical | FrontKind::JointState { .. } => {
                FrontWriters::Canonical(node.writer(&f.state_topic, Qos::BestEffort)?)
            }
        })
    }

    fn publish(&mut self, f: &FrontPlan, bound: &[Bound], lf: bool) {
        let now = Instant::now();
        let view = |b: &Bound| {
            let st = b.slot.device.state().borrow().clone();
            let joints = b.route.state(&st.joints, st.closure);
            (st, joints)
        };
        let b0 = &bound[0];
        let _ = match self {
            FrontWriters::Dex3 { state, lf: lfw } => {
                let (st, joints) = view(b0);
                let msg = fronts::dex3::encode_state(&b0.route.front, &joints, &st);
                match (lf, lfw) {
                    (true, Some(w)) => w.write(msg),
                    (true, None) => Ok(()),
                    (false, _) => state.write(msg),
                }
            }
            FrontWriters::Dex1Go(w) => match &f.kind {
                FrontKind::Dex1 {
                    variant: Variant::Actuator,
                    ..
                } => {
                    // Every element measured: each from its own gripper; an unbound one as
                    // never measured.
                    let mut m = unitree_go::MotorStates_ {
                        states: vec![fronts::dex1::unbound_state(&b0.route.front); f.elements()],
                    };
                    for b in bound {
                        let (st, joints) = view(b);
                        m.states[b.element] = fronts::dex1::go_state(&b.route.front, &joints[0], &st, now);
                    }
                    w.write(m)
                }
                _ => {
                    let (st, joints) = view(b0);
                    w.write(fronts::dex1::encode_go(&b0.route.front, &joints[0], &st, now))
                }
            },
            FrontWriters::Dex1Hg(w) => {
                let (st, joints) = view(b0);
                w.write(fronts::dex1::encode_hg(&b0.route.front, &joints[0], &st, now))
            }
            FrontWriters::Canonical(w) => {
                let st = b0.slot.device.state().borrow().clone();
                w.write(fronts::canonical::encode_state(&b0.slot.plan.name, &b0.slot.table, &st))
            }
        };
    }
}
