//! Opening EZGrippers: every gripper on one port shares one [`EzGripperBus`] (one thread,
//! sync read/write for all its servos), opened once for all of them before any device
//! (`prepare`) and kept in the open environment under its port. On the emulator backend the
//! bus is a virtual MX-64 bus on a pseudo-terminal ([`VirtualBus`]) that the driver opens like
//! a real /dev/ttyUSB0.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use super::adapter::EzGripperDevice;
use super::config::{EzGripperConfig, EzProfile};
use super::driver::{BusConfig, EzGripperBus, GripperConfig};
use super::emulator::{EmulatorConfig, ServoSpec, VirtualBus, MX64_NOISE};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::dynamixel::protocol::ServoId;
use crate::emu_common::Injected;
use crate::kind::{DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// The pseudo-terminal an emulated bus keyed `key` is linked at.
fn pty_link(key: &str) -> PathBuf {
    let safe: String = key
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    std::env::temp_dir().join(format!("handgate-{}-ezgripper{safe}", std::process::id()))
}

fn section(spec: &DeviceSpec<'_, EzProfile>) -> EzGripperConfig {
    spec.config.section()
}

/// The bus configuration for the grippers on one port (`devices`, all on that port). Bus-wide
/// keys (baud, response timeout, the driver's constants) come from the first gripper; the
/// validator makes every gripper on a serial port agree on the baud.
pub fn bus_config(devices: &[DeviceSpec<'_, EzProfile>]) -> Result<BusConfig, DeviceError> {
    let first = section(&devices[0]);
    let mut grippers = Vec::new();
    for d in devices {
        let s = section(d);
        let id = ServoId::new(s.servo_id_for(d.side)).map_err(DeviceError::config)?;
        // An emulated gripper with an object between its fingers would calibrate onto the
        // object: unless the profile gives a zero, it gets the emulated servo's closed stop.
        let zero_ticks = match s.zero_ticks {
            None if d.backend == Backend::Emulator && d.object_wire("jaw").is_some() => {
                Some(ServoSpec::new(id.get()).closed_stop_ticks)
            }
            z => z,
        };
        grippers.push(GripperConfig { id, zero_ticks });
    }
    let defaults = BusConfig::default();
    Ok(BusConfig {
        baud: first.baud,
        grippers,
        // An emulated gripper powers up uncalibrated, like a real one: calibrate it.
        calibrate_on_start: devices
            .iter()
            .any(|d| section(d).calibrate_on_start || d.backend == Backend::Emulator),
        response_timeout_ms: first.response_timeout_ms.unwrap_or(defaults.response_timeout_ms),
        // A measurement older than the devices' `stale_after` is stale (the same bound as
        // every other kind's; the shortest of the bus's devices).
        stale_after_ms: devices
            .iter()
            .map(|d| d.stale_after)
            .min()
            .unwrap_or_default()
            .as_millis() as u64,
        ezgripper: super::EzGripperParams {
            // The profile's max_open_percent is both the Dex1 scale and the clamp.
            max_open_pct: f32::from(first.max_open_percent),
            ..first.params.clone().unwrap_or_default()
        },
        ..defaults
    })
}

/// The virtual bus emulating the grippers `devs` on one port (`cfg`: their bus): one servo
/// per gripper, each with its `[devices.emulator]` object; the first gripper's noise.
pub fn emulator_config(devs: &[DeviceSpec<'_, EzProfile>], cfg: &BusConfig) -> Result<EmulatorConfig, DeviceError> {
    let ids: Vec<u8> = cfg.grippers.iter().map(|g| g.id.get()).collect();
    let mut emu = EmulatorConfig::with_ids(&ids);
    emu.baud = cfg.baud;
    emu.noise = devs[0].emulator.noise_for(devs[0].name, MX64_NOISE);
    for d in devs.iter().filter(|d| d.backend == Backend::Emulator) {
        let c = configure(d)?;
        if let Some(servo) = emu.servos.iter_mut().find(|v| v.id == c.id.get()) {
            if let Some(e) = c.emulated {
                servo.object_at_ticks = e.object_at_ticks;
                servo.faults = e.faults;
                if let Some(t) = e.start_ticks {
                    servo.start_ticks = servo.closed_stop_ticks + t;
                }
            }
        }
    }
    Ok(emu)
}

/// Opens one bus per port for `devices` (every EZGripper of the fleet).
pub fn prepare(devices: &[DeviceSpec<'_, EzProfile>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
    let mut by_port: BTreeMap<String, Vec<DeviceSpec<'_, EzProfile>>> = BTreeMap::new();
    for d in devices {
        by_port.entry(section(d).port).or_default().push(*d);
    }
    for (port, devs) in by_port {
        let cfg = bus_config(&devs)?;
        let bus = if devs.iter().any(|d| d.backend == Backend::Emulator) {
            // The emulated servos answer on the bus thread itself (VirtualBus::in_process):
            // the same driver, the same wire timing, no thread of their own to be late.
            let (emu, connector) = VirtualBus::in_process(emulator_config(&devs, &cfg)?);
            env.shared.insert(&port, Arc::new(emu));
            EzGripperBus::with_connector(connector, cfg)
        } else {
            EzGripperBus::open(PathBuf::from(&port), cfg)
        }
        .map_err(DeviceError::link)?;
        env.shared.insert(&port, Arc::new(bus));
    }
    Ok(())
}

/// What one EZGripper opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub struct EzOpen {
    /// The port (or, emulated, the virtual bus's key) its bus is kept under.
    pub port: String,
    /// Its bus's configuration were it alone on it (`prepare` merges the grippers of a port).
    pub bus: BusConfig,
    pub id: ServoId,
    /// Grip force limit, % of the servo's current limit.
    pub force_pct: f32,
    /// Emulator backend: what its emulated servo gets from `[devices.emulator]`.
    pub emulated: Option<EmulatedServo>,
}

/// What `[devices.emulator]` sets on an emulated EZGripper's servo.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatedServo {
    /// Measurement noise (on a shared bus the first gripper's applies to the bus).
    pub noise: crate::sim::Noise,
    /// `object_at.jaw`: an object between the fingers, ticks above the closed stop (the jaw
    /// position as percent open, scaled by the driver's `grip_max_ticks`).
    pub object_at_ticks: Option<i32>,
    /// `initial.jaw`: where the jaw is at power-up, ticks above the closed stop (same
    /// scaling); `None`: the emulator's default.
    pub start_ticks: Option<i32>,
    /// `fault`: what the servo injects.
    pub faults: Injected<1>,
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_, EzProfile>) -> Result<EzOpen, DeviceError> {
    let s = section(spec);
    let bus = bus_config(std::slice::from_ref(spec))?;
    let ticks = |pct: f32| (pct.clamp(0.0, 100.0) / 100.0 * bus.ezgripper.grip_max_ticks as f32).round() as i32;
    let emulated = match spec.backend {
        Backend::Emulator => Some(EmulatedServo {
            noise: spec.emulator.noise_for(spec.name, MX64_NOISE),
            object_at_ticks: spec.object_wire("jaw").map(ticks),
            start_ticks: spec
                .emulator
                .initial
                .contains_key("jaw")
                .then(|| ticks(spec.initial_wire("jaw", 0.0))),
            faults: Injected::of(spec.emulator_fault()?, "an EZGripper")?,
        }),
        _ => None,
    };
    Ok(EzOpen {
        emulated,
        bus,
        id: ServoId::new(s.servo_id_for(spec.side)).map_err(DeviceError::config)?,
        force_pct: s.force_limit_percent.map(f32::from).unwrap_or(100.0),
        port: s.port,
    })
}

/// Opens one EZGripper on the bus `prepare` opened for its port.
pub fn open(
    c: EzOpen,
    spec: &DeviceSpec<'_, EzProfile>,
    env: &mut OpenEnv<'_>,
) -> Result<Box<dyn HandDevice>, DeviceError> {
    let bus = env
        .shared
        .get::<Arc<EzGripperBus>>(&c.port)
        .cloned()
        .ok_or_else(|| DeviceError::Config(format!("no bus open on {}", c.port)))?;
    Ok(Box::new(EzGripperDevice::start(spec.info(), bus, c.id, c.force_pct)?))
}

/// `handgate emulate ezgripper`'s own options: the servos on the emulated bus and where its
/// pseudo-terminal is linked. No DDS: no domain or interface.
#[derive(Debug, Default)]
pub struct EzEmulate {
    /// Servo ids on the bus (default: the side's).
    pub ids: Vec<u8>,
    /// Where to link the pseudo-terminal (default: a temporary path).
    pub pty: Option<std::path::PathBuf>,
}

impl EmulateOptions for EzEmulate {
    const COMMON: &'static [&'static str] = &["side", "no-noise", "seed", "fault"];
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "ids",
            value: Some("ID,ID,.."),
            help: "servo ids on the emulated bus (default: the side's)",
        },
        EmulateOption {
            name: "pty",
            value: Some("PATH"),
            help: "where to link the bus's pseudo-terminal (default: a temporary path); give it as ezgripper.port",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        let v = value.unwrap_or_default();
        match name {
            "ids" => {
                for id in v.split(',') {
                    self.ids.push(
                        id.trim()
                            .parse()
                            .map_err(|_| format!("`{id}` is not a servo id (0-252)"))?,
                    );
                }
            }
            _ => self.pty = Some(v.into()),
        }
        Ok(())
    }
}

/// `handgate emulate ezgripper`: EZGrippers on a virtual MX-64 bus behind a pseudo-terminal
/// (`--ids`, default the side's servo id); prints the path to give as `ezgripper.port`.
pub fn emulate(args: &EmulateArgs, options: EzEmulate) -> Result<(String, Emulation), DeviceError> {
    let ids = if options.ids.is_empty() {
        vec![super::driver::default_id(args.side.unwrap_or_default()).get()]
    } else {
        options.ids
    };
    for id in &ids {
        ServoId::new(*id).map_err(DeviceError::config)?;
    }
    let link = options.pty.unwrap_or_else(|| {
        pty_link(&format!(
            "-emulate-{}",
            ids.iter().map(u8::to_string).collect::<Vec<_>>().join("-")
        ))
    });
    let mut cfg = EmulatorConfig::with_ids(&ids);
    cfg.noise = args.noise(MX64_NOISE);
    // Every servo on the bus is one jaw: the fault acts on each.
    let side = args.side.unwrap_or_default();
    let faults = Injected::of(args.fault_on(DeviceKind::Ezgripper, &[(side, 0)])?, "an EZGripper")?;
    for servo in &mut cfg.servos {
        servo.faults = faults;
    }
    let bus = VirtualBus::start(&link, cfg).map_err(DeviceError::link)?;
    let what = format!(
        "emulating EZGripper servo id(s) {} at 1000000 baud on {}",
        ids.iter().map(u8::to_string).collect::<Vec<_>>().join(", "),
        bus.path().display()
    );
    Ok((what, Emulation::Running(Box::new(bus))))
}
