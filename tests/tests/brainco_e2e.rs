//! The BrainCo Revo2 kind end to end through the `handgate` binary (docs/adapters.md,
//! "BrainCo Revo2"): a profile with two emulated hands driven through the canonical front, and
//! `handgate emulate brainco` as separate processes driven by the shipped `g1-brainco` profile
//! (backend dds) on the same domain, and a standalone `handgate emulate brainco` process driven by
//! the same DDS-client device the gateway opens. Domains 92, 93 and 94.

use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::handgate as hg;
use handgate_idl::unitree_go;
use std::sync::Arc;

use handgate_adapters::brainco::adapter::BraincoCodec;
use handgate_adapters::dds_device::{DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, Side};
use handgate_tests::{closure_cmd, poll, serial, Emulation as Emulator, Gateway, Latest};

const DEADLINE: Duration = Duration::from_secs(30);

fn node(domain: u32) -> Node {
    Node::new(domain, None).expect("DDS participant")
}

/// Sends `closure` to `device`'s canonical front once per state sample (the front's watchdog
/// holds the hand when commands stop) until the state satisfies `done`; returns that state.
fn drive(
    n: &Node,
    device: &str,
    closure: f32,
    mut done: impl FnMut(&hg::HandState_) -> bool,
    gw: &Gateway,
) -> hg::HandState_ {
    let mut w = n
        .writer::<hg::HandCmd_>(&format!("rt/handgate/{device}/cmd"), Qos::Reliable { depth: 1 })
        .unwrap();
    let mut state = Latest::<hg::HandState_>::new(n, &format!("rt/handgate/{device}/state"), Qos::BestEffort);
    w.wait_matched(1, DEADLINE)
        .unwrap_or_else(|e| panic!("{device}'s canonical front: {e}\n{}", gw.transcript()));
    let mut seq = 0;
    let reached = poll(DEADLINE, || {
        let s = state.next(Duration::from_secs(5))?;
        if s.freshness == hg::FRESH && done(&s) {
            return Some(s);
        }
        seq += 1;
        let _ = w.write(closure_cmd(seq, closure));
        None
    });
    reached.unwrap_or_else(|| {
        panic!(
            "{device} never reached closure {closure}: {:?}\n{}",
            state.last,
            gw.transcript()
        )
    })
}

/// URDF upper limits (docs/sources.md §7): thumb, thumb aux, then the four fingers.
#[allow(clippy::approx_constant)] // the URDF's literal 1.0472
const CLOSED_RAD: [f32; 6] = [1.5184, 1.0472, 1.4661, 1.4661, 1.4661, 1.4661];

fn assert_closed_positive(s: &hg::HandState_) {
    assert_eq!(s.kind, "brainco");
    assert_eq!(s.joints.len(), 6);
    for (j, max) in s.joints.iter().zip(CLOSED_RAD) {
        assert!(
            j.q > 0.9 * max && j.q < max + 0.02,
            "{} closed = +{max} rad: {s:?}",
            j.name
        );
    }
}

#[test]
fn two_emulated_brainco_hands_close_and_open_through_the_canonical_front() {
    let _g = serial();
    let profile = "name = \"brainco-sim\"\ndescription = \"two emulated BrainCo hands\"\n\
        [[devices]]\nname = \"bl\"\nkind = \"brainco\"\nside = \"left\"\nbackend = \"emulator\"\n\
        [[devices]]\nname = \"br\"\nkind = \"brainco\"\nside = \"right\"\nbackend = \"emulator\"\n\
        [[fronts]]\nkind = \"canonical\"\ndevice = \"bl\"\n\
        [[fronts]]\nkind = \"canonical\"\ndevice = \"br\"\n";
    let dir = std::env::temp_dir().join(format!("handgate-brainco-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("brainco-sim.toml");
    std::fs::write(&p, profile).unwrap();
    let gw = Gateway::start(92, &["--profile", p.to_str().unwrap()]);
    let n = node(92);
    for device in ["bl", "br"] {
        // The emulated service opens the hand at start-up.
        drive(&n, device, 0.0, |s| s.closure < 0.02, &gw);
        let closed = drive(&n, device, 1.0, |s| s.closure > 0.97, &gw);
        assert_closed_positive(&closed);
        let open = drive(&n, device, 0.0, |s| s.closure < 0.03, &gw);
        assert!(open.joints.iter().all(|j| j.q.abs() < 0.05), "{open:?}");
    }
}

#[test]
fn g1_brainco_profile_drives_two_emulated_brainco_services() {
    let _g = serial();
    let left = Emulator::start(&["brainco", "--side", "left", "--domain", "93"]);
    let _right = Emulator::start(&["brainco", "--side", "right", "--domain", "93"]);
    assert!(left.line.contains("rt/brainco/left/cmd"), "{}", left.line);
    let gw = Gateway::start(93, &["--profile", "g1-brainco"]);
    let n = node(93);
    // What the service itself reports (wire: q 1 = closed).
    let mut wire = Latest::<unitree_go::MotorStates_>::new(&n, "rt/brainco/right/state", Qos::BestEffort);
    let closed = drive(&n, "right_hand", 1.0, |s| s.closure > 0.97, &gw);
    assert_closed_positive(&closed);
    let w = poll(DEADLINE, || wire.update().cloned()).expect("the emulated service's state");
    assert!(
        w.states.iter().all(|m| m.q > 0.95),
        "closed on the wire is q near 1: {w:?}"
    );
    // The left hand was not commanded: the service opened it at start-up and holds it open.
    let mut left_state = Latest::<hg::HandState_>::new(&n, "rt/handgate/left_hand/state", Qos::BestEffort);
    let l = poll(DEADLINE, || {
        left_state.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .expect("left hand state");
    assert!(l.closure < 0.05, "{l:?}");
}

#[test]
fn a_standalone_emulate_brainco_process_is_driven_by_the_client_device() {
    let _g = serial();
    let emu = Emulator::start(&["brainco", "--side", "left", "--domain", "94", "--seed", "3"]);
    assert!(
        emu.line.contains("rt/brainco/left/cmd") && emu.line.contains("rt/brainco/left/state"),
        "{}",
        emu.line
    );
    let n = node(94);
    let table = Arc::new(
        DeviceKind::Brainco
            .table(Side::Left, &TableOverrides::default())
            .unwrap(),
    );
    let dev = DdsDevice::start(
        &n,
        DeviceInfo {
            name: "left_hand".into(),
            kind: DeviceKind::Brainco,
            side: Side::Left,
            backend: Backend::Dds,
            table: table.clone(),
        },
        DdsDeviceConfig {
            cmd_topic: "rt/brainco/left/cmd".into(),
            state_topic: Some("rt/brainco/left/state".into()),
            rate_hz: 100.0,
            stale_after: Duration::from_millis(200),
            forward: handgate_adapters::dds_device::Forwarding::default_for(100.0),
        },
        BraincoCodec::default(),
    )
    .unwrap();
    let mut rx = dev.state();
    // The service opened the hand at start-up.
    let open = poll(DEADLINE, || {
        let s = rx.borrow_and_update();
        (s.freshness == Freshness::Fresh && s.closure < 0.02).then(|| s.clone())
    });
    assert!(open.is_some(), "never fresh and open: {:?}", *rx.borrow());
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    let closed = poll(DEADLINE, || {
        let s = rx.borrow_and_update();
        (s.closure > 0.97).then(|| s.clone())
    })
    .unwrap_or_else(|| panic!("never closed: {:?}", *rx.borrow()));
    for (j, max) in closed.joints.iter().zip(CLOSED_RAD) {
        assert!(j.q > 0.9 * max && j.q < max + 0.02, "closed = +{max} rad: {closed:?}");
    }
}
