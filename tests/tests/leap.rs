//! The LEAP Hand v1 (docs/leap.md) against a client nobody here wrote: dynamixel-sdk 4.1.0
//! (PyPI, pinned in scripts/peers-requirements.txt) in a LEAP_Hand_API-style client
//! (tests/python/leap_client.py: the LEAP init, GroupSyncRead of 126..136 for ids 0-15,
//! GroupSyncWrite of goal positions), and handgate's own device, both against
//! `handgate emulate leap` on a pseudo-terminal. Domain 45 (the gateway test).

use std::path::PathBuf;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{node, poll, repo_root, serial, status_device, Emulation, Gateway, Latest, PyProcess};

const DEADLINE: Duration = Duration::from_secs(60);

fn pty_path(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-leap-test-{}-{tag}", std::process::id()))
}

fn client(args: &[&str]) -> PyProcess {
    PyProcess::spawn(
        "leap_client.py",
        &args.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
    )
    .expect("the LEAP client starts (.venv: scripts/setup.sh)")
}

/// The JSON after `prefix` in the client's output.
fn json_line(c: &PyProcess, prefix: &str) -> serde_json::Value {
    let line = c
        .wait_line(prefix, DEADLINE)
        .unwrap_or_else(|e| panic!("{prefix}: {e}\n{}", c.transcript()));
    serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line}: {e}"))
}

fn drives_the_emulated_hand(read: &str, tag: &str) {
    let _g = serial();
    let link = pty_path(tag);
    let emu = Emulation::start(&["leap", "--pty", link.to_str().unwrap()]);
    assert!(emu.line.contains("4000000 baud"), "{}", emu.line);
    let port = link.to_str().unwrap();
    // 3.9 LEAP rad = 43° closed from flat on every joint (inside every joint's range).
    let c = client(&["--port", port, "--read", read, "--target", "3.9", "--bad-input"]);
    c.wait_line("bad-input survived", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", c.transcript()));
    let ids = c.wait_line("pinged ", DEADLINE).unwrap();
    assert_eq!(ids, "[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]");
    let first = json_line(&c, "read ");
    // Power-up: flat, 180° on every motor.
    for p in first["pos"].as_array().unwrap() {
        assert!((p.as_f64().unwrap() - std::f64::consts::PI).abs() < 0.01, "{first}");
    }
    let reached = json_line(&c, "reached ");
    assert!(reached["max_err"].as_f64().unwrap() <= 0.05, "{reached}");
    c.wait_line("done", DEADLINE).unwrap();
}

#[test]
fn leap_sdk_client_inits_reads_and_moves_the_emulated_hand_with_sync_read() {
    drives_the_emulated_hand("sync", "sync");
}

#[test]
fn leap_sdk_client_inits_reads_and_moves_the_emulated_hand_with_fast_sync_read() {
    drives_the_emulated_hand("fast", "fast");
}

/// handgate's own device over the serial path (the pty opened like the U2D2's port at
/// 4 Mbaud): the shipped leap-lite profile, its port pointed at the emulator, reports the hand
/// fresh.
#[test]
fn leap_lite_profile_drives_the_emulated_hand_on_a_pty() {
    let _g = serial();
    let link = pty_path("profile");
    let _emu = Emulation::start(&["leap", "--pty", link.to_str().unwrap()]);
    let mut text = std::fs::read_to_string(repo_root().join("profiles/leap-lite.toml")).unwrap();
    let from = "port = \"/dev/serial/by-id/usb-FTDI_USB__-__Serial_Converter_FT0000LEAP-if00-port0\"";
    assert!(text.contains(from), "profiles/leap-lite.toml no longer names its port");
    text = text.replace(from, &format!("port = \"{}\"", link.display()));
    let dir = std::env::temp_dir().join(format!("handgate-leap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("leap-lite.toml");
    std::fs::write(&profile, text).unwrap();
    let _gw = Gateway::start(45, &["--profile", profile.to_str().unwrap()]);
    let node = node(45);
    let mut status: Latest<hg::GatewayStatus_> = Latest::new(&node, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let ok = poll(DEADLINE, || {
        let s = status.update()?;
        (status_device(s, "leap").freshness == hg::FRESH).then_some(())
    });
    assert!(ok.is_some(), "the LEAP never reported fresh: {:?}", status.update());
}

/// The virtual Dynamixel bus front (docs/fronts.md, "leap_bus"), domain 46: an emulated LEAP
/// Hand, an emulated Dex3 and an emulated Inspire DFX hand (as in sim-all), each behind a
/// `leap_bus` front on its own pty.
fn bus_profile(dir: &std::path::Path) -> PathBuf {
    let text = format!(
        r#"name = "leap-bus-test"
description = "leap_bus fronts on an emulated LEAP Hand and an emulated Dex3"
[dds]
domain = 46
[[devices]]
name = "leap"
kind = "leap"
side = "right"
backend = "emulator"
[[devices]]
name = "dex3_right"
kind = "dex3"
side = "right"
backend = "emulator"
[[devices]]
name = "inspire_right"
kind = "inspire_dfx"
side = "right"
backend = "emulator"
[[fronts]]
kind = "leap_bus"
device = "leap"
pty = "{leap}"
[[fronts]]
kind = "leap_bus"
device = "dex3_right"
pty = "{dex3}"
[[fronts]]
kind = "leap_bus"
device = "inspire_right"
pty = "{inspire}"
"#,
        leap = dir.join("leap-bus").display(),
        dex3 = dir.join("dex3-bus").display(),
        inspire = dir.join("inspire-bus").display()
    );
    let p = dir.join("leap-bus-test.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn bus_gateway(tag: &str) -> (Gateway, PathBuf) {
    let dir = std::env::temp_dir().join(format!("handgate-leap-bus-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = bus_profile(&dir);
    let gw = Gateway::start(46, &["--profile", profile.to_str().unwrap()]);
    for link in ["leap-bus", "dex3-bus", "inspire-bus"] {
        gw.wait_stdout(
            &format!("serving leap_bus on pty {}", dir.join(link).display()),
            DEADLINE,
        )
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    }
    (gw, dir)
}

/// A LEAP_Hand_API-style client, the LEAP init included, moves the emulated LEAP through the
/// virtual bus while handgate owns the (emulated) hand: 16 goals in, 16 positions back.
#[test]
fn leap_sdk_client_moves_the_emulated_leap_through_the_virtual_bus() {
    let _g = serial();
    let (gw, dir) = bus_gateway("leap");
    let port = dir.join("leap-bus");
    let c = client(&["--port", port.to_str().unwrap(), "--target", "3.9"]);
    let reached = json_line(&c, "reached ");
    assert!(
        reached["max_err"].as_f64().unwrap() <= 0.05,
        "{reached}\n{}",
        gw.transcript()
    );
    c.wait_line("done", DEADLINE).unwrap();
}

/// The same client closes another kind of hand through closure (the LEAP's closed posture is
/// closure 1): the LEAP index MCP it reads back moves from flat toward closed.
fn closes_another_kind(tag: &str, link: &str, bad_input: bool) -> Gateway {
    let (gw, dir) = bus_gateway(tag);
    let port = dir.join(link);
    // handgate's LEAP closed posture (leap/table.rs CLOSED) in LEAP radians.
    let closed = [
        0.0, 1.6, 1.4, 1.5, 0.0, 1.6, 1.4, 1.5, 0.0, 1.6, 1.4, 1.5, 1.4, 0.6, 0.6, 1.2f64,
    ];
    let mut args = vec![
        "--port".to_string(),
        port.display().to_string(),
        "--read".into(),
        "fast".into(),
        // Through closure the LEAP reads the posture at the device's measured closure, which
        // an emulated Dex3 approaches slowly (a manual run: within 0.149 rad after 479 cycles).
        "--tol".into(),
        "0.3".into(),
        "--target".into(),
    ];
    args.extend(closed.iter().map(|q| (std::f64::consts::PI + q).to_string()));
    if bad_input {
        args.push("--bad-input".into());
    }
    let c = PyProcess::spawn("leap_client.py", &args).unwrap();
    if bad_input {
        c.wait_line("bad-input survived", DEADLINE)
            .unwrap_or_else(|e| panic!("{e}\n{}", c.transcript()));
    }
    let first = json_line(&c, "read ");
    let flat = first["pos"].as_array().unwrap()[1].as_f64().unwrap();
    let reached = json_line(&c, "reached ");
    let closed_now = reached["pos"].as_array().unwrap()[1].as_f64().unwrap();
    assert!(
        closed_now - flat > 0.5,
        "index MCP moved from {flat} to {closed_now}: {reached}"
    );
    gw
}

/// A Dex3, after garbage, a bad CRC and half a packet on the pty, each refused, logged and
/// counted.
#[test]
fn leap_sdk_client_closes_a_dex3_through_the_virtual_bus_and_bad_input_is_refused() {
    let _g = serial();
    let gw = closes_another_kind("dex3", "dex3-bus", true);
    for reason in ["garbage", "bad_crc", "partial_frame"] {
        assert!(
            gw.transcript().contains(&format!("reason=\"{reason}\"")),
            "{reason} not logged\n{}",
            gw.transcript()
        );
    }
}

/// An Inspire DFX hand (the issue's "a Dynamixel client moving an Inspire hand").
#[test]
fn leap_sdk_client_closes_an_inspire_hand_through_the_virtual_bus() {
    let _g = serial();
    closes_another_kind("inspire", "inspire-bus", false);
}
