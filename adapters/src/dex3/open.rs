//! Opening a Dex3-1: over DDS as a client of a G1's resident service, over USB (a real hand
//! or the MCU emulator process behind `usb.socket`), or on the emulator backend (the MCU
//! emulator in-process, at the USB transport seam).

use std::time::Duration;

use super::config::{BusSlot, Dex3Profile, WiringConfig};
use super::dds_client::Dex3DdsCodec;
use super::dds_service_emulator::{Dex3ServiceConfig, Dex3ServiceEmulator};
use super::usb::adapter::{Dex3UsbDevice, UsbSource};
use super::usb::{run_emulator_server, BusAddr, BusId, DeviceId, EmulatorClock, EmulatorConfig, LoopConfig, WiringMap};
use crate::dds_device::{DdsDevice, DdsDeviceConfig};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Injected;
use crate::kind::{EmulateArgs, EmulateOption, EmulateOptions, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// The profile's (partial) wiring over the USB adapter's default map.
pub fn wiring(w: Option<&WiringConfig>) -> Result<WiringMap, DeviceError> {
    let mut m = WiringMap::default();
    let Some(w) = w else { return Ok(m) };
    let bad = |what: String| DeviceError::Config(what);
    let addr = |s: &BusSlot| -> Result<BusAddr, DeviceError> {
        Ok(BusAddr {
            bus: BusId::new(s.bus).map_err(DeviceError::config)?,
            id: DeviceId::new(s.id).map_err(DeviceError::config)?,
        })
    };
    for (name, slot) in &w.joints {
        let j = super::JOINTS
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| bad(format!("unknown joint {name}")))?;
        m.motors[j] = addr(slot)?;
    }
    for (name, slot) in &w.pads {
        let i: usize = name
            .strip_prefix("pad_")
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| bad(format!("unknown pad {name}")))?;
        *m.pads.get_mut(i).ok_or_else(|| bad(format!("unknown pad {name}")))? = addr(slot)?;
    }
    m.validate().map_err(DeviceError::config)?;
    Ok(m)
}

/// Where a Dex3 on backend usb or emulator sends its frames: `usb.socket` (the MCU emulator
/// in another process), the hand on USB (by `usb.serial`), or the emulator in-process.
pub fn usb_source<C: ?Sized>(spec: &DeviceSpec<'_, C>, profile: &Dex3Profile) -> UsbSource {
    let usb = profile.usb.clone().unwrap_or_default();
    if spec.backend == Backend::Usb {
        return match usb.socket {
            Some(path) => UsbSource::Socket(path),
            None => UsbSource::Hardware { serial: usb.serial },
        };
    }
    let mut q = [0.0f32; super::MOTOR_COUNT];
    let mut contacts = [None; super::MOTOR_COUNT];
    for j in &spec.table.joints {
        // Joints the profile does not place start at the hand's rest posture.
        let rest = super::physical::rest_wire(spec.side, j.wire_index);
        q[j.wire_index] = spec.initial_wire(j.name, rest);
        contacts[j.wire_index] = spec
            .object_wire(j.name)
            .map(|at| object_contact(spec.side, j.wire_index, at));
    }
    UsbSource::Emulator(Box::new(EmulatorConfig {
        initial_q: Some(q),
        noise: spec.emulator.noise_for(spec.name, super::physical::HG_MOTOR_NOISE),
        contacts,
        ..Default::default()
    }))
}

/// An emulated object blocking motor `i` (IDL order) of a `side` hand at wire position `at`:
/// it pushes back once the joint passes `at` in its closing direction (the table's wire sign
/// for the joint and side), with the service emulator's contact stiffness.
pub fn object_contact(side: crate::model::Side, i: usize, at: f32) -> crate::sim::Contact {
    crate::sim::Contact {
        at,
        dir: super::table::wire_sign(side, i),
        stiffness: super::dds_service_emulator::Dex3Tuning::default().contact_stiffness,
    }
}

/// What a Dex3 opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Dex3Open {
    /// A client of a G1's resident service.
    Dds { config: DdsDeviceConfig, timeout_bit: bool },
    /// The USB frame loop on `source` (a hand, the MCU emulator process or in-process).
    Usb { source: UsbSource, config: LoopConfig },
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_, Dex3Profile>) -> Result<Dex3Open, DeviceError> {
    let profile = spec.config;
    let timeout_bit = profile.timeout_bit();
    if spec.backend == Backend::Dds {
        let (Some(cmd_topic), Some(state_topic)) = profile.topics(spec.side) else {
            return Err(DeviceError::Config(
                "no dds topics (side center without dds.cmd_topic / state_topic)".into(),
            ));
        };
        let config = spec.dds_client(cmd_topic, state_topic);
        return Ok(Dex3Open::Dds { config, timeout_bit });
    }
    let usb = profile.usb.clone().unwrap_or_default();
    let mut source = usb_source(spec, profile);
    if let UsbSource::Emulator(cfg) = &mut source {
        cfg.faults = Injected::of(spec.emulator_fault()?, "a Dex3-1")?;
    }
    let config = LoopConfig {
        period: Duration::from_secs_f64(1.0 / spec.rate_hz.max(1.0)),
        timeout_bit,
        hold_kp: spec.table.hold_kp,
        hold_kd: spec.table.hold_kd,
        wiring: wiring(usb.wiring.as_ref())?,
        scalings: usb.scalings.unwrap_or_default(),
        align: usb.align(),
        // The spin before each deadline buys period jitter for real hardware; an emulated
        // hand has no use for it, and a fleet of them would burn a core on it
        // (docs/benchmarks.md, fleet scale).
        spin: match source {
            UsbSource::Emulator(_) => Duration::ZERO,
            _ => LoopConfig::default().spin,
        },
        // Emulated hands share one grid of deadlines: a fleet of them wakes together
        // (docs/benchmarks.md, fleet scale); a real hand keeps its own phase.
        shared_grid: matches!(source, UsbSource::Emulator(_)),
        ..Default::default()
    };
    Ok(Dex3Open::Usb { source, config })
}

/// Opens a Dex3 on its backend.
pub fn open(
    open: Dex3Open,
    spec: &DeviceSpec<'_, Dex3Profile>,
    env: &mut OpenEnv<'_>,
) -> Result<Box<dyn HandDevice>, DeviceError> {
    Ok(match open {
        Dex3Open::Dds { config, timeout_bit } => Box::new(DdsDevice::start(
            env.node,
            spec.info(),
            config,
            Dex3DdsCodec { timeout_bit },
        )?),
        Dex3Open::Usb { source, config } => {
            Box::new(Dex3UsbDevice::start(spec.info(), source, config).map_err(DeviceError::link)?)
        }
    })
}

/// `handgate emulate dex3`'s own options: what stands in for the hand.
#[derive(Debug, Default)]
pub struct Dex3Emulate {
    /// The hand's MCU behind this Unix socket (the USB frame protocol).
    pub socket: Option<std::path::PathBuf>,
    /// The G1's resident hand service on DDS instead of the MCU.
    pub service: bool,
}

impl EmulateOptions for Dex3Emulate {
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "socket",
            value: Some("PATH"),
            help: "the hand's MCU behind this Unix socket, speaking the USB frame protocol (point a device at it with usb.socket)",
        },
        EmulateOption {
            name: "service",
            value: None,
            help: "the G1's resident Dex3 hand service on DDS instead of the MCU",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        match name {
            "socket" => self.socket = value.map(Into::into),
            _ => self.service = true,
        }
        Ok(())
    }
}

/// `handgate emulate dex3`: the hand's MCU on a Unix socket (`--socket`), or the G1's resident
/// hand service on DDS (`--service`).
pub fn emulate(args: &EmulateArgs, options: Dex3Emulate) -> Result<(String, Emulation), DeviceError> {
    let side = args.side("dex3")?;
    let noise = args.noise(super::physical::HG_MOTOR_NOISE);
    let hand = [(side, 0)];
    match (&options.socket, options.service) {
        (Some(socket), false) => {
            let socket = socket.clone();
            let what = format!("emulating a Dex3-1 {side} hand on {}", socket.display());
            let cfg = EmulatorConfig {
                clock: EmulatorClock::Wall,
                noise,
                faults: Injected::of(args.fault_on(crate::model::DeviceKind::Dex3, &hand)?, "a Dex3-1")?,
                ..Default::default()
            };
            let run = move || run_emulator_server(&socket, side, cfg).map_err(DeviceError::link);
            Ok((what, Emulation::Blocking(Box::new(run))))
        }
        (None, true) => {
            let node = args.node()?;
            let mut cfg = Dex3ServiceConfig::new(side);
            cfg.noise = noise;
            let emu = Dex3ServiceEmulator::start(&node, cfg)?;
            args.inject_fault(&emu, crate::model::DeviceKind::Dex3, &hand)?;
            let (cmd, state) = super::dds_client::topics(side, super::dds_client::StateSource::State);
            let what = format!(
                "emulating the G1's Dex3-1 {side} hand service: {cmd}, {state} and its rt/lf copy on DDS domain {}",
                args.domain
            );
            Ok((what, Emulation::Running(Box::new((emu, node)))))
        }
        _ => Err(DeviceError::Config(
            "emulating a dex3 takes --socket PATH (the hand's MCU) or --service (the G1's hand service)".into(),
        )),
    }
}
