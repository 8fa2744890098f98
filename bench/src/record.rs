//! The recorder's cost: `handgate record` of every topic of the default fleet (all fronts at
//! their rates) as a separate process beside a release gateway: the recorder's CPU, the file
//! size, the write throughput and the drops.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::child;
use crate::stats::{cpu_seconds, status_kb};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordResult {
    pub secs: f64,
    pub domain: u32,
    pub topics: usize,
    pub messages: u64,
    pub dropped: u64,
    pub files: usize,
    pub file_bytes: u64,
    /// Recorder CPU over the measuring window, % of one core.
    pub cpu_pct: f64,
    /// The gateway's CPU over the same window, % of one core (for scale).
    pub gateway_cpu_pct: f64,
    pub rss_mb: f64,
    pub msgs_per_s: f64,
    pub mb_per_s: f64,
}

/// A `key: value` of metadata.yaml (first occurrence).
fn yaml_value(text: &str, key: &str) -> Option<String> {
    text.lines().find_map(|l| {
        l.trim()
            .strip_prefix(key)?
            .strip_prefix(':')
            .map(|v| v.trim().trim_matches('"').to_string())
    })
}

pub fn measure(handgate: &Path, gateway_pid: u32, domain: u32, secs: f64, dir: &Path) -> anyhow::Result<RecordResult> {
    let _ = std::fs::remove_dir_all(dir);
    let mut c = Command::new(handgate);
    c.arg("record").arg(dir).args(["--domain", &domain.to_string()]);
    let rec = child::Proc::start("handgate record", c, "recording", Duration::from_secs(60))?;
    // Warm-up: every reader matched and the stream steady.
    std::thread::sleep(Duration::from_secs(3));
    let (c0, g0, t0) = (
        cpu_seconds(rec.pid()).unwrap_or(0.0),
        cpu_seconds(gateway_pid).unwrap_or(0.0),
        Instant::now(),
    );
    std::thread::sleep(Duration::from_secs_f64(secs));
    let (c1, g1, dt) = (
        cpu_seconds(rec.pid()).unwrap_or(0.0),
        cpu_seconds(gateway_pid).unwrap_or(0.0),
        t0.elapsed().as_secs_f64(),
    );
    let rss_mb = status_kb(rec.pid(), "VmRSS").unwrap_or(0.0) / 1024.0;
    rec.stop();
    let meta = std::fs::read_to_string(dir.join("metadata.yaml"))?;
    let messages: u64 = yaml_value(&meta, "message_count")
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let dropped: u64 = yaml_value(&meta, "handgate.dropped_messages")
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let duration_ns: f64 = meta
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("duration:"))
        .nth(1)
        .and_then(|l| yaml_value(l, "nanoseconds"))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    let topics = meta.matches("- topic_metadata:").count();
    let mut files = 0;
    let mut file_bytes = 0;
    for e in std::fs::read_dir(dir)? {
        let p = e?.path();
        if p.extension().is_some_and(|x| x == "mcap") {
            files += 1;
            file_bytes += std::fs::metadata(&p)?.len();
        }
    }
    let span = (duration_ns / 1e9).max(1e-9);
    Ok(RecordResult {
        secs: dt,
        domain,
        topics,
        messages,
        dropped,
        files,
        file_bytes,
        cpu_pct: (c1 - c0) / dt * 100.0,
        gateway_cpu_pct: (g1 - g0) / dt * 100.0,
        rss_mb,
        msgs_per_s: messages as f64 / span,
        mb_per_s: file_bytes as f64 / 1e6 / span,
    })
}
