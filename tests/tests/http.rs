//! The gateway's HTTP server through the binary (docs/dashboard.md): `/metrics` read by
//! prometheus-client's own parser, `/healthz` flipping to 503 when a device's service goes
//! away, the loopback default, and the dashboard's commands: refused without the profile's
//! opt-in, and with it taken through the page's front (the table's checks, the watchdog).
//! Domains 176–179 (docs/development.md).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use handgate_tests::{handgate_bin, http_get as get, repo_root, Gateway, PyProcess};
use serde_json::Value;

const WAIT: Duration = Duration::from_secs(20);

/// Polls `GET path` until `ok(code, body)`, at most [`WAIT`].
fn wait_get(url: &str, path: &str, what: &str, ok: impl Fn(u16, &str) -> bool) -> (u16, String) {
    let deadline = Instant::now() + WAIT;
    loop {
        let (c, b) = get(url, path);
        if ok(c, &b) {
            return (c, b);
        }
        assert!(Instant::now() < deadline, "{what}: last {c} {b}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn temp_profile(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handgate-http-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A Dex1 gripper served by `handgate emulate dex1 --service` (its own process): killing
/// that process is the service going away.
fn dex1_over_dds(domain: u32) -> String {
    format!(
        "name = \"http-health\"\n[dds]\ndomain = {domain}\n\
         [[devices]]\nname = \"gripper\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"dds\"\n\
         watchdog = {{ timeout_ms = 200, safe_action = \"hold\" }}\n"
    )
}

#[test]
fn metrics_parse_with_prometheus_client_and_healthz_flips_when_the_service_goes_away() {
    let domain = 176;
    let emu = std::process::Command::new(handgate_bin())
        .args([
            "emulate",
            "dex1",
            "--side",
            "left",
            "--service",
            "--domain",
            &domain.to_string(),
        ])
        .current_dir(repo_root())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("handgate emulate");
    let mut emu = scopeguard(emu);
    let profile = temp_profile("health.toml", &dex1_over_dds(domain));
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap();
    assert!(url.starts_with("http://127.0.0.1:"), "loopback by default: {url}");

    let (_, body) = wait_get(&url, "/healthz", "fresh", |c, _| c == 200);
    assert!(body.starts_with("ok: 1 devices fresh"), "{body}");

    let probe = PyProcess::spawn("http_probe.py", &["metrics".into(), url.clone()]).unwrap();
    let line = probe.wait_line("{", WAIT).unwrap();
    let m: Value = serde_json::from_str(&format!("{{{line}")).unwrap();
    let fam = &m["families"];
    for (name, ty) in [
        ("handgate_device_fresh", "gauge"),
        ("handgate_device_state_samples", "counter"),
        ("handgate_device_watchdog_trips", "counter"),
        ("handgate_device_loop_period_seconds", "histogram"),
    ] {
        assert_eq!(fam[name], ty, "{name}: {fam}");
    }
    let s = &m["samples"];
    let labels = r#"backend="dds",device="gripper",kind="dex1""#;
    assert_eq!(s[format!("handgate_device_fresh{{{labels}}}")], 1.0, "{s}");
    assert!(
        s[format!("handgate_device_state_samples_total{{{labels}}}")]
            .as_f64()
            .unwrap()
            > 0.0
    );
    let count = s[format!("handgate_device_loop_period_seconds_count{{{labels}}}")]
        .as_f64()
        .unwrap();
    let inf = s[format!("handgate_device_loop_period_seconds_bucket{{{labels},le=\"+Inf\"}}")]
        .as_f64()
        .unwrap();
    assert!(count > 10.0 && count == inf, "count {count}, +Inf bucket {inf}");
    assert_eq!(
        s[format!("handgate_device_stale_events_total{{{labels}}}")],
        0.0,
        "fresh since the start: {s}"
    );

    // The service goes away: /healthz says which device and why.
    let _ = emu.0.kill();
    let _ = emu.0.wait();
    let (_, body) = wait_get(&url, "/healthz", "stale after the service stopped", |c, _| c == 503);
    assert!(body.contains("gripper: stale"), "{body}");
    // The stale spell is counted once (fresh -> stale), however long it lasts.
    let (_, text) = get(&url, "/metrics");
    let line = "handgate_device_stale_events_total{device=\"gripper\",kind=\"dex1\",backend=\"dds\"} ";
    let stale = text
        .lines()
        .find_map(|l| l.strip_prefix(line))
        .unwrap_or_else(|| panic!("no {line}in {text}"));
    assert_eq!(stale, "1", "{text}");
    drop(gw);
}

struct Guard(std::process::Child);
impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
fn scopeguard(c: std::process::Child) -> Guard {
    Guard(c)
}

/// A page (the websockets probe) sending `frame` every 100 ms for `for_ms`, as the
/// dashboard's slider does while commanding is on.
fn page(url: &str, frame: &str, for_ms: u32) -> PyProcess {
    let args = [
        "ws",
        url,
        "--send",
        frame,
        "--every-ms",
        "100",
        "--for-ms",
        &for_ms.to_string(),
    ];
    PyProcess::spawn("http_probe.py", &args.map(String::from)).unwrap()
}

/// Device `name`'s row of a status frame.
fn device(status: &Value, name: &str) -> Value {
    status["devices"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["device"] == name)
        .unwrap_or_else(|| panic!("no {name} in {status}"))
        .clone()
}

/// The frames of one type a probe printed (`<type> <json>` lines), waiting for `n` of them.
fn frames(p: &PyProcess, ty: &str, n: usize) -> Vec<Value> {
    (0..n)
        .map(|_| serde_json::from_str(&p.wait_line(&format!("{ty} "), WAIT).unwrap()).unwrap())
        .collect()
}

#[test]
fn without_the_profiles_opt_in_the_dashboard_accepts_no_command() {
    // The default fleet: one at a time with the other files' default-fleet gateways.
    let _serial = handgate_tests::serial();
    let gw = Gateway::start(177, &[]);
    let url = gw.http_url().unwrap();
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    let cmd = r#"{"type":"command","device":"dex1_left","closure":0.9}"#;
    let probe = page(&url, cmd, 600);
    let hello = &frames(&probe, "hello", 1)[0];
    assert_eq!(hello["commands"], false);
    let names: Vec<&str> = hello["devices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["dex3_left", "dex3_right", "dex1_left", "dex1_right"]);
    let refused = &frames(&probe, "refused", 1)[0];
    assert!(
        refused["reason"].as_str().unwrap().contains("[http] commands = true"),
        "{refused}"
    );
    probe.wait_line("sent_done", WAIT).unwrap();
    // Nothing reached the device: no target in force, nobody commands it.
    let sample = frames(&probe, "samples", 1).remove(0);
    assert_eq!(sample["devices"]["dex1_left"]["cmd"], Value::Null, "{sample}");
    // The status task's first numbers come after its first period.
    let (_, status) = wait_get(&url, "/api/status", "status with devices", |_, b| {
        b.contains("dex1_left")
    });
    let status: Value = serde_json::from_str(&status).unwrap();
    let d = device(&status, "dex1_left");
    assert_eq!(d["owner"], Value::Null, "{d}");
    // Another site's page may not even open the socket.
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET /ws HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://evil.example\r\nUpgrade: websocket\r\n\
         Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    .unwrap();
    let mut buf = String::new();
    s.read_to_string(&mut buf).unwrap();
    assert!(buf.starts_with("HTTP/1.1 403"), "{buf}");
}

#[test]
fn with_the_opt_in_page_commands_go_through_the_front_rules_and_its_watchdog() {
    let domain = 178;
    let profile = temp_profile(
        "commands.toml",
        &format!(
            "name = \"http-commands\"\n[dds]\ndomain = {domain}\n[http]\ncommands = true\ncommand_watchdog_ms = 300\n\
             [[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n\
             watchdog = {{ timeout_ms = 200, safe_action = \"hold\" }}\n"
        ),
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap();
    let cmd = r#"{"type":"command","device":"jaw","closure":0.8}"#;
    let probe = page(&url, cmd, 1500);
    assert_eq!(frames(&probe, "hello", 1)[0]["commands"], true);
    // The closure becomes a target (clamped by the table) and the jaw moves towards it.
    let deadline = Instant::now() + WAIT;
    let (target, q) = loop {
        let s = frames(&probe, "samples", 1).remove(0);
        let d = &s["devices"]["jaw"];
        if let (Some(t), Some(q)) = (d["cmd"][0].as_f64(), d["q"][0].as_f64()) {
            if t > 0.0 && q > 0.5 * t {
                break (t, q);
            }
        }
        assert!(Instant::now() < deadline, "the jaw never moved: {s}");
    };
    assert!(q > 0.0 && target > 0.0, "{target} {q}");
    let status = frames(&probe, "status", 1).remove(0);
    let d = device(&status, "jaw");
    assert!(
        d["owner"]
            .as_str()
            .unwrap()
            .starts_with("dashboard: dashboard page 127.0.0.1:"),
        "{d}"
    );
    // The page stops sending: after command_watchdog_ms the device's safe action runs.
    probe.wait_line("sent_done", WAIT).unwrap();
    let deadline = Instant::now() + WAIT;
    loop {
        let s = frames(&probe, "status", 1).remove(0);
        let d = device(&s, "jaw");
        if d["watchdog_trips"] == 1 && d["safe"] == true {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "no watchdog trip after the page fell silent: {d}"
        );
    }
    // A closure outside [0, 1] is refused at the edge, naming why.
    let bad = PyProcess::spawn(
        "http_probe.py",
        &[
            "ws".into(),
            url,
            "--send".into(),
            r#"{"type":"command","device":"jaw","closure":1.5}"#.into(),
        ],
    )
    .unwrap();
    let r = frames(&bad, "refused", 1).remove(0);
    assert!(r["reason"].as_str().unwrap().contains("[0, 1]"), "{r}");
}

#[test]
fn a_non_loopback_bind_is_an_explicit_choice_and_logged() {
    let profile = temp_profile(
        "any.toml",
        "name = \"http-any\"\n[http]\nbind = \"0.0.0.0\"\n[[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n",
    );
    let gw = Gateway::start(179, &["--profile", profile.to_str().unwrap()]);
    let line = gw.wait_stdout("http: listening", WAIT).unwrap();
    assert!(
        line.contains("WARN") && line.contains("non-loopback") && line.contains("url=http://0.0.0.0:"),
        "{line}"
    );
}
