//! `handgate emulate <kind>` for every kind (docs/adapters.md, "Emulators"): each emulator runs
//! as a process of its own where the hardware or the robot's service would be, so a profile
//! written for a robot runs off-robot against it, on any domain. Domains 190-197.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_go;
use handgate_tests::{
    handgate_bin, node, poll, repo_root, serial, status_device, Emulation as Emulator, Gateway, Latest,
};

/// Bound on an emulator's start, a gateway's first fresh state and a match.
const DEADLINE: Duration = Duration::from_secs(30);

/// Waits until the gateway on `domain` reports every device of `names` with freshness `want`.
fn wait_status(domain: u32, names: &[&str], want: u8) {
    let node = node(domain);
    let mut status: Latest<hg::GatewayStatus_> = Latest::new(&node, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let ok = poll(DEADLINE, || {
        let s = status.update()?;
        names
            .iter()
            .all(|n| status_device(s, n).freshness == want)
            .then_some(())
    });
    assert!(
        ok.is_some(),
        "devices {names:?} never reported freshness {want}: {:?}",
        status.update()
    );
}

/// A shipped profile with `(from, to)` replaced, written to a temp file.
fn shipped_edited(name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(repo_root().join("profiles").join(format!("{name}.toml"))).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "profiles/{name}.toml no longer contains {from:?}");
        text = text.replace(from, to);
    }
    let dir = std::env::temp_dir().join(format!("handgate-emulate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn g1_dex3_profile_runs_against_two_emulated_hand_services() {
    let _g = serial();
    let left = Emulator::start(&["dex3", "--service", "--side", "left", "--domain", "190"]);
    let _right = Emulator::start(&["dex3", "--service", "--side", "right", "--domain", "190"]);
    assert!(left.line.contains("rt/dex3/left/cmd"), "{}", left.line);
    let _gw = Gateway::start(190, &["--profile", "g1-dex3"]);
    wait_status(190, &["left_hand", "right_hand"], hg::FRESH);
}

#[test]
fn g1_dex5_profile_runs_against_two_emulated_hand_services() {
    let _g = serial();
    let left = Emulator::start(&["dex5", "--side", "left", "--domain", "197"]);
    let _right = Emulator::start(&["dex5", "--side", "right", "--domain", "197"]);
    assert!(
        left.line.contains("rt/dex5/left/cmd") && left.line.contains("rt/dex5/left/state"),
        "{}",
        left.line
    );
    let _gw = Gateway::start(197, &["--profile", "g1-dex5"]);
    wait_status(197, &["left_hand", "right_hand"], hg::FRESH);
}

/// The wrapper's conventions on both sides: the emulated service started with them on the
/// command line, the robot profile set to them; a canonical closure command closes the hand.
#[test]
fn g1_dex5_in_the_wrappers_conventions_runs_against_the_service_emulated_in_them() {
    let _g = serial();
    let conventions = ["--command-layout", "motors", "--gains", "unitree_dds_wrapper"];
    let _left = Emulator::start(&[["dex5", "--side", "left", "--domain", "198"].as_slice(), &conventions].concat());
    let _right = Emulator::start(&[["dex5", "--side", "right", "--domain", "198"].as_slice(), &conventions].concat());
    let profile = shipped_edited(
        "g1-dex5",
        &[
            ("gains = \"xr_teleoperate\"      #", "gains = \"unitree_dds_wrapper\" #"),
            ("command_layout = \"joints\"     #", "command_layout = \"motors\"     #"),
        ],
    );
    let _gw = Gateway::start(198, &["--profile", profile.to_str().unwrap()]);
    wait_status(198, &["left_hand", "right_hand"], hg::FRESH);
    let n = node(198);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/left_hand/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    w.wait_matched(1, DEADLINE)
        .expect("the canonical front reads its command topic");
    let mut state: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/left_hand/state", Qos::BestEffort);
    let closed = handgate_tests::stream_until(&mut w, &handgate_tests::closure_cmd(1, 0.8), DEADLINE, || {
        state.update().is_some_and(|s| s.closure > 0.6)
    });
    assert!(closed, "the hand did not close: {:?}", state.update());
}

#[test]
fn a_dex1_client_profile_runs_against_the_emulated_service_in_each_variant() {
    let _g = serial();
    for (variant, domain, topic) in [
        ("go", 191u32, "rt/dex1/left/cmd"),
        ("hg", 192, "rt/dex1/left/cmd"),
        ("actuator", 195, "rt/unitree_actuator/cmd"),
    ] {
        let emu = Emulator::start(&[
            "dex1",
            "--variant",
            variant,
            "--side",
            "left",
            "--domain",
            &domain.to_string(),
        ]);
        assert!(emu.line.contains(topic), "{}", emu.line);
        let profile = format!(
            "name = \"dex1-client\"\n[[devices]]\nname = \"grip\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"dds\"\n[devices.dds]\nvariant = \"{variant}\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"grip\"\n"
        );
        let dir = std::env::temp_dir().join(format!("handgate-emulate-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(format!("dex1-{variant}.toml"));
        std::fs::write(&p, profile).unwrap();
        let _gw = Gateway::start(domain, &["--profile", p.to_str().unwrap()]);
        wait_status(domain, &["grip"], hg::FRESH);
    }
}

#[test]
fn the_emulated_ai_sport_blend_listens_on_rt_hand_sdk() {
    let _g = serial();
    let emu = Emulator::start(&["hand_sdk", "--domain", "193"]);
    assert!(emu.line.contains("rt/hand_sdk"), "{}", emu.line);
    let node = node(193);
    let w = node
        .writer::<unitree_go::MotorCmds_>("rt/hand_sdk", Qos::Reliable { depth: 1 })
        .unwrap();
    w.wait_matched(1, DEADLINE).expect("the emulator reads rt/hand_sdk");
}

#[test]
fn g1_ezgripper_profile_runs_against_an_emulated_bus_on_a_pty() {
    let _g = serial();
    let pty = std::env::temp_dir().join(format!("handgate-emulate-{}-bus", std::process::id()));
    let emu = Emulator::start(&["ezgripper", "--ids", "1,2", "--pty", pty.to_str().unwrap()]);
    assert!(emu.line.contains(pty.to_str().unwrap()), "{}", emu.line);
    let port = pty.to_str().unwrap();
    let p = shipped_edited(
        "g1-ezgripper",
        &[
            ("port = \"/dev/ttyUSB0\"\nbaud", &format!("port = \"{port}\"\nbaud")),
            (
                "port = \"/dev/ttyUSB0\"         # same bus",
                &format!("port = \"{port}\"         # same bus"),
            ),
        ],
    );
    let _gw = Gateway::start(194, &["--profile", p.to_str().unwrap()]);
    wait_status(194, &["left_gripper", "right_gripper"], hg::FRESH);
}

/// `handgate <args>` to completion (bounded by `DEADLINE`): (exit success, stdout, stderr).
fn handgate(args: &[&str]) -> (bool, String, String) {
    let mut cmd = Command::new(handgate_bin());
    cmd.args(args);
    for (k, _) in std::env::vars() {
        if k.starts_with("HANDGATE_") {
            cmd.env_remove(k);
        }
    }
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("handgate starts");
    let done = poll(DEADLINE, || child.try_wait().ok().flatten());
    if done.is_none() {
        let _ = child.kill();
    }
    let out = child.wait_with_output().expect("handgate output");
    (
        done.is_some() && out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn write_profile(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("handgate-emulate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn discover_and_calibrate_go_through_the_devices_abilities() {
    let _g = serial();
    // A Dex3 over USB, the MCU emulated behind a socket: its wiring, as a profile snippet.
    let socket = std::env::temp_dir().join(format!("handgate-emulate-{}-dex3.sock", std::process::id()));
    let _ = std::fs::remove_file(&socket);
    let _mcu = Emulator::start(&["dex3", "--side", "left", "--socket", socket.to_str().unwrap()]);
    let hand = write_profile(
        "discover",
        &format!(
            "name = \"discover\"\n[dds]\ndomain = 196\n[[devices]]\nname = \"hand\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n[devices.usb]\nsocket = \"{}\"\n",
            socket.display()
        ),
    );
    let (ok, out, err) = handgate(&["discover", "hand", "--profile", hand.to_str().unwrap()]);
    assert!(ok, "{out}{err}");
    assert!(
        out.contains("motors answering: 7") && out.contains("[devices.usb.wiring.joints]"),
        "{out}"
    );
    // A Dex3 has no calibration: said, not silently done.
    let (ok, _, err) = handgate(&["calibrate", "hand", "--profile", hand.to_str().unwrap()]);
    assert!(!ok && err.contains("has no calibration"), "{err}");
    // An emulated EZGripper powers up uncalibrated: calibrating finds its zero.
    let grip = write_profile(
        "calibrate",
        "name = \"calibrate\"\n[dds]\ndomain = 196\n[[devices]]\nname = \"grip\"\nkind = \"ezgripper\"\nside = \"left\"\nbackend = \"emulator\"\n",
    );
    let (ok, out, err) = handgate(&["calibrate", "grip", "--profile", grip.to_str().unwrap()]);
    assert!(ok, "{out}{err}");
    assert!(out.contains("grip calibrated: zero_ticks = "), "{out}");
    let (ok, _, err) = handgate(&["discover", "grip", "--profile", grip.to_str().unwrap()]);
    assert!(!ok && err.contains("has no wiring discovery"), "{err}");
}
