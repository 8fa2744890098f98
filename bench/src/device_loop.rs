//! Benchmark 2: the Dex3 USB device loop at 1 kHz against the in-process MCU emulator
//! (the transport seam hardware would use), for a fixed time, next to a reference loop that
//! runs at the same time on the same machine and does nothing but sleep to absolute deadlines
//! at the same period (with the same scheduling policy): the best any user-space loop gets
//! here, measured with the same histogram and the same rule for a missed cycle;
//! optionally fed commands at a fixed rate, with the loop aligned to them or not.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::dex3::usb::{
    Align, Dex3Emulator, Dex3UsbLoop, EmulatorClock, EmulatorConfig, EmulatorTransport, LoopConfig, PeriodHistogram,
};
use handgate_adapters::dex3::{Dex3Command, Side};
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
    /// The loop's alignment (`off`, `early:GAP_US`, `phase:SHIFT_US`).
    #[serde(default)]
    pub align: Option<String>,
    /// Commands fed per second (`None`: none).
    #[serde(default)]
    pub cmd_hz: Option<f64>,
    /// Exchanges per second of wall time.
    #[serde(default)]
    pub exchanges_per_s: Option<f64>,
    /// Exchanges started early for a command.
    #[serde(default)]
    pub early: Option<u64>,
    /// Command set -> the start of the exchange sending it: median, p99, max, µs (upper
    /// edges of 5 µs buckets).
    #[serde(default)]
    pub cmd_wait_us: Option<[f64; 3]>,
    /// Shortest period, ms.
    #[serde(default)]
    pub min_ms: Option<f64>,
    /// The feeding thread's cost of one `set_command` (slot + wake): median, p99, µs.
    #[serde(default)]
    pub set_command_us: Option<[f64; 2]>,
    /// The reference loop over the same window (`None` in results of older runs).
    #[serde(default)]
    pub reference: Option<Reference>,
}

/// An alignment by name: `off`, `early[:MIN_GAP_US]` (default 500), `phase[:MAX_SHIFT_US]`
/// (default 20; lead 50 µs).
pub fn align_by_name(name: &str) -> anyhow::Result<Align> {
    let (mode, n) = match name.split_once(':') {
        Some((m, n)) => (m, Some(n.parse::<u64>()?)),
        None => (name, None),
    };
    let us = Duration::from_micros;
    Ok(match mode {
        "off" => Align::Off,
        "early" => Align::Early {
            min_gap: us(n.unwrap_or(500)),
        },
        "phase" => Align::Phase {
            max_shift: us(n.unwrap_or(20)),
            lead: us(50),
        },
        other => anyhow::bail!("unknown alignment {other:?}"),
    })
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

#[allow(clippy::too_many_arguments)]
pub fn run(
    label: &str,
    secs: f64,
    spin: Duration,
    fifo: bool,
    slack_ns: Option<u64>,
    align: Align,
    cmd_hz: Option<f64>,
) -> anyhow::Result<LoopResult> {
    let emu = Arc::new(Mutex::new(Dex3Emulator::new(
        Side::Left,
        EmulatorConfig {
            clock: EmulatorClock::Wall,
            ..EmulatorConfig::default()
        },
    )));
    let cfg = LoopConfig {
        spin,
        align,
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
    // Commands are only sent on a connection that is up when they are set.
    let up = Instant::now() + Duration::from_secs(10);
    while cmd_hz.is_some() && h.latest().seq == 0 && Instant::now() < up {
        std::thread::sleep(Duration::from_millis(1));
    }
    let pid = std::process::id();
    let c0 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs_f64(secs);
    let mut set_cost = Vec::new();
    match cmd_hz {
        None => std::thread::sleep(Duration::from_secs_f64(secs)),
        Some(hz) => {
            // As the hop client: each command at a uniformly random point of its period.
            let period = Duration::from_secs_f64(1.0 / hz);
            let cmd = Dex3Command::damping(0.1);
            let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
            let mut i: u32 = 0;
            let mut anchor = t0;
            loop {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                let at = anchor + period * i + period.mul_f64((rng >> 11) as f64 / (1u64 << 53) as f64);
                if at >= end {
                    break;
                }
                let now = Instant::now();
                if at > now {
                    std::thread::sleep(at - now);
                } else if now - at > period {
                    anchor = now - period * i;
                }
                let c = Instant::now();
                h.set_command(cmd);
                set_cost.push(c.elapsed().as_secs_f64() * 1e6);
                i += 1;
            }
            let now = Instant::now();
            if end > now {
                std::thread::sleep(end - now);
            }
        }
    }
    let s = h.stats();
    stop_ref.store(true, Ordering::Relaxed);
    let wall = t0.elapsed().as_secs_f64();
    let c1 = cpu_seconds(pid).unwrap_or(f64::NAN);
    h.stop();
    let wq = |p| {
        s.cmd_wait
            .quantile(p)
            .map(|d| d.as_secs_f64() * 1e6)
            .unwrap_or(f64::NAN)
    };
    set_cost.sort_by(f64::total_cmp);
    let pick = |q: f64| set_cost[((q * set_cost.len() as f64) as usize).min(set_cost.len() - 1)];
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
        align: Some(format!("{align:?}")),
        cmd_hz,
        exchanges_per_s: Some(s.exchanges as f64 / wall),
        early: Some(s.early),
        cmd_wait_us: (s.cmd_wait.count() > 0).then(|| [wq(0.5), wq(0.99), s.cmd_wait.max().as_secs_f64() * 1e6]),
        min_ms: s.period.min().map(|d| d.as_secs_f64() * 1e3),
        set_command_us: (!set_cost.is_empty()).then(|| [pick(0.5), pick(0.99)]),
        reference: Some(reference),
    })
}
