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
use handgate_adapters::ezgripper::emulator::{EmulatorConfig, Fault, VirtualBus};
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

/// The bus's reply grace, ms (the emulated servo shares a loaded machine's CPU).
const RESPONSE_TIMEOUT_MS: u64 = 100;

/// An emulated bus at `tag` with servo 1 at [`ZERO`], its driver and the device on it.
fn gripper(tag: &str) -> (VirtualBus, Arc<EzGripperBus>, EzGripperDevice) {
    let path: PathBuf = std::env::temp_dir().join(format!("handgate-ezg-{tag}-{}", std::process::id()));
    let emu = VirtualBus::start(&path, EmulatorConfig::with_ids(&[1])).unwrap();
    let id = ServoId::new(1).unwrap();
    let cfg = BusConfig {
        grippers: vec![GripperConfig {
            id,
            zero_ticks: Some(ZERO),
        }],
        calibrate_on_start: false,
        response_timeout_ms: RESPONSE_TIMEOUT_MS,
        // The devices' bound (the gateway passes the device's `stale_after`).
        stale_after_ms: 200,
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
    (emu, bus, dev)
}

#[test]
fn a_target_set_while_unplugged_or_before_is_never_sent_after_the_replug() {
    let (emu, bus, dev) = gripper("replug");
    let id = ServoId::new(1).unwrap();
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

/// A reply that does not come (a late status on a loaded host, a USB hiccup) is not an unplug:
/// while its last measurement is younger than `stale_after` (one missed reply: the reply grace
/// later) and fewer replies than `offline_after_misses` were missed in a row, the gripper's
/// state stays fresh, nothing is reseeded, the servo is not re-initialised and the client's
/// next target is applied. Before issue #26 every
/// missed reply marked the state stale, and the next reply reseeded the device: a hold, the
/// client's target dropped.
#[test]
fn a_few_missed_replies_are_not_an_unplug() {
    let (emu, bus, dev) = gripper("late");
    let id = ServoId::new(1).unwrap();
    let pos = || emu.position_ticks(1).unwrap();
    dev.command(jaw_at(70.0, 1)).unwrap();
    wait_for("the jaw at 70 %", || ((pos() - ticks(70)).abs() < 40).then_some(()));
    let before = dev.stats();
    let st0 = bus.stats().per_gripper[&1];
    let misses = 1;
    assert!(misses * RESPONSE_TIMEOUT_MS < 200 && (misses as u32) < BusConfig::default().offline_after_misses);
    let misses = misses as u32;
    emu.inject(Fault::NoReply { id: 1, count: misses });
    wait_for("the missed replies", || {
        (bus.stats().per_gripper[&1].timeouts >= st0.timeouts + u64::from(misses)).then_some(())
    });
    let r0 = bus.latest(id).unwrap().round;
    wait_for("replies again", || {
        (bus.latest(id).unwrap().round > r0 + 20).then_some(())
    });
    dev.command(jaw_at(40.0, 2)).unwrap();
    wait_for("the jaw at 40 %", || ((pos() - ticks(40)).abs() < 40).then_some(()));
    let after = dev.stats();
    assert_eq!(
        after.reseeds, before.reseeds,
        "a missed reply reseeded the gripper: {after:?}"
    );
    assert_eq!(
        after.stale_events, before.stale_events,
        "a missed reply made the state stale: {after:?}"
    );
    assert_eq!(
        bus.stats().per_gripper[&1].inits,
        st0.inits,
        "re-initialised: {:?}",
        bus.stats()
    );
    dev.stop();
}
