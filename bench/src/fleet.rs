//! Benchmark 4: fleet scale. One gateway serving `n3` emulated Dex3 (USB protocol, 1 kHz)
//! and `n1` emulated Dex1 (500 Hz), each with its Dex3/Dex1 front on private topics, on a
//! private domain: CPU, RSS, per-device state rate and missed cycles.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::handgate::GatewayStatus_;
use serde::{Deserialize, Serialize};

use crate::stats::{cpu_seconds, group_costs, group_cpu, status_kb, task_cpu, task_switches, GroupCost, Summary};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FleetResult {
    pub dex3: usize,
    pub dex1: usize,
    pub secs: f64,
    /// Gateway CPU over the window, % of one core.
    pub cpu_pct: f64,
    pub rss_mb: f64,
    pub peak_rss_mb: f64,
    pub threads: f64,
    /// Per-device mean state rate over the window (status topic), Hz, per kind.
    pub dex3_state_hz: Option<Summary>,
    pub dex1_state_hz: Option<Summary>,
    /// Cycles missed during the window, summed over the devices of a kind.
    pub dex3_missed: u64,
    pub dex1_missed: u64,
    /// Devices reported by the last status sample.
    pub devices_seen: usize,
    /// Gateway CPU per device cycle (CPU time over the window / the state samples all devices
    /// produced in it), µs.
    #[serde(default)]
    pub cpu_us_per_cycle: Option<f64>,
    /// % of one core per thread group over the window (emulator threads included: they are
    /// in-process here), largest first.
    #[serde(default)]
    pub threads_cpu: Vec<(String, f64)>,
    /// Per thread group: CPU, wake-ups (voluntary context switches) and preemptions per second,
    /// CPU per wake-up; largest CPU first.
    #[serde(default)]
    pub groups: Vec<GroupCost>,
    /// Per device kind, µs of CPU per device cycle of that kind spent on the threads that
    /// serve only that kind (Dex3: the `dex3-usb-loop` threads, emulator included; Dex1: the
    /// DDS-client device loops and the emulated peers' shared thread), and the rest (fronts,
    /// status, CycloneDDS: every thread serving all devices) per cycle of any device.
    #[serde(default)]
    pub per_cycle: Vec<CycleCost>,
    /// The 1-minute load average at the start and at the end of the window (the machine is
    /// shared: a figure carries its load).
    #[serde(default)]
    pub load1: Option<[f64; 2]>,
    /// Commands the gateway sent each Dex1 device (its DDS writes on the device's command
    /// topic), per device, Hz: what the reference must write too (none without a client).
    #[serde(default)]
    pub dex1_cmd_hz: Option<f64>,
    /// The reference ([`crate::fleet_ref`]) measured in the same run: a window right before the
    /// gateway's and one right after (empty: not measured).
    #[serde(default)]
    pub reference: Vec<crate::fleet_ref::ReferenceResult>,
}

/// CPU per device cycle on one set of threads.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CycleCost {
    /// What the cycles are: "dex3", "dex1" or "all devices".
    pub cycles_of: String,
    /// The thread groups counted ([`crate::stats::thread_group`] names).
    pub groups: Vec<String>,
    /// Their % of one core.
    pub cpu_pct: f64,
    /// Device cycles per second (the state rates summed over the devices).
    pub cycles_hz: f64,
    /// µs of CPU per cycle.
    pub us_per_cycle: f64,
}

/// Which thread groups serve only one kind of the fleet (the rest serve every device).
const KIND_GROUPS: &[(&str, &[&str])] = &[
    ("dex3", &["dex-usb-loop"]),
    ("dex1", &["dev-* (DDS-client device loops)", "emu-shared-"]),
];

/// CPU per device cycle over `groups`: each kind's own threads (`kinds`: kind and its thread
/// groups) per cycle of that kind (`hz`: kind and its device cycles per second), every other
/// thread per cycle of any device.
pub fn per_cycle(groups: &[GroupCost], kinds: &[(&str, &[&str])], hz: &[(&str, f64)]) -> Vec<CycleCost> {
    let cost = |cycles_of: &str, names: Vec<String>, cycles_hz: f64| {
        let cpu_pct: f64 = groups
            .iter()
            .filter(|g| names.contains(&g.group))
            .map(|g| g.cpu_pct)
            .sum();
        CycleCost {
            cycles_of: cycles_of.into(),
            us_per_cycle: if cycles_hz > 0.0 {
                cpu_pct / 100.0 * 1e6 / cycles_hz
            } else {
                f64::NAN
            },
            groups: names,
            cpu_pct,
            cycles_hz,
        }
    };
    let hz_of = |k: &str| hz.iter().find(|(n, _)| *n == k).map_or(0.0, |(_, h)| *h);
    let mut out: Vec<CycleCost> = kinds
        .iter()
        .map(|(kind, gs)| cost(kind, gs.iter().map(|g| g.to_string()).collect(), hz_of(kind)))
        .collect();
    let rest = groups
        .iter()
        .map(|g| g.group.clone())
        .filter(|g| !kinds.iter().any(|(_, gs)| gs.contains(&g.as_str())))
        .collect();
    out.push(cost("all devices", rest, hz.iter().map(|(_, h)| h).sum()));
    out
}

/// The profile: `n3` Dex3 + `n1` Dex1 on emulators with their fronts on `rt/bench/...`.
pub fn profile(n3: usize, n1: usize) -> String {
    let mut s = String::from(
        "# Generated by handgate-bench fleet (make bench): the fleet-scale benchmark.\n\
         name = \"bench-fleet\"\n\
         description = \"fleet-scale benchmark: emulated Dex3 at 1 kHz and Dex1 at 500 Hz\"\n\n\
         [dds]\ndomain = 110\n\n[log]\nlevel = \"warn\"\n\n[status]\nrate_hz = 1\n\n",
    );
    let side = |i: usize| if i % 2 == 0 { "left" } else { "right" };
    for i in 0..n3 {
        let _ = write!(
            s,
            "[[devices]]\nname = \"dex3_{i:02}\"\nkind = \"dex3\"\nside = \"{}\"\nbackend = \"emulator\"\n\n",
            side(i)
        );
    }
    for i in 0..n1 {
        let _ = write!(
            s,
            "[[devices]]\nname = \"dex1_{i:02}\"\nkind = \"dex1\"\nside = \"{}\"\nbackend = \"emulator\"\nrate_hz = 500\n\n",
            side(i)
        );
    }
    for i in 0..n3 {
        let _ = write!(
            s,
            "[[fronts]]\nkind = \"dex3\"\ndevice = \"dex3_{i:02}\"\ncmd_topic = \"rt/bench/dex3_{i:02}/cmd\"\n\
             state_topic = \"rt/bench/dex3_{i:02}/state\"\nlf_state_topic = \"rt/bench/lf/dex3_{i:02}/state\"\n\n"
        );
    }
    for i in 0..n1 {
        let _ = write!(
            s,
            "[[fronts]]\nkind = \"dex1\"\ndevice = \"dex1_{i:02}\"\nvariant = \"go\"\ncmd_topic = \"rt/bench/dex1_{i:02}/cmd\"\n\
             state_topic = \"rt/bench/dex1_{i:02}/state\"\n\n"
        );
    }
    s
}

/// What one window of a running gateway's status gives: process figures and, per device, the
/// mean state rate and the cycles missed during the window.
struct Window {
    wall: f64,
    cpu_pct: f64,
    rss_mb: f64,
    peak_rss_mb: f64,
    threads: f64,
    /// The last status sample of the window.
    last: GatewayStatus_,
    /// Mean state rate over the window, per device.
    rate: HashMap<String, f64>,
    /// Cycles missed during the window, per device.
    missed: HashMap<String, u64>,
    /// Mean command rate over the window, per device (commands the gateway sent it).
    cmd_rate: HashMap<String, f64>,
    /// % of one core per thread group.
    threads_cpu: Vec<(String, f64)>,
    groups: Vec<GroupCost>,
    load1: [f64; 2],
}

impl Window {
    /// CPU per device cycle, µs: CPU time over the window / the state samples of every device.
    fn cpu_us_per_cycle(&self) -> Option<f64> {
        let cycles: f64 = self.rate.values().sum::<f64>() * self.wall;
        (cycles > 0.0).then(|| self.cpu_pct / 100.0 * self.wall * 1e6 / cycles)
    }
}

impl Window {
    /// Device cycles per second of `kind` (`None`: every device).
    fn cycles_hz(&self, kind: Option<&str>) -> f64 {
        self.last
            .devices
            .iter()
            .filter(|d| kind.map_or(true, |k| d.kind == k))
            .filter_map(|d| self.rate.get(&d.device))
            .sum()
    }

    /// CPU per device cycle: each kind's own threads ([`KIND_GROUPS`]) per cycle of that kind,
    /// every other thread per cycle of any device.
    fn per_cycle(&self) -> Vec<CycleCost> {
        per_cycle(
            &self.groups,
            KIND_GROUPS,
            &[
                ("dex3", self.cycles_hz(Some("dex3"))),
                ("dex1", self.cycles_hz(Some("dex1"))),
            ],
        )
    }

    /// The mean command rate over the window of the devices of `kind`, Hz.
    fn cmd_hz(&self, kind: &str) -> Option<f64> {
        let v: Vec<f64> = self
            .last
            .devices
            .iter()
            .filter(|d| d.kind == kind)
            .filter_map(|d| self.cmd_rate.get(&d.device).copied())
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }

    /// The state-rate summary over the devices of `kind` and their missed cycles, summed.
    fn kind(&self, kind: &str) -> (Option<Summary>, u64) {
        let devs: Vec<_> = self.last.devices.iter().filter(|d| d.kind == kind).collect();
        let means: Vec<f64> = devs.iter().filter_map(|d| self.rate.get(&d.device).copied()).collect();
        let missed = devs
            .iter()
            .map(|d| self.missed.get(&d.device).copied().unwrap_or(0))
            .sum();
        (Summary::of(&means), missed)
    }
}

/// Waits (up to 60 s) for a status sample from `node` where `ready` holds, lets the gateway
/// (`pid`) run `warm`, then measures it for `secs`.
fn window(
    node: &Node,
    pid: u32,
    what: &str,
    ready: impl Fn(&GatewayStatus_) -> bool,
    secs: f64,
    warm: Duration,
) -> anyhow::Result<Window> {
    let reader = node.reader::<GatewayStatus_>("rt/handgate/status", Qos::Reliable { depth: 1 })?;
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        if reader.take().pop().is_some_and(|s| ready(&s)) {
            break;
        }
        anyhow::ensure!(Instant::now() < deadline, "{what} within 60 s");
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(warm);
    let _ = reader.take();
    let first = reader.wait_take(Duration::from_secs(5))?.pop().expect("one sample");
    let load0 = crate::stats::loadavg()[0];
    let c0 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let tasks0 = task_cpu(pid);
    let switches0 = task_switches(pid);
    let t0 = Instant::now();
    let mut rates: HashMap<String, Vec<f64>> = HashMap::new();
    let mut cmd_rates: HashMap<String, Vec<f64>> = HashMap::new();
    let mut last = first.clone();
    while t0.elapsed().as_secs_f64() < secs {
        for s in reader.take() {
            for d in &s.devices {
                rates
                    .entry(d.device.clone())
                    .or_default()
                    .push(f64::from(d.state_rate_hz));
                cmd_rates
                    .entry(d.device.clone())
                    .or_default()
                    .push(f64::from(d.cmd_rate_hz));
            }
            last = s;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let wall = t0.elapsed().as_secs_f64();
    let c1 = cpu_seconds(pid).unwrap_or(f64::NAN);
    let tasks1 = task_cpu(pid);
    let switches1 = task_switches(pid);
    let threads_cpu = group_cpu(&tasks0, &tasks1, wall);
    let groups = group_costs((&tasks0, &tasks1), (&switches0, &switches1), wall);
    let load1 = [load0, crate::stats::loadavg()[0]];
    let missed0: HashMap<&str, u64> = first
        .devices
        .iter()
        .map(|d| (d.device.as_str(), d.missed_cycles))
        .collect();
    let missed = last
        .devices
        .iter()
        .map(|d| {
            let before = *missed0.get(d.device.as_str()).unwrap_or(&0);
            (d.device.clone(), d.missed_cycles.saturating_sub(before))
        })
        .collect();
    let mean = |m: HashMap<String, Vec<f64>>| {
        m.into_iter()
            .map(|(d, v)| (d, v.iter().sum::<f64>() / v.len().max(1) as f64))
            .collect()
    };
    let (rate, cmd_rate) = (mean(rates), mean(cmd_rates));
    Ok(Window {
        wall,
        cpu_pct: 100.0 * (c1 - c0) / wall,
        rss_mb: status_kb(pid, "VmRSS").unwrap_or(f64::NAN) / 1024.0,
        peak_rss_mb: status_kb(pid, "VmHWM").unwrap_or(f64::NAN) / 1024.0,
        threads: status_kb(pid, "Threads").unwrap_or(f64::NAN),
        last,
        rate,
        missed,
        cmd_rate,
        threads_cpu,
        groups,
        load1,
    })
}

/// Measures a running gateway (`pid`) for `secs`, reading its status topic on `node`.
pub fn measure(node: &Node, pid: u32, n3: usize, n1: usize, secs: f64, warm: Duration) -> anyhow::Result<FleetResult> {
    // Ready: every device reported fresh once.
    let w = window(
        node,
        pid,
        "the fleet did not report every device fresh",
        |s| s.devices.len() == n3 + n1 && s.devices.iter().all(|d| d.freshness == 0),
        secs,
        warm,
    )?;
    let (dex3_state_hz, dex3_missed) = w.kind("dex3");
    let (dex1_state_hz, dex1_missed) = w.kind("dex1");
    Ok(FleetResult {
        dex3: n3,
        dex1: n1,
        secs: w.wall,
        cpu_pct: w.cpu_pct,
        rss_mb: w.rss_mb,
        peak_rss_mb: w.peak_rss_mb,
        threads: w.threads,
        dex3_state_hz,
        dex3_missed,
        dex1_state_hz,
        dex1_missed,
        devices_seen: w.last.devices.len(),
        cpu_us_per_cycle: w.cpu_us_per_cycle(),
        threads_cpu: w.threads_cpu.clone(),
        per_cycle: w.per_cycle(),
        dex1_cmd_hz: w.cmd_hz("dex1"),
        groups: w.groups,
        load1: Some(w.load1),
        reference: Vec::new(),
    })
}

/// `loop_threads`: the profile's `[realtime] loop_threads` (None: the default).
pub fn write_profile(path: &Path, n3: usize, n1: usize, loop_threads: Option<usize>) -> anyhow::Result<()> {
    let mut p = profile(n3, n1);
    if let Some(n) = loop_threads {
        let _ = write!(p, "[realtime]\nloop_threads = {n}\n");
    }
    std::fs::write(path, p)?;
    Ok(())
}

/// One kind's devices in a measured profile.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct KindRow {
    pub kind: String,
    pub devices: usize,
    /// Per-device mean state rate over the window (status topic), Hz.
    pub state_hz: Option<Summary>,
    /// Cycles missed during the window, summed over the kind's devices.
    pub missed: u64,
}

/// A shipped profile (every kind at its own rates: `sim-all`) measured as it runs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProfileResult {
    pub profile: String,
    pub domain: u32,
    pub secs: f64,
    /// Gateway CPU over the window, % of one core.
    pub cpu_pct: f64,
    pub rss_mb: f64,
    pub peak_rss_mb: f64,
    pub threads: f64,
    pub devices_seen: usize,
    pub kinds: Vec<KindRow>,
}

/// Measures a running gateway (`pid`) on profile `profile` for `secs`: waits until its status
/// reports every device fresh, then CPU, RSS and each kind's state rates and missed cycles.
pub fn measure_profile(
    node: &Node,
    pid: u32,
    profile: &str,
    secs: f64,
    warm: Duration,
) -> anyhow::Result<ProfileResult> {
    // Fresh, or commanded only (a one-way interface such as rt/hand_sdk is never measured):
    // not stale.
    let w = window(
        node,
        pid,
        &format!("profile {profile}: not every device reported fresh (or commanded only)"),
        |s| !s.devices.is_empty() && s.devices.iter().all(|d| d.freshness != handgate_idl::handgate::STALE),
        secs,
        warm,
    )?;
    let mut kinds: Vec<String> = w.last.devices.iter().map(|d| d.kind.clone()).collect();
    kinds.sort();
    kinds.dedup();
    let kinds = kinds
        .into_iter()
        .map(|kind| {
            let (state_hz, missed) = w.kind(&kind);
            KindRow {
                devices: w.last.devices.iter().filter(|d| d.kind == kind).count(),
                state_hz,
                missed,
                kind,
            }
        })
        .collect();
    Ok(ProfileResult {
        profile: profile.to_string(),
        domain: node.domain_id(),
        secs: w.wall,
        cpu_pct: w.cpu_pct,
        rss_mb: w.rss_mb,
        peak_rss_mb: w.peak_rss_mb,
        threads: w.threads,
        devices_seen: w.last.devices.len(),
        kinds,
    })
}
