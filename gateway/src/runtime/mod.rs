//! The runtime: starts the devices of a [`Plan`] through their kinds, binds fronts to them,
//! runs the status publisher, and brings every device to its safe state on shutdown. Split
//! along its reasons to change: device start-up ([`devices`]), front tasks ([`fronts`]),
//! status publishing ([`status`]).

mod devices;
pub(crate) mod fronts;
mod health;
mod ros;
pub(crate) mod status;

use std::collections::HashMap;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{DdsError, Node};
use handgate_adapters::device::{DeviceError, HandDevice};
use handgate_adapters::discovery::{Discovery, DiscoveryConfig};
use handgate_adapters::front::serve::FrontEnv;
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::open::Shared;
use tokio::sync::watch;

use crate::plan::{DevicePlan, Plan};

pub use devices::{open_device, open_devices};

/// Runtime errors (start-up).
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    #[error("DDS: {0}")]
    Dds(#[from] DdsError),
    #[error("device {device}: {source}")]
    Device {
        device: String,
        #[source]
        source: DeviceError,
    },
    #[error("front bound to unknown device {0:?}")]
    UnknownDevice(String),
    /// Another process already writes a state topic a front would write.
    #[error("{0}")]
    ForeignStateWriter(String),
    /// `[realtime]` asks for what this process may not do (the message names the fix).
    #[error(transparent)]
    Realtime(#[from] handgate_adapters::realtime::RealtimeError),
    #[error("[record]: {0}")]
    Record(#[from] handgate_record::RecordError),
    #[error("[http]: {0}")]
    Http(#[from] crate::http::HttpError),
    #[cfg(feature = "foxglove")]
    #[error("[foxglove]: {0}")]
    Foxglove(#[from] crate::live::LiveError),
}

/// Per-device counters kept by the fronts bound to it.
#[derive(Debug, Default)]
pub struct FrontCounters {
    pub accepted: AtomicU64,
    /// Which front sent the last accepted command (its `FrontId`; a front's silence action
    /// only runs when the device's last command was its own).
    pub last_front: AtomicU64,
    pub rejected: AtomicU64,
    /// Commands refused whole because another writer owns the front (`foreign_cmd` in
    /// status; `control = "exclusive"`).
    pub foreign_cmd: AtomicU64,
    /// Commands dropped whole: the same source timestamp as their writer's last accepted one
    /// (`duplicate_cmd` in status).
    pub duplicate_cmd: AtomicU64,
    /// Commands dropped whole: older than their writer's last accepted one (`reordered_cmd`).
    pub reordered_cmd: AtomicU64,
    /// Commands dropped whole: older than the front's `max_command_age_ms` on arrival
    /// (`late_cmd`).
    pub late_cmd: AtomicU64,
    /// Commands refused whole: their host is not in `export.allow_commands_from`
    /// (`not_allowed_cmd`).
    pub not_allowed_cmd: AtomicU64,
    /// Silence actions run (`wdog` in status): watchdog trips, a service's brake or timeout.
    pub watchdog_trips: AtomicU64,
    /// 1 while a silence action holds the device (until the next accepted command).
    pub tripped: AtomicU64,
    /// When the last command was accepted, ns since [`epoch`] (0: never).
    pub last_accepted_ns: AtomicU64,
    /// Who commands the device: the front and the writer (named when it changes).
    pub owner: std::sync::Mutex<Option<String>>,
}

/// The runtime's clock origin (the first call).
pub fn epoch() -> Instant {
    static EPOCH: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

impl FrontCounters {
    /// A command was accepted now.
    pub fn mark_accepted(&self) {
        let ns = epoch().elapsed().as_nanos().max(1) as u64;
        self.last_accepted_ns.store(ns, std::sync::atomic::Ordering::Relaxed);
    }

    /// How long ago the last command was accepted (`None`: never).
    pub fn since_accepted(&self) -> Option<Duration> {
        match self.last_accepted_ns.load(std::sync::atomic::Ordering::Relaxed) {
            0 => None,
            ns => Some(epoch().elapsed().saturating_sub(Duration::from_nanos(ns))),
        }
    }

    pub fn set_owner(&self, who: String) {
        *self.owner.lock().unwrap_or_else(|p| p.into_inner()) = Some(who);
    }

    pub fn owner(&self) -> Option<String> {
        self.owner.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

/// A device as the runtime holds it.
pub struct DeviceSlot {
    pub plan: DevicePlan,
    pub device: Arc<dyn HandDevice>,
    pub table: Arc<DeviceTable>,
    pub counters: Arc<FrontCounters>,
}

/// The clients' side of a gateway with `[export]` on a domain of its own.
pub struct Export {
    pub node: Node,
    pub discovery: Discovery,
}

/// A running gateway.
pub struct Runtime {
    pub node: Node,
    pub devices: Vec<Arc<DeviceSlot>>,
    shutdown: watch::Sender<bool>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
    started: Instant,
    /// What several devices share (a bus per port, an emulated service), alive as long as the
    /// runtime.
    pub shared: Shared,
    /// Every reader and writer on the devices' domain (its own thread; docs/discovery.md).
    pub discovery: Discovery,
    /// `[export]`: the clients' participant and its discovery; `None`: they share the devices'.
    pub export: Option<Export>,
    /// The `[record]` recorder (its own threads; never on a device path).
    recorder: Option<handgate_record::Recorder>,
    /// The latest status the status task computed (the dashboard, `/metrics`).
    pub status: watch::Receiver<Arc<handgate_idl::handgate::GatewayStatus_>>,
    /// The latest status extension (per front: command and state rates).
    pub status_ext: watch::Receiver<Arc<handgate_idl::handgate::GatewayStatusExt_>>,
    /// The `[foxglove]` live server (its own threads and runtime; never on a device path).
    #[cfg(feature = "foxglove")]
    live: Option<crate::live::Live>,
}

impl Runtime {
    /// Starts every device and front of `plan`. Must be called inside a tokio runtime.
    pub fn start(plan: &Plan) -> Result<Self, RuntimeError> {
        // `[realtime]`: checked (on a probe thread) before anything starts, so a missing
        // privilege stops the start naming it; the device loops apply it as they start.
        handgate_adapters::realtime::install(plan.realtime.clone())?;
        if let Err(already) = handgate_adapters::loops::configure_device_threads(plan.loop_threads) {
            // Only a process that started another gateway before (tests): its pool stays.
            tracing::warn!(
                loop_threads = plan.loop_threads,
                already,
                "device loops already run on {already} shared threads"
            );
        }
        let started = Instant::now();
        let node = Node::with_security(plan.domain, plan.interface.as_deref(), plan.security.as_ref())?;
        // Started first, so what is already on the domain is known by the time fronts open.
        let discovery = Discovery::start(&node, DiscoveryConfig::default())?;
        // `[export]`: the clients' side on a participant of its own, with its own discovery.
        let export = match &plan.export {
            Some(e) => {
                let n = Node::with_security(e.domain, e.interface.as_deref(), e.security.as_ref())?;
                let d = Discovery::start(&n, DiscoveryConfig::default())?;
                Some(Export { node: n, discovery: d })
            }
            None => None,
        };
        let (clients, clients_discovery) = match &export {
            Some(e) => (e.node.clone(), &e.discovery),
            None => (node.clone(), &discovery),
        };
        let env = FrontEnv {
            node: clients.clone(),
            discovery: clients_discovery.subscribe(),
            shared: Default::default(),
        };
        // Before any device opens, so a server that cannot listen stops the start without
        // touching hardware. Its DDS readers exist only while a client subscribes, by then
        // the fronts serve what it advertises.
        #[cfg(feature = "foxglove")]
        let live = start_live(&clients, plan)?;
        // Likewise the dashboard's port.
        let http_listener = plan.http.as_ref().map(crate::http::bind).transpose()?;
        let mut shared = Shared::default();
        let served = crate::diagnostics::served(plan);
        // The foreign-writer check's wait for discovery to settle runs on a thread of its own
        // while the devices open: neither needs the other, and the wait is most of a start.
        let (opened, settled) = std::thread::scope(|s| {
            let settling = refuses_foreign_writers(plan, &served).then(|| {
                std::thread::Builder::new()
                    .name("discovery-settle".into())
                    .spawn_scoped(s, || settle(clients_discovery, plan))
            });
            let opened = open_devices(&node, plan, &mut shared);
            tracing::debug!(
                since_start_ms = started.elapsed().as_millis() as u64,
                "start-up: devices open"
            );
            let settled = settling.map(|h| match h {
                Ok(h) => h.join().unwrap_or_else(|_| settle(clients_discovery, plan)),
                // No thread: the same wait on this one, after the devices.
                Err(_) => settle(clients_discovery, plan),
            });
            (opened, settled)
        });
        let opened = opened?;
        if let Some((snapshot, waited)) = settled {
            tracing::debug!(
                since_start_ms = started.elapsed().as_millis() as u64,
                waited_ms = waited.as_millis() as u64,
                participants = snapshot.participants.len(),
                endpoints = snapshot.endpoints.len(),
                "discovery settled"
            );
            check_foreign_state_writers(&snapshot, &served)?;
        }
        let mut devices = Vec::new();
        let mut by_name = HashMap::new();
        for (p, device) in plan.devices.iter().zip(opened) {
            let slot = Arc::new(DeviceSlot {
                plan: p.clone(),
                device,
                table: p.table.clone(),
                counters: Arc::new(FrontCounters::default()),
            });
            by_name.insert(p.name.clone(), slot.clone());
            devices.push(slot);
        }
        let (shutdown, shutdown_rx) = watch::channel(false);
        let mut tasks = Vec::new();
        let mut tallies = Vec::new();
        for f in &plan.fronts {
            let tally = Arc::new(status::FrontTally::new(f));
            tallies.push(tally.clone());
            tasks.push(fronts::spawn_front(
                &env,
                f,
                plan.allow_sources.as_ref(),
                &by_name,
                tally,
                shutdown_rx.clone(),
            )?);
        }
        let sides = match &export {
            // Each endpoint diagnosed on its own side: the fronts' on the clients', the
            // devices' on the robot's.
            Some(e) => {
                let (fronts, devices) = served
                    .iter()
                    .cloned()
                    .partition(|s| matches!(s.owner, crate::diagnostics::Owner::Front(_)));
                vec![(fronts, e.discovery.subscribe()), (devices, discovery.subscribe())]
            }
            None => vec![(served, discovery.subscribe())],
        };
        let (diag_task, diagnosis) = crate::diagnostics::spawn(sides, shutdown_rx.clone());
        tasks.push(diag_task);
        // Started after the fronts, so it subscribes what they serve.
        let recorder = match &plan.record {
            Some(r) => {
                let opts = crate::recording::options(&r.dir, r.max_mb, r.max_seconds, r.zstd);
                let rec = handgate_record::Recorder::start(&clients, crate::recording::topics(plan, &r.topics), opts)?;
                tracing::info!(dir = %r.dir.display(), topics = rec.topics.len(), "recording");
                Some(rec)
            }
            None => None,
        };
        let record_stats = recorder.as_ref().map(|r| r.stats());
        let (status_tx, status_rx) = watch::channel(Arc::new(handgate_idl::handgate::GatewayStatus_::default()));
        let (ext_tx, ext_rx) = watch::channel(Arc::new(handgate_idl::handgate::GatewayStatusExt_::default()));
        tasks.push(status::spawn_status(
            &clients,
            plan,
            devices.clone(),
            tallies,
            diagnosis,
            record_stats,
            status::StatusOut {
                latest: status_tx,
                latest_ext: ext_tx,
            },
            shutdown_rx.clone(),
        )?);
        if let (Some(h), Some(listener)) = (&plan.http, http_listener) {
            let mut fleet = crate::http::Fleet::new(plan, &devices, clients_discovery.subscribe(), status_rx.clone());
            fleet.status_ext = ext_rx.clone();
            if !h.fleet_domains.is_empty() {
                fleet.lab = Some(spawn_fleet_look(
                    plan,
                    &h.fleet_domains,
                    &clients,
                    clients_discovery,
                    shutdown_rx.clone(),
                ));
            }
            tasks.extend(crate::http::spawn(h, listener, fleet, &by_name, shutdown_rx.clone())?);
        }
        // The health messages are part of handgate's ROS presence (`[dds] ros_node`), on the
        // clients' side like the status; opened before the node is announced, which lists them.
        if crate::health::published(plan) {
            tasks.push(health::spawn_health(
                &clients,
                plan,
                status_rx.clone(),
                shutdown_rx.clone(),
            )?);
        }
        if let Some(ns) = &plan.namespace {
            tasks.push(ros::spawn_presence(&clients, ns.clone(), shutdown_rx.clone())?);
        }
        tracing::debug!(
            since_start_ms = started.elapsed().as_millis() as u64,
            "start-up: fronts open"
        );
        Ok(Self {
            node,
            devices,
            shutdown,
            tasks,
            started: Instant::now(),
            shared,
            discovery,
            export,
            recorder,
            status: status_rx,
            status_ext: ext_rx,
            #[cfg(feature = "foxglove")]
            live,
        })
    }

    pub fn uptime(&self) -> Duration {
        self.started.elapsed()
    }

    /// Safe state on every device (each device's configured safe action), then stop.
    pub async fn shutdown(mut self) -> Vec<(String, Result<(), DeviceError>)> {
        let _ = self.shutdown.send(true);
        for t in std::mem::take(&mut self.tasks) {
            let _ = t.await;
        }
        if let Some(rec) = self.recorder.take() {
            match tokio::task::spawn_blocking(move || rec.stop()).await {
                Ok(Ok(s)) => tracing::info!(
                    messages = s.messages,
                    dropped = s.dropped,
                    files = s.files.len(),
                    "recording finished"
                ),
                Ok(Err(e)) => tracing::warn!(error = %e, "recording not finished cleanly"),
                Err(e) => tracing::warn!(error = %e, "recording not finished cleanly"),
            }
        }
        #[cfg(feature = "foxglove")]
        if let Some(live) = self.live.take() {
            live.stop().await;
        }
        let mut out = Vec::new();
        let futs = self.devices.iter().map(|d| {
            let d = d.clone();
            async move {
                let r = tokio::time::timeout(SHUTDOWN_CONFIRM, d.device.shutdown(d.plan.safe_action)).await;
                (
                    d.plan.name.clone(),
                    r.unwrap_or(Err(DeviceError::NotConfirmed(SHUTDOWN_CONFIRM))),
                )
            }
        });
        for r in futures_join_all(futs).await {
            out.push(r);
        }
        out
    }
}

/// The `[foxglove]` live server. A profile with a `[foxglove]` section needs it: its failure
/// stops the start.
/// Without one (the defaults of a handgate built with the feature) a failure, such as the
/// port taken by another gateway, is a warning and the gateway runs without it.
#[cfg(feature = "foxglove")]
fn start_live(node: &Node, plan: &Plan) -> Result<Option<crate::live::Live>, RuntimeError> {
    let Some(f) = &plan.foxglove else {
        return Ok(None);
    };
    match crate::live::Live::start(node, plan, f) {
        Ok(l) => Ok(Some(l)),
        Err(e) if !f.required => {
            tracing::warn!(
                error = %e,
                "foxglove: not serving (no [foxglove] section in the profile: the gateway runs without it)"
            );
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// The fleet page's look (`[http] fleet_domains`), on a thread of its own (it blocks while it
/// listens): every few seconds, every gateway's status on those domains. The clients' domain
/// is looked on through the gateway's own participant there; the devices' domain (with
/// `[export]`: the robot's network) is not looked on; every other domain is joined on the
/// clients' interface. Ends on `shutdown`.
fn spawn_fleet_look(
    plan: &Plan,
    domains: &[u32],
    clients: &Node,
    clients_discovery: &Discovery,
    shutdown: watch::Receiver<bool>,
) -> watch::Receiver<Arc<crate::fleet::Fleet>> {
    let (tx, rx) = watch::channel(Arc::new(crate::fleet::Fleet::default()));
    let (clients_domain, interface) = plan.clients_side();
    let interface = interface.map(str::to_string);
    let own = (clients_domain, clients.clone(), clients_discovery.subscribe());
    let others: Vec<u32> = domains
        .iter()
        .copied()
        .filter(|d| *d != clients_domain && (plan.export.is_none() || *d != plan.domain))
        .collect();
    let look_own = domains.contains(&clients_domain);
    let spawned = std::thread::Builder::new().name("fleet-look".into()).spawn(move || {
        let (mut sides, _keep, errors) = crate::fleet::join(&others, interface.as_deref());
        if look_own {
            sides.insert(0, own);
        }
        while !*shutdown.borrow() {
            let mut f = crate::fleet::look_on(&sides, FLEET_LOOK);
            f.errors.extend(errors.iter().cloned());
            let _ = tx.send(Arc::new(f));
            let until = Instant::now() + FLEET_EVERY;
            while Instant::now() < until && !*shutdown.borrow() {
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    });
    if let Err(e) = spawned {
        tracing::warn!(error = %e, "http: no fleet page (its thread did not start)");
    }
    rx
}

/// How long each look of the fleet page listens, and how often it looks.
const FLEET_LOOK: Duration = Duration::from_secs(3);
const FLEET_EVERY: Duration = Duration::from_secs(2);

/// What other processes show on a domain: their participants and endpoints. This process's
/// own endpoints, which appear while its devices open, are not part of it.
fn others(s: &handgate_adapters::discovery::Snapshot) -> Vec<handgate_adapters::discovery::Guid> {
    s.participants
        .iter()
        .filter(|p| !p.origin.is_local())
        .map(|p| p.key)
        .chain(s.endpoints.iter().filter(|e| !e.origin.is_local()).map(|e| e.key))
        .collect()
}

/// Waits until discovery has settled (see [`Settle`]). Returns the snapshot and how long it
/// took.
fn settle(discovery: &Discovery, plan: &Plan) -> (Arc<handgate_adapters::discovery::Snapshot>, Duration) {
    let start = Instant::now();
    let mut s = Settle::new(
        &discovery.snapshot(),
        start,
        plan.discovery_settle,
        plan.discovery_max_wait,
    );
    loop {
        let left = s.deadline().saturating_duration_since(Instant::now());
        if left.is_zero() {
            break;
        }
        // Err: nothing changed within what is left of the settle time (or the cap came first).
        match discovery.wait_for(left, |snap| others(snap) != s.seen) {
            Ok(snap) => s.changed(&snap, Instant::now()),
            Err(_) => break,
        }
    }
    tracing::debug!(
        last_change_ms = s.quiet_from.duration_since(start).as_secs_f64() * 1e3,
        others = s.seen.len(),
        "discovery: the last change from other processes"
    );
    (discovery.snapshot(), start.elapsed())
}

/// Discovery has settled when what other processes show has been unchanged for `settle`, at
/// most `max_wait` in all, both counted from `start`. The quiet is counted from when discovery
/// read the last change (`Snapshot::changed_at`), not from when its snapshot came out (up to
/// its `min_publish_interval` later).
struct Settle {
    start: Instant,
    settle: Duration,
    cap: Instant,
    /// Other processes' participants and endpoints, as last seen.
    seen: Vec<handgate_adapters::discovery::Guid>,
    /// Quiet since: `start`, then each change of other processes' endpoints as it was read.
    quiet_from: Instant,
}

impl Settle {
    fn new(
        current: &handgate_adapters::discovery::Snapshot,
        start: Instant,
        settle: Duration,
        max_wait: Duration,
    ) -> Self {
        Self {
            start,
            settle,
            cap: start + max_wait,
            seen: others(current),
            quiet_from: start,
        }
    }

    /// Settled at this instant unless another change comes first.
    fn deadline(&self) -> Instant {
        (self.quiet_from + self.settle).min(self.cap)
    }

    /// A snapshot in which other processes' endpoints changed, taken at `now`.
    fn changed(&mut self, snap: &handgate_adapters::discovery::Snapshot, now: Instant) {
        self.seen = others(snap);
        self.quiet_from = snap.changed_at.map_or(now, |t| t.clamp(self.start, now));
    }
}

/// Whether the start waits for discovery to settle and refuses foreign state writers:
/// `dds.foreign_state_writers = "refuse"` and some front writes a topic.
fn refuses_foreign_writers(plan: &Plan, served: &[crate::diagnostics::ServedBy]) -> bool {
    use crate::profile::ForeignStateWriters;
    plan.foreign_state_writers == ForeignStateWriters::Refuse
        && served.iter().any(|s| {
            matches!(s.owner, crate::diagnostics::Owner::Front(_))
                && s.served.role == handgate_adapters::discovery::Role::Writer
        })
}

/// Before the fronts open, on the settled `snapshot`: another process already writing a state
/// topic a front would write refuses the start (`dds.foreign_state_writers = "refuse"`,
/// naming the topic and the process). With `"warn"` there is no check: the diagnostics task
/// flags such a writer in status.
fn check_foreign_state_writers(
    snapshot: &handgate_adapters::discovery::Snapshot,
    served: &[crate::diagnostics::ServedBy],
) -> Result<(), RuntimeError> {
    use crate::profile::ForeignStateWriters;
    let found = crate::diagnostics::foreign_state_writers(snapshot, served);
    if found.is_empty() {
        return Ok(());
    }
    let lines: Vec<String> = found
        .iter()
        .map(|f| {
            let who: Vec<String> = f.finding.remotes.iter().map(|r| r.who()).collect();
            format!(
                "{}: {} already has a writer in another process: {}",
                f.owner,
                f.finding.served_topic,
                who.join("; ")
            )
        })
        .collect();
    Err(RuntimeError::ForeignStateWriter(format!(
        "{}; stop the other source, or set [dds] foreign_state_writers = \"{}\" to start anyway",
        lines.join("; "),
        ForeignStateWriters::Warn
    )))
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

/// How long shutdown waits for each device to confirm its safe state.
const SHUTDOWN_CONFIRM: Duration = Duration::from_millis(500);

#[cfg(test)]
mod tests {
    use handgate_adapters::discovery::Origin::{Remote, ThisParticipant, ThisProcess};
    use handgate_adapters::discovery::Role;

    use crate::diagnostics::tests::snapshots::snap;

    #[test]
    fn the_settle_sees_other_processes_only() {
        // (`snap` keys an endpoint by its index: the remote reader comes first in each.)
        let before = snap(&[
            (3, Remote, Role::Reader, "rt/dex1/left/state", "t"),
            (1, ThisParticipant, Role::Writer, "rt/dex1/left/state", "t"),
        ]);
        // This process's devices open: its own endpoints and emulators' participants appear.
        let devices_opened = snap(&[
            (3, Remote, Role::Reader, "rt/dex1/left/state", "t"),
            (1, ThisParticipant, Role::Writer, "rt/dex1/left/state", "t"),
            (1, ThisParticipant, Role::Writer, "rt/handgate/emu/dex1_left/cmd", "t"),
            (2, ThisProcess, Role::Reader, "rt/handgate/emu/dex1_left/cmd", "t"),
        ]);
        assert_eq!(super::others(&before), super::others(&devices_opened));
        // Another process's writer is a change.
        let foreign = snap(&[
            (3, Remote, Role::Reader, "rt/dex1/left/state", "t"),
            (1, ThisParticipant, Role::Writer, "rt/dex1/left/state", "t"),
            (3, Remote, Role::Writer, "rt/dex1/left/state", "t"),
        ]);
        assert_ne!(super::others(&before), super::others(&foreign));
        assert_eq!(super::others(&foreign).len(), 3, "its participant and two endpoints");
    }

    #[test]
    fn only_a_command_only_front_is_not_told_its_devices_states() {
        let l = crate::profile::load(&crate::profile::LoadOptions {
            profile: Some(concat!(env!("CARGO_MANIFEST_DIR"), "/../profiles/sim-all.toml").into()),
            env: crate::profile::EnvLayer::Ignore,
            search_dirs: Some(vec![]),
            ..crate::profile::LoadOptions::default()
        })
        .unwrap();
        let plan = crate::resolve::plan(&l.profile).unwrap();
        let quiet: Vec<&str> = plan
            .fronts
            .iter()
            .filter(|f| !f.publishes_state())
            .map(|f| f.kind().as_str())
            .collect();
        assert_eq!(quiet, ["joint_state_command"]);
        assert!(plan.fronts.len() > 10, "sim-all serves every kind");
    }

    #[test]
    fn the_settle_counts_its_quiet_from_when_a_change_was_read() {
        use std::time::{Duration, Instant};
        let ms = Duration::from_millis;
        let t0 = Instant::now();
        let before = snap(&[(1, ThisParticipant, Role::Writer, "rt/dex1/left/state", "t")]);
        let mut s = super::Settle::new(&before, t0, ms(50), ms(1000));
        // Nothing changes: settled one settle time after the start.
        assert_eq!(s.deadline(), t0 + ms(50));
        // Another process's reader, read at 5 ms, in the snapshot published at 25 ms: quiet
        // since 5 ms, not since 25 ms.
        let mut seen = snap(&[
            (3, Remote, Role::Reader, "rt/dex1/left/state", "t"),
            (1, ThisParticipant, Role::Writer, "rt/dex1/left/state", "t"),
        ]);
        seen.changed_at = Some(t0 + ms(5));
        s.changed(&seen, t0 + ms(25));
        assert_eq!(s.deadline(), t0 + ms(55));
        // A change read before the wait began counts from the start; a snapshot without the
        // time (none read yet) from when it was seen; a stamp is never taken as later than
        // when the snapshot was seen.
        seen.changed_at = Some(t0.checked_sub(ms(3)).unwrap_or(t0));
        s.changed(&seen, t0 + ms(30));
        assert_eq!(s.deadline(), t0 + ms(50));
        seen.changed_at = None;
        s.changed(&seen, t0 + ms(40));
        assert_eq!(s.deadline(), t0 + ms(90));
        seen.changed_at = Some(t0 + ms(70));
        s.changed(&seen, t0 + ms(60));
        assert_eq!(s.deadline(), t0 + ms(110));
        // Never past the cap.
        let mut capped = super::Settle::new(&before, t0, ms(50), ms(60));
        seen.changed_at = Some(t0 + ms(40));
        capped.changed(&seen, t0 + ms(45));
        assert_eq!(capped.deadline(), t0 + ms(60));
    }
}
