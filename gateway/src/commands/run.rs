//! `handgate run`: serve a profile's fleet until SIGINT or SIGTERM, then move every device
//! to its safe state.

use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::model::Freshness;
use handgate_gateway::cli::OverrideArgs;
use handgate_gateway::{profile, runtime, systemd};

use super::{init_logging, load_plan, wait_for_signal, LOG_TARGET};

/// Runs the gateway for `profile` (exit 2 when it is invalid: nothing started).
pub fn run(profile: Option<String>, overrides: OverrideArgs) -> anyhow::Result<ExitCode> {
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
        tracing::info!(target: LOG_TARGET, profile = %plan.profile, domain = plan.domain, "handgate started");
        let watchdog = systemd_ready(&gw, plan.fronts.len());
        let sig = wait_for_signal().await?;
        if let Some(w) = watchdog {
            w.abort();
        }
        let _ = systemd::notify("STOPPING=1\nSTATUS=moving every device to its safe state");
        tracing::info!(target: LOG_TARGET, signal = sig, "stopping: moving every device to its safe state");
        for (name, r) in gw.shutdown().await {
            match r {
                Ok(()) => tracing::info!(target: LOG_TARGET, device = %name, "safe"),
                Err(e) => tracing::warn!(target: LOG_TARGET, device = %name, error = %e, "safe state not confirmed"),
            }
        }
        anyhow::Ok(())
    })?;
    rt.shutdown_timeout(Duration::from_millis(200));
    tracing::info!(target: LOG_TARGET, "stopped");
    Ok(ExitCode::SUCCESS)
}

/// Under systemd (`Type=notify`): READY once every device is open and every front bound,
/// then, with `WatchdogSec=`, the watchdog fed while every device loop is alive (a hung loop
/// stops the feed and systemd restarts the gateway). Outside systemd: nothing.
fn systemd_ready(gw: &runtime::Runtime, fronts: usize) -> Option<tokio::task::JoinHandle<()>> {
    match systemd::notify(&format!("READY=1\n{}", status(&gw.devices, fronts))) {
        Ok(true) => tracing::info!(target: LOG_TARGET, "systemd: ready"),
        Ok(false) => return None,
        Err(e) => tracing::warn!(target: LOG_TARGET, error = %e, "systemd: cannot notify readiness"),
    }
    let every = systemd::watchdog_interval()?;
    tracing::info!(
        target: LOG_TARGET,
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
                    let _ = systemd::notify(&format!("WATCHDOG=1\n{}", status(&devices, fronts)));
                }
                Err(stalled) if !hung_logged => {
                    hung_logged = true;
                    let names: Vec<&str> = stalled.iter().map(|&i| devices[i].plan.name.as_str()).collect();
                    tracing::error!(target: LOG_TARGET, devices = %names.join(","), "device loop hung: the systemd watchdog is no longer fed (systemd restarts the gateway)");
                }
                Err(_) => {}
            }
        }
    }))
}

/// The `STATUS=` line systemd shows for the gateway: how many devices it serves, how many of
/// them are fresh, how many fronts.
fn status(devices: &[Arc<runtime::DeviceSlot>], fronts: usize) -> String {
    let fresh = devices
        .iter()
        .filter(|d| d.device.state().borrow().freshness != Freshness::Stale)
        .count();
    format!(
        "STATUS=serving {} devices ({fresh} fresh), {fronts} fronts",
        devices.len()
    )
}
