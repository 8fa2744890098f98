//! Each DDS-side adapter against its emulated peer over real CycloneDDS (one domain per
//! test, 50..59): commands arrive with the exact wire values (order, signs, mode byte,
//! weight), state comes back canonical, and a peer that goes away and comes back never gets
//! the old setpoint replayed.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::dds_device::{DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::dex1::adapter::{Dex1GoCodec, Variant};
use handgate_adapters::dex1::emulator::{Dex1Command, Dex1Config, Dex1Emulator};
use handgate_adapters::dex3::dds_client::Dex3DdsCodec;
use handgate_adapters::dex3::dds_service_emulator::{Dex3ServiceConfig, Dex3ServiceEmulator};
use handgate_adapters::hand_sdk::adapter::{HandSdkCodec, WeightRamp};
use handgate_adapters::hand_sdk::emulator::{HandSdkConfig, HandSdkEmulator};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{CommandBody, DeviceKind, Freshness, HandCommand, JointCommand, SafeAction, Side};

const DEADLINE: Duration = Duration::from_secs(10);

fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + DEADLINE;
    while !cond() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn info(kind: DeviceKind, side: Side) -> DeviceInfo {
    DeviceInfo {
        name: format!("{kind}_{side}"),
        kind,
        side,
        backend: Backend::Dds,
        table: Arc::new(kind.table(side, &TableOverrides::default()).unwrap()),
    }
}

fn cfg(cmd: &str, state: Option<&str>, rate: f64) -> DdsDeviceConfig {
    DdsDeviceConfig {
        cmd_topic: cmd.into(),
        state_topic: state.map(Into::into),
        rate_hz: rate,
        stale_after: Duration::from_millis(150),
        forward: handgate_adapters::dds_device::Forwarding::default_for(rate),
    }
}

#[test]
fn dex3_adapter_sends_idl_order_mirrored_signs_and_mode_byte() {
    let node = Node::new(50, None).unwrap();
    let emu = Dex3ServiceEmulator::start(&node, Dex3ServiceConfig::new(Side::Left)).unwrap();
    let dev = DdsDevice::start(
        &node,
        info(DeviceKind::Dex3, Side::Left),
        cfg("rt/dex3/left/cmd", Some("rt/dex3/left/state"), 500.0),
        Dex3DdsCodec { timeout_bit: true },
    )
    .unwrap();
    let t = dev.info().table.clone();
    let idx = t.joint_by_name("index_0").unwrap();
    let thumb2 = t.joint_by_name("thumb_2").unwrap();
    dev.command(HandCommand::joints(
        1,
        vec![
            (idx, JointCommand::hold(1.0, 1.5, 0.1)),
            (thumb2, JointCommand::hold(0.5, 1.5, 0.1)),
        ],
    ))
    .unwrap();
    wait_for("the command at the service", || emu.last_command().is_some());
    let cmd = emu.last_command().unwrap();
    assert_eq!(cmd.motor_cmd.len(), 7);
    for (i, m) in cmd.motor_cmd.iter().enumerate() {
        assert_eq!(m.mode, 0x90 | i as u8, "RIS byte: id = index, FOC, timeout bit on");
    }
    assert_eq!(cmd.motor_cmd[5].q, -1.0, "left index_0 = IDL 5, closes negative");
    assert_eq!(cmd.motor_cmd[2].q, 0.5, "left thumb_2 = IDL 2, closes positive");
    assert_eq!(cmd.motor_cmd[5].kp, 1.5);
    // State comes back canonical (positive = closing) and fresh.
    let mut rx = dev.state();
    wait_for("index_0 to close", || {
        let s = rx.borrow_and_update();
        s.freshness == Freshness::Fresh && (s.joints[idx.index()].q - 1.0).abs() < 0.05
    });
    let s = rx.borrow().clone();
    assert!((s.joints[thumb2.index()].q - 0.5).abs() < 0.05);
    assert_eq!(s.pads.len(), 9);
    assert_eq!(s.cmd_seq, 1);
}

#[test]
fn dex1_adapter_maps_closure_to_radians_and_never_replays_after_the_service_returns() {
    let node = Node::new(51, None).unwrap();
    let mut c = Dex1Config::new(Variant::Go, Side::Right);
    c.initial_q = 5.4;
    let emu = Dex1Emulator::start(&node, c.clone()).unwrap();
    let dev = DdsDevice::start(
        &node,
        info(DeviceKind::Dex1, Side::Right),
        cfg("rt/dex1/right/cmd", Some("rt/dex1/right/state"), 200.0),
        Dex1GoCodec::new(Variant::Go, Side::Right),
    )
    .unwrap();
    let mut rx = dev.state();
    wait_for("the first state", || {
        rx.borrow_and_update().freshness == Freshness::Fresh
    });
    assert!(rx.borrow().joints[0].q.abs() < 0.05, "open = canonical 0");
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    wait_for(
        "q = 0 rad (closed) at the service",
        || matches!(emu.last_command(), Some(Dex1Command::Go(m)) if m.cmds.len() == 1 && m.cmds[0].q == 0.0 && m.cmds[0].kp == 5.0),
    );
    wait_for("the jaw to close", || {
        (rx.borrow_and_update().joints[0].q - 5.4).abs() < 0.1
    });
    // The service goes away: state goes stale.
    emu.stop();
    wait_for("stale state", || rx.borrow_and_update().freshness == Freshness::Stale);
    // A new service comes up with the jaw open (someone opened it by hand): the adapter must
    // hold it there, not drive it back to the old closed target.
    let emu2 = Dex1Emulator::start(&node, c).unwrap();
    wait_for("fresh state again", || {
        rx.borrow_and_update().freshness == Freshness::Fresh
    });
    wait_for("a command at the new service", || emu2.last_command().is_some());
    let end = Instant::now() + Duration::from_millis(300);
    while Instant::now() < end {
        if let Some(Dex1Command::Go(m)) = emu2.last_command() {
            assert!(m.cmds[0].q > 5.0, "stale closed target replayed: q = {}", m.cmds[0].q);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let stats = dev.stats();
    assert!(stats.reconnects >= 1 && stats.reseeds >= 1, "{stats:?}");
    // A new command moves it again.
    dev.command(HandCommand::closure(2, 0.5)).unwrap();
    wait_for(
        "half closed",
        || matches!(emu2.last_command(), Some(Dex1Command::Go(m)) if (m.cmds[0].q - 2.7).abs() < 1e-4),
    );
}

#[test]
fn hand_sdk_adapter_ramps_the_weight_and_hands_back_control() {
    let node = Node::new(52, None).unwrap();
    let emu = HandSdkEmulator::start(&node, HandSdkConfig::default()).unwrap();
    let dev = DdsDevice::start(
        &node,
        info(DeviceKind::HandSdk, Side::Left),
        cfg("rt/hand_sdk", None, 200.0),
        HandSdkCodec::new(WeightRamp {
            target: 1.0,
            per_second: 4.0,
        }),
    )
    .unwrap();
    assert_eq!(dev.state().borrow().freshness, Freshness::CommandedOnly);
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    wait_for("full weight", || emu.effective_weight() >= 0.999);
    let blended = emu.last_blended();
    assert!(
        blended.iter().all(|m| (m.tau - 0.3).abs() < 1e-4),
        "positive tau closes: {blended:?}"
    );
    // The adapter raises the weight by 4.0/s * 5 ms = 0.02 per message. ai_sport's tick may
    // miss messages on a loaded machine, so allow a few lost ones; a step from 0 to 1 (or
    // anything like it) fails.
    let hist = emu.weight_history();
    let max_step = hist.windows(2).map(|w| w[1] - w[0]).fold(0.0f32, f32::max);
    assert!(max_step <= 0.1, "the weight stepped by {max_step}: {hist:?}");
    assert!(hist.len() >= 10, "too few distinct weights for a ramp: {hist:?}");
    assert!(!emu.fallback());
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(dev.safe_state(SafeAction::Hold)).unwrap();
    wait_for("ai_sport back in control", || {
        emu.fallback() || emu.effective_weight() == 0.0
    });
    let hist = emu.weight_history();
    let max_drop = hist.windows(2).map(|w| w[0] - w[1]).fold(0.0f32, f32::max);
    assert!(
        max_drop <= 0.1,
        "the weight dropped by {max_drop} in one step: {hist:?}"
    );
}

#[test]
fn partial_command_keeps_other_joints_and_nan_is_refused_before_anything_moves() {
    let node = Node::new(53, None).unwrap();
    let emu = Dex3ServiceEmulator::start(&node, Dex3ServiceConfig::new(Side::Right)).unwrap();
    let dev = DdsDevice::start(
        &node,
        info(DeviceKind::Dex3, Side::Right),
        cfg("rt/dex3/right/cmd", Some("rt/dex3/right/state"), 500.0),
        Dex3DdsCodec { timeout_bit: false },
    )
    .unwrap();
    let t = dev.info().table.clone();
    let mid = t.joint_by_name("middle_1").unwrap();
    dev.command(HandCommand::joints(1, vec![(mid, JointCommand::hold(1.2, 1.5, 0.1))]))
        .unwrap();
    wait_for("middle_1 target at the service", || {
        emu.last_command()
            .is_some_and(|c| (c.motor_cmd[4].q - 1.2).abs() < 1e-6 && c.motor_cmd[4].mode == 0x14)
    });
    let bad = HandCommand {
        seq: 2,
        body: CommandBody::Joints(vec![(
            mid,
            JointCommand {
                q: f32::NAN,
                ..Default::default()
            },
        )]),
        tag: 0,
    };
    assert!(dev.command(bad).is_err());
    assert_eq!(dev.stats().rejected, 1);
    let idx = t.joint_by_name("index_1").unwrap();
    dev.command(HandCommand::joints(3, vec![(idx, JointCommand::hold(0.4, 1.5, 0.1))]))
        .unwrap();
    wait_for("both targets at the service", || {
        emu.last_command()
            .is_some_and(|c| (c.motor_cmd[6].q - 0.4).abs() < 1e-6 && (c.motor_cmd[4].q - 1.2).abs() < 1e-6)
    });
}
