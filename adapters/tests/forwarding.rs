//! Forwarding on arrival (docs/fronts.md, "Latency"): a DDS-client device publishes an
//! accepted command to its service at once, not at its loop's next tick; the first state
//! sample after that publish is the state reflecting it; and what the service receives is
//! bounded by `max_send_hz` whatever a client sends. Domains 54–56.
//!
//! The device loops here run at 2 Hz, so "before the next tick" is an ordering the loop's own
//! cycle counter shows (the command reached the service while the counter stood still), not a
//! duration.

#[path = "support/dex1_client.rs"]
mod dex1_client;

use std::time::{Duration, Instant};

use handgate_adapters::dds::Node;
use handgate_adapters::dds_device::{DdsDevice, Forwarding};
use handgate_adapters::device::HandDevice;
use handgate_adapters::dex1::adapter::Variant;
use handgate_adapters::dex1::emulator::{Dex1Command, Dex1Config, Dex1Emulator};
use handgate_adapters::model::{Freshness, HandCommand, Side};

fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + Duration::from_secs(20);
    while !cond() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn start(domain: u32, rate: f64, forward: Forwarding) -> (Node, Dex1Emulator, DdsDevice) {
    let node = Node::new(domain, None).unwrap();
    let mut c = Dex1Config::new(Variant::Go, Side::Right);
    c.initial_q = 5.4;
    let emu = Dex1Emulator::start(&node, c).unwrap();
    let dev = dex1_client::dex1_client(&node, rate, forward);
    let mut rx = dev.state();
    wait_for("the first fresh state", || {
        rx.borrow_and_update().freshness == Freshness::Fresh
    });
    (node, emu, dev)
}

/// Waits for the loop's next tick and returns its cycle count: the following tick is a whole
/// period (500 ms) away.
fn just_after_a_tick(dev: &DdsDevice) -> u64 {
    let c = dev.stats().cycles;
    wait_for("a tick", || dev.stats().cycles > c);
    dev.stats().cycles
}

fn closed_at_service(emu: &Dex1Emulator) -> bool {
    matches!(emu.last_command(), Some(Dex1Command::Go(m)) if m.cmds.len() == 1 && m.cmds[0].q == 0.0)
}

#[test]
fn a_command_reaches_the_service_before_the_next_tick_and_its_state_comes_back_with_it() {
    let (_node, emu, dev) = start(54, 2.0, Forwarding::default_for(2.0));
    let c = just_after_a_tick(&dev);
    let mut rx = dev.state();
    rx.mark_unchanged();
    dev.command(HandCommand {
        tag: 77,
        ..HandCommand::closure(1, 1.0)
    })
    .unwrap();
    wait_for("the command at the service", || closed_at_service(&emu));
    wait_for("the state reflecting it", || rx.borrow_and_update().cmd_seq == 1);
    let st = rx.borrow().clone();
    assert_eq!(st.cmd_tag, 77);
    assert_eq!(
        dev.stats().cycles,
        c,
        "forwarded and reflected without waiting for the 2 Hz loop's next tick"
    );
    // The state reflecting it was measured after the command went out, never before.
    assert!(st.measured_at.is_some());
}

#[test]
fn with_forwarding_off_a_command_waits_for_the_tick() {
    let (_node, emu, dev) = start(
        55,
        2.0,
        Forwarding {
            on_arrival: false,
            max_send_hz: 4.0,
        },
    );
    let c = just_after_a_tick(&dev);
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    wait_for("the command at the service", || closed_at_service(&emu));
    assert!(dev.stats().cycles > c, "sent by a tick, as before forwarding");
    // Its state comes at a later tick: the first one that finds a sample taken after it went out.
    let mut rx = dev.state();
    wait_for("the state reflecting it", || rx.borrow_and_update().cmd_seq == 1);
    assert!(
        dev.stats().cycles > c + 1,
        "reflected at a tick after the one that sent it"
    );
}

/// A client at about 10 kHz against a 50 Hz device bounded at 100 Hz: the service receives at
/// most `BURST + 100·T` samples in `T` seconds, and the newest command still gets through.
#[test]
fn a_flood_reaches_the_service_at_max_send_hz() {
    let (_node, emu, dev) = start(
        56,
        50.0,
        Forwarding {
            on_arrival: true,
            max_send_hz: 100.0,
        },
    );
    let before = emu.commands_received();
    let t0 = Instant::now();
    let mut seq = 0;
    while t0.elapsed() < Duration::from_secs(1) {
        seq += 1;
        let closure = if seq % 2 == 0 { 0.25 } else { 0.75 };
        dev.command(HandCommand::closure(seq, closure)).unwrap();
        std::thread::sleep(Duration::from_micros(100));
    }
    let sent_by_client = seq;
    dev.command(HandCommand::closure(seq + 1, 1.0)).unwrap();
    let elapsed = t0.elapsed().as_secs_f64();
    wait_for("the last command at the service", || closed_at_service(&emu));
    let got = emu.commands_received() - before;
    let bound = 2.0 + 100.0 * t0.elapsed().as_secs_f64();
    assert!(
        sent_by_client > 1000,
        "the client flooded: {sent_by_client} in {elapsed:.2} s"
    );
    assert!((got as f64) <= bound, "the service received {got} (bound {bound:.0})");
    assert!(
        got as f64 >= 50.0 * elapsed,
        "at least the loop rate got through: {got}"
    );
}
