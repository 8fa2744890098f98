//! The G1's `rt/hand_sdk` interface as a registered device kind: its facts, and how a device
//! opens: the DDS adapter publishing the ramped blend on the profile's topic, or on the
//! emulator backend the ai_sport blend emulator on a private topic driven by the very same
//! adapter.

use super::adapter::{HandSdkCodec, WeightRamp};
use super::config::HandSdkProfile;
use super::emulator::{HandSdkConfig, HandSdkEmulator};
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceCtx, DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, Kind, KindFacts, Problem, Rates,
    SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// The G1's `rt/hand_sdk` interface to an internally wired hand (4 motors).
    #[allow(non_upper_case_globals)]
    pub const HandSdk: DeviceKind = DeviceKind::of(&HandSdkKind);
}

/// The G1's `rt/hand_sdk` interface.
#[derive(Debug, Clone, Copy)]
pub struct HandSdkKind;

/// What an `rt/hand_sdk` device opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub struct HandSdkOpen {
    pub config: DdsDeviceConfig,
    pub ramp: WeightRamp,
    /// Emulator backend: the ai_sport blend emulator listening on `config.cmd_topic`.
    pub peer: Option<HandSdkConfig>,
}

/// `handgate emulate hand_sdk`: the blend publishes no state (nothing to place, no noise) and
/// serves both hands on one topic (no side).
#[derive(Debug, Default)]
pub struct HandSdkEmulate;

impl EmulateOptions for HandSdkEmulate {
    const COMMON: &'static [&'static str] = &["domain", "interface"];
    const OPTIONS: &'static [EmulateOption] = &[];
}

impl Kind for HandSdkKind {
    const FACTS: KindFacts = KindFacts {
        sections: &[SectionSpec {
            key: "hand_sdk",
            backends: &[Backend::Dds, Backend::Emulator],
        }],
        ..KindFacts::new(
            "hand_sdk",
            &super::JOINTS,
            &[Backend::Dds, Backend::Emulator],
            Rates::fixed(200.0),
        )
    };
    type Config = HandSdkProfile;
    type Open = HandSdkOpen;
    type Emulate = HandSdkEmulate;

    fn table(&self, side: Side, _config: &HandSdkProfile) -> DeviceTable {
        super::table::table(side)
    }

    fn configure(&self, spec: &DeviceSpec<'_, HandSdkProfile>) -> Result<HandSdkOpen, DeviceError> {
        let section = spec.config.section();
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
            config: spec.dds_client_at(section.publish_hz.unwrap_or(spec.rate_hz), topic, None),
            ramp: spec.config.ramp(),
            peer,
        })
    }

    /// Its command topic only.
    fn served(&self, open: &HandSdkOpen) -> Vec<crate::discovery::diagnose::Served> {
        open.config.served::<HandSdkCodec>()
    }

    fn open(
        &self,
        c: HandSdkOpen,
        spec: &DeviceSpec<'_, HandSdkProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
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

    /// The emulated ai_sport blend publishes no state and the adapter reads none: no
    /// `[devices.emulator]` key (initial posture, object, noise) could change what handgate
    /// sees, so each one set is refused.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        section
            .keys_set()
            .into_iter()
            .map(|key| {
                Problem::new(
                    &["emulator", key],
                    "has no effect on a hand_sdk: its emulator (the ai_sport blend) publishes no state \
                     (no position, torque or noise to emulate), remove it",
                )
            })
            .collect()
    }

    /// `handgate emulate hand_sdk`: ai_sport's `rt/hand_sdk` blend on DDS.
    fn emulate(&self, args: &EmulateArgs, _options: HandSdkEmulate) -> Result<(String, Emulation), DeviceError> {
        let node = args.node()?;
        let cfg = HandSdkConfig::default();
        let what = format!(
            "emulating ai_sport's hand SDK blend on {} on DDS domain {}",
            cfg.topic, args.domain
        );
        let emu = HandSdkEmulator::start(&node, cfg)?;
        Ok((what, Emulation::Running(Box::new((emu, node)))))
    }
}
