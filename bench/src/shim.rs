//! The shim hop (issue 17): a Dex1 client driving a Dex3 that is served by the G1-service
//! emulator running as its own process (`handgate emulate dex3 --service`), through a shim
//! that speaks Dex1 on one side and is a client of the Dex3 service on the other. Peers, one
//! after the other against the same emulator process:
//!
//! - **raw relay** (`handgate-bench shim-relay`): the least any shim can do, two raw DDS hops:
//!   from its DDS listeners, a Dex1 command is mapped and published to the service at once,
//!   and every service state is published as a Dex1 state carrying the tag of the last
//!   command forwarded before it arrived; no loop, no tick;
//! - **handgate**: `handgate run` with a Dex3 device on backend `dds` (the emulator's service)
//!   and a Dex1 front bound to it (through closure, docs/model.md "Front ⇄ device");
//! - **python shim** (`bench/python/shim.py`): the same two callbacks written with the
//!   official unitree_sdk2py, as integrators write it today.
//!
//! The client (`crate::hop::tagged_client`) publishes unitree_go `MotorCmds_` (the Dex1
//! front's `go` variant, 1 element) on `rt/dex1/{side}/cmd` with a unique tag in
//! `cmds[0].reserve[0]` and times the first `MotorStates_` on `rt/dex1/{side}/state` whose
//! `states[0].reserve[0]` carries it.

use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_device::{CMD_QOS, STATE_QOS};
use handgate_adapters::dex3::RisMode;
use handgate_adapters::kind::DeviceKind;
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::Side;
use handgate_idl::unitree_go::{MotorCmds_, MotorStates_};
use handgate_idl::unitree_hg::{HandCmd_, HandState_, DEX3_MOTORS};
use serde::{Deserialize, Serialize};

use crate::child::Proc;
use crate::hop::tagged_client;
use crate::stats::{loadavg, Summary};

/// The Dex1 front's `go` topics (what dex1_1_service and SAKE's EZGripper driver serve).
pub fn dex1_topics(side: Side) -> (String, String) {
    (format!("rt/dex1/{side}/cmd"), format!("rt/dex1/{side}/state"))
}

/// The Dex3 service's topics (the emulator's, the shim's device side).
pub fn dex3_topics(side: Side) -> (String, String) {
    use handgate_adapters::dex3::{cmd_topic, state_topic};
    (cmd_topic(side), state_topic(side))
}

/// What a shim does with a command and a state: a Dex1 jaw position (wire rad, `range` =
/// open, 0 = closed) becomes a Dex3 closure posture between the hand's open and closed
/// postures (wire values, from handgate's Dex3 table), and the Dex3's measured closure comes
/// back as the jaw position at that closure. The same mapping handgate's router applies
/// through closure, written out flat.
#[derive(Debug, Clone, PartialEq)]
pub struct Mapping {
    pub range: f32,
    pub open: [f32; DEX3_MOTORS],
    pub closed: [f32; DEX3_MOTORS],
    pub kp: f32,
    pub kd: f32,
}

impl Mapping {
    /// From the Dex3 table of `side` (its closure postures and gains) and the Dex1 default range.
    pub fn dex3(side: Side) -> anyhow::Result<Self> {
        let kind = DeviceKind::by_name("dex3").ok_or_else(|| anyhow::anyhow!("no dex3 kind"))?;
        let table = kind.table(side, &TableOverrides::default())?;
        let wire = |c: f32| -> anyhow::Result<Vec<_>> { Ok(table.to_wire(&table.closure_targets(c, None)?)) };
        let (open, closed) = (wire(0.0)?, wire(1.0)?);
        anyhow::ensure!(
            open.len() == DEX3_MOTORS && closed.len() == DEX3_MOTORS,
            "Dex3 table size"
        );
        Ok(Self {
            range: handgate_adapters::dex1::table::DEFAULT_RANGE as f32,
            open: std::array::from_fn(|i| open[i].q),
            closed: std::array::from_fn(|i| closed[i].q),
            kp: closed[0].kp,
            kd: closed[0].kd,
        })
    }

    /// The Dex3 command for a Dex1 jaw position (RIS mode: FOC, no timeout).
    pub fn command(&self, jaw_wire: f32) -> HandCmd_ {
        let c = closure_of_jaw(jaw_wire, self.range);
        let mut out = HandCmd_::with_motors(DEX3_MOTORS);
        for (i, m) in out.motor_cmd.iter_mut().enumerate() {
            m.mode = RisMode::foc(i as u8, false).encode();
            m.q = self.open[i] + c * (self.closed[i] - self.open[i]);
            m.kp = self.kp;
            m.kd = self.kd;
        }
        out
    }

    /// The Dex1 jaw position (wire) of a Dex3 state: its closure, mean over the joints that
    /// move between the postures.
    pub fn jaw(&self, s: &HandState_) -> f32 {
        let (mut sum, mut n) = (0.0f32, 0u32);
        for (i, m) in s.motor_state.iter().take(DEX3_MOTORS).enumerate() {
            let span = self.closed[i] - self.open[i];
            if span.abs() > 1e-6 {
                sum += ((m.q - self.open[i]) / span).clamp(0.0, 1.0);
                n += 1;
            }
        }
        let c = if n == 0 { 0.0 } else { sum / n as f32 };
        self.range * (1.0 - c)
    }

    /// The Python shim's arguments for the same mapping (one home: this table).
    pub fn args(&self) -> Vec<String> {
        let csv = |v: &[f32]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(",");
        vec![
            "--open".into(),
            csv(&self.open),
            "--closed".into(),
            csv(&self.closed),
            "--kp".into(),
            self.kp.to_string(),
            "--kd".into(),
            self.kd.to_string(),
            "--range".into(),
            self.range.to_string(),
        ]
    }
}

/// Closure [0, 1] of a Dex1 jaw position on the wire (`range` open, 0 closed).
fn closure_of_jaw(jaw_wire: f32, range: f32) -> f32 {
    if jaw_wire.is_finite() {
        (1.0 - jaw_wire / range).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The raw relay (`handgate-bench shim-relay`): two raw DDS hops, everything from the DDS
/// listeners. Runs until SIGINT/SIGTERM, then deletes its endpoints (so a later peer on the
/// domain does not see them linger).
pub fn relay(domain: u32, iface: Option<&str>, side: Side) -> anyhow::Result<()> {
    let map = Mapping::dex3(side)?;
    let node = Node::new(domain, iface)?;
    let (d1_cmd, d1_state) = dex1_topics(side);
    let (d3_cmd, d3_state) = dex3_topics(side);
    // As handgate's device and front: the same QoS on both sides.
    let mut to_service = node.writer::<HandCmd_>(&d3_cmd, CMD_QOS)?;
    let mut to_client = node.writer::<MotorStates_>(&d1_state, Qos::BestEffort)?;
    let last_tag = Arc::new(AtomicU32::new(0));
    let tag_w = last_tag.clone();
    let m = map.clone();
    let from_service = node.reader_with_callback::<HandState_, _>(&d3_state, STATE_QOS, move |h| {
        let mut v = Vec::new();
        h.take_into(&mut v);
        if let Some(s) = v.pop() {
            let mut out = MotorStates_::with_len(1);
            let q = m.jaw(&s);
            out.states[0].q = q;
            out.states[0].q_raw = q;
            out.states[0].reserve[0] = last_tag.load(Ordering::Acquire);
            let _ = to_client.write(out);
        }
    })?;
    to_service.wait_matched(1, Duration::from_secs(30))?;
    from_service.wait_matched(1, Duration::from_secs(30))?;
    let from_client = node.reader_with_callback::<MotorCmds_, _>(&d1_cmd, Qos::Reliable { depth: 16 }, move |h| {
        let mut v = Vec::new();
        h.take_into(&mut v);
        // Latest wins: the newest command of what arrived together.
        if let Some(c) = v.pop().filter(|c| c.cmds.len() == 1) {
            if to_service.write(map.command(c.cmds[0].q)).is_ok() {
                tag_w.store(c.cmds[0].reserve[0], Ordering::Release);
            }
        }
    })?;
    println!("READY");
    wait_for_stop();
    drop(from_client);
    drop(from_service);
    drop(node);
    Ok(())
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

fn wait_for_stop() {
    // SAFETY: the handler only stores to an atomic (async-signal-safe).
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
    while !STOP.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// One client run against one shim at one command rate.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShimResult {
    /// What the hop benchmark measures of a run (`peer_cpu_pct`: the shim process).
    #[serde(flatten)]
    pub hop: crate::hop::HopResult,
    /// CPU of the emulator process during the same run, % of one core.
    pub emulator_cpu_pct: f64,
    /// Load averages (1/5/15 min) when this run started and ended.
    pub load_start: [f64; 3],
    pub load_end: [f64; 3],
}

/// What `handgate-bench shim` writes.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShimRun {
    pub domain: u32,
    pub side: String,
    /// The emulator's command line.
    pub emulator: String,
    /// The profile handgate ran (its text).
    pub profile: String,
    pub load_start: [f64; 3],
    pub load_end: [f64; 3],
    /// Commands per run not counted (warm-up).
    pub warmup: usize,
    pub results: Vec<ShimResult>,
}

/// handgate's profile for this benchmark: a Dex3 on backend dds (the emulator's service
/// topics, the kind's defaults otherwise) and a Dex1 front (`go`) bound to it.
pub fn profile(domain: u32, side: Side) -> String {
    format!(
        "# Generated by handgate-bench shim: a Dex1 front driving a Dex3 that is a client of the\n\
         # G1 hand service (here `handgate emulate dex3 --service`), through closure.\n\
         name = \"bench-shim\"\n\
         description = \"Dex1 front -> Dex3 over DDS (shim benchmark)\"\n\n\
         [dds]\ndomain = {domain}\n\n\
         [log]\nlevel = \"warn\"\n\n\
         [[devices]]\nname = \"hand\"\nkind = \"dex3\"\nside = \"{side}\"\nbackend = \"dds\"\n\n\
         [devices.watchdog]\ntimeout_ms = 200\nsafe_action = \"hold\"\n\n\
         [[fronts]]\nkind = \"dex1\"\ndevice = \"hand\"\nvariant = \"go\"\n"
    )
}

/// A Dex1 `go` command for the client: the jaw sweeps over its range (a new position with
/// every command), tag in `reserve[0]`.
fn dex1_command(range: f32) -> impl Fn(u32) -> MotorCmds_ {
    move |tag| {
        let mut c = MotorCmds_::with_len(1);
        // A triangle over 10% .. 90% of the range, 200 commands a sweep.
        let phase = (tag % 200) as f32 / 100.0;
        let x = if phase <= 1.0 { phase } else { 2.0 - phase };
        c.cmds[0].q = range * (0.1 + 0.8 * x);
        c.cmds[0].kp = 5.0;
        c.cmds[0].kd = 0.05;
        c.cmds[0].reserve[0] = tag;
        c
    }
}

/// The client against a running shim (`peer_pid`) and emulator (`emu_pid`).
#[allow(clippy::too_many_arguments)]
pub fn client(
    domain: u32,
    iface: Option<&str>,
    side: Side,
    target: &str,
    rate_hz: f64,
    samples: usize,
    warmup: usize,
    peer_pid: u32,
    emu_pid: u32,
) -> anyhow::Result<ShimResult> {
    let node = Node::new(domain, iface)?;
    let (cmd, state) = dex1_topics(side);
    let range = handgate_adapters::dex1::table::DEFAULT_RANGE as f32;
    let load_start = loadavg();
    let run = tagged_client(
        &node,
        &cmd,
        &state,
        rate_hz,
        samples,
        warmup,
        &[peer_pid, emu_pid],
        dex1_command(range),
        |s: &MotorStates_| s.states.first().map(|m| m.reserve[0]),
    )?;
    Ok(ShimResult {
        hop: crate::hop::HopResult {
            target: target.into(),
            rate_hz,
            sent: run.sent,
            echoed: run.latency_us.len(),
            latency_us: Summary::of(&run.latency_us),
            peer_cpu_pct: run.cpu_pct[0],
        },
        emulator_cpu_pct: run.cpu_pct[1],
        load_start,
        load_end: loadavg(),
    })
}

/// Where the profile for handgate goes: beside the results.
pub fn profile_path(out: &Path) -> std::path::PathBuf {
    out.with_extension("toml")
}

/// What to run: `handgate-bench shim`'s arguments.
#[derive(Debug, Clone)]
pub struct Plan<'a> {
    pub handgate: &'a Path,
    /// The venv interpreter with unitree_sdk2py and `bench/python/shim.py` (the Python shim is
    /// skipped when the interpreter is absent).
    pub python: Option<(&'a Path, &'a Path)>,
    pub rates: &'a [f64],
    pub samples: usize,
    pub warmup: usize,
    pub domain: u32,
    pub iface: Option<&'a str>,
    /// Peers in order: handgate, relay, python.
    pub only: &'a [String],
    pub out: &'a Path,
}

/// Starts the emulator, then each shim in turn against it, and writes the results.
pub fn run(p: &Plan<'_>) -> anyhow::Result<ShimRun> {
    let side = Side::Left;
    let load_start = loadavg();
    let mut emu_cmd = Command::new(p.handgate);
    emu_cmd.args([
        "emulate",
        "dex3",
        "--service",
        "--side",
        "left",
        "--domain",
        &p.domain.to_string(),
    ]);
    if let Some(i) = p.iface {
        emu_cmd.args(["--interface", i]);
    }
    let emulator = format!("{emu_cmd:?}").replace('"', "");
    let emu = Proc::start(
        "emulator",
        emu_cmd,
        "emulating the G1's Dex3-1",
        Duration::from_secs(30),
    )?;
    let profile_text = profile(p.domain, side);
    let map = Mapping::dex3(side)?;
    let mut results = Vec::new();
    for peer in p.only {
        let (label, proc_) = match peer.as_str() {
            "handgate" => {
                let path = profile_path(p.out);
                std::fs::write(&path, &profile_text)?;
                ("handgate", crate::gateway(p.handgate, p.domain, p.iface, Some(&path))?)
            }
            "relay" => {
                let mut c = Command::new(std::env::current_exe()?);
                c.args(["shim-relay", "--domain", &p.domain.to_string()]);
                if let Some(i) = p.iface {
                    c.args(["--interface", i]);
                }
                (
                    "raw relay",
                    Proc::start("shim-relay", c, "READY", Duration::from_secs(60))?,
                )
            }
            "python" => {
                let Some((py, script)) = p.python.filter(|(py, _)| py.exists()) else {
                    eprintln!("shim: no venv python: the Python shim is skipped");
                    continue;
                };
                let mut c = Command::new(py);
                c.arg("-u").arg(script).args(["--domain", &p.domain.to_string()]);
                c.args(map.args());
                if let Some(i) = p.iface {
                    c.args(["--interface", i]);
                }
                (
                    "python shim",
                    Proc::start("shim.py", c, "READY", Duration::from_secs(60))?,
                )
            }
            other => anyhow::bail!("unknown peer {other:?} (handgate, relay, python)"),
        };
        for &rate in p.rates {
            let r = client(
                p.domain,
                p.iface,
                side,
                label,
                rate,
                p.samples,
                p.warmup,
                proc_.pid(),
                emu.pid(),
            )?;
            eprintln!("shim: {r:?}");
            results.push(r);
        }
        proc_.stop();
    }
    emu.stop();
    Ok(ShimRun {
        domain: p.domain,
        side: side.to_string(),
        emulator,
        profile: profile_text,
        load_start,
        load_end: loadavg(),
        warmup: p.warmup,
        results,
    })
}

/// docs/benchmarks.md §3b from `shim.json` and `bench/notes/shim.md`, with its rows of the
/// summary (the issue's three targets per rate).
pub fn report_section(
    results: &Path,
    repo: &Path,
    body: &mut String,
    summary: &mut Vec<(String, String, String, &'static str)>,
) {
    use crate::report::{notes, read, verdict};
    use std::fmt::Write as _;
    body.push_str("\n### 3b. Shim through a DDS-client device: a Dex1 client driving a Dex3 service\n\n");
    let Some(run) = read::<ShimRun>(results, "shim.json").filter(|r| !r.results.is_empty()) else {
        body.push_str("Not measured in this run.\n");
        notes(repo, "shim", body);
        return;
    };
    let l = |a: [f64; 3]| format!("{:.2} / {:.2} / {:.2}", a[0], a[1], a[2]);
    let _ = writeln!(
        body,
        "`handgate-bench shim` (`bench/src/shim.rs`): the G1's Dex3 hand service emulated by its own \
         process (`handgate emulate dex3 --service`, {side} hand: state on `rt/dex3/{side}/state` at its \
         500 Hz tick, commands taken at that tick) on DDS domain {d}; against that same process, one after \
         the other, three shims that serve a Dex1 client (unitree_go `MotorCmds_` on `rt/dex1/{side}/cmd`, \
         `MotorStates_` on `rt/dex1/{side}/state`, what dex1_1_service and SAKE's EZGripper driver serve) \
         and are clients of the Dex3 service, mapping the jaw to a Dex3 closure posture and back:\n\n\
         - **raw relay** (`handgate-bench shim-relay`): from its DDS listeners, each command is mapped and \
         published to the service at once, and each service state is published as a Dex1 state carrying \
         the tag of the last command forwarded before it: two raw DDS hops, no loop, no tick, the least any \
         shim can do;\n\
         - **handgate**: the release `handgate run` on the generated profile below (a Dex3 on backend `dds`, \
         a Dex1 front `go` bound to it through closure; defaults otherwise: device loop 500 Hz, forwarding \
         on arrival, `max_send_hz` 2000, front state 500 Hz);\n\
         - **python shim**: `bench/python/shim.py`, the same two callbacks with the official unitree_sdk2py \
         (what integrators write today).\n\n\
         The client publishes each command with a unique tag in `cmds[0].reserve[0]` at a uniformly random \
         point of its period (the jaw sweeping over its range), its grid moved to a new random phase (0–4 ms) \
         every 50 commands, so that a run integrates over the phase of the service's 2 ms tick and the \
         medians of different runs compare (a fixed grid keeps one phase for a whole run), and times the first Dex1 state whose \
         `states[0].reserve[0]` carries it; the first {w} commands of each run are warm-up. CPU from \
         `/proc/<pid>/stat` over each run: the shim's process alone, and the emulator's. Load average \
         1/5/15 min at the start of the benchmark {ls}, at its end {le}.\n",
        side = run.side,
        d = run.domain,
        w = run.warmup,
        ls = l(run.load_start),
        le = l(run.load_end),
    );
    body.push_str(
        "| shim | command rate | sent | echoed | median | p90 | p99 | max | shim CPU (% core) | emulator CPU (% core) | load 1 min, start → end |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &run.results {
        let _ = writeln!(
            body,
            "| {} | {:.1} | {:.1} | {:.2} → {:.2} |",
            r.hop.cells(),
            r.hop.peer_cpu_pct,
            r.emulator_cpu_pct,
            r.load_start[0],
            r.load_end[0]
        );
    }
    body.push_str(
        "\nTargets (same run, same rate): issue #30, handgate / raw relay at the median ≤ 1.2× and handgate's \
         CPU / the raw relay's ≤ 1.5×; issue #17, python shim / handgate at p99 ≥ 5× and handgate's CPU / \
         the python shim's ≤ 1/5.\n\n\
         | command rate | handgate / raw relay, median | handgate / raw relay, p99 | handgate CPU / raw relay CPU | python / handgate, median | python / handgate, p99 | handgate CPU / python CPU |\n\
         |---|---|---|---|---|---|---|\n",
    );
    let mut rates: Vec<f64> = run.results.iter().map(|r| r.hop.rate_hz).collect();
    rates.sort_by(f64::total_cmp);
    rates.dedup();
    let x = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}×"));
    for rate in rates {
        let get = |t: &str| run.results.iter().find(|r| r.hop.target == t && r.hop.rate_hz == rate);
        let (h, raw, py) = (get("handgate"), get("raw relay"), get("python shim"));
        let lat = |r: Option<&ShimResult>| r.and_then(|r| r.hop.latency_us);
        let ratio = |a: Option<Summary>, b: Option<Summary>, f: fn(&Summary) -> f64| Some(f(&a?) / f(&b?));
        let med = |s: &Summary| s.median;
        let p99 = |s: &Summary| s.p99;
        let h_raw = ratio(lat(h), lat(raw), med);
        let py_h = ratio(lat(py), lat(h), p99);
        let cpu = h.zip(py).map(|(h, p)| h.hop.peer_cpu_pct / p.hop.peer_cpu_pct);
        let cpu_raw = h.zip(raw).map(|(h, r)| h.hop.peer_cpu_pct / r.hop.peer_cpu_pct);
        let _ = writeln!(
            body,
            "| {rate:.0} Hz | {} | {} | {} | {} | {} | {} |",
            x(h_raw),
            x(ratio(lat(h), lat(raw), p99)),
            x(cpu_raw),
            x(ratio(lat(py), lat(h), med)),
            x(py_h),
            cpu.map_or("—".into(), |c| format!("{c:.2}")),
        );
        if let Some(v) = h_raw {
            summary.push((
                format!("shim hop at {rate:.0} Hz: handgate / raw relay (two raw DDS hops), median"),
                format!("{v:.2}×"),
                "≤ 1.2×".into(),
                verdict(v <= 1.2),
            ));
        }
        if let Some(v) = cpu_raw {
            summary.push((
                format!("shim hop at {rate:.0} Hz: handgate CPU / raw relay CPU"),
                format!("{v:.2}×"),
                "≤ 1.5×".into(),
                verdict(v <= 1.5),
            ));
        }
        if let Some(v) = py_h {
            summary.push((
                format!("shim hop at {rate:.0} Hz: python shim / handgate, p99"),
                format!("{v:.1}×"),
                "≥ 5× (#17)".into(),
                verdict(v >= 5.0),
            ));
        }
        if let Some(v) = cpu {
            summary.push((
                format!("shim hop at {rate:.0} Hz: handgate CPU / python shim CPU"),
                format!("{v:.2}"),
                "≤ 0.20 (#17)".into(),
                verdict(v <= 0.2),
            ));
        }
    }
    let _ = writeln!(
        body,
        "\nThe emulator: `{}`. handgate's profile (written beside the results as `shim.toml`):\n\n```toml\n{}```",
        run.emulator, run.profile
    );
    notes(repo, "shim", body);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jaw_closure_round_trip() {
        let m = Mapping::dex3(Side::Left).unwrap();
        assert!(m.open.iter().zip(&m.closed).any(|(o, c)| (o - c).abs() > 0.1));
        for jaw in [0.0f32, 1.35, 2.7, 5.4] {
            let cmd = m.command(jaw);
            let mut s = HandState_::with_sizes(DEX3_MOTORS, 0);
            for (st, c) in s.motor_state.iter_mut().zip(&cmd.motor_cmd) {
                st.q = c.q;
            }
            assert!((m.jaw(&s) - jaw).abs() < 1e-4, "{jaw} -> {}", m.jaw(&s));
        }
        assert_eq!(
            RisMode::decode(m.command(1.0).motor_cmd[3].mode),
            RisMode::foc(3, false)
        );
    }
}
