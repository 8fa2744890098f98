//! The Inspire DFX (`inspire_dfx`) as a registered device kind: its facts, and how a hand
//! opens: over DDS as a client of DFX_inspire_service, or on the emulator backend: ONE
//! emulated service for every emulated DFX hand of the profile (on private topics, opened
//! once in `prepare` and kept in the open environment), each hand driven by the very same
//! DDS codec.

use std::sync::Arc;

use super::adapter::{DfxCodec, SharedTargets};
use super::config::DfxProfile;
use super::emulator::{DfxConfig, DfxEmulator, DFX_NOISE};
use super::table::JOINTS;
use super::{HAND_ENTRIES, SERVICE_RATE_HZ};
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::{Fault, Hz};
use crate::front::kind::FrontKind;
use crate::kind::{
    DeviceCtx, DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, FleetMember, FleetProblem, Kind,
    KindFacts, Problem, Rates, SectionSpec, Sides,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};
use crate::service_client::ClientTopics;

impl DeviceKind {
    /// Inspire DFX (RH56DFX) hand, through DFX_inspire_service over DDS.
    #[allow(non_upper_case_globals)]
    pub const InspireDfx: DeviceKind = DeviceKind::of(&InspireDfxKind);
}

/// The Inspire DFX.
#[derive(Debug, Clone, Copy)]
pub struct InspireDfxKind;

const NAME: &str = "inspire_dfx";

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
        /// The fault this hand's `[devices.emulator]` injects into the shared service (a stuck
        /// joint at its entry in the 12).
        fault: Option<Fault>,
    },
}

/// `handgate emulate inspire_dfx`: one service for both hands (`--side` only names the hand of
/// a `--fault stuck=<joint>` given by its canonical name).
#[derive(Debug, Default)]
pub struct DfxEmulate;

impl EmulateOptions for DfxEmulate {
    const OPTIONS: &'static [EmulateOption] = &[];
}

fn element<C>(spec: &DeviceSpec<'_, C>) -> Result<usize, DeviceError> {
    super::element(spec.side)
        .ok_or_else(|| DeviceError::Config("an inspire_dfx hand is left or right, not center".into()))
}

/// The fault `spec`'s `[devices.emulator]` injects into the shared service: a stuck joint at
/// the hand's entry in the 12.
fn hand_fault<C>(spec: &DeviceSpec<'_, C>) -> Result<Option<Fault>, DeviceError> {
    let start = element(spec)? * HAND_ENTRIES;
    Ok(spec.emulator_fault()?.map(|f| match f {
        Fault::Stuck(entry) => Fault::Stuck(start + entry),
        other => other,
    }))
}

/// The emulated service for the emulated hands `devs` (at most one per side): each hand's
/// `emulator.initial` and `object_at` on its own six entries, the first hand's noise.
pub fn service_config<C>(devs: &[DeviceSpec<'_, C>]) -> Result<DfxConfig, DeviceError> {
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

impl Kind for InspireDfxKind {
    const FACTS: KindFacts = KindFacts {
        // DFX_inspire_service's own interface (`rt/inspire/*`, both hands): `super::serve`.
        fronts: &[FrontKind::InspireDfx],
        // The message holds a right (0–5) and a left (6–11) hand: no center.
        sides: Sides::LeftOrRight {
            note: " (its service's message has entries 0-5 right, 6-11 left)",
        },
        sections: &[SectionSpec {
            key: "dds",
            backends: &[Backend::Dds],
        }],
        // 100 Hz: xr_teleoperate's publish rate and the service's nominal loop
        // (docs/sources.md §7).
        ..KindFacts::new(
            NAME,
            &JOINTS,
            &[Backend::Dds, Backend::Emulator],
            Rates::fixed(SERVICE_RATE_HZ),
        )
    };
    type Config = DfxProfile;
    type Open = DfxOpen;
    type Emulate = DfxEmulate;
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];

    fn table(&self, side: Side, _config: &DfxProfile) -> DeviceTable {
        super::table::table(side)
    }

    fn configure(&self, spec: &DeviceSpec<'_, DfxProfile>) -> Result<DfxOpen, DeviceError> {
        let element = element(spec)?;
        if spec.backend == Backend::Dds {
            let (cmd, state) = spec.config.topics(spec.side);
            let config = spec.dds_client(cmd.unwrap_or_default(), state.unwrap_or_default());
            return Ok(DfxOpen::Dds { config, element });
        }
        let (cmd, state) = emulator_topics(EMULATED_SERVICE);
        Ok(DfxOpen::Emulated {
            config: spec.dds_client(cmd, state),
            element,
            service: Box::new(service_config(std::slice::from_ref(spec))?),
            fault: hand_fault(spec)?,
        })
    }

    fn served(&self, open: &DfxOpen) -> Vec<crate::discovery::diagnose::Served> {
        match open {
            DfxOpen::Dds { config, .. } | DfxOpen::Emulated { config, .. } => config.served::<DfxCodec>(),
        }
    }

    /// The service reports only `q`: velocity and torque noise have nothing to act on.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        section
            .keys_set()
            .into_iter()
            .filter(|k| matches!(*k, "velocity_noise_rad_s" | "torque_noise_nm"))
            .map(|key| {
                Problem::new(
                    &["emulator", key],
                    "has no effect on an inspire_dfx: its service reports only q (no velocity or torque), remove it",
                )
            })
            .collect()
    }

    /// Emulated hands share one emulated service (one per profile): two on one side would
    /// write the same six entries.
    fn validate_fleet(&self, members: &[FleetMember<'_, DfxProfile>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut seen: Vec<(Side, usize)> = Vec::new();
        for m in members.iter().filter(|m| m.ctx.backend == Backend::Emulator) {
            match seen.iter().find(|(s, _)| *s == m.ctx.side) {
                Some((_, j)) => out.push((
                    m.index,
                    Problem::new(
                        &["side"],
                        format!(
                            "devices[{j}] is the emulated {} hand already: emulated {NAME} devices share one service, one per side",
                            m.ctx.side
                        ),
                    ),
                )),
                None => seen.push((m.ctx.side, m.index)),
            }
        }
        out
    }

    /// Starts the one emulated service the profile's emulated DFX hands share, with each hand's
    /// fault (frozen and ignore-commands act on both hands: they share one message).
    fn prepare(&self, devices: &[DeviceSpec<'_, DfxProfile>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        let emulated: Vec<DeviceSpec<'_, DfxProfile>> = devices
            .iter()
            .filter(|d| d.backend == Backend::Emulator)
            .copied()
            .collect();
        if emulated.is_empty() {
            return Ok(());
        }
        let service = DfxEmulator::start(env.node, service_config(&emulated)?)?;
        for d in &emulated {
            if let Some(f) = hand_fault(d)? {
                service.inject(f)?;
            }
        }
        env.shared.insert(EMULATED_SERVICE, Arc::new(service));
        Ok(())
    }

    /// The hands on one command topic share their targets (`SharedTargets`, in `env.shared`
    /// under the topic): every message carries both.
    fn open(
        &self,
        open: DfxOpen,
        spec: &DeviceSpec<'_, DfxProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let topic = match &open {
            DfxOpen::Dds { config, .. } | DfxOpen::Emulated { config, .. } => {
                format!("inspire_dfx targets {}", config.cmd_topic)
            }
        };
        let shared = env.shared.get_or_default::<SharedTargets>(&topic);
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
    fn emulate(&self, args: &EmulateArgs, _options: DfxEmulate) -> Result<(String, Emulation), DeviceError> {
        let node = args.node()?;
        let cfg = DfxConfig {
            noise: args.noise(DFX_NOISE),
            ..DfxConfig::default()
        };
        let emu = DfxEmulator::start(&node, cfg)?;
        // Both hands in one message: frozen and ignore-commands act on both; a stuck joint is
        // on `--side`'s hand (default right), or the one its URDF name names.
        let side = args.side.unwrap_or(Side::Right);
        let mut hands: Vec<(Side, usize)> = [Side::Right, Side::Left]
            .into_iter()
            .filter_map(|s| Some((s, super::element(s)? * HAND_ENTRIES)))
            .collect();
        hands.sort_by_key(|(s, _)| *s != side);
        args.inject_fault(&emu, DeviceKind::InspireDfx, &hands)?;
        let (cmd, state) = emu.topics();
        let what = format!(
            "emulating DFX_inspire_service (both hands, entries 0-5 right, 6-11 left): {cmd}, {state} on DDS domain {}",
            args.domain
        );
        Ok((what, Emulation::Running(Box::new((emu, node)))))
    }
}
