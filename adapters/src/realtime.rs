//! Real-time settings of the device-loop threads (a profile's `[realtime]`; docs/deployment.md,
//! "Real-time").
//!
//! Decided once per process: [`install`] checks, before any device opens, that this process
//! may use the settings (the scheduling policy and CPU affinity are tried on a short-lived
//! probe thread, so the calling thread and every thread that exists already keep theirs),
//! locks the process's memory when asked (`mlockall` is process-wide) and keeps the settings.
//! Every device-loop thread calls [`enter_device_loop`] first thing, which applies them to that
//! thread alone. Nothing installed (the default): nothing changes.
//!
//! Linux only (the gateway's platform): `sched_setscheduler`, `sched_setaffinity` and
//! `mlockall` through `libc`.

use std::fmt;
use std::io;
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

/// Lowest and highest `SCHED_FIFO` / `SCHED_RR` priority on Linux
/// (`sched_get_priority_min` / `_max`).
pub const PRIORITY_MIN: u32 = 1;
pub const PRIORITY_MAX: u32 = 99;

/// Highest CPU number a `cpu_set_t` holds (glibc's `CPU_SETSIZE`).
pub const MAX_CPUS: usize = libc::CPU_SETSIZE as usize;

/// `CAP_SYS_NICE` and `CAP_IPC_LOCK` (linux/capability.h), bits of `CapEff`.
const CAP_SYS_NICE: u32 = 23;
const CAP_IPC_LOCK: u32 = 14;

/// The scheduling policy of the device-loop threads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Policy {
    /// `SCHED_OTHER`: the threads keep the default time-sharing scheduling (today's behaviour).
    #[default]
    Other,
    /// `SCHED_FIFO`: runs until it blocks or a higher priority wakes.
    Fifo,
    /// `SCHED_RR`: `SCHED_FIFO` with a time slice among threads of the same priority.
    Rr,
}

impl Policy {
    /// Every value, in declaration order.
    pub const ALL: &'static [Policy] = &[Policy::Other, Policy::Fifo, Policy::Rr];

    /// The spelling used in profile files.
    pub fn as_str(self) -> &'static str {
        match self {
            Policy::Other => "other",
            Policy::Fifo => "fifo",
            Policy::Rr => "rr",
        }
    }

    /// The kernel's name.
    pub fn sched_name(self) -> &'static str {
        match self {
            Policy::Other => "SCHED_OTHER",
            Policy::Fifo => "SCHED_FIFO",
            Policy::Rr => "SCHED_RR",
        }
    }

    /// A real-time policy (takes a priority).
    pub fn is_realtime(self) -> bool {
        self != Policy::Other
    }

    fn to_libc(self) -> libc::c_int {
        match self {
            Policy::Other => libc::SCHED_OTHER,
            Policy::Fifo => libc::SCHED_FIFO,
            Policy::Rr => libc::SCHED_RR,
        }
    }
}

impl fmt::Display for Policy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What the device-loop threads run with, as a validated profile decided it.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Settings {
    pub policy: Policy,
    /// `PRIORITY_MIN..=PRIORITY_MAX` with a real-time policy; ignored with `Other`.
    pub priority: u32,
    /// CPU affinity of the device-loop threads; empty: not pinned.
    pub cpus: Vec<usize>,
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)` at start (process-wide).
    pub mlockall: bool,
}

impl Settings {
    /// Nothing asked for: today's behaviour.
    pub fn is_default(&self) -> bool {
        !self.per_thread() && !self.mlockall
    }

    /// Something to apply on each device-loop thread.
    pub fn per_thread(&self) -> bool {
        self.policy.is_realtime() || !self.cpus.is_empty()
    }
}

impl fmt::Display for Settings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.policy.is_realtime() {
            write!(f, "{} priority {}", self.policy.sched_name(), self.priority)?;
        } else {
            f.write_str("SCHED_OTHER")?;
        }
        if self.cpus.is_empty() {
            f.write_str(", any CPU")?;
        } else {
            write!(f, ", CPUs {}", CpuList(&self.cpus))?;
        }
        if self.mlockall {
            f.write_str(", memory locked (mlockall)")?;
        }
        Ok(())
    }
}

/// A CPU set printed as the kernel prints `Cpus_allowed_list`: `0-3,6`.
pub struct CpuList<'a>(pub &'a [usize]);

impl fmt::Display for CpuList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut v = self.0.to_vec();
        v.sort_unstable();
        v.dedup();
        if v.is_empty() {
            return f.write_str("(none)");
        }
        let mut first = true;
        let mut i = 0;
        while i < v.len() {
            let start = v[i];
            let mut end = start;
            while i + 1 < v.len() && v[i + 1] == end + 1 {
                i += 1;
                end = v[i];
            }
            if !first {
                f.write_str(",")?;
            }
            first = false;
            if start == end {
                write!(f, "{start}")?;
            } else {
                write!(f, "{start}-{end}")?;
            }
            i += 1;
        }
        Ok(())
    }
}

/// A resource limit (`getrlimit`); `None`: unlimited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limit {
    pub soft: Option<u64>,
    pub hard: Option<u64>,
}

impl Limit {
    fn read(resource: libc::__rlimit_resource_t) -> Option<Limit> {
        let mut r = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes into the rlimit it is given.
        if unsafe { libc::getrlimit(resource, &mut r) } != 0 {
            return None;
        }
        let v = |x: libc::rlim_t| (x != libc::RLIM_INFINITY).then_some(x);
        Some(Limit {
            soft: v(r.rlim_cur),
            hard: v(r.rlim_max),
        })
    }

    /// `RLIMIT_RTPRIO` of this process.
    pub fn rtprio() -> Option<Limit> {
        Self::read(libc::RLIMIT_RTPRIO)
    }

    /// `RLIMIT_MEMLOCK` of this process.
    pub fn memlock() -> Option<Limit> {
        Self::read(libc::RLIMIT_MEMLOCK)
    }
}

/// How a limit prints: a number, bytes in a readable unit, or `unlimited`.
struct Shown(Option<Limit>, bool);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let one = |f: &mut fmt::Formatter<'_>, v: Option<u64>| match v {
            None => f.write_str("unlimited"),
            Some(b) if self.1 && b >= 1 << 20 && b % (1 << 20) == 0 => write!(f, "{} MiB", b >> 20),
            Some(b) if self.1 && b >= 1 << 10 && b % (1 << 10) == 0 => write!(f, "{} KiB", b >> 10),
            Some(b) if self.1 => write!(f, "{b} bytes"),
            Some(n) => write!(f, "{n}"),
        };
        match self.0 {
            None => f.write_str("unknown"),
            Some(l) => {
                f.write_str("soft ")?;
                one(f, l.soft)?;
                f.write_str(", hard ")?;
                one(f, l.hard)
            }
        }
    }
}

/// Whether capability `cap` is in this process's effective set (`CapEff` of
/// /proc/self/status); `None` when that cannot be read.
pub fn has_capability(cap: u32) -> Option<bool> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let hex = status.lines().find_map(|l| l.strip_prefix("CapEff:"))?.trim();
    let bits = u64::from_str_radix(hex, 16).ok()?;
    Some(bits & (1u64 << cap) != 0)
}

fn cap_phrase(name: &str, has: Option<bool>) -> String {
    match has {
        Some(true) => format!("{name} (which this process has)"),
        Some(false) => format!("{name} (which this process lacks)"),
        None => name.to_string(),
    }
}

/// Why the settings cannot be used. Each message names the profile key, what the kernel
/// refused, the privilege that is missing and the fix.
#[derive(Debug, thiserror::Error)]
pub enum RealtimeError {
    /// `sched_setscheduler` refused a real-time policy (EPERM).
    #[error("{}", sched_refused(*.policy, *.priority, .rtprio, *.cap_sys_nice))]
    SchedRefused {
        policy: Policy,
        priority: u32,
        rtprio: Option<Limit>,
        cap_sys_nice: Option<bool>,
    },
    /// `sched_setscheduler` failed otherwise.
    #[error("[realtime] policy = \"{policy}\", priority = {priority}: the kernel refused {} at priority {priority}: {os}", .policy.sched_name())]
    Sched {
        policy: Policy,
        priority: u32,
        os: io::Error,
    },
    /// A CPU of `cpus` this process may not run on.
    #[error("[realtime] cpus = [{}]: {} (this process may use CPUs {}){}", .requested.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", "), cpus_refused(.requested, .allowed), CpuList(.allowed), .os.as_ref().map(|e| format!("; sched_setaffinity: {e}")).unwrap_or_default())]
    Cpus {
        requested: Vec<usize>,
        allowed: Vec<usize>,
        os: Option<io::Error>,
    },
    /// Memory cannot be locked (or would stop growing once locked).
    #[error("{}", mlock_refused(.cause, .memlock, *.cap_ipc_lock))]
    Mlockall {
        cause: String,
        memlock: Option<Limit>,
        cap_ipc_lock: Option<bool>,
    },
    /// The CPUs this process may use cannot be read.
    #[error("[realtime] cannot read this process's CPU affinity: {0}")]
    Affinity(io::Error),
    /// The probe thread could not be started.
    #[error("[realtime] cannot start the probe thread: {0}")]
    Probe(io::Error),
    /// A second [`install`] in one process with other settings.
    #[error("[realtime] this process already runs its device loops with {installed}; it cannot switch to {requested}")]
    AlreadyInstalled { installed: Settings, requested: Settings },
}

fn sched_refused(policy: Policy, priority: u32, rtprio: &Option<Limit>, cap: Option<bool>) -> String {
    let mut s = format!(
        "[realtime] policy = \"{policy}\", priority = {priority}: the kernel refused {} at priority {priority} \
         (EPERM): it needs {} or RLIMIT_RTPRIO of at least {priority} (now {}). Fix: in the systemd unit add \
         `LimitRTPRIO={priority}`, or `AmbientCapabilities=CAP_SYS_NICE` with CAP_SYS_NICE in \
         `CapabilityBoundingSet=` (docs/deployment.md, \"Real-time\"); \
         from a shell, `ulimit -r {priority}` (up to the hard limit) or an `rtprio` line in \
         /etc/security/limits.conf; or remove `policy` from [realtime] (default \"other\")",
        policy.sched_name(),
        cap_phrase("CAP_SYS_NICE", cap),
        Shown(*rtprio, false),
    );
    if cap == Some(true) {
        s.push_str(
            ". This process has CAP_SYS_NICE, so the refusal comes from elsewhere: most likely its cgroup \
             has no real-time budget (cpu.rt_runtime_us = 0 with CONFIG_RT_GROUP_SCHED, e.g. in a container)",
        );
    }
    s
}

fn cpus_refused(requested: &[usize], allowed: &[usize]) -> String {
    let bad: Vec<String> = requested
        .iter()
        .filter(|c| !allowed.contains(c))
        .map(|c| c.to_string())
        .collect();
    match bad.len() {
        0 => "the kernel refused this CPU set".to_string(),
        1 => format!("CPU {} is not one this process may run on", bad[0]),
        _ => format!("CPUs {} are not ones this process may run on", bad.join(", ")),
    }
}

fn mlock_refused(cause: &str, memlock: &Option<Limit>, cap: Option<bool>) -> String {
    format!(
        "[realtime] mlockall = true: {cause}: locking the gateway's memory needs RLIMIT_MEMLOCK = unlimited \
         (now {}) or {}. Fix: in the systemd unit add `LimitMEMLOCK=infinity`, or \
         `AmbientCapabilities=CAP_IPC_LOCK` with CAP_IPC_LOCK in `CapabilityBoundingSet=` (docs/deployment.md, \"Real-time\"); from a shell, \
         `ulimit -l unlimited`; or set mlockall = false",
        Shown(*memlock, true),
        cap_phrase("CAP_IPC_LOCK", cap),
    )
}

/// The CPUs the calling thread may run on (`sched_getaffinity`): the process's set, unless
/// the thread was pinned.
pub fn allowed_cpus() -> io::Result<Vec<usize>> {
    // SAFETY: a zeroed cpu_set_t is an empty set; sched_getaffinity fills it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    if unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok((0..MAX_CPUS).filter(|&c| unsafe { libc::CPU_ISSET(c, &set) }).collect())
}

/// Applies `s` to the calling thread: CPU affinity, then the scheduling policy (with
/// `SCHED_RESET_ON_FORK`, so a thread it starts does not inherit a real-time policy).
/// `Policy::Other` leaves the thread's scheduling as it is.
pub fn apply_to_current_thread(s: &Settings) -> Result<(), RealtimeError> {
    if !s.cpus.is_empty() {
        // SAFETY: as in allowed_cpus; CPU_SET only for numbers below CPU_SETSIZE.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        for &c in &s.cpus {
            if c >= MAX_CPUS {
                return Err(RealtimeError::Cpus {
                    requested: s.cpus.clone(),
                    allowed: allowed_cpus().unwrap_or_default(),
                    os: None,
                });
            }
            unsafe { libc::CPU_SET(c, &mut set) };
        }
        // pid 0: the calling thread.
        if unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) } != 0 {
            let source = io::Error::last_os_error();
            return Err(RealtimeError::Cpus {
                requested: s.cpus.clone(),
                allowed: allowed_cpus().unwrap_or_default(),
                os: Some(source),
            });
        }
    }
    if s.policy.is_realtime() {
        let param = libc::sched_param {
            sched_priority: s.priority as libc::c_int,
        };
        // pid 0: the calling thread (Linux schedules threads).
        let rc = unsafe { libc::sched_setscheduler(0, s.policy.to_libc() | libc::SCHED_RESET_ON_FORK, &param) };
        if rc != 0 {
            let source = io::Error::last_os_error();
            return Err(if source.raw_os_error() == Some(libc::EPERM) {
                RealtimeError::SchedRefused {
                    policy: s.policy,
                    priority: s.priority,
                    rtprio: Limit::rtprio(),
                    cap_sys_nice: has_capability(CAP_SYS_NICE),
                }
            } else {
                RealtimeError::Sched {
                    policy: s.policy,
                    priority: s.priority,
                    os: source,
                }
            });
        }
    }
    Ok(())
}

/// Checks `cpus` against the CPUs this thread may use.
fn check_cpus(cpus: &[usize]) -> Result<(), RealtimeError> {
    if cpus.is_empty() {
        return Ok(());
    }
    let allowed = allowed_cpus().map_err(RealtimeError::Affinity)?;
    if cpus.iter().all(|c| allowed.contains(c)) {
        Ok(())
    } else {
        Err(RealtimeError::Cpus {
            requested: cpus.to_vec(),
            allowed,
            os: None,
        })
    }
}

/// Tries `s` on a thread of its own, which then ends.
fn probe(s: &Settings) -> Result<(), RealtimeError> {
    let probe = s.clone();
    std::thread::Builder::new()
        .name("realtime-probe".into())
        .spawn(move || apply_to_current_thread(&probe))
        .map_err(RealtimeError::Probe)?
        .join()
        .unwrap_or_else(|_| Err(RealtimeError::Probe(io::Error::other("the probe thread panicked"))))
}

/// `mlockall(MCL_CURRENT | MCL_FUTURE)`. Refused up front when the lock would later stop
/// the process from growing: without CAP_IPC_LOCK, memory locked under MCL_FUTURE counts
/// against RLIMIT_MEMLOCK, and an allocation past it fails.
fn lock_memory() -> Result<(), RealtimeError> {
    let memlock = Limit::memlock();
    let cap = has_capability(CAP_IPC_LOCK);
    let limited = memlock.map_or(true, |l| l.soft.is_some());
    if cap != Some(true) && limited {
        return Err(RealtimeError::Mlockall {
            cause: "with MCL_FUTURE every later allocation is locked too, and past RLIMIT_MEMLOCK it fails".into(),
            memlock,
            cap_ipc_lock: cap,
        });
    }
    // SAFETY: no pointers involved.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } != 0 {
        let e = io::Error::last_os_error();
        return Err(RealtimeError::Mlockall {
            cause: format!("mlockall(MCL_CURRENT | MCL_FUTURE) failed: {e}"),
            memlock,
            cap_ipc_lock: cap,
        });
    }
    Ok(())
}

static INSTALLED: OnceLock<Settings> = OnceLock::new();

/// Checks and keeps `s` for every device-loop thread started from now on; call it before any
/// device opens. Default settings change nothing and are not kept. A second call with the
/// same settings is a no-op; with others, an error (the process is already set up).
pub fn install(s: Settings) -> Result<(), RealtimeError> {
    if let Some(cur) = INSTALLED.get() {
        return if *cur == s {
            Ok(())
        } else {
            Err(RealtimeError::AlreadyInstalled {
                installed: cur.clone(),
                requested: s,
            })
        };
    }
    if s.is_default() {
        return Ok(());
    }
    check_cpus(&s.cpus)?;
    if s.per_thread() {
        probe(&s)?;
    }
    if s.mlockall {
        lock_memory()?;
    }
    tracing::info!(settings = %s, "realtime: device loops will run with these settings");
    let _ = INSTALLED.set(s);
    Ok(())
}

/// The settings [`install`] kept, if any.
pub fn installed() -> Option<&'static Settings> {
    INSTALLED.get()
}

/// Called first thing by every device-loop thread: applies the installed settings to it.
/// Nothing installed: returns at once. A failure (the start-up check passed, so rare: a
/// changed limit or cgroup) is logged as an error naming the thread (its name names the
/// device) and the loop runs on with the default scheduling; it never panics.
pub fn enter_device_loop() {
    let Some(s) = INSTALLED.get() else {
        return;
    };
    if !s.per_thread() {
        return;
    }
    let t = std::thread::current();
    let name = t.name().unwrap_or("(unnamed)");
    // SAFETY: gettid has no preconditions.
    let tid = unsafe { libc::gettid() };
    match apply_to_current_thread(s) {
        Ok(()) => tracing::debug!(thread = name, tid, settings = %s, "realtime: device loop set up"),
        Err(e) => tracing::error!(
            thread = name,
            tid,
            "realtime: device loop {name} runs WITHOUT its real-time settings: {e}"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_print_like_the_kernel() {
        assert_eq!(CpuList(&[0, 1, 2, 3, 6]).to_string(), "0-3,6");
        assert_eq!(CpuList(&[5, 1]).to_string(), "1,5");
        assert_eq!(CpuList(&[1]).to_string(), "1");
        assert_eq!(CpuList(&[]).to_string(), "(none)");
    }

    #[test]
    fn the_default_changes_nothing() {
        let s = Settings::default();
        assert!(s.is_default() && !s.per_thread());
        assert!(!Policy::default().is_realtime());
        // A default install keeps nothing, so device loops return at once.
        install(Settings::default()).unwrap();
        assert!(installed().is_none());
    }

    #[test]
    fn refusals_name_the_privilege_and_the_fix() {
        let e = RealtimeError::SchedRefused {
            policy: Policy::Fifo,
            priority: 42,
            rtprio: Some(Limit {
                soft: Some(0),
                hard: Some(0),
            }),
            cap_sys_nice: Some(false),
        }
        .to_string();
        for want in [
            "policy = \"fifo\", priority = 42",
            "SCHED_FIFO",
            "CAP_SYS_NICE (which this process lacks)",
            "RLIMIT_RTPRIO of at least 42 (now soft 0, hard 0)",
            "LimitRTPRIO=42",
            "AmbientCapabilities=CAP_SYS_NICE",
            "ulimit -r 42",
        ] {
            assert!(e.contains(want), "{want:?} missing in: {e}");
        }
        let m = RealtimeError::Mlockall {
            cause: "x".into(),
            memlock: Some(Limit {
                soft: Some(8 << 20),
                hard: None,
            }),
            cap_ipc_lock: Some(false),
        }
        .to_string();
        for want in [
            "mlockall = true",
            "RLIMIT_MEMLOCK",
            "now soft 8 MiB, hard unlimited",
            "LimitMEMLOCK=infinity",
            "CAP_IPC_LOCK",
        ] {
            assert!(m.contains(want), "{want:?} missing in: {m}");
        }
        let c = RealtimeError::Cpus {
            requested: vec![0, 7],
            allowed: vec![0, 1],
            os: None,
        }
        .to_string();
        assert!(
            c.contains("cpus = [0, 7]") && c.contains("CPU 7 is not") && c.contains("may use CPUs 0-1"),
            "{c}"
        );
    }

    #[test]
    fn the_allowed_cpus_include_the_one_this_thread_runs_on() {
        let allowed = allowed_cpus().unwrap();
        // SAFETY: no preconditions.
        let now = unsafe { libc::sched_getcpu() };
        assert!(
            now >= 0 && allowed.contains(&(now as usize)),
            "{now} not in {allowed:?}"
        );
    }

    #[test]
    fn pinning_applies_to_the_calling_thread_only() {
        let allowed = allowed_cpus().unwrap();
        let last = *allowed.last().unwrap();
        let s = Settings {
            cpus: vec![last],
            ..Settings::default()
        };
        let pinned = std::thread::spawn(move || {
            apply_to_current_thread(&s).unwrap();
            allowed_cpus().unwrap()
        })
        .join()
        .unwrap();
        assert_eq!(pinned, vec![last]);
        assert_eq!(allowed_cpus().unwrap(), allowed, "the spawning thread was pinned too");
        let bad = Settings {
            cpus: vec![MAX_CPUS + 1],
            ..Settings::default()
        };
        let e = std::thread::spawn(move || apply_to_current_thread(&bad))
            .join()
            .unwrap();
        assert!(matches!(e, Err(RealtimeError::Cpus { .. })), "{e:?}");
    }
}
