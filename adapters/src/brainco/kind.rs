//! The BrainCo Revo2 as a registered device kind: its facts, and how a hand opens: a client
//! of `brainco_hand_service` over DDS, or on the emulator backend of the service's emulator
//! on private topics, through the very same codec (`crate::service_client`).

use super::adapter::BraincoCodec;
use super::config::BraincoProfile;
use super::emulator::{BraincoConfig, BraincoEmulator, BRAINCO_DEFAULT_HZ, BRAINCO_NOISE, BRAINCO_REST_Q};
use super::table::JOINTS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::front::kind::FrontKind;
use crate::kind::{DeviceKind, EmulateArgs, Emulation, Kind, KindFacts, Rates, SectionSpec, Sides};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};
use crate::service_client::{emulate_service, ClientOpen};

impl DeviceKind {
    /// BrainCo Revo2 hand (through `brainco_hand_service` over DDS).
    #[allow(non_upper_case_globals)]
    pub const Brainco: DeviceKind = DeviceKind::of(&BraincoKind);
}

/// The BrainCo Revo2.
#[derive(Debug, Clone, Copy)]
pub struct BraincoKind;

/// What a BrainCo hand opens with: a client sending this finger speed in every entry's `dq`
/// (and on the emulator backend, the emulated service).
pub type BraincoOpen = ClientOpen<f32, BraincoConfig>;

impl Kind for BraincoKind {
    const FACTS: KindFacts = KindFacts {
        // `brainco_hand_service`'s own interface (`rt/brainco/{side}/*`): `super::serve`.
        fronts: &[FrontKind::Brainco],
        sides: Sides::LeftOrRight { note: "" },
        sections: &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }],
        // The service's loop (docs/sources.md §7); the emulated service runs at the device's.
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
        let missing = "a brainco hand is left or right (or names dds.cmd_topic and dds.state_topic)";
        ClientOpen::of(
            spec,
            spec.config.topics(spec.side),
            missing,
            spec.config.speed(),
            |cmd, state| {
                let mut peer = BraincoConfig::new(spec.side);
                for (i, joint) in JOINTS.iter().enumerate() {
                    peer.initial[i] = spec.initial_wire(joint, BRAINCO_REST_Q[i]);
                    peer.object[i] = spec.object_wire(joint);
                }
                peer.noise = spec.emulator.noise_for(spec.name, BRAINCO_NOISE);
                peer.rate = Hz(spec.rate_hz);
                peer.topics = Some((cmd, state));
                peer
            },
        )
    }

    fn served(&self, open: &BraincoOpen) -> Vec<crate::discovery::diagnose::Served> {
        open.config.served::<BraincoCodec>()
    }

    fn open(
        &self,
        open: BraincoOpen,
        spec: &DeviceSpec<'_, BraincoProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let codec = BraincoCodec::new(open.codec);
        open.start(codec, spec, env, BraincoEmulator::start)
    }

    /// `handgate emulate brainco --side left|right`: one hand's `brainco_hand_service` on DDS.
    fn emulate(&self, args: &EmulateArgs, _options: ()) -> Result<(String, Emulation), DeviceError> {
        let side = args.side("brainco")?;
        let Some((cmd, state)) = super::topics(side) else {
            return Err(DeviceError::Config("a brainco hand is left or right".into()));
        };
        let mut cfg = BraincoConfig::new(side);
        cfg.noise = args.noise(BRAINCO_NOISE);
        let what = format!(
            "emulating brainco_hand_service ({side} hand): {cmd}, {state} on DDS domain {}",
            args.domain
        );
        Ok((what, emulate_service(args, |node| BraincoEmulator::start(node, cfg))?))
    }
}
