//! Opening an Inspire DFX hand: over DDS as a client of DFX_inspire_service, or on the
//! emulator backend: ONE emulated service for every emulated DFX hand of the profile (on
//! private topics, opened once in `prepare` and kept in the open environment), each hand
//! driven by the very same DDS codec.

use std::sync::Arc;

use super::adapter::{DfxCodec, SharedTargets};
use super::emulator::{DfxConfig, DfxEmulator, DFX_NOISE};
use super::kind::DfxProfile;
use super::table::JOINTS;
use super::{HAND_ENTRIES, SERVICE_RATE_HZ};
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// The key (in `env.shared`) and the private-topic name of the emulated service every
/// emulated DFX hand of a profile shares.
pub const EMULATED_SERVICE: &str = "inspire_dfx";

/// What an Inspire DFX hand opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub enum DfxOpen {
    /// A client of DFX_inspire_service, writing `element`'s entries.
    Dds { config: DdsDeviceConfig, element: usize },
    /// A client of the shared emulated service (`service`: its settings as this hand's
    /// `[devices.emulator]` makes them; with two hands `prepare` merges both).
    Emulated {
        config: DdsDeviceConfig,
        element: usize,
        service: Box<DfxConfig>,
    },
}

fn element(spec: &DeviceSpec<'_>) -> Result<usize, DeviceError> {
    super::element(spec.side)
        .ok_or_else(|| DeviceError::Config("an inspire_dfx hand is left or right, not center".into()))
}

/// The emulated service for the emulated hands `devs` (at most one per side): each hand's
/// `emulator.initial` and `object_at` on its own six entries, the first hand's noise.
pub fn service_config(devs: &[DeviceSpec<'_>]) -> Result<DfxConfig, DeviceError> {
    let mut cfg = DfxConfig {
        rate: Hz(SERVICE_RATE_HZ),
        topics: Some(emulator_topics(EMULATED_SERVICE)),
        ..DfxConfig::default()
    };
    if let Some(first) = devs.first() {
        cfg.noise = first.emulator.noise_for(first.name, DFX_NOISE);
    }
    for d in devs {
        let e = element(d)?;
        for (i, joint) in JOINTS.iter().enumerate() {
            let entry = e * HAND_ENTRIES + i;
            cfg.initial[entry] = d.initial_wire(joint, cfg.initial[entry]);
            cfg.object_at[entry] = d.object_wire(joint);
        }
    }
    Ok(cfg)
}

/// What an Inspire DFX hand opened from `spec` serves on DDS.
pub fn served(spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
    match configure(spec) {
        Ok(DfxOpen::Dds { config, .. } | DfxOpen::Emulated { config, .. }) => config.served::<DfxCodec>(),
        Err(_) => Vec::new(),
    }
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_>) -> Result<DfxOpen, DeviceError> {
    let element = element(spec)?;
    let cfg = |(cmd_topic, state_topic): (String, String)| DdsDeviceConfig {
        cmd_topic,
        state_topic: Some(state_topic),
        rate_hz: spec.rate_hz,
        stale_after: spec.stale_after,
        forward: spec.forwarding(spec.rate_hz),
    };
    if spec.backend == Backend::Dds {
        let profile = spec.config::<DfxProfile>().cloned().unwrap_or_default();
        return Ok(DfxOpen::Dds {
            config: cfg(profile.topics()),
            element,
        });
    }
    Ok(DfxOpen::Emulated {
        config: cfg(emulator_topics(EMULATED_SERVICE)),
        element,
        service: Box::new(service_config(std::slice::from_ref(spec))?),
    })
}

/// Starts the one emulated service the profile's emulated DFX hands share.
pub fn prepare(devices: &[DeviceSpec<'_>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
    let emulated: Vec<DeviceSpec<'_>> = devices
        .iter()
        .filter(|d| d.backend == Backend::Emulator)
        .copied()
        .collect();
    if emulated.is_empty() {
        return Ok(());
    }
    let service = DfxEmulator::start(env.node, service_config(&emulated)?)?;
    env.shared.insert(EMULATED_SERVICE, Arc::new(service));
    Ok(())
}

/// Opens an Inspire DFX hand on its backend. The hands on one command topic share their
/// targets (`SharedTargets`, in `env.shared` under the topic): every message carries both.
pub fn open(spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
    let open = configure(spec)?;
    let topic = match &open {
        DfxOpen::Dds { config, .. } | DfxOpen::Emulated { config, .. } => {
            format!("inspire_dfx targets {}", config.cmd_topic)
        }
    };
    let shared = match env.shared.get::<SharedTargets>(&topic) {
        Some(s) => s.clone(),
        None => {
            let s = SharedTargets::default();
            env.shared.insert(&topic, s.clone());
            s
        }
    };
    let codec = DfxCodec::with_shared(spec.side, shared)
        .ok_or_else(|| DeviceError::Config("an inspire_dfx hand is left or right, not center".into()))?;
    Ok(match open {
        DfxOpen::Dds { config, .. } => Box::new(DdsDevice::start(env.node, spec.info(), config, codec)?),
        DfxOpen::Emulated { config, .. } => {
            let service = env
                .shared
                .get::<Arc<DfxEmulator>>(EMULATED_SERVICE)
                .cloned()
                .ok_or_else(|| DeviceError::Config("the emulated inspire_dfx service was not started".into()))?;
            let device = DdsDevice::start(env.node, spec.info(), config, codec)?;
            Box::new(WithPeer::new(device, service))
        }
    })
}

/// `handgate emulate inspire_dfx`: one DFX_inspire_service for both hands on DDS.
pub fn emulate(args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
    if args.variant.is_some() || args.socket.is_some() || args.service || !args.ids.is_empty() || args.pty.is_some() {
        return Err(DeviceError::Config(
            "handgate emulate inspire_dfx takes only --domain, --interface, --no-noise and --seed".into(),
        ));
    }
    let node = args.node()?;
    let cfg = DfxConfig {
        noise: args.noise(DFX_NOISE),
        ..DfxConfig::default()
    };
    let emu = DfxEmulator::start(&node, cfg)?;
    let (cmd, state) = emu.topics();
    let what = format!(
        "emulating DFX_inspire_service (both hands, entries 0-5 right, 6-11 left): {cmd}, {state} on DDS domain {}",
        args.domain
    );
    Ok((what, Emulation::Running(Box::new((emu, node)))))
}
