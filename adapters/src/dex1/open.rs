//! Opening a Dex1-1: over DDS as a client of dex1_1_service (or SAKE's EZGripper driver), in
//! the profile's wire variant, or on the emulator backend: the service's emulator on private
//! topics driven by the very same DDS adapter.

use super::adapter::{Dex1GoCodec, Dex1HgCodec, SharedElements, Variant};
use super::emulator::{Dex1Config, Dex1Emulator, DEX1_REST_Q};
use super::kind::Dex1Profile;
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// What a Dex1 opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Dex1Open {
    /// A client of dex1_1_service in `variant`.
    Dds { config: DdsDeviceConfig, variant: Variant },
    /// The service's emulator (`peer`, on private topics) and the `go` client of it.
    Emulated { peer: Dex1Config, config: DdsDeviceConfig },
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_>) -> Result<Dex1Open, DeviceError> {
    let profile = spec.config::<Dex1Profile>().cloned().unwrap_or_default();
    let cfg = |cmd_topic: String, state_topic: String| DdsDeviceConfig {
        cmd_topic,
        state_topic: Some(state_topic),
        rate_hz: spec.rate_hz,
        stale_after: spec.stale_after,
        forward: spec.forwarding(spec.rate_hz),
    };
    if spec.backend == Backend::Dds {
        let (Some(cmd), Some(state)) = super::kind::dds_topics(&profile, spec.side) else {
            return Err(DeviceError::Config(
                "no dds topics (side center without dds.cmd_topic / state_topic)".into(),
            ));
        };
        return Ok(Dex1Open::Dds {
            config: cfg(cmd, state),
            variant: profile.variant(),
        });
    }
    // Emulator backend: dex1_1_service's emulator (variant go) on private topics.
    let (cmd_t, state_t) = emulator_topics(spec.name);
    let mut peer = Dex1Config::new(Variant::Go, spec.side);
    peer.initial_q = spec.initial_wire("jaw", DEX1_REST_Q);
    peer.noise = spec
        .emulator
        .noise_for(spec.name, crate::dex3::physical::HG_MOTOR_NOISE);
    peer.object = spec.object_wire("jaw");
    peer.rate = Hz(spec.rate_hz);
    peer.topics = Some((cmd_t.clone(), state_t.clone()));
    Ok(Dex1Open::Emulated {
        peer,
        config: cfg(cmd_t, state_t),
    })
}

/// What a Dex1 opened from `spec` serves on DDS.
pub fn served(spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
    match configure(spec) {
        Ok(Dex1Open::Dds {
            config,
            variant: Variant::Hg,
        }) => config.served::<Dex1HgCodec>(),
        Ok(Dex1Open::Dds { config, .. } | Dex1Open::Emulated { config, .. }) => config.served::<Dex1GoCodec>(),
        Err(_) => Vec::new(),
    }
}

/// Opens a Dex1 on its backend.
pub fn open(spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
    Ok(match configure(spec)? {
        Dex1Open::Dds {
            config,
            variant: Variant::Hg,
        } => Box::new(DdsDevice::start(env.node, spec.info(), config, Dex1HgCodec)?),
        Dex1Open::Dds { config, variant } => {
            // The actuator variant's grippers on one command topic share their commands.
            let key = format!("dex1 elements {}", config.cmd_topic);
            let shared = match env.shared.get::<SharedElements>(&key) {
                Some(s) => s.clone(),
                None => {
                    let s = SharedElements::default();
                    env.shared.insert(&key, s.clone());
                    s
                }
            };
            Box::new(DdsDevice::start(
                env.node,
                spec.info(),
                config,
                Dex1GoCodec::with_shared(variant, spec.side, shared),
            )?)
        }
        Dex1Open::Emulated { peer, config } => {
            let peer = Dex1Emulator::start(env.node, peer)?;
            let device = DdsDevice::start(env.node, spec.info(), config, Dex1GoCodec::new(Variant::Go, spec.side))?;
            Box::new(WithPeer::new(device, peer))
        }
    })
}

/// `handgate emulate dex1`: dex1_1_service (or SAKE's driver) in the `--variant` wire variant
/// on DDS.
pub fn emulate(args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
    let variant = match args.variant.as_deref().unwrap_or("go") {
        "go" => Variant::Go,
        "hg" => Variant::Hg,
        "actuator" => Variant::Actuator,
        other => {
            return Err(DeviceError::Config(format!(
                "unknown dex1 variant {other:?} (go, hg, actuator)"
            )))
        }
    };
    let side = match variant {
        // One actuator service serves both grippers.
        Variant::Actuator => args.side.unwrap_or(crate::model::Side::Left),
        _ => args.side("dex1")?,
    };
    let node = args.node()?;
    let mut cfg = Dex1Config::new(variant, side);
    cfg.noise = args.noise(crate::dex3::physical::HG_MOTOR_NOISE);
    let emu = Dex1Emulator::start(&node, cfg)?;
    let (cmd, state) = variant.topics(side);
    let what = format!(
        "emulating dex1_1_service ({variant}): {cmd}, {state} on DDS domain {}",
        args.domain
    );
    Ok((what, Emulation::Running(Box::new((emu, node)))))
}
