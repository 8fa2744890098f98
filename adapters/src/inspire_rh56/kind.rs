//! The Inspire RH56 (DFX, E2, DFTP) driven directly as a registered device kind: its facts,
//! its table (the Inspire hand's, shared with the DFX and FTP kinds), how hands open (one line
//! per port, `prepare`) and `handgate emulate inspire_rh56`.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::adapter::Rh56Device;
use super::bus::{BusConfig, EmulatedLine, Rh56Bus};
use super::config::Protocol;
use super::config::{Rh56Config, Rh56Profile};
use super::emulator::{HandSpec, Line, Rh56Hand};
use super::pty::{PtyLine, TcpLine};
use super::regs::FINGERS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, FleetMember, FleetProblem, Kind, KindFacts,
    Problem, Rates, SectionSpec, Sides,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// Inspire RH56DFX / RH56E2 / RH56DFTP on its own RS-485 line.
    #[allow(non_upper_case_globals)]
    pub const InspireRh56: DeviceKind = DeviceKind::of(&InspireRh56Kind);
}

/// The Inspire RH56 driven directly.
#[derive(Debug, Clone, Copy)]
pub struct InspireRh56Kind;

/// The device loop's default rate: what Unitree's DFX service polls its hands at
/// (`inspire_dfx::SERVICE_RATE_HZ`).
pub const DEFAULT_RATE_HZ: f64 = crate::inspire_dfx::SERVICE_RATE_HZ;

impl Kind for InspireRh56Kind {
    const FACTS: KindFacts = KindFacts {
        sides: Sides::LeftOrRight { note: ", not center" },
        fronts: &[crate::front::kind::FrontKind::InspireRh56],
        sections: &[SectionSpec {
            key: "inspire_rh56",
            backends: &[Backend::Serial, Backend::Emulator],
        }],
        ..KindFacts::new(
            "inspire_rh56",
            &crate::inspire_dfx::table::JOINTS,
            &[Backend::Serial, Backend::Emulator],
            Rates::fixed(DEFAULT_RATE_HZ),
        )
    };
    type Config = Rh56Profile;
    type Open = Rh56Open;
    type Emulate = Rh56Emulate;

    fn table(&self, side: Side, _config: &Rh56Profile) -> DeviceTable {
        DeviceTable {
            kind: DeviceKind::InspireRh56,
            ..crate::inspire_ftp::table::table(side)
        }
    }

    fn validate_emulator(
        &self,
        _ctx: &crate::kind::DeviceCtx<'_>,
        section: &crate::open::EmulatorSection,
    ) -> Vec<Problem> {
        let mut out = Vec::new();
        for (key, set) in [
            ("noise", section.noise.is_some()),
            ("seed", section.seed.is_some()),
            ("velocity_noise_rad_s", section.velocity_noise_rad_s.is_some()),
            ("torque_noise_nm", section.torque_noise_nm.is_some()),
            ("position_noise_rad", section.position_noise_rad.is_some()),
        ] {
            if set {
                out.push(Problem::new(
                    &["emulator", key],
                    "has no effect on an inspire_rh56: its emulated registers carry no noise, remove it",
                ));
            }
        }
        if section.object_at.contains_key("thumb_rotate") {
            out.push(Problem::new(
                &["emulator", "object_at", "thumb_rotate"],
                "has no effect on an inspire_rh56: the thumb rotation never closes on an object (place it on \
                 thumb_bend), remove it",
            ));
        }
        out
    }

    /// Hands on one port share one baud and need distinct ids.
    fn validate_fleet(&self, members: &[FleetMember<'_, Rh56Profile>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut ports: HashMap<String, (usize, u32)> = HashMap::new();
        let mut ids: HashMap<(String, u8), usize> = HashMap::new();
        for m in members {
            let c = m.config.section();
            match ports.get(&c.port) {
                Some(&(j, baud)) if baud != c.baud => out.push((
                    m.index,
                    Problem::new(
                        &["inspire_rh56", "baud"],
                        format!(
                            "devices[{j}] uses {} at {baud} baud; one line has one baud rate",
                            c.port
                        ),
                    ),
                )),
                Some(_) => {}
                None => {
                    ports.insert(c.port.clone(), (m.index, c.baud));
                }
            }
            if let Some(j) = ids.insert((c.port.clone(), c.id), m.index) {
                out.push((
                    m.index,
                    Problem::new(
                        &["inspire_rh56", "id"],
                        format!("hand id {} on {} is also devices[{j}]", c.id, c.port),
                    ),
                ));
            }
        }
        out
    }

    fn prepare(&self, devices: &[DeviceSpec<'_, Rh56Profile>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        let mut by_port: BTreeMap<String, Vec<DeviceSpec<'_, Rh56Profile>>> = BTreeMap::new();
        for d in devices {
            by_port.entry(d.config.section().port).or_default().push(*d);
        }
        for (port, devs) in by_port {
            let cfg = bus_config(&devs);
            let bus = if devs.iter().any(|d| d.backend == Backend::Emulator) {
                let hands = devs.iter().map(|d| Rh56Hand::new(hand_spec(d))).collect();
                let line = Arc::new(Mutex::new(Line::new(hands)));
                env.shared.insert(&format!("{port}#emulated"), line.clone());
                Rh56Bus::with_connector(
                    Box::new(EmulatedLine {
                        line,
                        baud: cfg.baud,
                        protocol: cfg.protocol,
                    }),
                    cfg,
                )
            } else {
                Rh56Bus::open(&port, cfg)
            }
            .map_err(DeviceError::link)?;
            env.shared.insert(&port, Arc::new(bus));
        }
        Ok(())
    }

    fn configure(&self, spec: &DeviceSpec<'_, Rh56Profile>) -> Result<Rh56Open, DeviceError> {
        let c = spec.config.section();
        Ok(Rh56Open {
            bus: bus_config(std::slice::from_ref(spec)),
            emulated: (spec.backend == Backend::Emulator).then(|| hand_spec(spec)),
            stale_after: spec.stale_after,
            config: c,
        })
    }

    fn emulate(&self, _args: &EmulateArgs, options: Rh56Emulate) -> Result<(String, Emulation), DeviceError> {
        let ids = if options.ids.is_empty() { vec![1] } else { options.ids };
        let link = options.pty.unwrap_or_else(|| {
            std::env::temp_dir().join(format!(
                "handgate-{}-inspire_rh56-{}",
                std::process::id(),
                ids.iter().map(u8::to_string).collect::<Vec<_>>().join("-")
            ))
        });
        let hands = ids
            .iter()
            .map(|id| {
                let mut s = HandSpec::new(*id);
                s.tactile = options.tactile;
                Rh56Hand::new(s)
            })
            .collect();
        let list = ids.iter().map(u8::to_string).collect::<Vec<_>>().join(", ");
        if let Some(at) = options.tcp {
            let line = TcpLine::start(at, Line::new(hands)).map_err(DeviceError::link)?;
            let what = format!(
                "emulating RH56 hand id(s) {list} (Modbus TCP, unit = id) on {}",
                line.addr
            );
            return Ok((what, Emulation::Running(Box::new(line))));
        }
        let protocol = if options.modbus {
            Protocol::ModbusRtu
        } else {
            Protocol::Serial
        };
        let line = PtyLine::start_with(&link, Line::new(hands), protocol).map_err(DeviceError::link)?;
        let what = format!(
            "emulating RH56 hand id(s) {list} ({}) on {}",
            if options.modbus {
                "Modbus RTU"
            } else {
                "the serial protocol"
            },
            line.path().display()
        );
        Ok((what, Emulation::Running(Box::new(line))))
    }

    fn open(
        &self,
        open: Rh56Open,
        spec: &DeviceSpec<'_, Rh56Profile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let bus = env
            .shared
            .get::<Arc<Rh56Bus>>(&open.config.port)
            .cloned()
            .ok_or_else(|| DeviceError::Config(format!("no RH56 line open on {}", open.config.port)))?;
        Ok(Box::new(Rh56Device::start(
            spec.info(),
            bus,
            open.config.id,
            open.stale_after,
        )?))
    }
}

/// The line's configuration for the hands `devices` (all on one port): bus-wide keys from the
/// first (the validator makes every hand on a port agree on the baud); the fastest device's
/// rate sets the round period.
pub fn bus_config(devices: &[DeviceSpec<'_, Rh56Profile>]) -> BusConfig {
    let first = devices[0].config.section();
    let hz = devices.iter().map(|d| d.rate_hz).fold(0.0, f64::max);
    BusConfig {
        baud: first.baud,
        ids: devices.iter().map(|d| d.config.section().id).collect(),
        response_timeout: Duration::from_millis(first.response_timeout_ms),
        period: (hz > 0.0).then(|| Duration::from_secs_f64(1.0 / hz)),
        slow_every: first.slow_every.max(1),
        force_set: first.force_set,
        speed_set: first.speed_set,
        stale_after: devices.iter().map(|d| d.stale_after).min().unwrap_or_default(),
        protocol: first.protocol,
        tactile: first.tactile,
    }
}

/// The emulated hand of `spec`: its id, `[devices.emulator]`'s `initial` and `object_at`
/// as angles (through the device's table).
pub fn hand_spec(spec: &DeviceSpec<'_, Rh56Profile>) -> HandSpec {
    let c = spec.config.section();
    let mut h = HandSpec::new(c.id);
    h.tactile = c.tactile;
    for j in spec.table.joints.iter().filter(|j| j.wire_index < FINGERS) {
        h.start[j.wire_index] = spec.initial_wire(j.name, 1000.0).clamp(0.0, 1000.0);
        h.object_at[j.wire_index] = spec.object_wire(j.name).map(|a| a.clamp(0.0, 1000.0));
    }
    h
}

/// What one RH56 opens with, decided from the profile before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Rh56Open {
    pub config: Rh56Config,
    /// Its line's configuration were it alone on it (`prepare` merges the hands of a port).
    pub bus: BusConfig,
    /// Emulator backend: its emulated hand.
    pub emulated: Option<HandSpec>,
    pub stale_after: Duration,
}

/// `handgate emulate inspire_rh56`'s own options.
#[derive(Debug, Default)]
pub struct Rh56Emulate {
    /// Hand ids on the line (default 1).
    pub ids: Vec<u8>,
    /// Where to link the pseudo-terminal.
    pub pty: Option<PathBuf>,
    /// The hands are DFTPs (tactile cells read contact).
    pub tactile: bool,
    /// Modbus RTU on the pty instead of the serial protocol.
    pub modbus: bool,
    /// Modbus TCP on this address instead of a pty.
    pub tcp: Option<std::net::SocketAddr>,
}

impl EmulateOptions for Rh56Emulate {
    const COMMON: &'static [&'static str] = &[];
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "ids",
            value: Some("ID,ID,.."),
            help: "hand ids on the emulated line (default 1)",
        },
        EmulateOption {
            name: "pty",
            value: Some("PATH"),
            help: "where to link the line's pseudo-terminal (default: a temporary path); give it as inspire_rh56.port",
        },
        EmulateOption {
            name: "tactile",
            value: None,
            help: "emulate DFTPs: their tactile cells read the fingers' contact",
        },
        EmulateOption {
            name: "modbus",
            value: None,
            help: "answer Modbus RTU on the pty instead of the hand's serial protocol",
        },
        EmulateOption {
            name: "tcp",
            value: Some("ADDR"),
            help: "serve Modbus TCP on ADDR (e.g. 127.0.0.1:6000, the DFTP's port) instead of a pty",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        let v = value.unwrap_or_default();
        match name {
            "ids" => {
                for id in v.split(',') {
                    let id: u8 = id
                        .trim()
                        .parse()
                        .map_err(|_| format!("`{id}` is not a hand id (1-254)"))?;
                    if id == 0 || id == 255 {
                        return Err(format!("`{id}` is not a hand id (1-254)"));
                    }
                    self.ids.push(id);
                }
            }
            "tactile" => self.tactile = true,
            "modbus" => self.modbus = true,
            "tcp" => {
                self.tcp = Some(
                    v.parse()
                        .map_err(|_| format!("`{v}` is not an address and port, e.g. 127.0.0.1:6000"))?,
                )
            }
            _ => self.pty = Some(v.into()),
        }
        Ok(())
    }
}
