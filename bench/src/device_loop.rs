//! Benchmark 2: the Dex3 USB device loop at 1 kHz against the in-process MCU emulator
//! (the transport seam hardware would use), for a fixed time, next to a reference loop that
//! runs at the same time on the same machine and does nothing but sleep to absolute deadlines
//! at the same period (with the same scheduling policy): the best any user-space loop gets
//! here, measured with the same histogram and the same rule for a missed cycle.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::dex3::usb::{
    Dex3Emulator, Dex3UsbLoop, EmulatorClock, EmulatorConfig, EmulatorTransport, LoopConfig, PeriodHistogram,
};
use handgate_adapters::dex3::Side;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::stats::cpu_seconds;

/// One loop run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LoopResult {
    pub label: String,
    pub spin_us: u64,
    pub fifo: bool,
    /// Timer slack of the loop thread, ns (`None`: the default, 50 µs).
    pub slack_ns: Option<u64>,
    pub secs: f64,
    /// Wall time the loop actually ran (the stats are read at its end).
    pub wall_s: f64,
    pub cycles: u64,
    /// Period quantiles, ms (upper edges of 5 µs buckets).
    pub median_ms: f64,
    pub p90_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    /// |p99 period − nominal period|, µs.
    pub p99_jitter_us: f64,
    pub misses: u64,
    pub good_frames: u64,
    /// CPU of this process during the run, % of one core.
    pub cpu_pct: f64,
    /// The reference loop over the same window (`None` in results of older runs).
    #[serde(default)]
    pub reference: Option<Reference>,
}

/// The reference loop's periods: the same quantities as the device loop's.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Reference {
    pub cycles: u64,
    pub median_ms: f64,
    pub p90_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    pub p99_jitter_us: f64,
    pub misses: u64,
}

/// Runs a loop that only sleeps to absolute deadlines (`t0 + k·period`, a late wake-up
/// skips the deadlines it missed and counts them, as the device loop does) until `stop`.
fn reference_loop(period: Duration, stop: Arc<AtomicBool>) -> (PeriodHistogram, u64) {
    let mut hist = PeriodHistogram::new();
    let mut misses = 0u64;
    let t0 = Instant::now();
    let mut last: Option<Instant> = None;
    let mut k: u64 = 0;
    let at = |k: u64| t0 + Duration::from_nanos(period.as_nanos() as u64 * k);
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if let Some(l) = last.replace(now) {
            hist.record(now - l);
        }
        k += 1;
        let mut next = at(k);
        let now = Instant::now();
        if now > next {
            let behind = ((now - next).as_nanos() / period.as_nanos()) as u64 + 1;
            misses += behind;
            k += behind;
            next = at(k);
        }
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
    }
    (hist, misses)
}

/// Sets the calling thread's scheduling policy; threads it creates inherit it (glibc's
/// default `PTHREAD_INHERIT_SCHED`).
pub fn set_fifo(priority: Option<i32>) -> std::io::Result<()> {
    let (policy, prio) = match priority {
        Some(p) => (libc::SCHED_FIFO, p),
        None => (libc::SCHED_OTHER, 0),
    };
    let param = libc::sched_param { sched_priority: prio };
    // SAFETY: pid 0 is the calling thread; `param` is a valid sched_param.
    let rc = unsafe { libc::sched_setscheduler(0, policy, &param) };
    if rc != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Sets the calling thread's timer slack (how late the kernel may fire its sleeps; 50 µs by
/// default for normal threads); threads it creates inherit it.
pub fn set_timer_slack(ns: u64) -> std::io::Result<()> {
    // SAFETY: PR_SET_TIMERSLACK takes one integer argument.
    let rc = unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, ns as libc::c_ulong, 0, 0, 0) };
    if rc != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// A loop configuration by name: `default`, `fifo`, `spin0`, `slack` (spin 0, timer slack
/// 1 ns), `slack-spin` (spin 100 µs, slack 1 ns).
pub fn by_name(name: &str) -> anyhow::Result<(Duration, bool, Option<u64>)> {
    let us = Duration::from_micros;
    Ok(match name {
        "default" => (LoopConfig::default().spin, false, None),
        "fifo" => (LoopConfig::default().spin, true, None),
        "spin0" => (us(0), false, None),
        "slack" => (us(0), false, Some(1)),
        "slack-spin" => (LoopConfig::default().spin, false, Some(1)),
        other => anyhow::bail!("unknown loop configuration {other:?}"),
    })
}

pub fn run(label: &str, secs: f64, spin: Duration, fifo: bool, slack_ns: Option<u64>) -> anyhow::Result<LoopResult> {
    let emu = Arc::new(Mutex::new(Dex3Emulator::new(
        Side::Left,
        EmulatorConfig {
            clock: EmulatorClock::Wall,
            ..EmulatorConfig::default()
        },
    )));
    let cfg = LoopConfig {
        spin,
        ..LoopConfig::default()
    };
    let period = cfg.period;
    if fifo {
        set_fifo(Some(50)).map_err(|e| anyhow::anyhow!("SCHED_FIFO: {e} (needs root or CAP_SYS_NICE)"))?;
    }
    if let Some(ns) = slack_ns {
        set_timer_slack(ns)?;
    }
    let h = Dex3UsbLoop::spawn(EmulatorTransport::factory(emu), cfg);
    // The reference inherits the same policy and slack (created while they are set).
    let stop_ref = Arc::new(AtomicBool::new(false));
    let sr = stop_ref.clone();
    let reference = std::thread::Builder::new()
        .name("reference-loop".into())
        .spawn(move || reference_loop(period, sr))?;
    if fifo {
        set_fifo(None)?;
    }
    if slack_ns.is_some() {
        set_timer_slack(50_000)?;
    }
    let h = h?;
    let pid = std::process::id();
    let c0 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(secs));
    let s = h.stats();
    stop_ref.store(true, Ordering::Relaxed);
    let wall = t0.elapsed().as_secs_f64();
    let c1 = cpu_seconds(pid).unwrap_or(f64::NAN);
    h.stop();
    let (rh, rmiss) = reference
        .join()
        .map_err(|_| anyhow::anyhow!("the reference loop panicked"))?;
    let rq = |p| rh.quantile(p).map(|d| d.as_secs_f64() * 1e3).unwrap_or(f64::NAN);
    let nominal_ms = period.as_secs_f64() * 1e3;
    let reference = Reference {
        cycles: rh.count(),
        median_ms: rq(0.5),
        p90_ms: rq(0.9),
        p99_ms: rq(0.99),
        max_ms: rh.max().as_secs_f64() * 1e3,
        p99_jitter_us: (rq(0.99) - nominal_ms).abs() * 1e3,
        misses: rmiss,
    };
    let q = |p| s.period.quantile(p).map(|d| d.as_secs_f64() * 1e3).unwrap_or(f64::NAN);
    let p99 = q(0.99);
    Ok(LoopResult {
        label: label.into(),
        spin_us: spin.as_micros() as u64,
        fifo,
        slack_ns,
        secs,
        wall_s: wall,
        cycles: s.period.count(),
        median_ms: q(0.5),
        p90_ms: q(0.9),
        p99_ms: p99,
        max_ms: s.period.max().as_secs_f64() * 1e3,
        p99_jitter_us: (p99 - period.as_secs_f64() * 1e3).abs() * 1e3,
        misses: s.misses,
        good_frames: s.good_frames,
        cpu_pct: 100.0 * (c1 - c0) / wall,
        reference: Some(reference),
    })
}
