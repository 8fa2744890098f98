//! Collects criterion's per-sample measurements (`<target>/criterion/*/new/sample.json`)
//! written since a given time: per-iteration time of each of criterion's samples.

use std::path::Path;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::stats::Summary;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CodecResult {
    pub id: String,
    /// Per-iteration time over criterion's samples, ns.
    pub ns: Summary,
}

#[derive(Deserialize)]
struct Sample {
    iters: Vec<f64>,
    times: Vec<f64>,
}

#[derive(Deserialize)]
struct Bench {
    full_id: String,
}

pub fn collect(dir: &Path, since_epoch_s: u64) -> anyhow::Result<Vec<CodecResult>> {
    let since = UNIX_EPOCH + Duration::from_secs(since_epoch_s);
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(out);
    };
    for e in entries.flatten() {
        let new = e.path().join("new");
        let sample = new.join("sample.json");
        let Ok(meta) = std::fs::metadata(&sample) else { continue };
        if meta.modified().unwrap_or(SystemTime::UNIX_EPOCH) < since {
            continue;
        }
        let s: Sample = serde_json::from_str(&std::fs::read_to_string(&sample)?)?;
        let b: Bench = serde_json::from_str(&std::fs::read_to_string(new.join("benchmark.json"))?)?;
        let per: Vec<f64> = s.iters.iter().zip(&s.times).map(|(i, t)| t / i.max(1.0)).collect();
        if let Some(ns) = Summary::of(&per) {
            out.push(CodecResult { id: b.full_id, ns });
        }
    }
    out.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(out)
}
