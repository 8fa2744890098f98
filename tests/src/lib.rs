//! Shared helpers for handgate's cross-crate and interop tests.
//!
//! * [`repo_root`], [`venv_python`]: where the repository and the interop venv
//!   (`scripts/setup.sh`) are.
//! * [`PyProcess`]: a Python helper process (one of `tests/python/*.py`) whose stdout lines
//!   are collected on a thread; wait for a line with a deadline; killed on drop.
//! * [`Gateway`], [`handgate_bin`]: the real `handgate` binary running `handgate run` on a
//!   test's own DDS domain, started when it reports it is serving, stopped with SIGINT on drop.
//! * [`Fixture`], [`golden_fixtures`], [`FromPlain`]: the golden CDR fixtures written by
//!   `tests/python/gen_golden.py` with the official unitree_sdk2py, and the conversion of their
//!   "plain" JSON values (also what the Python interop scripts print) into handgate's wire types.
//!
//! Plain-value conventions (same as `tests/python/wire_schema.py`): integers, booleans and
//! strings are their JSON kinds; f32 and f64 values are JSON numbers holding the exact value
//! (`-0.0` included) or the strings `"inf"`, `"-inf"`, `"nan"` (the quiet NaNs 0x7fc00000 and
//! 0x7ff8000000000000); arrays and sequences are JSON arrays; nested structs are objects with
//! exactly the IDL field names.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use handgate_idl::{handgate, inspire, ros2, unitree_go, unitree_hg};
use serde_json::Value;

// ---------------------------------------------------------------------------------------------
// Locations

/// The repository root (the parent of this crate's directory).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// `tests/fixtures/golden/`.
pub fn golden_dir() -> PathBuf {
    repo_root().join("tests").join("fixtures").join("golden")
}

/// `tests/python/<name>`.
pub fn python_script(name: &str) -> PathBuf {
    repo_root().join("tests").join("python").join(name)
}

/// The interop venv's interpreter, `.venv/bin/python`. Panics with instructions when missing:
/// the interop tests need the official SDK and must not silently pass without it.
pub fn venv_python() -> PathBuf {
    let py = repo_root().join(".venv").join("bin").join("python");
    assert!(
        py.exists(),
        "{} is missing: the interop tests need the official unitree_sdk2py. Run `scripts/setup.sh` \
         (or `make test`) in {} first.",
        py.display(),
        repo_root().display()
    );
    py
}

// ---------------------------------------------------------------------------------------------
// Rates: what `make test` holds and what `make reliability` holds

/// Whether the full reliability suites run (`HANDGATE_RELIABILITY_FULL=1`: `make
/// reliability`, on the release binary): their long windows, and every rate held to its
/// nominal both ways ([`RateCheck`]).
pub fn reliability_full() -> bool {
    std::env::var("HANDGATE_RELIABILITY_FULL").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// A state rate measured over a window, against its nominal rate and a tolerance (a
/// fraction). In `make test` (debug binaries, a machine that may be busy with other work) a
/// rate **below** nominal is reported, not held: a starved debug gateway misses periods, and
/// a suite that fails when a laptop compiles something else is one people learn to ignore
/// (docs/development.md, "A busy machine"). A rate **above** nominal is held everywhere: load
/// never makes a loop publish faster, so that is a defect (a duplicate publish, a wrong
/// period). With [`reliability_full`] both bounds are held (`make reliability`, release).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateCheck {
    pub measured: f64,
    pub nominal: f64,
    pub tol: f64,
}

impl RateCheck {
    /// Whether the rate breaks what is held in this run.
    pub fn fails(&self) -> bool {
        let over = self.measured > self.nominal * (1.0 + self.tol);
        let under = self.measured < self.nominal * (1.0 - self.tol);
        over || (under && reliability_full())
    }

    /// `12.3 Hz (+1.2 %)`, and what this run holds: a line for a report.
    pub fn line(&self) -> String {
        let dev = (self.measured / self.nominal - 1.0) * 100.0;
        let held = if reliability_full() {
            format!("held to ±{:.0} %", self.tol * 100.0)
        } else {
            format!(
                "held to +{:.0} %; below nominal reported, held by make reliability",
                self.tol * 100.0
            )
        };
        format!(
            "{:.1} Hz against {:.1} Hz ({dev:+.1} %, {held})",
            self.measured, self.nominal
        )
    }
}

/// Network interface for the interop tests, from `HANDGATE_INTEROP_IFACE` (e.g. `lo`), passed
/// to both sides (`Node::new(domain, Some(iface))` and `ChannelFactoryInitialize(domain, iface)`).
/// Unset or empty: both let CycloneDDS pick an interface, as `ChannelFactoryInitialize(domain)`
/// does.
pub fn interop_interface() -> Option<String> {
    std::env::var("HANDGATE_INTEROP_IFACE").ok().filter(|s| !s.is_empty())
}

// ---------------------------------------------------------------------------------------------
// Network namespaces (several hosts on one machine)

/// `program`, run inside network namespace `netns` when given (`ip netns exec NS program`).
pub fn in_netns(netns: Option<&str>, program: &Path) -> Command {
    match netns {
        Some(ns) => {
            let mut c = Command::new("ip");
            c.args(["netns", "exec", ns]).arg(program);
            c
        }
        None => Command::new(program),
    }
}

/// The `handgate` binary under test ([`handgate_bin`]), inside network namespace `netns` when
/// given, run from the repository root (where `profiles/` is) and with none of this process's
/// `HANDGATE_*` variables: handgate reads every `HANDGATE_*` variable as a profile key and
/// refuses an unknown one (docs/profiles.md), so the harness's own (`HANDGATE_INTEROP_IFACE`,
/// `HANDGATE_RELIABILITY_FULL`, ...) would make every command loading a profile (`run`,
/// `check`, `doctor`, `record`, ...) exit 2 with `environment (HANDGATE_INTEROP_IFACE):
/// interop_iface: unknown key` on stderr and nothing on stdout.
pub fn handgate_cmd(netns: Option<&str>) -> Command {
    handgate_cmd_under(netns, &[])
}

/// [`handgate_cmd`], run under `prefix` (a program and its arguments before the binary, e.g.
/// `faketime -f @...`; empty: none).
pub fn handgate_cmd_under(netns: Option<&str>, prefix: &[&str]) -> Command {
    let mut cmd = match prefix.split_first() {
        Some((program, args)) => {
            let mut c = in_netns(netns, Path::new(program));
            c.args(args).arg(handgate_bin());
            c
        }
        None => in_netns(netns, &handgate_bin()),
    };
    without_handgate_env(&mut cmd, std::env::vars().map(|(k, _)| k));
    cmd.current_dir(repo_root());
    cmd
}

/// Keeps `cmd` from inheriting the `HANDGATE_*` variables among `inherited`.
fn without_handgate_env(cmd: &mut Command, inherited: impl Iterator<Item = String>) {
    for k in inherited.filter(|k| k.starts_with("HANDGATE_")) {
        cmd.env_remove(k);
    }
}

/// Why two test hosts could not be made.
#[derive(Debug, thiserror::Error)]
pub enum NetNsError {
    #[error("network namespaces need root (this test runs as uid {0})")]
    NotRoot(u32),
    #[error("`ip {args}` failed: {stderr}")]
    Ip { args: String, stderr: String },
    #[error("could not run `ip`: {0}")]
    Spawn(#[source] std::io::Error),
}

fn ip(args: &[&str]) -> Result<(), NetNsError> {
    let out = Command::new("ip").args(args).output().map_err(NetNsError::Spawn)?;
    if out.status.success() {
        Ok(())
    } else {
        Err(NetNsError::Ip {
            args: args.join(" "),
            stderr: String::from_utf8_lossy(&out.stderr).trim().to_string(),
        })
    }
}

/// Two network namespaces joined by a veth pair: two hosts on one machine, whose traffic
/// stays on the pair (nothing is routed to the machine's own interfaces). Deleted on drop
/// (deleting a namespace deletes its end of the pair, and with it the other end).
#[derive(Debug)]
pub struct NetNs {
    /// Namespace names, and each one's veth interface and IPv4 address.
    pub hosts: [(String, String, String); 2],
}

impl NetNs {
    /// Creates the pair with names unique to this process and `tag` (`tag`: up to 4
    /// characters; interface names are limited to 15).
    pub fn pair(tag: &str) -> Result<Self, NetNsError> {
        // SAFETY: geteuid has no preconditions.
        let uid = unsafe { libc::geteuid() };
        if uid != 0 {
            return Err(NetNsError::NotRoot(uid));
        }
        let id = std::process::id() % 100_000;
        let subnet = 10 + id % 200;
        let hosts = [0, 1].map(|i| {
            (
                format!("hg-{tag}-{id}-{i}"),
                format!("hg{tag}{id}{}", ["a", "b"][i]),
                format!("10.{subnet}.{}.{}", id % 250, i + 1),
            )
        });
        let me = Self { hosts };
        let [(na, va, aa), (nb, vb, ab)] = &me.hosts;
        for (ns, _, _) in &me.hosts {
            let _ = ip(&["netns", "del", ns]); // a leftover of a killed run
            ip(&["netns", "add", ns])?;
        }
        ip(&[
            "link", "add", va, "netns", na, "type", "veth", "peer", "name", vb, "netns", nb,
        ])?;
        for (ns, v, a) in [(na, va, aa), (nb, vb, ab)] {
            ip(&["-n", ns, "addr", "add", &format!("{a}/24"), "dev", v])?;
            ip(&["-n", ns, "link", "set", v, "up"])?;
            ip(&["-n", ns, "link", "set", "lo", "up"])?;
        }
        Ok(me)
    }
}

/// Network namespaces joined by veth pairs as a test says ([`Hosts::link`]): a small network
/// of hosts on one machine (a robot's internal network, a gateway PC with two interfaces, a lab
/// network). Traffic stays on the pairs; deleted on drop.
#[derive(Debug)]
pub struct Hosts {
    /// Namespace names, in the order given.
    pub ns: Vec<String>,
    tag: String,
    id: u32,
}

/// One veth pair of [`Hosts`]: each end's interface and IPv4 address.
#[derive(Debug, Clone)]
pub struct Link {
    pub a_if: String,
    pub a_addr: String,
    pub b_if: String,
    pub b_addr: String,
}

impl Hosts {
    /// `n` empty hosts (namespaces with `lo` up), named after this process and `tag` (up to 4
    /// characters).
    pub fn new(tag: &str, n: usize) -> Result<Self, NetNsError> {
        // SAFETY: geteuid has no preconditions.
        let uid = unsafe { libc::geteuid() };
        if uid != 0 {
            return Err(NetNsError::NotRoot(uid));
        }
        let id = std::process::id() % 100_000;
        let me = Hosts {
            ns: (0..n).map(|i| format!("hg-{tag}-{id}-{i}")).collect(),
            tag: tag.into(),
            id,
        };
        for ns in &me.ns {
            let _ = ip(&["netns", "del", ns]); // a leftover of a killed run
            ip(&["netns", "add", ns])?;
            ip(&["-n", ns, "link", "set", "lo", "up"])?;
        }
        Ok(me)
    }

    /// [`Hosts::new`] for the test file `test`: `None`, with a line saying why (`SKIPPED
    /// <test>: ...`), where it may not make network namespaces (not root); any other failure
    /// panics.
    pub fn for_test(test: &str, tag: &str, n: usize) -> Option<Self> {
        match Self::new(tag, n) {
            Ok(h) => Some(h),
            Err(e @ NetNsError::NotRoot(_)) => {
                eprintln!("SKIPPED {test}: {e}; run `cargo test -p handgate-tests --test {test}` as root");
                None
            }
            Err(e) => panic!("could not make the test hosts: {e}"),
        }
    }

    /// Joins host `a` (address `subnet.ha`) and host `b` (`subnet.hb`) with veth pair number
    /// `k` on `subnet`/24 (`subnet`: three octets, e.g. `192.168.123`; two links of one host
    /// need two subnets, two hosts in different namespaces may reuse one). A host number 0
    /// leaves that end without an address (a switch's port, [`Hosts::bridge`]).
    pub fn link(&self, k: u8, a: usize, b: usize, subnet: &str, (ha, hb): (u8, u8)) -> Result<Link, NetNsError> {
        let name = |end: &str| format!("hg{}{}{k}{end}", self.tag, self.id);
        let l = Link {
            a_if: name("a"),
            a_addr: format!("{subnet}.{ha}"),
            b_if: name("b"),
            b_addr: format!("{subnet}.{hb}"),
        };
        let (na, nb) = (&self.ns[a], &self.ns[b]);
        ip(&[
            "link", "add", &l.a_if, "netns", na, "type", "veth", "peer", "name", &l.b_if, "netns", nb,
        ])?;
        for (ns, v, addr, host) in [(na, &l.a_if, &l.a_addr, ha), (nb, &l.b_if, &l.b_addr, hb)] {
            if host != 0 {
                ip(&["-n", ns, "addr", "add", &format!("{addr}/24"), "dev", v])?;
            }
            ip(&["-n", ns, "link", "set", v, "up"])?;
        }
        Ok(l)
    }

    /// A switch in host `host`: a bridge over its interfaces `ports` (ends of [`Hosts::link`]s
    /// given no address, `hb = 0`), so the hosts at their other ends share one network.
    pub fn bridge(&self, host: usize, ports: &[&str]) -> Result<(), NetNsError> {
        let ns = &self.ns[host];
        ip(&["-n", ns, "link", "add", "br0", "type", "bridge"])?;
        for p in ports {
            ip(&["-n", ns, "link", "set", p, "master", "br0"])?;
        }
        ip(&["-n", ns, "link", "set", "br0", "up"])
    }

    /// Adds port `port` to host `host`'s switch ([`Hosts::bridge`]).
    pub fn bridge_add(&self, host: usize, port: &str) -> Result<(), NetNsError> {
        ip(&["-n", &self.ns[host], "link", "set", port, "master", "br0"])
    }

    /// Takes link `dev` of host `host` down or up (a cable pulled, plugged back).
    pub fn set_link(&self, host: usize, dev: &str, up: bool) -> Result<(), NetNsError> {
        ip(&["-n", &self.ns[host], "link", "set", dev, if up { "up" } else { "down" }])
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        for ns in &self.ns {
            let _ = ip(&["netns", "del", ns]);
        }
    }
}

impl Drop for NetNs {
    fn drop(&mut self) {
        for (ns, _, _) in &self.hosts {
            let _ = ip(&["netns", "del", ns]);
        }
    }
}

/// A packet capture on one interface of a test host (`tests/python/rtps_capture.py`): the UDP
/// datagrams per destination port and the RTPS participants that sent them.
pub struct Capture(PyProcess);

/// What a [`Capture`] saw.
#[derive(Debug, Clone)]
pub struct Traffic {
    pub ports: std::collections::BTreeMap<u16, u64>,
    /// GUID prefixes (hex) of the RTPS participants that sent on the interface.
    pub participants: std::collections::BTreeSet<String>,
}

impl Capture {
    /// Starts capturing on `iface` in `netns` (at most `max` long) and waits until it does.
    pub fn start(netns: &str, iface: &str, max: Duration) -> Capture {
        let args = [iface.to_string(), max.as_secs().to_string()];
        let p = PyProcess::spawn_in(Some(netns), "rtps_capture.py", &args).expect("start the capture");
        p.wait_line("READY", Duration::from_secs(30))
            .unwrap_or_else(|e| panic!("{e}"));
        Capture(p)
    }

    /// Ends the capture (SIGTERM) and reads what it saw.
    pub fn finish(&self) -> Traffic {
        // SAFETY: kill(2) on the capture's own pid.
        unsafe { libc::kill(self.0.id() as i32, libc::SIGTERM) };
        let line = |prefix: &str| {
            let l = self
                .0
                .wait_line(prefix, Duration::from_secs(30))
                .unwrap_or_else(|e| panic!("{e}"));
            serde_json::from_str::<serde_json::Value>(l.trim_start_matches(prefix)).unwrap()
        };
        let ports = line("PORTS ");
        let participants = line("PARTICIPANTS ");
        Traffic {
            ports: ports
                .as_object()
                .unwrap()
                .iter()
                .map(|(k, n)| (k.parse().unwrap(), n.as_u64().unwrap()))
                .collect(),
            participants: participants
                .as_array()
                .unwrap()
                .iter()
                .map(|p| p.as_str().unwrap().to_string())
                .collect(),
        }
    }
}

impl Traffic {
    /// Datagrams to the well-known ports of DDS domain `domain` (7400 + 250 × domain and the
    /// 250 above: discovery, and user traffic where CycloneDDS uses fixed ports; its unicast
    /// data ports are otherwise ephemeral, see `participants`).
    pub fn on_domain(&self, domain: u32) -> u64 {
        let base = (7400 + 250 * domain) as u16;
        self.ports.range(base..base + 250).map(|(_, n)| n).sum()
    }
}

// ---------------------------------------------------------------------------------------------
// Python helper processes

/// Failure while driving a Python helper process.
#[derive(Debug, thiserror::Error)]
pub enum PyError {
    #[error("could not start {script}: {source}")]
    Spawn {
        script: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{script}: no line starting with {prefix:?} within {timeout:?}\n{transcript}")]
    Timeout {
        script: String,
        prefix: String,
        timeout: Duration,
        transcript: String,
    },
    #[error("{script} closed its stdout before printing a line starting with {prefix:?}\n{transcript}")]
    Exited {
        script: String,
        prefix: String,
        transcript: String,
    },
}

/// A running `tests/python/<script>` under the venv interpreter. Its stdout is read line by
/// line on a thread; stderr is kept for error messages. The process is killed when dropped.
pub struct PyProcess {
    script: String,
    child: Child,
    lines: Receiver<String>,
    seen: Mutex<Vec<String>>,
    stderr: Arc<Mutex<String>>,
}

impl std::fmt::Debug for PyProcess {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PyProcess")
            .field("script", &self.script)
            .field("pid", &self.child.id())
            .finish()
    }
}

impl PyProcess {
    /// Starts `.venv/bin/python tests/python/<script> <args>` (unbuffered output).
    pub fn spawn(script: &str, args: &[String]) -> Result<Self, PyError> {
        Self::spawn_in(None, script, args)
    }

    /// [`PyProcess::spawn`] inside network namespace `netns` (`ip netns exec`; see [`NetNs`]).
    pub fn spawn_in(netns: Option<&str>, script: &str, args: &[String]) -> Result<Self, PyError> {
        Self::spawn_with(netns, script, args, |_| {})
    }

    /// [`PyProcess::spawn_in`] with `configure` applied to the command before it starts (its
    /// environment: [`ros2_env`]).
    pub fn spawn_with(
        netns: Option<&str>,
        script: &str,
        args: &[String],
        configure: impl FnOnce(&mut Command),
    ) -> Result<Self, PyError> {
        let mut cmd = in_netns(netns, &venv_python());
        cmd.arg("-u")
            .arg(python_script(script))
            .args(args)
            .current_dir(repo_root())
            .env("PYTHONUNBUFFERED", "1")
            .env("PYTHONDONTWRITEBYTECODE", "1");
        configure(&mut cmd);
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| PyError::Spawn {
                script: script.to_string(),
                source,
            })?;
        let stdout = child.stdout.take().expect("stdout is piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                match line {
                    Ok(l) => {
                        if tx.send(l).is_err() {
                            break;
                        }
                    }
                    Err(_) => break,
                }
            }
        });
        let stderr = Arc::new(Mutex::new(String::new()));
        let mut err_pipe = child.stderr.take().expect("stderr is piped");
        let err_buf = Arc::clone(&stderr);
        std::thread::spawn(move || {
            let mut chunk = [0u8; 4096];
            while let Ok(n) = err_pipe.read(&mut chunk) {
                if n == 0 {
                    break;
                }
                let text = String::from_utf8_lossy(&chunk[..n]).into_owned();
                err_buf.lock().unwrap_or_else(|e| e.into_inner()).push_str(&text);
            }
        });
        Ok(Self {
            script: script.to_string(),
            child,
            lines,
            seen: Mutex::new(Vec::new()),
            stderr,
        })
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Waits until the process prints a line starting with `prefix` and returns the rest of
    /// that line. Other lines are kept for the error transcript.
    pub fn wait_line(&self, prefix: &str, timeout: Duration) -> Result<String, PyError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    if let Some(rest) = line.strip_prefix(prefix) {
                        return Ok(rest.to_string());
                    }
                    self.seen.lock().unwrap_or_else(|e| e.into_inner()).push(line);
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(PyError::Timeout {
                        script: self.script.clone(),
                        prefix: prefix.to_string(),
                        timeout,
                        transcript: self.transcript(),
                    })
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(PyError::Exited {
                        script: self.script.clone(),
                        prefix: prefix.to_string(),
                        transcript: self.transcript(),
                    })
                }
            }
        }
    }

    /// What the process printed so far that no `wait_line` consumed, plus its stderr.
    pub fn transcript(&self) -> String {
        let out = self.seen.lock().unwrap_or_else(|e| e.into_inner()).join("\n");
        let err = self.stderr.lock().unwrap_or_else(|e| e.into_inner()).clone();
        format!(
            "--- {} stdout ---\n{out}\n--- {} stderr ---\n{err}",
            self.script, self.script
        )
    }
}

impl Drop for PyProcess {
    fn drop(&mut self) {
        // The helper may already have exited; both calls are then harmless errors.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The environment of a ROS 2 (Jazzy) process run from the venv's PyPI wheels (`ros-jazzy-rclpy`
/// and the packages scripts/setup.sh installs; docs/development.md "The Python environment"),
/// set on `cmd` for DDS domain `domain`, with its log files under `log_dir`:
///
/// - `ROS_DOMAIN_ID`: the domain; `RMW_IMPLEMENTATION=rmw_fastrtps_cpp` (the only rmw the venv
///   holds, named so a developer's ROS setup cannot pick another);
/// - `AMENT_PREFIX_PATH`: the venv, where the wheels install their `share/` (the ament index,
///   the message packages' type description files); nothing of a ROS installation;
/// - `LD_LIBRARY_PATH` is not set here: the wheels' `ros_wheels_bootstrapper.pth` sets it to
///   the venv's `lib/` and `ros_*.libs/` and re-executes the interpreter once (guarded by
///   `_ROS_WHEELS_BOOTSTRAP_COMPLETE`, removed here so an inherited one cannot skip it);
///   inherited ROS variables (a sourced `/opt/ros/*/setup.bash`: `LD_LIBRARY_PATH`,
///   `PYTHONPATH`, `ROS_LOCALHOST_ONLY`, ...) are removed so they cannot mix another ROS in;
/// - `FASTDDS_BUILTIN_TRANSPORTS=UDPv4`: Fast DDS without its shared-memory transport, whose
///   segments in `/dev/shm` outlive a killed process and are shared across the network
///   namespaces the tests run in; handgate (CycloneDDS) speaks UDP anyway;
/// - `ROS_LOG_DIR`: `log_dir` (rcl writes a log file per process, `~/.ros/log` by default).
pub fn ros2_env(cmd: &mut Command, domain: u32, log_dir: &Path) {
    for k in [
        "LD_LIBRARY_PATH",
        "PYTHONPATH",
        "_ROS_WHEELS_BOOTSTRAP_COMPLETE",
        "ROS_DISTRO",
        "ROS_VERSION",
        "ROS_LOCALHOST_ONLY",
        "ROS_AUTOMATIC_DISCOVERY_RANGE",
        "ROS_STATIC_PEERS",
        "ROS_DISCOVERY_SERVER",
        "ROS_SECURITY_ENABLE",
        "FASTRTPS_DEFAULT_PROFILES_FILE",
        "FASTDDS_DEFAULT_PROFILES_FILE",
    ] {
        cmd.env_remove(k);
    }
    cmd.env("ROS_DOMAIN_ID", domain.to_string())
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env("AMENT_PREFIX_PATH", repo_root().join(".venv"))
        .env("FASTDDS_BUILTIN_TRANSPORTS", "UDPv4")
        .env("ROS_LOG_DIR", log_dir);
}

// ---------------------------------------------------------------------------------------------
// The handgate binary

/// The `handgate` binary of this build: `target/<profile>/handgate`, next to the directory
/// (`target/<profile>/deps/`) holding the running test executable. (Only the gateway crate's
/// own tests get `CARGO_BIN_EXE_handgate`.)
///
/// The first call in a test process runs `cargo build -p handgate --features foxglove` (same
/// cargo, same target directory, same profile; the features `make test` builds the workspace
/// with, so the two builds share one binary) so the tests always run the gateway of the current
/// source, never one built earlier from other code; when the sources did not change that is a
/// no-op taking well under a second. `HANDGATE_TESTS_NO_BUILD=1` skips it (the binary must then exist).
/// Panics with cargo's output when the build fails.
pub fn handgate_bin() -> PathBuf {
    static BUILT: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    BUILT
        .get_or_init(build_handgate)
        .clone()
        .unwrap_or_else(|e| panic!("{e}"))
}

fn build_handgate() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| format!("the test executable's path: {e}"))?;
    let profile_dir = exe
        .parent()
        .and_then(|deps| {
            if deps.file_name().is_some_and(|n| n == "deps") {
                deps.parent()
            } else {
                Some(deps)
            }
        })
        .ok_or("the test executable lives in target/<profile>/deps")?
        .to_path_buf();
    let bin = profile_dir.join(format!("handgate{}", std::env::consts::EXE_SUFFIX));
    let skip = matches!(std::env::var("HANDGATE_TESTS_NO_BUILD").as_deref(), Ok(v) if !v.is_empty() && v != "0");
    if !skip {
        // target/<profile>: the target directory is its parent, the profile its name.
        let profile = profile_dir.file_name().and_then(|n| n.to_str()).unwrap_or("debug");
        let target_dir = profile_dir.parent().ok_or("target/<profile> has a parent")?;
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.current_dir(repo_root())
            .args([
                "build",
                "--quiet",
                "-p",
                "handgate",
                "--features",
                "foxglove",
                "--target-dir",
            ])
            .arg(target_dir);
        match profile {
            "debug" => {}
            "release" => {
                cmd.arg("--release");
            }
            other => {
                cmd.args(["--profile", other]);
            }
        }
        let out = cmd
            .stdin(Stdio::null())
            .output()
            .map_err(|e| format!("could not run cargo build -p handgate --features foxglove: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "cargo build -p handgate --features foxglove failed ({}): the end-to-end tests run \
                 the gateway of the current source.\n{}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
    }
    if !bin.exists() {
        return Err(format!(
            "{} is missing: the end-to-end tests run the real gateway binary. Run `cargo build -p \
             handgate --features foxglove` (with the same CARGO_TARGET_DIR and profile) or `make \
             test` first.",
            bin.display()
        ));
    }
    Ok(bin)
}

/// A Unix signal the tests send to a gateway.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    Int,
    Term,
}

impl Signal {
    fn name(self) -> &'static str {
        match self {
            Signal::Int => "INT",
            Signal::Term => "TERM",
        }
    }
}

/// Failure while starting or driving the gateway process.
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    #[error("could not start {bin}: {source}")]
    Spawn {
        bin: String,
        #[source]
        source: std::io::Error,
    },
    #[error("handgate printed no line containing {what:?} within {timeout:?}\n{transcript}")]
    Timeout {
        what: String,
        timeout: Duration,
        transcript: String,
    },
    #[error("handgate closed its stdout (exited) before printing a line containing {what:?}\n{transcript}")]
    Exited { what: String, transcript: String },
    #[error("could not send SIG{signal} to pid {pid}: {detail}")]
    Signal {
        signal: &'static str,
        pid: u32,
        detail: String,
    },
}

/// Text a child process wrote, collected on threads.
#[derive(Default)]
struct Captured {
    lines: Mutex<(Vec<String>, bool)>,
    changed: Condvar,
    stderr: Mutex<String>,
}

/// How long [`Gateway::start`] waits for `handgate serving ...` (DDS start-up included).
pub const GATEWAY_START_TIMEOUT: Duration = Duration::from_secs(30);
/// How long dropping a [`Gateway`] waits after SIGINT before killing it.
pub const GATEWAY_STOP_GRACE: Duration = Duration::from_secs(2);

/// A running `handgate run --domain N [args]`. Its stdout (the resolved fleet, the
/// `handgate serving ...` line and the logs) and stderr are collected on threads. Dropping it
/// sends SIGINT and waits up to [`GATEWAY_STOP_GRACE`], then kills it.
pub struct Gateway {
    domain: u32,
    child: Child,
    out: Arc<Captured>,
}

impl std::fmt::Debug for Gateway {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gateway")
            .field("domain", &self.domain)
            .field("pid", &self.child.id())
            .finish()
    }
}

impl Gateway {
    /// Starts `handgate run --domain <domain> <args>` from the repository root (no
    /// `HANDGATE_*` variables inherited; `HANDGATE_INTEROP_IFACE` adds `--interface`) and
    /// waits until it prints `handgate serving`. Panics (with its output) when it does not.
    pub fn start(domain: u32, args: &[&str]) -> Gateway {
        Self::try_start(domain, args).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Gateway::start`], returning the error instead.
    pub fn try_start(domain: u32, args: &[&str]) -> Result<Gateway, GatewayError> {
        Self::try_start_on(domain, args, interop_interface().as_deref())
    }

    /// As [`Gateway::try_start`] with an explicit network interface (`None`: CycloneDDS picks,
    /// as a client that calls `ChannelFactoryInitialize(domain)` without one does).
    pub fn try_start_on(domain: u32, args: &[&str], interface: Option<&str>) -> Result<Gateway, GatewayError> {
        let gw = Self::spawn(domain, args, interface)?;
        gw.wait_stdout("handgate serving", GATEWAY_START_TIMEOUT)?;
        Ok(gw)
    }

    /// Spawns `handgate run --domain <domain> [--interface <interface>] <args>` without
    /// waiting for readiness.
    pub fn spawn(domain: u32, args: &[&str], interface: Option<&str>) -> Result<Gateway, GatewayError> {
        Self::spawn_in(None, domain, args, interface)
    }

    /// [`Gateway::spawn`] inside network namespace `netns` (`ip netns exec`; see [`NetNs`]).
    pub fn spawn_in(
        netns: Option<&str>,
        domain: u32,
        args: &[&str],
        interface: Option<&str>,
    ) -> Result<Gateway, GatewayError> {
        let bin = handgate_bin();
        let mut cmd = handgate_cmd(netns);
        cmd.arg("run").arg("--domain").arg(domain.to_string());
        if let Some(iface) = interface {
            cmd.arg("--interface").arg(iface);
        }
        cmd.args(args);
        // Tests run in parallel: the dashboard on any free port, unless a test chooses one.
        if !args.contains(&"--http-port") {
            cmd.args(["--http-port", "0"]);
        }
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| GatewayError::Spawn {
                bin: bin.display().to_string(),
                source,
            })?;
        let out = Arc::new(Captured::default());
        let stdout = child.stdout.take().expect("stdout is piped");
        let o = Arc::clone(&out);
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                o.lines.lock().unwrap_or_else(|e| e.into_inner()).0.push(line);
                o.changed.notify_all();
            }
            o.lines.lock().unwrap_or_else(|e| e.into_inner()).1 = true;
            o.changed.notify_all();
        });
        let mut err_pipe = child.stderr.take().expect("stderr is piped");
        let o = Arc::clone(&out);
        std::thread::spawn(move || {
            let mut chunk = [0u8; 4096];
            while let Ok(n) = err_pipe.read(&mut chunk) {
                if n == 0 {
                    break;
                }
                let text = String::from_utf8_lossy(&chunk[..n]).into_owned();
                o.stderr.lock().unwrap_or_else(|e| e.into_inner()).push_str(&text);
            }
        });
        Ok(Gateway { domain, child, out })
    }

    /// The dashboard's base URL (`http://ADDR/`), from its start-up log line.
    pub fn http_url(&self) -> Result<String, GatewayError> {
        let line = self.wait_stdout("http: listening", GATEWAY_START_TIMEOUT)?;
        // `url=...` in the human log format, `"url":"..."` in the JSON one.
        let human = line.split_whitespace().find_map(|w| w.strip_prefix("url="));
        let json = || line.split("\"url\":\"").nth(1).and_then(|r| r.split('"').next());
        Ok(human.or_else(json).unwrap_or_default().to_string())
    }

    /// The DDS domain it serves.
    pub fn domain(&self) -> u32 {
        self.domain
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// The child process.
    pub fn child(&mut self) -> &mut Child {
        &mut self.child
    }

    /// Waits until a stdout line contains `what` (lines printed earlier count) and returns it.
    pub fn wait_stdout(&self, what: &str, timeout: Duration) -> Result<String, GatewayError> {
        let deadline = Instant::now() + timeout;
        let mut g = self.out.lines.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if let Some(l) = g.0.iter().find(|l| l.contains(what)) {
                return Ok(l.clone());
            }
            if g.1 {
                drop(g);
                return Err(GatewayError::Exited {
                    what: what.to_string(),
                    transcript: self.transcript(),
                });
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                drop(g);
                return Err(GatewayError::Timeout {
                    what: what.to_string(),
                    timeout,
                    transcript: self.transcript(),
                });
            }
            g = self
                .out
                .changed
                .wait_timeout(g, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    /// The Foxglove live server's URL (`ws://ADDR`), from its start-up log line
    /// (`foxglove: listening url=ws://...`; docs/foxglove.md).
    pub fn foxglove_url(&self) -> Result<String, GatewayError> {
        let line = self.wait_stdout("foxglove: listening", GATEWAY_START_TIMEOUT)?;
        Ok(line
            .split_whitespace()
            .find_map(|w| w.strip_prefix("url="))
            .unwrap_or_default()
            .to_string())
    }

    /// Everything it printed so far (stdout, then stderr).
    pub fn transcript(&self) -> String {
        let out = self.out.lines.lock().unwrap_or_else(|e| e.into_inner()).0.join("\n");
        let err = self.out.stderr.lock().unwrap_or_else(|e| e.into_inner()).clone();
        format!("--- handgate stdout ---\n{out}\n--- handgate stderr ---\n{err}")
    }

    /// Whether the process is still running.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Sends `signal` to the process (with `kill(1)`, keeping this crate free of libc).
    pub fn signal(&self, signal: Signal) -> Result<(), GatewayError> {
        let pid = self.child.id();
        let err = |detail: String| GatewayError::Signal {
            signal: signal.name(),
            pid,
            detail,
        };
        let st = Command::new("kill")
            .arg("-s")
            .arg(signal.name())
            .arg(pid.to_string())
            .status()
            .map_err(|e| err(e.to_string()))?;
        if st.success() {
            Ok(())
        } else {
            Err(err(format!("kill exited with {st}")))
        }
    }

    /// Polls for the process's exit until `timeout`; None if it is still running.
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Ok(Some(st)) = self.child.try_wait() {
                return Some(st);
            }
            if Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        if !self.is_running() {
            return;
        }
        if self.signal(Signal::Int).is_ok() && self.wait_exit(GATEWAY_STOP_GRACE).is_some() {
            return;
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

// ---------------------------------------------------------------------------------------------
// Plain values -> wire types

/// A plain JSON value that does not fit the wire type.
#[derive(Debug, thiserror::Error)]
pub enum PlainError {
    #[error("{at}: expected {want}, found {found}")]
    Type {
        at: String,
        want: &'static str,
        found: String,
    },
    #[error("{at}: {value} is out of range for {want}")]
    Range {
        at: String,
        value: String,
        want: &'static str,
    },
    #[error("{at}: array of {found} elements, the type has {want}")]
    Length { at: String, found: usize, want: usize },
    #[error("{at}: fields {found:?}, the type has {want:?}")]
    Fields {
        at: String,
        found: Vec<String>,
        want: Vec<&'static str>,
    },
}

fn type_err(at: &str, want: &'static str, v: &Value) -> PlainError {
    PlainError::Type {
        at: at.to_string(),
        want,
        found: v.to_string(),
    }
}

/// Builds a wire value from its plain JSON form (see the module docs).
pub trait FromPlain: Sized {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError>;
}

macro_rules! plain_int {
    ($($t:ty),*) => {$(
        impl FromPlain for $t {
            fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
                let n = v.as_i64().ok_or_else(|| type_err(at, "an integer", v))?;
                <$t>::try_from(n).map_err(|_| PlainError::Range {
                    at: at.to_string(),
                    value: n.to_string(),
                    want: stringify!($t),
                })
            }
        }
    )*};
}
plain_int!(i8, u8, i16, u16, i32, u32);

impl FromPlain for u64 {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        v.as_u64().ok_or_else(|| type_err(at, "an unsigned 64-bit integer", v))
    }
}

impl FromPlain for bool {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        v.as_bool().ok_or_else(|| type_err(at, "a boolean", v))
    }
}

impl FromPlain for String {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        v.as_str()
            .map(str::to_string)
            .ok_or_else(|| type_err(at, "a string", v))
    }
}

impl FromPlain for f64 {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        match v {
            Value::String(s) if s == "nan" => Ok(f64::NAN),
            Value::String(s) if s == "inf" => Ok(f64::INFINITY),
            Value::String(s) if s == "-inf" => Ok(f64::NEG_INFINITY),
            // Exact: serde_json is built with `float_roundtrip` for this crate.
            Value::Number(n) => n.as_f64().ok_or_else(|| type_err(at, "an f64", v)),
            _ => Err(type_err(at, "an f64 number or \"inf\"/\"-inf\"/\"nan\"", v)),
        }
    }
}

impl FromPlain for f32 {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        match v {
            Value::String(s) if s == "nan" => Ok(f32::NAN),
            Value::String(s) if s == "inf" => Ok(f32::INFINITY),
            Value::String(s) if s == "-inf" => Ok(f32::NEG_INFINITY),
            Value::Number(n) => {
                let x = n.as_f64().ok_or_else(|| type_err(at, "an f32", v))?;
                // `as` rounds to nearest, so a parse that is off in the last f64 bit still
                // lands on the f32 the fixture holds; only true overflow becomes infinite.
                if (x as f32).is_infinite() {
                    return Err(PlainError::Range {
                        at: at.to_string(),
                        value: x.to_string(),
                        want: "f32",
                    });
                }
                // The fixture holds the exact f32 value, so this conversion is exact.
                Ok(x as f32)
            }
            _ => Err(type_err(at, "an f32 number or \"inf\"/\"-inf\"/\"nan\"", v)),
        }
    }
}

impl<T: FromPlain, const N: usize> FromPlain for [T; N] {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        let items: Vec<T> = Vec::<T>::from_plain(v, at)?;
        let found = items.len();
        items.try_into().map_err(|_| PlainError::Length {
            at: at.to_string(),
            found,
            want: N,
        })
    }
}

impl<T: FromPlain> FromPlain for Vec<T> {
    fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
        let arr = v.as_array().ok_or_else(|| type_err(at, "an array", v))?;
        arr.iter()
            .enumerate()
            .map(|(i, x)| T::from_plain(x, &format!("{at}[{i}]")))
            .collect()
    }
}

/// Implements [`FromPlain`] for a struct from its field list. The struct literal makes the
/// compiler insist the list is complete; the key check rejects unknown or missing JSON fields.
macro_rules! plain_struct {
    ($ty:path { $($field:ident),* $(,)? }) => {
        impl FromPlain for $ty {
            fn from_plain(v: &Value, at: &str) -> Result<Self, PlainError> {
                let obj = v.as_object().ok_or_else(|| type_err(at, "an object", v))?;
                let want: Vec<&'static str> = vec![$(stringify!($field)),*];
                let mut found: Vec<String> = obj.keys().cloned().collect();
                let mut sorted_want: Vec<String> = want.iter().map(|s| s.to_string()).collect();
                found.sort();
                sorted_want.sort();
                if found != sorted_want {
                    return Err(PlainError::Fields { at: at.to_string(), found, want });
                }
                Ok(Self {
                    $($field: FromPlain::from_plain(
                        &obj[stringify!($field)],
                        &format!("{at}.{}", stringify!($field)),
                    )?,)*
                })
            }
        }
    };
}

plain_struct!(unitree_hg::MotorCmd_ {
    mode,
    q,
    dq,
    tau,
    kp,
    kd,
    reserve
});
plain_struct!(unitree_hg::MotorState_ {
    mode,
    q,
    dq,
    ddq,
    tau_est,
    temperature,
    vol,
    sensor,
    motorstate,
    reserve
});
plain_struct!(unitree_hg::PressSensorState_ {
    pressure,
    temperature,
    lost,
    reserve
});
plain_struct!(unitree_hg::IMUState_ {
    quaternion,
    gyroscope,
    accelerometer,
    rpy,
    temperature
});
plain_struct!(unitree_hg::HandCmd_ { motor_cmd, reserve });
plain_struct!(unitree_hg::HandState_ {
    motor_state,
    press_sensor_state,
    imu_state,
    power_v,
    power_a,
    system_v,
    device_v,
    error,
    reserve
});
plain_struct!(unitree_go::MotorCmd_ {
    mode,
    q,
    dq,
    tau,
    kp,
    kd,
    reserve
});
plain_struct!(unitree_go::MotorCmds_ { cmds });
plain_struct!(unitree_go::MotorState_ {
    mode,
    q,
    dq,
    ddq,
    tau_est,
    q_raw,
    dq_raw,
    ddq_raw,
    temperature,
    lost,
    reserve
});
plain_struct!(unitree_go::MotorStates_ { states });

plain_struct!(handgate::JointCmd_ {
    name,
    q,
    dq,
    tau,
    kp,
    kd
});
plain_struct!(handgate::HandCmd_ {
    seq,
    mode,
    closure,
    stiffness,
    joints
});
plain_struct!(handgate::JointState_ {
    name,
    q,
    dq,
    tau,
    temperature
});
plain_struct!(handgate::HandState_ {
    device,
    kind,
    side,
    cmd_seq,
    stamp_ns,
    freshness,
    closure,
    joints,
    pressure,
    accelerometer,
    gyroscope,
    power_v,
    power_a,
    faults
});
plain_struct!(handgate::DeviceStatus_ {
    device,
    kind,
    backend,
    freshness,
    safe,
    cmd_rate_hz,
    state_rate_hz,
    crc_errors,
    bad_input,
    watchdog_trips,
    reconnects,
    missed_cycles,
    age_ms,
    foreign_cmd,
    duplicate_cmd,
    reordered_cmd,
    late_cmd,
    owner,
    not_allowed_cmd,
    motion,
    motion_joint,
    tracking_error,
    faults
});
plain_struct!(handgate::EndpointStatus_ {
    owner,
    topic,
    role,
    matched,
    who
});
plain_struct!(handgate::Diagnostic_ {
    owner,
    topic,
    kind,
    detail,
    fix
});
plain_struct!(handgate::GatewayStatus_ {
    profile,
    uptime_ms,
    devices,
    endpoints,
    diagnostics,
    record_messages,
    record_dropped,
    domain,
    interface,
    export_domain,
    export_interface,
    namespace,
    host
});
plain_struct!(ros2::Time_ { sec, nanosec });
plain_struct!(ros2::Header_ { stamp, frame_id });
plain_struct!(ros2::JointState_ {
    header,
    name,
    position,
    velocity,
    effort
});
plain_struct!(ros2::KeyValue_ { key, value });
plain_struct!(ros2::DiagnosticStatus_ {
    level,
    name,
    message,
    hardware_id,
    values
});
plain_struct!(ros2::DiagnosticArray_ { header, status });
plain_struct!(ros2::GenericHardwareState_ {
    health_status,
    error_domain,
    operational_mode,
    power_state,
    connectivity_status,
    manufacturer,
    model,
    firmware_version,
    state_details
});
plain_struct!(ros2::CANopenState_ {
    node_id,
    nmt_state,
    dsp_402_state,
    last_emcy_code
});
plain_struct!(ros2::EtherCATState_ {
    slave_position,
    vendor_id,
    product_code,
    al_state,
    has_error,
    al_status_code
});
plain_struct!(ros2::VDA5050State_ {
    order_id,
    action_status,
    last_node_id,
    driving,
    battery_charge,
    operating_mode,
    error_type,
    error_description
});
plain_struct!(ros2::HardwareDeviceStatus_ {
    header,
    device_id,
    hardware_status,
    canopen_states,
    ethercat_states,
    vda5050_states
});
plain_struct!(ros2::HardwareStatus_ {
    header,
    hardware_id,
    hardware_device_states
});
plain_struct!(inspire::InspireHandCtrl {
    pos_set,
    angle_set,
    force_set,
    speed_set,
    mode
});
plain_struct!(inspire::InspireHandState {
    pos_act,
    angle_act,
    force_act,
    current,
    err,
    status,
    temperature
});
plain_struct!(inspire::InspireHandTouch {
    fingerone_tip_touch,
    fingerone_top_touch,
    fingerone_palm_touch,
    fingertwo_tip_touch,
    fingertwo_top_touch,
    fingertwo_palm_touch,
    fingerthree_tip_touch,
    fingerthree_top_touch,
    fingerthree_palm_touch,
    fingerfour_tip_touch,
    fingerfour_top_touch,
    fingerfour_palm_touch,
    fingerfive_tip_touch,
    fingerfive_top_touch,
    fingerfive_middle_touch,
    fingerfive_palm_touch,
    palm_touch
});

/// Parses one JSON document (e.g. a line a Python helper printed) into a wire value.
pub fn from_plain_json<T: FromPlain>(text: &str) -> Result<T, FixtureError> {
    let v: Value = serde_json::from_str(text).map_err(|e| FixtureError::Json {
        path: "<line>".into(),
        source: e,
    })?;
    Ok(T::from_plain(&v, "value")?)
}

// ---------------------------------------------------------------------------------------------
// Golden fixtures

/// A golden fixture could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FixtureError {
    #[error("reading {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("parsing {path}: {source}")]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{path}: field {field} missing or not a {want}")]
    Field {
        path: PathBuf,
        field: &'static str,
        want: &'static str,
    },
    #[error("{path}: bad hex at offset {offset}")]
    Hex { path: PathBuf, offset: usize },
    #[error(transparent)]
    Plain(#[from] PlainError),
}

/// One golden fixture: a value and the CDR bytes the official Python SDK made from it.
#[derive(Debug, Clone)]
pub struct Fixture {
    pub path: PathBuf,
    /// `unitree_hg`, `unitree_go`, `handgate`, `builtin_interfaces`, `std_msgs`, `sensor_msgs`.
    pub module: String,
    /// e.g. `HandCmd_`.
    pub type_name: String,
    /// `empty`, `typical`, `extreme`, `nan` or `sdk_default`.
    pub case: String,
    /// e.g. `unitree_hg::msg::dds_::HandCmd_`.
    pub dds_type_name: String,
    /// The plain JSON value.
    pub value: Value,
    /// Little-endian CDR with the encapsulation header, as unitree_sdk2py serialised it.
    pub cdr_le: Vec<u8>,
}

impl Fixture {
    /// `module::Type case`, for messages.
    pub fn label(&self) -> String {
        format!("{}::{} {}", self.module, self.type_name, self.case)
    }

    /// The fixture's value as a handgate wire value.
    pub fn value_as<T: FromPlain>(&self) -> Result<T, PlainError> {
        T::from_plain(&self.value, &self.label())
    }
}

/// Decodes lowercase or uppercase hex without separators.
pub fn hex_decode(s: &str) -> Option<Vec<u8>> {
    let b = s.as_bytes();
    if b.len() % 2 != 0 {
        return None;
    }
    b.chunks(2)
        .map(|p| {
            let hi = (p[0] as char).to_digit(16)?;
            let lo = (p[1] as char).to_digit(16)?;
            Some((hi * 16 + lo) as u8)
        })
        .collect()
}

/// Reads one fixture file.
pub fn load_fixture(path: &Path) -> Result<Fixture, FixtureError> {
    let text = std::fs::read_to_string(path).map_err(|source| FixtureError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let v: Value = serde_json::from_str(&text).map_err(|source| FixtureError::Json {
        path: path.to_path_buf(),
        source,
    })?;
    let field = |name: &'static str| -> Result<String, FixtureError> {
        v.get(name)
            .and_then(Value::as_str)
            .map(str::to_string)
            .ok_or_else(|| FixtureError::Field {
                path: path.to_path_buf(),
                field: name,
                want: "string",
            })
    };
    let hex = field("cdr_le_hex")?;
    let cdr_le = hex_decode(&hex).ok_or_else(|| FixtureError::Hex {
        path: path.to_path_buf(),
        offset: 0,
    })?;
    let value = v.get("value").cloned().ok_or(FixtureError::Field {
        path: path.to_path_buf(),
        field: "value",
        want: "object",
    })?;
    Ok(Fixture {
        path: path.to_path_buf(),
        module: field("module")?,
        type_name: field("type")?,
        case: field("case")?,
        dds_type_name: field("dds_type_name")?,
        value,
        cdr_le,
    })
}

/// Every fixture in [`golden_dir`], sorted by file name.
pub fn golden_fixtures() -> Result<Vec<Fixture>, FixtureError> {
    let dir = golden_dir();
    let rd = std::fs::read_dir(&dir).map_err(|source| FixtureError::Io {
        path: dir.clone(),
        source,
    })?;
    let mut paths: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    paths.sort();
    paths.iter().map(|p| load_fixture(p)).collect()
}

/// The fixture `<module>__<type_name>__<case>.json`.
pub fn fixture(module: &str, type_name: &str, case: &str) -> Result<Fixture, FixtureError> {
    load_fixture(&golden_dir().join(format!("{module}__{type_name}__{case}.json")))
}

// ---------------------------------------------------------------------------------------------
// Waiting on DDS in gateway-level tests (e2e_gateway.rs, reliability.rs).

/// Serialises the tests of one test binary that start gateways: on a 2-core machine, parallel
/// gateways starve each other into spurious watchdog trips.
pub fn serial() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// A participant on `domain` (on `HANDGATE_INTEROP_IFACE` when set).
pub fn node(domain: u32) -> handgate_adapters::dds::Node {
    handgate_adapters::dds::Node::new(domain, interop_interface().as_deref()).expect("DDS participant")
}

/// Polls `f` every millisecond until it returns Some or `timeout` passes.
pub fn poll<T>(timeout: Duration, mut f: impl FnMut() -> Option<T>) -> Option<T> {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(v) = f() {
            return Some(v);
        }
        if Instant::now() >= deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// How often [`stream_until`] writes: 100 Hz, a typical client rate.
pub const STREAM_PERIOD: Duration = Duration::from_millis(10);

/// Writes `msg` every [`STREAM_PERIOD`] until `cond` holds (checked after each write and
/// between writes) or `timeout` passes; returns whether `cond` held.
pub fn stream_until<T: handgate_idl::TopicType + Clone>(
    w: &mut handgate_adapters::dds::Writer<T>,
    msg: &T,
    timeout: Duration,
    mut cond: impl FnMut() -> bool,
) -> bool {
    let deadline = Instant::now() + timeout;
    let mut next = Instant::now();
    loop {
        if Instant::now() >= next {
            w.write(msg.clone()).expect("write");
            next += STREAM_PERIOD;
        }
        if cond() {
            return true;
        }
        if Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// The newest sample of a reader, remembered between calls.
pub struct Latest<T: handgate_idl::TopicType + Clone> {
    pub reader: handgate_adapters::dds::Reader<T>,
    pub last: Option<T>,
    pub count: u64,
}

impl<T: handgate_idl::TopicType + Clone> Latest<T> {
    pub fn new(node: &handgate_adapters::dds::Node, topic: &str, qos: handgate_adapters::dds::Qos) -> Self {
        Self {
            reader: node.reader(topic, qos).expect("reader"),
            last: None,
            count: 0,
        }
    }

    /// Takes whatever arrived, calling `each` on every sample; returns the newest.
    pub fn update_with(&mut self, mut each: impl FnMut(&T)) -> Option<&T> {
        for s in self.reader.take() {
            each(&s);
            self.count += 1;
            self.last = Some(s);
        }
        self.last.as_ref()
    }

    /// Takes whatever arrived; returns the newest sample seen so far.
    pub fn update(&mut self) -> Option<&T> {
        self.update_with(|_| {})
    }

    /// Waits for a sample newer than the ones already taken.
    pub fn next(&mut self, timeout: Duration) -> Option<T> {
        let before = self.count;
        poll(timeout, || {
            self.update();
            (self.count > before).then(|| self.last.clone()).flatten()
        })
    }
}

/// The status row of device `name`.
pub fn status_device<'a>(s: &'a handgate::GatewayStatus_, name: &str) -> &'a handgate::DeviceStatus_ {
    s.devices
        .iter()
        .find(|d| d.device == name)
        .unwrap_or_else(|| panic!("status has no device {name}: {s:?}"))
}

/// `profiles/default.toml` with each `(from, to)` replaced (every `from` must occur: a test
/// fails loudly when the default profile changes under it), written to a file of its own
/// under the system temp dir; returns its path.
pub fn default_profile_edited(name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(repo_root().join("profiles").join("default.toml")).expect("default profile");
    for (from, to) in edits {
        assert!(
            text.contains(from),
            "profiles/default.toml no longer contains {from:?}; update this test"
        );
        text = text.replace(from, to);
    }
    let dir = std::env::temp_dir().join(format!("handgate-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).expect("write profile");
    p
}

/// The default profile's front on `device` (a `device = "<device>"` line of
/// `profiles/default.toml`'s fronts), with `silence = "watchdog"`: today's strict watchdog
/// for tests that rely on it (docs/fronts.md, "Silence").
pub fn default_profile_with_watchdog(name: &str, front_device_line: &str) -> PathBuf {
    default_profile_edited(
        name,
        &[(
            front_device_line,
            &format!("{front_device_line}\nsilence = \"watchdog\""),
        )],
    )
}

// ---------------------------------------------------------------------------------------------
// Profiles and canonical messages shared by the kinds' end-to-end tests.

/// Writes `text` as `<name>.toml` in this test process's directory for `tag`
/// (`$TMPDIR/handgate-<tag>-<pid>/`) and returns its path.
pub fn temp_profile(tag: &str, name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handgate-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("profile directory");
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).expect("profile written");
    p
}

/// A client of one hand service (`kind`, its left hand, as device `hand`) with a canonical
/// front and the status at its highest rate, 10 Hz (so the status adds at most 100 ms to a
/// report), written for `tag` ([`temp_profile`]).
pub fn hand_client_profile(tag: &str, kind: &str) -> PathBuf {
    temp_profile(
        tag,
        &format!("{kind}-client"),
        &format!(
            "name = \"{kind}-client\"\n[status]\nrate_hz = 10\n\
             [[devices]]\nname = \"hand\"\nkind = \"{kind}\"\nside = \"left\"\nbackend = \"dds\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"hand\"\n"
        ),
    )
}

/// `handgate emulate <kind>`'s left hand service on `domain` with `fault` injected (the Dex3's
/// service, not its USB MCU): what [`hand_client_profile`]'s device `hand` is a client of. On
/// `HANDGATE_INTEROP_IFACE` when set, as the gateway [`Gateway::start`] runs is.
pub fn faulty_hand_service(kind: &str, domain: u32, fault: &str) -> Emulation {
    let d = domain.to_string();
    let service: &[&str] = if kind == "dex3" { &["--service"] } else { &[] };
    let iface = interop_interface();
    let on: Vec<&str> = iface.iter().flat_map(|i| ["--interface", i.as_str()]).collect();
    Emulation::start(
        &[
            &[kind][..],
            service,
            &["--side", "left", "--domain", &d, "--fault", fault],
            &on,
        ]
        .concat(),
    )
}

/// tests/python/health_peer.py on `domain` (the ROS 2 health messages as JSON lines, `DIAG` and
/// `HW`), once its readers exist.
pub fn health_peer(domain: u32) -> PyProcess {
    let py = PyProcess::spawn(
        "health_peer.py",
        &["--domain".into(), domain.to_string(), "--timeout".into(), "120".into()],
    )
    .unwrap();
    py.wait_line("READY", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    py
}

/// Writes `closure` on `device`'s canonical front (`rt/handgate/<device>/cmd`) every
/// [`STREAM_PERIOD`] on a thread, from the moment the front matches until the flag is set.
/// The thread returns when it wrote its first command (`None`: it was stopped before).
pub fn stream_closure(
    domain: u32,
    device: &str,
    closure: f32,
) -> (
    std::sync::Arc<std::sync::atomic::AtomicBool>,
    std::thread::JoinHandle<Option<Instant>>,
) {
    use std::sync::atomic::Ordering;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let s = stop.clone();
    let topic = format!("rt/handgate/{device}/cmd");
    let t = std::thread::spawn(move || {
        let n = node(domain);
        let mut w = n
            .writer::<handgate::HandCmd_>(&topic, handgate_adapters::dds::Qos::Reliable { depth: 1 })
            .expect("writer");
        w.wait_matched(1, Duration::from_secs(60))
            .expect("the canonical front matched");
        let mut first = None;
        let mut seq = 0;
        while !s.load(Ordering::Relaxed) {
            seq += 1;
            w.write(closure_cmd(seq, closure)).expect("write");
            first.get_or_insert_with(Instant::now);
            std::thread::sleep(STREAM_PERIOD);
        }
        first
    });
    (stop, t)
}

/// The legacy actuator pair's command (`rt/unitree_actuator/cmd`): two elements, right then
/// left, wire q (0 closed, 5.4 open), kp 5, kd 0.05, as old xr_teleoperate sends.
pub fn actuator_cmd(right: f32, left: f32) -> unitree_go::MotorCmds_ {
    let mut c = unitree_go::MotorCmds_::with_len(2);
    for (m, q) in c.cmds.iter_mut().zip([right, left]) {
        *m = unitree_go::MotorCmd_ {
            q,
            kp: 5.0,
            kd: 0.05,
            ..Default::default()
        };
    }
    c
}

/// `handgate doctor <args>` (in network namespace `netns`, if any) with no `HANDGATE_*`
/// variables from this environment: its exit code and its stdout then stderr.
pub fn run_doctor(netns: Option<&str>, args: &[&str]) -> (i32, String) {
    let out = handgate_cmd(netns)
        .arg("doctor")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("handgate doctor runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.code().unwrap_or(-1), text)
}

/// A `[[devices]]` table of an emulated device.
pub fn emulated_device(name: &str, kind: &str, side: &str) -> String {
    format!("[[devices]]\nname = \"{name}\"\nkind = \"{kind}\"\nside = \"{side}\"\nbackend = \"emulator\"\n")
}

/// Canonical position (rad) of joint `name` in a canonical front's state.
pub fn canonical_q(s: &handgate::HandState_, name: &str) -> f32 {
    s.joints
        .iter()
        .find(|j| j.name == name)
        .unwrap_or_else(|| panic!("no joint {name} in {s:?}"))
        .q
}

/// IDL index of index_0 on the Dex3 wire (the left index closes negative).
pub const DEX3_INDEX_0: usize = 5;

/// A Dex3 command as the SDK's clients write it: every motor id i, FOC (RIS byte `0x10 | i`),
/// kp 1.5, kd 0.1, q 0, except index_0 at `index_0` (wire frame); `tag` in `reserve[0]`.
pub fn dex3_cmd(index_0: f32, tag: u32) -> unitree_hg::HandCmd_ {
    let mut c = unitree_hg::HandCmd_::sdk_default();
    for (i, m) in c.motor_cmd.iter_mut().enumerate() {
        *m = unitree_hg::MotorCmd_ {
            mode: 0x10 | i as u8,
            kp: 1.5,
            kd: 0.1,
            ..Default::default()
        };
    }
    c.motor_cmd[DEX3_INDEX_0].q = index_0;
    c.reserve[0] = tag;
    c
}

/// A canonical closure command (0 open, 1 closed).
pub fn closure_cmd(seq: u64, closure: f32) -> handgate::HandCmd_ {
    handgate::HandCmd_ {
        seq,
        mode: handgate::MODE_CLOSURE,
        closure,
        ..Default::default()
    }
}

/// `handgate check PROFILE` from the repository root, without the caller's `HANDGATE_*`
/// environment.
pub fn handgate_check(profile: &Path) -> std::process::Output {
    handgate_cmd(None)
        .arg("check")
        .arg(profile)
        .output()
        .expect("handgate check runs")
}

/// A `handgate emulate ARGS` process (without the caller's `HANDGATE_*` environment), killed
/// on drop.
pub struct Emulation {
    child: Child,
    /// The line it printed on start (what it emulates, where).
    pub line: String,
}

impl Emulation {
    /// Starts it and waits (up to 30 s) for the line saying what it emulates.
    pub fn start(args: &[&str]) -> Emulation {
        Self::start_in(None, args)
    }

    /// [`Emulation::start`] inside network namespace `netns`.
    pub fn start_in(netns: Option<&str>, args: &[&str]) -> Emulation {
        let mut cmd = handgate_cmd(netns);
        cmd.arg("emulate").args(args);
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("handgate emulate starts");
        let stdout = child.stdout.take().expect("stdout is piped");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut lines = BufReader::new(stdout).lines();
            if let Some(Ok(l)) = lines.next() {
                let _ = tx.send(l);
            }
            // Keep reading so the emulator never blocks on a full pipe.
            for _ in lines {}
        });
        let line = rx
            .recv_timeout(Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("handgate emulate {args:?} printed nothing"));
        Emulation { child, line }
    }
}

impl Emulation {
    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Emulation {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

// ---------------------------------------------------------------------------------------------
// The gateway's HTTP endpoints and its process, as the soak and HTTP tests read them.

/// `GET url+path` over a plain socket (`url` as [`Gateway::http_url`] gives it): (status code,
/// body).
pub fn http_get(url: &str, path: &str) -> (u16, String) {
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    http_raw(url, &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n"))
}

/// `request` (a whole request head, as written) sent to the server of `url`, read until the
/// server closes: (status code, body).
pub fn http_raw(url: &str, request: &str) -> (u16, String) {
    use std::io::Write;
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let mut s = std::net::TcpStream::connect(addr).unwrap_or_else(|e| panic!("connect {addr}: {e}"));
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut buf = String::new();
    s.read_to_string(&mut buf).unwrap();
    let code = buf
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no status line: {buf:?}"));
    let body = buf
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (code, body)
}

/// The per-device samples of a `/metrics` text: `(metric, device label) -> value` for every
/// sample line with a `device="..."` label (histogram buckets excluded).
pub fn device_metrics(text: &str) -> std::collections::HashMap<(String, String), f64> {
    let mut out = std::collections::HashMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let Some((name, rest)) = line.split_once('{') else {
            continue;
        };
        let Some((labels, value)) = rest.rsplit_once("} ") else {
            continue;
        };
        if labels.contains("le=\"") {
            continue;
        }
        let Some(device) = labels
            .split(',')
            .find_map(|l| l.strip_prefix("device=\""))
            .and_then(|d| d.strip_suffix('"'))
        else {
            continue;
        };
        let v = match value.trim() {
            "NaN" => f64::NAN,
            "+Inf" => f64::INFINITY,
            "-Inf" => f64::NEG_INFINITY,
            v => v.parse().unwrap_or_else(|_| panic!("not a number in {line:?}")),
        };
        out.insert((name.to_string(), device.to_string()), v);
    }
    out
}

/// The resident set size of process `pid` (`VmRSS` of `/proc/<pid>/status`), KiB.
pub fn vm_rss_kib(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

#[cfg(test)]
mod unit {
    use super::*;
    use serde_json::json;

    /// A harness variable in the test process (`HANDGATE_INTEROP_IFACE=lo`) is read by
    /// handgate as a profile key and refused; [`handgate_cmd`] keeps it out, so `check` (and
    /// `doctor`, `run`: anything loading a profile) works with it set.
    #[test]
    fn the_harness_variables_do_not_reach_handgate() {
        let inherited = || {
            let mut c = in_netns(None, &handgate_bin());
            c.current_dir(repo_root())
                .env("HANDGATE_INTEROP_IFACE", "lo")
                .arg("check");
            c
        };
        let o = inherited().output().unwrap();
        assert_eq!(o.status.code(), Some(2), "handgate refuses it as a profile key");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("environment (HANDGATE_INTEROP_IFACE): interop_iface: unknown key"),
            "{err}"
        );
        let mut c = inherited();
        without_handgate_env(&mut c, ["HANDGATE_INTEROP_IFACE".to_string()].into_iter());
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stdout).contains("dds: domain 1"));
    }

    #[test]
    fn hex_decodes_and_rejects_garbage() {
        assert_eq!(hex_decode("00ff7F"), Some(vec![0, 0xff, 0x7f]));
        assert_eq!(hex_decode("abc"), None);
        assert_eq!(hex_decode("zz"), None);
    }

    #[test]
    fn floats_accept_the_non_finite_spellings() {
        assert!(f32::from_plain(&json!("nan"), "x").unwrap().is_nan());
        assert_eq!(f32::from_plain(&json!("-inf"), "x").unwrap(), f32::NEG_INFINITY);
        assert_eq!(f32::from_plain(&json!(-0.0), "x").unwrap().to_bits(), 0x8000_0000);
        assert!(matches!(
            f32::from_plain(&json!(1e39), "x"),
            Err(PlainError::Range { .. })
        ));
        assert!(matches!(
            f32::from_plain(&json!("NaN"), "x"),
            Err(PlainError::Type { .. })
        ));
        assert_eq!(f64::from_plain(&json!(5e-324), "x").unwrap().to_bits(), 1);
    }

    #[test]
    fn integers_are_range_checked() {
        assert_eq!(u8::from_plain(&json!(255), "x").unwrap(), 255);
        assert!(matches!(
            u8::from_plain(&json!(256), "x"),
            Err(PlainError::Range { .. })
        ));
        assert!(matches!(
            i16::from_plain(&json!(-32769), "x"),
            Err(PlainError::Range { .. })
        ));
        assert!(matches!(
            u32::from_plain(&json!(1.5), "x"),
            Err(PlainError::Type { .. })
        ));
        assert_eq!(u64::from_plain(&json!(u64::MAX), "x").unwrap(), u64::MAX);
    }

    #[test]
    fn structs_reject_missing_unknown_fields_and_wrong_lengths() {
        let ok = json!({"quaternion": [1.0, 0, 0, 0], "gyroscope": [0, 0, 0], "accelerometer": [0, 0, 0],
                        "rpy": [0, 0, 0], "temperature": 30});
        let imu = unitree_hg::IMUState_::from_plain(&ok, "imu").unwrap();
        assert_eq!((imu.quaternion[0], imu.temperature), (1.0, 30));

        let mut extra = ok.clone();
        extra["id"] = json!(1);
        assert!(matches!(
            unitree_hg::IMUState_::from_plain(&extra, "imu"),
            Err(PlainError::Fields { .. })
        ));
        let mut short = ok.clone();
        short["rpy"] = json!([0, 0]);
        let err = unitree_hg::IMUState_::from_plain(&short, "imu").unwrap_err();
        assert!(err.to_string().contains("imu.rpy"), "{err}");
    }
}
