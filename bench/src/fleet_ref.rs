//! The fleet benchmark's reference (issue #37): the fleet's emulated hands and its DDS traffic
//! without handgate's own path, measured in the same run as the gateway so that the fleet's
//! verdict is a ratio to it and carries across machines.
//!
//! One process (`handgate-bench fleet-reference`, its own DDS domain) runs what a gateway serving
//! `n3` emulated Dex3 and `n1` emulated Dex1 with a front each cannot do without:
//!
//! - per Dex3 hand, a thread of its own (`ref-hand-usb`) waking at 1 kHz on the process-wide grid
//!   of deadlines the gateway's emulated hands share ([`handgate_adapters::loops::grid_at_or_after`]),
//!   skipping the deadlines it woke too late for, as the gateway's loop does. Each cycle is one
//!   emulated USB exchange ([`crate::hop::Exchange`], the hop's floor + exchange): the command
//!   frame built and encoded (a hold at the first measured position, as the gateway's loop sends
//!   without a client), exchanged with the same MCU emulator at the same transport seam (its joint
//!   model, CRCs, frame handling), the reply decoded into a measurement. Then the front's
//!   publishes: its state at 500 Hz and its low-frequency copy at 50 Hz, each a `write_with` on a
//!   best-effort writer of the front's topic (with no client attached, a check of the matched
//!   readers and no write, as the gateway's front). A thread per hand because a hand on USB
//!   blocks its thread for each transfer (the hop's floor + exchange on a thread: the least a
//!   gateway can do for a USB hand);
//! - per Dex1, the same emulated `dex1_1_service` the gateway's emulator backend starts (`go`
//!   variant, 500 Hz, on the device's private topics, on the emulators' shared thread), a command
//!   writer on its command topic (the gateway's device writes no command without a client: the
//!   fleet's status reports it, `dex1_cmd_hz`) and a state reader whose listener takes each sample
//!   into a reused buffer and makes the front's publish from there (`write_with`, as above);
//! - each front's command reader (no client: no sample).
//!
//! What it leaves out is handgate's: the Dex3 loop's schedule, statistics, command slot, state
//! conversion and watch channels, the DDS-client device loops ticking at 500 Hz, the fronts'
//! cores, grids and locks, supervision, status, the tokio runtime.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Writer};
use handgate_adapters::dds_device::{emulator_topics, CMD_QOS};
use handgate_adapters::dex1::emulator::{Dex1Config, Dex1Emulator, Dex1Variant};
use handgate_adapters::dex3::usb::EmulatorConfig;
use handgate_adapters::dex3::{Dex3Command, Dex3Measurement, Side};
use handgate_adapters::emu_common::Hz;
use handgate_adapters::front::serve::{COMMAND_QOS, STATE_QOS};
use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};
use handgate_idl::unitree_hg::{HandCmd_, HandState_, DEX3_MOTORS, DEX3_PRESS_SENSORS};
use serde::{Deserialize, Serialize};

use crate::child::Proc;
use crate::fleet::{per_cycle, CycleCost};
use crate::stats::{cpu_seconds, group_costs, status_kb, task_cpu, task_switches, GroupCost, Summary};

/// The Dex3 loop's rate, the Dex1 service's, the fronts' state and the Dex3 front's
/// low-frequency copy (the fleet's profile: docs/fronts.md's defaults).
const DEX3_HZ: u64 = 1000;
const DEX1_HZ: f64 = 500.0;
const FRONT_HZ: u64 = 500;
const LF_HZ: u64 = 50;

/// The thread groups of each kind in the reference ([`crate::stats::thread_group`] names).
pub const REF_KIND_GROUPS: &[(&str, &[&str])] = &[("dex3", &["ref-hand-usb"]), ("dex1", &["emu-shared-"])];

/// Cycles done per device, since the reference started.
struct Counts {
    dex3: Vec<AtomicU64>,
    dex3_missed: Vec<AtomicU64>,
    dex1: Vec<AtomicU64>,
}

fn counters(n: usize) -> Vec<AtomicU64> {
    (0..n).map(|_| AtomicU64::new(0)).collect()
}

fn side(i: usize) -> Side {
    if i % 2 == 0 {
        Side::Left
    } else {
        Side::Right
    }
}

/// The Dex3 front's state from a measurement (built only when a client reads it).
fn hand_state(m: &Dex3Measurement) -> HandState_ {
    let mut s = HandState_::with_sizes(DEX3_MOTORS, DEX3_PRESS_SENSORS);
    for (w, m) in s.motor_state.iter_mut().zip(&m.motors) {
        w.q = m.q;
        w.dq = m.dq;
        w.tau_est = m.tau;
    }
    s
}

/// One emulated Dex3 hand: an exchange per deadline of the shared 1 kHz grid, the front's
/// publishes after it. Runs until the process ends.
fn hand(
    i: usize,
    mut ex: crate::hop::Exchange,
    mut front: Writer<HandState_>,
    mut lf: Writer<HandState_>,
    counts: Arc<Counts>,
) {
    let period = Duration::from_nanos(1_000_000_000 / DEX3_HZ);
    let table = handgate_adapters::dex3::table::table(side(i));
    let mut cmd = Dex3Command::damping(table.hold_kd);
    let mut held = false;
    let mut k: u64 = 0;
    let mut next = handgate_adapters::loops::grid_at_or_after(Instant::now(), period);
    loop {
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
        match ex.send(&cmd) {
            Ok(m) => {
                if !held {
                    // As the gateway's loop without a client: hold where the hand was measured.
                    cmd = Dex3Command::hold(std::array::from_fn(|j| m.motors[j].q), table.hold_kp, table.hold_kd);
                    held = true;
                }
                if k % (DEX3_HZ / FRONT_HZ) == 0 {
                    let _ = front.write_with(|| Some(hand_state(m)));
                }
                if k % (DEX3_HZ / LF_HZ) == 0 {
                    let _ = lf.write_with(|| Some(hand_state(m)));
                }
                counts.dex3[i].fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => eprintln!("fleet reference: dex3_{i:02}: exchange failed: {e}"),
        }
        // Absolute deadlines; those woken too late for are skipped (the gateway's schedule).
        k += 1;
        next += period;
        let now = Instant::now();
        if now > next {
            let behind = ((now - next).as_nanos() / period.as_nanos()) as u64 + 1;
            k += behind;
            next += period * behind as u32;
            counts.dex3_missed[i].fetch_add(behind, Ordering::Relaxed);
        }
    }
}

/// The reference process (`handgate-bench fleet-reference`): starts everything, prints `READY`
/// once every device did a cycle, then every 500 ms a `COUNTS` line ([`CountsLine`]). Runs
/// until killed.
pub fn run(n3: usize, n1: usize, domain: u32) -> anyhow::Result<()> {
    let node = Node::new(domain, None)?;
    let counts = Arc::new(Counts {
        dex3: counters(n3),
        dex3_missed: counters(n3),
        dex1: counters(n1),
    });
    let mut dex1_peers = Vec::new();
    let mut cmd_readers = (Vec::new(), Vec::new());
    for i in 0..n1 {
        let name = format!("dex1_{i:02}");
        let (cmd_topic, state_topic) = emulator_topics(&name);
        let mut cfg = Dex1Config::new(Dex1Variant::Go, side(i));
        cfg.rate = Hz(DEX1_HZ);
        cfg.topics = Some((cmd_topic.clone(), state_topic.clone()));
        let emu = Dex1Emulator::start(&node, cfg)?;
        let cmd_writer = node.writer::<MotorCmds_>(&cmd_topic, CMD_QOS)?;
        cmd_readers
            .1
            .push(node.reader::<MotorCmds_>(&format!("rt/bench/{name}/cmd"), COMMAND_QOS)?);
        let mut front = node.writer::<MotorStates_>(&format!("rt/bench/{name}/state"), STATE_QOS)?;
        let c = counts.clone();
        let mut v = Vec::new();
        let reader = node.reader_with_callback::<MotorStates_, _>(&state_topic, STATE_QOS, move |h| {
            let n = h.take_into(&mut v);
            if n > 0 {
                c.dex1[i].fetch_add(n as u64, Ordering::Relaxed);
                if let Some(s) = v.pop() {
                    let _ = front.write_with(|| Some(s));
                }
                v.clear();
            }
        })?;
        dex1_peers.push((emu, cmd_writer, reader));
    }
    for i in 0..n3 {
        let name = format!("dex3_{i:02}");
        let ex = crate::hop::Exchange::with(side(i), EmulatorConfig::default())?;
        let front = node.writer::<HandState_>(&format!("rt/bench/{name}/state"), STATE_QOS)?;
        let lf = node.writer::<HandState_>(&format!("rt/bench/lf/{name}/state"), STATE_QOS)?;
        cmd_readers
            .0
            .push(node.reader::<HandCmd_>(&format!("rt/bench/{name}/cmd"), COMMAND_QOS)?);
        let c = counts.clone();
        std::thread::Builder::new()
            .name("ref-hand-usb".into())
            .spawn(move || hand(i, ex, front, lf, c))?;
    }
    let t0 = Instant::now();
    let all = |v: &[AtomicU64]| v.iter().all(|c| c.load(Ordering::Relaxed) > 0);
    while !(all(&counts.dex3) && all(&counts.dex1)) {
        anyhow::ensure!(
            t0.elapsed() < Duration::from_secs(60),
            "fleet reference: not every device did a cycle within 60 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    println!("READY");
    let csv = |v: &[AtomicU64]| {
        v.iter()
            .map(|c| c.load(Ordering::Relaxed).to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    loop {
        std::thread::sleep(Duration::from_millis(500));
        println!(
            "COUNTS {} {} {} {}",
            t0.elapsed().as_nanos(),
            csv(&counts.dex3),
            csv(&counts.dex3_missed),
            csv(&counts.dex1)
        );
    }
}

/// A `COUNTS` line: the reference's time (s since its start) and per device the cycles done
/// (Dex3 exchanges, Dex1 state samples taken) and the Dex3 deadlines missed.
#[derive(Debug, Clone, PartialEq)]
pub struct CountsLine {
    pub t: f64,
    pub dex3: Vec<u64>,
    pub dex3_missed: Vec<u64>,
    pub dex1: Vec<u64>,
}

impl CountsLine {
    pub fn parse(l: &str) -> anyhow::Result<Self> {
        let mut f = l.split(' ');
        anyhow::ensure!(f.next() == Some("COUNTS"), "not a COUNTS line: {l:?}");
        let mut next = || f.next().ok_or_else(|| anyhow::anyhow!("short COUNTS line: {l:?}"));
        let t = next()?.parse::<u128>()? as f64 / 1e9;
        let list = |s: &str| -> anyhow::Result<Vec<u64>> {
            s.split(',').filter(|x| !x.is_empty()).map(|x| Ok(x.parse()?)).collect()
        };
        Ok(Self {
            t,
            dex3: list(next()?)?,
            dex3_missed: list(next()?)?,
            dex1: list(next()?)?,
        })
    }
}

/// One window of the reference process.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferenceResult {
    pub secs: f64,
    /// Reference CPU over the window, % of one core.
    pub cpu_pct: f64,
    pub rss_mb: f64,
    pub threads: f64,
    /// Per-device cycle rate over the window (Dex3 exchanges, Dex1 state samples taken), Hz.
    pub dex3_hz: Option<Summary>,
    pub dex1_hz: Option<Summary>,
    /// Dex3 deadlines missed in the window, summed over the hands.
    pub dex3_missed: u64,
    /// Device cycles per second, all devices.
    pub cycles_hz: f64,
    /// CPU per device cycle, µs.
    pub cpu_us_per_cycle: Option<f64>,
    pub groups: Vec<GroupCost>,
    /// As [`crate::fleet::FleetResult::per_cycle`], with the reference's own threads per kind
    /// ([`REF_KIND_GROUPS`]).
    pub per_cycle: Vec<CycleCost>,
    pub load1: [f64; 2],
}

/// Measures the running reference `p` for `secs` after `warm`.
pub fn measure(p: &Proc, secs: f64, warm: Duration) -> anyhow::Result<ReferenceResult> {
    std::thread::sleep(warm);
    let line = Duration::from_secs(5);
    let first = CountsLine::parse(&p.next_line("COUNTS", line)?)?;
    let pid = p.pid();
    let load0 = crate::stats::loadavg()[0];
    let c0 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let tasks0 = task_cpu(pid);
    let switches0 = task_switches(pid);
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs_f64((secs - 0.25).max(0.0)));
    let last = CountsLine::parse(&p.next_line("COUNTS", line)?)?;
    let wall = t0.elapsed().as_secs_f64();
    let c1 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let tasks1 = task_cpu(pid);
    let switches1 = task_switches(pid);
    let load1 = [load0, crate::stats::loadavg()[0]];
    let span = (last.t - first.t).max(1e-9);
    let rates = |a: &[u64], b: &[u64]| -> Vec<f64> {
        a.iter()
            .zip(b)
            .map(|(a, b)| b.saturating_sub(*a) as f64 / span)
            .collect()
    };
    let (r3, r1) = (rates(&first.dex3, &last.dex3), rates(&first.dex1, &last.dex1));
    let (hz3, hz1): (f64, f64) = (r3.iter().sum(), r1.iter().sum());
    let cpu_pct = 100.0 * (c1 - c0) / wall;
    let groups = group_costs((&tasks0, &tasks1), (&switches0, &switches1), wall);
    let cycles_hz = hz3 + hz1;
    Ok(ReferenceResult {
        secs: wall,
        cpu_pct,
        rss_mb: status_kb(pid, "VmRSS").unwrap_or(f64::NAN) / 1024.0,
        threads: status_kb(pid, "Threads").unwrap_or(f64::NAN),
        dex3_hz: Summary::of(&r3),
        dex1_hz: Summary::of(&r1),
        dex3_missed: last
            .dex3_missed
            .iter()
            .zip(&first.dex3_missed)
            .map(|(b, a)| b.saturating_sub(*a))
            .sum(),
        cycles_hz,
        cpu_us_per_cycle: (cycles_hz > 0.0).then(|| cpu_pct / 100.0 * 1e6 / cycles_hz),
        per_cycle: per_cycle(&groups, REF_KIND_GROUPS, &[("dex3", hz3), ("dex1", hz1)]),
        groups,
        load1,
    })
}

/// Starts the reference (`bench`: this binary) on `domain`, measures it and stops it.
pub fn run_and_measure(
    bench: &std::path::Path,
    n3: usize,
    n1: usize,
    domain: u32,
    secs: f64,
    warm: Duration,
) -> anyhow::Result<ReferenceResult> {
    let mut c = std::process::Command::new(bench);
    c.args([
        "fleet-reference",
        "--dex3",
        &n3.to_string(),
        "--dex1",
        &n1.to_string(),
        "--domain",
        &domain.to_string(),
    ]);
    let p = Proc::start("fleet reference", c, "READY", Duration::from_secs(90))?;
    let r = measure(&p, secs, warm);
    p.stop();
    let r = r?;
    eprintln!("fleet reference: {r:?}");
    Ok(r)
}

/// The reference windows of a run pooled: CPU over their time, and CPU per cycle of each kind
/// and of all devices over their cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pooled {
    pub secs: f64,
    pub cpu_pct: f64,
    pub us_per_cycle: f64,
    /// Per kind's own threads per cycle of the kind: (dex3, dex1), and the rest per cycle of
    /// any device.
    pub dex3_us: f64,
    pub dex1_us: f64,
    pub rest_us: f64,
}

pub fn pooled(refs: &[ReferenceResult]) -> Option<Pooled> {
    if refs.is_empty() {
        return None;
    }
    let secs: f64 = refs.iter().map(|r| r.secs).sum();
    // CPU seconds and cycles of a set of threads over every window.
    let cost = |of: &str| {
        let (mut cpu, mut cycles) = (0.0, 0.0);
        for r in refs {
            if let Some(c) = r.per_cycle.iter().find(|c| c.cycles_of == of) {
                cpu += c.cpu_pct / 100.0 * r.secs;
                cycles += c.cycles_hz * r.secs;
            }
        }
        cpu * 1e6 / cycles
    };
    let cpu_s: f64 = refs.iter().map(|r| r.cpu_pct / 100.0 * r.secs).sum();
    let cycles: f64 = refs.iter().map(|r| r.cycles_hz * r.secs).sum();
    Some(Pooled {
        secs,
        cpu_pct: 100.0 * cpu_s / secs,
        us_per_cycle: cpu_s * 1e6 / cycles,
        dex3_us: cost("dex3"),
        dex1_us: cost("dex1"),
        rest_us: cost("all devices"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_counts_line_round_trips() {
        let l = CountsLine::parse("COUNTS 1500000000 10,11 0,2 5,6,7").unwrap();
        assert_eq!(l.t, 1.5);
        assert_eq!(
            (l.dex3, l.dex3_missed, l.dex1),
            (vec![10, 11], vec![0, 2], vec![5, 6, 7])
        );
        assert!(CountsLine::parse("READY").is_err());
    }
}
