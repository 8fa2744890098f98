//! Benchmark 2b: the Dex3 USB device loop while endpoint discovery runs on a busy domain.
//!
//! The process does what the gateway does: one participant with [`Discovery`] on it (its own
//! thread) and a device loop at 1 kHz on the in-process MCU emulator. The loop runs four
//! times for the same duration: with the domain quiet; with another process holding K
//! endpoints and churning C of them a second (`busy_domain` example: discovery keeps
//! working); busy still but with discovery stopped (what the busy domain costs without
//! handgate's discovery: CycloneDDS's own endpoint matching and the other process's CPU);
//! quiet again (so drift in the machine's load shows).

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::discovery::{Discovery, DiscoveryConfig};
use serde::{Deserialize, Serialize};

use crate::device_loop::{self, LoopResult};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BusyResult {
    pub domain: u32,
    /// The loop configuration (`handgate-bench loop` names).
    pub config: String,
    pub endpoints: usize,
    pub churn_per_s: usize,
    /// Quiet, busy, busy without discovery, quiet again.
    pub quiet: LoopResult,
    pub busy: LoopResult,
    pub busy_no_discovery: LoopResult,
    pub quiet_after: LoopResult,
    /// Remote endpoints discovery listed when the busy phase started, and the snapshots it
    /// published during it.
    pub seen_at_start: usize,
    pub snapshots_during_busy: u64,
    /// Endpoints the busy process deleted and re-created during its phase.
    pub churned: usize,
    pub dropped_endpoints: u64,
    pub bad_samples: u64,
    /// Load average when each phase ended.
    pub load: [[f64; 3]; 4],
}

pub fn run(
    secs: f64,
    endpoints: usize,
    churn: usize,
    domain: u32,
    busy_exe: &Path,
    config: &str,
) -> anyhow::Result<BusyResult> {
    let node = Node::new(domain, None)?;
    let disc = Discovery::start(&node, DiscoveryConfig::default())?;
    let (spin, fifo, slack) = device_loop::by_name(config)?;
    let phase = |label: &str| {
        device_loop::run(
            &format!("{label} ({config})"),
            secs,
            spin,
            fifo,
            slack,
            Default::default(),
            None,
        )
    };
    let quiet = phase("quiet domain")?;
    let l0 = crate::stats::loadavg();

    let mut child = Command::new(busy_exe)
        .args([domain.to_string(), endpoints.to_string(), churn.to_string()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| anyhow::anyhow!("cannot start {}: {e}", busy_exe.display()))?;
    let mut lines = BufReader::new(child.stdout.take().expect("piped")).lines();
    match lines.next() {
        Some(Ok(l)) if l.starts_with("READY") => {}
        other => anyhow::bail!("busy_domain did not get ready: {other:?}"),
    }
    let remote = |s: &handgate_adapters::discovery::Snapshot| s.remote_endpoints().count();
    let s0 = disc
        .wait_for(Duration::from_secs(60), |s| remote(s) >= endpoints)
        .map_err(|_| anyhow::anyhow!("discovery did not list {endpoints} remote endpoints within 60 s"))?;
    let t0 = Instant::now();
    let busy = phase(&format!("{endpoints} remote endpoints, {churn}/s churned"))?;
    let s1 = disc.snapshot();
    let l1 = crate::stats::loadavg();
    eprintln!("busy phase: {:.1} s", t0.elapsed().as_secs_f64());
    drop(disc);
    let busy_no_discovery = phase(&format!(
        "{endpoints} remote endpoints, {churn}/s churned, discovery stopped"
    ))?;
    let l2 = crate::stats::loadavg();
    drop(child.stdin.take()); // busy_domain exits when stdin closes
    let churned = lines
        .find_map(|l| l.ok()?.strip_prefix("CHURNED ")?.trim().parse().ok())
        .unwrap_or(0);
    let _ = child.wait();
    let quiet_after = phase("quiet domain again, discovery stopped")?;
    let l3 = crate::stats::loadavg();
    Ok(BusyResult {
        domain,
        config: config.into(),
        endpoints,
        churn_per_s: churn,
        quiet,
        busy,
        busy_no_discovery,
        quiet_after,
        seen_at_start: remote(&s0),
        snapshots_during_busy: s1.generation.saturating_sub(s0.generation),
        churned,
        dropped_endpoints: s1.counters.dropped_endpoints,
        bad_samples: s1.counters.bad_samples,
        load: [l0, l1, l2, l3],
    })
}
