//! The Dex5-1 kind over real CycloneDDS (docs/sources.md §7 "Dex5-1"): the emulated hand
//! service against a client writing what xr_teleoperate's `Dex5_1_Controller` writes, the
//! registry opening an emulated hand that honours its profile, and a client device on the
//! service's own topics reaching a closure target. DDS domains 66, 67 and 68.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos, Reader};
use handgate_adapters::device::{Backend, HandDevice};
use handgate_adapters::dex5::config::Dex5Profile;
use handgate_adapters::dex5::emulator::{Dex5EmuConfig, Dex5Emulator};
use handgate_adapters::dex5::table::{self, closed_posture, CommandLayout, Conventions, Gains, COUPLING};
use handgate_adapters::dex5::{JOINTS, MODE_DISABLED, MODE_ENABLED};
use handgate_adapters::kind::KindConfig;
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, Side};
use handgate_adapters::open::{DeviceSpec, EmulatorSection, OpenEnv, Shared};
use handgate_adapters::sim::Noise;
use handgate_idl::unitree_hg::{HandCmd_, HandState_, MotorCmd_};

const DEADLINE: Duration = Duration::from_secs(20);

fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + DEADLINE;
    while !cond() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Takes state samples until `done` holds (or the deadline passes).
fn watch_until(r: &Reader<HandState_>, mut done: impl FnMut(&HandState_) -> bool) -> HandState_ {
    let end = Instant::now() + DEADLINE;
    loop {
        let s = r.wait_take(DEADLINE).unwrap().pop().unwrap();
        if done(&s) {
            return s;
        }
        assert!(Instant::now() < end, "condition not reached; last {s:?}");
    }
}

/// A command as xr_teleoperate's controller builds it: 20 entries in wire order, mode 1,
/// kp / kd 0.10 / 0.001 on the fingers and 1.0 / 0.02 on the thumb, q the URDF angles.
fn xr_cmd(q: &[f32]) -> HandCmd_ {
    let g = Gains::default();
    HandCmd_ {
        motor_cmd: q
            .iter()
            .enumerate()
            .map(|(i, q)| MotorCmd_ {
                mode: MODE_ENABLED,
                q: *q,
                kp: g.kp[i],
                kd: g.kd[i],
                ..Default::default()
            })
            .collect(),
        reserve: [0; 4],
    }
}

/// The default closed posture on `side`'s wire.
fn closed_wire(side: Side) -> Vec<f32> {
    closed_posture(COUPLING)
        .iter()
        .enumerate()
        .map(|(i, q)| q * table::wire_sign(side, i))
        .collect()
}

#[test]
fn the_emulated_service_rests_off_follows_an_xr_teleoperate_command_and_ignores_a_dex3_one() {
    let node = Node::new(66, None).unwrap();
    let cfg = Dex5EmuConfig {
        noise: Noise::OFF,
        ..Dex5EmuConfig::new(Side::Left)
    };
    let r = node
        .reader::<HandState_>("rt/dex5/left/state", Qos::Reliable { depth: 64 })
        .unwrap();
    let emu = Dex5Emulator::start(&node, cfg).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    // At rest, before any command: 20 entries, every motor off, not all zero (xr_teleoperate
    // waits for a non-zero state).
    let rest = watch_until(&r, |_| true);
    assert_eq!(rest.motor_state.len(), 20);
    assert!(rest.motor_state.iter().all(|m| m.mode == MODE_DISABLED));
    assert!(rest.motor_state.iter().any(|m| m.q != 0.0));

    let mut w = node
        .writer::<HandCmd_>("rt/dex5/left/cmd", Qos::Reliable { depth: 4 })
        .unwrap();
    w.wait_matched(1, DEADLINE).unwrap();
    let want = closed_wire(Side::Left);
    w.write(xr_cmd(&want)).unwrap();
    let s = watch_until(&r, |s| {
        s.motor_state
            .iter()
            .zip(&want)
            .all(|(m, q)| m.mode == MODE_ENABLED && (m.q - q).abs() < 1e-3)
    });
    assert!(s.motor_state[17].q < -0.5, "the left thumb roll closes negative");
    assert!(
        (s.motor_state[3].q - COUPLING * s.motor_state[2].q).abs() < 1e-5,
        "index Pitch_24 follows Pitch_23"
    );
    // A Dex3 client's seven entries: ignored and counted, the hand stays closed.
    w.write(HandCmd_::sdk_default()).unwrap();
    wait_for("the Dex3 command counted", || emu.snapshot().rejected >= 1);
    let s = watch_until(&r, |_| true);
    assert!(s.motor_state.iter().zip(&want).all(|(m, q)| (m.q - q).abs() < 1e-3));
    let snap = emu.snapshot();
    assert_eq!(snap.commands, 1);
    assert!(snap.states_published > 0);
}

/// The Dex5 table of `side` under `config`.
fn table_of(side: Side, config: &Dex5Profile) -> Arc<DeviceTable> {
    Arc::new(
        DeviceKind::Dex5
            .factory()
            .table_with(side, config, &TableOverrides::default())
            .unwrap(),
    )
}

/// A Dex5 device as the gateway resolves it from a profile (watchdog and forwarding at their
/// defaults).
/// Opens `spec` through the registry, as the gateway does: the device, and what it shares
/// with others (kept alive with it).
fn open(node: &Node, spec: &DeviceSpec<'_>) -> (Box<dyn HandDevice>, Shared) {
    let mut shared = Shared::default();
    let mut env = OpenEnv {
        node,
        shared: &mut shared,
    };
    let dev = spec.kind.factory().open(spec, &mut env).unwrap();
    (dev, shared)
}

fn spec<'a>(
    name: &'a str,
    (side, backend, rate_hz): (Side, Backend, f64),
    table: &'a Arc<DeviceTable>,
    emulator: &'a EmulatorSection,
    config: &'a Dex5Profile,
) -> DeviceSpec<'a> {
    DeviceSpec {
        name,
        kind: DeviceKind::Dex5,
        side,
        backend,
        rate_hz,
        stale_after: Duration::from_millis(200),
        forward_on_arrival: true,
        max_send_hz: None,
        table,
        emulator,
        config: config as &dyn KindConfig,
    }
}

#[test]
fn the_registry_opens_an_emulated_hand_that_honours_the_profile() {
    let node = Node::new(67, None).unwrap();
    assert_eq!(DeviceKind::by_name("dex5"), Some(DeviceKind::Dex5), "registered");
    // The wrapper's motor layout and a stiffer coupling: the emulated service takes the same.
    let config = Dex5Profile {
        dex5: Some(Conventions {
            command_layout: CommandLayout::Motors,
            coupling: 1.0,
            ..Default::default()
        }),
        ..Default::default()
    };
    let table = table_of(Side::Right, &config);
    let mut emulator = EmulatorSection {
        noise: Some(false),
        ..Default::default()
    };
    emulator.initial.insert("thumb_0".into(), 0.3);
    emulator.object_at.insert("middle_1".into(), 0.6);
    let spec = spec(
        "dex5_reg",
        (Side::Right, Backend::Emulator, 250.0),
        &table,
        &emulator,
        &config,
    );
    let (dev, _shared) = open(&node, &spec);
    let mut rx = dev.state();
    wait_for("fresh state", || rx.borrow_and_update().freshness == Freshness::Fresh);
    let s = rx.borrow().clone();
    assert!(
        (s.joints[16].q - 0.3).abs() < 1e-5,
        "thumb_0 starts where the profile puts it"
    );
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    let closed = closed_posture(1.0);
    let middle_1 = JOINTS.iter().position(|j| *j == "middle_1").unwrap();
    wait_for("closed, middle_1 on the object", || {
        let s = rx.borrow_and_update();
        s.joints.iter().enumerate().all(|(i, j)| {
            let want = if i == middle_1 { 0.6 } else { closed[i] };
            (j.q - want).abs() < 0.01
        })
    });
    let s = rx.borrow().clone();
    // The coupling of 1.0: every distal joint reads its middle joint's angle.
    for i in [3, 7, 11, 15] {
        assert!((s.joints[i].q - s.joints[i - 1].q).abs() < 1e-4, "{i}: {s:?}");
    }
    assert!(s.joints[middle_1].tau > 0.0, "pressing on the object: {s:?}");
    assert!(
        s.closure > 0.8 && s.closure < 1.0,
        "closed but for one joint: {}",
        s.closure
    );
}

#[test]
fn a_client_on_the_services_topics_reaches_a_closure_target_and_goes_stale_when_it_stops() {
    let node = Node::new(68, None).unwrap();
    let emu = Dex5Emulator::start(&node, Dex5EmuConfig::new(Side::Left)).unwrap();
    let config = Dex5Profile::default();
    let table = table_of(Side::Left, &config);
    let emulator = EmulatorSection::default();
    let spec = spec(
        "left_hand",
        (Side::Left, Backend::Dds, 500.0),
        &table,
        &emulator,
        &config,
    );
    let (dev, _shared) = open(&node, &spec);
    let mut rx = dev.state();
    wait_for("fresh state", || rx.borrow_and_update().freshness == Freshness::Fresh);
    dev.command(HandCommand::closure(1, 0.5)).unwrap();
    wait_for("the service took a 20-entry command at xr_teleoperate's gains", || {
        emu.snapshot().last_command.is_some_and(|m| {
            m.motor_cmd.len() == 20
                && (m.motor_cmd[5].kp - 0.10).abs() < 1e-6
                && (m.motor_cmd[19].kp - 1.0).abs() < 1e-6
        })
    });
    wait_for("half closed", || (rx.borrow_and_update().closure - 0.5).abs() < 0.01);
    let half = table.closure_targets(0.5, None).unwrap();
    assert!(
        (emu.position(17) + half[17].q).abs() < 0.01,
        "the left thumb roll, negative on the wire"
    );
    emu.stop();
    wait_for("stale after the service stops", || {
        rx.borrow_and_update().freshness == Freshness::Stale
    });
}
