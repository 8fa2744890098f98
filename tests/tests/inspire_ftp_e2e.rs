//! The Inspire FTP kind through the real `handgate` binary. Domains 84–87
//! (docs/development.md).
//!
//! What runs: `handgate emulate inspire_ftp` as a process of its own where Inspire's DDS driver
//! would be, driven across the process boundary by the kind's own device (opened through the
//! registry, as the gateway opens it) on 84 and 85; `handgate check` on the shipped profile and
//! on a fleet of two emulated hands with a canonical front; `handgate run` serving two emulated
//! hands through their canonical fronts (86), and a dds-backend hand against the `handgate
//! emulate` process (87). Tests take turns ([`serial`]); every wait is on readiness with a
//! deadline.

use std::process::Command;
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::dds::Qos;
use handgate_adapters::device::{Backend, HandDevice};
use handgate_adapters::inspire_ftp::config::{DdsConfig, InspireFtpProfile};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, HandState, Side};
use handgate_adapters::open::{DeviceSpec, EmulatorSection, OpenEnv, Shared};
use handgate_idl::handgate as hg;
use handgate_tests::{
    handgate_bin, handgate_cmd, node, serial, stream_until, temp_profile, Emulation, Gateway, Latest,
};

const DEADLINE: Duration = Duration::from_secs(30);

/// A profile written for this run; `handgate run --profile <it>` loads it.
fn write_profile(name: &str, text: &str) -> std::path::PathBuf {
    temp_profile("ftp", name, text)
}

/// The newest canonical state on `r` that satisfies `ok`, while `cmd` streams on `w`.
fn drive(
    w: &mut handgate_adapters::dds::Writer<hg::HandCmd_>,
    r: &mut Latest<hg::HandState_>,
    cmd: &hg::HandCmd_,
    what: &str,
    mut ok: impl FnMut(&hg::HandState_) -> bool,
) -> hg::HandState_ {
    let reached = stream_until(w, cmd, DEADLINE, || r.update().is_some_and(&mut ok));
    assert!(reached, "{what}: last {:?}", r.last);
    r.last.clone().unwrap()
}

fn q(s: &hg::HandState_, joint: &str) -> f32 {
    s.joints.iter().find(|j| j.name == joint).map_or(f32::NAN, |j| j.q)
}

/// Opens an inspire_ftp device on backend dds through the registry, as the gateway does.
fn open(node: &Node, name: &str, side: Side, dds: DdsConfig) -> Box<dyn HandDevice> {
    let kind = DeviceKind::by_name("inspire_ftp").expect("registered");
    let table = Arc::new(kind.table(side, &TableOverrides::default()).unwrap());
    let emulator = EmulatorSection::default();
    let config = InspireFtpProfile {
        dds: Some(dds),
        ..Default::default()
    };
    let spec: DeviceSpec<'_> = DeviceSpec {
        name,
        kind,
        side,
        backend: Backend::Dds,
        rate_hz: 100.0,
        stale_after: Duration::from_millis(300),
        forward_on_arrival: true,
        max_send_hz: None,
        table: &table,
        emulator: &emulator,
        config: &config,
    };
    let mut shared = Shared::default();
    kind.factory()
        .open(
            &spec,
            &mut OpenEnv {
                node,
                shared: &mut shared,
            },
        )
        .expect("opens")
}

fn wait_state(dev: &dyn HandDevice, what: &str, mut ok: impl FnMut(&HandState) -> bool) -> HandState {
    let mut rx = dev.state();
    let end = Instant::now() + DEADLINE;
    loop {
        let s = rx.borrow_and_update().clone();
        if ok(&s) {
            return s;
        }
        assert!(Instant::now() < end, "{what}: last {s:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn emulated_driver_process_is_driven_by_the_kind_over_dds_with_touch() {
    let _g = serial();
    let emu = Emulation::start(&["inspire_ftp", "--side", "left", "--no-noise", "--domain", "84"]);
    assert!(
        emu.line.contains("rt/inspire_hand/ctrl/l") && emu.line.contains("rt/inspire_hand/touch/l"),
        "{}",
        emu.line
    );
    let node = node(84);
    let dev = open(&node, "left_hand", Side::Left, DdsConfig::default());
    // The driver's start-up state: where the hand was left, 900 = 0.17 rad on a finger.
    let s = wait_state(&*dev, "a fresh state with the tactile pads", |s| {
        s.freshness == Freshness::Fresh && s.pads.len() == 17
    });
    assert!((s.joints[0].q - 0.17).abs() < 1e-4, "{:?}", s.joints[0]);
    // Closure 1: the fingers close (positive), the thumb stays straight.
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    let s = wait_state(&*dev, "the fist", |s| s.joints.iter().take(4).all(|j| j.q > 1.69));
    assert!(s.joints[4].q.abs() < 1e-3);
    // Closure 0: back open (canonical 0, the thumb rotation at its −0.1 end).
    dev.command(HandCommand::closure(2, 0.0)).unwrap();
    let s = wait_state(&*dev, "open", |s| s.joints.iter().take(4).all(|j| j.q < 0.01));
    assert!((s.joints[5].q + 0.1).abs() < 1e-3, "{:?}", s.joints[5]);
}

#[test]
fn rs485_driver_process_has_no_touch_and_unknown_transport_is_refused() {
    let _g = serial();
    let emu = Emulation::start(&["inspire_ftp", "--side", "right", "--variant", "rs485", "--domain", "85"]);
    assert!(
        emu.line.contains("RS-485") && !emu.line.contains("touch/r"),
        "{}",
        emu.line
    );
    let node = node(85);
    let dev = open(
        &node,
        "right_hand",
        Side::Right,
        DdsConfig {
            touch: Some(false),
            ..Default::default()
        },
    );
    let s = wait_state(&*dev, "a fresh state", |s| s.freshness == Freshness::Fresh);
    assert!(s.pads.is_empty(), "no touch over RS-485");
    dev.command(HandCommand::closure(1, 0.5)).unwrap();
    wait_state(&*dev, "half closed", |s| (s.closure - 0.5).abs() < 0.02);
    let out = Command::new(handgate_bin())
        .args([
            "emulate",
            "inspire_ftp",
            "--side",
            "left",
            "--variant",
            "can",
            "--domain",
            "85",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("rs485"));
}

#[test]
fn check_describes_the_shipped_profile_and_a_two_hand_emulated_fleet() {
    let out = handgate_cmd(None).args(["check", "g1-inspire-ftp"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains(
            "via rt/inspire_hand/ctrl/l / rt/inspire_hand/state/l (Modbus TCP: touch on rt/inspire_hand/touch/l)"
        ),
        "{text}"
    );
    let dir = std::env::temp_dir().join(format!("handgate-ftp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("ftp-sim.toml");
    std::fs::write(
        &p,
        "name = \"ftp-sim\"\n\
         [[devices]]\nname = \"l\"\nkind = \"inspire_ftp\"\nside = \"left\"\nbackend = \"emulator\"\n\
         [devices.emulator]\nobject_at = { index = 1.0 }\n\
         [[devices]]\nname = \"r\"\nkind = \"inspire_ftp\"\nside = \"right\"\nbackend = \"emulator\"\n\
         [[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"r\"\n",
    )
    .unwrap();
    let out = handgate_cmd(None)
        .args(["check", p.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        text.contains("inspire_ftp left   emulator") && text.contains("inspire_ftp right  emulator"),
        "{text}"
    );
    // A thumb rotation never closes on an object: refused, naming the key.
    std::fs::write(
        &p,
        "[[devices]]\nname = \"l\"\nkind = \"inspire_ftp\"\nside = \"left\"\nbackend = \"emulator\"\n\
         [devices.emulator]\nobject_at = { thumb_rotate = 1.0 }\n",
    )
    .unwrap();
    let out = Command::new(handgate_bin())
        .args(["check", p.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("emulator.object_at.thumb_rotate"));
}

/// Two emulated hands, each driven through its canonical front by `handgate run`: one
/// joint by name on the left (positive closes: the index goes to 1.2 rad, the others keep
/// their rest), a closure on the right (the fist); the state comes back measured, with the 17
/// tactile pads' peaks.
#[test]
fn two_emulated_hands_through_their_canonical_fronts() {
    let _g = serial();
    let p = write_profile(
        "ftp-pair",
        "name = \"ftp-pair\"\n\
         [[devices]]\nname = \"l\"\nkind = \"inspire_ftp\"\nside = \"left\"\nbackend = \"emulator\"\n\
         [devices.watchdog]\ntimeout_ms = 2000\n\
         [[devices]]\nname = \"r\"\nkind = \"inspire_ftp\"\nside = \"right\"\nbackend = \"emulator\"\n\
         [devices.watchdog]\ntimeout_ms = 2000\n\
         [[fronts]]\nkind = \"canonical\"\ndevice = \"l\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"r\"\n",
    );
    let _gw = Gateway::start(86, &["--profile", p.to_str().unwrap()]);
    let n = node(86);
    let mut wl = n
        .writer::<hg::HandCmd_>("rt/handgate/l/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut wr = n
        .writer::<hg::HandCmd_>("rt/handgate/r/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut sl: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/l/state", Qos::BestEffort);
    let mut sr: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/r/state", Qos::BestEffort);
    wl.wait_matched(1, DEADLINE).unwrap();
    wr.wait_matched(1, DEADLINE).unwrap();
    // A partial command resolves the joints it does not name against the measured state, so
    // command once the hand has been measured (its canonical state is fresh).
    let fresh = handgate_tests::poll(DEADLINE, || {
        sl.update().filter(|s| s.freshness == hg::FRESH).map(|s| q(s, "middle"))
    })
    .expect("a fresh left state");
    assert!((fresh - 0.17).abs() < 0.01, "the rest posture: {fresh}");
    let left = hg::HandCmd_ {
        seq: 1,
        mode: hg::MODE_JOINTS,
        joints: vec![hg::JointCmd_ {
            name: "index".into(),
            q: 1.2,
            ..Default::default()
        }],
        ..Default::default()
    };
    let s = drive(&mut wl, &mut sl, &left, "left index at 1.2 rad", |s| {
        s.freshness == hg::FRESH && (q(s, "index") - 1.2).abs() < 0.01
    });
    assert_eq!((s.kind.as_str(), s.side.as_str()), ("inspire_ftp", "left"));
    assert!(
        (q(&s, "middle") - 0.17).abs() < 0.01,
        "the middle keeps its rest: {s:?}"
    );
    assert_eq!(s.pressure.len(), 17, "one peak per tactile segment");
    let right = hg::HandCmd_ {
        seq: 1,
        mode: hg::MODE_CLOSURE,
        closure: 1.0,
        ..Default::default()
    };
    let s = drive(&mut wr, &mut sr, &right, "the right fist", |s| {
        s.freshness == hg::FRESH && ["pinky", "ring", "middle", "index"].iter().all(|j| q(s, j) > 1.68)
    });
    assert!(
        q(&s, "thumb_bend").abs() < 0.02,
        "the fist keeps the thumb straight: {s:?}"
    );
    assert!((s.closure - 1.0).abs() < 0.02);
}

/// A hand on backend dds in `handgate run` reaches the `handgate emulate` process on
/// the driver's standard topics, and a closure through the canonical front moves it.
#[test]
fn dds_backend_hand_in_the_gateway_drives_the_emulate_process() {
    let _g = serial();
    let _emu = Emulation::start(&["inspire_ftp", "--side", "right", "--seed", "5", "--domain", "87"]);
    let p = write_profile(
        "ftp-client",
        "name = \"ftp-client\"\n\
         [[devices]]\nname = \"hand\"\nkind = \"inspire_ftp\"\nside = \"right\"\nbackend = \"dds\"\n\
         [devices.watchdog]\ntimeout_ms = 2000\n\
         [[fronts]]\nkind = \"canonical\"\ndevice = \"hand\"\n",
    );
    let _gw = Gateway::start(87, &["--profile", p.to_str().unwrap()]);
    let n = node(87);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/hand/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut s: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/hand/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let half = hg::HandCmd_ {
        seq: 1,
        mode: hg::MODE_CLOSURE,
        closure: 0.5,
        ..Default::default()
    };
    let st = drive(&mut w, &mut s, &half, "half closed", |s| {
        s.freshness == hg::FRESH && (q(s, "index") - 0.85).abs() < 0.02 && s.pressure.len() == 17
    });
    assert!(st.closure > 0.45 && st.closure < 0.55, "{st:?}");
}
