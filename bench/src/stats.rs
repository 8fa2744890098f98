//! Sample summaries (exact order statistics over the recorded samples) and host facts.

use serde::{Deserialize, Serialize};

/// median / p90 / p99 / max of a set of samples, in the samples' unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub n: usize,
    pub min: f64,
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Summary {
    /// Nearest-rank quantiles; `None` for no samples.
    pub fn of(samples: &[f64]) -> Option<Self> {
        if samples.is_empty() {
            return None;
        }
        let mut v = samples.to_vec();
        v.sort_by(f64::total_cmp);
        let q = |p: f64| {
            let rank = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len());
            v[rank - 1]
        };
        Some(Self {
            n: v.len(),
            min: v[0],
            median: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            max: v[v.len() - 1],
        })
    }
}

/// The 1-, 5- and 15-minute load averages.
pub fn loadavg() -> [f64; 3] {
    let s = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let mut it = s.split_whitespace().map(|x| x.parse().unwrap_or(f64::NAN));
    [
        it.next().unwrap_or(f64::NAN),
        it.next().unwrap_or(f64::NAN),
        it.next().unwrap_or(f64::NAN),
    ]
}

/// CPU model from /proc/cpuinfo.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .unwrap_or_default()
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .map(|r| r.trim_start_matches([' ', '\t', ':']).to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// Online CPUs.
pub fn nproc() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

/// utime + stime of a process, seconds.
pub fn cpu_seconds(pid: u32) -> Option<f64> {
    stat_cpu(&std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?).map(|(_, c)| c)
}

/// The command name and utime+stime, seconds, of a `/proc/<pid>[/task/<tid>]/stat` text.
fn stat_cpu(s: &str) -> Option<(String, f64)> {
    let (open, close) = (s.find('(')?, s.rfind(')')?);
    // Fields after the ")" that closes the command name: state is field 3, utime 14, stime 15.
    let f: Vec<&str> = s.get(close + 2..)?.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
    Some((s[open + 1..close].to_string(), (utime + stime) / hz.max(1.0)))
}

/// `parse` of each thread's `/proc/<pid>/task/<tid>/<file>`, by tid (threads whose file cannot
/// be read or parsed are left out).
fn per_task<V>(pid: u32, file: &str, parse: impl Fn(&str) -> Option<V>) -> std::collections::HashMap<u32, V> {
    let mut out = std::collections::HashMap::new();
    let Ok(dir) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return out;
    };
    for e in dir.flatten() {
        let Some(tid) = e.file_name().to_str().and_then(|t| t.parse::<u32>().ok()) else {
            continue;
        };
        if let Some(v) = std::fs::read_to_string(e.path().join(file))
            .ok()
            .as_deref()
            .and_then(&parse)
        {
            out.insert(tid, v);
        }
    }
    out
}

/// CPU seconds of each thread of `pid`, by tid: (thread name, utime+stime).
pub fn task_cpu(pid: u32) -> TaskCpu {
    per_task(pid, "stat", stat_cpu)
}

/// A thread's group for per-thread CPU tables: DDS device loops (`dev-<device>`) as one,
/// other names without their digits (`tokio-runtime-w`, `dex3-usb-loop`, emulator threads).
pub fn thread_group(name: &str) -> String {
    if name.starts_with("dev-") {
        return "dev-* (DDS-client device loops)".into();
    }
    name.chars().filter(|c| !c.is_ascii_digit()).collect()
}

/// % of one core per thread group between two [`task_cpu`] readings `wall` seconds apart
/// (threads that ended in between are not counted), largest first.
pub fn group_cpu(
    before: &std::collections::HashMap<u32, (String, f64)>,
    after: &std::collections::HashMap<u32, (String, f64)>,
    wall: f64,
) -> Vec<(String, f64)> {
    let mut g: std::collections::BTreeMap<String, f64> = std::collections::BTreeMap::new();
    for (tid, (name, c1)) in after {
        let c0 = before.get(tid).map_or(0.0, |b| b.1);
        *g.entry(thread_group(name)).or_default() += 100.0 * (c1 - c0) / wall.max(1e-9);
    }
    let mut v: Vec<(String, f64)> = g.into_iter().collect();
    v.sort_by(|a, b| b.1.total_cmp(&a.1));
    v
}

/// Context switches of each thread of `pid`, by tid: (thread name, voluntary, involuntary),
/// from `/proc/<pid>/task/<tid>/status`. A voluntary switch is the thread blocking (a sleep to
/// its next deadline, a wait for work), so over a window it counts the thread's wake-ups; an
/// involuntary one is the thread preempted while it could still run.
pub fn task_switches(pid: u32) -> TaskSwitches {
    per_task(pid, "status", |status| {
        let field = |key: &str| {
            status
                .lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix(':').map(str::trim))
        };
        Some((
            field("Name")?.to_string(),
            field("voluntary_ctxt_switches")?.parse().ok()?,
            field("nonvoluntary_ctxt_switches")?.parse().ok()?,
        ))
    })
}

/// [`task_cpu`]'s reading: (thread name, CPU seconds) by tid.
pub type TaskCpu = std::collections::HashMap<u32, (String, f64)>;
/// [`task_switches`]'s reading: (thread name, voluntary, involuntary) by tid.
pub type TaskSwitches = std::collections::HashMap<u32, (String, u64, u64)>;

/// One thread group over a window: CPU and context switches.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GroupCost {
    /// [`thread_group`]'s name.
    pub group: String,
    /// Threads of the group alive at the end of the window.
    pub threads: usize,
    /// % of one core.
    pub cpu_pct: f64,
    /// Voluntary context switches per second: the group's wake-ups.
    pub wakeups_hz: f64,
    /// Involuntary context switches per second (preempted while runnable).
    pub preempted_hz: f64,
    /// CPU per wake-up, µs (`None` without wake-ups).
    pub us_per_wakeup: Option<f64>,
}

/// Per thread group between two readings `wall` seconds apart ([`task_cpu`] and
/// [`task_switches`] before and after; threads that ended in between are not counted), CPU
/// largest first.
pub fn group_costs(cpu: (&TaskCpu, &TaskCpu), switches: (&TaskSwitches, &TaskSwitches), wall: f64) -> Vec<GroupCost> {
    let wall = wall.max(1e-9);
    let mut g: std::collections::BTreeMap<String, GroupCost> = std::collections::BTreeMap::new();
    for (tid, (name, c1)) in cpu.1 {
        let c0 = cpu.0.get(tid).map_or(0.0, |b| b.1);
        let e = g.entry(thread_group(name)).or_default();
        e.threads += 1;
        e.cpu_pct += 100.0 * (c1 - c0) / wall;
    }
    for (tid, (name, v1, n1)) in switches.1 {
        let (v0, n0) = switches.0.get(tid).map_or((0, 0), |b| (b.1, b.2));
        let e = g.entry(thread_group(name)).or_default();
        e.wakeups_hz += v1.saturating_sub(v0) as f64 / wall;
        e.preempted_hz += n1.saturating_sub(n0) as f64 / wall;
    }
    let mut v: Vec<GroupCost> = g
        .into_iter()
        .map(|(group, mut c)| {
            c.us_per_wakeup = (c.wakeups_hz > 0.0).then(|| c.cpu_pct / 100.0 * 1e6 / c.wakeups_hz);
            c.group = group;
            c
        })
        .collect();
    v.sort_by(|a, b| b.cpu_pct.total_cmp(&a.cpu_pct));
    v
}

/// A `/proc/<pid>/status` field in kB (VmRSS, VmHWM).
pub fn status_kb(pid: u32, key: &str) -> Option<f64> {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix(key)?.strip_prefix(':').map(str::to_string))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Summary::of(&v).unwrap();
        assert_eq!((s.median, s.p90, s.p99, s.max), (50.0, 90.0, 99.0, 100.0));
        assert!(Summary::of(&[]).is_none());
    }
}
