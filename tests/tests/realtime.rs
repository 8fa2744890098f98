//! `[realtime]` end to end (docs/deployment.md, "Real-time"): the real `handgate run` with a
//! profile asking for `SCHED_FIFO`, a CPU and `mlockall`, read back from the kernel
//! (`/proc/<pid>/task/<tid>/stat` fields 40 `rt_priority` and 41 `policy`,
//! `Cpus_allowed_list` and `VmLck` of `status`):
//!
//! * every device-loop thread (the Dex3 USB loop `dex3-usb-loop`, the DDS-client device loop
//!   on its shared thread `dev-shared-0` (docs/deployment.md, "Loop threads"), the EZGripper bus worker `ezgripper-bus` and its device `ezgripper-<name>`)
//!   runs `SCHED_FIFO` at the priority, pinned to the CPU; every other thread (tokio workers,
//!   CycloneDDS, the in-process emulators, main) stays `SCHED_OTHER` on every CPU; memory is
//!   locked;
//! * without the privilege (as root: `setpriv` drops CAP_SYS_NICE / CAP_IPC_LOCK from the
//!   bounding set, `prlimit` sets RLIMIT_RTPRIO 0 / RLIMIT_MEMLOCK 64 KiB), `handgate run` stops
//!   before serving and before any device opens, naming the missing privilege and the fix;
//! * `cpus` naming a CPU the process may not use (`taskset`) is a profile error naming the key.
//!
//! Where this machine cannot run a check (no privilege for SCHED_FIFO, util-linux tools
//! missing) the test says so on stderr and passes, except under CI (`CI` set): then it fails.
//! Domains 185 (the fleet) and 186 (the refused starts: no DDS traffic expected).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use handgate_tests::{handgate_bin, Gateway};

/// The priority the profile asks for (any of 1..=99; not the 50 a careless default would use).
const PRIORITY: u32 = 7;
/// `SCHED_OTHER` and `SCHED_FIFO` as /proc prints the policy.
const SCHED_OTHER: u32 = 0;
const SCHED_FIFO: u32 = 1;
/// Bound on the device loops showing their settings after `handgate serving`, and on a refused
/// start's exit.
const DEADLINE: Duration = Duration::from_secs(30);

/// Written straight to stderr, past the harness's capture, so a skip shows in `make test`.
fn say(msg: &str) {
    let _ = writeln!(std::io::stderr(), "{msg}");
}

/// A check this machine cannot run: loud, and a failure under CI.
fn cannot_run(test: &str, why: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{test}: {why} (CI is set: this check must run)");
    }
    say(&format!("SKIPPED {test}: {why}"));
}

/// A directory removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("handgate-rt-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create the temporary directory");
        TempDir(dir)
    }

    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).expect("write the profile");
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `0-3,6` (the kernel's list format) as numbers.
fn parse_cpu_list(s: &str) -> Vec<usize> {
    let mut out = Vec::new();
    for part in s.trim().split(',').filter(|p| !p.is_empty()) {
        match part.split_once('-') {
            Some((a, b)) => out.extend(a.parse::<usize>().unwrap()..=b.parse::<usize>().unwrap()),
            None => out.push(part.parse().unwrap()),
        }
    }
    out
}

fn status_field(status: &str, key: &str) -> Option<String> {
    status
        .lines()
        .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix(':')))
        .map(|v| v.trim().to_string())
}

/// The CPUs this test process may use.
fn my_cpus() -> Vec<usize> {
    let status = std::fs::read_to_string("/proc/self/status").expect("read /proc/self/status");
    parse_cpu_list(&status_field(&status, "Cpus_allowed_list").expect("Cpus_allowed_list"))
}

/// One thread of a process as the kernel shows it.
#[derive(Debug, Clone)]
struct Task {
    tid: u32,
    comm: String,
    policy: u32,
    rt_priority: u32,
    cpus: Vec<usize>,
}

fn tasks(pid: u32) -> Vec<Task> {
    let mut out = Vec::new();
    let Ok(dir) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return out;
    };
    for e in dir.flatten() {
        let Ok(tid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let (Ok(stat), Ok(status), Ok(comm)) = (
            std::fs::read_to_string(e.path().join("stat")),
            std::fs::read_to_string(e.path().join("status")),
            std::fs::read_to_string(e.path().join("comm")),
        ) else {
            continue; // the thread ended meanwhile
        };
        // Fields after "pid (comm) ": field 3 first, so field N is at N - 3.
        let rest: Vec<&str> = stat
            .rsplit_once(") ")
            .expect("stat has (comm)")
            .1
            .split_whitespace()
            .collect();
        let field = |n: usize| rest[n - 3].parse::<u32>().expect("a number");
        out.push(Task {
            tid,
            comm: comm.trim().to_string(),
            rt_priority: field(40),
            policy: field(41),
            cpus: parse_cpu_list(&status_field(&status, "Cpus_allowed_list").expect("Cpus_allowed_list")),
        });
    }
    out
}

/// A thread name as /proc shows it (`comm`: at most 15 bytes).
fn comm(name: &str) -> String {
    name.chars().take(15).collect()
}

/// Whether this process may give a thread SCHED_FIFO (tried on a thread of its own).
fn may_use_fifo() -> bool {
    std::thread::spawn(|| {
        let p = libc::sched_param { sched_priority: 1 };
        // SAFETY: pid 0 is this (short-lived) thread; param is a valid sched_param.
        unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &p) == 0 }
    })
    .join()
    .unwrap()
}

const FLEET: &str = r#"
[[devices]]
name = "hand"
kind = "dex3"
side = "left"
backend = "emulator"

[[devices]]
name = "jaw"
kind = "dex1"
side = "left"
backend = "emulator"

[[devices]]
name = "grip"
kind = "ezgripper"
side = "left"
backend = "emulator"

[devices.ezgripper]
port = "rt-bus"
servo_id = 1
response_timeout_ms = 100

[[fronts]]
kind = "canonical"
device = "hand"
"#;

#[test]
fn device_loops_run_fifo_pinned_and_nothing_else_does() {
    const TEST: &str = "device_loops_run_fifo_pinned_and_nothing_else_does";
    if !may_use_fifo() {
        cannot_run(
            TEST,
            "this process may not use SCHED_FIFO (no CAP_SYS_NICE, RLIMIT_RTPRIO 0, or a cgroup without a \
             real-time budget); run the suite as root as CI does",
        );
        return;
    }
    let all = my_cpus();
    // The last CPU: with two or more, a pinned loop differs from every other thread.
    let pin = *all.last().expect("at least one CPU");
    if all.len() < 2 {
        say(&format!(
            "{TEST}: one CPU ({pin}) available, so pinning cannot be told from no pinning here; the policy checks still run"
        ));
    }
    let dir = TempDir::new("fleet");
    let profile = dir.write(
        "rt.toml",
        &format!(
            "name = \"rt\"\n[foxglove]\nenabled = false\n[realtime]\npolicy = \"fifo\"\npriority = {PRIORITY}\n\
             cpus = [{pin}]\nmlockall = true\n{FLEET}"
        ),
    );
    let gw = Gateway::start(185, &["--profile", profile.to_str().unwrap()]);
    let fleet_line = gw
        .wait_stdout("realtime: device loops", Duration::from_secs(1))
        .unwrap_or_else(|e| panic!("the fleet summary names [realtime]: {e}"));
    assert!(
        fleet_line.contains(&format!("SCHED_FIFO priority {PRIORITY}, CPUs {pin}, memory locked")),
        "{fleet_line}"
    );
    let pid = gw.id();
    let device_loops: Vec<String> = ["dex3-usb-loop", "dev-shared-0", "ezgripper-bus", "ezgripper-grip"]
        .iter()
        .map(|n| comm(n))
        .collect();
    let is_loop = |t: &Task| device_loops.contains(&t.comm);
    // Each loop applies its settings first thing after it starts: wait until every one shows.
    let start = Instant::now();
    let seen = loop {
        let ts = tasks(pid);
        let done = device_loops.iter().all(|n| {
            ts.iter()
                .any(|t| &t.comm == n && t.policy == SCHED_FIFO && t.rt_priority == PRIORITY)
        });
        if done {
            break ts;
        }
        if start.elapsed() > DEADLINE {
            panic!(
                "device loops not all SCHED_FIFO {PRIORITY} within {DEADLINE:?}:\n{ts:#?}\n{}",
                gw.transcript()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut problems = Vec::new();
    for t in &seen {
        if is_loop(t) {
            if (t.policy, t.rt_priority, &t.cpus) != (SCHED_FIFO, PRIORITY, &vec![pin]) {
                problems.push(format!(
                    "device loop {} (tid {}) {t:?}: want SCHED_FIFO {PRIORITY} on CPU {pin}",
                    t.comm, t.tid
                ));
            }
        } else if (t.policy, t.rt_priority, &t.cpus) != (SCHED_OTHER, 0, &all) {
            problems.push(format!(
                "{} (tid {}) {t:?}: want SCHED_OTHER on CPUs {all:?} (not a device loop)",
                t.comm, t.tid
            ));
        }
    }
    let workers = seen.iter().filter(|t| t.comm.starts_with("tokio-")).count();
    assert!(workers >= 1, "no tokio worker among {seen:#?}");
    // The in-process emulated services' thread (the Dex1 service here) is not a device loop:
    // SCHED_OTHER, checked above. (The emulated Dex3 MCU and EZGripper servos answer on their
    // device loops' own threads, as the hardware answers the loop's exchange.)
    assert!(
        seen.iter().any(|t| t.comm.starts_with("emu-shared-")),
        "no emulator thread among {seen:#?}"
    );
    assert!(problems.is_empty(), "{}\nall threads: {seen:#?}", problems.join("\n"));
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("gateway status");
    let locked_kb: u64 = status_field(&status, "VmLck")
        .and_then(|v| v.split_whitespace().next().and_then(|n| n.parse().ok()))
        .expect("VmLck");
    assert!(locked_kb > 0, "mlockall = true but VmLck is 0:\n{status}");
    say(&format!(
        "{TEST}: {} threads, {} device loops SCHED_FIFO {PRIORITY} on CPU {pin}, {workers} tokio workers SCHED_OTHER; VmLck {locked_kb} kB, {}",
        seen.len(),
        seen.iter().filter(|t| is_loop(t)).count(),
        status_field(&status, "VmRSS").unwrap_or_default()
    ));
}

/// Runs `prefix... handgate run --domain 186 --profile <profile>` to its exit.
fn run_refused(prefix: &[&str], profile: &Path) -> (bool, String, String) {
    let bin = handgate_bin();
    let mut cmd = Command::new(prefix[0]);
    cmd.args(&prefix[1..])
        .arg(&bin)
        .args(["run", "--domain", "186", "--http-port", "0", "--profile"])
        .arg(profile)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, _) in std::env::vars() {
        if k.starts_with("HANDGATE_") {
            cmd.env_remove(k);
        }
    }
    let mut child = cmd
        .spawn()
        .unwrap_or_else(|e| panic!("spawn {prefix:?} handgate run: {e}"));
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            let out = child.wait_with_output().expect("collect output");
            panic!(
                "handgate run did not stop within {DEADLINE:?}:\n{}\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let Output { status, stdout, stderr } = child.wait_with_output().expect("collect output");
    (
        status.success(),
        String::from_utf8_lossy(&stdout).into_owned(),
        String::from_utf8_lossy(&stderr).into_owned(),
    )
}

/// `prlimit ... [setpriv ...]`: the privilege-dropping prefix, or why it cannot be built.
fn without(limit: &str, cap: &str) -> Result<Vec<String>, String> {
    let root = unsafe { libc::geteuid() } == 0;
    let mut prefix = vec!["prlimit".to_string(), limit.to_string()];
    if root {
        // Root keeps every capability of its bounding set across exec: drop it there.
        prefix.extend([
            "setpriv".into(),
            format!("--inh-caps=-{cap}"),
            format!("--bounding-set=-{cap}"),
        ]);
    }
    let mut probe = Command::new(&prefix[0]);
    probe.args(&prefix[1..]).arg("true");
    match probe.output() {
        Ok(o) if o.status.success() => Ok(prefix),
        Ok(o) => Err(format!(
            "`{} true` fails here: {}",
            prefix.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Err(e) => Err(format!(
            "`{}` cannot run ({e}): prlimit and setpriv come with util-linux",
            prefix[0]
        )),
    }
}

fn assert_refused(what: &str, (ok, stdout, stderr): (bool, String, String), want: &[String]) {
    assert!(!ok, "{what}: handgate run succeeded:\n{stdout}\n{stderr}");
    // Stopped before serving, and before any device opened (the Dex3 loop logs its connect).
    for never in ["handgate serving", "dex3 usb: connected", "device loop started"] {
        assert!(
            !stdout.contains(never),
            "{what}: {never:?} printed:\n{stdout}\n{stderr}"
        );
    }
    for w in want {
        assert!(stderr.contains(w.as_str()), "{what}: missing {w:?} in:\n{stderr}");
    }
}

#[test]
fn without_the_privilege_the_start_stops_naming_it_and_the_fix() {
    const TEST: &str = "without_the_privilege_the_start_stops_naming_it_and_the_fix";
    let dir = TempDir::new("refused");
    // SCHED_FIFO without CAP_SYS_NICE and with RLIMIT_RTPRIO 0.
    match without("--rtprio=0", "sys_nice") {
        Err(why) => cannot_run(TEST, &why),
        Ok(prefix) => {
            let profile = dir.write(
                "fifo.toml",
                &format!("name = \"rt-refused\"\n[foxglove]\nenabled = false\n[realtime]\npolicy = \"fifo\"\npriority = {PRIORITY}\n{FLEET}"),
            );
            let prefix: Vec<&str> = prefix.iter().map(String::as_str).collect();
            assert_refused(
                "fifo",
                run_refused(&prefix, &profile),
                &[
                    format!("policy = \"fifo\", priority = {PRIORITY}"),
                    "CAP_SYS_NICE (which this process lacks)".into(),
                    format!("RLIMIT_RTPRIO of at least {PRIORITY} (now soft 0, hard 0)"),
                    format!("LimitRTPRIO={PRIORITY}"),
                    "AmbientCapabilities=CAP_SYS_NICE".into(),
                    format!("ulimit -r {PRIORITY}"),
                ],
            );
        }
    }
    // mlockall without CAP_IPC_LOCK and with RLIMIT_MEMLOCK 64 KiB.
    match without("--memlock=65536", "ipc_lock") {
        Err(why) => cannot_run(TEST, &why),
        Ok(prefix) => {
            let profile = dir.write(
                "mlock.toml",
                &format!("name = \"rt-refused\"\n[foxglove]\nenabled = false\n[realtime]\nmlockall = true\n{FLEET}"),
            );
            let prefix: Vec<&str> = prefix.iter().map(String::as_str).collect();
            assert_refused(
                "mlockall",
                run_refused(&prefix, &profile),
                &[
                    "mlockall = true".into(),
                    "RLIMIT_MEMLOCK = unlimited (now soft 64 KiB, hard 64 KiB)".into(),
                    "CAP_IPC_LOCK (which this process lacks)".into(),
                    "LimitMEMLOCK=infinity".into(),
                ],
            );
        }
    }
}

#[test]
fn a_cpu_the_process_may_not_use_is_a_profile_error() {
    const TEST: &str = "a_cpu_the_process_may_not_use_is_a_profile_error";
    let all = my_cpus();
    if all.len() < 2 {
        cannot_run(TEST, "one CPU available: no CPU to withhold with taskset");
        return;
    }
    let (first, last) = (all[0], *all.last().unwrap());
    let dir = TempDir::new("cpus");
    let profile = dir.write(
        "cpus.toml",
        &format!("name = \"rt-cpus\"\n[realtime]\ncpus = [{last}]\n{FLEET}"),
    );
    let out = match Command::new("taskset")
        .arg("-c")
        .arg(first.to_string())
        .arg(handgate_bin())
        .arg("check")
        .arg(&profile)
        .stdin(Stdio::null())
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            cannot_run(TEST, &format!("taskset (util-linux) cannot run: {e}"));
            return;
        }
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "handgate check exit code; stderr:\n{stderr}"
    );
    let want = format!(
        "{}: realtime.cpus[0]: CPU {last} is not one this process may run on (allowed: {first})",
        profile.display()
    );
    assert!(stderr.contains(&want), "missing {want:?} in:\n{stderr}");
}
