//! Driver tests over the pty emulator: the driver opens a real tty path, exactly as it
//! would open /dev/ttyUSB0. Every wait is a condition polled with a deadline.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::control_table::{reg, HardwareError, OperatingMode};
use super::driver::{BusConfig, Calibration, EzError, EzGripperBus, GraspState, GripperConfig, GripperState};
use super::emulator::{EmulatorConfig, Fault, ServoSpec, VirtualBus};
use crate::dynamixel::protocol::{Request, ServoId, Status, StatusError};
use crate::serial::transport::{SerialPort, Transport, TransportError};

const DEADLINE: Duration = Duration::from_secs(20);

fn link(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("handgate-ezg-{}-{name}", std::process::id()))
}

fn id(v: u8) -> ServoId {
    ServoId::new(v).unwrap()
}

/// Polls `f` until it returns Some or the deadline passes.
fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + DEADLINE;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn cfg(ids: &[(u8, Option<i32>)]) -> BusConfig {
    BusConfig {
        grippers: ids
            .iter()
            .map(|&(i, zero)| GripperConfig {
                id: id(i),
                zero_ticks: zero,
            })
            .collect(),
        calibrate_on_start: false,
        // Generous, so a starved emulator thread on a loaded CI machine is not a lost reply.
        response_timeout_ms: 100,
        ..Default::default()
    }
}

/// Opens the bus; a NoAnswer is retried, as a heavily loaded machine can starve the
/// emulator thread through all of `open`'s pings (the silent-bus case has its own test).
fn open(emu: &VirtualBus, c: BusConfig) -> EzGripperBus {
    let mut last = None;
    for _ in 0..5 {
        match EzGripperBus::open(emu.path(), c.clone()) {
            Ok(b) => return b,
            Err(e @ EzError::NoAnswer { .. }) => last = Some(e),
            Err(e) => panic!("open: {e}"),
        }
    }
    panic!("open: {last:?}");
}

fn fresh(bus: &EzGripperBus, i: u8, f: impl Fn(&GripperState) -> bool) -> GripperState {
    let end = Instant::now() + DEADLINE;
    loop {
        let s = bus.latest(id(i)).unwrap();
        if !s.stale && f(&s) {
            return s;
        }
        assert!(
            Instant::now() < end,
            "timed out waiting for a gripper {i} condition; last state {s:?}; {:?}",
            bus.stats()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn ezgripper_emulator_answers_raw_ping_and_enforces_access_rules() {
    let emu = VirtualBus::start(link("raw"), EmulatorConfig::with_ids(&[1])).unwrap();
    let mut port = SerialPort::open(emu.path(), 1_000_000).unwrap();
    let mut ask = |req: Request| -> Status {
        port.write_all(&req.encode().unwrap()).unwrap();
        let mut d = crate::dynamixel::protocol::Decoder::new();
        let mut buf = [0u8; 256];
        wait_for("status", || {
            let n = port.read(&mut buf, Duration::from_millis(5)).unwrap();
            d.push(&buf[..n]);
            d.next_frame().map(|f| Status::from_packet(&f.unwrap()).unwrap())
        })
    };
    let ping = ask(Request::Ping { id: 1 });
    assert_eq!(
        crate::dynamixel::protocol::le_u16(&ping.params),
        Some(311),
        "MX-64(2.0) model number"
    );
    // Read-only item.
    let st = ask(Request::Write {
        id: 1,
        addr: reg::PRESENT_POSITION.addr,
        data: vec![0; 4],
    });
    assert_eq!(st.error.number, crate::dynamixel::protocol::ErrorNumber::AccessError);
    // Half an item.
    let st = ask(Request::Write {
        id: 1,
        addr: reg::GOAL_POSITION.addr,
        data: vec![0; 2],
    });
    assert_eq!(
        st.error.number,
        crate::dynamixel::protocol::ErrorNumber::DataLengthError
    );
    // EEPROM with torque on.
    assert_eq!(
        ask(Request::Write {
            id: 1,
            addr: reg::TORQUE_ENABLE.addr,
            data: vec![1],
        })
        .error,
        StatusError::OK
    );
    let st = ask(Request::Write {
        id: 1,
        addr: reg::OPERATING_MODE.addr,
        data: vec![5],
    });
    assert_eq!(st.error.number, crate::dynamixel::protocol::ErrorNumber::AccessError);
}

#[test]
fn ezgripper_open_reports_missing_port_and_silent_bus() {
    let e = EzGripperBus::open("/nonexistent/ttyUSB7", cfg(&[(1, None)])).unwrap_err();
    assert!(matches!(e, EzError::Transport(TransportError::NotFound { .. })), "{e}");
    let emu = VirtualBus::start(link("silent"), EmulatorConfig::with_ids(&[5])).unwrap();
    let e = EzGripperBus::open(emu.path(), cfg(&[(1, None)])).unwrap_err();
    assert!(matches!(&e, EzError::NoAnswer { ids, .. } if ids == &vec![1]), "{e}");
    assert!(e.to_string().contains("no answer"));
}

#[test]
fn ezgripper_calibrates_against_the_closed_stop() {
    let emu = VirtualBus::start(link("cal"), EmulatorConfig::with_ids(&[1])).unwrap();
    let c = BusConfig {
        calibrate_on_start: true,
        ..cfg(&[(1, None)])
    };
    let bus = open(&emu, c);
    // The driver put the servo in current-based position mode with SAKE's settings.
    wait_for("init", || {
        (emu.register(1, reg::TORQUE_ENABLE) == Some(1)).then_some(())
    });
    assert_eq!(
        emu.register(1, reg::OPERATING_MODE),
        Some(OperatingMode::CurrentBasedPosition as i64)
    );
    assert_eq!(emu.register(1, reg::CURRENT_LIMIT), Some(1600));
    assert_eq!(emu.register(1, reg::RETURN_DELAY_TIME), Some(2));
    let s = fresh(&bus, 1, |s| matches!(s.calibration, Calibration::Calibrated { .. }));
    let zero = s.calibration.zero().unwrap();
    assert!((zero - 1000).abs() <= 5, "zero {zero}, closed stop at 1000");
    // Then it settles at 50 % like the SAKE driver.
    let s = fresh(&bus, 1, |s| (s.position_pct - 50.0).abs() < 2.0);
    assert!((emu.position_ticks(1).unwrap() - (zero + 1250)).abs() < 60, "{s:?}");
    // Calibration on demand while open: lands on the same stop.
    bus.calibrate(id(1)).unwrap();
    fresh(&bus, 1, |s| s.calibration == Calibration::Running);
    let s = fresh(&bus, 1, |s| matches!(s.calibration, Calibration::Calibrated { .. }));
    assert!(
        (s.calibration.zero().unwrap() - 1000).abs() <= 5,
        "{s:?} servo at {:?}, {:?}",
        emu.position_ticks(1),
        bus.stats()
    );
}

#[test]
fn ezgripper_tracks_position_targets() {
    let emu = VirtualBus::start(link("track"), EmulatorConfig::with_ids(&[1])).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000))]));
    let g = bus.gripper(id(1)).unwrap();
    for target in [80.0, 20.0, 55.0] {
        g.set_target(target, 60.0).unwrap();
        let s = fresh(&bus, 1, |s| {
            (s.position_pct - target).abs() < 1.5 && s.grasp == GraspState::Idle
        });
        let truth = emu.position_ticks(1).unwrap();
        assert!(
            (truth - (1000 + (target * 25.0) as i32)).abs() < 40,
            "target {target}: servo at {truth}, {s:?}"
        );
        assert_eq!(s.target.unwrap().position_pct, target);
    }
    // Force % maps onto Goal Current (100 % = the 1600-unit current limit).
    assert_eq!(emu.register(1, reg::GOAL_CURRENT), Some(960));
    assert!(g.set_target(f32::NAN, 10.0).is_err());
    assert!(matches!(bus.gripper(id(9)), Err(EzError::UnknownGripper(9))));
}

/// `[devices.emulator] object_at = { jaw = 3.0 }` (44 % open) reaches the virtual bus the
/// emulator backend opens: closing stops at the object and the driver reports grasping;
/// without it the same close ends idle near 0 %.
#[test]
fn profile_object_at_stops_the_jaw_and_grasps() {
    use crate::device::Backend;
    use crate::kind::DeviceKind;
    use crate::model::Side;
    use crate::open::{DeviceSpec, EmulatorSection};
    let run = |name: &str, object: Option<f64>| {
        let profile = super::config::EzProfile::default();
        let table = std::sync::Arc::new(DeviceKind::Ezgripper.table(Side::Left, &Default::default()).unwrap());
        let mut section = EmulatorSection::default();
        if let Some(o) = object {
            section.object_at.insert("jaw".into(), o);
        }
        let spec = DeviceSpec {
            name: "g",
            kind: DeviceKind::Ezgripper,
            side: Side::Left,
            backend: Backend::Emulator,
            rate_hz: 100.0,
            stale_after: Duration::from_millis(200),
            forward_on_arrival: true,
            max_send_hz: None,
            table: &table,
            emulator: &section,
            config: &profile,
        };
        let specs = [spec];
        let mut bc = super::open::bus_config(&specs).unwrap();
        let emu = VirtualBus::start(link(name), super::open::emulator_config(&specs, &bc).unwrap()).unwrap();
        bc.response_timeout_ms = 100;
        let bus = open(&emu, bc);
        let gid = super::open::configure(&spec).unwrap().id;
        let g = bus.gripper(gid).unwrap();
        fresh(&bus, gid.get(), |s| {
            matches!(s.calibration, Calibration::Calibrated { .. })
        });
        g.set_target(80.0, 40.0).unwrap();
        fresh(&bus, gid.get(), |s| {
            s.grasp == GraspState::Idle && s.position_pct > 75.0
        });
        let mut rx = g.subscribe();
        g.set_target(0.0, 40.0).unwrap();
        let mut seen_moving = false;
        wait_for("the close to end", || {
            if rx.has_changed().unwrap_or(false) {
                let s = rx.borrow_and_update().clone();
                if s.stale {
                    // A reply missed on a loaded machine: not a measurement of the close.
                    return None;
                }
                seen_moving |= s.grasp == GraspState::Moving;
                let done = s.grasp == GraspState::Grasping || (seen_moving && s.grasp == GraspState::Idle);
                return done.then_some(s);
            }
            None
        })
    };
    let pct = 100.0 * (5.4 - 3.0) / 5.4;
    let s = run("profile-object", Some(3.0));
    assert_eq!(s.grasp, GraspState::Grasping, "{s:?}");
    assert!(
        (s.position_pct - pct).abs() < 3.0,
        "stopped by the object at {pct} %: {s:?}"
    );
    assert!(s.effort_pct > 20.0, "pressing on the object: {s:?}");
    let s = run("profile-no-object", None);
    assert_eq!(s.grasp, GraspState::Idle, "{s:?}");
    assert!(s.position_pct < 3.0, "closed: {s:?}");
}

#[test]
fn ezgripper_detects_contact_and_grasp() {
    let mut ec = EmulatorConfig::with_ids(&[1]);
    ec.servos[0] = ServoSpec {
        object_at_ticks: Some(1000), // 40 % open
        ..ServoSpec::new(1)
    };
    let emu = VirtualBus::start(link("grasp"), ec).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000))]));
    let g = bus.gripper(id(1)).unwrap();
    let mut rx = g.subscribe();
    g.set_target(0.0, 40.0).unwrap();
    let mut seen_moving = false;
    let s = wait_for("grasping", || {
        if rx.has_changed().unwrap_or(false) {
            let s = rx.borrow_and_update().clone();
            seen_moving |= s.grasp == GraspState::Moving;
            return (s.grasp == GraspState::Grasping).then_some(s);
        }
        None
    });
    assert!(seen_moving, "closing should report moving before the grasp");
    assert!(
        (s.position_pct - 40.0).abs() < 3.0,
        "stopped by the object at 40 %: {s:?}"
    );
    assert!(s.effort_pct > 20.0, "pressing on the object: {s:?}");
    // Opening releases it.
    g.set_target(90.0, 40.0).unwrap();
    fresh(&bus, 1, |s| s.grasp == GraspState::Moving);
    fresh(&bus, 1, |s| {
        s.grasp == GraspState::Idle && (s.position_pct - 90.0).abs() < 2.0
    });
    // Without the object the same close ends idle at 0 %.
    emu.set_object(1, None);
    g.set_target(0.0, 40.0).unwrap();
    fresh(&bus, 1, |s| s.grasp == GraspState::Idle && s.position_pct < 2.0);
}

#[test]
fn ezgripper_reports_faults_and_recovers() {
    let emu = VirtualBus::start(link("faults"), EmulatorConfig::with_ids(&[1])).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000))]));
    let g = bus.gripper(id(1)).unwrap();
    g.set_target(60.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 60.0).abs() < 2.0);

    // No reply: counted as timeouts, then fresh data again.
    let before = bus.stats().per_gripper[&1];
    emu.inject(Fault::NoReply { id: 1, count: 3 });
    wait_for("timeouts", || {
        (bus.stats().per_gripper[&1].timeouts >= before.timeouts + 3).then_some(())
    });
    let r = bus.latest(id(1)).unwrap().round;
    fresh(&bus, 1, |s| s.round > r + 2);

    // Bad CRC: counted, then fresh data again.
    let before = bus.stats();
    emu.inject(Fault::BadCrc { id: 1, count: 3 });
    wait_for("crc errors", || {
        (bus.stats().crc_errors >= before.crc_errors + 3).then_some(())
    });
    assert!(bus.stats().per_gripper[&1].crc_errors >= 3);
    let r = bus.latest(id(1)).unwrap().round;
    fresh(&bus, 1, |s| s.round > r + 2);

    // Overload: the alert bit leads to Hardware Error Status, reported with its name.
    emu.inject(Fault::Overload { id: 1 });
    let s = fresh(&bus, 1, |s| s.hardware_error.contains(HardwareError::OVERLOAD));
    assert!(s.last_error.as_deref().unwrap_or("").contains("overload"), "{s:?}");
    assert!(bus.stats().per_gripper[&1].hardware_alerts > 0);
    // Torque is off: a new target is not followed...
    assert_eq!(emu.register(1, reg::TORQUE_ENABLE), Some(0));
    // ...until a reboot clears the error and the driver re-initialises the servo.
    g.reboot();
    fresh(&bus, 1, |s| s.hardware_error.is_empty());
    g.set_target(30.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 30.0).abs() < 2.0);
    assert_eq!(emu.register(1, reg::TORQUE_ENABLE), Some(1));
    assert_eq!(emu.stats().reboots, 1);
}

#[test]
fn ezgripper_reconnects_after_unplug() {
    let emu = VirtualBus::start(link("unplug"), EmulatorConfig::with_ids(&[1])).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000))]));
    let g = bus.gripper(id(1)).unwrap();
    g.set_target(70.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 70.0).abs() < 2.0);
    emu.unplug();
    wait_for("disconnect", || (!bus.stats().connected).then_some(()));
    wait_for("stale", || bus.latest(id(1)).unwrap().stale.then_some(()));
    assert!(bus.stats().disconnects >= 1);
    assert!(!emu.path().exists(), "the device path is gone while unplugged");
    emu.replug();
    wait_for("reconnect", || {
        (bus.stats().reconnects >= 1 && bus.stats().connected).then_some(())
    });
    let r = bus.latest(id(1)).unwrap().round;
    fresh(&bus, 1, |s| s.round > r);
    g.set_target(25.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 25.0).abs() < 2.0);
}

#[test]
fn ezgripper_serves_two_grippers_in_one_round() {
    let emu = VirtualBus::start(link("two"), EmulatorConfig::with_ids(&[1, 2])).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000)), (2, Some(1000))]));
    bus.gripper(id(1)).unwrap().set_target(30.0, 50.0).unwrap();
    bus.gripper(id(2)).unwrap().set_target(70.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 30.0).abs() < 2.0);
    fresh(&bus, 2, |s| (s.position_pct - 70.0).abs() < 2.0);
    // Both grippers were read by the same sync read packets, round after round...
    wait_for("sync reads of both ids", || {
        let stats = emu.stats();
        (stats.sync_reads_by_ids.get(&vec![1, 2]).copied().unwrap_or(0) >= 10).then_some(())
    });
    // (Not every sync read needs to list both: on a starved machine a gripper can miss its
    // init replies and join a few rounds later.)
    // ...so their measurements come from the same rounds.
    wait_for("same round", || {
        let (a, b) = (bus.latest(id(1)).unwrap(), bus.latest(id(2)).unwrap());
        (a.round == b.round && a.measured_at == b.measured_at).then_some(())
    });
    let st = bus.stats();
    let (c1, c2) = (st.per_gripper[&1], st.per_gripper[&2]);
    if c1.inits == 1 && c2.inits == 1 {
        // Neither went offline (which a heavily loaded machine can cause), so every round
        // polled both.
        assert_eq!(c1.polls, st.rounds, "{st:?}");
        assert_eq!(c2.polls, st.rounds, "{st:?}");
    }
    wait_for("samples of both", || {
        let st = bus.stats();
        (st.per_gripper[&1].samples >= 10 && st.per_gripper[&2].samples >= 10).then_some(())
    });
    // Round periods are kept once asked for, never before.
    assert!(bus.take_round_periods().is_empty(), "none kept unasked");
    let mut periods = Vec::new();
    wait_for("round periods recorded", || {
        periods.extend(bus.take_round_periods());
        (periods.len() > 5).then_some(())
    });
    // A silent gripper does not hold up the other one.
    let r2 = bus.latest(id(2)).unwrap().round;
    emu.inject(Fault::NoReply { id: 1, count: 4 });
    wait_for("timeouts on 1", || {
        (bus.stats().per_gripper[&1].timeouts >= c1.timeouts + 4).then_some(())
    });
    fresh(&bus, 2, |s| s.round > r2 + 4);
    fresh(&bus, 1, |s| s.round > r2 + 4);
}

#[test]
fn ezgripper_uncalibrated_gripper_holds_until_calibrated() {
    let emu = VirtualBus::start(link("uncal"), EmulatorConfig::with_ids(&[1])).unwrap();
    let bus = open(&emu, cfg(&[(1, None)]));
    let g = bus.gripper(id(1)).unwrap();
    let s = fresh(&bus, 1, |s| s.round > 2);
    assert_eq!(s.calibration, Calibration::Uncalibrated);
    let start = emu.position_ticks(1).unwrap();
    g.set_target(0.0, 50.0).unwrap();
    let r = bus.latest(id(1)).unwrap().round;
    let s = fresh(&bus, 1, |s| s.round > r + 50);
    assert!(
        (emu.position_ticks(1).unwrap() - start).abs() < 10,
        "moved without a zero"
    );
    assert_eq!(s.target, None);
    assert_eq!(s.position_pct, 0.0);
    g.calibrate();
    fresh(&bus, 1, |s| matches!(s.calibration, Calibration::Calibrated { .. }));
    g.set_target(80.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 80.0).abs() < 1.5);
}

#[test]
fn ezgripper_ignores_the_echo_of_a_half_duplex_adapter() {
    let mut ec = EmulatorConfig::with_ids(&[1, 2]);
    ec.echo = true;
    let emu = VirtualBus::start(link("echo"), ec).unwrap();
    let bus = open(&emu, cfg(&[(1, Some(1000)), (2, Some(1000))]));
    bus.gripper(id(1)).unwrap().set_target(35.0, 50.0).unwrap();
    bus.gripper(id(2)).unwrap().set_target(65.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 35.0).abs() < 2.0);
    fresh(&bus, 2, |s| (s.position_pct - 65.0).abs() < 2.0);
    let st = bus.stats();
    assert_eq!(st.crc_errors, 0, "{st:?}");
}

/// The in-process bus (what an emulated gripper of a profile runs on): the same driver over
/// [`VirtualBus::in_process`]'s transport tracks targets, grasps two grippers in one round
/// with the line's timing, takes injected missed replies and CRC errors, and reconnects after
/// an unplug without replaying a target.
#[test]
fn in_process_bus_tracks_faults_and_reconnects() {
    let (emu, connector) = VirtualBus::in_process(EmulatorConfig::with_ids(&[1, 2]));
    let mut c = cfg(&[(1, Some(1000)), (2, Some(1000))]);
    // On the bus thread itself nothing is late for want of a CPU: the real default grace.
    c.response_timeout_ms = BusConfig::default().response_timeout_ms;
    let bus = EzGripperBus::with_connector(connector, c).unwrap();
    assert!(emu.path().as_os_str().is_empty());
    let (g1, g2) = (bus.gripper(id(1)).unwrap(), bus.gripper(id(2)).unwrap());
    g1.set_target(30.0, 50.0).unwrap();
    g2.set_target(70.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 30.0).abs() < 2.0);
    fresh(&bus, 2, |s| (s.position_pct - 70.0).abs() < 2.0);
    wait_for("same round", || {
        let (a, b) = (bus.latest(id(1)).unwrap(), bus.latest(id(2)).unwrap());
        (a.round == b.round && a.measured_at == b.measured_at).then_some(())
    });
    // The line's time: a round (sync write of 2 goals, sync read of 2 present blocks) takes
    // at least its wire time, so at most this many rounds a second.
    let st = bus.stats();
    let r0 = (st.rounds, Instant::now());
    wait_for("rounds", || (bus.stats().rounds > r0.0 + 200).then_some(()));
    let hz = (bus.stats().rounds - r0.0) as f64 / r0.1.elapsed().as_secs_f64();
    // Sync write: 12 bytes + (id + goal block) per servo; sync read: 14 + an id per servo;
    // a status: 11 + the present block.
    let (goal, present) = (
        super::control_table::GOAL_BLOCK.len as usize,
        super::control_table::PRESENT_BLOCK.len as usize,
    );
    let wire = crate::dynamixel::protocol::wire_time(12 + 2 * (1 + goal) + 14 + 2 + 2 * (11 + present), 1_000_000);
    assert!(
        hz < 1.0 / wire.as_secs_f64(),
        "{hz:.0} rounds/s is faster than the line allows"
    );
    let t0 = bus.stats().per_gripper[&1].timeouts;
    emu.inject(Fault::NoReply { id: 1, count: 3 });
    wait_for("missed replies", || {
        (bus.stats().per_gripper[&1].timeouts >= t0 + 3).then_some(())
    });
    let c0 = bus.stats().per_gripper[&2].crc_errors;
    emu.inject(Fault::BadCrc { id: 2, count: 2 });
    wait_for("CRC errors", || {
        (bus.stats().per_gripper[&2].crc_errors >= c0 + 2).then_some(())
    });
    emu.unplug();
    wait_for("disconnect", || (!bus.stats().connected).then_some(()));
    wait_for("stale", || bus.latest(id(1)).unwrap().stale.then_some(()));
    emu.replug();
    wait_for("reconnect", || {
        (bus.stats().reconnects >= 1 && bus.stats().connected).then_some(())
    });
    let r = bus.latest(id(1)).unwrap().round;
    fresh(&bus, 1, |s| s.round > r);
    g1.set_target(50.0, 50.0).unwrap();
    fresh(&bus, 1, |s| (s.position_pct - 50.0).abs() < 2.0);
}
