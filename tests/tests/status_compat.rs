//! The status across handgate versions (issue #37, part 5; docs/wire-types.md, "Status: frozen,
//! and its extension"): `rt/handgate/status` is frozen, and everything new goes to the
//! `@appendable` XCDR2 extension on `rt/handgate/status_ext`.
//!
//! The readers of other versions are kept here as they are:
//! - today's status layout, frozen: a Rust copy ([`frozen`], never to be edited) and a Python
//!   one (`tests/python/handgate_status_frozen.py`, CycloneDDS Python 0.10.2);
//! - the extension as a LATER version might declare it (members appended to both structs and a
//!   new sequence: `LaterGatewayStatusExt_` in `tests/python/status_compat_peer.py`).
//!
//! (a) a reader of the frozen layout reads every field of this version's status, in bytes and
//!     from the running gateway, whose fronts' rates in the extension match what the test
//!     measures in the same window;
//! (b) this version reads a later version's extension (bytes, and `handgate fleet` over DDS),
//!     and a later reader reads this version's;
//! (c) this version's `handgate fleet`, `handgate status` and dashboard fleet page read a
//!     gateway that publishes only today's layout.
//!
//! Domains 31 (a), 32 (b), 33 (c) (docs/development.md). Needs `.venv` (scripts/setup.sh).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::handgate as hg;
use handgate_idl::{from_cdr, to_cdr_be, to_cdr_le};
use handgate_tests::{handgate_bin, http_get, interop_interface, poll, repo_root, Gateway, PyProcess};
use serde_json::Value;

const DOMAIN_LIVE: u32 = 31;
const DOMAIN_LATER: u32 = 32;
const DOMAIN_OLD: u32 = 33;
/// Upper bound for any single readiness wait (Python start-up, DDS discovery).
const DEADLINE: Duration = Duration::from_secs(45);

/// Today's status types, frozen: a reader built against the layout of `rt/handgate/status` as
/// it was frozen. NEVER EDIT: a change to `GatewayStatus_` or `DeviceStatus_` in idl/ that
/// this copy cannot read is exactly what these tests exist to catch.
mod frozen {
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct DeviceStatus_ {
        pub device: String,
        pub kind: String,
        pub backend: String,
        pub freshness: u8,
        pub safe: bool,
        pub cmd_rate_hz: f32,
        pub state_rate_hz: f32,
        pub crc_errors: u64,
        pub bad_input: u64,
        pub watchdog_trips: u64,
        pub reconnects: u64,
        pub missed_cycles: u64,
        pub age_ms: f32,
        pub foreign_cmd: u64,
        pub duplicate_cmd: u64,
        pub reordered_cmd: u64,
        pub late_cmd: u64,
        pub owner: String,
        pub not_allowed_cmd: u64,
        pub motion: u8,
        pub motion_joint: String,
        pub tracking_error: f32,
        pub faults: u32,
    }

    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct EndpointStatus_ {
        pub owner: String,
        pub topic: String,
        pub role: String,
        pub matched: u32,
        pub who: Vec<String>,
    }

    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct Diagnostic_ {
        pub owner: String,
        pub topic: String,
        pub kind: String,
        pub detail: String,
        pub fix: String,
    }

    #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
    pub struct GatewayStatus_ {
        pub profile: String,
        pub uptime_ms: u64,
        pub devices: Vec<DeviceStatus_>,
        pub endpoints: Vec<EndpointStatus_>,
        pub diagnostics: Vec<Diagnostic_>,
        pub record_messages: u64,
        pub record_dropped: u64,
        pub domain: u32,
        pub interface: String,
        pub export_domain: u32,
        pub export_interface: String,
        pub namespace: String,
        pub host: String,
    }
}

/// This version's status with every field set, none to its default, the strings of different
/// lengths (so that a shifted field cannot read as the right value by chance).
fn every_field() -> hg::GatewayStatus_ {
    let dev = |i: u64, name: &str| hg::DeviceStatus_ {
        device: name.into(),
        kind: "dex3".into(),
        backend: "emulator".into(),
        freshness: hg::STALE,
        safe: true,
        cmd_rate_hz: 100.5 + i as f32,
        state_rate_hz: 499.25 + i as f32,
        crc_errors: 1 + 100 * i,
        bad_input: 2 + 100 * i,
        watchdog_trips: 3 + 100 * i,
        reconnects: 4 + 100 * i,
        missed_cycles: 5 + 100 * i,
        age_ms: 1.75 + i as f32,
        foreign_cmd: 6 + 100 * i,
        duplicate_cmd: 7 + 100 * i,
        reordered_cmd: 8 + 100 * i,
        late_cmd: 9 + 100 * i,
        owner: format!("front dex3_{name}: process xr (pid 7) on op"),
        not_allowed_cmd: 10 + 100 * i,
        motion: hg::MOTION_JOINT_STUCK,
        motion_joint: "index_0".into(),
        tracking_error: 0.125 + i as f32,
        faults: 0x21 + i as u32,
    };
    hg::GatewayStatus_ {
        profile: "lab-g1-dex3".into(),
        uptime_ms: u64::MAX - 1,
        devices: vec![dev(0, "left_hand"), dev(1, "right")],
        endpoints: vec![hg::EndpointStatus_ {
            owner: "front dex3_left".into(),
            topic: "rt/dex3/left/cmd".into(),
            role: "reader".into(),
            matched: 2,
            who: vec!["process a (pid 1) on h at 10.0.0.1".into(), "b".into()],
        }],
        diagnostics: vec![hg::Diagnostic_ {
            owner: "front dex3_left".into(),
            topic: "rt/dex3/left/state".into(),
            kind: "qos_mismatch".into(),
            detail: "reliable reader, best-effort writer".into(),
            fix: "make the reader best effort".into(),
        }],
        record_messages: 11,
        record_dropped: 12,
        domain: 13,
        interface: "eth0".into(),
        export_domain: 14,
        export_interface: "eth1".into(),
        namespace: "/robot_a".into(),
        host: "pc2".into(),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len() / 2)
        .map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).unwrap())
        .collect()
}

/// Runs the peer in a mode without DDS and returns the rest of its `prefix` line.
fn peer_once(args: &[&str], prefix: &str) -> String {
    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    let py = PyProcess::spawn("status_compat_peer.py", &args).unwrap();
    py.wait_line(prefix, DEADLINE).unwrap_or_else(|e| panic!("{e}"))
}

/// Whether `rust` (serde_json of a Rust value) and `py` (the peer's JSON) hold the same values:
/// floats compared as f32 (serde_json writes an f32 in its shortest form; Python widens it),
/// NaN written `null` by serde_json and `"nan"` by the peer.
fn same(rust: &Value, py: &Value, at: &str) -> Result<(), String> {
    match (rust, py) {
        (Value::Null, Value::String(s)) if s == "nan" => Ok(()),
        (Value::Number(a), Value::Number(b)) => {
            let equal = match (a.as_u64(), b.as_u64()) {
                (Some(x), Some(y)) => x == y,
                _ => a.as_f64().map(|x| x as f32) == b.as_f64().map(|y| y as f32),
            };
            equal.then_some(()).ok_or(format!("{at}: {a} != {b}"))
        }
        (Value::Array(a), Value::Array(b)) => {
            if a.len() != b.len() {
                return Err(format!("{at}: {} elements != {}", a.len(), b.len()));
            }
            a.iter()
                .zip(b)
                .enumerate()
                .try_for_each(|(i, (x, y))| same(x, y, &format!("{at}[{i}]")))
        }
        (Value::Object(a), Value::Object(b)) => {
            let (ka, kb): (Vec<_>, Vec<_>) = (a.keys().collect(), b.keys().collect());
            if ka != kb {
                return Err(format!("{at}: fields {ka:?} != {kb:?}"));
            }
            a.iter().try_for_each(|(k, x)| same(x, &b[k], &format!("{at}.{k}")))
        }
        (a, b) => (a == b).then_some(()).ok_or(format!("{at}: {a} != {b}")),
    }
}

/// (a), in bytes: the frozen Rust copy and the frozen Python declaration both read every field
/// of this version's status, and the bytes are exactly today's layout (re-encoding what the
/// frozen copy read gives the same bytes). Appending a field to `GatewayStatus_` or
/// `DeviceStatus_` fails this test.
#[test]
fn the_frozen_layout_reads_every_field_of_this_versions_status() {
    let now = every_field();
    let want = serde_json::to_value(&now).unwrap();
    for bytes in [to_cdr_le(&now).unwrap(), to_cdr_be(&now).unwrap()] {
        let old: frozen::GatewayStatus_ = from_cdr(&bytes).unwrap();
        same(&want, &serde_json::to_value(&old).unwrap(), "rust frozen").unwrap();
        let again = if bytes[1] == 1 {
            to_cdr_le(&old).unwrap()
        } else {
            to_cdr_be(&old).unwrap()
        };
        assert_eq!(hex(&again), hex(&bytes), "the status is no longer today's layout");
    }
    // CycloneDDS Python's reader of the frozen declaration, from the same bytes.
    let py = peer_once(&["decode-status", "--hex", &hex(&to_cdr_le(&now).unwrap())], "JSON ");
    same(&want, &serde_json::from_str(&py).unwrap(), "python frozen").unwrap();
}

/// The extension's bytes: this version's encoding is CycloneDDS Python's of the same
/// `@appendable` declaration, byte for byte; a reader of a LATER layout reads it (its own
/// members at their defaults); this version reads a later sample (the members it knows).
#[test]
fn the_extension_reads_across_layouts_in_bytes() {
    let ext = hg::GatewayStatusExt_ {
        version: hg::STATUS_EXT_VERSION,
        fronts: vec![
            hg::FrontStatus_ {
                name: "dex3_left".into(),
                kind: "dex3".into(),
                cmd_rate_hz: 99.5,
                state_rate_hz: 500.0,
            },
            hg::FrontStatus_ {
                name: "joint_state".into(),
                kind: "joint_state".into(),
                cmd_rate_hz: 0.0,
                state_rate_hz: 100.0,
            },
        ],
        refused_participants: 3,
    };
    let json = serde_json::to_string(&ext).unwrap();
    let py = peer_once(&["encode", "--layout", "today", "--json", &json], "HEX ");
    assert_eq!(
        hex(&ext.to_xcdr2()),
        py,
        "handgate's XCDR2 differs from CycloneDDS Python's"
    );
    assert_eq!(hg::GatewayStatusExt_::from_xcdr2(&unhex(&py)).unwrap(), ext);

    // A later reader of this version's bytes.
    let later = peer_once(
        &["decode", "--layout", "later", "--hex", &hex(&ext.to_xcdr2())],
        "JSON ",
    );
    let later: Value = serde_json::from_str(&later).unwrap();
    assert_eq!(later["version"], hg::STATUS_EXT_VERSION);
    assert_eq!(later["fronts"][1]["name"], "joint_state");
    assert_eq!(later["fronts"][0]["cmd_rate_hz"], 99.5);
    assert_eq!(later["fronts"][0]["dropped_cmd"], 0, "{later}");
    assert_eq!(later["notes"], Value::Array(vec![]), "{later}");

    // This version reading a later sample.
    let (sample, known) = later_sample();
    let bytes = unhex(&peer_once(&["encode", "--layout", "later", "--json", &sample], "HEX "));
    assert!(
        bytes.len() > known.to_xcdr2().len() + 40,
        "the later sample carries more"
    );
    assert_eq!(hg::GatewayStatusExt_::from_xcdr2(&bytes).unwrap(), known);
    // And the plain-CDR reader of before cannot: what an XCDR1 final extension would do.
    assert!(from_cdr::<hg::GatewayStatusExt_>(&bytes).is_err());
}

/// A later version's extension sample (JSON for the peer's `later` layout) and what this
/// version must read of it.
fn later_sample() -> (String, hg::GatewayStatusExt_) {
    let json = serde_json::json!({
        "version": 3,
        "fronts": [
            {"name": "dex3_left", "kind": "dex3", "cmd_rate_hz": 48.5, "state_rate_hz": 500.0,
             "dropped_cmd": 12345678901u64, "owner": "front dex3_left: process xr", "latency_ms": [0.5, 0.75]},
            {"name": "canonical_dex3_left", "kind": "canonical", "cmd_rate_hz": 20.0, "state_rate_hz": 100.0,
             "dropped_cmd": 1, "owner": "", "latency_ms": []},
        ],
        "refused_participants": 7,
        "load": 0.25,
        "notes": ["a note of a later version", "another"],
    });
    let known = hg::GatewayStatusExt_ {
        version: 3,
        refused_participants: 7,
        fronts: vec![
            hg::FrontStatus_ {
                name: "dex3_left".into(),
                kind: "dex3".into(),
                cmd_rate_hz: 48.5,
                state_rate_hz: 500.0,
            },
            hg::FrontStatus_ {
                name: "canonical_dex3_left".into(),
                kind: "canonical".into(),
                cmd_rate_hz: 20.0,
                state_rate_hz: 100.0,
            },
        ],
    };
    (json.to_string(), known)
}

/// An old gateway's status (today's layout), as the peer publishes it (JSON).
fn old_status(ns: &str, owner: &str) -> String {
    serde_json::json!({
        "profile": "lab-g1-dex3", "uptime_ms": 61000,
        "devices": [
            {"device": "left_hand", "kind": "dex3", "backend": "dds", "freshness": 0, "safe": false,
             "cmd_rate_hz": 100.0, "state_rate_hz": 500.0, "crc_errors": 0, "bad_input": 0,
             "watchdog_trips": 0, "reconnects": 0, "missed_cycles": 0, "age_ms": 1.0,
             "foreign_cmd": 0, "duplicate_cmd": 0, "reordered_cmd": 0, "late_cmd": 0,
             "owner": owner, "not_allowed_cmd": 0, "motion": 0, "motion_joint": "",
             "tracking_error": 0.01, "faults": 0},
            {"device": "right_hand", "kind": "dex3", "backend": "dds", "freshness": 1, "safe": true,
             "cmd_rate_hz": 0.0, "state_rate_hz": 0.0, "crc_errors": 0, "bad_input": 0,
             "watchdog_trips": 1, "reconnects": 0, "missed_cycles": 0, "age_ms": 900.0,
             "foreign_cmd": 0, "duplicate_cmd": 0, "reordered_cmd": 0, "late_cmd": 0,
             "owner": "", "not_allowed_cmd": 0, "motion": 0, "motion_joint": "",
             "tracking_error": 0.0, "faults": 32},
        ],
        "endpoints": [], "diagnostics": [], "record_messages": 0, "record_dropped": 0,
        "domain": 0, "interface": "eth0", "export_domain": 0, "export_interface": "eth0",
        "namespace": ns, "host": "old-robot-pc",
    })
    .to_string()
}

fn peer_args(mode: &str, domain: u32, topic: &str, extra: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = [
        mode,
        "--domain",
        &domain.to_string(),
        "--topic",
        topic,
        "--timeout",
        "120",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    a.extend(extra.iter().map(|s| s.to_string()));
    a
}

/// `handgate <args>` of this build: its stdout (it must succeed).
fn handgate(args: &[&str]) -> String {
    let out = std::process::Command::new(handgate_bin())
        .args(args)
        .current_dir(repo_root())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "handgate {args:?}: {text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// (a), live: the frozen Python reader reads the running gateway's status, every field equal
/// to what this version's reader takes of the same sample; and the extension's per-front rates
/// are what the test measures in the same window: the commands it sends to a front, the state
/// samples it receives from that front.
#[test]
fn a_frozen_reader_reads_the_running_gateway_and_the_fronts_rates_are_measured() {
    let gw = Gateway::start(DOMAIN_LIVE, &[]);
    let py = PyProcess::spawn(
        "status_compat_peer.py",
        &peer_args("read-status", DOMAIN_LIVE, "rt/handgate/status", &[]),
    )
    .unwrap();
    // A later version's reader of the extension (CycloneDDS Python, more members than this
    // version writes), on the running gateway.
    let later = PyProcess::spawn(
        "status_compat_peer.py",
        &peer_args(
            "read-ext",
            DOMAIN_LIVE,
            "rt/handgate/status_ext",
            &["--layout", "later"],
        ),
    )
    .unwrap();
    py.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    later.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    let node = Node::new(DOMAIN_LIVE, interop_interface().as_deref()).unwrap();
    let status = node
        .reader::<hg::GatewayStatus_>("rt/handgate/status", Qos::Reliable { depth: 4 })
        .unwrap();
    let ext = node
        .reader::<hg::GatewayStatusExt_>("rt/handgate/status_ext", Qos::Reliable { depth: 4 })
        .unwrap();
    let state = node
        .reader::<hg::HandState_>("rt/handgate/dex3_left/state", Qos::BestEffortDepth { depth: 64 })
        .unwrap();
    let mut cmd = node
        .writer::<hg::HandCmd_>("rt/handgate/dex3_left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    cmd.wait_matched(1, DEADLINE).unwrap();
    state.wait_matched(1, DEADLINE).unwrap();

    // Every sample this version's reader takes, by uptime, to find the one Python read.
    let mut ours: BTreeMap<u64, hg::GatewayStatus_> = BTreeMap::new();
    let mut py_seen: Vec<Value> = Vec::new();
    let mut compared = 0;
    // Commands at about 50 Hz for 4.5 s; what the test sends and receives, counted.
    let start = Instant::now();
    let period = Duration::from_millis(20);
    let (mut sent, mut received) = (0u64, 0u64);
    let mut exts: Vec<(Instant, hg::GatewayStatusExt_)> = Vec::new();
    let mut seq = 0;
    let url = gw.http_url().unwrap();
    let mut metrics: Option<String> = None;
    while start.elapsed() < Duration::from_millis(4500) {
        // `/metrics` once while the stream runs (its status window inside the stream).
        if metrics.is_none() && start.elapsed() > Duration::from_millis(3200) {
            metrics = Some(http_get(&url, "/metrics").1);
        }
        seq += 1;
        cmd.write(hg::HandCmd_ {
            seq,
            mode: hg::MODE_CLOSURE,
            closure: (seq % 50) as f32 / 50.0,
            ..Default::default()
        })
        .unwrap();
        sent += 1;
        received += state.take().len() as u64;
        for s in status.take() {
            ours.insert(s.uptime_ms, s);
        }
        exts.extend(ext.take().into_iter().map(|x| (Instant::now(), x)));
        // Paced on a grid from the start (the stream, not a wait for readiness).
        let next = start + period * seq as u32;
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    let elapsed = start.elapsed().as_secs_f64();
    let (sent_hz, received_hz) = (sent as f64 / elapsed, received as f64 / elapsed);

    // The frozen reader's samples, each compared with this version's of the same uptime.
    let deadline = Instant::now() + DEADLINE;
    while compared < 2 && Instant::now() < deadline {
        let line = py.wait_line("STATUS ", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
        py_seen.push(serde_json::from_str(&line).unwrap());
        for s in status.take() {
            ours.insert(s.uptime_ms, s);
        }
        for p in &py_seen {
            if let Some(s) = p["uptime_ms"].as_u64().and_then(|u| ours.get(&u)) {
                same(&serde_json::to_value(s).unwrap(), p, "live status").unwrap();
                assert_eq!(s.devices.len(), 4, "the default profile's four devices");
                compared += 1;
            }
        }
        py_seen.retain(|p| !p["uptime_ms"].as_u64().is_some_and(|u| ours.contains_key(&u)));
    }
    assert!(compared >= 2, "no sample read by both readers: {}", py.transcript());

    // Rates in the extension, from the samples published while the stream ran (the first
    // second of it excluded: its window began before the stream).
    let mid: Vec<&hg::FrontStatus_> = exts
        .iter()
        .filter(|(at, _)| at.duration_since(start) > Duration::from_millis(2000))
        .filter_map(|(_, x)| x.fronts.iter().find(|f| f.name == "canonical_dex3_left"))
        .collect();
    assert!(!mid.is_empty(), "no extension sample during the stream: {exts:?}");
    println!(
        "sent {sent_hz:.1} Hz, received {received_hz:.1} Hz; the extension said (cmd, state): {:?}",
        mid.iter().map(|f| (f.cmd_rate_hz, f.state_rate_hz)).collect::<Vec<_>>()
    );
    for f in &mid {
        assert_eq!(f.kind, "canonical");
        assert!(
            (f64::from(f.cmd_rate_hz) - sent_hz).abs() < 0.15 * sent_hz,
            "client command rate {} Hz, the test sent {sent_hz:.1} Hz",
            f.cmd_rate_hz
        );
        assert!(
            (f64::from(f.state_rate_hz) - received_hz).abs() < 0.15 * received_hz,
            "state rate {} Hz, the test received {received_hz:.1} Hz",
            f.state_rate_hz
        );
    }
    // `/metrics`: the same two rates per front, as gauges.
    let metrics = metrics.unwrap();
    let gauge = |name: &str| -> f64 {
        let key = format!("{name}{{front=\"canonical_dex3_left\",kind=\"canonical\"}} ");
        metrics
            .lines()
            .find_map(|l| l.strip_prefix(&key))
            .unwrap_or_else(|| panic!("no {key}in /metrics"))
            .parse()
            .unwrap()
    };
    let (cmd_g, state_g) = (
        gauge("handgate_front_cmd_rate_hz"),
        gauge("handgate_front_state_rate_hz"),
    );
    println!("/metrics: cmd {cmd_g:.1} Hz, state {state_g:.1} Hz");
    assert!((cmd_g - sent_hz).abs() < 0.15 * sent_hz, "{cmd_g} vs {sent_hz}");
    assert!(
        (state_g - received_hz).abs() < 0.15 * received_hz,
        "{state_g} vs {received_hz}"
    );

    // A front nobody commands: no client command rate, its state published all the same.
    let last = &exts.last().unwrap().1;
    let other = last.fronts.iter().find(|f| f.name == "dex3_left").unwrap();
    assert_eq!(other.cmd_rate_hz, 0.0, "{last:?}");
    assert!(other.state_rate_hz > 0.0, "{last:?}");
    assert_eq!(last.version, hg::STATUS_EXT_VERSION);

    // The later reader read this version's extension: every front, its own members at their
    // defaults.
    let line = later.wait_line("EXT ", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    let seen: Value = serde_json::from_str(&line).unwrap();
    assert_eq!(seen["version"], hg::STATUS_EXT_VERSION, "{seen}");
    let names: Vec<&str> = seen["fronts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    let ours: Vec<&str> = last.fronts.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ours, "{seen}");
    assert!(
        seen["fronts"]
            .as_array()
            .unwrap()
            .iter()
            .all(|f| f["dropped_cmd"] == 0 && f["owner"] == ""),
        "{seen}"
    );

    // `handgate status` shows both: the fronts' client command rates beside their state rates.
    let text = handgate(&["status", "--domain", &DOMAIN_LIVE.to_string(), "--once"]);
    assert!(text.contains("dev cmd Hz"), "{text}");
    assert!(
        text.contains("client cmd Hz") && text.contains("state pub Hz"),
        "{text}"
    );
    assert!(text.contains("\n  canonical_dex3_left  canonical"), "{text}");
    drop(gw);
}

/// (b), over DDS: a gateway of a later version (its status frozen, its extension of the later
/// layout, published by CycloneDDS Python) is read by this version's `handgate fleet`: every
/// front, with the rates of the members this version knows.
#[test]
fn this_versions_fleet_reads_a_later_gateways_extension() {
    let topic = "rt/robot_b/handgate/status";
    let (sample, known) = later_sample();
    let st = PyProcess::spawn(
        "status_compat_peer.py",
        &peer_args(
            "write-status",
            DOMAIN_LATER,
            topic,
            &["--json", &old_status("/robot_b", "front dex3_left: process xr")],
        ),
    )
    .unwrap();
    let ext = PyProcess::spawn(
        "status_compat_peer.py",
        &peer_args(
            "write-ext",
            DOMAIN_LATER,
            &hg::status_ext_topic(topic),
            &["--layout", "later", "--json", &sample],
        ),
    )
    .unwrap();
    st.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));
    ext.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));

    // This version's own reader of the extension, matched by the later writer.
    let node = Node::new(DOMAIN_LATER, interop_interface().as_deref()).unwrap();
    let r = node
        .reader::<hg::GatewayStatusExt_>(&hg::status_ext_topic(topic), Qos::Reliable { depth: 1 })
        .unwrap();
    let got = r
        .wait_take(DEADLINE)
        .unwrap_or_else(|e| panic!("{e}: {}", ext.transcript()));
    assert_eq!(got.last().unwrap(), &known);

    let text = handgate(&["fleet", "--domains", &DOMAIN_LATER.to_string(), "--seconds", "4"]);
    assert!(text.starts_with("1 gateway(s)\n"), "{text}");
    assert!(
        text.contains("  left_hand        dex3       fresh    -       front dex3_left: process xr"),
        "{text}"
    );
    assert!(
        text.contains(
            "  front dex3_left           dex3       client commands    48.5 Hz  state published   500.0 Hz\n"
        ),
        "{text}"
    );
    assert!(
        text.contains(
            "  front canonical_dex3_left canonical  client commands    20.0 Hz  state published   100.0 Hz\n"
        ),
        "{text}"
    );
}

/// (c): a gateway of today's layout (the frozen status, no extension; published by CycloneDDS
/// Python from the frozen declaration) is read by this version's `handgate fleet`, `handgate
/// status` and dashboard fleet page, beside a gateway of this version.
#[test]
fn this_version_reads_a_gateway_of_todays_layout() {
    let old_topic = "rt/old_robot/handgate/status";
    let owner = "front dex3_left: process xr_teleoperate (pid 4242) on op at 10.0.0.9";
    let old = PyProcess::spawn(
        "status_compat_peer.py",
        &peer_args(
            "write-status",
            DOMAIN_OLD,
            old_topic,
            &["--json", &old_status("/old_robot", owner)],
        ),
    )
    .unwrap();
    old.wait_line("READY", DEADLINE).unwrap_or_else(|e| panic!("{e}"));

    // This version's gateway on the same domain, with the fleet page on it.
    let shipped = std::fs::read_to_string(repo_root().join("profiles/default.toml")).unwrap();
    let profile = std::env::temp_dir().join(format!("handgate-status-compat-{}.toml", std::process::id()));
    std::fs::write(
        &profile,
        format!("{shipped}\n[http]\nfleet_domains = \"{DOMAIN_OLD}\"\n"),
    )
    .unwrap();
    let gw = Gateway::start(DOMAIN_OLD, &["--profile", profile.to_str().unwrap()]);

    let d = DOMAIN_OLD.to_string();
    let text = handgate(&["fleet", "--domains", &d, "--seconds", "4"]);
    assert!(text.starts_with("2 gateway(s)\n"), "{text}");
    let old_block = text
        .split("\n\n")
        .find(|b| b.contains(&format!("domain {d}  /old_robot  host old-robot-pc")))
        .unwrap_or_else(|| panic!("the old gateway is not listed: {text}"));
    assert!(old_block.contains("devices 1/2 fresh, 1 safe"), "{old_block}");
    assert!(
        old_block.contains(&format!("  left_hand        dex3       fresh    -       {owner}")),
        "{old_block}"
    );
    assert!(
        old_block.contains("  right_hand       dex3       STALE    SAFE    no command yet"),
        "{old_block}"
    );
    assert!(
        old_block.contains("(no status extension: a handgate older than fronts' rates, or none yet)"),
        "{old_block}"
    );
    let new_block = text
        .split("\n\n")
        .find(|b| b.contains(&format!("domain {d}  /  host")))
        .unwrap_or_else(|| panic!("this version's gateway is not listed: {text}"));
    assert!(
        new_block.contains("  front canonical_dex3_left  canonical    client commands "),
        "{new_block}"
    );

    // `handgate status` on the old gateway: its devices, and no fronts' table.
    let status = handgate(&["status", "--domain", &d, "--namespace", "/old_robot", "--once"]);
    assert!(status.contains("profile lab-g1-dex3  uptime 61.0 s"), "{status}");
    assert!(
        status.contains("\nleft_hand        dex3       dds       fresh"),
        "{status}"
    );
    assert!(status.contains("fronts: no status extension"), "{status}");

    // The dashboard's fleet page lists both, each as `handgate fleet` does.
    let url = gw.http_url().unwrap();
    let page = poll(DEADLINE, || {
        let (code, body) = http_get(&url, "/fleet");
        (code == 200 && body.contains("/old_robot") && body.contains("front canonical_dex3_left ")).then_some(body)
    })
    .unwrap_or_else(|| panic!("fleet page: {}", http_get(&url, "/fleet").1));
    assert!(
        page.contains("(no status extension: a handgate older than fronts' rates"),
        "{page}"
    );
    let _ = std::fs::remove_file(&profile);
}
