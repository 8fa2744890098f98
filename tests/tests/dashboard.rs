//! The dashboard page (`gateway/assets/`, docs/dashboard.md) in headless Chromium against the
//! real `handgate run`, driven step by step through `tests/browser/dashboard.mjs`
//! (playwright-core, Debian's `/usr/bin/chromium`; `scripts/setup.sh` installs both):
//!
//! - read-only (the default profile): the page served by the binary shows every device of the
//!   fleet `handgate check` resolves (cards and fleet table); no command control is rendered
//!   and the page sends nothing; a closure command through the canonical DDS front moves
//!   `index_0` of `dex3_left` and the chart's data follows to the position the hand reports on
//!   DDS; after SIGINT stops the gateway the page reads `disconnected`, and it reconnects by
//!   itself to a gateway started again on the same port;
//! - `[http] commands = true` with `[http] token_file` (commands need a token), the page opened
//!   as `http://localhost:PORT/` (the read-only test opens `127.0.0.1`): without the token it is
//!   a form asking for it (401, no cookie); the token typed there gives the page its cookie
//!   (HttpOnly, SameSite=Strict, unseen by the page's script) and the URL without the token, and
//!   the page connects and plots; every card has its controls; the slider with "command" on moves
//!   the hand (seen on DDS and on the chart) and the fleet table names the page as its owner;
//!   "safe" puts the device in its safe state (the status topic says so); a device another front commands is refused and the
//!   card shows the reason.
//!
//! - a hand that reports but does not move: its card's badge and its fleet row name the joint.
//!
//! Domains 182-183 and 199 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline (DDS samples, the page's state through `waitForFunction`).
//! Without Chromium the tests are skipped with a message, unless `CI` is set: then they fail.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::atomic::Ordering;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{
    canonical_q, default_profile_edited, faulty_hand_service, hand_client_profile, handgate_check, node, poll,
    repo_root, serial, status_device, stream_closure, Gateway, Latest, Signal,
};
use serde_json::{json, Value};

/// Deadline of every wait: generous, since a loaded 2-core machine (CI, other builds) can stall
/// the gateway, Chromium and the DDS clients for seconds; a passing run never waits it out.
const DEADLINE: Duration = Duration::from_secs(60);
/// The joint the tests watch, and by how much (rad, canonical: closing positive) it must move.
const JOINT: &str = "index_0";
const MARGIN: f64 = 0.5;
/// The chart's last point against the position on DDS once the hand is still (rad; the page's
/// numbers are rounded to 1e-5).
const TOL: f64 = 0.01;
/// The fleet table's owner cells.
const OWNER_DEX3_LEFT: &str = r#"#fleet tr[data-row="dex3_left"] td[data-col="owner"]"#;
const OWNER_DEX1_LEFT: &str = r#"#fleet tr[data-row="dex1_left"] td[data-col="owner"]"#;

// ---------------------------------------------------------------------------------------------
// The browser

/// Chromium's path, or why it is missing. Only a missing Chromium skips the tests (outside
/// CI); a missing node or playwright-core fails them, with the fix.
fn chromium() -> Result<PathBuf, String> {
    let path = std::env::var_os("CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    if path.exists() {
        Ok(path)
    } else {
        Err(format!(
            "{} is missing (Debian package chromium; scripts/setup.sh installs it)",
            path.display()
        ))
    }
}

fn browser_dir() -> PathBuf {
    repo_root().join("tests").join("browser")
}

/// The page driver, or None when the test is skipped (no Chromium, not under CI).
fn browser_or_skip(test: &str) -> Option<Browser> {
    let under_ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
    match chromium() {
        Ok(_) => {}
        Err(why) if under_ci => panic!("{why}: CI runs the dashboard's browser test"),
        Err(why) => {
            eprintln!("SKIPPED {test}: {why}");
            return None;
        }
    }
    let pw = browser_dir()
        .join("node_modules")
        .join("playwright-core")
        .join("package.json");
    assert!(
        pw.exists(),
        "{} is missing: run scripts/setup.sh (npm ci in tests/browser)",
        pw.display()
    );
    Some(Browser::start())
}

/// `node tests/browser/dashboard.mjs`: one JSON request per line in, `OK <json>` or
/// `ERR <message>` per request out.
struct Browser {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    stderr: Arc<Mutex<String>>,
}

impl Browser {
    fn start() -> Browser {
        let mut child = Command::new("node")
            .arg(browser_dir().join("dashboard.mjs"))
            .current_dir(browser_dir())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("node runs (Node.js >= 20; scripts/setup.sh)");
        let stdout = child.stdout.take().expect("piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let stderr = Arc::new(Mutex::new(String::new()));
        let mut pipe = child.stderr.take().expect("piped");
        let buf = stderr.clone();
        std::thread::spawn(move || {
            let mut s = String::new();
            let _ = pipe.read_to_string(&mut s);
            buf.lock().unwrap_or_else(|e| e.into_inner()).push_str(&s);
        });
        let stdin = child.stdin.take();
        let b = Browser {
            child,
            stdin,
            lines,
            stderr,
        };
        let first = b.line(Duration::from_secs(60));
        assert_eq!(
            first.as_deref(),
            Ok("READY"),
            "dashboard.mjs did not start\n{}",
            b.stderr()
        );
        b
    }

    fn stderr(&self) -> String {
        self.stderr.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn line(&self, timeout: Duration) -> Result<String, String> {
        self.lines.recv_timeout(timeout).map_err(|e| match e {
            RecvTimeoutError::Timeout => format!("no answer within {timeout:?}"),
            RecvTimeoutError::Disconnected => "dashboard.mjs exited".to_string(),
        })
    }

    /// Sends a request and returns its answer; `Err` with the driver's message.
    fn try_call(&mut self, req: Value) -> Result<Value, String> {
        let stdin = self.stdin.as_mut().expect("open");
        writeln!(stdin, "{req}")
            .and_then(|_| stdin.flush())
            .map_err(|e| format!("writing to dashboard.mjs: {e}"))?;
        // Each request carries its own deadline (timeout_ms, 60 s by default); this one only
        // catches a driver that hangs.
        let line = self.line(Duration::from_secs(180))?;
        if let Some(ok) = line.strip_prefix("OK ") {
            serde_json::from_str(ok).map_err(|e| format!("{e}: {ok}"))
        } else {
            Err(line)
        }
    }

    /// [`Browser::try_call`], panicking with the gateway's output on failure.
    fn call(&mut self, req: Value, gw: &Gateway) -> Value {
        let r = self.try_call(req.clone());
        r.unwrap_or_else(|e| {
            panic!(
                "{req}: {e}\n--- dashboard.mjs stderr ---\n{}\n{}",
                self.stderr(),
                gw.transcript()
            )
        })
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if let Some(mut stdin) = self.stdin.take() {
            let _ = writeln!(stdin, "{}", json!({"op": "quit"}));
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers

/// A token file (0600, a fresh random token) for `[http] token_file`, and its token.
fn token_file(name: &str) -> (PathBuf, String) {
    use std::os::unix::fs::PermissionsExt;
    let mut raw = [0u8; 24];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut raw))
        .expect("/dev/urandom");
    let token: String = raw.iter().map(|b| format!("{b:02x}")).collect();
    let dir = std::env::temp_dir().join(format!("handgate-dashboard-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join(name);
    std::fs::write(&p, format!("{token}\n")).expect("token file");
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).expect("chmod 600");
    (p, token)
}

/// The device names `handgate check PROFILE` resolves, in its order.
fn fleet_names(profile: &Path) -> Vec<String> {
    let out = handgate_check(profile);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "handgate check failed:\n{text}");
    let names: Vec<String> = text
        .lines()
        .skip_while(|l| !l.starts_with("devices ("))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect();
    assert!(!names.is_empty(), "no devices in handgate check's output:\n{text}");
    names
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|s| s.as_str().unwrap_or_else(|| panic!("not a string: {s}")).to_string())
        .collect()
}

/// `device`'s entry in the page's hello.
fn hello_device<'a>(hello: &'a Value, device: &str) -> &'a Value {
    hello["devices"]
        .as_array()
        .and_then(|a| a.iter().find(|d| d["name"] == device))
        .unwrap_or_else(|| panic!("hello has no device {device}: {hello}"))
}

/// Index of `joint` among `device`'s joints in the page's hello (the order of its charts).
fn joint_index(hello: &Value, device: &str, joint: &str) -> usize {
    let d = hello_device(hello, device);
    d["joints"]
        .as_array()
        .and_then(|j| j.iter().position(|j| j["name"] == joint))
        .unwrap_or_else(|| panic!("{device} has no joint {joint}: {d}"))
}

/// The joint's position on the canonical state once it has not changed by more than 1e-3 rad
/// for 300 ms (the hand is still).
fn settled(state: &mut Latest<hg::HandState_>, joint: &str) -> Option<f64> {
    let mut last: Option<(f32, Instant)> = None;
    poll(DEADLINE, || {
        let q = canonical_q(state.update()?, joint);
        match last {
            Some((p, since)) if (q - p).abs() <= 1e-3 => {
                (since.elapsed() >= Duration::from_millis(300)).then_some(q as f64)
            }
            _ => {
                last = Some((q, Instant::now()));
                None
            }
        }
    })
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

// ---------------------------------------------------------------------------------------------

#[test]
fn the_page_shows_the_default_fleet_follows_a_dds_command_and_reads_disconnected_when_the_gateway_stops() {
    let _serial = serial();
    let Some(mut b) = browser_or_skip("dashboard read-only") else {
        return;
    };
    let domain = 182;
    let names = fleet_names(&repo_root().join("profiles").join("default.toml"));
    let mut gw = Gateway::start(domain, &[]);
    let url = gw.http_url().unwrap_or_else(|e| panic!("{e}"));
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");

    // (a) The page from the binary: every device of the fleet, in a card and a table row.
    let st = b.call(json!({"op": "open", "url": url}), &gw);
    assert_eq!(strings(&st["devices"]), names, "hello's devices: {st}");
    assert_eq!(strings(&st["cards"]), names, "device cards: {st}");
    assert_eq!(strings(&st["rows"]), names, "fleet table rows: {st}");
    assert_eq!(st["conn"], "connected", "{st}");

    // Read-only: no command control, nothing sent.
    assert_eq!(st["commands"], false, "{st}");
    assert_eq!(st["controls"], 0, "command controls rendered on a read-only page: {st}");

    // A pressure map for each device with pads in hello, fed by pads frames: one array per pad,
    // rows x cols values each.
    let hello = b.call(json!({"op": "hello"}), &gw);
    let with_pads: Vec<String> = hello["devices"]
        .as_array()
        .expect("devices")
        .iter()
        .filter(|d| d["pads"].as_array().is_some_and(|p| !p.is_empty()))
        .map(|d| d["name"].as_str().expect("name").to_string())
        .collect();
    assert!(with_pads.contains(&"dex3_left".to_string()), "{hello}");
    assert_eq!(strings(&st["padMaps"]), with_pads, "{st}");
    let st = b.call(json!({"op": "wait_pads", "device": "dex3_left"}), &gw);
    let layout = hello_device(&hello, "dex3_left")["pads"]
        .as_array()
        .expect("dex3_left's pads");
    let values = st["pads"]["dex3_left"].as_array().expect("dex3_left's pads frame");
    assert_eq!(values.len(), layout.len(), "{st}");
    for (p, v) in layout.iter().zip(values) {
        let cells = num(&p["rows"]) * num(&p["cols"]);
        assert_eq!(v.as_array().map(Vec::len), Some(cells as usize), "pad {p}: {v}");
    }

    // (b) A closure command through the canonical DDS front moves index_0; the chart follows.
    let j = joint_index(&hello, "dex3_left", JOINT);
    let n = node(domain);
    let mut state = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let rest = settled(&mut state, JOINT).unwrap_or_else(|| panic!("no still state: {:?}", state.last));
    let before = num(&b.call(json!({"op": "plotted", "device": "dex3_left", "joint": j}), &gw));
    assert!(
        (before - rest).abs() < TOL,
        "at rest the chart shows {before}, DDS {rest}"
    );

    let (stop, streaming) = stream_closure(domain, "dex3_left", 1.0);
    let moved = poll(DEADLINE, || {
        let q = canonical_q(state.update()?, JOINT) as f64;
        (q >= rest + MARGIN).then_some(q)
    });
    let on_chart = b.try_call(json!({"op": "wait_plotted", "device": "dex3_left", "joint": j,
        "lo": rest + MARGIN, "hi": 1e9}));
    stop.store(true, Ordering::Relaxed);
    streaming.join().expect("streaming thread");
    let moved = moved.unwrap_or_else(|| panic!("{JOINT} did not close on DDS: {:?}\n{}", state.last, gw.transcript()));
    let on_chart = on_chart.unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    println!("{JOINT}: rest {rest:.4}, DDS {moved:.4}, chart {on_chart}");

    // Still again (the watchdog holds it): the chart's last point is where DDS says it is.
    let held = settled(&mut state, JOINT).unwrap_or_else(|| panic!("no still state: {:?}", state.last));
    assert!(held >= rest + MARGIN, "{JOINT} at {held}, from {rest}");
    let shown = num(&b.call(
        json!({"op": "wait_plotted", "device": "dex3_left", "joint": j, "lo": held - TOL, "hi": held + TOL}),
        &gw,
    ));
    println!("{JOINT} held at {held:.4} on DDS, {shown} on the chart");

    let st = b.call(json!({"op": "state"}), &gw);
    assert_eq!(st["sent"], 0, "a read-only page sent frames: {st}");
    assert_eq!(
        st["frames"]["refused"], 0,
        "the gateway refused frames of a read-only page: {st}"
    );
    assert_eq!(st["controls"], 0, "{st}");
    assert_eq!(st["pageErrors"], json!([]), "the page reported errors: {st}");
    let fps = num(&st["fps"]);
    println!("page: {fps} drawing frames/s, frames {}", st["frames"]);

    // (c) The gateway stops: the page says so (and keeps trying to reconnect).
    gw.signal(Signal::Int).unwrap_or_else(|e| panic!("{e}"));
    let exit = gw.wait_exit(Duration::from_secs(10));
    assert!(
        exit.is_some_and(|s| s.success()),
        "gateway exit: {exit:?}\n{}",
        gw.transcript()
    );
    let st = b.call(json!({"op": "wait_conn", "text": "disconnected"}), &gw);
    assert_eq!(st["connected"], false, "{st}");
    assert!(num(&st["closes"]) >= 1.0, "{st}");
    let hellos = num(&st["frames"]["hello"]);

    // A gateway on the same address again: the page reconnects by itself (backoff up to 2 s)
    // and reads the new hello.
    let port = url
        .trim_end_matches('/')
        .rsplit(':')
        .next()
        .expect("a port")
        .to_string();
    let gw = Gateway::start(domain, &["--http-port", &port]);
    let st = b.call(json!({"op": "ready"}), &gw);
    assert_eq!(st["conn"], "connected", "{st}");
    assert_eq!(num(&st["frames"]["hello"]), hellos + 1.0, "{st}");
    assert_eq!(strings(&st["cards"]), names, "{st}");
}

#[test]
fn with_commands_enabled_the_slider_moves_the_hand_safe_stops_it_and_a_foreign_owner_is_refused() {
    let _serial = serial();
    let Some(mut b) = browser_or_skip("dashboard commands") else {
        return;
    };
    let domain = 183;
    let (tf, token) = token_file("dashboard-commands.token");
    let profile = default_profile_edited(
        "dashboard-commands",
        &[(
            "\n[status]\n",
            &format!(
                "\n[http]\ncommands = true\ntoken_file = \"{}\"\n\n[status]\n",
                tf.display()
            ),
        )],
    );
    let names = fleet_names(&profile);
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap_or_else(|e| panic!("{e}"));
    // Opened as `localhost` (the read-only test opens 127.0.0.1): the Host and Origin the
    // server checks (docs/dashboard.md, "Security") are that name's.
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    let url = url.replacen("127.0.0.1", "localhost", 1);

    // Without the token: a form asking for it, nothing of the dashboard, no cookie.
    let g = b.call(json!({"op": "goto", "url": url}), &gw);
    assert_eq!(
        (&g["status"], &g["form"], &g["dashboard"]),
        (&json!(401), &json!(1), &json!(false)),
        "{g}"
    );
    assert_eq!(g["cookies"], json!([]), "{g}");
    // The token typed in the form: the page's cookie, the URL without the token, and the page
    // connected (its WebSocket carries the cookie) and plotting.
    let st = b.call(json!({"op": "login", "token": token}), &gw);
    assert_eq!(st["url"], json!(url), "the URL keeps no token: {st}");
    assert_eq!(
        st["cookies"],
        json!([{"name": "handgate_token", "httpOnly": true, "sameSite": "Strict"}]),
        "{st}"
    );
    assert_eq!(st["scriptSeesCookie"], false, "{st}");
    assert_eq!(st["conn"], "connected", "{st}");
    assert_eq!(st["commands"], true, "{st}");
    assert_eq!(strings(&st["cards"]), names, "{st}");
    for name in &names {
        assert_eq!(
            strings(&st["controlsByDevice"][name]),
            ["command", "closure", "safe"],
            "{name}'s controls: {st}"
        );
    }
    assert_eq!(st["sent"], 0, "sent before any control was touched: {st}");

    let hello = b.call(json!({"op": "hello"}), &gw);
    let j = joint_index(&hello, "dex3_left", JOINT);
    let n = node(domain);
    let mut state = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let rest = settled(&mut state, JOINT).unwrap_or_else(|| panic!("no still state: {:?}", state.last));

    // Slider at 1.0, command on: the page streams at 10 Hz and the hand closes.
    b.call(json!({"op": "set_closure", "device": "dex3_left", "value": 1.0}), &gw);
    assert_eq!(
        b.call(json!({"op": "command", "device": "dex3_left", "on": true}), &gw),
        true
    );
    let moved = poll(DEADLINE, || {
        let q = canonical_q(state.update()?, JOINT) as f64;
        (q >= rest + MARGIN).then_some(q)
    })
    .unwrap_or_else(|| {
        panic!(
            "the page's command did not close {JOINT}: {:?}\n{}",
            state.last,
            gw.transcript()
        )
    });
    let on_chart = b.call(
        json!({"op": "wait_plotted", "device": "dex3_left", "joint": j, "lo": rest + MARGIN, "hi": 1e9}),
        &gw,
    );
    println!("page command: {JOINT} from {rest:.4} to {moved:.4} on DDS, {on_chart} on the chart");
    // The fleet table names the page's front as the owner (status frames, 1 Hz).
    let owner = b.call(
        json!({"op": "wait_text", "selector": OWNER_DEX3_LEFT, "contains": "dashboard"}),
        &gw,
    );
    println!("owner: {owner}");
    let st = b.call(json!({"op": "state"}), &gw);
    assert!(num(&st["sent"]) >= 1.0, "{st}");

    // "safe": the device goes to its safe state; the toggle is off and the page stops sending.
    let st = b.call(json!({"op": "safe", "device": "dex3_left"}), &gw);
    let sent_after_safe = num(&st["sent"]);
    let safe = poll(DEADLINE, || {
        let d = status_device(status.update()?, "dex3_left");
        d.safe.then_some(())
    });
    assert!(
        safe.is_some(),
        "dex3_left not safe after the page's safe: {:?}\n{}",
        status.last,
        gw.transcript()
    );
    let st = b.call(json!({"op": "state"}), &gw);
    assert_eq!(
        num(&st["sent"]),
        sent_after_safe,
        "the page kept sending after safe: {st}"
    );

    // A device another front commands: the page is refused, and its card says why.
    let (stop, streaming) = stream_closure(domain, "dex1_left", 0.5);
    let owned = b.try_call(json!({"op": "wait_text", "selector": OWNER_DEX1_LEFT, "contains": "canonical"}));
    let refused = owned.as_ref().ok().map(|_| {
        b.call(json!({"op": "command", "device": "dex1_left", "on": true}), &gw);
        b.try_call(json!({"op": "wait_refused", "device": "dex1_left"}))
    });
    let _ = b.try_call(json!({"op": "command", "device": "dex1_left", "on": false}));
    stop.store(true, Ordering::Relaxed);
    streaming.join().expect("streaming thread");
    owned.unwrap_or_else(|e| panic!("the canonical front never owned dex1_left: {e}\n{}", gw.transcript()));
    let text = refused.unwrap().unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    let text = text.as_str().unwrap_or_default().to_string();
    assert!(
        text.starts_with("refused: ") && text.contains("dex1_left is commanded by"),
        "{text}"
    );
    println!("card: {text}");
    let st = b.call(json!({"op": "state"}), &gw);
    assert_eq!(st["pageErrors"], json!([]), "the page reported errors: {st}");
}

/// A hand that reports but does not move (`handgate emulate dex3 --service --fault
/// stuck=index_0`, a closure streamed on its canonical front): its card's badge names the
/// verdict and the joint, and so does the fleet table (docs/dashboard.md; docs/adapters.md
/// "Motion"). Domain 199.
#[test]
fn a_card_names_the_joint_of_a_hand_that_reports_but_does_not_move() {
    let _serial = serial();
    let Some(mut b) = browser_or_skip("dashboard motion") else {
        return;
    };
    let domain = 199;
    let _emu = faulty_hand_service("dex3", domain, "stuck=index_0");
    let profile = hand_client_profile("dashboard", "dex3");
    let gw = Gateway::start(domain, &["--profile", profile.to_str().unwrap()]);
    let url = gw.http_url().unwrap_or_else(|e| panic!("{e}"));
    b.call(json!({"op": "open", "url": url}), &gw);
    let (stop, t) = stream_closure(domain, "hand", 0.8);
    let badge = b.try_call(json!({
        "op": "wait_text",
        "selector": r#"article.card[data-device="hand"] [data-motion="joint_stuck"]"#,
        "contains": "joint stuck: index_0",
    }));
    let cell = b.try_call(json!({
        "op": "wait_text",
        "selector": r#"#fleet tr[data-row="hand"] td[data-col="motion"]"#,
        "contains": "joint stuck: index_0",
    }));
    stop.store(true, Ordering::Relaxed);
    t.join().expect("the closure stream");
    badge.unwrap_or_else(|e| panic!("the card's badge: {e}\n{}", gw.transcript()));
    cell.unwrap_or_else(|e| panic!("the fleet table: {e}\n{}", gw.transcript()));
}
