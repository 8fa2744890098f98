use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use handgate_gateway::cli::{Cli, Command};
use handgate_gateway::profile::{self, LoadOptions, LogFormat};
use handgate_gateway::{resolve, runtime, tools};
use handgate_idl::handgate as hg;

/// Exit code for an invalid profile: nothing was started.
const EXIT_INVALID: u8 = 2;

fn load(profile: Option<String>, overrides: handgate_gateway::cli::OverrideArgs) -> Result<profile::Loaded, ExitCode> {
    profile::load(&LoadOptions {
        profile,
        overrides: overrides.into(),
        ..LoadOptions::default()
    })
    .map_err(|e| {
        for line in e.lines() {
            eprintln!("{line}");
        }
        ExitCode::from(EXIT_INVALID)
    })
}

/// Loads `profile` and resolves its plan; errors printed (each naming the profile's origin)
/// and `Err(code)` when either step fails.
fn load_plan(
    profile: Option<String>,
    overrides: handgate_gateway::cli::OverrideArgs,
) -> Result<(profile::Loaded, handgate_gateway::plan::Plan), ExitCode> {
    let l = load(profile, overrides)?;
    match resolve::plan(&l.profile) {
        Ok(p) => Ok((l, p)),
        Err(errors) => {
            for e in errors {
                eprintln!("{}: {e}", l.origin);
            }
            Err(ExitCode::from(EXIT_INVALID))
        }
    }
}

/// Loads `profile`, opens its device `name` alone and runs `f` on it (then moves it to its
/// safe state). `Err(code)` when the profile is invalid.
fn with_device<F, Fut>(
    profile: Option<String>,
    overrides: handgate_gateway::cli::OverrideArgs,
    name: &str,
    f: F,
) -> anyhow::Result<Result<String, ExitCode>>
where
    F: FnOnce(std::sync::Arc<dyn handgate_adapters::device::HandDevice>) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<String>>,
{
    let (_, plan) = match load_plan(profile, overrides) {
        Ok(lp) => lp,
        Err(code) => return Ok(Err(code)),
    };
    let Some(safe) = plan.devices.iter().find(|d| d.name == name).map(|d| d.safe_action) else {
        let names: Vec<&str> = plan.devices.iter().map(|d| d.name.as_str()).collect();
        anyhow::bail!(
            "no device named {name} in profile {} (devices: {})",
            plan.profile,
            names.join(", ")
        );
    };
    let rt = tokio::runtime::Runtime::new()?;
    let out = rt.block_on(async {
        let node = handgate_adapters::dds::Node::new(plan.domain, plan.interface.as_deref())?;
        let mut shared = handgate_adapters::open::Shared::default();
        let device = runtime::open_device(&node, &plan, name, &mut shared)?;
        let out = f(device.clone()).await;
        let _ = device.shutdown(safe).await;
        out
    });
    rt.shutdown_timeout(Duration::from_millis(200));
    Ok(Ok(out?))
}

fn init_logging(level: &str, format: LogFormat) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    use std::io::IsTerminal;
    let fmt = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::stdout().is_terminal());
    match format {
        LogFormat::Human => fmt.init(),
        LogFormat::Json => fmt.json().init(),
    }
}

/// Under systemd (`Type=notify`): READY once every device is open and every front bound,
/// then, with `WatchdogSec=`, the watchdog fed while every device loop is alive (a hung loop
/// stops the feed and systemd restarts the gateway). Outside systemd: nothing.
fn systemd_ready(gw: &runtime::Runtime, fronts: usize) -> Option<tokio::task::JoinHandle<()>> {
    use handgate_gateway::systemd;
    let status = |gw: &runtime::Runtime| {
        let fresh = gw
            .devices
            .iter()
            .filter(|d| d.device.state().borrow().freshness != handgate_adapters::model::Freshness::Stale)
            .count();
        format!(
            "STATUS=serving {} devices ({fresh} fresh), {fronts} fronts",
            gw.devices.len()
        )
    };
    match systemd::notify(&format!("READY=1\n{}", status(gw))) {
        Ok(true) => tracing::info!("systemd: ready"),
        Ok(false) => return None,
        Err(e) => tracing::warn!(error = %e, "systemd: cannot notify readiness"),
    }
    let every = systemd::watchdog_interval()?;
    tracing::info!(
        interval_ms = every.as_millis() as u64,
        "systemd: feeding the watchdog while every device loop runs"
    );
    let devices = gw.devices.clone();
    Some(tokio::spawn(async move {
        let mut live = systemd::Liveness::default();
        let mut tick = tokio::time::interval(every);
        let mut hung_logged = false;
        loop {
            tick.tick().await;
            let cycles: Vec<u64> = devices.iter().map(|d| d.device.stats().cycles).collect();
            match live.check(&cycles) {
                Ok(()) => {
                    hung_logged = false;
                    let fresh = devices
                        .iter()
                        .filter(|d| d.device.state().borrow().freshness != handgate_adapters::model::Freshness::Stale)
                        .count();
                    let _ = systemd::notify(&format!(
                        "WATCHDOG=1\nSTATUS=serving {} devices ({fresh} fresh), {fronts} fronts",
                        devices.len()
                    ));
                }
                Err(stalled) if !hung_logged => {
                    hung_logged = true;
                    let names: Vec<&str> = stalled.iter().map(|&i| devices[i].plan.name.as_str()).collect();
                    tracing::error!(devices = %names.join(","), "device loop hung: the systemd watchdog is no longer fed (systemd restarts the gateway)");
                }
                Err(_) => {}
            }
        }
    }))
}

async fn wait_for_signal() -> anyhow::Result<&'static str> {
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    tokio::select! {
        r = tokio::signal::ctrl_c() => { r?; Ok("SIGINT") }
        _ = term.recv() => Ok("SIGTERM"),
    }
}

fn main() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { list: true, .. } => {
            for p in profile::list_profiles(&handgate_gateway::cli::profile_dirs()) {
                println!("{:<16} {:<40} {}", p.name, p.origin.to_string(), p.description);
            }
        }
        Command::Check { profile, overrides, .. } => match load(profile, overrides) {
            Ok(l) => print!("{}", profile::render_fleet(&l.profile, &l.origin)),
            Err(code) => return Ok(code),
        },
        Command::Run { profile, overrides } => {
            let (l, plan) = match load_plan(profile, overrides) {
                Ok(lp) => lp,
                Err(code) => return Ok(code),
            };
            init_logging(&l.profile.log.level, l.profile.log.format);
            print!("{}", profile::render_fleet(&l.profile, &l.origin));
            let rt = tokio::runtime::Runtime::new()?;
            rt.block_on(async {
                let gw = runtime::Runtime::start(&plan)?;
                println!(
                    "handgate serving {} device(s), {} front(s) on DDS domain {}",
                    gw.devices.len(),
                    plan.fronts.len(),
                    plan.domain
                );
                tracing::info!(profile = %plan.profile, domain = plan.domain, "handgate started");
                let watchdog = systemd_ready(&gw, plan.fronts.len());
                let sig = wait_for_signal().await?;
                if let Some(w) = watchdog {
                    w.abort();
                }
                let _ = handgate_gateway::systemd::notify("STOPPING=1\nSTATUS=moving every device to its safe state");
                tracing::info!(signal = sig, "stopping: moving every device to its safe state");
                for (name, r) in gw.shutdown().await {
                    match r {
                        Ok(()) => tracing::info!(device = %name, "safe"),
                        Err(e) => tracing::warn!(device = %name, error = %e, "safe state not confirmed"),
                    }
                }
                anyhow::Ok(())
            })?;
            rt.shutdown_timeout(Duration::from_millis(200));
            tracing::info!("stopped");
        }
        Command::Doctor {
            profile,
            seconds,
            scan,
            no_scan,
            no_sweep,
            count_only,
            overrides,
        } => {
            use handgate_gateway::doctor;
            let listen = doctor::listen_time(seconds).map_err(anyhow::Error::msg)?;
            let scan = match (no_scan, scan) {
                (true, _) => Vec::new(),
                (false, Some(s)) => doctor::parse_scan(&s).map_err(|e| anyhow::anyhow!("--scan {s}: {e}"))?,
                (false, None) => doctor::default_scan(),
            };
            let sweep = (!no_sweep && !count_only)
                .then(|| {
                    std::env::current_exe().ok().map(|exe| doctor::Sweep {
                        exe,
                        profile: profile.clone(),
                    })
                })
                .flatten();
            let (_, plan) = match load_plan(profile, overrides) {
                Ok(lp) => lp,
                Err(code) => return Ok(code),
            };
            let scan = if count_only { Vec::new() } else { scan };
            let out = doctor::run(&plan, &doctor::Options { listen, scan, sweep })?;
            if count_only {
                println!("relevant {}", out.relevant);
                return Ok(ExitCode::SUCCESS);
            }
            print!("{}", out.text);
            if !out.problems.is_empty() {
                return Ok(ExitCode::from(1));
            }
        }
        Command::Status {
            dds,
            topic,
            once,
            timeout,
        } => {
            let node = handgate_adapters::dds::Node::new(dds.domain, dds.interface.as_deref())?;
            loop {
                let s = tools::status_once(&node, &dds.topic(&topic), Duration::from_secs_f64(timeout))?;
                if !once {
                    print!("\x1b[2J\x1b[H");
                }
                print!("{}", tools::render_status(&s));
                if once {
                    break;
                }
            }
        }
        Command::List => {
            for kind in handgate_adapters::kind::DeviceKind::all() {
                if let Some(found) = kind.factory().list_attached() {
                    for line in found? {
                        println!("{line}");
                    }
                }
            }
        }
        Command::Discover {
            device,
            profile,
            overrides,
        } => {
            let out = match with_device(profile, overrides, &device, |d| async move {
                let Some(ability) = d.discovery() else {
                    anyhow::bail!("device {} ({}) has no wiring discovery", d.info().name, d.info().kind);
                };
                Ok(ability.discover().await?)
            })? {
                Ok(out) => out,
                Err(code) => return Ok(code),
            };
            print!("{out}");
        }
        Command::Calibrate {
            device,
            profile,
            overrides,
        } => {
            let out = match with_device(profile, overrides, &device, |d| async move {
                let Some(ability) = d.calibration() else {
                    anyhow::bail!("device {} ({}) has no calibration", d.info().name, d.info().kind);
                };
                Ok(ability.calibrate().await?)
            })? {
                Ok(out) => out,
                Err(code) => return Ok(code),
            };
            println!("{device} calibrated: {out}");
        }
        Command::Emulate(cmd) => {
            use handgate_adapters::kind::{DeviceKind, Emulation};
            let Some(kind) = DeviceKind::by_name(&cmd.kind) else {
                anyhow::bail!(
                    "unknown kind {:?} (kinds: {})",
                    cmd.kind,
                    DeviceKind::names().join(", ")
                );
            };
            let args = handgate_adapters::kind::EmulateArgs::try_from(cmd).map_err(|e| anyhow::anyhow!(e))?;
            let (what, emulation) = kind.factory().emulate(&args)?;
            println!("{what}");
            match emulation {
                Emulation::Blocking(run) => run()?,
                Emulation::Running(keep) => {
                    let rt = tokio::runtime::Runtime::new()?;
                    let sig = rt.block_on(wait_for_signal())?;
                    tracing::info!(signal = sig, "stopping the emulator");
                    drop(keep);
                }
            }
        }
        Command::Record(cmd) => {
            let (l, plan) = match load_plan(cmd.profile, cmd.overrides) {
                Ok(lp) => lp,
                Err(code) => return Ok(code),
            };
            init_logging(&l.profile.log.level, l.profile.log.format);
            let node = handgate_adapters::dds::Node::new(plan.domain, plan.interface.as_deref())?;
            let topics = handgate_gateway::recording::topics(&plan, &cmd.record.topics);
            let opts = handgate_gateway::recording::options(
                &cmd.name,
                cmd.record.max_mb,
                cmd.record.max_seconds,
                cmd.record.zstd,
            );
            let rec = handgate_record::Recorder::start(&node, topics, opts)?;
            println!(
                "recording {} topic(s) of profile {} on DDS domain {} into {}",
                rec.topics.len(),
                plan.profile,
                plan.domain,
                cmd.name.display()
            );
            let rt = tokio::runtime::Runtime::new()?;
            rt.block_on(async {
                match cmd.duration {
                    Some(d) => tokio::select! {
                        r = wait_for_signal() => r.map(|_| ()),
                        _ = tokio::time::sleep(Duration::from_secs_f64(d.max(0.0))) => Ok(()),
                    },
                    None => wait_for_signal().await.map(|_| ()),
                }
            })?;
            let s = rec.stop()?;
            println!(
                "recorded {} message(s), {} dropped, {} bytes of messages in {} file(s)",
                s.messages,
                s.dropped,
                s.bytes,
                s.files.len()
            );
        }
        Command::Replay(cmd) => {
            if cmd.domain == 0 && !cmd.allow_robot {
                eprintln!(
                    "refusing to replay on DDS domain 0 (a robot's): replayed commands move real hands; \
                     pass --allow-robot to do it anyway"
                );
                return Ok(ExitCode::from(EXIT_INVALID));
            }
            let bag = handgate_record::bag::Bag::open(&cmd.dir)?;
            for (f, e) in &bag.truncated {
                eprintln!("{}: read up to a damaged record ({e})", f.display());
            }
            let node = handgate_adapters::dds::Node::new(cmd.domain, cmd.interface.as_deref())?;
            let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            let s2 = stop.clone();
            let rt = tokio::runtime::Runtime::new()?;
            rt.spawn(async move {
                if wait_for_signal().await.is_ok() {
                    s2.store(true, std::sync::atomic::Ordering::Relaxed);
                }
            });
            let opts = handgate_record::replay::ReplayOptions {
                rate: cmd.rate,
                looped: cmd.looped,
                topics: cmd.topics,
                wait_match: Duration::from_secs_f64(cmd.wait.max(0.0)),
                readers: cmd.readers,
                settle: Duration::from_millis(cmd.settle_ms),
            };
            println!("replaying {} on DDS domain {}", cmd.dir.display(), cmd.domain);
            let s = handgate_record::replay::replay(&node, &bag, &opts, || {
                stop.load(std::sync::atomic::Ordering::Relaxed)
            })?;
            for t in &s.unmatched {
                eprintln!(
                    "{t}: fewer than {} reader(s) matched when the replay started",
                    cmd.readers
                );
            }
            println!(
                "replayed {} message(s) on {} topic(s), {} pass(es)",
                s.published,
                s.topics.len(),
                s.passes
            );
            rt.shutdown_timeout(Duration::from_millis(100));
        }
        Command::Export(cmd) => {
            let bag = handgate_record::bag::Bag::open(&cmd.dir)?;
            let opts = handgate_record::export::ExportOptions {
                rate_hz: cmd.rate,
                left: (!cmd.only_right).then_some(cmd.left),
                right: (!cmd.only_left).then_some(cmd.right),
            };
            let v = handgate_record::export::xr_teleoperate(&bag, &opts)?;
            let text = serde_json::to_string_pretty(&v)?;
            match cmd.output {
                Some(p) => {
                    std::fs::write(&p, text)?;
                    println!("wrote {}", p.display());
                }
                None => println!("{text}"),
            }
        }
        Command::Send {
            device,
            dds,
            closure,
            joint,
            kp,
            kd,
            safe,
            timeout,
            hold,
            force,
        } => {
            let node = handgate_adapters::dds::Node::new(dds.domain, dds.interface.as_deref())?;
            let cmd = if safe {
                hg::HandCmd_ {
                    mode: hg::MODE_SAFE,
                    ..Default::default()
                }
            } else if let Some(c) = closure {
                hg::HandCmd_ {
                    mode: hg::MODE_CLOSURE,
                    closure: c,
                    ..Default::default()
                }
            } else if !joint.is_empty() {
                hg::HandCmd_ {
                    mode: hg::MODE_JOINTS,
                    joints: joint
                        .into_iter()
                        .map(|(name, q)| hg::JointCmd_ {
                            name,
                            q,
                            kp,
                            kd,
                            ..Default::default()
                        })
                        .collect(),
                    ..Default::default()
                }
            } else {
                anyhow::bail!("say what to send: --closure X, --joint NAME=RAD (repeatable) or --safe");
            };
            let n = tools::send(
                &node,
                &dds.namespace.clone().unwrap_or_default(),
                &device,
                cmd,
                tools::SendOptions {
                    timeout: Duration::from_secs_f64(timeout),
                    hold: Duration::from_secs_f64(hold),
                    force,
                },
            )?;
            println!("sent {n} command(s) to {device}");
        }
    }
    Ok(ExitCode::SUCCESS)
}
