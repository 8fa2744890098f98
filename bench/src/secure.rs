//! `handgate-bench secure-hop` (docs/benchmarks.md §3c): what DDS Security adds to the export
//! hop. The default profile's emulated hands, the fronts on an export domain of their own; a
//! Rust client on that domain times `HandCmd_` → the `HandState_` reflecting it, as
//! `handgate-bench hop` does. Plain and secured (`[export.security]`, the client joining with
//! an operator identity of the same lab keystore) alternate in one run, twice each, so both are
//! measured on the same machine in the same minutes.

use std::path::{Path, PathBuf};
use std::process::Command;

use handgate_adapters::dds::Node;
use handgate_adapters::dds_security::Security;

use crate::hop::{self, HopResult};

/// The lab keystore for the run: a CA, the robot's gateway identity and an operator's, both
/// granted `domain`, made by `handgate security` itself.
fn keystore(handgate: &Path, dir: &Path, domain: u32) -> anyhow::Result<PathBuf> {
    let ks = dir.join("keystore");
    let run = |args: &[&str]| -> anyhow::Result<()> {
        let out = Command::new(handgate).arg("security").args(args).output()?;
        anyhow::ensure!(
            out.status.success(),
            "handgate security {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        Ok(())
    };
    let k = ks.to_string_lossy().into_owned();
    let d = domain.to_string();
    run(&["init", "--keystore", &k])?;
    run(&["issue", "--keystore", &k, "robot", "--role", "gateway", "--robot", &d])?;
    run(&[
        "issue",
        "--keystore",
        &k,
        "operator",
        "--role",
        "operator",
        "--robot",
        &d,
    ])?;
    Ok(ks)
}

#[allow(clippy::too_many_arguments)]
pub fn run(
    handgate: &Path,
    repo: &Path,
    export_domain: u32,
    devices_domain: u32,
    rates: &[f64],
    samples: usize,
    warmup: usize,
    rounds: usize,
) -> anyhow::Result<Vec<HopResult>> {
    let dir = std::env::temp_dir().join(format!("handgate-secure-hop-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let ks = keystore(handgate, &dir, export_domain)?;
    let base = std::fs::read_to_string(repo.join("profiles/default.toml"))?;
    let plain = base.clone() + &format!("\n[export]\ndomain = {export_domain}\n");
    let secure = plain.clone()
        + &format!(
            "\n[export.security]\nenclave = \"{}\"\n",
            ks.join("enclaves/robot").display()
        );
    let (plain_p, secure_p) = (dir.join("plain.toml"), dir.join("secure.toml"));
    std::fs::write(&plain_p, plain)?;
    std::fs::write(&secure_p, secure)?;
    let operator = Security::from_enclave(&ks.join("enclaves/operator"), None);
    let (cmd_t, st_t) = ("rt/dex3/left/cmd", "rt/dex3/left/state");
    let mut results = Vec::new();
    for round in 0..rounds.max(1) {
        for (label, profile, identity) in [
            ("export, plain", &plain_p, None),
            ("export, DDS Security", &secure_p, Some(&operator)),
        ] {
            let gw = crate::gateway(handgate, devices_domain, None, Some(profile))?;
            let node = Node::with_security(export_domain, None, identity)?;
            for &rate in rates {
                let r = hop::client(&node, label, cmd_t, st_t, rate, samples, warmup, gw.pid())?;
                eprintln!("secure-hop: round {round}: {r:?}");
                results.push(r);
            }
            drop(node);
            gw.stop();
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(results)
}

/// docs/benchmarks.md §3c from `secure_hop.json`: every run's row, and per rate the secured
/// hop over the plain one (medians and p99 pooled per variant: the median of the rounds').
pub fn report_section(
    results: &Path,
    repo: &Path,
    body: &mut String,
    summary: &mut Vec<(String, String, String, &'static str)>,
) {
    use crate::report::{notes, read, us};
    use std::fmt::Write as _;
    body.push_str("\n### 3c. The export hop with DDS Security\n\n");
    body.push_str(
        "`handgate-bench secure-hop`: the default profile's emulated hands with the fronts on an export \
         domain of their own (`[export] domain = 109`), the hop of §3 measured there by a Rust client \
         on that domain: plain, then with `[export.security]` (the robot's gateway identity) and the \
         client joining as an operator identity of the same keystore (`handgate security`: ECDSA P-256, \
         discovery, liveliness and data encrypted, docs/security.md), alternating, twice each, in one \
         run on the same machine.\n\n",
    );
    let Some(v) = read::<Vec<HopResult>>(results, "secure_hop.json").filter(|v| !v.is_empty()) else {
        body.push_str("Not measured in this run.\n");
        notes(repo, "secure", body);
        return;
    };
    body.push_str(
        "| path | command rate | sent | echoed | median | p90 | p99 | max | gateway CPU (% core) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &v {
        let _ = writeln!(body, "| {} | {:.0} |", r.cells(), r.peer_cpu_pct);
    }
    body.push_str(
        "\nWhat DDS Security adds (same run; each figure the median over the rounds of that variant):\n\n\
         | command rate | plain median | secured median | added, median | plain p99 | secured p99 | added, p99 | secured / plain, median | secured / plain, p99 |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let mut rates: Vec<f64> = v.iter().map(|r| r.rate_hz).collect();
    rates.sort_by(f64::total_cmp);
    rates.dedup();
    let med = |mut xs: Vec<f64>| -> Option<f64> {
        xs.sort_by(f64::total_cmp);
        (!xs.is_empty()).then(|| xs[(xs.len() - 1) / 2])
    };
    for rate in rates {
        let pick = |label: &str, f: fn(&crate::stats::Summary) -> f64| {
            med(v
                .iter()
                .filter(|r| r.target == label && r.rate_hz == rate)
                .filter_map(|r| r.latency_us.as_ref().map(f))
                .collect())
        };
        let (Some(p50), Some(s50), Some(p99), Some(s99)) = (
            pick("export, plain", |s| s.median),
            pick("export, DDS Security", |s| s.median),
            pick("export, plain", |s| s.p99),
            pick("export, DDS Security", |s| s.p99),
        ) else {
            continue;
        };
        let _ = writeln!(
            body,
            "| {rate:.0} Hz | {} | {} | {} | {} | {} | {} | {:.2}× | {:.2}× |",
            us(p50),
            us(s50),
            us(s50 - p50),
            us(p99),
            us(s99),
            us(s99 - p99),
            s50 / p50,
            s99 / p99
        );
        summary.push((
            format!("export hop at {rate:.0} Hz: added by DDS Security, median / p99"),
            format!("{} / {}", us(s50 - p50), us(s99 - p99)),
            "measured".into(),
            "",
        ));
    }
    notes(repo, "secure", body);
}
