//! The Inspire RH56 driven directly (docs/inspire-rh56.md): pyrh56 0.4.0 (PyPI, not written
//! here) against `handgate emulate inspire-rh56` and against the RH56 front on a pty (two RH56
//! hands on one emulated line, and an emulated Dex3 behind it); handgate's own device driving
//! the standalone emulator; bad input on the emulator's pty. Domains 47 and 69.

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{
    node, poll, python_script, repo_root, serial, status_device, stream_closure, venv_python, Emulation as Emulator,
    Gateway, Latest,
};

const DEADLINE: Duration = Duration::from_secs(30);

/// A path under the temp dir unique to this process and `what`.
fn tmp(what: &str) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-rh56-test-{}-{what}", std::process::id()))
}

/// Runs tests/python/rh56_pyrh56.py with `args` (bounded): its stdout, asserting success.
fn pyrh56(args: &[&str]) -> String {
    let mut child = Command::new(venv_python())
        .arg(python_script("rh56_pyrh56.py"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python starts");
    let done = poll(Duration::from_secs(60), || child.try_wait().ok().flatten());
    if done.is_none() {
        let _ = child.kill();
    }
    let out = child.wait_with_output().expect("python output");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(
        done.is_some() && out.status.success(),
        "pyrh56 {args:?} failed:\n{o}\n{e}"
    );
    assert!(o.contains("DONE"), "{o}\n{e}");
    o
}

/// A shipped profile with `(from, to)` replaced, written to a temp file.
fn shipped_edited(name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(repo_root().join("profiles").join(format!("{name}.toml"))).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "profiles/{name}.toml no longer contains {from:?}");
        text = text.replace(from, to);
    }
    let p = tmp(&format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// Waits until the gateway on `domain` reports every device of `names` fresh.
fn wait_fresh(domain: u32, names: &[&str]) {
    let node = node(domain);
    let mut status: Latest<hg::GatewayStatus_> = Latest::new(&node, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let ok = poll(DEADLINE, || {
        let s = status.update()?;
        names
            .iter()
            .all(|n| status_device(s, n).freshness == hg::FRESH)
            .then_some(())
    });
    assert!(ok.is_some(), "devices {names:?} never fresh: {:?}", status.update());
}

#[test]
fn pyrh56_drives_two_hands_on_handgate_emulate_inspire_rh56() {
    let pty = tmp("emulated-line");
    let emu = Emulator::start(&["inspire-rh56", "--ids", "1,2", "--pty", pty.to_str().unwrap()]);
    assert!(
        emu.line.contains("1, 2") && emu.line.contains(pty.to_str().unwrap()),
        "{}",
        emu.line
    );
    let out = pyrh56(&[pty.to_str().unwrap(), "1,2"]);
    assert!(out.contains("OK 1 ") && out.contains("OK 2 "), "{out}");
}

/// handgate's own device (the rh56-pair profile, backend serial) drives the standalone
/// emulator's two hands on one line; a canonical closure command closes the left hand.
#[test]
fn the_rh56_pair_profile_drives_handgate_emulate_over_its_pty() {
    let _g = serial();
    let pty = tmp("pair-line");
    let port = pty.to_str().unwrap();
    let _emu = Emulator::start(&["inspire-rh56", "--ids", "1,2", "--pty", port]);
    let p = shipped_edited(
        "rh56-pair",
        &[
            ("domain = 1 ", "domain = 47 "),
            (
                "port = \"/dev/ttyUSB0\"         # better",
                &format!("port = \"{port}\"         # better"),
            ),
            (
                "port = \"/dev/ttyUSB0\"         # the same line",
                &format!("port = \"{port}\"         # the same line"),
            ),
        ],
    );
    let _gw = Gateway::start(47, &["--profile", p.to_str().unwrap()]);
    wait_fresh(47, &["rh56_left", "rh56_right"]);
    let n = node(47);
    let mut st: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/rh56_left/state", Qos::BestEffort);
    let (stop, t) = stream_closure(47, "rh56_left", 1.0);
    let closed = poll(DEADLINE, || st.update().filter(|s| s.closure > 0.9).cloned());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = t.join();
    assert!(closed.is_some(), "the left hand never closed: {:?}", st.update());
}

/// pyrh56 on the RH56 front's ptys drives two emulated RH56 hands on one line
/// (rh56-pair-sim), through the gateway; pymodbus drives the left one through a Modbus RTU
/// front on a pty of its own.
#[test]
fn pyrh56_drives_the_pair_through_the_rh56_front() {
    let _g = serial();
    let (l, r, rtu) = (tmp("front-left"), tmp("front-right"), tmp("front-rtu"));
    // The shipped Modbus TCP front gives way to a Modbus RTU front (the TCP one has its test).
    let tcp_front = "[[fronts]]\nkind = \"inspire_rh56\"\ndevice = \"rh56_right\"\nserve = \"modbus_tcp\"";
    let rtu_front = format!(
        "[[fronts]]\nkind = \"inspire_rh56\"\ndevice = \"rh56_left\"\nserve = \"modbus_rtu\"\nid = 1\npty = \"{}\"",
        rtu.display()
    );
    let p = shipped_edited(
        "rh56-pair-sim",
        &[
            ("domain = 1 ", "domain = 47 "),
            (
                "pty = \"/tmp/handgate-rh56-left\"",
                &format!("pty = \"{}\"", l.display()),
            ),
            (
                "pty = \"/tmp/handgate-rh56-right\"",
                &format!("pty = \"{}\"", r.display()),
            ),
            (tcp_front, &rtu_front),
        ],
    );
    let _gw = Gateway::start(47, &["--profile", p.to_str().unwrap()]);
    wait_fresh(47, &["rh56_left", "rh56_right"]);
    assert!(pyrh56(&[l.to_str().unwrap(), "1"]).contains("OK 1 "));
    assert!(pyrh56(&[r.to_str().unwrap(), "2"]).contains("OK 2 "));
    let out = Command::new(venv_python())
        .arg(python_script("rh56_modbus_rtu.py"))
        .args([rtu.to_str().unwrap(), "1"])
        .output()
        .expect("python runs");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        out.status.success() && o.contains("DONE"),
        "pymodbus on the RTU front failed:\n{o}\n{e}"
    );
}

/// pyrh56 on the RH56 front drives a hand of another kind: an emulated Dex3, through closure.
#[test]
fn pyrh56_drives_a_dex3_behind_the_rh56_front() {
    let _g = serial();
    let pty = tmp("front-dex3");
    let p = shipped_edited(
        "rh56-front-dex3-sim",
        &[
            ("domain = 1 ", "domain = 69 "),
            (
                "pty = \"/tmp/handgate-rh56-dex3\"",
                &format!("pty = \"{}\"", pty.display()),
            ),
        ],
    );
    let _gw = Gateway::start(69, &["--profile", p.to_str().unwrap()]);
    wait_fresh(69, &["dex3_right"]);
    let n = node(69);
    let mut st: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/dex3_right/state", Qos::BestEffort);
    let port = pty.to_str().unwrap().to_string();
    let client = std::thread::spawn(move || pyrh56(&[&port, "1", "--closure"]));
    // The Dex3 itself moved: its canonical state closes past 0.5 while pyrh56 makes a fist.
    let mut most: f32 = 0.0;
    while !client.is_finished() {
        st.update_with(|s| most = most.max(s.closure));
        std::thread::sleep(Duration::from_millis(5));
    }
    let out = client.join().expect("the pyrh56 run");
    assert!(out.contains("OK 1 "), "{out}");
    assert!(most > 0.5, "the Dex3 closed only to {most}");
}

/// Garbage, a bad checksum, a request for an absent id and half a frame on the emulator's
/// pty: each skipped and counted, and the next good request answered.
#[test]
fn bad_input_on_the_emulated_line_is_counted_and_the_line_goes_on() {
    use handgate_adapters::inspire_rh56::emulator::{HandSpec, Line, Rh56Hand};
    use handgate_adapters::inspire_rh56::proto::{decode_reply, encode_read, Reply};
    use handgate_adapters::inspire_rh56::pty::PtyLine;
    use handgate_adapters::serial::{SerialPort, Transport};
    use std::sync::atomic::Ordering;

    let link = tmp("bad-input");
    let line = PtyLine::start(&link, Line::new(vec![Rh56Hand::new(HandSpec::new(1))])).unwrap();
    let mut port = SerialPort::open(&link, 115_200).unwrap();
    let mut good = Vec::new();
    encode_read(1, 1546, 12, &mut good).unwrap();
    let mut bad_sum = good.clone();
    bad_sum[8] ^= 0x55;
    let mut absent = Vec::new();
    encode_read(7, 1546, 12, &mut absent).unwrap();
    let mut input = vec![0x00, 0x13, 0x37, 0x90];
    input.extend_from_slice(&bad_sum);
    input.extend_from_slice(&absent);
    input.extend_from_slice(&good[..5]); // half a frame, then a whole one
    input.extend_from_slice(&good);
    port.write_all(&input).unwrap();
    let mut rx = Vec::new();
    let deadline = Instant::now() + DEADLINE;
    let reply = loop {
        let mut buf = [0u8; 64];
        let n = port.read(&mut buf, Duration::from_millis(100)).unwrap();
        rx.extend_from_slice(&buf[..n]);
        if let Ok((r, _)) = decode_reply(&rx) {
            break r;
        }
        assert!(Instant::now() < deadline, "no reply: {rx:02x?}");
    };
    assert!(
        matches!(reply, Reply::Read { id: 1, addr: 1546, data } if data.len() == 12),
        "{reply:?}"
    );
    let c = &line.counters;
    assert_eq!(c.answered.load(Ordering::Relaxed), 1);
    assert_eq!(c.unanswered.load(Ordering::Relaxed), 1, "the absent id");
    assert!(
        c.bad_checksum.load(Ordering::Relaxed) >= 2,
        "the bad sum and the cut frame"
    );
    assert!(c.garbage.load(Ordering::Relaxed) >= 1);
    // Only the one reply came back.
    std::thread::sleep(Duration::from_millis(100));
    let mut buf = [0u8; 64];
    let n = port.read(&mut buf, Duration::from_millis(50)).unwrap();
    assert_eq!(rx.len() + n, 20, "{rx:02x?}");
}

/// Runs tests/python/rh56_dftp.py against `port` on loopback (bounded): its stdout.
fn dftp(port: u16) -> String {
    let out = Command::new(venv_python())
        .arg(python_script("rh56_dftp.py"))
        .args(["127.0.0.1", &port.to_string()])
        .output()
        .expect("python runs");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert!(
        out.status.success() && o.contains("DONE"),
        "inspire-rh56dftp failed:\n{o}\n{e}"
    );
    o
}

/// The refusals of `front` by `reason` in the gateway's /metrics.
fn refused(metrics: &str, front: &str, reason: &str) -> u64 {
    metrics
        .lines()
        .find(|l| {
            l.starts_with("handgate_stream_refused_total")
                && l.contains(&format!("\"{front}\""))
                && l.contains(&format!("reason=\"{reason}\""))
        })
        .and_then(|l| l.rsplit(' ').next()?.parse::<f64>().ok())
        .map_or(0, |v| v as u64)
}

/// inspire-rh56dftp 0.1.0 drives an emulated RH56 through the Modbus TCP front (targets,
/// angles, forces, all 1062 tactile cells in its own batches); then bad input on that front:
/// garbage, half a frame, a client that never sends, 100 clients at once: each refused and
/// counted, and the client after them still served.
#[test]
fn inspire_rh56dftp_drives_a_hand_through_the_modbus_tcp_front_and_bad_input_is_refused() {
    use std::io::{Read, Write};
    use std::net::TcpStream;
    let _g = serial();
    const PORT: u16 = 16_047;
    let p = shipped_edited(
        "rh56-pair-sim",
        &[
            ("domain = 1 ", "domain = 47 "),
            (
                "pty = \"/tmp/handgate-rh56-left\"",
                &format!("pty = \"{}\"", tmp("l").display()),
            ),
            (
                "pty = \"/tmp/handgate-rh56-right\"",
                &format!("pty = \"{}\"", tmp("r").display()),
            ),
            (
                "serve = \"modbus_tcp\"",
                &format!("serve = \"modbus_tcp\"\nlisten = \"127.0.0.1:{PORT}\"\nidle_s = 1.0"),
            ),
        ],
    );
    let gw = Gateway::start(47, &["--profile", p.to_str().unwrap()]);
    wait_fresh(47, &["rh56_left", "rh56_right"]);
    let out = dftp(PORT);
    assert!(out.contains("tactile_cells=1062"), "{out}");

    let front = "inspire_rh56_tcp_rh56_right";
    let at = ("127.0.0.1", PORT);
    // Garbage (not Modbus: protocol id 0x1337), then a good request on the same connection.
    let mut c = TcpStream::connect(at).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    c.write_all(&[0, 1, 0x13, 0x37, 0, 6, 1, 3, 0, 0, 0, 1]).unwrap();
    let read_angles = [0u8, 2, 0, 0, 0, 6, 1, 0x03, 0x06, 0x0A, 0, 6];
    std::thread::sleep(Duration::from_millis(200));
    c.write_all(&read_angles).unwrap();
    let mut reply = [0u8; 21];
    c.read_exact(&mut reply).unwrap();
    assert_eq!(&reply[..9], &[0, 2, 0, 0, 0, 15, 1, 3, 12], "{reply:?}");
    // Half a frame, then silence: the client is closed as idle (idle_s = 1).
    let mut half = TcpStream::connect(at).unwrap();
    half.write_all(&read_angles[..5]).unwrap();
    half.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut b = [0u8; 1];
    let closed = half.read(&mut b);
    assert!(matches!(closed, Ok(0)), "the idle client was not closed: {closed:?}");
    // 100 clients at once: beyond the 16 served, each is closed at once and counted.
    let many: Vec<TcpStream> = (0..100).filter_map(|_| TcpStream::connect(at).ok()).collect();
    assert_eq!(many.len(), 100);
    let url = gw.http_url().unwrap();
    let m = poll(DEADLINE, || {
        let (_, m) = handgate_tests::http_get(&url, "/metrics");
        (refused(&m, front, "too_many_clients") >= 80).then_some(m)
    })
    .expect("the clients beyond 16 refused and counted");
    assert!(refused(&m, front, "garbage") >= 1, "{m}");
    assert!(refused(&m, front, "idle") >= 1, "{m}");
    drop(many);
    // The front still serves the next client, and the device is still fresh.
    let out = dftp(PORT);
    assert!(out.contains("OK "), "{out}");
    wait_fresh(47, &["rh56_left", "rh56_right"]);
}

/// inspire-rh56dftp 0.1.0 against `handgate emulate inspire-rh56 --tcp --tactile` (the DFTP's
/// Ethernet port emulated); then handgate's own device over Modbus TCP (rh56-dftp-tcp) drives
/// the same emulator, its tactile cells coming back as the Inspire FTP front's touch.
#[test]
fn the_dftp_over_modbus_tcp_emulated_driven_by_inspire_rh56dftp_and_by_the_device() {
    let _g = serial();
    const PORT: u16 = 16_048;
    let at = format!("127.0.0.1:{PORT}");
    let emu = Emulator::start(&["inspire-rh56", "--tcp", &at, "--tactile"]);
    assert!(
        emu.line.contains("Modbus TCP") && emu.line.contains(&at),
        "{}",
        emu.line
    );
    let out = dftp(PORT);
    assert!(out.contains("tactile_cells=1062"), "{out}");
    let p = shipped_edited(
        "rh56-dftp-tcp",
        &[
            ("domain = 1 ", "domain = 47 "),
            ("port = \"192.168.11.210:6000\"", &format!("port = \"{at}\"")),
        ],
    );
    let _gw = Gateway::start(47, &["--profile", p.to_str().unwrap()]);
    wait_fresh(47, &["dftp_right"]);
    let n = node(47);
    let mut touch: Latest<handgate_idl::inspire::InspireHandTouch> =
        Latest::new(&n, "rt/inspire_hand/touch/r", Qos::BestEffort);
    let got = poll(DEADLINE, || touch.update().cloned());
    let t = got.expect("the FTP front published touch from the DFTP's cells");
    assert_eq!(t.palm_touch.len(), 112);
}

/// The rh56-pair profile over Modbus RTU against `handgate emulate inspire-rh56 --modbus`.
#[test]
fn the_rh56_pair_over_modbus_rtu_drives_handgate_emulate_modbus() {
    let _g = serial();
    let pty = tmp("rtu-line");
    let port = pty.to_str().unwrap();
    let emu = Emulator::start(&["inspire-rh56", "--ids", "1,2", "--modbus", "--pty", port]);
    assert!(emu.line.contains("Modbus RTU"), "{}", emu.line);
    let p = shipped_edited(
        "rh56-pair",
        &[
            ("domain = 1 ", "domain = 47 "),
            (
                "port = \"/dev/ttyUSB0\"         # better",
                &format!("protocol = \"modbus_rtu\"\nport = \"{port}\"         # better"),
            ),
            (
                "port = \"/dev/ttyUSB0\"         # the same line",
                &format!("protocol = \"modbus_rtu\"\nport = \"{port}\"         # the same line"),
            ),
        ],
    );
    let _gw = Gateway::start(47, &["--profile", p.to_str().unwrap()]);
    wait_fresh(47, &["rh56_left", "rh56_right"]);
    let n = node(47);
    let mut st: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/rh56_right/state", Qos::BestEffort);
    let (stop, t) = stream_closure(47, "rh56_right", 1.0);
    let closed = poll(DEADLINE, || st.update().filter(|s| s.closure > 0.9).cloned());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = t.join();
    assert!(closed.is_some(), "the right hand never closed: {:?}", st.update());
}
