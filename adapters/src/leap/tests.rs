//! The LEAP Hand's servos, emulator and device loop, against each other.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::control_table::{DEFAULT_IDS, PRESENT_BLOCK};
use super::device::{LeapBusConfig, LeapDevice};
use super::emulator::{in_process, EmulatorConfig, LeapEmulator};
use crate::device::{Backend, DeviceInfo, HandDevice};
use crate::dynamixel::control_table::reg;
use crate::dynamixel::protocol::{
    decode_all, fast_sync_entries, is_fast_reply, ErrorNumber, Request, Status, StatusRef,
};
use crate::model::{DeviceKind, Freshness, HandCommand, Side};
use crate::sim::Noise;

const DEADLINE: Duration = Duration::from_secs(10);

fn exact() -> EmulatorConfig {
    let mut c = EmulatorConfig::with_ids(&DEFAULT_IDS);
    c.noise = Noise::OFF;
    c
}

/// Sends `req` to `emu` at `now`; the statuses it answers with.
fn ask(emu: &mut LeapEmulator, req: &Request, now: Instant) -> Vec<Status> {
    let mut out = Vec::new();
    emu.feed(&req.encode().unwrap(), now, &mut out);
    decode_all(&out)
        .into_iter()
        .map(|f| Status::from_packet(&f.unwrap()).unwrap())
        .collect()
}

#[test]
fn leap_servos_answer_ping_read_write_and_refuse_what_a_servo_refuses() {
    let mut emu = LeapEmulator::new(&exact());
    let now = Instant::now();
    let pong = ask(&mut emu, &Request::Ping { id: 5 }, now);
    assert_eq!(pong.len(), 1);
    assert_eq!(pong[0].params[..2], 1240u16.to_le_bytes(), "XC330-M288");
    let all = ask(&mut emu, &Request::Ping { id: 0xFE }, now);
    assert_eq!(all.iter().map(|s| s.id).collect::<Vec<_>>(), DEFAULT_IDS.to_vec());
    // Flat: 180° = 2048 ticks.
    let pos = ask(
        &mut emu,
        &Request::Read {
            id: 3,
            addr: 132,
            len: 4,
        },
        now,
    );
    assert_eq!(pos[0].params, 2048i32.to_le_bytes());
    // A read-only item refuses a write; EEPROM refuses one under torque; RAM takes it.
    let w = |id, addr, data: &[u8]| Request::Write {
        id,
        addr,
        data: data.to_vec(),
    };
    assert_eq!(
        ask(&mut emu, &w(1, 132, &[0, 0, 0, 0]), now)[0].error.number,
        ErrorNumber::AccessError
    );
    assert_eq!(ask(&mut emu, &w(1, 11, &[5]), now)[0].error.number, ErrorNumber::None);
    assert_eq!(ask(&mut emu, &w(1, 64, &[1]), now)[0].error.number, ErrorNumber::None);
    assert_eq!(
        ask(&mut emu, &w(1, 11, &[3]), now)[0].error.number,
        ErrorNumber::AccessError
    );
    assert_eq!(emu.bus().servo(1).unwrap().get(reg::OPERATING_MODE), 5);
    assert_eq!(
        ask(&mut emu, &w(1, 660, &[0, 0, 0]), now)[0].error.number,
        ErrorNumber::DataLengthError
    );
    // Sync write reaches each listed servo, and answers nothing.
    let sw = Request::SyncWrite {
        addr: 102,
        len: 2,
        entries: DEFAULT_IDS
            .iter()
            .map(|&id| (id, (300 + id as u16).to_le_bytes().to_vec()))
            .collect(),
    };
    assert!(ask(&mut emu, &sw, now).is_empty());
    assert_eq!(emu.bus().servo(15).unwrap().get(reg::GOAL_CURRENT), 315);
}

/// The LEAP's read: present current..position (126, 10 bytes) of all 16, as 16 statuses
/// (Sync Read) or as one packet (Fast Sync Read), the same bytes either way.
#[test]
fn leap_sync_read_and_fast_sync_read_return_the_same_blocks() {
    let mut emu = LeapEmulator::new(&exact());
    let now = Instant::now();
    let ids = DEFAULT_IDS.to_vec();
    let (addr, len) = (PRESENT_BLOCK.addr, PRESENT_BLOCK.len);
    let slow = ask(
        &mut emu,
        &Request::SyncRead {
            addr,
            len,
            ids: ids.clone(),
        },
        now,
    );
    assert_eq!(slow.len(), 16);
    let mut out = Vec::new();
    emu.feed(
        &Request::FastSyncRead { addr, len, ids }.encode().unwrap(),
        now,
        &mut out,
    );
    let frames = decode_all(&out);
    assert_eq!(frames.len(), 1, "one packet for all 16");
    let pk = frames[0].clone().unwrap();
    assert!(is_fast_reply(pk.id, pk.instruction));
    let fast: Vec<(u8, Vec<u8>)> = fast_sync_entries(&pk.params, 10)
        .unwrap()
        .map(|e| (e.id, e.data.to_vec()))
        .collect();
    let slow: Vec<(u8, Vec<u8>)> = slow.into_iter().map(|s| (s.id, s.params)).collect();
    assert_eq!(fast, slow);
    // A Fast Sync Read naming a servo that is not on the bus is not answered.
    let mut out = Vec::new();
    emu.feed(
        &Request::FastSyncRead {
            addr,
            len,
            ids: vec![0, 40],
        }
        .encode()
        .unwrap(),
        now,
        &mut out,
    );
    assert!(out.is_empty());
    assert_eq!(emu.stats().bus.fast_sync_reads, 2);
    // Garbage and a bad CRC are counted, never answered.
    let mut bad = Request::Ping { id: 1 }.encode().unwrap();
    let n = bad.len();
    bad[n - 1] ^= 0xFF;
    let mut out = Vec::new();
    emu.feed(&[0x00, 0x13, 0x37], now, &mut out);
    emu.feed(&bad, now, &mut out);
    assert!(out.is_empty());
    assert_eq!(emu.stats().decoder.bad_crc, 1);
    assert!(emu.stats().decoder.garbage_bytes >= 3);
}

/// With torque on in current-based position mode a joint goes to its goal; an object stops it
/// short, the servo pushing at its goal current.
#[test]
fn leap_emulated_joint_follows_its_goal_and_an_object_stops_it_at_the_current_limit() {
    let mut cfg = exact();
    cfg.servos[1].object_at_rad = Some(std::f32::consts::PI + 0.8);
    let mut emu = LeapEmulator::new(&cfg);
    let t0 = Instant::now();
    let goal = 2048 + 1000; // 1.53 rad past flat
    let sw = |addr: u16, len: u16, v: i64| Request::SyncWrite {
        addr,
        len,
        entries: DEFAULT_IDS
            .iter()
            .map(|&id| (id, v.to_le_bytes()[..len as usize].to_vec()))
            .collect(),
    };
    for req in [
        sw(11, 1, 5),
        sw(84, 2, 600),
        sw(80, 2, 200),
        sw(102, 2, 350),
        sw(116, 4, goal),
        sw(64, 1, 1),
    ] {
        ask(&mut emu, &req, t0);
    }
    let mut t = t0;
    for _ in 0..1000 {
        t += Duration::from_millis(2);
        emu.step_to(t);
    }
    let free = emu.position(2).unwrap();
    assert!(
        (free - (goal as f32 * super::control_table::RAD_PER_TICK)).abs() < 0.02,
        "{free}"
    );
    let blocked = emu.position(1).unwrap();
    assert!((blocked - (std::f32::consts::PI + 0.8)).abs() < 0.05, "{blocked}");
    let cur = emu.bus().servo(1).unwrap().get(reg::PRESENT_CURRENT);
    assert!((300..=350).contains(&cur), "pushing at the goal current: {cur} mA");
    let free_cur = emu.bus().servo(2).unwrap().get(reg::PRESENT_CURRENT);
    assert!(free_cur.abs() < 100, "{free_cur}");
}

fn info() -> DeviceInfo {
    DeviceInfo {
        name: "leap".into(),
        kind: DeviceKind::Leap,
        side: Side::Right,
        backend: Backend::Emulator,
        table: Arc::new(super::table::table(Side::Right)),
    }
}

fn wait_for(dev: &LeapDevice, what: &str, ok: impl Fn(&crate::model::HandState) -> bool) {
    let mut rx = dev.state();
    let end = Instant::now() + DEADLINE;
    while !ok(&rx.borrow_and_update()) {
        assert!(Instant::now() < end, "{what}: {:?}", *rx.borrow());
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn device_closes_the_hand(fast: bool) {
    let (emu, connector) = in_process(exact());
    let cfg = LeapBusConfig {
        fast_sync_read: fast,
        ..Default::default()
    };
    let dev = LeapDevice::start(info(), connector, cfg).unwrap();
    wait_for(&dev, "fresh", |s| s.freshness == Freshness::Fresh);
    {
        // The LEAP's init reached every servo.
        let e = emu.lock().unwrap();
        for s in &e.bus().servos {
            assert_eq!(s.get(reg::OPERATING_MODE), 5, "id {}", s.id);
            assert_eq!(s.get(reg::RETURN_DELAY_TIME), 0);
            assert_eq!(s.get(reg::GOAL_CURRENT), 350);
            assert_eq!(s.get(reg::POSITION_I_GAIN), 0);
            let side = [0, 4, 8].contains(&s.id);
            assert_eq!(s.get(reg::POSITION_P_GAIN), if side { 450 } else { 600 });
            assert_eq!(s.get(reg::POSITION_D_GAIN), if side { 150 } else { 200 });
            assert_eq!(s.get(reg::TORQUE_ENABLE), 1);
            assert_eq!(s.get(reg::GOAL_POSITION), 2048, "the goal is where it stood");
        }
        let st = e.stats().bus;
        if fast {
            assert!(st.fast_sync_reads > 0 && st.sync_reads == 0, "{st:?}");
        } else {
            assert!(st.sync_reads > 0 && st.fast_sync_reads == 0, "{st:?}");
        }
    }
    // Flat reads 0 rad on every joint (180° on the motor).
    assert!(dev.state().borrow().joints.iter().all(|j| j.q.abs() < 0.01));
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    let closed = |s: &crate::model::HandState| {
        s.cmd_seq == 1
            && s.joints
                .iter()
                .zip(super::table::CLOSED)
                .all(|(j, c)| (j.q - c).abs() < 0.05)
    };
    wait_for(&dev, "every joint at the closed posture", closed);
    assert!(dev.state().borrow().closure > 0.95);
    let e = emu.lock().unwrap();
    let goal = e.bus().servo(1).unwrap().get(reg::GOAL_POSITION);
    assert_eq!(
        goal,
        super::control_table::rad_to_ticks(std::f32::consts::PI + 1.6) as i64
    );
    drop(e);
    let s = dev.stats();
    assert!(s.state_samples > 0 && s.sent > 0, "{s:?}");
}

#[test]
fn leap_device_initialises_reads_and_closes_the_emulated_hand_with_sync_read() {
    device_closes_the_hand(false);
}

#[test]
fn leap_device_initialises_reads_and_closes_the_emulated_hand_with_fast_sync_read() {
    device_closes_the_hand(true);
}

#[test]
fn leap_status_ref_of_a_sync_read_reply_is_the_block() {
    let mut emu = LeapEmulator::new(&exact());
    let mut out = Vec::new();
    emu.feed(
        &Request::SyncRead {
            addr: 126,
            len: 10,
            ids: vec![7],
        }
        .encode()
        .unwrap(),
        Instant::now(),
        &mut out,
    );
    let pk = decode_all(&out).pop().unwrap().unwrap();
    let st = StatusRef::from_packet((&pk).into()).unwrap();
    assert_eq!(st.params.len(), 10);
    assert_eq!(st.params[6..10], 2048i32.to_le_bytes());
}

/// The virtual bus's session: a goal write to some servos becomes one command naming those
/// servos; a read answers from the image; garbage, a bad CRC and an impossible length are
/// refused with their reason, and a half packet waits for the rest.
#[test]
fn leap_bus_session_turns_goal_writes_into_commands_and_refuses_bad_input() {
    use super::front::{BusSession, GoalWrite};
    use crate::front::stream::Session;
    let image = Arc::new(std::sync::Mutex::new(super::servos::ServoBus::new(&DEFAULT_IDS)));
    let mut s = BusSession::new(image.clone());
    let now = Instant::now();
    let mut out = Vec::new();
    let mut got: Vec<GoalWrite> = Vec::new();
    let goals = Request::SyncWrite {
        addr: 116,
        len: 4,
        entries: vec![
            (1, 2500i32.to_le_bytes().to_vec()),
            (13, 1900i32.to_le_bytes().to_vec()),
        ],
    }
    .encode()
    .unwrap();
    assert_eq!(s.on_bytes(&goals, now, &mut out, &mut |m| got.push(m)), Ok(goals.len()));
    assert!(out.is_empty(), "a sync write is not answered");
    assert_eq!(got.len(), 1);
    let want: Vec<(usize, i32)> = got[0]
        .goals
        .iter()
        .enumerate()
        .filter_map(|(i, g)| g.map(|g| (i, g)))
        .collect();
    assert_eq!(want, vec![(1, 2500), (13, 1900)]);
    // Another item written is no command.
    let gains = Request::Write {
        id: 2,
        addr: 84,
        data: vec![0x58, 0x02],
    }
    .encode()
    .unwrap();
    assert_eq!(s.on_bytes(&gains, now, &mut out, &mut |m| got.push(m)), Ok(gains.len()));
    assert_eq!(got.len(), 1);
    assert_eq!(image.lock().unwrap().servo(2).unwrap().get(reg::POSITION_P_GAIN), 600);
    let st = decode_all(&out);
    assert_eq!(st.len(), 1, "the write's status");
    // Half a packet: nothing consumed yet.
    let read = Request::Read {
        id: 4,
        addr: 132,
        len: 4,
    }
    .encode()
    .unwrap();
    assert_eq!(s.on_bytes(&read[..6], now, &mut out, &mut |_| {}), Ok(0));
    // Garbage before a header: skipped up to it.
    let mut junk = vec![0x00, 0x13, 0x37];
    junk.extend_from_slice(&read);
    let e = s.on_bytes(&junk, now, &mut out, &mut |_| {}).unwrap_err();
    assert_eq!((e.reason, e.skip), ("garbage", Some(3)));
    let mut bad = read.clone();
    let n = bad.len();
    bad[n - 1] ^= 0x55;
    assert_eq!(
        s.on_bytes(&bad, now, &mut out, &mut |_| {}).unwrap_err().reason,
        "bad_crc"
    );
    let huge = [0xFF, 0xFF, 0xFD, 0x00, 0x01, 0xFF, 0xFF, 0x02];
    assert_eq!(
        s.on_bytes(&huge, now, &mut out, &mut |_| {}).unwrap_err().reason,
        "bad_length"
    );
    assert_eq!(got.len(), 1, "no bad input became a command");
}
