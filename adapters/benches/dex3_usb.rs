//! Dex3-1 USB benchmarks.
//!
//! (a) `exchange_codec`: one full host-side exchange without I/O: build + encode the 1234-byte
//!     command frame with its CRCs, then verify + decode + parse the 1270-byte state frame.
//! (b) loop period jitter: the 1 kHz device loop against the in-process emulator for
//!     `DEX3_JITTER_SECS` seconds (default 10), printing the cycle-period histogram summary.
//!     Runs only under `cargo bench` (not in `cargo test --benches` smoke mode).

use criterion::{black_box, criterion_group, Criterion};
use handgate_adapters::dex3::usb::codec::{McuToLinuxState, STATE_FRAME_LEN};
use handgate_adapters::dex3::usb::convert::{apply_state, build_command};
use handgate_adapters::dex3::usb::device_loop::{Dex3UsbLoop, LoopConfig};
use handgate_adapters::dex3::usb::emulator::{Dex3Emulator, EmulatorConfig, EmulatorTransport, Reply};
use handgate_adapters::dex3::usb::scaling::Scalings;
use handgate_adapters::dex3::usb::wiring::WiringMap;
use handgate_adapters::dex3::{Dex3Command, Dex3Measurement, Side};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

fn exchange_codec(c: &mut Criterion) {
    let wiring = WiringMap::default();
    let s = Scalings::default();
    let cmd = Dex3Command::hold([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7], 1.5, 0.1);
    // A realistic reply: 7 motor packets and 9 sensor packets.
    let mut emu = Dex3Emulator::new(Side::Right, EmulatorConfig::default());
    let mut reply = [0u8; STATE_FRAME_LEN];
    let req = build_command(&cmd, &wiring, &s, true).encode();
    assert_eq!(emu.handle_frame(&req, &mut reply), Reply::Frame);
    let mut meas = Dex3Measurement::empty(Instant::now());

    c.bench_function("dex3_usb/exchange_codec", |b| {
        b.iter(|| {
            let out = build_command(black_box(&cmd), &wiring, &s, true).encode();
            black_box(&out);
            let st = McuToLinuxState::decode(black_box(&reply)).unwrap();
            black_box(apply_state(&mut meas, &st, &wiring, &s))
        })
    });
    c.bench_function("dex3_usb/encode_command", |b| {
        b.iter(|| black_box(build_command(black_box(&cmd), &wiring, &s, true).encode()))
    });
    c.bench_function("dex3_usb/decode_state", |b| {
        b.iter(|| black_box(McuToLinuxState::decode(black_box(&reply)).unwrap()))
    });
}

fn loop_jitter(secs: u64, spin: Duration) {
    let emu = Arc::new(Mutex::new(Dex3Emulator::new(Side::Right, EmulatorConfig::default())));
    let cfg = LoopConfig {
        spin,
        ..LoopConfig::default()
    };
    let h = Dex3UsbLoop::spawn(EmulatorTransport::factory(emu), cfg).unwrap();
    std::thread::sleep(Duration::from_secs(secs));
    let s = h.stats();
    h.stop();
    let q = |p| {
        s.period
            .quantile(p)
            .map(|d| format!("{:.3} ms", d.as_secs_f64() * 1e3))
            .unwrap_or_default()
    };
    println!(
        "dex3_usb/loop_jitter spin={}us {}s: cycles {} median {} p90 {} p99 {} max {:.3} ms misses {} good_frames {}",
        spin.as_micros(),
        secs,
        s.period.count(),
        q(0.5),
        q(0.9),
        q(0.99),
        s.period.max().as_secs_f64() * 1e3,
        s.misses,
        s.good_frames
    );
}

criterion_group!(benches, exchange_codec);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    let is_bench = std::env::args().any(|a| a == "--bench");
    if is_bench {
        let secs = std::env::var("DEX3_JITTER_SECS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(10);
        loop_jitter(secs, Duration::from_micros(100));
        loop_jitter(secs, Duration::ZERO);
    }
}
