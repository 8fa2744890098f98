//! Device loop + in-process emulator. Every wait polls a condition with a deadline; nothing
//! asserts timing figures.

use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::dex3::usb::adapter::{Dex3UsbDevice, UsbSource};
use handgate_adapters::dex3::usb::device_loop::{Dex3UsbHandle, Dex3UsbLoop, LoopConfig};
use handgate_adapters::dex3::usb::emulator::{lock, Dex3Emulator, EmulatorConfig, EmulatorTransport, SharedEmulator};
use handgate_adapters::dex3::usb::Align;
use handgate_adapters::dex3::{Dex3Command, Dex3Measurement, Joint, MotorCommand, Side};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{CommandBody, DeviceKind, Freshness, HandCommand, JointCommand, JointId};
use std::sync::{Arc, Mutex};
use std::time::Duration;

mod common;
use common::{wait_for, wait_meas};

const DEADLINE: Duration = Duration::from_secs(20);

fn setup(side: Side, cfg: LoopConfig) -> (SharedEmulator, Dex3UsbHandle) {
    let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(side, EmulatorConfig::default())));
    let h = Dex3UsbLoop::spawn(EmulatorTransport::factory(emu.clone()), cfg).unwrap();
    (emu, h)
}

fn all_present(m: &Dex3Measurement) -> bool {
    !m.stale && m.motors.iter().all(|m| m.present) && m.pads.iter().all(|p| p.present)
}

fn one_joint(base: [f32; 7], j: Joint, q: f32) -> Dex3Command {
    let mut c = Dex3Command::hold(base, 1.5, 0.1);
    *c.motor_mut(j) = MotorCommand {
        q,
        kp: 1.5,
        kd: 0.1,
        ..Default::default()
    };
    c
}

#[test]
fn commanded_joint_reaches_target() {
    let (emu, h) = setup(Side::Right, LoopConfig::default());
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    h.set_command(one_joint(m0.positions(), Joint::Index0, 1.0));
    let m = wait_meas(DEADLINE, &h, "index_0 at 1.0", |m| {
        (m.motor(Joint::Index0).q - 1.0).abs() < 0.02
    });
    assert!(!m.motor(Joint::Index0).timeout);
    assert!(m.imu.accel[2] > 9.0);
    let s = h.stats();
    assert!(s.good_frames > 0 && s.connects == 1 && s.reconnects == 0);
    assert!(s.period.count() > 0);
    // Every motor packet carried the timeout bit (default on), and the hand saw the target.
    let lc = lock(&emu).last_command(Joint::Index0).unwrap();
    assert!((lc.q - 1.0).abs() < 1e-3);
    h.stop();
}

#[test]
fn latest_command_wins() {
    let (_emu, h) = setup(Side::Left, LoopConfig::default());
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    for q in [-0.2, -0.4, -0.6, -1.2] {
        h.set_command(one_joint(m0.positions(), Joint::Middle1, q));
    }
    wait_meas(DEADLINE, &h, "middle_1 at -1.2", |m| {
        (m.motor(Joint::Middle1).q + 1.2).abs() < 0.02
    });
}

#[test]
fn timeout_bit_trips_when_commands_stop_and_clears_on_request() {
    let cfg = LoopConfig {
        failures_before_reconnect: u32::MAX,
        exchange_timeout: Duration::from_millis(5),
        ..LoopConfig::default()
    };
    let (emu, h) = setup(Side::Right, cfg);
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    h.set_command(one_joint(m0.positions(), Joint::Middle0, 0.8));
    wait_meas(DEADLINE, &h, "middle_0 at 0.8", |m| {
        (m.motor(Joint::Middle0).q - 0.8).abs() < 0.02
    });

    // Commands stop reaching the hand; 1.5 s pass on the hand's clock.
    lock(&emu).stall_for(Duration::from_secs(3600));
    wait_meas(DEADLINE, &h, "stale during the stall", |m| m.stale);
    lock(&emu).advance(Duration::from_millis(1500));
    assert!(lock(&emu).timed_out(Joint::Middle0));
    lock(&emu).clear_faults();

    // The loop keeps sending the bit: the trip stays latched and is reported.
    let m = wait_meas(DEADLINE, &h, "timeout reported", |m| {
        !m.stale && m.motor(Joint::Middle0).timeout
    });
    assert!(m.motors.iter().all(|m| m.timeout));
    let s = h.stats();
    assert!(s.timeouts > 0);
    assert_eq!(s.reconnects, 0);

    h.clear_timeouts();
    wait_meas(DEADLINE, &h, "timeout cleared", |m| {
        !m.stale && m.motors.iter().all(|m| !m.timeout)
    });
    h.set_command(one_joint(m0.positions(), Joint::Middle0, 0.3));
    wait_meas(DEADLINE, &h, "middle_0 follows again", |m| {
        (m.motor(Joint::Middle0).q - 0.3).abs() < 0.02
    });
}

#[test]
fn timeout_bit_can_be_disabled() {
    let cfg = LoopConfig {
        timeout_bit: false,
        ..LoopConfig::default()
    };
    let (emu, h) = setup(Side::Right, cfg);
    wait_meas(DEADLINE, &h, "first state", all_present);
    lock(&emu).stall_for(Duration::from_secs(3600));
    wait_meas(DEADLINE, &h, "stale during the stall", |m| m.stale);
    lock(&emu).advance(Duration::from_millis(1500));
    assert!(!lock(&emu).timed_out(Joint::Thumb0));
    lock(&emu).clear_faults();
    wait_meas(DEADLINE, &h, "fresh", |m| !m.stale);
}

#[test]
fn crc_burst_is_counted_and_last_good_state_kept_stale() {
    // No reconnect however long the burst lasts (the test thread may be descheduled).
    let cfg = LoopConfig {
        failures_before_reconnect: u32::MAX,
        ..LoopConfig::default()
    };
    let (emu, h) = setup(Side::Left, cfg);
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    h.set_command(one_joint(m0.positions(), Joint::Thumb2, 1.0));
    wait_meas(DEADLINE, &h, "thumb_2 at 1.0", |m| {
        (m.motor(Joint::Thumb2).q - 1.0).abs() < 0.02
    });

    lock(&emu).corrupt_frames(1_000_000);
    let bad0 = h.stats().frame_crc_errors;
    let m1 = wait_meas(DEADLINE, &h, "stale after corrupt frames", |m| m.stale);
    wait_for(DEADLINE, "20 more CRC errors", || {
        (h.stats().frame_crc_errors >= bad0 + 20).then_some(())
    });
    let m2 = h.latest();
    assert!(m2.stale);
    assert_eq!(m2.seq, m1.seq, "no corrupt frame may update the measurement");
    assert_eq!(m2.measured_at, m1.measured_at);
    assert_eq!(m2.positions(), m1.positions());
    assert!((m2.motor(Joint::Thumb2).q - 1.0).abs() < 0.02);
    assert_eq!(h.stats().reconnects, 0);

    lock(&emu).clear_faults();
    let m3 = wait_meas(DEADLINE, &h, "fresh again", |m| !m.stale);
    assert!(m3.seq > m2.seq);

    // Corrupt motor packets inside good frames: counted, the other joints still update.
    let pkt0 = h.stats().packet_crc_errors;
    lock(&emu).corrupt_motor_packets(10);
    wait_for(DEADLINE, "10 packet CRC errors", || {
        (h.stats().packet_crc_errors >= pkt0 + 10).then_some(())
    });
}

#[test]
fn unplug_replug_holds_measured_position_not_old_command() {
    let (emu, h) = setup(Side::Right, LoopConfig::default());
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    h.set_command(one_joint(m0.positions(), Joint::Thumb0, 0.8));
    wait_meas(DEADLINE, &h, "thumb_0 at 0.8", |m| {
        (m.motor(Joint::Thumb0).q - 0.8).abs() < 0.02
    });

    lock(&emu).unplug();
    wait_for(DEADLINE, "disconnected", || (!h.stats().connected).then_some(()));
    assert!(h.latest().stale);
    // While unplugged, somebody moves the finger.
    lock(&emu).set_joint_q(Joint::Thumb0, -0.5);
    let frames_before = lock(&emu).stats().frames_ok;
    lock(&emu).replug();

    wait_for(DEADLINE, "reconnected", || (h.stats().reconnects >= 1).then_some(()));
    wait_meas(DEADLINE, &h, "fresh after reconnect", all_present);
    wait_for(DEADLINE, "300 exchanges after the replug", || {
        (lock(&emu).stats().frames_ok > frames_before + 300).then_some(())
    });
    let lc = lock(&emu).last_command(Joint::Thumb0).unwrap();
    assert!((lc.q + 0.5).abs() < 0.01, "old command replayed: {lc:?}");
    assert_eq!(lc.kp, LoopConfig::default().hold_kp);
    let q = lock(&emu).joint_q(Joint::Thumb0);
    assert!((q + 0.5).abs() < 0.02, "joint moved to {q}");

    // A command set after the reconnect moves it.
    h.set_command(one_joint(h.latest().positions(), Joint::Thumb0, 0.3));
    wait_meas(DEADLINE, &h, "thumb_0 at 0.3", |m| {
        (m.motor(Joint::Thumb0).q - 0.3).abs() < 0.02
    });
}

#[test]
fn subscribe_sees_updates() {
    let (_emu, h) = setup(Side::Left, LoopConfig::default());
    let mut rx = h.subscribe();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .unwrap();
    rt.block_on(async {
        tokio::time::timeout(DEADLINE, async {
            loop {
                rx.changed().await.unwrap();
                if rx.borrow().seq > 10 {
                    break;
                }
            }
        })
        .await
        .expect("updates");
    });
}

#[test]
fn repeated_timeouts_reopen_the_transport() {
    let cfg = LoopConfig {
        exchange_timeout: Duration::from_millis(1),
        failures_before_reconnect: 5,
        ..LoopConfig::default()
    };
    let (emu, h) = setup(Side::Right, cfg);
    wait_meas(DEADLINE, &h, "first state", all_present);
    lock(&emu).drop_replies(20);
    wait_for(DEADLINE, "a reconnect after timeouts", || {
        (h.stats().reconnects >= 1).then_some(())
    });
    wait_meas(DEADLINE, &h, "fresh again", |m| !m.stale);
    let s = h.stats();
    assert!(s.timeouts >= 5, "timeouts {}", s.timeouts);
    assert_eq!(s.transport_errors, 0);
}

#[test]
fn invalid_configuration_is_refused() {
    let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(Side::Left, EmulatorConfig::default())));
    let mut bad = LoopConfig::default();
    bad.wiring.motors[1] = bad.wiring.motors[0];
    assert!(Dex3UsbLoop::spawn(EmulatorTransport::factory(emu.clone()), bad).is_err());
    let zero = LoopConfig {
        period: Duration::ZERO,
        ..LoopConfig::default()
    };
    assert!(Dex3UsbLoop::spawn(EmulatorTransport::factory(emu), zero).is_err());
}

// ---------------------------------------------------------------------------------------------
// Aligning the exchange to commands (`Align::Early`). The period is longer than any wait here
// (`LONG` > `DEADLINE`): the exchange that sends a command set after the connect's can only be
// an early one, so these wait on the measurement carrying the command and assert order, never
// durations (without the early exchange they fail at `DEADLINE`).

const LONG: Duration = Duration::from_secs(60);

fn early(min_gap_us: u64) -> LoopConfig {
    LoopConfig {
        period: LONG,
        align: Align::Early {
            min_gap: Duration::from_micros(min_gap_us),
        },
        ..LoopConfig::default()
    }
}

#[test]
fn early_sends_a_command_before_the_next_deadline() {
    let (emu, h) = setup(Side::Left, early(200));
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    assert_eq!(
        m0.seq, 1,
        "one exchange at the connect, the next deadline a minute away"
    );
    for (i, q) in [0.3f32, 0.5, 0.7].into_iter().enumerate() {
        let seq = h.set_command(one_joint(m0.positions(), Joint::Index0, q));
        let m = wait_meas(DEADLINE, &h, "the measurement carrying the command", |m| {
            m.cmd_seq == seq
        });
        // Exactly one exchange per command: the early one sent it.
        assert_eq!(m.seq, 2 + i as u64);
        let lc = lock(&emu).last_command(Joint::Index0).unwrap();
        assert!((lc.q - q).abs() < 1e-3, "the hand saw {}, not {q}", lc.q);
    }
    let s = h.stats();
    assert_eq!(s.early, 3);
    assert_eq!(s.cmd_wait.count(), 3);
    assert_eq!(s.misses, 0);
    h.stop();
}

#[test]
fn early_ignores_commands_set_before_the_connect() {
    // Off-grid wakes follow only commands the loop may send: one set before the connect is
    // never sent, so it wakes nothing (the loop stays on its minute-long grid).
    let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(Side::Right, EmulatorConfig::default())));
    lock(&emu).unplug();
    let h = Dex3UsbLoop::spawn(EmulatorTransport::factory(emu.clone()), early(200)).unwrap();
    wait_for(DEADLINE, "a failed connect", || {
        (h.stats().connect_failures > 0).then_some(())
    });
    let before = h.set_command(Dex3Command::damping(0.1));
    lock(&emu).replug();
    let m0 = wait_meas(DEADLINE, &h, "first state", all_present);
    let seq = h.set_command(one_joint(m0.positions(), Joint::Thumb1, 0.4));
    assert!(seq > before);
    let m = wait_meas(DEADLINE, &h, "the command after the connect", |m| m.cmd_seq == seq);
    assert_eq!(m.seq, m0.seq + 1);
    assert_eq!(h.stats().early, 1);
}

#[test]
fn early_device_echoes_a_client_command_before_the_next_deadline() {
    // The same through the adapter: a client command in, the state echoing its seq and tag
    // out, with the next scheduled exchange a minute away.
    let side = Side::Left;
    let table = Arc::new(DeviceKind::Dex3.table(side, &TableOverrides::default()).unwrap());
    let info = DeviceInfo {
        name: "align".into(),
        kind: DeviceKind::Dex3,
        side,
        backend: Backend::Emulator,
        table: table.clone(),
    };
    let dev = Dex3UsbDevice::start(info, UsbSource::Emulator(Box::default()), early(300)).unwrap();
    let rx = dev.state();
    wait_for(DEADLINE, "a fresh state", || {
        (rx.borrow().freshness == Freshness::Fresh).then_some(())
    });
    let j = table.joint_by_name("index_0").unwrap().index();
    for seq in 1..=3u64 {
        let body = CommandBody::Joints(vec![(JointId(j as u8), JointCommand::hold(0.2 * seq as f32, 1.5, 0.1))]);
        dev.command(HandCommand {
            seq,
            body,
            tag: 100 + seq as u32,
        })
        .unwrap();
        let (s, t) = wait_for(DEADLINE, "the state echoing the command", || {
            let st = rx.borrow();
            (st.cmd_seq == seq).then_some((st.cmd_seq, st.cmd_tag))
        });
        assert_eq!((s, t), (seq, 100 + seq as u32));
    }
    assert_eq!(
        dev.stats().state_samples,
        4,
        "the connect's exchange and one per command"
    );
}
