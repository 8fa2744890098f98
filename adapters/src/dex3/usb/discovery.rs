//! Wiring discovery: learn which (bus, id) pairs the hand answers from.
//!
//! Motors answer only when addressed, and not to the broadcast id 15 (manual), so discovery
//! sends, on every bus, zero-gain packets in status 0 ("lock"/stop) with the timeout bit at 0
//! (no latching) to every id 0..=14, split over two exchanges because a 240-byte bus buffer
//! holds 12 motor packets. A broadcast round comes first (it makes every motor stop; sensors
//! report in every reply regardless). Nothing here drives a motor: kp = kd = tau = 0.
//!
//! The report lists every motor and sensor address seen; [`DiscoveryReport::wiring_template`]
//! renders it as the profile's `[devices.usb.wiring]` tables to fill in (which joint/pad each address is must
//! still be decided by moving the fingers: the report shows each motor's position).

use super::codec::{
    parse_feedback, BusId, DeviceId, LinuxToMcuCmd, McuToLinuxState, MotorCmdFrame, ParseCounters, RisMode,
    BROADCAST_ID, CMD_FRAME_LEN, STATE_FRAME_LEN,
};
use super::scaling::Scalings;
use super::transport::{Dex3Transport, TransportError};
use super::wiring::{BusAddr, WiringMap};
use crate::dex3::{Joint, MotorStatus, MOTOR_COUNT, PAD_COUNT};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;
use thiserror::Error;

/// Discovery settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiscoveryOptions {
    /// How many times each round of ids is sent (answers are merged).
    pub repeats: u32,
    pub timeout: Duration,
}

impl Default for DiscoveryOptions {
    fn default() -> Self {
        Self {
            repeats: 3,
            timeout: Duration::from_millis(100),
        }
    }
}

/// One motor seen during discovery.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorSighting {
    pub answers: u32,
    /// Last reported position, rad (with the scalings given).
    pub q: f32,
    pub status: u8,
    pub timeout: bool,
    pub error: u32,
}

/// What the hand answered.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiscoveryReport {
    pub motors: BTreeMap<BusAddr, MotorSighting>,
    /// Sensor address → number of answers.
    pub sensors: BTreeMap<BusAddr, u32>,
    pub exchanges: u32,
    pub failed_exchanges: u32,
    pub frame_crc_errors: u32,
    pub packet_errors: ParseCounters,
    /// `mode` bytes of the last good state frame.
    pub hand_mode: [u8; 2],
}

#[derive(Debug, Error)]
pub enum DiscoveryError {
    #[error("the hand never answered ({failed} failed exchanges; last error: {last})")]
    NoAnswer { failed: u32, last: TransportError },
    #[error("transport lost: {0}")]
    Transport(TransportError),
}

fn frame_for(ids: impl Iterator<Item = u8> + Clone) -> [u8; CMD_FRAME_LEN] {
    let mut cmd = LinuxToMcuCmd::default();
    for bus in BusId::ALL {
        for id in ids.clone() {
            let f = MotorCmdFrame {
                mode: RisMode::new(id, MotorStatus::Lock, false),
                ..Default::default()
            };
            // 12 packets at most per round: always fits.
            let _ = cmd.buses[bus.index()].push(&f.encode(), bus.index());
        }
    }
    cmd.encode()
}

/// Runs discovery over an open transport.
pub fn discover(
    t: &mut dyn Dex3Transport,
    opts: DiscoveryOptions,
    scalings: &Scalings,
) -> Result<DiscoveryReport, DiscoveryError> {
    let rounds = [
        frame_for(std::iter::once(BROADCAST_ID)),
        frame_for(0..8u8),
        frame_for(8..BROADCAST_ID),
    ];
    let mut rep = DiscoveryReport::default();
    let mut state = [0u8; STATE_FRAME_LEN];
    let mut last_err = None;
    for _ in 0..opts.repeats.max(1) {
        for frame in &rounds {
            match t.exchange(frame, &mut state, opts.timeout) {
                Ok(()) => {
                    rep.exchanges += 1;
                    let Ok(st) = McuToLinuxState::decode(&state) else {
                        rep.frame_crc_errors += 1;
                        continue;
                    };
                    rep.hand_mode = st.mode;
                    let p = parse_feedback(&st);
                    rep.packet_errors.bad_crc += p.counters.bad_crc;
                    rep.packet_errors.unknown_header += p.counters.unknown_header;
                    rep.packet_errors.truncated += p.counters.truncated;
                    rep.packet_errors.oversize += p.counters.oversize;
                    for (bus, f) in p.motors {
                        let Ok(id) = DeviceId::new(f.mode.id) else { continue };
                        let s = rep.motors.entry(BusAddr { bus, id }).or_insert(MotorSighting {
                            answers: 0,
                            q: 0.0,
                            status: 0,
                            timeout: false,
                            error: 0,
                        });
                        s.answers += 1;
                        s.q = scalings.decode_fb_position(f.pos);
                        s.status = f.mode.status.raw();
                        s.timeout = f.mode.timeout;
                        s.error = f.error;
                    }
                    for (bus, f) in p.sensors {
                        let Ok(id) = DeviceId::new(f.id()) else { continue };
                        *rep.sensors.entry(BusAddr { bus, id }).or_insert(0) += 1;
                    }
                }
                Err(e) if e.needs_reconnect() => return Err(DiscoveryError::Transport(e)),
                Err(e) => {
                    rep.failed_exchanges += 1;
                    last_err = Some(e);
                }
            }
        }
    }
    if rep.exchanges == 0 {
        return Err(DiscoveryError::NoAnswer {
            failed: rep.failed_exchanges,
            last: last_err.unwrap_or(TransportError::Disconnected),
        });
    }
    Ok(rep)
}

impl DiscoveryReport {
    /// A wiring map in address order, when exactly 7 motors and 9 sensors answered: joints in
    /// IDL order get the motor addresses sorted by (bus, id), pads the sensor addresses. This is
    /// a GUESS to edit, not a finding: it only proves the counts.
    pub fn address_order_guess(&self) -> Option<WiringMap> {
        if self.motors.len() != MOTOR_COUNT || self.sensors.len() != PAD_COUNT {
            return None;
        }
        let m: Vec<BusAddr> = self.motors.keys().copied().collect();
        let s: Vec<BusAddr> = self.sensors.keys().copied().collect();
        let w = WiringMap {
            motors: m.try_into().ok()?,
            pads: s.try_into().ok()?,
        };
        w.validate().ok()?;
        Some(w)
    }

    /// Human-readable summary plus a TOML skeleton of the wiring table.
    pub fn wiring_template(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "# Dex3-1 discovery: {} exchanges ({} failed, {} bad frame CRC), hand mode {:?}",
            self.exchanges, self.failed_exchanges, self.frame_crc_errors, self.hand_mode
        );
        let _ = writeln!(
            out,
            "# motors answering: {}, sensors answering: {}",
            self.motors.len(),
            self.sensors.len()
        );
        for (a, s) in &self.motors {
            let _ = writeln!(
                out,
                "#   motor  {a}: {} answers, q = {:+.3} rad, status {}, timeout {}, error {:#x}",
                s.answers, s.q, s.status, s.timeout, s.error
            );
        }
        for (a, n) in &self.sensors {
            let _ = writeln!(out, "#   sensor {a}: {n} answers");
        }
        let guess = self.address_order_guess();
        let _ = writeln!(
            out,
            "# Move each finger by hand and re-run to see which motor's q changes; then edit:"
        );
        // In the profile's format (`[devices.usb.wiring]` of a `[[devices]]` entry).
        let _ = writeln!(out, "[devices.usb.wiring.joints]");
        let motors: Vec<BusAddr> = match &guess {
            Some(w) => w.motors.to_vec(),
            None => self.motors.keys().copied().collect(),
        };
        for (i, a) in motors.iter().enumerate() {
            match Joint::from_index(i) {
                Some(j) => {
                    let _ = writeln!(out, "{} = {{ bus = {}, id = {} }}", j.name(), a.bus.get(), a.id.get());
                }
                None => {
                    let _ = writeln!(
                        out,
                        "# extra motor, not a Dex3 joint: bus {} id {}",
                        a.bus.get(),
                        a.id.get()
                    );
                }
            }
        }
        let _ = writeln!(out, "[devices.usb.wiring.pads]");
        for (i, a) in self.sensors.keys().enumerate() {
            let _ = writeln!(out, "pad_{i} = {{ bus = {}, id = {} }}", a.bus.get(), a.id.get());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex3::usb::emulator::{lock, Dex3Emulator, EmulatorConfig, EmulatorTransport, SharedEmulator};
    use crate::dex3::Side;
    use std::sync::{Arc, Mutex};

    #[test]
    fn finds_a_non_default_wiring_without_moving_anything() {
        // The emulated hand is wired differently from our default assumption.
        let a = BusAddr::of;
        let wiring = WiringMap {
            motors: [a(2, 0), a(2, 1), a(2, 5), a(0, 3), a(0, 4), a(1, 9), a(1, 14)],
            pads: [
                a(0, 0),
                a(1, 0),
                a(2, 0),
                a(3, 0),
                a(3, 1),
                a(3, 2),
                a(4, 0),
                a(4, 1),
                a(4, 2),
            ],
        };
        wiring.validate().unwrap();
        let cfg = EmulatorConfig {
            wiring,
            initial_q: Some([0.2, 0.1, -0.3, 0.4, 0.5, 0.6, 0.7]),
            ..Default::default()
        };
        let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(Side::Right, cfg)));
        let mut t = EmulatorTransport::open(&emu).unwrap();
        let rep = discover(&mut t, DiscoveryOptions::default(), &Scalings::default()).unwrap();
        let motors: Vec<BusAddr> = rep.motors.keys().copied().collect();
        let mut expected = wiring.motors.to_vec();
        expected.sort();
        assert_eq!(motors, expected);
        let sensors: Vec<BusAddr> = rep.sensors.keys().copied().collect();
        assert_eq!(sensors, wiring.pads.to_vec());
        assert!(rep
            .motors
            .values()
            .all(|s| s.answers == 3 && s.status == 0 && !s.timeout));
        assert!((rep.motors[&a(1, 9)].q - 0.6).abs() < 0.01);
        assert_eq!(rep.exchanges, 9);
        assert_eq!(lock(&emu).stats().broadcasts, 3 * 5);
        // Nothing was driven: no joint moved.
        assert!((lock(&emu).joint_q(Joint::Index1) - 0.7).abs() < 1e-3);
        let guess = rep.address_order_guess().unwrap();
        assert_eq!(guess.pads, wiring.pads);
        let toml = rep.wiring_template();
        assert!(toml.contains("thumb_2 = { bus = 1, id = 9 }"), "{toml}");
        assert!(toml.contains("[devices.usb.wiring.joints]") && toml.contains("[devices.usb.wiring.pads]"));
        assert!(toml.contains("motors answering: 7, sensors answering: 9"));
    }

    #[test]
    fn no_answer_is_an_error() {
        let emu: SharedEmulator = Arc::new(Mutex::new(Dex3Emulator::new(Side::Left, EmulatorConfig::default())));
        let mut t = EmulatorTransport::open(&emu).unwrap();
        lock(&emu).drop_replies(100);
        let opts = DiscoveryOptions {
            repeats: 1,
            timeout: Duration::from_millis(1),
        };
        assert!(matches!(
            discover(&mut t, opts, &Scalings::default()),
            Err(DiscoveryError::NoAnswer { failed: 3, .. })
        ));
    }
}
