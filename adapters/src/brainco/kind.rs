//! The BrainCo Revo2 as a registered device kind: its facts, and how a device opens: over DDS
//! as a client of `brainco_hand_service`, or on the emulator backend, the service's emulator
//! on private topics driven by the very same codec.

use super::adapter::BraincoCodec;
use super::config::BraincoProfile;
use super::emulator::{BraincoConfig, BraincoEmulator, BRAINCO_DEFAULT_HZ, BRAINCO_NOISE, BRAINCO_REST_Q};
use super::table::JOINTS;
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::front::kind::FrontKind;
use crate::kind::{DeviceKind, EmulateArgs, Emulation, Kind, KindFacts, Rates, SectionSpec, Sides};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// BrainCo Revo2 hand (through `brainco_hand_service` over DDS).
    #[allow(non_upper_case_globals)]
    pub const Brainco: DeviceKind = DeviceKind::of(&BraincoKind);
}

/// The BrainCo Revo2.
#[derive(Debug, Clone, Copy)]
pub struct BraincoKind;

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

impl Kind for BraincoKind {
    const FACTS: KindFacts = KindFacts {
        // `brainco_hand_service`'s own interface (`rt/brainco/{side}/*`): `super::serve`.
        fronts: &[FrontKind::Brainco],
        sides: Sides::LeftOrRight { note: "" },
        sections: &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }],
        // 500 Hz: the service's loop (docs/sources.md §7); the emulated service runs at the
        // device's rate.
        ..KindFacts::new(
            "brainco",
            &JOINTS,
            &[Backend::Dds, Backend::Emulator],
            Rates::fixed(BRAINCO_DEFAULT_HZ),
        )
    };
    type Config = BraincoProfile;
    type Open = BraincoOpen;
    type Emulate = ();

    fn table(&self, side: Side, _config: &BraincoProfile) -> DeviceTable {
        super::table::table(side)
    }

    fn configure(&self, spec: &DeviceSpec<'_, BraincoProfile>) -> Result<BraincoOpen, DeviceError> {
        let speed = spec.config.speed();
        if spec.backend == Backend::Dds {
            let (Some(cmd), Some(state)) = spec.config.topics(spec.side) else {
                return Err(DeviceError::Config(
                    "a brainco hand is left or right (or names dds.cmd_topic and dds.state_topic)".into(),
                ));
            };
            let config = spec.dds_client(cmd, state);
            return Ok(BraincoOpen::Dds { config, speed });
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
        let config = spec.dds_client(cmd_t, state_t);
        Ok(BraincoOpen::Emulated { peer, config, speed })
    }

    fn served(&self, open: &BraincoOpen) -> Vec<crate::discovery::diagnose::Served> {
        match open {
            BraincoOpen::Dds { config, .. } | BraincoOpen::Emulated { config, .. } => config.served::<BraincoCodec>(),
        }
    }

    fn open(
        &self,
        open: BraincoOpen,
        spec: &DeviceSpec<'_, BraincoProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        Ok(match open {
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
    fn emulate(&self, args: &EmulateArgs, _options: ()) -> Result<(String, Emulation), DeviceError> {
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
}
