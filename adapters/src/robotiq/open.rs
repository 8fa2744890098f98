//! Opening a Robotiq gripper: what a profile decides ([`RobotiqOpen`], `configure`) and the
//! device on its line (`open`); `handgate emulate robotiq` (`emulate`).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::config::RobotiqProfile;
use super::device::{EmulatedLink, Link, LoopConfig, RobotiqDevice};
use super::emulator::{Gripper, Tuning};
use super::table::Variant;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::open::{DeviceSpec, OpenEnv};

/// Where the gripper's Modbus RTU line is.
#[derive(Debug, Clone, PartialEq)]
pub enum Line {
    /// An RS-485 adapter.
    Serial { port: String, baud: u32 },
    /// RTU frames over a TCP connection (a UR arm's Tool Communication forwarder).
    Tcp { host: String, port: u16 },
    /// The in-process emulator.
    Emulated(EmulatedGripper),
}

/// What the emulator backend's gripper starts with.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatedGripper {
    /// Finger position at power-up, counts (`initial.jaw`; default open).
    pub position: f32,
    /// `object_at.jaw`, counts.
    pub object_at: Option<f32>,
    pub tuning: Tuning,
}

/// What one Robotiq opens with.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotiqOpen {
    pub variant: Variant,
    pub line: Line,
    pub slave: u8,
    /// Grace for a reply beyond its wire time.
    pub response_timeout: Duration,
    pub run: LoopConfig,
}

/// Default grace for a reply beyond its wire time: a USB adapter's latency (16 ms FTDI
/// default) plus the gripper's own turnaround, with margin (assumed).
pub const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(50);

/// `host:port` split (no name lookup: that is the connection's business).
pub fn resolve_tcp(s: &str) -> Result<(String, u16), String> {
    let (host, port) = s.rsplit_once(':').ok_or("no `:port`")?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return Err("no host".into());
    }
    let port: u16 = port.parse().map_err(|_| format!("`{port}` is not a port"))?;
    if port == 0 {
        return Err("port 0".into());
    }
    Ok((host.to_string(), port))
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_, RobotiqProfile>) -> Result<RobotiqOpen, DeviceError> {
    let r = spec.config.section();
    let line = match spec.backend {
        Backend::Emulator => {
            let noise = spec.emulator.noise_for(spec.name, crate::sim::Noise::OFF.with_seed(0));
            let counts_per_unit = 255.0 / r.variant.spec().closed;
            let tuning = Tuning {
                position_noise: match (spec.emulator.noise, spec.emulator.position_noise_rad) {
                    (Some(false), _) => 0.0,
                    // The profile's standard deviation in the joint's unit, as counts.
                    (_, Some(sd)) => sd as f32 * counts_per_unit,
                    _ => Tuning::default().position_noise,
                },
                seed: noise.seed,
                ..Tuning::default()
            };
            Line::Emulated(EmulatedGripper {
                position: spec.initial_wire("jaw", 0.0).clamp(0.0, 255.0),
                object_at: spec.object_wire("jaw").map(|o| o.clamp(0.0, 255.0)),
                tuning,
            })
        }
        _ => match (&r.port, &r.tcp) {
            (Some(port), _) => Line::Serial {
                port: port.clone(),
                baud: r.baud,
            },
            (None, Some(t)) => {
                let (host, port) = resolve_tcp(t).map_err(|e| DeviceError::Config(format!("robotiq.tcp: {e}")))?;
                Line::Tcp { host, port }
            }
            (None, None) => return Err(DeviceError::Config("robotiq: needs `port` or `tcp`".into())),
        },
    };
    Ok(RobotiqOpen {
        variant: r.variant,
        line,
        slave: r.slave,
        response_timeout: r
            .response_timeout_ms
            .map(Duration::from_millis)
            .unwrap_or(DEFAULT_RESPONSE_TIMEOUT),
        run: LoopConfig {
            rate_hz: spec.rate_hz,
            stale_after: spec.stale_after,
            speed: r.speed,
            force: r.force,
        },
    })
}

/// Opens the gripper `c` describes.
pub fn open(
    c: RobotiqOpen,
    spec: &DeviceSpec<'_, RobotiqProfile>,
    _env: &mut OpenEnv<'_>,
) -> Result<Box<dyn HandDevice>, DeviceError> {
    let link: Box<dyn Link> = match &c.line {
        Line::Emulated(e) => Box::new(EmulatedLink(Arc::new(Mutex::new(Gripper::new(
            c.variant.spec(),
            e.tuning,
            e.position,
            e.object_at,
            Instant::now(),
        ))))),
        Line::Serial { .. } | Line::Tcp { .. } => {
            return Err(DeviceError::Unsupported(
                "a Robotiq on a serial line or RTU over TCP (not yet)",
            ))
        }
    };
    Ok(Box::new(RobotiqDevice::start(spec.info(), link, c.run)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tcp_addresses_split_into_host_and_port() {
        assert_eq!(
            resolve_tcp("192.168.1.10:54321").unwrap(),
            ("192.168.1.10".into(), 54321)
        );
        assert_eq!(resolve_tcp("[::1]:54321").unwrap(), ("::1".into(), 54321));
        assert_eq!(resolve_tcp("ur5e.local:54321").unwrap(), ("ur5e.local".into(), 54321));
        for bad in ["", ":54321", "host", "host:x", "host:0", "host:70000"] {
            assert!(resolve_tcp(bad).is_err(), "{bad}");
        }
    }
}
