//! The Robotiq kind and front with a peer nobody here wrote, pyRobotiqGripper 3.3.14 (PyPI,
//! unmodified: tests/python/robotiq_pyrobotiq.py calls its public API), through the real
//! `handgate` binary:
//!
//! - RTU over TCP (its `RTU_VIA_TCP`, UR's forwarder port) against the Robotiq front of a
//!   gateway driving an emulated Robotiq: activation, a close onto an emulated object (gOBJ
//!   2 where the object is), an open;
//! - RTU on a serial port against `handgate emulate robotiq` on its pseudo-terminal;
//! - the whole chain: pyRobotiqGripper → the front → handgate's own Robotiq device over RTU
//!   on a pty → `handgate emulate robotiq`;
//! - a Robotiq client closing a Dex3 (an emulated Dex3 hand behind the Robotiq front, an
//!   object under its index): the client sees the hand's closure as gPO and gOBJ 2;
//! - the shipped profiles against the emulator: robotiq-usb (its port the emulator's pty,
//!   pyRobotiqGripper on the front's RTU pty) and ur-robotiq-2f85 (the arm's forwarder the
//!   emulator's RTU over TCP, a URCap text-socket client on the front).
//!
//! Domain 38 (docs/development.md). Tests take turns ([`serial`]); every wait is on readiness
//! with a deadline. Needs the binary (`cargo build -p handgate`) and `.venv` with
//! scripts/peers-requirements.txt.

use std::path::PathBuf;
use std::time::Duration;

use handgate_tests::{emulated_device, serial, temp_profile, Emulation, Gateway, PyProcess};
use serde_json::Value;

const DOMAIN: u32 = 38;
const DEADLINE: Duration = Duration::from_secs(30);

fn write_profile(name: &str, body: &str) -> PathBuf {
    temp_profile(
        "robotiq-peer",
        name,
        &format!("name = \"{name}\"\ndescription = \"test\"\n{body}"),
    )
}

/// The Robotiq front of `device`, RTU over TCP on a free port, its pty at `pty`, URCap off.
fn front(device: &str, pty: &std::path::Path) -> String {
    format!(
        "[[fronts]]\nkind = \"robotiq\"\ndevice = \"{device}\"\nrtu_tcp = \"127.0.0.1:0\"\nurcap_tcp = \"\"\npty = \"{}\"\n",
        pty.display()
    )
}

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-robotiq-peer-{}-{name}", std::process::id()))
}

/// The address the gateway's Robotiq front serves RTU over TCP on (from its start-up line).
fn rtu_tcp_addr(gw: &Gateway) -> String {
    let line = gw
        .wait_stdout("robotiq front: RTU over TCP at tcp ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}"));
    line.rsplit("at tcp ")
        .next()
        .and_then(|r| r.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {line}"))
        .to_string()
}

/// The peer's `event` line, parsed.
fn event(py: &PyProcess, name: &str) -> Value {
    let prefix = format!("{{\"event\": \"{name}\"");
    let rest = py
        .wait_line(&prefix, DEADLINE)
        .unwrap_or_else(|e| panic!("pyRobotiqGripper: no {name} event: {e}"));
    serde_json::from_str(&format!("{prefix}{rest}")).unwrap_or_else(|e| panic!("{prefix}{rest}: {e}"))
}

fn int(v: &Value, key: &str) -> i64 {
    v[key].as_i64().unwrap_or_else(|| panic!("no integer {key} in {v}"))
}

/// Runs the peer's activate / close / open against `args` and checks what it saw: activated,
/// the close stopped by an object at `object_at` counts (gOBJ 2), the open at position.
fn activate_close_open(args: &[String], object_at: i64) {
    let py = PyProcess::spawn("robotiq_pyrobotiq.py", args).expect("python peer starts");
    let connected = event(&py, "connected");
    assert_eq!(
        connected["status"]["gSTA"], 0,
        "a powered-up gripper is not activated: {connected}"
    );
    let activated = event(&py, "activated");
    assert_eq!(activated["activated"], true, "{activated}");
    assert_eq!(activated["status"]["gSTA"], 3, "{activated}");
    let closed = event(&py, "closed");
    assert_eq!(
        int(&closed, "object"),
        2,
        "stopped by the object while closing: {closed}"
    );
    let at = int(&closed, "position");
    assert!(
        (at - object_at).abs() <= 3,
        "stopped at the object ({object_at}), not at {at}: {closed}"
    );
    assert_eq!(closed["status"]["gPR"], 255, "{closed}");
    assert!(int(&closed["status"], "gCU") > 0, "a grip draws current: {closed}");
    let opened = event(&py, "opened");
    assert_eq!(int(&opened, "object"), 3, "at the requested position: {opened}");
    // Within the front's "at position" band (4 counts: another device rarely lands on the
    // exact count) or exactly open (the emulated gripper).
    assert!(int(&opened, "position") <= 4, "{opened}");
    event(&py, "done");
}

/// pyRobotiqGripper over RTU_VIA_TCP against the gateway's Robotiq front, an emulated 2F-85
/// behind it with an object at 60 % of its travel (0.48 of 0.8 rad: 153 counts).
#[test]
fn pyrobotiqgripper_rtu_over_tcp_drives_an_emulated_robotiq_through_the_front() {
    let _serial = serial();
    let pty = tmp("front-pty");
    let profile = write_profile(
        "robotiq-front-tcp",
        &format!(
            "{}[devices.robotiq]\nvariant = \"2f-85\"\n[devices.emulator]\nobject_at = {{ jaw = 0.48 }}\n{}",
            emulated_device("gripper", "robotiq", "center"),
            front("gripper", &pty)
        ),
    );
    let gw = Gateway::start(DOMAIN, &[profile.to_str().unwrap()]);
    let addr = rtu_tcp_addr(&gw);
    activate_close_open(&["--tcp".into(), addr], 153);
}

/// pyRobotiqGripper over RTU on a serial port (the pty `handgate emulate robotiq` prints),
/// an object at 128 counts.
#[test]
fn pyrobotiqgripper_rtu_on_a_pty_drives_handgate_emulate_robotiq() {
    let _serial = serial();
    let link = tmp("emulate-pty");
    let emu = Emulation::start(&["robotiq", "--pty", link.to_str().unwrap(), "--object-at", "128"]);
    assert!(emu.line.contains("robotiq.port"), "{}", emu.line);
    activate_close_open(&["--port".into(), link.display().to_string()], 128);
}

/// The whole chain: pyRobotiqGripper (RTU over TCP) → the gateway's Robotiq front →
/// handgate's own Robotiq device (backend serial, RTU on the emulator's pty) → `handgate
/// emulate robotiq` with an object at 100 counts.
#[test]
fn the_robotiq_device_drives_handgate_emulate_robotiq_under_a_robotiq_client() {
    let _serial = serial();
    let link = tmp("chain-emulate-pty");
    let _emu = Emulation::start(&["robotiq", "--pty", link.to_str().unwrap(), "--object-at", "100"]);
    let profile = write_profile(
        "robotiq-chain",
        &format!(
            "[[devices]]\nname = \"gripper\"\nkind = \"robotiq\"\nside = \"center\"\nbackend = \"serial\"\n\
             [devices.robotiq]\nport = \"{}\"\n{}",
            link.display(),
            front("gripper", &tmp("chain-front-pty"))
        ),
    );
    let gw = Gateway::start(DOMAIN, &[profile.to_str().unwrap()]);
    gw.wait_stdout("robotiq: activated", DEADLINE)
        .unwrap_or_else(|e| panic!("the device activates the emulated gripper: {e}"));
    let addr = rtu_tcp_addr(&gw);
    activate_close_open(&["--tcp".into(), addr], 100);
}

/// A Robotiq client closes a Dex3: an emulated Dex3 hand (an object under its index) behind
/// the Robotiq front. rPR 255 closes the hand through closure; the client reads the hand's
/// closure as gPO and its grasp (the motion verdict "holding") as gOBJ 2, then opens it.
#[test]
fn a_robotiq_client_closes_a_dex3() {
    let _serial = serial();
    let profile = write_profile(
        "robotiq-dex3",
        &format!(
            "{}[devices.emulator]\nobject_at = {{ index_0 = 0.6, middle_0 = 0.6, thumb_2 = 0.5 }}\n{}",
            emulated_device("hand", "dex3", "left"),
            front("hand", &tmp("dex3-front-pty"))
        ),
    );
    let gw = Gateway::start(DOMAIN, &[profile.to_str().unwrap()]);
    let addr = rtu_tcp_addr(&gw);
    let py = PyProcess::spawn("robotiq_pyrobotiq.py", &["--tcp".into(), addr]).expect("python peer starts");
    let activated = event(&py, "activated");
    assert_eq!(activated["activated"], true, "{activated}");
    let closed = event(&py, "closed");
    assert_eq!(int(&closed, "object"), 2, "the hand holds the object: {closed}");
    let at = int(&closed, "position");
    assert!((40..250).contains(&at), "the hand's closure, short of closed: {closed}");
    let opened = event(&py, "opened");
    assert!(int(&opened, "position") <= 10, "the hand opened: {opened}");
    event(&py, "done");
}

/// A shipped profile with `(from, to)` replaced, written to a temp file.
fn shipped_edited(name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(
        handgate_tests::repo_root()
            .join("profiles")
            .join(format!("{name}.toml")),
    )
    .unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name}.toml has no `{from}`");
        text = text.replacen(from, to, 1);
    }
    temp_profile("robotiq-peer", &format!("{name}-edited"), &text)
}

/// The shipped robotiq-usb profile, its adapter replaced by `handgate emulate robotiq`'s pty
/// (an object at 90 counts): handgate's device activates the gripper, and pyRobotiqGripper,
/// pointed at the front's RTU pty as it would be at /dev/ttyUSB0, closes it onto the object.
#[test]
fn the_robotiq_usb_profile_drives_the_emulator_and_serves_its_pty() {
    let _serial = serial();
    let link = tmp("usb-emulate-pty");
    let front_pty = tmp("usb-front-pty");
    let _emu = Emulation::start(&["robotiq", "--pty", link.to_str().unwrap(), "--object-at", "90"]);
    let front_keys = format!(
        "device = \"gripper\"\nrtu_tcp = \"127.0.0.1:0\"\nurcap_tcp = \"127.0.0.1:0\"\npty = \"{}\"\n",
        front_pty.display()
    );
    let profile = shipped_edited(
        "robotiq-usb",
        &[
            ("port = \"/dev/ttyUSB0\"", &format!("port = \"{}\"", link.display())),
            (
                "kind = \"robotiq\"\ndevice = \"gripper\"\n",
                &format!("kind = \"robotiq\"\n{front_keys}"),
            ),
        ],
    );
    let gw = Gateway::start(DOMAIN, &[profile.to_str().unwrap()]);
    gw.wait_stdout("robotiq: activated", DEADLINE)
        .unwrap_or_else(|e| panic!("the device activates the emulated gripper: {e}"));
    activate_close_open(&["--port".into(), front_pty.display().to_string()], 90);
}

/// A URCap text-socket client (the protocol UR programs speak on port 63352) over the shipped
/// ur-robotiq-2f85 profile, the arm's forwarder replaced by `handgate emulate robotiq --tcp`
/// (an object at 90 counts): reset, activate (STA 3), a move on one line, OBJ 2 at the object.
#[test]
fn a_urcap_client_closes_the_ur_profiles_gripper_over_rtu_over_tcp() {
    use std::io::{Read, Write};
    let _serial = serial();
    let emu = Emulation::start(&["robotiq", "--tcp", "127.0.0.1:0", "--object-at", "90"]);
    let arm = emu
        .line
        .split_whitespace()
        .find(|w| w.starts_with("127.0.0.1:"))
        .unwrap_or_else(|| panic!("no address in {}", emu.line))
        .trim_end_matches(':')
        .to_string();
    let profile = shipped_edited(
        "ur-robotiq-2f85",
        &[
            ("tcp = \"192.168.1.10:54321\"", &format!("tcp = \"{arm}\"")),
            (
                "kind = \"robotiq\"\ndevice = \"gripper\"",
                &format!(
                    "kind = \"robotiq\"\ndevice = \"gripper\"\nrtu_tcp = \"127.0.0.1:0\"\nurcap_tcp = \"127.0.0.1:0\"\npty = \"{}\"",
                    tmp("ur-front-pty").display()
                ),
            ),
        ],
    );
    let gw = Gateway::start(DOMAIN, &[profile.to_str().unwrap()]);
    gw.wait_stdout("robotiq: activated", DEADLINE)
        .unwrap_or_else(|e| panic!("the device activates the emulated gripper over TCP: {e}"));
    let line = gw
        .wait_stdout("robotiq front: URCap socket at tcp ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}"));
    let addr = line
        .rsplit("at tcp ")
        .next()
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .to_string();
    let mut s = std::net::TcpStream::connect(&addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut say = |line: &str| -> String {
        s.write_all(format!("{line}\n").as_bytes()).unwrap();
        let mut b = [0u8; 128];
        let n = s.read(&mut b).unwrap_or_else(|e| panic!("`{line}`: no answer: {e}"));
        String::from_utf8_lossy(&b[..n]).into_owned()
    };
    assert_eq!(say("SET ACT 0"), "ack");
    assert_eq!(say("GET STA"), "STA 0");
    assert_eq!(say("SET ACT 1"), "ack");
    let deadline = std::time::Instant::now() + DEADLINE;
    while say("GET STA") != "STA 3" {
        assert!(std::time::Instant::now() < deadline, "never activated");
    }
    assert_eq!(say("SET POS 255 SPE 255 FOR 100 GTO 1"), "ack");
    loop {
        let obj = say("GET OBJ");
        if obj == "OBJ 2" {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "never stopped on the object: {obj}"
        );
    }
    let pos: i64 = say("GET POS").trim_start_matches("POS ").parse().unwrap();
    assert!((pos - 90).abs() <= 3, "at the object (90), not {pos}");
    assert_eq!(say("GET PRE"), "PRE 255");
}
