//! The Dex1-1 as a registered device kind: its facts, and how a gripper opens: over DDS as a
//! client of dex1_1_service (or SAKE's EZGripper driver), in the profile's wire variant, or
//! on the emulator backend: the service's emulator on private topics driven by the very
//! same DDS adapter.

use super::adapter::{Dex1GoCodec, Dex1HgCodec, SharedElements, Variant};
use super::config::Dex1Profile;
use super::emulator::{Dex1Config, Dex1Emulator, DEX1_REST_Q};
use super::table::SEED_SPEC_RANGE_RAD;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Hz;
use crate::front::kind::FrontKind;
use crate::kind::{
    DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, Kind, KindFacts, Rates, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::{Side, GRIPPER_JOINTS};
use crate::open::{DeviceSpec, OpenEnv};
use crate::service_client::{emulate_service, ClientOpen, ClientTopics};

impl DeviceKind {
    /// Unitree Dex1-1 parallel gripper (through dex1_1_service over DDS).
    #[allow(non_upper_case_globals)]
    pub const Dex1: DeviceKind = DeviceKind::of(&Dex1Kind);
}

/// The Dex1-1.
#[derive(Debug, Clone, Copy)]
pub struct Dex1Kind;

/// What a Dex1 opens with: a client of dex1_1_service in its wire variant (`go` with the
/// emulated service).
pub type Dex1Open = ClientOpen<Variant, Dex1Config>;

/// `handgate emulate dex1`'s own options.
#[derive(Debug, Default)]
pub struct Dex1Emulate {
    /// Wire variant (default `go`).
    pub variant: Option<Variant>,
}

impl EmulateOptions for Dex1Emulate {
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "variant",
            value: Some("go|hg|actuator"),
            help: "the service's wire variant (default go)",
        },
        EmulateOption {
            name: "service",
            value: None,
            help: "dex1_1_service on DDS (the only thing emulated for a Dex1: accepted for symmetry with dex3)",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        match (name, value) {
            ("variant", Some("go")) => self.variant = Some(Variant::Go),
            ("variant", Some("hg")) => self.variant = Some(Variant::Hg),
            ("variant", Some("actuator")) => self.variant = Some(Variant::Actuator),
            ("variant", Some(other)) => return Err(format!("unknown dex1 variant {other:?} (go, hg, actuator)")),
            _ => {}
        }
        Ok(())
    }
}

impl Kind for Dex1Kind {
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];
    const FACTS: KindFacts = KindFacts {
        fronts: &[FrontKind::Dex1],
        sections: &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }],
        // dex1_1_service's loop.
        ..KindFacts::new(
            "dex1",
            &GRIPPER_JOINTS,
            &[Backend::Dds, Backend::Emulator],
            Rates::fixed(super::SERVICE_HZ),
        )
    };
    type Config = Dex1Profile;
    type Open = Dex1Open;
    type Emulate = Dex1Emulate;

    fn table(&self, side: Side, config: &Dex1Profile) -> DeviceTable {
        super::table::table(side, config.range_rad() as f32)
    }

    /// 0 (open) ..= 2π, the widest range in the field (the seed spec's).
    fn hardware_range(&self, _side: Side, joint: &str) -> Option<(f64, f64)> {
        GRIPPER_JOINTS
            .contains(&joint)
            .then_some((0.0, f64::from(SEED_SPEC_RANGE_RAD)))
    }

    fn configure(&self, spec: &DeviceSpec<'_, Dex1Profile>) -> Result<Dex1Open, DeviceError> {
        let missing = "no dds topics (side center without dds.cmd_topic / state_topic)";
        let variant = match spec.backend {
            Backend::Dds => spec.config.variant(),
            // The emulated dex1_1_service speaks `go`, on private topics.
            _ => Variant::Go,
        };
        ClientOpen::of(spec, spec.config.topics(spec.side), missing, variant, |cmd, state| {
            let mut peer = Dex1Config::new(Variant::Go, spec.side);
            peer.initial_q = spec.initial_wire("jaw", DEX1_REST_Q);
            peer.noise = spec
                .emulator
                .noise_for(spec.name, crate::dex3::physical::HG_MOTOR_NOISE);
            peer.object = spec.object_wire("jaw");
            peer.rate = Hz(spec.rate_hz);
            peer.topics = Some((cmd, state));
            peer
        })
    }

    fn served(&self, open: &Dex1Open) -> Vec<crate::discovery::diagnose::Served> {
        match open.codec {
            Variant::Hg => open.config.served::<Dex1HgCodec>(),
            _ => open.config.served::<Dex1GoCodec>(),
        }
    }

    fn open(
        &self,
        open: Dex1Open,
        spec: &DeviceSpec<'_, Dex1Profile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        if open.codec == Variant::Hg {
            return open.start(Dex1HgCodec, spec, env, Dex1Emulator::start);
        }
        // The actuator variant's grippers on one command topic share their commands.
        let key = format!("dex1 elements {}", open.config.cmd_topic);
        let shared = env.shared.get_or_default::<SharedElements>(&key);
        let codec = Dex1GoCodec::with_shared(open.codec, spec.side, shared);
        open.start(codec, spec, env, Dex1Emulator::start)
    }

    /// `handgate emulate dex1`: dex1_1_service (or SAKE's driver) in the `--variant` wire
    /// variant on DDS.
    fn emulate(&self, args: &EmulateArgs, options: Dex1Emulate) -> Result<(String, Emulation), DeviceError> {
        let variant = options.variant.unwrap_or(Variant::Go);
        let side = match variant {
            // One actuator service serves both grippers.
            Variant::Actuator => args.side.unwrap_or(Side::Left),
            _ => args.side("dex1")?,
        };
        let mut cfg = Dex1Config::new(variant, side);
        cfg.noise = args.noise(crate::dex3::physical::HG_MOTOR_NOISE);
        let (cmd, state) = variant.topics(side);
        let what = format!(
            "emulating dex1_1_service ({variant}): {cmd}, {state} on DDS domain {}",
            args.domain
        );
        // The actuator pair's stuck jaw: `--side`'s gripper (default left), or the one its
        // URDF name names.
        let mut hands = match variant {
            Variant::Actuator => [Side::Right, Side::Left]
                .map(|s| (s, super::adapter::actuator_index(s)))
                .to_vec(),
            _ => vec![(side, 0)],
        };
        hands.sort_by_key(|(s, _)| *s != side);
        Ok((
            what,
            emulate_service(args, DeviceKind::Dex1, &hands, |node| Dex1Emulator::start(node, cfg))?,
        ))
    }
}
