//! The Inspire FTP kind through the real `handgate` binary. Domains 238 and 239.
//!
//! What runs: `handgate emulate inspire_ftp` as a process of its own where Inspire's DDS driver
//! would be, driven across the process boundary by the kind's own device (opened through the
//! registry, as the gateway opens it); `handgate check` on the shipped profile and on a fleet
//! of two emulated hands with a canonical front.
//!
//! What does not run here: a *gateway* on these domains. This kind's test domains are
//! 235–239 and the gateway refuses a domain above 232 (`profile::MAX_DOMAIN_ID`: the standard
//! RTPS port mapping, 7400 + 250 · id, overflows 16 bits there), so the two-hand profile
//! through the canonical front and a dds-backend profile against the emulate process cannot
//! be started on them. The emulate process and this test share a CycloneDDS configuration
//! (`CYCLONEDDS_URI`) with a domain gain of 200 and a discovery tag unique to this run.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::device::{Backend, HandDevice};
use handgate_adapters::inspire_ftp::kind::{DdsConfig, InspireFtpProfile};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, HandState, Side};
use handgate_adapters::open::{DeviceSpec, EmulatorSection, OpenEnv, Shared};
use handgate_tests::{handgate_bin, serial};

const DEADLINE: Duration = Duration::from_secs(30);

/// The CycloneDDS configuration of domain `id` for this run (also the child's `CYCLONEDDS_URI`).
fn dds_config(id: u32) -> String {
    format!(
        "<CycloneDDS><Domain Id=\"{id}\"><Discovery><Tag>handgate-ftp-e2e-{}-{id}</Tag>\
         <Ports><DomainGain>200</DomainGain></Ports></Discovery></Domain></CycloneDDS>",
        std::process::id()
    )
}

fn node(id: u32) -> Node {
    let d = cyclonedds_rs::dds_domain::DdsDomain::create(id, Some(&dds_config(id))).expect("domain");
    std::mem::forget(d);
    Node::new(id, None).expect("participant")
}

/// `handgate emulate <args>`, killed on drop.
struct Emulate {
    child: Child,
    line: String,
}

impl Emulate {
    fn start(domain: u32, args: &[&str]) -> Emulate {
        let mut cmd = Command::new(handgate_bin());
        cmd.arg("emulate").args(args).args(["--domain", &domain.to_string()]);
        for (k, _) in std::env::vars() {
            if k.starts_with("HANDGATE_") {
                cmd.env_remove(k);
            }
        }
        cmd.env("CYCLONEDDS_URI", dds_config(domain));
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("handgate emulate starts");
        let out = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut lines = BufReader::new(out).lines();
            if let Some(Ok(l)) = lines.next() {
                let _ = tx.send(l);
            }
            for _ in lines {}
        });
        let line = rx.recv_timeout(DEADLINE).expect("handgate emulate printed its topics");
        Emulate { child, line }
    }
}

impl Drop for Emulate {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Opens an inspire_ftp device on backend dds through the registry, as the gateway does.
fn open(node: &Node, name: &str, side: Side, dds: DdsConfig) -> Box<dyn HandDevice> {
    let kind = DeviceKind::by_name("inspire_ftp").expect("registered");
    let table = Arc::new(kind.table(side, &TableOverrides::default()).unwrap());
    let emulator = EmulatorSection::default();
    let config = InspireFtpProfile { dds: Some(dds) };
    let spec = DeviceSpec {
        name,
        kind,
        side,
        backend: Backend::Dds,
        rate_hz: 100.0,
        stale_after: Duration::from_millis(300),
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
    let emu = Emulate::start(238, &["inspire_ftp", "--side", "left", "--no-noise"]);
    assert!(
        emu.line.contains("rt/inspire_hand/ctrl/l") && emu.line.contains("rt/inspire_hand/touch/l"),
        "{}",
        emu.line
    );
    let node = node(238);
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
    let emu = Emulate::start(239, &["inspire_ftp", "--side", "right", "--variant", "rs485"]);
    assert!(
        emu.line.contains("RS-485") && !emu.line.contains("touch/r"),
        "{}",
        emu.line
    );
    let node = node(239);
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
            "239",
        ])
        .env("CYCLONEDDS_URI", dds_config(239))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("rs485"));
}

#[test]
fn check_describes_the_shipped_profile_and_a_two_hand_emulated_fleet() {
    let out = Command::new(handgate_bin())
        .args(["check", "g1-inspire-ftp"])
        .output()
        .unwrap();
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
    let out = Command::new(handgate_bin())
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
