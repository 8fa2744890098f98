//! Benchmark 5b: two Inspire RH56 hands on one RS-485 line at 115200 baud (issue #38 part 7:
//! at least 100 Hz each, what Unitree's DFX service polls). The project's own line
//! (`inspire_rh56::bus::Rh56Bus`, the serial protocol, as fast as the line answers) over the
//! in-process emulated line, whose every reply is handed over when its bytes would have
//! crossed the wire at the line's baud; both hands commanded with targets that change at
//! `command_hz`. Measured: each hand's readings a second (ANGLE_ACT reads); against the wire
//! limit computed from the frames' lengths and the baud for the same schedule.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use handgate_adapters::inspire_rh56::bus::{BusConfig, EmulatedLine, Rh56Bus};
use handgate_adapters::inspire_rh56::config::Protocol;
use handgate_adapters::inspire_rh56::emulator::{HandSpec, Line, Rh56Hand};
use serde::{Deserialize, Serialize};

/// One schedule's figures.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Run {
    /// Commands per second per hand (each a changed target: one ANGLE_SET write).
    pub command_hz: f64,
    pub secs: f64,
    /// Readings a second, per hand (ids 1 and 2).
    pub per_hand_hz: [f64; 2],
    /// The line's limit for this schedule, readings a second per hand.
    pub wire_limit_hz: f64,
    pub timeouts: u64,
    pub load1: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Result {
    pub baud: u32,
    pub slow_every: u32,
    pub runs: Vec<Run>,
}

/// Bytes a round costs per hand: the ANGLE_ACT read (9-byte request, 20-byte reply) and a
/// share of the slow read (9 + 50 bytes every `slow_every` rounds).
fn round_bytes(slow_every: u32) -> f64 {
    29.0 + 59.0 / f64::from(slow_every)
}

/// A write exchange: a 20-byte ANGLE_SET request and its 9-byte acknowledgement.
const WRITE_BYTES: f64 = 29.0;

/// Readings a second per hand the line allows two hands whose targets change `command_hz`
/// times a second, at `bytes_per_s`: a target is written at most once a round (the line
/// writes the latest at the hand's turn), so while the rounds outpace the commands each
/// command costs one write, and once they do not every round carries a write.
fn wire_limit(bytes_per_s: f64, command_hz: f64, slow_every: u32) -> f64 {
    let reads_only = (bytes_per_s - 2.0 * command_hz * WRITE_BYTES) / (2.0 * round_bytes(slow_every));
    if reads_only >= command_hz {
        reads_only
    } else {
        bytes_per_s / (2.0 * (round_bytes(slow_every) + WRITE_BYTES))
    }
}

fn one(baud: u32, command_hz: f64, secs: f64) -> (Run, u32) {
    let line = Arc::new(Mutex::new(Line::new(vec![
        Rh56Hand::new(HandSpec::new(1)),
        Rh56Hand::new(HandSpec::new(2)),
    ])));
    let cfg = BusConfig {
        baud,
        ids: vec![1, 2],
        ..BusConfig::default()
    };
    let slow_every = cfg.slow_every;
    let bus = Rh56Bus::with_connector(
        Box::new(EmulatedLine {
            line,
            baud,
            protocol: Protocol::Serial,
        }),
        cfg,
    )
    .expect("the line starts");
    let (a, b) = (bus.subscribe(1).unwrap(), bus.subscribe(2).unwrap());
    let ready = Instant::now() + Duration::from_secs(10);
    while !(a.borrow().online && b.borrow().online) && Instant::now() < ready {
        std::thread::sleep(Duration::from_millis(5));
    }
    let (r0a, r0b, t0) = (a.borrow().round, b.borrow().round, Instant::now());
    let period = Duration::from_secs_f64(1.0 / command_hz);
    let mut k = 0i16;
    let mut next = t0;
    while t0.elapsed() < Duration::from_secs_f64(secs) {
        k = (k + 37) % 1000;
        bus.set_angles(1, [k; 6]).unwrap();
        bus.set_angles(2, [1000 - k; 6]).unwrap();
        next += period;
        if let Some(d) = next.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    let per_hand_hz = [
        (a.borrow().round - r0a) as f64 / dt,
        (b.borrow().round - r0b) as f64 / dt,
    ];
    let bytes_per_s = f64::from(baud) / 10.0;
    let wire_limit_hz = wire_limit(bytes_per_s, command_hz, slow_every);
    (
        Run {
            command_hz,
            secs: dt,
            per_hand_hz,
            wire_limit_hz,
            timeouts: bus.stats().timeouts,
            load1: crate::stats::loadavg()[0],
        },
        slow_every,
    )
}

/// Both hands commanded at 50 Hz (the verdict), then at 100 Hz (where the serial protocol's
/// wire limit itself is under 100 readings a second: a write every round), `secs` each.
pub fn run(secs: f64) -> Result {
    let baud = 115_200;
    let (a, slow_every) = one(baud, 50.0, secs);
    let (b, _) = one(baud, 100.0, secs);
    Result {
        baud,
        slow_every,
        runs: vec![a, b],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wire_limit_counts_a_write_a_command_or_a_write_a_round() {
        let c = 11_520.0; // 115200 baud, 10 bits a byte
                          // 50 Hz of targets: the reads take what the writes leave.
        let l = wire_limit(c, 50.0, 10);
        assert!((l - (c - 2.0 * 50.0 * 29.0) / (2.0 * 34.9)).abs() < 1e-6, "{l}");
        // 100 Hz of targets is more than the rounds allow: a write every round.
        let l = wire_limit(c, 100.0, 10);
        assert!((l - c / (2.0 * (34.9 + 29.0))).abs() < 1e-6, "{l}");
        assert!(l < 100.0);
    }
}
