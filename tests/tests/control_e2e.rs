//! One commanding client per front (`control`, docs/fronts.md "One commanding client per
//! front"), end to end through the real `handgate` binary:
//!
//! - two official-SDK clients (`tests/python/stream_client.py`, two processes) streaming
//!   different targets on one Dex3 front: the hand follows the first only, the second's
//!   commands are counted in `foreign_cmd` (status topic and `handgate status --once`) and
//!   it is named in the log once; killed, the first falls silent and, after the hold time,
//!   the second commands the hand;
//! - `control = "shared"`: both clients' commands reach the hand (latest wins);
//! - `handgate send --force` takes the canonical front over from a client streaming on it.
//!
//! The hand's joint is measured on the front's own state (wire frame) or the canonical state.
//! Domains 125-127 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline. Needs the binary (built by the helpers) and `.venv`.

use std::process::{Command, Output, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_hg;
use handgate_tests::{
    canonical_q, default_profile_edited, handgate_bin, interop_interface, node, poll, repo_root, serial, status_device,
    stream_until, Gateway, Latest, PyProcess,
};

const DEADLINE: Duration = Duration::from_secs(20);
/// "At a target", rad.
const TOL: f32 = 0.05;
/// IDL index of index_0 on the Dex3 wire.
const INDEX_0: usize = 5;
/// The default profile's devices' watchdog, and the longer one these tests give them: a
/// front that keeps the last target is held that long by its owner, and 1 s rides out a
/// client (or this test's streaming thread) stalled by a loaded machine without handing
/// the front over early.
const DEFAULT_WATCHDOG: &str = "watchdog = { timeout_ms = 200, safe_action = \"hold\" }";
const WATCHDOG: &str = "watchdog = { timeout_ms = 1000, safe_action = \"hold\" }";
const HOLD_MS: u64 = 1000;

/// The default profile's left Dex3 front (the line that binds it).
const DEX3_LEFT_FRONT: &str = "device = \"dex3_left\"      # rt/dex3/left/{cmd,state}, rt/lf/dex3/left/state";

fn dds_args(domain: u32) -> Vec<String> {
    let mut a = vec!["--domain".to_string(), domain.to_string()];
    if let Some(i) = interop_interface() {
        a.extend(["--interface".to_string(), i]);
    }
    a
}

/// A streaming SDK client on the left Dex3 front, index_0 at `target` (wire frame), once it
/// writes.
fn client(domain: u32, target: f32) -> PyProcess {
    let mut args = dds_args(domain);
    args.extend(["--side".into(), "left".into(), "--target".into(), target.to_string()]);
    let p = PyProcess::spawn("stream_client.py", &args).unwrap_or_else(|e| panic!("{e}"));
    p.wait_line("STREAMING", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    p
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Runs `handgate <args> <dds args>` to completion.
fn handgate(domain: u32, args: &[&str]) -> Output {
    Command::new(handgate_bin())
        .args(args)
        .args(dds_args(domain))
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .output()
        .expect("handgate runs")
}

/// The wire index_0 of the left Dex3 front's state, newest.
fn wire_q(state: &mut Latest<unitree_hg::HandState_>) -> Option<f32> {
    state.update().map(|s| s.motor_state[INDEX_0].q)
}

/// Lines of the gateway's output containing every one of `parts`.
fn log_lines(gw: &Gateway, parts: &[&str]) -> Vec<String> {
    gw.transcript()
        .lines()
        .filter(|l| parts.iter().all(|p| l.contains(p)))
        .map(str::to_string)
        .collect()
}

#[test]
fn a_second_sdk_client_is_refused_while_the_first_streams_and_takes_over_once_it_is_silent() {
    let _serial = serial();
    let domain = 125;
    let profile = default_profile_edited("control-exclusive", &[(DEFAULT_WATCHDOG, WATCHDOG)]);
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let n = node(domain);
    let mut state = Latest::<unitree_hg::HandState_>::new(&n, "rt/dex3/left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });

    // The first client streams index_0 = -1.0 (left index_0 closes negative): the hand gets there.
    let first = client(domain, -1.0);
    poll(DEADLINE, || wire_q(&mut state).filter(|q| (q + 1.0).abs() < TOL)).unwrap_or_else(|| {
        panic!(
            "first client's target not reached: {:?}\n{}",
            state.last,
            gw.transcript()
        )
    });

    // The second streams -0.3 on the same front: refused whole, counted, the hand stays.
    let second = client(domain, -0.3);
    let mut max_dev = 0.0f32;
    let mut samples = 0u64;
    let d = poll(DEADLINE, || {
        state.update_with(|s| {
            max_dev = max_dev.max((s.motor_state[INDEX_0].q + 1.0).abs());
            samples += 1;
        });
        let d = status_device(status.update()?, "dex3_left").clone();
        (d.foreign_cmd >= 100).then_some(d)
    })
    .unwrap_or_else(|| panic!("foreign_cmd did not rise: {:?}\n{}", status.last, gw.transcript()));
    println!(
        "second client refused: {d:?}; index_0 within {max_dev:.4} rad of the first's target over {samples} state samples"
    );
    assert!(samples >= 50, "too few state samples: {samples}");
    assert!(
        max_dev < TOL,
        "the hand moved toward the second client's target: max deviation {max_dev}\n{}",
        gw.transcript()
    );

    // `handgate status --once` shows the count in its foreign column.
    let o = handgate(domain, &["status", "--once"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("foreign"), "{out}");
    let row = out
        .lines()
        .find(|l| l.starts_with("dex3_left "))
        .unwrap_or_else(|| panic!("no dex3_left row:\n{out}"));
    // device kind backend state safe cmdHz stateHz age crc bad wdog recon missed foreign track motion
    let foreign: u64 = row.split_whitespace().nth(13).unwrap().parse().unwrap();
    assert!(foreign >= 100, "{out}");

    // The log names the second client once (its process and pid), with who owns the front.
    let pid = format!("pid {}", second.id());
    let named = log_lines(&gw, &["refused the commands of", &pid]);
    assert_eq!(named.len(), 1, "{named:?}\n{}", gw.transcript());
    assert!(
        named[0].contains(&format!("pid {}", first.id())),
        "the owner is named too: {}",
        named[0]
    );

    // The first client goes away: after the hold time the second commands the hand.
    drop(first);
    poll(DEADLINE, || wire_q(&mut state).filter(|q| (q + 0.3).abs() < TOL))
        .unwrap_or_else(|| panic!("second client did not take over: {:?}\n{}", state.last, gw.transcript()));
    let took = gw
        .wait_stdout("commands this front: ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(took.contains(&pid) && took.contains("was silent for"), "{took}");
    let silent_ms: u64 = took
        .split("was silent for ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{took}"));
    println!("take-over after the first client's silence: {took}");
    // The device's watchdog time: the hold of a front that keeps the last target.
    assert!(silent_ms >= HOLD_MS, "{took}");
    assert_eq!(
        log_lines(&gw, &["refused the commands of", &pid]).len(),
        1,
        "named once\n{}",
        gw.transcript()
    );
}

#[test]
fn shared_control_takes_both_clients_commands() {
    let _serial = serial();
    let domain = 126;
    let profile = default_profile_edited(
        "control-shared",
        &[(DEX3_LEFT_FRONT, &format!("{DEX3_LEFT_FRONT}\ncontrol = \"shared\""))],
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let n = node(domain);
    let mut state = Latest::<unitree_hg::HandState_>::new(&n, "rt/dex3/left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });

    let _first = client(domain, -1.0);
    poll(DEADLINE, || wire_q(&mut state).filter(|q| (q + 1.0).abs() < TOL)).unwrap_or_else(|| {
        panic!(
            "first client's target not reached: {:?}\n{}",
            state.last,
            gw.transcript()
        )
    });
    // With both streaming, the second's commands reach the hand too: it leaves the first's target.
    let _second = client(domain, -0.3);
    let q = poll(DEADLINE, || wire_q(&mut state).filter(|q| (q + 1.0).abs() > 0.1)).unwrap_or_else(|| {
        panic!(
            "the second client's commands did not reach the hand: {:?}\n{}",
            state.last,
            gw.transcript()
        )
    });
    println!("shared: index_0 at {q} with both clients streaming");
    let s = status.next(DEADLINE).expect("status");
    assert_eq!(status_device(&s, "dex3_left").foreign_cmd, 0, "{s:?}");
    assert!(
        log_lines(&gw, &["refused the commands of"]).is_empty(),
        "{}",
        gw.transcript()
    );
}

#[test]
fn send_force_takes_the_front_over_from_a_streaming_client() {
    let _serial = serial();
    let domain = 127;
    let profile = default_profile_edited("control-force", &[(DEFAULT_WATCHDOG, WATCHDOG)]);
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let n = node(domain);
    let mut state = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/dex3_left/cmd", Qos::Reliable { depth: 1 })
        .expect("writer");
    w.wait_matched(1, DEADLINE).expect("the canonical front matched");
    let cmd = |q: f32| hg::HandCmd_ {
        mode: hg::MODE_JOINTS,
        joints: vec![hg::JointCmd_ {
            name: "index_0".into(),
            q,
            kp: 1.5,
            kd: 0.1,
            ..Default::default()
        }],
        ..Default::default()
    };
    let at =
        |s: &Option<hg::HandState_>, q: f32| s.as_ref().is_some_and(|s| (canonical_q(s, "index_0") - q).abs() < TOL);

    // This test's writer streams index_0 = 0.2 (canonical: closing positive) and owns the front.
    assert!(
        stream_until(&mut w, &cmd(0.2), DEADLINE, || {
            state.update();
            at(&state.last, 0.2)
        }),
        "streaming client's target not reached: {:?}\n{}",
        state.last,
        gw.transcript()
    );

    // Runs `handgate send` in a thread while this client keeps streaming.
    let spawn_send = |force: bool| {
        let done = Arc::new(Mutex::new(None));
        let d = done.clone();
        let mut args = vec!["send", "dex3_left", "--joint", "index_0=0.8", "--hold", "1.5"];
        if force {
            args.push("--force");
        }
        let args: Vec<String> = args.into_iter().map(String::from).collect();
        std::thread::spawn(move || {
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            *d.lock().unwrap() = Some(handgate(domain, &a));
        });
        done
    };

    // Without --force: refused, counted, the hand stays at the streaming client's target.
    let plain = spawn_send(false);
    let mut max_dev = 0.0f32;
    assert!(
        stream_until(&mut w, &cmd(0.2), DEADLINE * 2, || {
            state.update_with(|s| max_dev = max_dev.max((canonical_q(s, "index_0") - 0.2).abs()));
            plain.lock().unwrap().is_some()
        }),
        "handgate send did not finish"
    );
    let o = plain.lock().unwrap().take().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(
        max_dev < TOL,
        "a plain send moved the hand: {max_dev}\n{}",
        gw.transcript()
    );
    let refused = poll(DEADLINE, || {
        let s = status.next(Duration::from_millis(50))?;
        let d = status_device(&s, "dex3_left").clone();
        (d.foreign_cmd > 0).then_some(d.foreign_cmd)
    })
    .unwrap_or_else(|| panic!("no foreign_cmd: {:?}\n{}", status.last, gw.transcript()));
    println!("plain send refused: foreign_cmd {refused}");

    // With --force: the hand goes to the sender's target while this client still streams.
    let forced = spawn_send(true);
    assert!(
        stream_until(&mut w, &cmd(0.2), DEADLINE, || {
            state.update();
            at(&state.last, 0.8)
        }),
        "send --force did not take over: {:?}\n{}",
        state.last,
        gw.transcript()
    );
    let line = gw
        .wait_stdout("took this front over from", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}"));
    println!("{line}");
    assert!(line.contains("handgate"), "{line}");
    assert!(
        stream_until(&mut w, &cmd(0.2), DEADLINE, || forced.lock().unwrap().is_some()),
        "handgate send --force did not finish"
    );
    let o = forced.lock().unwrap().take().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
}
