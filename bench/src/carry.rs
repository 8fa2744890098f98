//! A `make bench` subset (`BENCH_ONLY=...`) keeps every other section: the raw results of the
//! sections it did not run are carried from the last report's raw directory
//! (`docs/benchmarks/raw/`) into this run's results, with the date and load of the run that
//! measured them (`runs.json`), so the report keeps them, marked as carried, and the raw
//! directory keeps the union.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::report::{read, Machine};

/// Each section of `scripts/bench.sh` (its `BENCH_ONLY` name) and the files it writes into the
/// results directory. One home for this list: the report and the carry both read it.
pub const SECTIONS: &[(&str, &[&str])] = &[
    (
        "codec",
        &[
            "codec_dex3.json",
            "codec_ezgripper.json",
            "ezgripper.md",
            "leap.md",
            "robotiq.md",
        ],
    ),
    ("loop", &["loop.json"]),
    ("busy", &["busy.json"]),
    ("hop", &["hop.json", "hop_min_gap_100.toml"]),
    ("shim", &["shim.json", "shim.toml"]),
    ("secure", &["secure_hop.json"]),
    (
        "fleet",
        &["fleet.json", "fleet_own.json", "fleet.toml", "fleet_own.toml"],
    ),
    ("simall", &["simall.json"]),
    ("startup", &["startup.json"]),
    ("timers", &["timers.json"]),
    ("rh56", &["rh56.json"]),
    ("record", &["record.json"]),
    ("dashboard", &["dashboard.json"]),
];

/// Which run measured a section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measured {
    /// The run's date (UTC), as in its `machine.json`.
    pub date: String,
    /// The load average 1/5/15 min at the start of that run.
    pub load_start: [f64; 3],
    /// Carried from an earlier run (not measured by the run whose report this is).
    pub carried: bool,
}

/// Per section name, the run that measured it (`runs.json` in a results directory).
pub type Runs = BTreeMap<String, Measured>;

/// The file that records which run measured each section.
pub const RUNS_FILE: &str = "runs.json";

/// The runs of a results directory: its `runs.json`, or (a directory written before the
/// carry existed, or by a full run) every section with a file there measured by the run of
/// its `machine.json`.
pub fn runs_of(dir: &Path) -> Runs {
    if let Some(r) = read::<Runs>(dir, RUNS_FILE) {
        return r;
    }
    let Some(m) = read::<Machine>(dir, "machine.json") else {
        return Runs::new();
    };
    SECTIONS
        .iter()
        .filter(|(_, files)| files.iter().any(|f| dir.join(f).exists()))
        .map(|(name, _)| {
            (
                name.to_string(),
                Measured {
                    date: m.date.clone(),
                    load_start: m.load_start,
                    carried: false,
                },
            )
        })
        .collect()
}

/// Completes `results` (this run's, with its `machine.json`) from `raw` (the last report's):
/// every section not in `measured` whose files are in `raw` is copied in and recorded as
/// carried from the run that measured it; writes `runs.json`. Returns the runs.
pub fn carry(raw: &Path, results: &Path, measured: &[String]) -> anyhow::Result<Runs> {
    let this = read::<Machine>(results, "machine.json")
        .ok_or_else(|| anyhow::anyhow!("{}: no machine.json", results.display()))?;
    let before = runs_of(raw);
    let mut runs = Runs::new();
    for (name, files) in SECTIONS {
        if measured.iter().any(|m| m == name) {
            runs.insert(
                name.to_string(),
                Measured {
                    date: this.date.clone(),
                    load_start: this.load_start,
                    carried: false,
                },
            );
            continue;
        }
        let Some(then) = before.get(*name) else { continue };
        let mut copied = 0;
        for f in *files {
            let from = raw.join(f);
            if from.exists() && !results.join(f).exists() {
                std::fs::copy(&from, results.join(f))?;
                copied += 1;
            }
        }
        if copied > 0 {
            runs.insert(
                name.to_string(),
                Measured {
                    carried: true,
                    ..then.clone()
                },
            );
        }
    }
    std::fs::write(results.join(RUNS_FILE), serde_json::to_string_pretty(&runs)?)?;
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(dir: &Path, date: &str, load: f64) {
        let m = Machine {
            date: date.into(),
            load_start: [load, load, load],
        };
        std::fs::write(dir.join("machine.json"), serde_json::to_string(&m).unwrap()).unwrap();
    }

    #[test]
    fn a_subset_carries_the_other_sections_with_the_run_that_measured_them() {
        let tmp = std::env::temp_dir().join(format!("handgate-carry-{}", std::process::id()));
        let (raw, first, second) = (tmp.join("raw"), tmp.join("first"), tmp.join("second"));
        for d in [&raw, &first, &second] {
            std::fs::create_dir_all(d).unwrap();
        }
        // The last full run, written before runs.json existed.
        machine(&raw, "2026-11-24 23:27", 1.33);
        for f in ["hop.json", "startup.json", "shim.json", "shim.toml"] {
            std::fs::write(raw.join(f), format!("old {f}")).unwrap();
        }
        // A startup-only run.
        machine(&first, "2026-11-27 05:30", 2.5);
        std::fs::write(first.join("startup.json"), "new").unwrap();
        let runs = carry(&raw, &first, &["startup".into()]).unwrap();
        assert_eq!(std::fs::read_to_string(first.join("startup.json")).unwrap(), "new");
        assert_eq!(
            std::fs::read_to_string(first.join("shim.toml")).unwrap(),
            "old shim.toml"
        );
        assert!(!runs["startup"].carried);
        assert_eq!(runs["startup"].date, "2026-11-27 05:30");
        assert!(runs["hop"].carried);
        assert_eq!(runs["hop"].date, "2026-11-24 23:27");
        assert_eq!(runs["hop"].load_start[0], 1.33);
        assert!(!runs.contains_key("loop"), "no section out of nothing");
        // The next subset carries from that union: the dates stay those of the measuring runs.
        machine(&second, "2026-11-27 06:00", 0.5);
        std::fs::write(second.join("hop.json"), "newer").unwrap();
        let runs = carry(&first, &second, &["hop".into()]).unwrap();
        assert_eq!(runs["startup"].date, "2026-11-27 05:30");
        assert!(runs["startup"].carried);
        assert_eq!(runs["shim"].date, "2026-11-24 23:27");
        assert!(!runs["hop"].carried);
        assert_eq!(runs_of(&second), runs);
        let _ = std::fs::remove_dir_all(&tmp);
    }

    #[test]
    fn every_file_has_one_section() {
        let mut all: Vec<&str> = SECTIONS.iter().flat_map(|(_, f)| f.iter().copied()).collect();
        let n = all.len();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), n);
    }
}
