//! Opening an `rt/hand_sdk` device: the DDS adapter publishing the ramped blend on the
//! profile's topic, or on the emulator backend the ai_sport blend emulator on a private topic
//! driven by the very same adapter.

use super::adapter::{HandSdkCodec, WeightRamp};
use super::emulator::{HandSdkConfig, HandSdkEmulator};
use super::kind::HandSdkProfile;
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// What an `rt/hand_sdk` device opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub struct HandSdkOpen {
    pub config: DdsDeviceConfig,
    pub ramp: WeightRamp,
    /// Emulator backend: the ai_sport blend emulator listening on `config.cmd_topic`.
    pub peer: Option<HandSdkConfig>,
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_>) -> Result<HandSdkOpen, DeviceError> {
    let profile = spec.config::<HandSdkProfile>().cloned().unwrap_or_default();
    let section = profile.section();
    let topic = if spec.backend == Backend::Dds {
        section.topic.clone()
    } else {
        emulator_topics(spec.name).0
    };
    let peer = (spec.backend != Backend::Dds).then(|| HandSdkConfig {
        topic: topic.clone(),
        ..Default::default()
    });
    Ok(HandSdkOpen {
        config: DdsDeviceConfig {
            cmd_topic: topic,
            state_topic: None,
            rate_hz: section.publish_hz.unwrap_or(spec.rate_hz),
            stale_after: spec.stale_after,
            forward: spec.forwarding(section.publish_hz.unwrap_or(spec.rate_hz)),
        },
        ramp: profile.ramp(),
        peer,
    })
}

/// What a hand_sdk device opened from `spec` serves on DDS (its command topic only).
pub fn served(spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
    configure(spec).map_or_else(|_| Vec::new(), |c| c.config.served::<HandSdkCodec>())
}

/// Opens a hand_sdk device on its backend.
pub fn open(spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
    let c = configure(spec)?;
    let codec = HandSdkCodec::new(c.ramp);
    match c.peer {
        None => Ok(Box::new(DdsDevice::start(env.node, spec.info(), c.config, codec)?)),
        Some(peer) => {
            let peer = HandSdkEmulator::start(env.node, peer)?;
            let device = DdsDevice::start(env.node, spec.info(), c.config, codec)?;
            Ok(Box::new(WithPeer::new(device, peer)))
        }
    }
}

/// `handgate emulate hand_sdk`: ai_sport's `rt/hand_sdk` blend on DDS.
pub fn emulate(args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
    let node = args.node()?;
    let cfg = HandSdkConfig::default();
    let what = format!(
        "emulating ai_sport's hand SDK blend on {} on DDS domain {}",
        cfg.topic, args.domain
    );
    let emu = HandSdkEmulator::start(&node, cfg)?;
    Ok((what, Emulation::Running(Box::new((emu, node)))))
}
