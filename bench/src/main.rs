//! `handgate-bench`: the benchmarks `make bench` runs (`scripts/bench.sh`), each writing JSON,
//! and the report that turns them into docs/benchmarks.md. See docs/benchmarks.md.

mod busy;
mod carry;
mod child;
mod criterion;
mod device_loop;
mod fleet;
mod fleet_ref;
mod hop;
mod record;
mod report;
mod rh56;
mod secure;
mod shim;
mod startup;
mod stats;
mod timers;

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use clap::{Parser, Subcommand};
use handgate_adapters::dds::Node;

#[derive(Debug, Parser)]
#[command(name = "handgate-bench", about = "handgate benchmarks (make bench)")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Record the date and load average at the start of a run.
    Machine {
        #[arg(long)]
        out: PathBuf,
    },
    /// The Dex3 USB device loop on the emulator, per configuration.
    Loop {
        #[arg(long, default_value_t = 60.0)]
        secs: f64,
        /// Configurations, in order: default, fifo (SCHED_FIFO 50: needs root or
        /// CAP_SYS_NICE), spin0, slack (spin 0, timer slack 1 ns), slack-spin.
        #[arg(long, value_delimiter = ',', default_value = "default")]
        configs: Vec<String>,
        /// Alignment modes to run each configuration with: off, early[:MIN_GAP_US],
        /// phase[:MAX_SHIFT_US] (docs/dex3-usb.md, "Aligning the exchange to commands").
        #[arg(long, value_delimiter = ',', default_value = "off")]
        aligns: Vec<String>,
        /// Feed the loop commands at this rate (each at a random point of its period, as the
        /// hop client does); none by default.
        #[arg(long)]
        cmd_hz: Option<f64>,
        #[arg(long)]
        out: PathBuf,
    },
    /// The device loop while discovery runs on a busy domain (quiet, busy, quiet again).
    Busy {
        #[arg(long, default_value_t = 30.0)]
        secs: f64,
        /// Remote endpoints the busy process holds.
        #[arg(long, default_value_t = 500)]
        endpoints: usize,
        /// Endpoints it deletes and re-creates every second.
        #[arg(long, default_value_t = 50)]
        churn: usize,
        #[arg(long, default_value_t = 114)]
        domain: u32,
        /// Loop configurations (as for `loop`), each a full run of the four phases.
        #[arg(long, value_delimiter = ',', default_value = "default")]
        configs: Vec<String>,
        /// The `busy_domain` example binary (adapters/examples/busy_domain.rs).
        #[arg(long)]
        busy_domain: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// The end-to-end hop against the floor, handgate and the Python relay.
    Hop {
        #[arg(long)]
        handgate: PathBuf,
        /// The venv interpreter with unitree_sdk2py (skip the relay when absent).
        #[arg(long)]
        python: Option<PathBuf>,
        #[arg(long)]
        relay: PathBuf,
        #[arg(long, value_delimiter = ',', default_value = "200,1000")]
        rates: Vec<f64>,
        #[arg(long, default_value_t = 2000)]
        samples: usize,
        #[arg(long, default_value_t = 200)]
        warmup: usize,
        /// Domains: base (handgate), base+1 (floor), base+2 (relay), base+3 (floor + tick),
        /// base+12 (floor + one emulated exchange), base+15 (the same exchange on a thread of its own).
        #[arg(long, default_value_t = 100)]
        domain_base: u32,
        #[arg(long)]
        interface: Option<String>,
        /// Only these peers (floor, floor-exchange, floor-exchange-thread, floor-1khz, handgate,
        /// python).
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "floor,floor-exchange,floor-exchange-thread,floor-1khz,handgate,python"
        )]
        only: Vec<String>,
        /// Run the `handgate` peer on these profiles too, after the default profile (labelled
        /// `handgate`), one after the other, each labelled `handgate LABEL` (repeatable:
        /// LABEL=PATH).
        #[arg(long)]
        handgate_profile: Vec<String>,
        #[arg(long)]
        out: PathBuf,
    },
    /// The export hop plain and with DDS Security, alternating in one run (docs/benchmarks.md §3c).
    SecureHop {
        #[arg(long)]
        handgate: PathBuf,
        /// The repository (its profiles/default.toml).
        #[arg(long, default_value = ".")]
        repo: PathBuf,
        #[arg(long, value_delimiter = ',', default_value = "200,1000")]
        rates: Vec<f64>,
        #[arg(long, default_value_t = 2000)]
        samples: usize,
        #[arg(long, default_value_t = 200)]
        warmup: usize,
        /// The clients' (export) domain; the devices' is --devices-domain.
        #[arg(long, default_value_t = 109)]
        domain: u32,
        #[arg(long, default_value_t = 229)]
        devices_domain: u32,
        /// Plain then secured, this many times.
        #[arg(long, default_value_t = 2)]
        rounds: usize,
        #[arg(long)]
        out: PathBuf,
    },
    /// The floor's echo peer (internal to `hop`).
    Echo {
        #[arg(long)]
        domain: u32,
        #[arg(long)]
        interface: Option<String>,
        #[arg(long, default_value = "rt/dex3/left/cmd")]
        cmd_topic: String,
        #[arg(long, default_value = "rt/dex3/left/state")]
        state_topic: String,
        /// Answer at the next tick of this period (µs) instead of at once.
        #[arg(long)]
        tick_us: Option<u64>,
        /// One emulated Dex3 USB exchange per command before answering.
        #[arg(long)]
        exchange: bool,
        /// With `--exchange`: the exchange and the answer on a thread of their own, handed
        /// each command by the listener.
        #[arg(long)]
        threaded: bool,
    },
    /// The shim hop: a Dex1 client driving a Dex3 served by the G1-service emulator (its own
    /// process) through handgate, a raw Rust relay and a unitree_sdk2py shim (bench/src/shim.rs).
    Shim {
        #[arg(long)]
        handgate: PathBuf,
        /// The venv interpreter with unitree_sdk2py (skip the Python shim when absent).
        #[arg(long)]
        python: Option<PathBuf>,
        /// bench/python/shim.py
        #[arg(long)]
        script: PathBuf,
        #[arg(long, value_delimiter = ',', default_value = "200,1000")]
        rates: Vec<f64>,
        #[arg(long, default_value_t = 2000)]
        samples: usize,
        #[arg(long, default_value_t = 200)]
        warmup: usize,
        #[arg(long, default_value_t = 107)]
        domain: u32,
        #[arg(long)]
        interface: Option<String>,
        /// Peers, in this order (handgate first: it refuses to start beside another writer
        /// of its front's state topic).
        #[arg(long, value_delimiter = ',', default_value = "handgate,relay,python")]
        only: Vec<String>,
        #[arg(long)]
        out: PathBuf,
    },
    /// The shim benchmark's raw relay (internal to `shim`).
    ShimRelay {
        #[arg(long)]
        domain: u32,
        #[arg(long)]
        interface: Option<String>,
    },
    /// Fleet scale: one gateway with many emulated devices.
    Fleet {
        #[arg(long)]
        handgate: PathBuf,
        #[arg(long, default_value_t = 32)]
        dex3: usize,
        #[arg(long, default_value_t = 32)]
        dex1: usize,
        #[arg(long, default_value_t = 30.0)]
        secs: f64,
        #[arg(long, default_value_t = 110)]
        domain: u32,
        /// `[realtime] loop_threads` of the gateway (default: the profile default; 0: a
        /// thread per device loop).
        #[arg(long)]
        loop_threads: Option<usize>,
        /// The reference (the same emulated hands and DDS traffic without handgate,
        /// bench/src/fleet_ref.rs) for this long right before the gateway and again right
        /// after (default: half of `secs` each); 0: no reference.
        #[arg(long)]
        reference_secs: Option<f64>,
        /// The reference's DDS domain.
        #[arg(long, default_value_t = 105)]
        reference_domain: u32,
        #[arg(long)]
        out: PathBuf,
    },
    /// The fleet benchmark's reference process (internal to `fleet`).
    FleetReference {
        #[arg(long, default_value_t = 32)]
        dex3: usize,
        #[arg(long, default_value_t = 32)]
        dex1: usize,
        #[arg(long, default_value_t = 105)]
        domain: u32,
    },
    /// What a loop's own thread costs: `n` empty loops on their own threads, then as tasks
    /// of the shared loop threads (handgate_adapters::loops), CPU and lateness of each.
    Timers {
        #[arg(long, default_value_t = 64)]
        loops: usize,
        #[arg(long, default_value_t = 1000.0)]
        hz: f64,
        #[arg(long, default_value_t = 10.0)]
        secs: f64,
        #[arg(long)]
        out: PathBuf,
    },
    /// Two Inspire RH56 hands on one emulated RS-485 line at 115200 baud: readings a second per
    /// hand against the line's wire limit.
    Rh56 {
        #[arg(long, default_value_t = 10.0)]
        secs: f64,
        #[arg(long)]
        out: PathBuf,
    },
    /// Start-up: from `handgate run` to every device fresh and a first state on every front.
    Startup {
        #[arg(long)]
        handgate: PathBuf,
        #[arg(long, default_value = "sim-all")]
        profile: String,
        #[arg(long, default_value_t = 113)]
        domain: u32,
        #[arg(long, default_value_t = 5)]
        runs: usize,
        #[arg(long)]
        out: PathBuf,
    },
    /// A shipped profile as it runs (default `sim-all`: every kind emulated at its own
    /// rates): CPU, RSS, each kind's state rate and missed cycles.
    Profile {
        #[arg(long)]
        handgate: PathBuf,
        #[arg(long, default_value = "sim-all")]
        profile: String,
        #[arg(long, default_value_t = 30.0)]
        secs: f64,
        #[arg(long, default_value_t = 111)]
        domain: u32,
        #[arg(long)]
        out: PathBuf,
    },
    /// The recorder's cost: `handgate record` of every topic of the default fleet beside a
    /// release gateway.
    Record {
        #[arg(long)]
        handgate: PathBuf,
        #[arg(long, default_value_t = 600.0)]
        secs: f64,
        #[arg(long, default_value_t = 158)]
        domain: u32,
        /// The recording directory (removed first).
        #[arg(long)]
        dir: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Criterion samples written since a time (epoch seconds).
    Criterion {
        #[arg(long)]
        dir: PathBuf,
        #[arg(long)]
        since: u64,
        #[arg(long)]
        out: PathBuf,
    },
    /// Complete a subset run's results (`BENCH_ONLY`) with the sections it did not measure from
    /// the last report's raw results, each with the run that measured it (`runs.json`).
    Carry {
        /// The last report's raw results (docs/benchmarks/raw).
        #[arg(long)]
        raw: PathBuf,
        /// This run's results (with its machine.json).
        #[arg(long)]
        results: PathBuf,
        /// The sections this run measured (scripts/bench.sh names, space-separated).
        #[arg(long)]
        measured: String,
    },
    /// Write docs/benchmarks.md from a results directory.
    Report {
        #[arg(long)]
        results: PathBuf,
        #[arg(long)]
        repo: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
}

fn save<T: serde::Serialize>(path: &std::path::Path, v: &T) -> anyhow::Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(v)?)?;
    Ok(())
}

fn gateway(
    bin: &std::path::Path,
    domain: u32,
    iface: Option<&str>,
    profile: Option<&std::path::Path>,
) -> anyhow::Result<child::Proc> {
    let mut c = Command::new(bin);
    c.arg("run").arg("--domain").arg(domain.to_string());
    // The dashboard on any free port (benchmarks may overlap a running gateway).
    c.args(["--http-port", "0"]);
    if let Some(p) = profile {
        c.arg("--profile").arg(p);
    }
    if let Some(i) = iface {
        c.arg("--interface").arg(i);
    }
    for (k, _) in std::env::vars() {
        if k.starts_with("HANDGATE_") {
            c.env_remove(k);
        }
    }
    child::Proc::start("handgate", c, "handgate serving", Duration::from_secs(60))
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().cmd {
        Cmd::Machine { out } => {
            let date = Command::new("date")
                .args(["-u", "+%Y-%m-%d %H:%M"])
                .output()
                .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
                .unwrap_or_default();
            save(
                &out,
                &report::Machine {
                    date,
                    load_start: stats::loadavg(),
                },
            )?;
        }
        Cmd::Loop {
            secs,
            configs,
            aligns,
            cmd_hz,
            out,
        } => {
            let mut v = Vec::new();
            for name in &configs {
                for align in &aligns {
                    let (spin, fifo, slack) = device_loop::by_name(name)?;
                    let a = device_loop::align_by_name(align)?;
                    let label = if aligns.len() > 1 || a != Default::default() {
                        format!("{name}, align {align}")
                    } else {
                        name.clone()
                    };
                    match device_loop::run(&label, secs, spin, fifo, slack, a, cmd_hz) {
                        Ok(r) => {
                            eprintln!("loop: {r:?}");
                            v.push(r);
                        }
                        Err(e) => eprintln!("loop: {label} skipped: {e}"),
                    }
                }
            }
            save(&out, &v)?;
        }
        Cmd::Busy {
            secs,
            endpoints,
            churn,
            domain,
            configs,
            busy_domain,
            out,
        } => {
            let mut v = Vec::new();
            for c in &configs {
                match busy::run(secs, endpoints, churn, domain, &busy_domain, c) {
                    Ok(r) => {
                        eprintln!("busy: {r:?}");
                        v.push(r);
                    }
                    Err(e) => eprintln!("busy: {c} skipped: {e}"),
                }
            }
            save(&out, &v)?;
        }
        Cmd::Hop {
            handgate,
            python,
            relay,
            rates,
            samples,
            warmup,
            domain_base,
            interface,
            only,
            handgate_profile,
            out,
        } => {
            let iface = interface.as_deref();
            let (cmd_t, st_t) = ("rt/dex3/left/cmd", "rt/dex3/left/state");
            let mut results = Vec::new();
            // (peer, handgate label and profile): `handgate` once per --handgate-profile.
            let mut peers: Vec<(&str, Option<(String, PathBuf)>)> = Vec::new();
            for peer in &only {
                if peer == "handgate" && !handgate_profile.is_empty() {
                    // The default profile first, as `handgate` (what the ratios compare), then
                    // each variant.
                    peers.push((peer, None));
                    for p in &handgate_profile {
                        let (l, path) = p
                            .split_once('=')
                            .ok_or_else(|| anyhow::anyhow!("--handgate-profile takes LABEL=PATH, got {p:?}"))?;
                        peers.push((peer, Some((format!("handgate {l}"), PathBuf::from(path)))));
                    }
                } else {
                    peers.push((peer, None));
                }
            }
            for (peer, hg_profile) in peers {
                let (label, domain, proc_) = match peer {
                    "floor" => {
                        let mut c = Command::new(std::env::current_exe()?);
                        c.args(["echo", "--domain", &(domain_base + 1).to_string()]);
                        if let Some(i) = iface {
                            c.args(["--interface", i]);
                        }
                        (
                            "floor",
                            domain_base + 1,
                            child::Proc::start("echo", c, "READY", Duration::from_secs(30))?,
                        )
                    }
                    "floor-1khz" => {
                        let mut c = Command::new(std::env::current_exe()?);
                        c.args(["echo", "--tick-us", "1000", "--domain", &(domain_base + 3).to_string()]);
                        if let Some(i) = iface {
                            c.args(["--interface", i]);
                        }
                        (
                            "floor + 1 kHz tick",
                            domain_base + 3,
                            child::Proc::start("echo", c, "READY", Duration::from_secs(30))?,
                        )
                    }
                    "floor-exchange" => {
                        let mut c = Command::new(std::env::current_exe()?);
                        c.args(["echo", "--exchange", "--domain", &(domain_base + 12).to_string()]);
                        if let Some(i) = iface {
                            c.args(["--interface", i]);
                        }
                        (
                            "floor + exchange",
                            domain_base + 12,
                            child::Proc::start("echo", c, "READY", Duration::from_secs(30))?,
                        )
                    }
                    "floor-exchange-thread" => {
                        let mut c = Command::new(std::env::current_exe()?);
                        c.args([
                            "echo",
                            "--exchange",
                            "--threaded",
                            "--domain",
                            &(domain_base + 15).to_string(),
                        ]);
                        if let Some(i) = iface {
                            c.args(["--interface", i]);
                        }
                        (
                            "floor + exchange on a thread",
                            domain_base + 15,
                            child::Proc::start("echo", c, "READY", Duration::from_secs(30))?,
                        )
                    }
                    "handgate" => match &hg_profile {
                        None => ("handgate", domain_base, gateway(&handgate, domain_base, iface, None)?),
                        Some((l, p)) => (
                            l.as_str(),
                            domain_base,
                            gateway(&handgate, domain_base, iface, Some(p))?,
                        ),
                    },
                    "python" => {
                        let Some(py) = python.as_ref().filter(|p| p.exists()) else {
                            eprintln!("hop: no venv python: the Python relay is skipped");
                            continue;
                        };
                        let mut c = Command::new(py);
                        c.arg("-u")
                            .arg(&relay)
                            .args(["--domain", &(domain_base + 2).to_string()]);
                        if let Some(i) = iface {
                            c.args(["--interface", i]);
                        }
                        (
                            "python relay",
                            domain_base + 2,
                            child::Proc::start("relay.py", c, "READY", Duration::from_secs(60))?,
                        )
                    }
                    other => anyhow::bail!("unknown peer {other:?}"),
                };
                let node = Node::new(domain, iface)?;
                for &rate in &rates {
                    let r = hop::client(&node, label, cmd_t, st_t, rate, samples, warmup, proc_.pid())?;
                    eprintln!("hop: {r:?}");
                    results.push(r);
                }
                drop(node);
                proc_.stop();
            }
            save(&out, &results)?;
        }
        Cmd::SecureHop {
            handgate,
            repo,
            rates,
            samples,
            warmup,
            domain,
            devices_domain,
            rounds,
            out,
        } => {
            let r = secure::run(
                &handgate,
                &repo,
                domain,
                devices_domain,
                &rates,
                samples,
                warmup,
                rounds,
            )?;
            save(&out, &r)?;
        }
        Cmd::Echo {
            domain,
            interface,
            cmd_topic,
            state_topic,
            tick_us,
            exchange,
            threaded,
        } => hop::echo(
            domain,
            interface.as_deref(),
            &cmd_topic,
            &state_topic,
            tick_us.map(Duration::from_micros),
            exchange,
            threaded,
        )?,
        Cmd::Timers { loops, hz, secs, out } => {
            let r = timers::run(loops, hz, secs);
            eprintln!("timers: {r:?}");
            save(&out, &r)?;
        }
        Cmd::Rh56 { secs, out } => {
            let r = rh56::run(secs);
            eprintln!("rh56: {r:?}");
            save(&out, &r)?;
        }
        Cmd::Startup {
            handgate,
            profile,
            domain,
            runs,
            out,
        } => {
            let r = startup::run(&handgate, &profile, domain, runs)?;
            save(&out, &r)?;
        }
        Cmd::Shim {
            handgate,
            python,
            script,
            rates,
            samples,
            warmup,
            domain,
            interface,
            only,
            out,
        } => {
            let r = shim::run(&shim::Plan {
                handgate: &handgate,
                python: python.as_deref().map(|p| (p, script.as_path())),
                rates: &rates,
                samples,
                warmup,
                domain,
                iface: interface.as_deref(),
                only: &only,
                out: &out,
            })?;
            save(&out, &r)?;
        }
        Cmd::ShimRelay { domain, interface } => {
            shim::relay(domain, interface.as_deref(), handgate_adapters::model::Side::Left)?
        }
        Cmd::Fleet {
            handgate,
            dex3,
            dex1,
            secs,
            domain,
            loop_threads,
            reference_secs,
            reference_domain,
            out,
        } => {
            let warm = Duration::from_secs(3);
            let ref_secs = reference_secs.unwrap_or(secs / 2.0);
            let bench = std::env::current_exe()?;
            let reference = || fleet_ref::run_and_measure(&bench, dex3, dex1, reference_domain, ref_secs, warm);
            let before = if ref_secs > 0.0 { Some(reference()?) } else { None };
            let profile = out.with_extension("toml");
            fleet::write_profile(&profile, dex3, dex1, loop_threads)?;
            let gw = gateway(&handgate, domain, None, Some(&profile))?;
            let node = Node::new(domain, None)?;
            let r = fleet::measure(&node, gw.pid(), dex3, dex1, secs, warm);
            gw.stop();
            let mut r = r?;
            eprintln!("fleet: {r:?}");
            r.reference.extend(before);
            if ref_secs > 0.0 {
                r.reference.push(reference()?);
            }
            save(&out, &r)?;
        }
        Cmd::FleetReference { dex3, dex1, domain } => fleet_ref::run(dex3, dex1, domain)?,
        Cmd::Profile {
            handgate,
            profile,
            secs,
            domain,
            out,
        } => {
            let gw = gateway(&handgate, domain, None, Some(std::path::Path::new(&profile)))?;
            let node = Node::new(domain, None)?;
            let r = fleet::measure_profile(&node, gw.pid(), &profile, secs, Duration::from_secs(3));
            gw.stop();
            let r = r?;
            eprintln!("profile: {r:?}");
            save(&out, &r)?;
        }
        Cmd::Record {
            handgate,
            secs,
            domain,
            dir,
            out,
        } => {
            let gw = gateway(&handgate, domain, None, None)?;
            let r = record::measure(&handgate, gw.pid(), domain, secs, &dir);
            gw.stop();
            let r = r?;
            eprintln!("record: {r:?}");
            save(&out, &r)?;
        }
        Cmd::Criterion { dir, since, out } => save(&out, &criterion::collect(&dir, since)?)?,
        Cmd::Carry { raw, results, measured } => {
            let measured: Vec<String> = measured.split_whitespace().map(str::to_string).collect();
            for (name, m) in carry::carry(&raw, &results, &measured)? {
                if m.carried {
                    eprintln!("bench: {name}: carried from the run of {}", m.date);
                }
            }
        }
        Cmd::Report { results, repo, out } => report::write(&results, &repo, &out)?,
    }
    Ok(())
}
