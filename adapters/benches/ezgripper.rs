//! Measured-state rate of the EZGripper bus driver at 1 Mbaud through the pty emulator with
//! simulated wire timing (10 bits per byte, the servo's Return Delay Time, replies queued on
//! the line), for one and for two grippers on one bus.
//!
//! Run: `cargo bench -p handgate-adapters --bench ezgripper` (optional argument: seconds per
//! case, default 5). Prints one markdown table row per case: round period median/p90/p99
//! and the resulting measured-state rate per gripper.

use std::time::{Duration, Instant};

use handgate_adapters::dynamixel::protocol::{wire_time, Request};
use handgate_adapters::ezgripper::control_table::{GOAL_BLOCK, PRESENT_BLOCK};
use handgate_adapters::ezgripper::emulator::{EmulatorConfig, VirtualBus};
use handgate_adapters::ezgripper::{BusConfig, EzGripperBus, GripperConfig, ServoId};

fn pct(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// Wire time of one round: sync write + sync read + one status per gripper + return delays.
fn wire_round(n: u8, return_delay: Duration) -> Duration {
    let ids: Vec<u8> = (1..=n).collect();
    let sw = Request::SyncWrite {
        addr: GOAL_BLOCK.addr,
        len: GOAL_BLOCK.len,
        entries: ids.iter().map(|&i| (i, vec![0u8; GOAL_BLOCK.len as usize])).collect(),
    }
    .encode()
    .expect("encodes")
    .len();
    let sr = Request::SyncRead {
        addr: PRESENT_BLOCK.addr,
        len: PRESENT_BLOCK.len,
        ids,
    }
    .encode()
    .expect("encodes")
    .len();
    let status = 11 + PRESENT_BLOCK.len as usize;
    wire_time(sw + sr + n as usize * status, 1_000_000) + return_delay * n as u32
}

fn run_case(n: u8, usb_latency: Duration, secs: f64) {
    let link = std::env::temp_dir().join(format!("handgate-ezg-bench-{}-{n}", std::process::id()));
    let ids: Vec<u8> = (1..=n).collect();
    let mut ec = EmulatorConfig::with_ids(&ids);
    ec.usb_latency = usb_latency;
    let emu = VirtualBus::start(&link, ec).expect("emulator starts");
    let cfg = BusConfig {
        grippers: ids
            .iter()
            .map(|&i| GripperConfig {
                id: ServoId::new(i).expect("valid id"),
                zero_ticks: Some(1000),
            })
            .collect(),
        calibrate_on_start: false,
        ..Default::default()
    };
    // A load spike on the shared machine can starve the emulator through open's pings.
    let bus = (0..5)
        .find_map(|_| EzGripperBus::open(emu.path(), cfg.clone()).ok())
        .expect("bus opens");
    for &i in &ids {
        bus.gripper(ServoId::new(i).expect("valid id"))
            .expect("configured")
            .set_target(50.0, 40.0)
            .expect("finite");
    }
    // Warm up until every gripper delivered fresh state, then measure.
    let warm = Instant::now();
    while ids.iter().any(|&i| {
        bus.latest(ServoId::new(i).expect("valid id"))
            .map(|s| s.stale)
            .unwrap_or(true)
    }) {
        assert!(warm.elapsed() < Duration::from_secs(10), "no state from the emulator");
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(300));
    let _ = bus.take_round_periods();
    let s0 = bus.stats();
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(secs));
    let el = t0.elapsed();
    let s1 = bus.stats();
    let mut p = bus.take_round_periods();
    p.sort_unstable();
    let samples: Vec<u64> = ids
        .iter()
        .map(|i| s1.per_gripper[i].samples - s0.per_gripper[i].samples)
        .collect();
    let errors = (s1.timeouts - s0.timeouts) + (s1.crc_errors - s0.crc_errors);
    let med = pct(&p, 0.5);
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    println!(
        "| {n} | {:.0} us | {:>6.0} | {:>6.0} | {:>6.0} | {:>6.0} | {:.0} | {} | {} |",
        usb_latency.as_secs_f64() * 1e6,
        us(wire_round(n, Duration::from_micros(4))),
        us(med),
        us(pct(&p, 0.9)),
        us(pct(&p, 0.99)),
        1.0 / med.as_secs_f64(),
        samples
            .iter()
            .map(|&s| format!("{:.0}", s as f64 / el.as_secs_f64()))
            .collect::<Vec<_>>()
            .join(" / "),
        errors,
    );
    drop(bus);
    drop(emu);
}

fn main() {
    // `cargo bench` passes "--bench"; take the first numeric argument as seconds per case.
    let secs = std::env::args()
        .skip(1)
        .find_map(|a| a.parse::<f64>().ok())
        .unwrap_or(5.0);
    println!("| grippers | USB latency | wire time/round (us) | period median (us) | p90 | p99 | Hz per gripper (median) | measured states/s per gripper | timeouts+CRC errors |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for usb in [Duration::ZERO, Duration::from_millis(1)] {
        for n in [1u8, 2] {
            run_case(n, usb, secs);
        }
    }
}
