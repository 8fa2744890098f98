//! The [`Kind`] of every register-mapped hand: `[devices.<kind>]` keys ([`LineSection`]), the
//! fleet rules (one baud per port, distinct slave ids), one line per port shared by its
//! devices (`prepare`), `handgate emulate <kind>` on a pty. A kind is [`HandKind`] over its
//! [`RegisterHand`].

use std::collections::{BTreeMap, HashMap};
use std::marker::PhantomData;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Deserializer};

use super::device::ModbusHandDevice;
use super::emulated::{serve_pty, Cores, EmulatedLine};
use super::line::{HandLine, LineConfig};
use super::{EmuSpec, RegisterHand};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceCtx, EmulateArgs, EmulateOption, EmulateOptions, Emulation, FleetMember, FleetProblem, Kind, KindFacts,
    Problem, Settings,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};
use crate::serial::{Connector, SerialConnector, Transport, TransportError};

/// `[devices.<kind>]`: a hand on an RS-485 line (or RTU over TCP).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LineSection {
    /// The serial port of the line (an emulated line is keyed by it too).
    pub port: String,
    /// Absent: the hand's own (`RegisterHand::BAUD`, `RegisterHand::SLAVE`).
    pub baud: Option<u32>,
    pub slave: Option<u8>,
    /// RTU frames over TCP to this address (a serial-to-Ethernet gateway) instead of `port`.
    pub tcp: Option<SocketAddr>,
    /// Grace for a reply beyond its wire time, ms (turnaround, USB adapter latency).
    pub response_timeout_ms: u64,
}

impl Default for LineSection {
    fn default() -> Self {
        LineSection {
            port: "/dev/ttyUSB0".into(),
            baud: None,
            slave: None,
            tcp: None,
            response_timeout_ms: 20,
        }
    }
}

/// A register-mapped hand's profile keys: `[devices.<H::FACTS.name>]`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HandProfile<H: RegisterHand> {
    pub section: Option<LineSection>,
    _hand: PhantomData<H>,
}

impl<'de, H: RegisterHand> Deserialize<'de> for HandProfile<H> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = BTreeMap::<String, LineSection>::deserialize(d)?;
        let section = map.remove(H::FACTS.name);
        if let Some(k) = map.keys().next() {
            return Err(serde::de::Error::unknown_field(k, &[H::FACTS.name]));
        }
        Ok(HandProfile {
            section,
            _hand: PhantomData,
        })
    }
}

/// A section with the hand's defaults filled in.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    pub port: String,
    pub baud: u32,
    pub slave: u8,
    pub tcp: Option<SocketAddr>,
    pub response_timeout: Duration,
}

impl Resolved {
    /// What the line is keyed by: the TCP address or the port.
    pub fn key(&self) -> String {
        self.tcp.map_or_else(|| self.port.clone(), |a| a.to_string())
    }
}

impl<H: RegisterHand> HandProfile<H> {
    pub fn resolved(&self) -> Resolved {
        let s = self.section.clone().unwrap_or_default();
        Resolved {
            port: s.port,
            baud: s.baud.unwrap_or(H::BAUD),
            slave: s.slave.unwrap_or(H::SLAVE),
            tcp: s.tcp,
            response_timeout: Duration::from_millis(s.response_timeout_ms),
        }
    }
}

impl<H: RegisterHand> Settings for HandProfile<H> {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let Some(s) = &self.section else { return out };
        let name = H::FACTS.name;
        if s.port.trim().is_empty() && s.tcp.is_none() {
            out.push(Problem::new(
                &[name, "port"],
                "must name a serial port, e.g. /dev/ttyUSB0",
            ));
        }
        if let Some(b) = s.baud.filter(|b| !H::BAUDS.contains(b)) {
            out.push(Problem::new(
                &[name, "baud"],
                format!("{b} is not a baud rate the hand takes ({:?})", H::BAUDS),
            ));
        }
        if let Some(id) = s.slave.filter(|id| !(1..=247).contains(id)) {
            out.push(Problem::new(
                &[name, "slave"],
                format!("must be between 1 and 247, got {id}"),
            ));
        }
        if !(1..=1000).contains(&s.response_timeout_ms) {
            out.push(Problem::new(
                &[name, "response_timeout_ms"],
                format!("must be between 1 and 1000 ms, got {}", s.response_timeout_ms),
            ));
        }
        out
    }

    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        let r = self.resolved();
        match r.tcp {
            Some(a) => format!(", RTU over TCP {a} slave {}", r.slave),
            None => format!(", {} @ {} baud slave {}", r.port, r.baud, r.slave),
        }
    }

    fn serial_ports(&self) -> Vec<PathBuf> {
        let r = self.resolved();
        if r.tcp.is_some() {
            Vec::new()
        } else {
            vec![PathBuf::from(r.port)]
        }
    }
}

/// RTU over TCP: a connection per (re)connect.
#[derive(Debug, Clone)]
pub struct TcpConnector(pub SocketAddr);

impl Connector for TcpConnector {
    fn connect(&mut self) -> Result<Box<dyn Transport>, TransportError> {
        Ok(Box::new(crate::modbus::master::TcpTransport::connect(
            self.0,
            Duration::from_secs(2),
        )?))
    }

    fn describe(&self) -> String {
        format!("Modbus RTU over TCP {}", self.0)
    }
}

/// The kind of a register-mapped hand `H`.
#[derive(Debug, Clone, Copy, Default)]
pub struct HandKind<H>(PhantomData<fn() -> H>);

impl<H> HandKind<H> {
    pub const NEW: Self = HandKind(PhantomData);
}

/// What one hand opens with, decided from the profile.
#[derive(Debug, Clone, PartialEq)]
pub struct HandOpen {
    pub line: Resolved,
    pub emulated: Option<EmuSpec>,
    pub stale_after: Duration,
}

fn emu_spec<H: RegisterHand>(spec: &DeviceSpec<'_, HandProfile<H>>) -> EmuSpec {
    let n = spec.table.joints.iter().map(|j| j.wire_index + 1).max().unwrap_or(0);
    let mut e = EmuSpec {
        slave: spec.config.resolved().slave,
        start: vec![0.0; n],
        object_at: vec![None; n],
    };
    for j in &spec.table.joints {
        e.start[j.wire_index] = spec.initial_wire(j.name, j.q_to_wire(0.0));
        e.object_at[j.wire_index] = spec.object_wire(j.name);
    }
    e
}

impl<H: RegisterHand> Kind for HandKind<H> {
    const FACTS: KindFacts = H::FACTS;
    type Config = HandProfile<H>;
    type Open = HandOpen;
    type Emulate = HandEmulate;

    fn table(&self, side: Side, _config: &HandProfile<H>) -> DeviceTable {
        H::table(side)
    }

    /// The emulated registers carry no noise: the noise keys are refused, not ignored.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        [
            ("noise", section.noise.is_some()),
            ("seed", section.seed.is_some()),
            ("position_noise_rad", section.position_noise_rad.is_some()),
            ("velocity_noise_rad_s", section.velocity_noise_rad_s.is_some()),
            ("torque_noise_nm", section.torque_noise_nm.is_some()),
        ]
        .into_iter()
        .filter(|(_, set)| *set)
        .map(|(key, _)| {
            Problem::new(
                &["emulator", key],
                format!(
                    "has no effect on a {}: its emulated registers carry no noise, remove it",
                    H::FACTS.name
                ),
            )
        })
        .collect()
    }

    /// Hands on one port share one baud and need distinct slave ids.
    fn validate_fleet(&self, members: &[FleetMember<'_, HandProfile<H>>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut bauds: HashMap<String, (usize, u32)> = HashMap::new();
        let mut slaves: HashMap<(String, u8), usize> = HashMap::new();
        for m in members {
            let r = m.config.resolved();
            match bauds.get(&r.key()) {
                Some(&(j, b)) if b != r.baud => out.push((
                    m.index,
                    Problem::new(
                        &[H::FACTS.name, "baud"],
                        format!(
                            "{} baud on {}, where devices[{j}] runs {b}: one line, one baud",
                            r.baud,
                            r.key()
                        ),
                    ),
                )),
                Some(_) => {}
                None => {
                    bauds.insert(r.key(), (m.index, r.baud));
                }
            }
            if let Some(j) = slaves.insert((r.key(), r.slave), m.index) {
                out.push((
                    m.index,
                    Problem::new(
                        &[H::FACTS.name, "slave"],
                        format!("slave {} on {} is also devices[{j}]", r.slave, r.key()),
                    ),
                ));
            }
        }
        out
    }

    fn prepare(&self, devices: &[DeviceSpec<'_, HandProfile<H>>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        let mut by_line: BTreeMap<String, Vec<DeviceSpec<'_, HandProfile<H>>>> = BTreeMap::new();
        for d in devices {
            by_line.entry(d.config.resolved().key()).or_default().push(*d);
        }
        for (key, devs) in by_line {
            let first = devs[0].config.resolved();
            let hz = devs.iter().map(|d| d.rate_hz).fold(0.0, f64::max);
            let cfg = LineConfig {
                baud: first.baud,
                slaves: devs.iter().map(|d| d.config.resolved().slave).collect(),
                response_timeout: first.response_timeout,
                period: (hz > 0.0).then(|| Duration::from_secs_f64(1.0 / hz)),
                state: H::STATE,
                target: H::TARGET,
                init: H::INIT,
                over_tcp: first.tcp.is_some(),
            };
            let connector: Box<dyn Connector> = if devs.iter().any(|d| d.backend == Backend::Emulator) {
                let cores: Cores<H::Core> = Arc::new(Mutex::new(
                    devs.iter()
                        .map(|d| {
                            let e = emu_spec(d);
                            (e.slave, H::core(&e))
                        })
                        .collect(),
                ));
                Box::new(EmulatedLine::new(cores, first.baud))
            } else if let Some(a) = first.tcp {
                Box::new(TcpConnector(a))
            } else {
                Box::new(SerialConnector {
                    path: first.port.clone().into(),
                    baud: first.baud,
                })
            };
            let line = HandLine::start(connector, cfg).map_err(DeviceError::link)?;
            env.shared.insert(&key, Arc::new(line));
        }
        Ok(())
    }

    fn configure(&self, spec: &DeviceSpec<'_, HandProfile<H>>) -> Result<HandOpen, DeviceError> {
        Ok(HandOpen {
            line: spec.config.resolved(),
            emulated: (spec.backend == Backend::Emulator).then(|| emu_spec(spec)),
            stale_after: spec.stale_after,
        })
    }

    fn open(
        &self,
        open: HandOpen,
        spec: &DeviceSpec<'_, HandProfile<H>>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let key = open.line.key();
        let line = env
            .shared
            .get::<Arc<HandLine>>(&key)
            .cloned()
            .ok_or_else(|| DeviceError::Config(format!("no {} line open on {key}", H::FACTS.name)))?;
        Ok(Box::new(ModbusHandDevice::<H>::start(
            spec.info(),
            line,
            open.line.slave,
            open.stale_after,
        )?))
    }

    fn emulate(&self, _args: &EmulateArgs, options: HandEmulate) -> Result<(String, Emulation), DeviceError> {
        let slaves = if options.slaves.is_empty() {
            vec![H::SLAVE]
        } else {
            options.slaves
        };
        let baud = options.baud.unwrap_or(H::BAUD);
        let name = H::FACTS.name;
        let link = options
            .pty
            .unwrap_or_else(|| std::env::temp_dir().join(format!("handgate-{}-{name}", std::process::id())));
        let table = H::table(Side::Right);
        let cores: Cores<H::Core> = Arc::new(Mutex::new(
            slaves
                .iter()
                .map(|s| {
                    let n = table.joints.iter().map(|j| j.wire_index + 1).max().unwrap_or(0);
                    let mut start = vec![0.0; n];
                    for j in &table.joints {
                        start[j.wire_index] = j.q_to_wire(0.0);
                    }
                    let e = EmuSpec {
                        slave: *s,
                        start,
                        object_at: vec![None; n],
                    };
                    (*s, H::core(&e))
                })
                .collect(),
        ));
        let server = serve_pty(&link, cores, baud, name).map_err(DeviceError::link)?;
        let list: Vec<String> = slaves.iter().map(u8::to_string).collect();
        let what = format!(
            "emulating {name} slave(s) {} (Modbus RTU @ {baud} baud) on {}",
            list.join(", "),
            link.display()
        );
        Ok((what, Emulation::Running(Box::new(server))))
    }
}

/// `handgate emulate <kind>`'s own options.
#[derive(Debug, Default)]
pub struct HandEmulate {
    pub slaves: Vec<u8>,
    pub pty: Option<PathBuf>,
    pub baud: Option<u32>,
}

impl EmulateOptions for HandEmulate {
    const COMMON: &'static [&'static str] = &[];
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "slaves",
            value: Some("ID,ID,.."),
            help: "slave ids on the emulated line (default: the hand's own)",
        },
        EmulateOption {
            name: "pty",
            value: Some("PATH"),
            help: "where to link the line's pseudo-terminal (default: a temporary path); give it as the device's port",
        },
        EmulateOption {
            name: "baud",
            value: Some("BAUD"),
            help: "the line's baud rate (frame gap); default: the hand's own",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        let v = value.unwrap_or_default();
        match name {
            "slaves" => {
                for s in v.split(',') {
                    match s.trim().parse::<u8>() {
                        Ok(id) if (1..=247).contains(&id) => self.slaves.push(id),
                        _ => return Err(format!("`{s}` is not a slave id (1-247)")),
                    }
                }
            }
            "baud" => self.baud = Some(v.parse().map_err(|_| format!("`{v}` is not a baud rate"))?),
            _ => self.pty = Some(v.into()),
        }
        Ok(())
    }
}
