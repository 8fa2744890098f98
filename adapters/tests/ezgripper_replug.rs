//! EZGripper: no stale target after an unplug (issue 18). The jaw is commanded while the USB
//! adapter is unplugged (the pty is gone); after the replug the gripper must hold where it is
//! measured, and neither that target nor the one from before the unplug may reach the bus
//! again. Asserted on the emulated servo's own Goal Position register and present position
//! (ground truth), polled every millisecond over many bus rounds.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::ezgripper::adapter::EzGripperDevice;
use handgate_adapters::ezgripper::control_table::reg;
use handgate_adapters::ezgripper::emulator::{EmulatorConfig, VirtualBus};
use handgate_adapters::ezgripper::{BusConfig, EzError, EzGripperBus, GripperConfig, ServoId};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{CommandBody, DeviceKind, HandCommand, JointCommand, JointId, Side};

const DEADLINE: Duration = Duration::from_secs(30);
/// Zero (closed) position of the servo, ticks; open is positive, 2500 ticks = 100 % (the
/// SAKE driver's GRIP_MAX, docs/ezgripper.md).
const ZERO: i32 = 1000;
const TICKS_PER_PCT: i32 = 25;

fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + DEADLINE;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// A canonical jaw command for `pct` % open (the EZGripper table: 100 % = open = jaw 0 rad,
/// 0 % = closed = jaw 5.4 rad; written out, not taken from the table).
fn jaw_at(pct: f32, seq: u64) -> HandCommand {
    let jaw = (100.0 - pct) / 100.0 * 5.4;
    HandCommand {
        seq,
        body: CommandBody::Joints(vec![(JointId(0), JointCommand::hold(jaw, 5.0, 0.05))]),
        tag: 0,
    }
}

fn ticks(pct: i32) -> i32 {
    ZERO + pct * TICKS_PER_PCT
}

#[test]
fn a_target_set_while_unplugged_or_before_is_never_sent_after_the_replug() {
    let path: PathBuf = std::env::temp_dir().join(format!("handgate-ezg-replug-{}", std::process::id()));
    let emu = VirtualBus::start(&path, EmulatorConfig::with_ids(&[1])).unwrap();
    let id = ServoId::new(1).unwrap();
    let cfg = BusConfig {
        grippers: vec![GripperConfig {
            id,
            zero_ticks: Some(ZERO),
        }],
        calibrate_on_start: false,
        response_timeout_ms: 100,
        ..Default::default()
    };
    let bus = (0..5)
        .find_map(|_| match EzGripperBus::open(emu.path(), cfg.clone()) {
            Ok(b) => Some(b),
            Err(EzError::NoAnswer { .. }) => None,
            Err(e) => panic!("open: {e}"),
        })
        .expect("the bus opens");
    let bus = Arc::new(bus);
    let table = Arc::new(
        DeviceKind::Ezgripper
            .table(Side::Left, &TableOverrides::default())
            .unwrap(),
    );
    let info = DeviceInfo {
        name: "grip".into(),
        kind: DeviceKind::Ezgripper,
        side: Side::Left,
        backend: Backend::Serial,
        table,
    };
    let dev = EzGripperDevice::start(info, bus.clone(), id, 50.0).unwrap();
    let pos = || emu.position_ticks(1).unwrap();
    let goal = || emu.register(1, reg::GOAL_POSITION).unwrap() as i32;

    // A: 70 % open, reached.
    dev.command(jaw_at(70.0, 1)).unwrap();
    wait_for("the jaw at 70 %", || ((pos() - ticks(70)).abs() < 40).then_some(()));

    // Unplugged: the pty closes. The client moves the jaw's target to 20 % meanwhile.
    emu.unplug();
    wait_for("the link is down", || (!bus.stats().connected).then_some(()));
    let at_unplug = pos();
    // The command is accepted (it is valid); whether it reaches anything is the point.
    let _ = dev.command(jaw_at(20.0, 2));

    // Replugged: the driver reconnects and polls again.
    emu.replug();
    wait_for("reconnected", || {
        (bus.stats().reconnects >= 1 && bus.stats().connected).then_some(())
    });
    let r0 = bus.latest(id).unwrap().round;
    let mut goals = Vec::new();
    wait_for("300 rounds after the replug", || {
        goals.push(goal());
        assert!(
            (pos() - ticks(20)).abs() > 200,
            "the jaw moved to {} ticks, toward the 20 % target set while unplugged ({}); it was at {at_unplug}",
            pos(),
            ticks(20)
        );
        (bus.latest(id).unwrap().round > r0 + 300).then_some(())
    });
    for g in &goals {
        assert!(
            (g - ticks(20)).abs() > 100,
            "goal {g} ticks sent after the replug: the 20 % target set while unplugged ({})",
            ticks(20)
        );
    }
    // Held where it was measured.
    let end = pos();
    assert!(
        (end - at_unplug).abs() < 60,
        "the jaw is at {end} ticks after the replug, it was at {at_unplug}"
    );
    assert!(
        (goal() - end).abs() < 60,
        "the goal on the bus ({}) is not a hold at the measured position {end}",
        goal()
    );

    // A new command moves it.
    dev.command(jaw_at(40.0, 3)).unwrap();
    wait_for("the jaw at 40 %", || ((pos() - ticks(40)).abs() < 40).then_some(()));
    dev.stop();
}
