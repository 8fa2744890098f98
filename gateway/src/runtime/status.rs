//! The gateway's status heartbeat (`rt/handgate/status`): per device, freshness, rates and
//! counters; per served endpoint, its matched counterparts; discovery's findings.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::model::Freshness;
use handgate_idl::handgate as hgmsg;
use tokio::sync::watch;

use super::{DeviceSlot, RuntimeError};
use crate::plan::Plan;
use crate::ticker::Ticker;

/// One front's tallies for the status extension ([`hgmsg::FrontStatus_`]): the command samples
/// it took from clients and its publishes of its state topic (not the `rt/lf` copy), counted
/// by the front's task; the status task turns them into rates.
#[derive(Debug)]
pub(crate) struct FrontTally {
    pub name: String,
    pub kind: String,
    /// The front has a state topic (a command-only front publishes nothing: its rate is 0).
    pub publishes_state: bool,
    /// Command samples taken (every sample a reader's listener or the queue handed the front,
    /// before any check).
    pub commands: AtomicU64,
    /// Publishes of its state topic.
    pub states: AtomicU64,
}

impl FrontTally {
    pub fn new(f: &crate::plan::FrontPlan) -> Self {
        Self::named(&f.name, f.kind().as_str(), f.publishes_state())
    }

    /// A tally of a front that is not in the profile (the dashboard page's own), which the
    /// status does not report.
    pub fn named(name: &str, kind: &str, publishes_state: bool) -> Self {
        Self {
            name: name.to_string(),
            kind: kind.to_string(),
            publishes_state,
            commands: AtomicU64::new(0),
            states: AtomicU64::new(0),
        }
    }

    pub fn command(&self) {
        self.commands.fetch_add(1, Ordering::Relaxed);
    }

    pub fn state(&self) {
        self.states.fetch_add(1, Ordering::Relaxed);
    }
}

/// Two counters' rates per second between status ticks (a device's commands sent and states,
/// a front's commands taken and states published). The first reading is 0 (no interval yet);
/// a status published between ticks (a changed motion verdict) repeats the last tick's rates
/// rather than measuring over a few milliseconds.
#[derive(Debug, Clone, Copy, Default)]
struct TickRates {
    /// The counts at the last tick, and when.
    last: Option<(u64, u64, Instant)>,
    /// The rates computed then.
    rates: Option<(f32, f32)>,
}

impl TickRates {
    /// The rates at `now` of `counts`, measured anew on a tick (or the first time).
    fn at(&mut self, (a, b): (u64, u64), now: Instant, on_tick: bool) -> (f32, f32) {
        if let Some(r) = self.rates.filter(|_| !on_tick) {
            return r;
        }
        let (pa, pb, pt) = self.last.unwrap_or((a, b, now));
        let dt = now.duration_since(pt).as_secs_f32();
        let per_s = |x: u64, p: u64| if dt > 0.0 { x.saturating_sub(p) as f32 / dt } else { 0.0 };
        let r = (per_s(a, pa), per_s(b, pb));
        self.last = Some((a, b, now));
        self.rates = Some(r);
        r
    }
}

/// What the status task publishes and tells the rest of the gateway: the frozen status and its
/// extension (docs/wire-types.md, "Status: frozen, and its extension").
pub(super) struct StatusOut {
    pub latest: watch::Sender<Arc<hgmsg::GatewayStatus_>>,
    pub latest_ext: watch::Sender<Arc<hgmsg::GatewayStatusExt_>>,
}

#[allow(clippy::too_many_arguments)]
pub(super) fn spawn_status(
    node: &Node,
    plan: &Plan,
    devices: Vec<Arc<DeviceSlot>>,
    fronts: Vec<Arc<FrontTally>>,
    diagnosis: watch::Receiver<Arc<crate::diagnostics::Diagnosis>>,
    record: Option<Arc<handgate_record::RecordStats>>,
    out: StatusOut,
    mut shutdown: watch::Receiver<bool>,
) -> Result<tokio::task::JoinHandle<()>, RuntimeError> {
    let StatusOut { latest, latest_ext } = out;
    let mut writer = node.writer::<hgmsg::GatewayStatus_>(&plan.status_topic, Qos::Reliable { depth: 1 })?;
    // The extension beside it: XCDR2, appendable; the same QoS.
    let mut ext_writer = node
        .writer::<hgmsg::GatewayStatusExt_>(&hgmsg::status_ext_topic(&plan.status_topic), Qos::Reliable { depth: 1 })?;
    let profile = plan.profile.clone();
    // Both DDS sides and where the gateway runs, so `handgate status` and `handgate fleet`
    // show them (`[export]`: the clients' side is where this is published).
    let (export_domain, export_interface) = plan.clients_side();
    let sides = hgmsg::GatewayStatus_ {
        domain: plan.domain,
        interface: plan.interface.clone().unwrap_or_default(),
        export_domain,
        export_interface: export_interface.unwrap_or_default().to_string(),
        namespace: plan.own_namespace.ros().to_string(),
        host: host_name(),
        ..Default::default()
    };
    let period = Duration::from_secs_f64(1.0 / plan.status_hz.clamp(0.1, 10.0));
    let started = Instant::now();
    Ok(tokio::spawn(async move {
        let mut tick = Ticker::new(period);
        // A motion verdict that changes is published at once, not at the next tick: at the
        // default 1 Hz a fault would otherwise wait up to a second more (docs/adapters.md,
        // "Motion"). Checking costs a borrow of each device's state.
        let mut motion_tick = Ticker::new(MOTION_CHECK);
        // Per device (commands sent, states) and per front (commands taken, states published).
        let mut device_rates = vec![TickRates::default(); devices.len()];
        let mut front_rates = vec![TickRates::default(); fronts.len()];
        let mut published_motion: Vec<u8> = vec![hgmsg::MOTION_OK; devices.len()];
        loop {
            let on_tick = tokio::select! {
                _ = tick.tick() => true,
                _ = motion_tick.tick() => {
                    let same = devices.len() == published_motion.len()
                        && devices.iter().zip(&published_motion).all(|(d, m)| d.device.state().borrow().motion.verdict.code() == *m);
                    if same {
                        continue;
                    }
                    false
                }
                _ = shutdown.changed() => break,
            };
            let now = Instant::now();
            let (endpoints, diagnostics) = crate::diagnostics::to_status(&diagnosis.borrow());
            let mut msg = hgmsg::GatewayStatus_ {
                profile: profile.clone(),
                uptime_ms: started.elapsed().as_millis() as u64,
                devices: vec![],
                endpoints,
                diagnostics,
                ..sides.clone()
            };
            if let Some(r) = &record {
                msg.record_messages = r.written.load(Ordering::Relaxed);
                msg.record_dropped = r.dropped.load(Ordering::Relaxed);
            }
            for (d, rates) in devices.iter().zip(&mut device_rates) {
                let s = d.device.stats();
                let st = d.device.state().borrow().clone();
                let (cmd_rate_hz, state_rate_hz) = rates.at((s.sent, s.state_samples), now, on_tick);
                msg.devices.push(hgmsg::DeviceStatus_ {
                    device: d.plan.name.clone(),
                    kind: d.plan.kind.as_str().into(),
                    backend: d.plan.backend.as_str().into(),
                    freshness: match st.freshness {
                        Freshness::Fresh => hgmsg::FRESH,
                        Freshness::Stale => hgmsg::STALE,
                        Freshness::CommandedOnly => hgmsg::COMMANDED_ONLY,
                    },
                    safe: d.counters.tripped.load(Ordering::Relaxed) != 0
                        || st.faults & handgate_adapters::model::faults::SAFE_STATE != 0,
                    cmd_rate_hz,
                    state_rate_hz,
                    crc_errors: s.crc_errors,
                    bad_input: d.counters.rejected.load(Ordering::Relaxed) + s.rejected,
                    watchdog_trips: d.counters.watchdog_trips.load(Ordering::Relaxed),
                    reconnects: s.reconnects,
                    missed_cycles: s.missed_cycles,
                    foreign_cmd: d.counters.foreign_cmd.load(Ordering::Relaxed),
                    duplicate_cmd: d.counters.duplicate_cmd.load(Ordering::Relaxed),
                    reordered_cmd: d.counters.reordered_cmd.load(Ordering::Relaxed),
                    late_cmd: d.counters.late_cmd.load(Ordering::Relaxed),
                    owner: d.counters.owner().unwrap_or_default(),
                    not_allowed_cmd: d.counters.not_allowed_cmd.load(Ordering::Relaxed),
                    age_ms: st.age(now).map(|a| a.as_secs_f32() * 1000.0).unwrap_or(f32::NAN),
                    motion: st.motion.verdict.code(),
                    motion_joint: st
                        .motion
                        .joint
                        .and_then(|j| d.plan.kind.joint_names().get(j))
                        .map(|n| n.to_string())
                        .unwrap_or_default(),
                    tracking_error: st.motion.tracking_error(),
                    faults: st.faults,
                });
            }
            published_motion.clear();
            published_motion.extend(msg.devices.iter().map(|d| d.motion));
            let ext = hgmsg::GatewayStatusExt_ {
                version: hgmsg::STATUS_EXT_VERSION,
                fronts: fronts
                    .iter()
                    .zip(&mut front_rates)
                    .map(|(f, rates)| {
                        let counts = (f.commands.load(Ordering::Relaxed), f.states.load(Ordering::Relaxed));
                        let (cmd, state) = rates.at(counts, now, on_tick);
                        hgmsg::FrontStatus_ {
                            name: f.name.clone(),
                            kind: f.kind.clone(),
                            cmd_rate_hz: cmd,
                            state_rate_hz: if f.publishes_state { state } else { 0.0 },
                        }
                    })
                    .collect(),
                refused_participants: handgate_adapters::dds_security::secured()
                    .iter()
                    .map(|(_, r)| r.total())
                    .sum::<u64>()
                    .min(u64::from(u32::MAX)) as u32,
            };
            latest.send_replace(Arc::new(msg.clone()));
            latest_ext.send_replace(Arc::new(ext.clone()));
            let _ = writer.write(msg);
            let _ = ext_writer.write(ext);
        }
    }))
}

/// How often the status task looks for a changed motion verdict to publish at once.
const MOTION_CHECK: Duration = Duration::from_millis(50);

/// This host's name (the kernel's), empty when it cannot be read.
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_default()
}
