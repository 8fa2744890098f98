//! The LEAP Hand's exchange rate against the wire limit: handgate's LEAP device loop (sync
//! write of 16 goal positions, then a sync read, or a fast sync read, of present current,
//! velocity and position of the 16 servos) run as fast as the bus allows, against the
//! in-process emulator that books the line at 4 Mbaud (10 bits a byte, Return Delay Time 0,
//! the LEAP's setting) and makes each reply readable only when it would have fully arrived.
//!
//! The wire limit of one cycle is the bytes of the three packets (sync write, read request,
//! the replies) at 4 Mbaud; the ratio is the measured cycle rate over it, in the same run.
//!
//! Run: `cargo bench -p handgate-adapters --bench leap` (optional argument: seconds per case,
//! default 5). Prints one markdown table row per case.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::dynamixel::protocol::{wire_time, Request};
use handgate_adapters::leap::control_table::{BAUD, DEFAULT_IDS, PRESENT_BLOCK};
use handgate_adapters::leap::device::{LeapBusConfig, LeapDevice};
use handgate_adapters::leap::emulator::{in_process, EmulatorConfig};
use handgate_adapters::model::{DeviceKind, HandCommand, Side};

/// Bytes on the wire per cycle: sync write of 16 goals, the read request, the replies.
fn cycle_bytes(fast: bool) -> usize {
    let ids = DEFAULT_IDS.to_vec();
    let sw = Request::SyncWrite {
        addr: 116,
        len: 4,
        entries: ids.iter().map(|&i| (i, vec![0u8; 4])).collect(),
    }
    .encode()
    .expect("encodes")
    .len();
    let (addr, len) = (PRESENT_BLOCK.addr, PRESENT_BLOCK.len);
    let read = if fast {
        Request::FastSyncRead { addr, len, ids }
    } else {
        Request::SyncRead { addr, len, ids }
    }
    .encode()
    .expect("encodes")
    .len();
    let n = DEFAULT_IDS.len();
    let l = len as usize;
    let replies = if fast {
        // One packet: header, id, length, instruction, then error, id, data, CRC per servo.
        8 + n * (l + 4)
    } else {
        // One status per servo: 11 bytes of framing + the data.
        n * (11 + l)
    };
    sw + read + replies
}

fn run_case(fast: bool, secs: f64) {
    let (_emu, connector) = in_process(EmulatorConfig::with_ids(&DEFAULT_IDS));
    let cfg = LeapBusConfig {
        fast_sync_read: fast,
        // Far above what the wire allows: the loop runs back to back, each cycle as soon as
        // the previous one's replies are in.
        rate_hz: 20_000.0,
        stale_after: Duration::from_secs(1),
        ..Default::default()
    };
    let info = DeviceInfo {
        name: "bench".into(),
        kind: DeviceKind::Leap,
        side: Side::Right,
        backend: Backend::Emulator,
        table: Arc::new(DeviceKind::Leap.table(Side::Right, &Default::default()).expect("table")),
    };
    let dev = LeapDevice::start(info, connector, cfg).expect("starts");
    let rx = dev.state();
    let start = Instant::now();
    while rx.borrow().measured_at.is_none() {
        assert!(start.elapsed() < Duration::from_secs(10), "never measured");
        std::thread::sleep(Duration::from_millis(5));
    }
    // Something commanded: every cycle writes the 16 goals.
    dev.command(HandCommand::closure(1, 0.5)).expect("command");
    std::thread::sleep(Duration::from_millis(200));
    let c = dev.bus_counters();
    let ex0 = c.exchanges.load(std::sync::atomic::Ordering::Relaxed);
    let s0 = dev.stats();
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(secs));
    let dt = t0.elapsed().as_secs_f64();
    let s1 = dev.stats();
    let ex1 = c.exchanges.load(std::sync::atomic::Ordering::Relaxed);
    let missing = c.missing_replies.load(std::sync::atomic::Ordering::Relaxed);
    dev.stop();
    let rate = (ex1 - ex0) as f64 / dt;
    let fresh = (s1.state_samples - s0.state_samples) as f64 / dt;
    let sent = (s1.sent - s0.sent) as f64 / dt;
    let bytes = cycle_bytes(fast);
    let limit = 1.0 / wire_time(bytes, BAUD).as_secs_f64();
    println!(
        "| {} | {bytes} B | {limit:.0} Hz | {rate:.0} Hz | {:.0} % | {sent:.0} Hz | {fresh:.0} Hz | {missing} |",
        if fast { "fast sync read" } else { "sync read" },
        rate / limit * 100.0
    );
}

fn main() {
    let secs: f64 = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(5.0);
    println!(
        "| read | wire bytes / cycle | wire limit | cycles | of limit | goal writes | fresh states | replies missing |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    run_case(false, secs);
    run_case(true, secs);
}
