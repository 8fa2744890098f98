//! The gateway's HTTP server through the binary (docs/dashboard.md): `/metrics` read by
//! prometheus-client's own parser, `/healthz` flipping to 503 when a device's service goes
//! away, the loopback default, and the dashboard's commands: refused without the profile's
//! opt-in, and with it taken through the page's front (the table's checks, the watchdog);
//! with commands on, a DNS-rebinding page (another site's name in `Host` and `Origin`) refused
//! before anything is done, while the page works from `localhost`, `127.0.0.1` and the
//! profile's `allowed_hosts`. Domains 176–179 and 187 (docs/development.md).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use handgate_tests::{device_metrics, handgate_bin, http_get as get, http_raw, repo_root, Gateway, PyProcess};
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
/// dashboard's slider does while commanding is on; with `origin`, the `Origin` a browser page
/// of that origin sends.
fn page(url: &str, frame: &str, for_ms: u32, origin: Option<&str>) -> PyProcess {
    let mut args: Vec<String> = [
        "ws",
        url,
        "--send",
        frame,
        "--every-ms",
        "100",
        "--for-ms",
        &for_ms.to_string(),
    ]
    .map(String::from)
    .into();
    if let Some(o) = origin {
        args.extend(["--origin".to_string(), o.to_string()]);
    }
    PyProcess::spawn("http_probe.py", &args).unwrap()
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
    let probe = page(&url, cmd, 600, None);
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
    let (code, body) = http_raw(&url, &upgrade(addr, Some("http://evil.example")));
    assert_eq!(code, 403, "{body}");
}

/// A WebSocket upgrade of `/ws` naming `host`, with `origin` as a browser page sends it.
fn upgrade(host: &str, origin: Option<&str>) -> String {
    let origin = origin.map(|o| format!("Origin: {o}\r\n")).unwrap_or_default();
    format!(
        "GET /ws HTTP/1.1\r\nHost: {host}\r\n{origin}Upgrade: websocket\r\nConnection: Upgrade\r\n\
         Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
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
    let probe = page(&url, cmd, 1500, None);
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

/// `handgate_http_refused_total` of a `/metrics` text: (host, origin).
fn refused(metrics: &str) -> (f64, f64) {
    let get = |reason: &str| {
        let prefix = format!("handgate_http_refused_total{{reason=\"{reason}\"}} ");
        metrics
            .lines()
            .find_map(|l| l.strip_prefix(&prefix))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {prefix}in {metrics}"))
    };
    (get("host"), get("origin"))
}

#[test]
fn with_commands_on_a_rebinding_page_is_refused_before_anything_and_nothing_moves() {
    let domain = 187;
    let profile = temp_profile(
        "rebinding.toml",
        &format!(
            "name = \"http-rebinding\"\n[dds]\ndomain = {domain}\n[http]\ncommands = true\n\
             allowed_hosts = [\"hand-pc.example\"]\n\
             [[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n"
        ),
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap();
    let port = url.trim_end_matches('/').rsplit(':').next().unwrap().to_string();
    let evil = format!("evil.example:{port}");
    let commands =
        |text: &str| device_metrics(text)[&("handgate_device_commands_total".to_string(), "jaw".to_string())];

    // The page of the issue: its own rebound name in Host and in Origin. No upgrade: 421, and
    // the server closed the connection (http_raw read to its end), so no frame can follow.
    let (code, body) = http_raw(&url, &upgrade(&evil, Some(&format!("http://{evil}"))));
    assert_eq!(code, 421, "{body}");
    assert!(
        body.contains("evil.example") && body.contains("[http] allowed_hosts"),
        "the refusal names the Host and the fix: {body}"
    );
    let mut hosts_refused = 1;
    // Every route refuses another name before anything else: no page, no metrics, no fleet.
    let lookalikes = [
        evil.clone(),
        format!("localhost.evil.example:{port}"),
        format!("127.0.0.1.evil.example:{port}"),
    ];
    for path in [
        "/",
        "/metrics",
        "/healthz",
        "/api/hello",
        "/api/status",
        "/assets/app.js",
    ] {
        for host in &lookalikes {
            let (code, body) = http_raw(&url, &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n\r\n"));
            assert_eq!(code, 421, "{path} for {host}: {body}");
            assert!(!body.contains("jaw") && !body.contains("handgate_"), "{body}");
            hosts_refused += 1;
        }
    }
    let (code, _) = http_raw(&url, &format!("POST / HTTP/1.1\r\nHost: {evil}\r\n\r\n"));
    assert_eq!(code, 421, "the Host before the method");
    hosts_refused += 1;
    // Malformed, repeated or (HTTP/1.1) missing Host: 400.
    for req in [
        format!("GET / HTTP/1.1\r\nHost: 127.0.0.1@evil.example:{port}\r\n\r\n"),
        format!("GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nHost: {evil}\r\n\r\n"),
        "GET / HTTP/1.1\r\n\r\n".to_string(),
    ] {
        let (code, body) = http_raw(&url, &req);
        assert_eq!(code, 400, "{req:?}: {body}");
        hosts_refused += 1;
    }
    // A Host of this server, but a page of another site, another local site (port) or none.
    let origins = [format!("http://{evil}"), "http://localhost:3000".into(), "null".into()];
    for origin in &origins {
        let (code, body) = http_raw(&url, &upgrade(&format!("localhost:{port}"), Some(origin)));
        assert_eq!(code, 403, "Origin {origin}: {body}");
    }
    // Nothing reached the device; every refusal counted and the first logged.
    let (_, text) = get(&url, "/metrics");
    assert_eq!(commands(&text), 0.0, "{text}");
    assert_eq!(refused(&text), (hosts_refused as f64, origins.len() as f64));
    let line = gw.wait_stdout("http: refused a request", WAIT).unwrap();
    assert!(line.contains("WARN") && line.contains("evil.example"), "{line}");

    // HTTP/1.0 without Host: no browser sends it, so no page is behind it; served.
    let (code, body) = http_raw(&url, "GET /api/hello HTTP/1.0\r\n\r\n");
    assert_eq!(code, 200, "{body}");
    assert!(body.contains("\"jaw\""), "{body}");

    // The page itself from localhost, 127.0.0.1 and the profile's name (any case, a
    // trailing dot).
    for host in [
        format!("localhost:{port}"),
        format!("127.0.0.1:{port}"),
        format!("hand-pc.example:{port}"),
        format!("LocalHost.:{port}"),
    ] {
        let (code, body) = http_raw(&url, &format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n"));
        assert_eq!(code, 200, "{host}: {body}");
        assert!(body.starts_with("<!doctype html>"), "{host}: {body}");
    }
    // Its WebSocket opened by a page of localhost (a name resolved to loopback here): its
    // commands move the jaw, which is what the refused page's would have done.
    let cmd = r#"{"type":"command","device":"jaw","closure":0.8}"#;
    let local = format!("http://localhost:{port}/");
    let probe = page(&local, cmd, 1000, Some(&format!("http://localhost:{port}")));
    assert_eq!(frames(&probe, "hello", 1)[0]["commands"], true);
    let deadline = Instant::now() + WAIT;
    loop {
        let s = frames(&probe, "samples", 1).remove(0);
        if s["devices"]["jaw"]["cmd"][0].as_f64().is_some_and(|t| t > 0.0) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the localhost page never commanded the jaw: {s}"
        );
    }
    let (_, text) = get(&url, "/metrics");
    assert!(commands(&text) > 0.0, "{text}");
    // ... and by a page of 127.0.0.1.
    let ip_page = page(&url, cmd, 0, Some(&format!("http://127.0.0.1:{port}")));
    assert_eq!(frames(&ip_page, "hello", 1)[0]["commands"], true);
}
