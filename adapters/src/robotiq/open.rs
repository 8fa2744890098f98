//! Opening a Robotiq gripper: what a profile decides ([`RobotiqOpen`], `configure`) and the
//! device on its line (`open`); `handgate emulate robotiq` (`emulate`).

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::config::RobotiqProfile;
use super::device::{EmulatedLink, Link, LoopConfig, RobotiqDevice};
use super::emulator::{Gripper, Tuning};
use super::kind::RobotiqEmulate;
use super::regs::{BAUD, SLAVE_ID};
use super::table::Variant;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::front::serve::{Inbox, Queue};
use crate::front::stream::{serve_pty, serve_tcp, StreamLimits};
use crate::kind::{EmulateArgs, Emulation};
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
    /// Grace for a reply beyond its wire time (`None`: the line's default).
    pub response_timeout: Option<Duration>,
    pub run: LoopConfig,
}

/// Default grace for a reply beyond its wire time on a serial port: a USB adapter's latency
/// (16 ms FTDI default) plus the gripper's own turnaround, with margin (assumed). Over TCP the
/// Modbus kit's default (`RtuTiming::over_tcp`).
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
        response_timeout: r.response_timeout_ms.map(Duration::from_millis),
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
        Line::Serial { .. } | Line::Tcp { .. } => super::rtu::open_link(&c)?,
    };
    Ok(Box::new(RobotiqDevice::start(spec.info(), link, c.run)?))
}

/// The pseudo-terminal `handgate emulate robotiq` links when given no `--pty`.
pub fn emulate_pty(slave: u8) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("handgate-{}-robotiq-slave{slave}", std::process::id()))
}

/// `handgate emulate robotiq`: an emulated gripper answering Modbus RTU (slave 9, no exception
/// responses) on a pseudo-terminal, or RTU over TCP with `--tcp`.
pub fn emulate(args: &EmulateArgs, o: RobotiqEmulate) -> Result<(String, Emulation), DeviceError> {
    let variant = o.variant.unwrap_or_default();
    let slave = o.slave.unwrap_or(SLAVE_ID);
    let tuning = Tuning {
        position_noise: if args.no_noise {
            0.0
        } else {
            Tuning::default().position_noise
        },
        seed: args.seed.unwrap_or(Tuning::default().seed),
        ..Tuning::default()
    };
    let g = Arc::new(Mutex::new(Gripper::new(
        variant.spec(),
        tuning,
        0.0,
        o.object_at.map(f32::from),
        Instant::now(),
    )));
    // Nothing reads the commands of an emulator's sessions: its inbox's queue is closed.
    let (tx, _) = tokio::sync::mpsc::channel(1);
    let inbox = Inbox::for_tests(Queue::new(tx));
    let what = format!(
        "emulating a Robotiq {} (slave {slave}, Modbus RTU, no exception responses)",
        variant.name()
    );
    let make = move || super::front::rtu_session_on(g.clone(), slave);
    let (server, line) = match (o.tcp, o.pty) {
        (Some(at), _) => {
            let s = serve_tcp(
                at,
                StreamLimits::default(),
                make,
                inbox,
                "robotiq emulator",
                "robotiq emulator tcp",
            )
            .map_err(DeviceError::link)?;
            let line = format!(
                "{what} as RTU over TCP on {}: give it as robotiq.tcp",
                s.local_addr.map_or_else(|| at.to_string(), |a| a.to_string())
            );
            (s, line)
        }
        (None, pty) => {
            let link = pty.unwrap_or_else(|| emulate_pty(slave));
            let s =
                serve_pty(&link, make, inbox, "robotiq emulator", "robotiq emulator pty").map_err(DeviceError::link)?;
            (
                s,
                format!("{what} at {} baud on {}: give it as robotiq.port", BAUD, link.display()),
            )
        }
    };
    Ok((line, Emulation::Running(Box::new(server))))
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
