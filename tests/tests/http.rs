//! The gateway's HTTP server through the binary (docs/dashboard.md): `/metrics` read by
//! prometheus-client's own parser, `/healthz` flipping to 503 when a device's service goes
//! away, the loopback default, and the dashboard's commands: refused without the profile's
//! opt-in, and with it taken through the page's front (the table's checks, the watchdog);
//! with commands on, a DNS-rebinding page (another site's name in `Host` and `Origin`) refused
//! before anything is done, while the page works from `localhost`, `127.0.0.1` and the
//! profile's `allowed_hosts`. The token (`[http] token_file`): required off loopback (`check`
//! and `run` refuse a profile without one), then on every route, by header or by the page's
//! cookie; commands only with a token. Domains 176–179, 187 and 106 (docs/development.md).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use handgate_tests::{
    device_metrics, handgate_bin, handgate_check, http_get as get, http_raw, repo_root, Gateway, PyProcess,
};
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

/// A token file (0600, a fresh random token and a newline) and its token.
fn token_file(name: &str) -> (PathBuf, String) {
    use std::io::Read;
    use std::os::unix::fs::PermissionsExt;
    let mut raw = [0u8; 24];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut raw))
        .unwrap();
    let token: String = raw.iter().map(|b| format!("{b:02x}")).collect();
    let p = temp_profile(name, &format!("{token}\n"));
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
    (p, token)
}

/// `GET path` with `Authorization: Bearer token`.
fn get_with(url: &str, path: &str, token: &str) -> (u16, String) {
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    http_raw(
        url,
        &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {token}\r\n\r\n"),
    )
}

/// The page's cookie for `token`, as a browser sends it back.
fn cookie(token: &str) -> String {
    format!("handgate_token={token}")
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
/// of that origin sends; with `token`, the cookie of a page opened with it.
fn page(url: &str, frame: &str, for_ms: u32, origin: Option<&str>, token: Option<&str>) -> PyProcess {
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
    if let Some(t) = token {
        args.extend(["--cookie".to_string(), cookie(t)]);
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
    let probe = page(&url, cmd, 600, None, None);
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
    let (tf, token) = token_file("commands.token");
    let profile = temp_profile(
        "commands.toml",
        &format!(
            "name = \"http-commands\"\n[dds]\ndomain = {domain}\n[http]\ncommands = true\ncommand_watchdog_ms = 300\n\
             token_file = \"{}\"\n\
             [[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n\
             watchdog = {{ timeout_ms = 200, safe_action = \"hold\" }}\n",
            tf.display()
        ),
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap();
    let cmd = r#"{"type":"command","device":"jaw","closure":0.8}"#;
    let probe = page(&url, cmd, 1500, None, Some(&token));
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
            "--cookie".into(),
            cookie(&token),
        ],
    )
    .unwrap();
    let r = frames(&bad, "refused", 1).remove(0);
    assert!(r["reason"].as_str().unwrap().contains("[0, 1]"), "{r}");
}

const JAW: &str = "[[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n";

#[test]
fn a_non_loopback_bind_needs_a_token_and_without_one_commands_stay_off() {
    let domain = 179;
    // Off loopback without a token: `check` and `run` refuse it, naming the key.
    let open = temp_profile(
        "open.toml",
        &format!("name = \"http-open\"\n[http]\nbind = \"0.0.0.0\"\n{JAW}"),
    );
    let out = handgate_check(&open);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!out.status.success(), "check accepted it:\n{text}");
    assert!(
        text.contains("http.token_file") && text.contains("required") && text.contains("0.0.0.0"),
        "{text}"
    );
    let mut gw = Gateway::spawn(domain, &["--profile", open.to_str().unwrap()], None).unwrap();
    let exit = gw.wait_exit(WAIT);
    assert!(
        exit.is_some_and(|s| !s.success()),
        "run served off loopback without a token: {exit:?}\n{}",
        gw.transcript()
    );
    drop(gw);

    // With a token it serves, and says where and that a token is required.
    let (tf, _) = token_file("open.token");
    let with = temp_profile(
        "open-token.toml",
        &format!(
            "name = \"http-open\"\n[http]\nbind = \"0.0.0.0\"\ntoken_file = \"{}\"\n{JAW}",
            tf.display()
        ),
    );
    let gw = Gateway::start(domain, &["--profile", with.to_str().unwrap()]);
    let line = gw.wait_stdout("http: listening", WAIT).unwrap();
    assert!(
        line.contains("WARN")
            && line.contains("non-loopback")
            && line.contains("url=http://0.0.0.0:")
            && line.contains("token_required=true"),
        "{line}"
    );
    drop(gw);

    // Loopback, `commands = true`, no token: check warns, the server accepts no command.
    let lo = temp_profile(
        "lo-commands.toml",
        &format!("name = \"http-lo\"\n[dds]\ndomain = {domain}\n[http]\ncommands = true\n{JAW}"),
    );
    let out = handgate_check(&lo);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("WARNING commands = true needs [http] token_file"),
        "{text}"
    );
    let gw = Gateway::start(domain, &["--profile", lo.to_str().unwrap()]);
    let warn = gw
        .wait_stdout("commands = true but no [http] token_file", WAIT)
        .unwrap();
    assert!(warn.contains("WARN"), "{warn}");
    let url = gw.http_url().unwrap();
    let cmd = r#"{"type":"command","device":"jaw","closure":0.9}"#;
    let probe = page(&url, cmd, 600, None, None);
    assert_eq!(frames(&probe, "hello", 1)[0]["commands"], false);
    let refused = &frames(&probe, "refused", 1)[0];
    assert!(
        refused["reason"].as_str().unwrap().contains("needs [http] token_file"),
        "{refused}"
    );
    probe.wait_line("sent_done", WAIT).unwrap();
    let sample = frames(&probe, "samples", 1).remove(0);
    assert_eq!(sample["devices"]["jaw"]["cmd"], Value::Null, "{sample}");
    let (_, text) = get(&url, "/metrics");
    assert!(text.contains("handgate_dashboard_commands_enabled 0"), "{text}");
    let commands = device_metrics(&text)[&("handgate_device_commands_total".to_string(), "jaw".to_string())];
    assert_eq!(commands, 0.0, "{text}");
}

/// The whole response to `request` (head and body), read until the server closes.
fn raw_response(url: &str, request: &str) -> String {
    use std::io::{Read, Write};
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut buf = String::new();
    s.read_to_string(&mut buf).unwrap();
    buf
}

/// `handgate_http_refused_total{reason="token"}` of a `/metrics` text.
fn refused_token(metrics: &str) -> f64 {
    let prefix = "handgate_http_refused_total{reason=\"token\"} ";
    metrics
        .lines()
        .find_map(|l| l.strip_prefix(prefix))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {prefix}in {metrics}"))
}

#[test]
fn with_a_token_every_route_refuses_requests_without_it_and_the_page_works_with_its_cookie() {
    let domain = 106;
    let (tf, token) = token_file("routes.token");
    let profile = temp_profile(
        "routes.toml",
        &format!(
            "name = \"http-token\"\n[dds]\ndomain = {domain}\n[http]\nbind = \"0.0.0.0\"\ncommands = true\n\
             token_file = \"{}\"\nfleet_domains = \"{domain}\"\n{JAW}",
            tf.display()
        ),
    );
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    // Bound on every address; reached through loopback.
    let url = gw.http_url().unwrap().replacen("0.0.0.0", "127.0.0.1", 1);
    let addr = url.trim_start_matches("http://").trim_end_matches('/').to_string();
    let started = Instant::now();
    let mut refused = 0;

    // Every route without the token: 401, nothing of the fleet, nothing about the token.
    let routes = [
        "/",
        "/index.html",
        "/assets/app.js",
        "/ws",
        "/metrics",
        "/healthz",
        "/api/hello",
        "/api/status",
        "/fleet",
        "/api/fleet",
        "/no-such-page",
    ];
    for path in routes {
        let r = raw_response(&url, &format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
        assert!(r.starts_with("HTTP/1.1 401 "), "{path}: {r}");
        assert!(
            r.contains("\r\nWWW-Authenticate: Bearer realm=\"handgate\"\r\n"),
            "{path}: {r}"
        );
        assert!(
            !r.contains("jaw") && !r.contains("handgate_") && !r.contains(&token),
            "{path}: {r}"
        );
        refused += 1;
    }
    // HEAD, HTTP/1.0 without Host and other methods too.
    for req in [
        format!("HEAD /metrics HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        "GET /api/hello HTTP/1.0\r\n\r\n".to_string(),
        format!("POST / HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    ] {
        let (code, body) = http_raw(&url, &req);
        assert_eq!(code, 401, "{req:?}: {body}");
        refused += 1;
    }
    // A wrong token of the same length, by header, cookie or URL; another scheme.
    let mut wrong = token.clone().into_bytes();
    wrong[token.len() - 1] = if wrong[token.len() - 1] == b'0' { b'1' } else { b'0' };
    let wrong = String::from_utf8(wrong).unwrap();
    assert_eq!(wrong.len(), token.len());
    for extra in [
        format!("Authorization: Bearer {wrong}\r\n"),
        format!("Cookie: {}\r\n", cookie(&wrong)),
        format!("Authorization: Basic {token}\r\n"),
        format!("Cookie: other={token}\r\n"),
    ] {
        let (code, body) = http_raw(&url, &format!("GET /metrics HTTP/1.1\r\nHost: {addr}\r\n{extra}\r\n"));
        assert_eq!(code, 401, "{extra:?}: {body}");
        refused += 1;
    }
    let (code, _) = get(&url, &format!("/?token={wrong}"));
    assert_eq!(code, 401);
    refused += 1;
    // A browser gets a form asking for the token, nothing of the dashboard.
    let (code, body) = http_raw(
        &url,
        &format!("GET / HTTP/1.1\r\nHost: {addr}\r\nAccept: text/html,*/*\r\n\r\n"),
    );
    assert_eq!(code, 401, "{body}");
    assert!(body.contains("name=\"token\"") && !body.contains("<script"), "{body}");
    refused += 1;
    // The WebSocket without the cookie, from the page's own origin: refused before the upgrade.
    let origin = format!("http://{addr}");
    let r = raw_response(&url, &upgrade(&addr, Some(&origin)));
    assert!(r.starts_with("HTTP/1.1 401 "), "{r}");
    refused += 1;
    let bare = page(
        &url,
        r#"{"type":"command","device":"jaw","closure":0.9}"#,
        0,
        Some(&origin),
        None,
    );
    let err = bare.wait_line("hello", WAIT);
    assert!(
        matches!(err, Err(handgate_tests::PyError::Exited { .. })),
        "the probe opened the socket without the cookie: {err:?}"
    );
    let deadline = Instant::now() + WAIT;
    while !bare.transcript().contains("HTTP 401") {
        assert!(Instant::now() < deadline, "{}", bare.transcript());
        std::thread::sleep(Duration::from_millis(20));
    }
    refused += 1;

    // The right token by header (Prometheus' `authorization` / `bearer_token_file`).
    let (code, text) = get_with(&url, "/metrics", &token);
    assert_eq!(code, 200, "{text}");
    assert_eq!(refused_token(&text), refused as f64, "every refusal counted: {text}");
    assert_eq!(refused_hosts(&text), (0.0, 0.0), "{text}");
    let (code, body) = get_with(&url, "/api/hello", &token);
    assert!(code == 200 && body.contains("\"jaw\""), "{code} {body}");
    let (code, body) = get_with(&url, "/", &token);
    assert!(code == 200 && body.starts_with("<!doctype html>"), "{body}");
    let probe = PyProcess::spawn("http_probe.py", &["metrics".into(), url.clone(), token.clone()]).unwrap();
    let line = probe.wait_line("{", WAIT).unwrap();
    let m: Value = serde_json::from_str(&format!("{{{line}")).unwrap();
    assert_eq!(m["families"]["handgate_http_refused"], "counter", "{m}");

    // The page opened with `?token=`: its cookie, and the URL without the token.
    let r = raw_response(&url, &format!("GET /?token={token} HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
    assert!(r.starts_with("HTTP/1.1 303 "), "{r}");
    assert!(r.contains("\r\nLocation: /\r\n"), "{r}");
    let set = format!(
        "\r\nSet-Cookie: {}; Path=/; HttpOnly; SameSite=Strict\r\n",
        cookie(&token)
    );
    assert!(r.contains(&set), "{r}");
    let r = raw_response(
        &url,
        &format!("GET /fleet?x=1&token={token} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    );
    assert!(r.contains("\r\nLocation: /fleet?x=1\r\n"), "{r}");
    for path in ["/", "/assets/app.js", "/fleet"] {
        let (code, body) = http_raw(
            &url,
            &format!(
                "GET {path} HTTP/1.1\r\nHost: {addr}\r\nCookie: theme=dark; {}\r\n\r\n",
                cookie(&token)
            ),
        );
        assert_eq!(code, 200, "{path}: {body}");
    }
    // ... and its WebSocket with the cookie: the page's commands move the jaw.
    let cmd = r#"{"type":"command","device":"jaw","closure":0.8}"#;
    let probe = page(&url, cmd, 1500, Some(&origin), Some(&token));
    assert_eq!(frames(&probe, "hello", 1)[0]["commands"], true);
    let deadline = Instant::now() + WAIT;
    loop {
        let s = frames(&probe, "samples", 1).remove(0);
        let d = &s["devices"]["jaw"];
        if let (Some(t), Some(q)) = (d["cmd"][0].as_f64(), d["q"][0].as_f64()) {
            if t > 0.0 && q > 0.5 * t {
                break;
            }
        }
        assert!(Instant::now() < deadline, "the jaw never moved: {s}");
    }
    // Nothing more refused; logged at most once per 10 s from this address, never the token.
    let (_, text) = get_with(&url, "/metrics", &token);
    assert_eq!(refused_token(&text), refused as f64, "{text}");
    gw.wait_stdout("http: refused a request without the right token", WAIT)
        .unwrap();
    let log = gw.transcript();
    let lines = log.matches("http: refused a request without the right token").count();
    let allowed = 1 + (started.elapsed().as_secs() / 10) as usize;
    assert!(
        (1..=allowed).contains(&lines),
        "{lines} log lines for {refused} refusals in {:?}",
        started.elapsed()
    );
    assert!(!log.contains(&token), "the token was logged:\n{log}");
}

/// `handgate_http_refused_total` of a `/metrics` text: (host, origin).
fn refused_hosts(metrics: &str) -> (f64, f64) {
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
    let (tf, token) = token_file("rebinding.token");
    let profile = temp_profile(
        "rebinding.toml",
        &format!(
            "name = \"http-rebinding\"\n[dds]\ndomain = {domain}\n[http]\ncommands = true\n\
             allowed_hosts = [\"hand-pc.example\"]\ntoken_file = \"{}\"\n\
             [[devices]]\nname = \"jaw\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"emulator\"\n",
            tf.display()
        ),
    );
    // Requests carry the token: the Host and Origin checks hold even for a client that has it.
    let auth = format!("Authorization: Bearer {token}\r\n");
    let with_auth = |req: String| req.replacen("\r\n", &format!("\r\n{auth}"), 1);
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap();
    let port = url.trim_end_matches('/').rsplit(':').next().unwrap().to_string();
    let evil = format!("evil.example:{port}");
    let commands =
        |text: &str| device_metrics(text)[&("handgate_device_commands_total".to_string(), "jaw".to_string())];

    // The page of the issue: its own rebound name in Host and in Origin. No upgrade: 421, and
    // the server closed the connection (http_raw read to its end), so no frame can follow.
    let (code, body) = http_raw(&url, &with_auth(upgrade(&evil, Some(&format!("http://{evil}")))));
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
            let (code, body) = http_raw(&url, &with_auth(format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n\r\n")));
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
        let (code, body) = http_raw(&url, &with_auth(req.clone()));
        assert_eq!(code, 400, "{req:?}: {body}");
        hosts_refused += 1;
    }
    // A Host of this server, but a page of another site, another local site (port) or none.
    let origins = [format!("http://{evil}"), "http://localhost:3000".into(), "null".into()];
    for origin in &origins {
        let (code, body) = http_raw(&url, &with_auth(upgrade(&format!("localhost:{port}"), Some(origin))));
        assert_eq!(code, 403, "Origin {origin}: {body}");
    }
    // Nothing reached the device; every refusal counted and the first logged.
    let (_, text) = get_with(&url, "/metrics", &token);
    assert_eq!(commands(&text), 0.0, "{text}");
    assert_eq!(refused_hosts(&text), (hosts_refused as f64, origins.len() as f64));
    assert_eq!(refused_token(&text), 0.0, "the Host and Origin come first: {text}");
    let line = gw.wait_stdout("http: refused a request", WAIT).unwrap();
    assert!(line.contains("WARN") && line.contains("evil.example"), "{line}");

    // HTTP/1.0 without Host: no browser sends it, so no page is behind it; served.
    let (code, body) = http_raw(&url, &with_auth("GET /api/hello HTTP/1.0\r\n\r\n".into()));
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
        let (code, body) = http_raw(&url, &with_auth(format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n")));
        assert_eq!(code, 200, "{host}: {body}");
        assert!(body.starts_with("<!doctype html>"), "{host}: {body}");
    }
    // Its WebSocket opened by a page of localhost (a name resolved to loopback here): its
    // commands move the jaw, which is what the refused page's would have done.
    let cmd = r#"{"type":"command","device":"jaw","closure":0.8}"#;
    let local = format!("http://localhost:{port}/");
    let probe = page(
        &local,
        cmd,
        1000,
        Some(&format!("http://localhost:{port}")),
        Some(&token),
    );
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
    let (_, text) = get_with(&url, "/metrics", &token);
    assert!(commands(&text) > 0.0, "{text}");
    // ... and by a page of 127.0.0.1.
    let ip_page = page(&url, cmd, 0, Some(&format!("http://127.0.0.1:{port}")), Some(&token));
    assert_eq!(frames(&ip_page, "hello", 1)[0]["commands"], true);
}
