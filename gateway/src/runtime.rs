//! The runtime: builds devices from a [`Plan`], binds fronts to them, runs watchdogs and the
//! status publisher, and brings every device to its safe state on shutdown.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::dds::{DdsError, Node, Qos};
use handgate_adapters::dds_device::{DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Capabilities, DeviceError, DeviceInfo, HandDevice};
use handgate_adapters::dex1::adapter::{Dex1GoCodec, Dex1HgCodec, Variant};
use handgate_adapters::dex3::dds_client::Dex3DdsCodec;
use handgate_adapters::hand_sdk::adapter::HandSdkCodec;
use handgate_adapters::mapping::{DeviceTable, MappingError};
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, HandState};
use handgate_adapters::tables::{table_for, TableParams};
use handgate_idl::handgate as hgmsg;
use handgate_idl::{ros2, unitree_go, unitree_hg};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

use crate::fronts::{self, FrontCommand, Rejection};
use crate::plan::{DevicePlan, FrontKind, FrontPlan, Plan, Transport};
use crate::router;

/// Runtime errors (start-up).
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    #[error("DDS: {0}")]
    Dds(#[from] DdsError),
    #[error("device {device}: {source}")]
    Mapping {
        device: String,
        #[source]
        source: MappingError,
    },
    #[error("device {0}: {1}")]
    Device(String, String),
    #[error("front bound to unknown device {0:?}")]
    UnknownDevice(String),
}

/// Per-device counters kept by the fronts bound to it.
#[derive(Debug, Default)]
pub struct FrontCounters {
    pub accepted: AtomicU64,
    pub rejected: AtomicU64,
    pub watchdog_trips: AtomicU64,
    /// 1 while a watchdog holds the device in its safe state.
    pub tripped: AtomicU64,
}

/// A device as the runtime holds it.
pub struct DeviceSlot {
    pub plan: DevicePlan,
    pub device: Arc<dyn HandDevice>,
    pub table: Arc<DeviceTable>,
    pub counters: Arc<FrontCounters>,
}

/// A running gateway.
pub struct Runtime {
    pub node: Node,
    pub devices: Vec<Arc<DeviceSlot>>,
    shutdown: watch::Sender<bool>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
    started: Instant,
    /// EZGripper buses (and emulated buses), alive as long as the runtime.
    pub buses: crate::ezbus::Buses,
}

fn table(p: &DevicePlan) -> Result<Arc<DeviceTable>, RuntimeError> {
    table_for(p.kind, p.side, &p.table)
        .map(Arc::new)
        .map_err(|source| RuntimeError::Mapping {
            device: p.name.clone(),
            source,
        })
}

/// Builds one device (DDS-side kinds). Other backends are added by [`build_device`].
fn build_any_device(
    node: &Node,
    p: &DevicePlan,
    table: Arc<DeviceTable>,
    buses: &crate::ezbus::Buses,
) -> Result<Arc<dyn HandDevice>, RuntimeError> {
    let info = |caps: Capabilities| DeviceInfo {
        name: p.name.clone(),
        kind: p.kind,
        side: p.side,
        backend: p.backend,
        table: table.clone(),
        capabilities: caps,
    };
    let cfg = |cmd: &str, state: Option<&str>, rate: f64| DdsDeviceConfig {
        cmd_topic: cmd.to_string(),
        state_topic: state.map(str::to_string),
        rate_hz: rate,
        stale_after: p.stale_after,
    };
    let dev: Arc<dyn HandDevice> = match &p.transport {
        Transport::Dex3Dds {
            cmd_topic,
            state_topic,
            timeout_bit,
        } => Arc::new(DdsDevice::start(
            node,
            info(Capabilities {
                feedback: true,
                pressure: true,
                imu: true,
                power: true,
                ..Default::default()
            }),
            cfg(cmd_topic, Some(state_topic), p.rate_hz),
            Dex3DdsCodec {
                timeout_bit: *timeout_bit,
            },
        )?),
        Transport::Dex1Dds {
            variant,
            cmd_topic,
            state_topic,
        } => {
            let caps = Capabilities {
                feedback: true,
                ..Default::default()
            };
            let c = cfg(cmd_topic, Some(state_topic), p.rate_hz);
            match variant {
                Variant::Hg => Arc::new(DdsDevice::start(node, info(caps), c, Dex1HgCodec)?),
                v => Arc::new(DdsDevice::start(node, info(caps), c, Dex1GoCodec::new(*v, p.side))?),
            }
        }
        Transport::HandSdk {
            topic,
            ramp,
            publish_hz,
        } => Arc::new(DdsDevice::start(
            node,
            info(Capabilities::default()),
            cfg(topic, None, *publish_hz),
            HandSdkCodec::new(*ramp),
        )?),
        Transport::Dex3Usb {
            source,
            timeout_bit,
            wiring,
            scalings,
        } => {
            let config = handgate_adapters::dex3::usb::LoopConfig {
                period: Duration::from_secs_f64(1.0 / p.rate_hz.max(1.0)),
                timeout_bit: *timeout_bit,
                hold_kp: table.hold_kp,
                hold_kd: table.hold_kd,
                wiring: *wiring,
                scalings: *scalings,
                // The spin before each deadline buys period jitter for real hardware; an
                // emulated hand has no use for it, and a fleet of them would burn a core on it
                // (docs/benchmarks.md, fleet scale).
                spin: match source {
                    handgate_adapters::dex3::usb::adapter::UsbSource::Emulator(_) => Duration::ZERO,
                    _ => handgate_adapters::dex3::usb::LoopConfig::default().spin,
                },
                ..Default::default()
            };
            let dev = handgate_adapters::dex3::usb::adapter::Dex3UsbDevice::start(
                info(handgate_adapters::dex3::usb::adapter::CAPABILITIES),
                source.clone(),
                config,
            )
            .map_err(|e| RuntimeError::Device(p.name.clone(), e.to_string()))?;
            Arc::new(dev)
        }
        Transport::EzGripper {
            port,
            servo_id,
            force_pct,
            ..
        } => {
            let bus = buses
                .buses
                .get(port)
                .cloned()
                .ok_or_else(|| RuntimeError::Device(p.name.clone(), format!("no bus open on {port}")))?;
            let id = handgate_adapters::ezgripper::ServoId::new(*servo_id)
                .map_err(|e| RuntimeError::Device(p.name.clone(), e.to_string()))?;
            let dev = handgate_adapters::ezgripper::adapter::EzGripperDevice::start(
                info(handgate_adapters::ezgripper::adapter::CAPABILITIES),
                bus,
                id,
                *force_pct,
            )
            .map_err(|e| RuntimeError::Device(p.name.clone(), e.to_string()))?;
            Arc::new(dev)
        }
        Transport::EmulatedDds(peer) => return crate::emulated::build(node, p, peer, info(Capabilities::default())),
    };
    Ok(dev)
}

/// Builds any device of the plan.
pub fn build_device(
    node: &Node,
    p: &DevicePlan,
    buses: &crate::ezbus::Buses,
) -> Result<(Arc<dyn HandDevice>, Arc<DeviceTable>), RuntimeError> {
    let t = table(p)?;
    let dev = build_any_device(node, p, t.clone(), buses)?;
    Ok((dev, t))
}

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

impl Runtime {
    /// Starts every device and front of `plan`. Must be called inside a tokio runtime.
    pub fn start(plan: &Plan) -> Result<Self, RuntimeError> {
        let node = Node::new(plan.domain, plan.interface.as_deref())?;
        let buses = crate::ezbus::open(&plan.devices)?;
        let mut devices = Vec::new();
        let mut by_name = HashMap::new();
        for p in &plan.devices {
            let (device, table) = build_device(&node, p, &buses)?;
            let slot = Arc::new(DeviceSlot {
                plan: p.clone(),
                device,
                table,
                counters: Arc::new(FrontCounters::default()),
            });
            by_name.insert(p.name.clone(), slot.clone());
            devices.push(slot);
        }
        let (shutdown, shutdown_rx) = watch::channel(false);
        let mut tasks = Vec::new();
        for f in &plan.fronts {
            tasks.push(spawn_front(&node, f, &by_name, shutdown_rx.clone())?);
        }
        tasks.push(spawn_status(&node, plan, devices.clone(), shutdown_rx.clone())?);
        Ok(Self {
            node,
            devices,
            shutdown,
            tasks,
            started: Instant::now(),
            buses,
        })
    }

    pub fn uptime(&self) -> Duration {
        self.started.elapsed()
    }

    /// Safe state on every device (each device's configured safe action), then stop.
    pub async fn shutdown(self) -> Vec<(String, Result<(), DeviceError>)> {
        let _ = self.shutdown.send(true);
        for t in self.tasks {
            let _ = t.await;
        }
        let mut out = Vec::new();
        let futs = self.devices.iter().map(|d| {
            let d = d.clone();
            async move {
                let r = tokio::time::timeout(Duration::from_millis(500), d.device.shutdown(d.plan.safe_action)).await;
                (
                    d.plan.name.clone(),
                    r.unwrap_or(Err(DeviceError::Link("safe state not confirmed within 500 ms".into()))),
                )
            }
        });
        for r in futures_join_all(futs).await {
            out.push(r);
        }
        out
    }
}

async fn futures_join_all<F>(futs: impl Iterator<Item = F>) -> Vec<F::Output>
where
    F: std::future::Future + Send + 'static,
    F::Output: Send + 'static,
{
    let handles: Vec<_> = futs.map(tokio::spawn).collect();
    let mut out = Vec::new();
    for h in handles {
        if let Ok(v) = h.await {
            out.push(v);
        }
    }
    out
}

fn front_table(f: &FrontPlan, device: &DeviceSlot) -> Result<Arc<DeviceTable>, RuntimeError> {
    let (kind, params) = match &f.kind {
        FrontKind::Dex3 { .. } => (DeviceKind::Dex3, TableParams::default()),
        FrontKind::Dex1 { range_rad, .. } => (
            DeviceKind::Dex1,
            TableParams {
                range_rad: *range_rad,
                ..Default::default()
            },
        ),
        FrontKind::Canonical | FrontKind::JointState { .. } => return Ok(device.table.clone()),
    };
    table_for(kind, f.side, &params)
        .map(Arc::new)
        .map_err(|source| RuntimeError::Mapping {
            device: device.plan.name.clone(),
            source,
        })
}

fn spawn_front(
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
        let urdf = *urdf_names;
        let period = Duration::from_secs_f64(1.0 / f.state_hz.max(0.1));
        return Ok(tokio::spawn(async move {
            let mut tick = tokio::time::interval(period);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
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
        }));
    }
    let slot = devices
        .get(&f.device)
        .cloned()
        .ok_or_else(|| RuntimeError::UnknownDevice(f.device.clone()))?;
    let ftable = front_table(f, &slot)?;
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
    let span = tracing::info_span!("device", name = %slot.plan.name, front = %f.state_topic);
    Ok(tokio::spawn(tracing::Instrument::instrument(
        async move {
            let _reader = reader_keep;
            let device = slot.device.clone();
            let dtable = slot.table.clone();
            let counters = slot.counters.clone();
            let name = f.device.clone();
            let mut seq: u64 = 0;
            let mut last_valid: Option<Instant> = None;
            let mut tripped = false;
            let mut watchdog = f.watchdog;
            let mut state_tick = tokio::time::interval(Duration::from_secs_f64(1.0 / f.state_hz.max(0.1)));
            state_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
            let lf_hz = match &f.kind {
                FrontKind::Dex3 {
                    lf_state_topic: Some(_),
                    lf_state_hz,
                } => *lf_state_hz,
                _ => 0.0,
            };
            let mut lf_tick = tokio::time::interval(Duration::from_secs_f64(1.0 / lf_hz.max(0.1)));
            lf_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
            // Commands dropped because this front's queue was full (reported at most once a
            // second, with the running total, so a flood's losses are visible).
            let mut dropped_reported = (0u64, Instant::now() - Duration::from_secs(2));
            let mut wd_tick = tokio::time::interval(Duration::from_millis(5));
            wd_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
            // Prompt state: after a command is accepted, the first state that reflects it
            // (`cmd_seq` == its seq) is published at once instead of at the next state tick, and
            // the tick restarts from there. At most one extra publish per accepted command, never
            // more than one per device measurement; the front listens to the device's state only
            // while such a command is pending.
            let mut state_rx = device.state();
            let mut awaiting: Option<(u64, Instant)> = None;
            loop {
                tokio::select! {
                    msg = rx.recv() => {
                        let Some(msg) = msg else { break };
                        let measured = {
                            let st = device.state().borrow().clone();
                            router::route_state(&ftable, &dtable, &st.joints, st.closure)
                        };
                        let decoded: Result<(handgate_adapters::model::CommandBody, u32, bool), Rejection> = match &msg {
                            Incoming::Dex3(m) => fronts::dex3::decode_cmd(m, &ftable, &measured).map(|c| routed(&ftable, &dtable, c)),
                            Incoming::Dex1Go(m) => {
                                let v = match &f.kind { FrontKind::Dex1 { variant, .. } => *variant, _ => Variant::Go };
                                fronts::dex1::decode_go(m, v, f.side, &ftable).map(|c| routed(&ftable, &dtable, c))
                            }
                            Incoming::Dex1Hg(m) => fronts::dex1::decode_hg(m, &ftable).map(|c| routed(&ftable, &dtable, c)),
                            Incoming::Canonical(m) => fronts::canonical::decode_cmd(m, &dtable, slot.plan.safe_action).map(|b| (b, 0, false)),
                        };
                        match decoded {
                            Ok((body, tag, timeout_bit)) => {
                                seq += 1;
                                match device.command(HandCommand { seq, body, tag }) {
                                    Ok(()) => {
                                        counters.accepted.fetch_add(1, Ordering::Relaxed);
                                        last_valid = Some(Instant::now());
                                        state_rx.mark_unchanged();
                                        awaiting = Some((seq, Instant::now()));
                                        watchdog = if timeout_bit { f.watchdog.min(Duration::from_secs(1)) } else { f.watchdog };
                                        if tripped {
                                            tripped = false;
                                            counters.tripped.store(0, Ordering::Relaxed);
                                            info!(front = %f.state_topic, device = %name, "commands resumed after watchdog");
                                        }
                                    }
                                    Err(e) => {
                                        counters.rejected.fetch_add(1, Ordering::Relaxed);
                                        log.warn(&f.state_topic, "device_rejected", &e);
                                    }
                                }
                            }
                            Err(r) => {
                                counters.rejected.fetch_add(1, Ordering::Relaxed);
                                log.warn(&f.state_topic, r.reason(), &r);
                            }
                        }
                    }
                    _ = wd_tick.tick() => {
                        let d = dropped.load(Ordering::Relaxed);
                        if d > dropped_reported.0 && dropped_reported.1.elapsed() >= Duration::from_secs(1) {
                            warn!(front = %f.state_topic, device = %name, dropped = d - dropped_reported.0,
                                queue_full_total = d, "front queue full: commands dropped unprocessed");
                            dropped_reported = (d, Instant::now());
                        }
                        if let Some(t) = last_valid {
                            if !tripped && t.elapsed() > watchdog {
                                tripped = true;
                                counters.watchdog_trips.fetch_add(1, Ordering::Relaxed);
                                counters.tripped.store(1, Ordering::Relaxed);
                                warn!(front = %f.state_topic, device = %name, timeout_ms = watchdog.as_millis() as u64,
                                    action = ?slot.plan.safe_action, "command watchdog tripped: moving device to its safe state");
                                let _ = device.safe_state(slot.plan.safe_action).await;
                            }
                        }
                    }
                    changed = state_rx.changed(), if awaiting.is_some() => {
                        if changed.is_err() {
                            awaiting = None;
                            continue;
                        }
                        let st = state_rx.borrow_and_update().clone();
                        if let Some((want, since)) = awaiting {
                            if st.cmd_seq == want {
                                out.publish(&f, &ftable, &dtable, &st, false);
                                state_tick.reset();
                                awaiting = None;
                            } else if since.elapsed() > PROMPT_STATE_WAIT {
                                // Superseded by another front's command, or never applied.
                                awaiting = None;
                            }
                        }
                    }
                    _ = state_tick.tick() => {
                        let st = device.state().borrow().clone();
                        out.publish(&f, &ftable, &dtable, &st, false);
                    }
                    _ = lf_tick.tick(), if lf_hz > 0.0 => {
                        let st = device.state().borrow().clone();
                        out.publish(&f, &ftable, &dtable, &st, true);
                    }
                    _ = shutdown.changed() => break,
                }
            }
        },
        span,
    )))
}

/// How long a front waits for the state reflecting an accepted command before it stops
/// listening for it (the periodic state carries on regardless).
const PROMPT_STATE_WAIT: Duration = Duration::from_millis(100);

fn routed(
    ftable: &DeviceTable,
    dtable: &DeviceTable,
    c: FrontCommand,
) -> (handgate_adapters::model::CommandBody, u32, bool) {
    (router::route_command(ftable, dtable, &c.joints), c.tag, c.timeout_bit)
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

    fn publish(&mut self, f: &FrontPlan, ftable: &DeviceTable, dtable: &DeviceTable, st: &HandState, lf: bool) {
        let joints = router::route_state(ftable, dtable, &st.joints, st.closure);
        let now = Instant::now();
        let _ = match self {
            FrontWriters::Dex3 { state, lf: lfw } => {
                let msg = fronts::dex3::encode_state(ftable, &joints, st);
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
                    // Both indices: ours from the device; the other one is not ours to report.
                    let mut m = unitree_go::MotorStates_::with_len(2);
                    let i = handgate_adapters::dex1::adapter::actuator_index(f.side);
                    m.states[i] = fronts::dex1::go_state(ftable, &joints[0], st, now);
                    w.write(m)
                }
                _ => w.write(fronts::dex1::encode_go(ftable, &joints[0], st, now)),
            },
            FrontWriters::Dex1Hg(w) => w.write(fronts::dex1::encode_hg(ftable, &joints[0], st, now)),
            FrontWriters::Canonical(w) => w.write(fronts::canonical::encode_state(&f.device, dtable, st)),
        };
    }
}

fn spawn_status(
    node: &Node,
    plan: &Plan,
    devices: Vec<Arc<DeviceSlot>>,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let mut writer = node.writer::<hgmsg::GatewayStatus_>(&plan.status_topic, Qos::Reliable { depth: 1 })?;
    let profile = plan.profile.clone();
    let period = Duration::from_secs_f64(1.0 / plan.status_hz.clamp(0.1, 10.0));
    let started = Instant::now();
    Ok(tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        let mut prev: HashMap<String, (u64, u64, Instant)> = HashMap::new();
        loop {
            tokio::select! {
                _ = tick.tick() => {
                    let now = Instant::now();
                    let mut msg = hgmsg::GatewayStatus_ { profile: profile.clone(), uptime_ms: started.elapsed().as_millis() as u64, devices: vec![] };
                    for d in &devices {
                        let s = d.device.stats();
                        let st = d.device.state().borrow().clone();
                        let (pc, ps, pt) = prev.get(&d.plan.name).cloned().unwrap_or((s.sent, s.state_samples, now));
                        let dt = now.duration_since(pt).as_secs_f32();
                        let rate = |a: u64, b: u64| if dt > 0.0 { a.saturating_sub(b) as f32 / dt } else { 0.0 };
                        prev.insert(d.plan.name.clone(), (s.sent, s.state_samples, now));
                        msg.devices.push(hgmsg::DeviceStatus_ {
                            device: d.plan.name.clone(),
                            kind: d.plan.kind.as_str().into(),
                            backend: d.plan.backend.as_str().into(),
                            freshness: match st.freshness { Freshness::Fresh => hgmsg::FRESH, Freshness::Stale => hgmsg::STALE, Freshness::CommandedOnly => hgmsg::COMMANDED_ONLY },
                            safe: d.counters.tripped.load(Ordering::Relaxed) != 0 || st.faults & handgate_adapters::model::faults::SAFE_STATE != 0,
                            cmd_rate_hz: rate(s.sent, pc),
                            state_rate_hz: rate(s.state_samples, ps),
                            crc_errors: s.crc_errors,
                            bad_input: d.counters.rejected.load(Ordering::Relaxed) + s.rejected,
                            watchdog_trips: d.counters.watchdog_trips.load(Ordering::Relaxed),
                            reconnects: s.reconnects,
                            missed_cycles: s.missed_cycles,
                            age_ms: st.age(now).map(|a| a.as_secs_f32() * 1000.0).unwrap_or(f32::NAN),
                        });
                    }
                    let _ = writer.write(msg);
                }
                _ = shutdown.changed() => break,
            }
        }
    }))
}
