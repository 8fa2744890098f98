//! A generic DDS-client device: a device loop thread at a fixed rate that folds the latest
//! canonical command into targets, encodes them with a per-kind [`DdsCodec`], publishes, and
//! turns the peer's state samples back into canonical state. Used by the Dex3-over-DDS,
//! Dex1-1 and rt/hand_sdk adapters; each kind only supplies its codec.

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use async_trait::async_trait;
use cyclonedds_rs::TopicType;
use tokio::sync::watch;

use crate::control::{Active, CommandState, Counters};
use crate::dds::{DdsError, Node, Qos};
use crate::device::{DeviceError, DeviceInfo, DeviceStats, HandDevice};
use crate::mapping::DeviceTable;
use crate::model::{faults, Freshness, HandCommand, HandState, SafeAction};

/// Per-kind wire encoding for a DDS-client device.
pub trait DdsCodec: Send + 'static {
    type Cmd: TopicType + Clone + Send + 'static;
    type State: TopicType + Clone + Send + 'static;

    /// The message to publish this cycle for the targets in force, or None to stay silent.
    /// `dt` is the loop period in seconds.
    fn encode(&mut self, active: &Active, table: &DeviceTable, dt: f32) -> Option<Self::Cmd>;

    /// Canonical state from one state sample (joints in canonical order), or None if the
    /// sample does not carry this device (wrong size, other side).
    fn decode(&mut self, sample: &Self::State, table: &DeviceTable) -> Option<HandState>;

    /// For devices without feedback: the state to publish (what is commanded).
    fn commanded_state(&self, _table: &DeviceTable) -> Option<HandState> {
        None
    }
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
        out
    }
}

struct Shared<S> {
    latest: Mutex<Option<S>>,
}

/// A running DDS-client device.
pub struct DdsDevice {
    info: DeviceInfo,
    cmd: CommandState,
    state_rx: watch::Receiver<HandState>,
    cycles: watch::Receiver<u64>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl DdsDevice {
    /// Creates the endpoints on `node` and starts the device loop.
    pub fn start<C: DdsCodec>(
        node: &Node,
        info: DeviceInfo,
        config: DdsDeviceConfig,
        mut codec: C,
    ) -> Result<Self, DdsError> {
        let table = info.table.clone();
        let cmd = CommandState::new(table.clone());
        let mut writer = node.writer::<C::Cmd>(&config.cmd_topic, CMD_QOS)?;
        let shared: Arc<Shared<C::State>> = Arc::new(Shared {
            latest: Mutex::new(None),
        });
        let counters = cmd.counters.clone();
        let reader = match &config.state_topic {
            Some(t) => {
                let sh = shared.clone();
                let ctr = counters.clone();
                Some(node.reader_with_callback::<C::State, _>(t, STATE_QOS, move |h| {
                    let mut v = Vec::new();
                    if h.take_into(&mut v) > 0 {
                        ctr.state_samples.fetch_add(v.len() as u64, Ordering::Relaxed);
                        *sh.latest.lock().unwrap_or_else(|p| p.into_inner()) = v.pop();
                    }
                })?)
            }
            None => None,
        };
        let n = table.joint_count();
        let initial = match &config.state_topic {
            // A device without feedback reports what is commanded from the start.
            None => codec.commanded_state(&table).unwrap_or_else(|| HandState::empty(n)),
            Some(_) => HandState::empty(n),
        };
        let (state_tx, state_rx) = watch::channel(initial);
        let (cycle_tx, cycles) = watch::channel(0u64);
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let stop2 = stop.clone();
        let loop_cmd = cmd.clone();
        let name = info.name.clone();
        let span = tracing::info_span!("device", name = %info.name, kind = %info.kind, backend = info.backend.as_str());
        let thread = std::thread::Builder::new()
            .name(format!("dev-{name}"))
            .spawn(move || {
                let _span = span.enter();
                tracing::debug!(rate_hz = config.rate_hz, cmd = %config.cmd_topic, "device loop started");
                let _keep_reader = reader;
                let period = Duration::from_secs_f64(1.0 / config.rate_hz.max(1.0));
                let dt = period.as_secs_f32();
                let start = Instant::now();
                let mut k: u64 = 0;
                let mut current = HandState::empty(n);
                let mut link = crate::link::LinkTracker::default();
                let mut clock = crate::control::CycleClock::default();
                while !stop2.load(Ordering::Relaxed) {
                    let now = Instant::now();
                    clock.tick(&loop_cmd.counters, now);
                    let sample = shared.latest.lock().unwrap_or_else(|p| p.into_inner()).take();
                    if let Some(s) = sample {
                        if let Some(mut st) = codec.decode(&s, &table) {
                            st.measured_at = Some(now);
                            st.measured_wall = Some(SystemTime::now());
                            st.freshness = Freshness::Fresh;
                            st.closure = table.closure_of(&st.joints.iter().map(|j| j.q).collect::<Vec<_>>());
                            current = st;
                            if link.observe(true, &current.joints, &loop_cmd) {
                                // The peer came back: never replay what was in force before.
                                tracing::info!("peer back: holding the measured position until the next command");
                            }
                        }
                    }
                    if config.state_topic.is_some() {
                        let stale = current.age(now).map(|a| a > config.stale_after).unwrap_or(true);
                        if stale {
                            if link.is_up() {
                                tracing::warn!(
                                    stale_after_ms = config.stale_after.as_millis() as u64,
                                    "peer state stale: link down"
                                );
                            }
                            current.freshness = Freshness::Stale;
                            current.faults |= faults::LINK_DOWN;
                            link.observe(false, &current.joints, &loop_cmd);
                        }
                    }
                    let active = loop_cmd.step(&current.joints);
                    // Never "hold" a position that was never measured.
                    if config.state_topic.is_some() && crate::link::blind_hold(link.ever_measured(), &active) {
                        // stay silent
                    } else if let Some(msg) = codec.encode(&active, &table, dt) {
                        if writer.write(msg).is_ok() {
                            Counters::inc(&loop_cmd.counters.sent);
                        }
                    }
                    let mut out = if config.state_topic.is_none() {
                        codec.commanded_state(&table).unwrap_or_else(|| current.clone())
                    } else {
                        current.clone()
                    };
                    crate::link::stamp(&mut out, &loop_cmd, matches!(active, Active::Safe(..)), false);
                    let _ = state_tx.send(out);
                    k += 1;
                    let _ = cycle_tx.send(k);
                    let next = start + period * (k as u32);
                    let now = Instant::now();
                    if next > now {
                        std::thread::sleep(next - now);
                    } else if now - next > period {
                        Counters::inc(&loop_cmd.counters.missed_cycles);
                    }
                }
            })
            .map_err(|e| DdsError::Thread(e.to_string()))?;
        Ok(Self {
            info,
            cmd,
            state_rx,
            cycles,
            stop,
            thread: Mutex::new(Some(thread)),
        })
    }

    /// Stops the loop thread (after the caller put the device in a safe state).
    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.lock().unwrap_or_else(|p| p.into_inner()).take() {
            let _ = t.join();
        }
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
        Ok(self.cmd.submit(cmd)?)
    }

    fn command_checked(&self, seq: u64, body: crate::mapping::CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.cmd.submit_checked(seq, body, tag);
        Ok(())
    }

    fn state(&self) -> watch::Receiver<HandState> {
        self.state_rx.clone()
    }

    fn commanded(&self) -> Option<Vec<f32>> {
        self.cmd.targets()
    }

    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError> {
        self.cmd.request_safe(action);
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
