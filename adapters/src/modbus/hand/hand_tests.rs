//! The line of register-mapped hands over the emulated line: two ROHands and a silent slave,
//! targets written once, reconnect without replay.

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::emulated::{Cores, EmulatedLine};
use super::line::{HandLine, LineConfig, Reading};
use super::{EmuSpec, RegisterHand};
use crate::modbus::server::RegisterMap;
use crate::modbus::Table;
use crate::rohand::{reg, Rohand, FINGERS};

fn cores(slaves: &[u8]) -> Cores<<Rohand as RegisterHand>::Core> {
    Arc::new(Mutex::new(
        slaves
            .iter()
            .map(|s| {
                let e = EmuSpec {
                    slave: *s,
                    start: vec![0.0; FINGERS],
                    object_at: vec![None; FINGERS],
                };
                (*s, Rohand::core(&e))
            })
            .collect(),
    ))
}

fn config(slaves: &[u8]) -> LineConfig {
    LineConfig {
        baud: 115_200,
        slaves: slaves.to_vec(),
        response_timeout: Duration::from_millis(20),
        period: None,
        state: Rohand::STATE,
        target: Rohand::TARGET,
        init: Rohand::INIT,
        over_tcp: false,
    }
}

fn wait(rx: &mut watch::Receiver<Reading>, what: &str, ok: impl Fn(&Reading) -> bool) -> Reading {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let r = *rx.borrow_and_update();
        if ok(&r) {
            return r;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: last {:?} {:?}",
            r.online,
            r.last_error
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn target_of(cores: &Cores<<Rohand as RegisterHand>::Core>, i: usize) -> [u16; FINGERS] {
    let mut t = [0u16; FINGERS];
    cores.lock().unwrap()[i]
        .1
        .read(Table::Holding, reg::POS_TARGET, &mut t)
        .unwrap();
    t
}

const POS: usize = (reg::POS - reg::FINGER_STATUS) as usize;

#[test]
fn two_hands_go_on_while_a_third_slave_stays_silent() {
    let cores = cores(&[2, 3]);
    let line = HandLine::start(Box::new(EmulatedLine::new(cores.clone(), 115_200)), config(&[2, 3, 4])).unwrap();
    let (mut a, mut b, mut silent) = (
        line.subscribe(2).unwrap(),
        line.subscribe(3).unwrap(),
        line.subscribe(4).unwrap(),
    );
    wait(&mut silent, "slave 4 missed", |r| r.last_error == Some("timeout"));
    line.set_target(2, &[65535; FINGERS]).unwrap();
    let ra = wait(&mut a, "hand 2 closed", |r| {
        r.online && r.regs()[POS..POS + FINGERS] == [65535; 6]
    });
    let rb = wait(&mut b, "hand 3 read", |r| {
        r.online && r.round >= ra.round.saturating_sub(1)
    });
    assert_eq!(rb.regs()[POS..POS + FINGERS], [0; 6], "hand 3 was not commanded");
    let s = *silent.borrow();
    assert!(!s.online && s.round == 0, "{s:?}");
    // The target was written once although every round served the hand.
    let rounds = line.counters.rounds.load(Ordering::Relaxed);
    wait(&mut a, "more rounds", |r| r.round > ra.round + 5);
    assert!(line.counters.rounds.load(Ordering::Relaxed) > rounds);
    assert_eq!(line.counters.writes.load(Ordering::Relaxed), 1);
    assert!(line.counters.misses.load(Ordering::Relaxed) >= 1);
    // A round's rate is the wire's: 2 x (FC03 of 66 words) plus one timeout (20 ms + its
    // request's wire time) at most ~50 rounds a second.
    assert_eq!(target_of(&cores, 1), [0; FINGERS]);
}

#[test]
fn after_an_unplug_the_line_reconnects_and_never_replays_a_stale_target() {
    let cores = cores(&[2]);
    let emulated = EmulatedLine::new(cores.clone(), 115_200);
    let unplugged = emulated.unplugged.clone();
    let line = HandLine::start(Box::new(emulated), config(&[2])).unwrap();
    let mut rx = line.subscribe(2).unwrap();
    line.set_target(2, &[1000; FINGERS]).unwrap();
    wait(&mut rx, "first target reached", |r| r.online && r.regs()[POS] == 1000);
    unplugged.store(true, Ordering::Relaxed);
    wait(&mut rx, "offline", |r| !r.online);
    // Set while the hand cannot hear it: stale by the time the line is back.
    line.set_target(2, &[50_000; FINGERS]).unwrap();
    let before = rx.borrow().round;
    unplugged.store(false, Ordering::Relaxed);
    wait(&mut rx, "back", |r| r.online && r.round > before + 3);
    assert_eq!(line.counters.reconnects.load(Ordering::Relaxed), 1);
    assert_eq!(target_of(&cores, 0), [1000; FINGERS], "the stale target was replayed");
    assert_eq!(line.counters.writes.load(Ordering::Relaxed), 1);
    // A new command after the reconnect is written.
    line.set_target(2, &[2000; FINGERS]).unwrap();
    wait(&mut rx, "new target reached", |r| r.regs()[POS] == 2000);
}

/// `tcp = "host:port"`: the same line over RTU frames on TCP (a serial-to-Ethernet gateway),
/// here a kit RTU session serving slave 2's state block (with the target block inside it).
#[test]
fn the_line_runs_rtu_over_tcp() {
    use super::kind::TcpConnector;
    use crate::modbus::server::Bank;
    use crate::modbus::session::RtuSession;

    let make = || {
        RtuSession::new(
            2,
            Bank {
                holding_base: reg::FINGER_STATUS,
                holding: vec![0; Rohand::STATE.1 as usize],
                ..Default::default()
            },
            0,
        )
    };
    let (tx, _rx) = tokio::sync::mpsc::channel(1);
    let inbox = crate::front::serve::Inbox::for_tests(crate::front::serve::Queue::new(tx));
    let server = crate::front::stream::serve_tcp(
        "127.0.0.1:0".parse().unwrap(),
        Default::default(),
        make,
        inbox,
        "rohand-test",
        "rohand-test",
    )
    .unwrap();
    let addr = server.local_addr.unwrap();
    let mut cfg = config(&[2]);
    cfg.over_tcp = true;
    cfg.response_timeout = Duration::from_millis(500);
    let line = HandLine::start(Box::new(TcpConnector(addr)), cfg).unwrap();
    let mut rx = line.subscribe(2).unwrap();
    wait(&mut rx, "read over TCP", |r| r.online);
    line.set_target(2, &[65535; FINGERS]).unwrap();
    let target = (reg::POS_TARGET - reg::FINGER_STATUS) as usize;
    wait(&mut rx, "target written over TCP", |r| {
        r.regs()[target..target + FINGERS] == [65535; FINGERS]
    });
}
