//! The binary's subcommands, one function each (`main` only parses and dispatches), and what
//! several of them share: loading a profile and its plan with the errors printed, opening one
//! device alone, logging, waiting for a signal. Part of the `handgate` binary, not of the
//! `handgate_gateway` library (they return `anyhow` errors).

pub mod check;
pub mod devices;
pub mod doctor;
pub mod emulate;
pub mod recording;
pub mod run;
pub mod security;
pub mod send;
pub mod status;

use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::device::HandDevice;
use handgate_gateway::cli::OverrideArgs;
use handgate_gateway::plan::Plan;
use handgate_gateway::profile::{self, LoadOptions, LogFormat};
use handgate_gateway::{resolve, runtime};

/// The target the subcommands log under: the binary's name, whichever module they live in
/// (what `RUST_LOG=handgate=...` and the JSON logs' `target` name).
pub const LOG_TARGET: &str = "handgate";

/// Exit code for an invalid profile: nothing was started.
pub const EXIT_INVALID: u8 = 2;

/// Loads `profile` with the command line's `overrides`; errors printed and `Err(code)` when
/// it is invalid.
pub fn load(profile: Option<String>, overrides: OverrideArgs) -> Result<profile::Loaded, ExitCode> {
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
pub fn load_plan(profile: Option<String>, overrides: OverrideArgs) -> Result<(profile::Loaded, Plan), ExitCode> {
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

/// Loads `profile`, opens its device `name` alone, runs `f` on it (then moves it to its safe
/// state) and hands `f`'s output to `print`. Exit 2 when the profile is invalid.
pub fn with_device<F, Fut>(
    profile: Option<String>,
    overrides: OverrideArgs,
    name: &str,
    f: F,
    print: impl FnOnce(String),
) -> anyhow::Result<ExitCode>
where
    F: FnOnce(Arc<dyn HandDevice>) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<String>>,
{
    let (_, plan) = match load_plan(profile, overrides) {
        Ok(lp) => lp,
        Err(code) => return Ok(code),
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
    print(out?);
    Ok(ExitCode::SUCCESS)
}

/// Logging at the profile's level and format (`RUST_LOG` wins over the level).
pub fn init_logging(level: &str, format: LogFormat) {
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

/// Waits for SIGINT (Ctrl-C) or SIGTERM and names the one that came.
pub async fn wait_for_signal() -> anyhow::Result<&'static str> {
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    tokio::select! {
        r = tokio::signal::ctrl_c() => { r?; Ok("SIGINT") }
        _ = term.recv() => Ok("SIGTERM"),
    }
}

/// `handgate fleet`: every gateway on `domains`, read from their status topics.
pub fn fleet(domains: &str, interface: Option<&str>, seconds: f64) -> anyhow::Result<ExitCode> {
    let domains = handgate_gateway::doctor::parse_scan(domains).map_err(|e| anyhow::anyhow!("--domains: {e}"))?;
    let listen = handgate_gateway::doctor::listen_time(seconds).map_err(|e| anyhow::anyhow!("--seconds: {e}"))?;
    let f = handgate_gateway::fleet::look(&domains, interface, listen);
    print!("{}", handgate_gateway::fleet::render(&f));
    Ok(if f.errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
