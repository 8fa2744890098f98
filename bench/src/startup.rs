//! Start-up: from `handgate run` (the process spawned) to every device of a profile fresh,
//! and to the first state sample on each front's state topic.
//!
//! The topics come from the profile as the gateway resolves it (`recording::live_topics`: each
//! front's state topic, the canonical states, `rt/joint_states`). Every device's freshness is
//! read from its canonical state (`rt/handgate/<device>/state`); every other front state topic
//! through a reader of its own wire type. Every reader exists before the spawn, and each time
//! is taken in the reader's DDS listener when the sample arrives, so the figures are the
//! gateway's (and DDS discovery's), not a poll's.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::handgate::{HandState_, STALE};
use handgate_idl::{handgate, inspire, ros2, unitree_go, unitree_hg, DdsTypeName, TopicType};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StartupResult {
    pub profile: String,
    pub runs: usize,
    /// Per run: spawn → the `handgate serving` log line, ms.
    pub serving_ms: Vec<f64>,
    /// Per run: spawn → every device fresh (its canonical state not stale), ms.
    pub all_fresh_ms: Vec<f64>,
    /// Per run: spawn → a first state on every front's state topic, ms.
    pub all_fronts_ms: Vec<f64>,
    /// Of the last run: spawn → the first sample, per topic, ms.
    pub per_topic_ms: BTreeMap<String, f64>,
    /// Of the last run: spawn → fresh, per device, ms.
    pub per_device_ms: BTreeMap<String, f64>,
    pub load_start: [f64; 3],
    pub load_end: [f64; 3],
}

fn epoch_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// One start's times, ms after the spawn: `handgate serving`, every device fresh, every front
/// topic with a sample, per topic, per device.
type Once = (f64, f64, f64, BTreeMap<String, f64>, BTreeMap<String, f64>);

/// One start of `bin` on `profile` (a name or path) on `domain`.
fn once(bin: &std::path::Path, profile: &str, domain: u32, timeout: Duration) -> anyhow::Result<Once> {
    let loaded = handgate_gateway::profile::load(&handgate_gateway::profile::LoadOptions {
        profile: Some(profile.to_string()),
        ..Default::default()
    })
    .map_err(|e| anyhow::anyhow!("{}", e.lines().join("; ")))?;
    let plan = handgate_gateway::resolve::plan(&loaded.profile)
        .map_err(|e| anyhow::anyhow!("{}", e.iter().map(|x| x.to_string()).collect::<Vec<_>>().join("; ")))?;
    let devices: Vec<String> = plan.devices.iter().map(|d| d.name.clone()).collect();
    let canonical = |d: &str| format!("rt/handgate/{d}/state");
    let topics: Vec<_> = handgate_gateway::recording::live_topics(&plan, &[])
        .into_iter()
        .filter(|t| t.dds_topic != "rt/handgate/status" && !t.dds_topic.contains("/emu/"))
        // The health messages (`rt/diagnostics`, `rt/hardware_status`) follow the status
        // (1 Hz), not a front: they are no front's state.
        .filter(|t| {
            t.dds_type != <ros2::DiagnosticArray_ as DdsTypeName>::DDS_TYPE_NAME
                && t.dds_type != <ros2::HardwareStatus_ as DdsTypeName>::DDS_TYPE_NAME
        })
        .filter(|t| !devices.iter().any(|d| canonical(d) == t.dds_topic))
        .collect();
    let node = Node::new(domain, None)?;
    let first: Arc<Mutex<BTreeMap<usize, u64>>> = Arc::default();
    let mut keep: Vec<Box<dyn std::any::Any>> = Vec::new();
    for (i, t) in topics.iter().enumerate() {
        keep.push(first_sample(&node, &t.dds_topic, &t.dds_type, i, first.clone())?);
    }
    let fresh: Arc<Mutex<BTreeMap<String, u64>>> = Arc::default();
    let mut readers = Vec::new();
    for d in &devices {
        let fr = fresh.clone();
        let name = d.clone();
        readers.push(
            node.reader_with_callback::<HandState_, _>(&canonical(d), Qos::BestEffort, move |h| {
                let now = epoch_ns();
                let mut v = Vec::new();
                h.take_into(&mut v);
                if v.iter().any(|s| s.freshness != STALE) {
                    fr.lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .entry(name.clone())
                        .or_insert(now);
                }
            })?,
        );
    }
    let t0 = epoch_ns();
    let gw = crate::gateway(bin, domain, None, Some(std::path::Path::new(profile)))?;
    let serving = (epoch_ns() - t0) as f64 / 1e6;
    let end = Instant::now() + timeout;
    loop {
        let nf = fresh.lock().unwrap_or_else(|e| e.into_inner()).len();
        let nt = first.lock().unwrap_or_else(|e| e.into_inner()).len();
        if nf == devices.len() && nt == topics.len() {
            break;
        }
        anyhow::ensure!(
            Instant::now() < end,
            "start-up: {nf}/{} devices fresh, {nt}/{} front topics with a sample after {timeout:?}",
            devices.len(),
            topics.len()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    gw.stop();
    drop(keep);
    drop(readers);
    let ms = |t: u64| t.saturating_sub(t0) as f64 / 1e6;
    let per_device: BTreeMap<String, f64> = fresh
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .map(|(d, t)| (d.clone(), ms(*t)))
        .collect();
    let per_topic: BTreeMap<String, f64> = first
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .map(|(i, t)| (topics[*i].dds_topic.clone(), ms(*t)))
        .collect();
    let all_fresh = per_device.values().copied().fold(0.0, f64::max);
    let all_fronts = per_topic.values().copied().fold(0.0, f64::max);
    Ok((serving, all_fresh, all_fronts, per_topic, per_device))
}

/// A best-effort reader of `topic` (DDS type `dds_type`, one of the wire types the fronts
/// write) whose listener puts the arrival time of its first sample at `index` in `first`.
/// Returned boxed: it only has to live as long as the measurement.
fn first_sample(
    node: &Node,
    topic: &str,
    dds_type: &str,
    index: usize,
    first: Arc<Mutex<BTreeMap<usize, u64>>>,
) -> anyhow::Result<Box<dyn std::any::Any>> {
    fn typed<T: TopicType + Clone + 'static>(
        node: &Node,
        topic: &str,
        index: usize,
        first: Arc<Mutex<BTreeMap<usize, u64>>>,
    ) -> anyhow::Result<Box<dyn std::any::Any>> {
        let reader = node.reader_with_callback::<T, _>(topic, Qos::BestEffort, move |h| {
            let now = epoch_ns();
            let mut v = Vec::new();
            h.take_into(&mut v);
            if !v.is_empty() {
                first
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .entry(index)
                    .or_insert(now);
            }
        })?;
        Ok(Box::new(reader))
    }
    macro_rules! by_type {
        ($($ty:ty),* $(,)?) => {
            $(if dds_type == <$ty as DdsTypeName>::DDS_TYPE_NAME {
                return typed::<$ty>(node, topic, index, first);
            })*
        };
    }
    by_type!(
        unitree_hg::HandState_,
        unitree_go::MotorStates_,
        handgate::HandState_,
        ros2::JointState_,
        inspire::InspireHandState,
        inspire::InspireHandTouch,
    );
    anyhow::bail!("start-up: {topic}: no reader for type {dds_type}")
}

/// `runs` starts of `bin` on `profile`, one after the other.
pub fn run(bin: &std::path::Path, profile: &str, domain: u32, runs: usize) -> anyhow::Result<StartupResult> {
    let load_start = crate::stats::loadavg();
    let mut r = StartupResult {
        profile: profile.into(),
        runs,
        serving_ms: Vec::new(),
        all_fresh_ms: Vec::new(),
        all_fronts_ms: Vec::new(),
        per_topic_ms: BTreeMap::new(),
        per_device_ms: BTreeMap::new(),
        load_start,
        load_end: load_start,
    };
    for i in 0..runs {
        let (s, f, t, topics, devices) = once(bin, profile, domain, Duration::from_secs(30))?;
        eprintln!("startup run {i}: serving {s:.0} ms, all fresh {f:.0} ms, every front {t:.0} ms");
        r.serving_ms.push(s);
        r.all_fresh_ms.push(f);
        r.all_fronts_ms.push(t);
        r.per_topic_ms = topics;
        r.per_device_ms = devices;
    }
    r.load_end = crate::stats::loadavg();
    Ok(r)
}
