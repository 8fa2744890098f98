//! Opening a BrainCo hand: over DDS as a client of `brainco_hand_service`, or on the emulator
//! backend: the service's emulator on private topics driven by the very same codec.

use super::adapter::BraincoCodec;
use super::emulator::{BraincoConfig, BraincoEmulator, BRAINCO_NOISE, BRAINCO_REST_Q};
use super::kind::BraincoProfile;
use super::table::JOINTS;
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// What a BrainCo hand opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub enum BraincoOpen {
    /// A client of `brainco_hand_service`, sending `speed` in every entry's `dq`.
    Dds { config: DdsDeviceConfig, speed: f32 },
    /// The service's emulator (`peer`, on private topics) and the client of it.
    Emulated {
        peer: BraincoConfig,
        config: DdsDeviceConfig,
        speed: f32,
    },
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_>) -> Result<BraincoOpen, DeviceError> {
    let profile = spec.config::<BraincoProfile>().cloned().unwrap_or_default();
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
                "a brainco hand is left or right (or names dds.cmd_topic and dds.state_topic)".into(),
            ));
        };
        return Ok(BraincoOpen::Dds {
            config: cfg(cmd, state),
            speed: profile.speed(),
        });
    }
    let (cmd_t, state_t) = emulator_topics(spec.name);
    let mut peer = BraincoConfig::new(spec.side);
    for (i, joint) in JOINTS.iter().enumerate() {
        peer.initial[i] = spec.initial_wire(joint, BRAINCO_REST_Q[i]);
        peer.object[i] = spec.object_wire(joint);
    }
    peer.noise = spec.emulator.noise_for(spec.name, BRAINCO_NOISE);
    peer.rate = Hz(spec.rate_hz);
    peer.topics = Some((cmd_t.clone(), state_t.clone()));
    Ok(BraincoOpen::Emulated {
        peer,
        config: cfg(cmd_t, state_t),
        speed: profile.speed(),
    })
}

/// What a BrainCo hand opened from `spec` serves on DDS.
pub fn served(spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
    match configure(spec) {
        Ok(BraincoOpen::Dds { config, .. } | BraincoOpen::Emulated { config, .. }) => config.served::<BraincoCodec>(),
        Err(_) => Vec::new(),
    }
}

/// Opens a BrainCo hand on its backend.
pub fn open(spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
    Ok(match configure(spec)? {
        BraincoOpen::Dds { config, speed } => Box::new(DdsDevice::start(
            env.node,
            spec.info(),
            config,
            BraincoCodec::new(speed),
        )?),
        BraincoOpen::Emulated { peer, config, speed } => {
            let peer = BraincoEmulator::start(env.node, peer)?;
            let device = DdsDevice::start(env.node, spec.info(), config, BraincoCodec::new(speed))?;
            Box::new(WithPeer::new(device, peer))
        }
    })
}

/// `handgate emulate brainco --side left|right`: one hand's `brainco_hand_service` on DDS.
pub fn emulate(args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
    if args.socket.is_some() || args.service || args.variant.is_some() || !args.ids.is_empty() || args.pty.is_some() {
        return Err(DeviceError::Config(
            "emulating a brainco takes --side, --domain, --interface, --no-noise and --seed only".into(),
        ));
    }
    let side = args.side("brainco")?;
    let Some((cmd, state)) = super::topics(side) else {
        return Err(DeviceError::Config("a brainco hand is left or right".into()));
    };
    let node = args.node()?;
    let mut cfg = BraincoConfig::new(side);
    cfg.noise = args.noise(BRAINCO_NOISE);
    let emu = BraincoEmulator::start(&node, cfg)?;
    let what = format!(
        "emulating brainco_hand_service ({side} hand): {cmd}, {state} on DDS domain {}",
        args.domain
    );
    Ok((what, Emulation::Running(Box::new((emu, node)))))
}
