//! The device side of the kit for DDS-service hands.
//!
//! - [`ServiceHand`]: a hand whose robot runs one service per hand on the side's standard
//!   topics (BrainCo, Dex5-1) says what differs (facts, codec, emulated service) and is a
//!   [`Kind`] by the blanket implementation here.
//! - [`DdsProfile`]: the profile keys of a kind whose only section is `[devices.dds]` (topic
//!   overrides checked and defaulted here, the kind's own keys by its [`DdsSection`]).
//! - [`ClientOpen`]: what any service client opens with and how ([`ClientOpen::start`]): on
//!   backend dds a [`DdsDevice`] with the kind's codec on the service's topics; on the
//!   emulator backend the same device driving the service's emulator ([`ServiceEmulator`]
//!   around the kind's core) on the device's private topics ([`emulator_topics`]), started
//!   first and kept with it ([`WithPeer`]). Kinds of another shape (both hands in one message,
//!   a third topic: Dex1, Inspire DFX and FTP, the Dex3 service) use it directly.
//!
//! docs/adapters.md, "Adding a device kind".

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::dds::Node;
use crate::dds_device::{emulator_topics, DdsCodec, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::discovery::diagnose::Served;
use crate::emu_common::{EmulatorError, Hz};
use crate::kind::{
    DdsTopicKeys, DeviceCtx, EmulateArgs, EmulateOptions, Emulation, Kind, KindFacts, Problem, Settings,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, EmulatorSection, OpenEnv};
use crate::service_emulator::{ServiceCore, ServiceEmulator, ServiceWire};
use crate::sim::Noise;

/// What a client of a DDS service hand opens with, decided from the profile before anything
/// starts.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientOpen<S, P> {
    /// The client's topics and timing.
    pub config: DdsDeviceConfig,
    /// What the kind's codec is built from (its profile keys).
    pub codec: S,
    /// Emulator backend: the emulated service's configuration (on the client's topics).
    pub peer: Option<P>,
    /// Emulator backend: the fault its service injects (`[devices.emulator] fault`).
    pub fault: Option<crate::emu_common::Fault>,
}

impl<S, P> ClientOpen<S, P> {
    /// The device `spec` on its backend: on dds a client of the service on `topics` (both
    /// needed: `Err` with `missing` otherwise); on the emulator backend a client of the
    /// service `peer(cmd_topic, state_topic)` builds on the device's private topics.
    pub fn of<C: ?Sized>(
        spec: &DeviceSpec<'_, C>,
        topics: (Option<String>, Option<String>),
        missing: &str,
        codec: S,
        peer: impl FnOnce(String, String) -> P,
    ) -> Result<Self, DeviceError> {
        if spec.backend == Backend::Dds {
            let (Some(cmd), Some(state)) = topics else {
                return Err(DeviceError::Config(missing.into()));
            };
            return Ok(Self {
                config: spec.dds_client(cmd, state),
                codec,
                peer: None,
                fault: None,
            });
        }
        let fault = spec.emulator_fault()?;
        let (cmd, state) = emulator_topics(spec.name);
        Ok(Self {
            config: spec.dds_client(cmd.clone(), state.clone()),
            codec,
            peer: Some(peer(cmd, state)),
            fault,
        })
    }

    /// Starts the device with `codec`, and first its emulated service with `start_peer`
    /// (e.g. `ServiceEmulator::<Core>::start`) when there is one, with its fault injected.
    pub fn start<D, C, K>(
        self,
        codec: D,
        spec: &DeviceSpec<'_, C>,
        env: &mut OpenEnv<'_>,
        start_peer: impl FnOnce(&Node, P) -> Result<ServiceEmulator<K>, EmulatorError>,
    ) -> Result<Box<dyn HandDevice>, DeviceError>
    where
        D: DdsCodec,
        C: ?Sized,
        K: ServiceCore,
        K::Config: Sync,
    {
        let peer = self.peer.map(|p| start_peer(env.node, p)).transpose()?;
        if let (Some(f), Some(peer)) = (self.fault, &peer) {
            peer.inject(f)?;
        }
        let device = DdsDevice::start(env.node, spec.info(), self.config, codec)?;
        Ok(match peer {
            Some(peer) => Box::new(WithPeer::new(device, peer)),
            None => Box::new(device),
        })
    }
}

/// `handgate emulate <kind>` for a service hand: the service `start` starts on the command
/// line's domain, with the command line's `--fault` (joints named as on the `kind` hands
/// `hands`, [`EmulateArgs::fault_on`]), running until the process stops.
pub fn emulate_service<C: ServiceCore>(
    args: &EmulateArgs,
    kind: crate::model::DeviceKind,
    hands: &[(Side, usize)],
    start: impl FnOnce(&Node) -> Result<ServiceEmulator<C>, EmulatorError>,
) -> Result<Emulation, DeviceError> {
    let node = args.node()?;
    let emu = start(&node)?;
    args.inject_fault(&emu, kind, hands)?;
    Ok(Emulation::Running(Box::new((emu, node))))
}

/// The registered kind called `name` (a kind's own name: always registered).
fn registered(name: &str) -> Result<crate::model::DeviceKind, DeviceError> {
    crate::model::DeviceKind::by_name(name).ok_or_else(|| DeviceError::Config(format!("kind {name} is not registered")))
}

/// A hand that is a client of a robot's hand service running one instance per hand on the
/// side's standard topics (BrainCo's `brainco_hand_service`, the Dex5-1 service): what differs
/// from kind to kind. Its [`Kind`] is the blanket implementation below: a client over DDS with
/// the kind's codec, on the emulator backend the kind's emulated service as its peer, and
/// `handgate emulate <kind> --side left|right` running that service alone.
pub trait ServiceHand: Sync + Send + fmt::Debug + 'static {
    /// The kind's facts (most often [`KindFacts::hand_service`]).
    const FACTS: KindFacts;
    /// The service, as `handgate emulate` names it.
    const SERVICE: &'static str;
    /// The faults its emulated service injects ([`Kind::EMULATOR_FAULTS`]).
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];
    /// The emulated service's measurement noise.
    const NOISE: Noise;
    /// The kind's profile keys.
    type Config: Settings + ClientTopics;
    /// What the codec is built from, decided from the profile (and shown by `handgate check`).
    type Wire: Clone + fmt::Debug + PartialEq + Send + Sync + 'static;
    type Codec: DdsCodec;
    /// The options of `handgate emulate <kind>` besides the common ones (`()`: none).
    type Emulate: EmulateOptions;
    /// The emulated service's core; its configuration holds one entry per joint in
    /// `FACTS.joints` order ([`EmulatedHand`]).
    type Core: ServiceCore<Config: EmulatedHand + fmt::Debug + Clone + PartialEq> + ServiceWire<Self::Core>;

    /// The kind's mapping table for `side` with its own configuration applied.
    fn table(side: Side, config: &Self::Config) -> DeviceTable;
    fn wire(config: &Self::Config) -> Self::Wire;
    fn codec(wire: Self::Wire) -> Self::Codec;
    /// The emulated service of one hand on `side` at its defaults (its own rate and topics,
    /// its rest posture) speaking `wire`, with `noise`.
    fn service(side: Side, wire: &Self::Wire, noise: Noise) -> <Self::Core as ServiceCore>::Config;
    /// What the service run alone (`handgate emulate`) speaks, given its options. Default:
    /// what a device with no keys of its own speaks.
    fn emulated_wire(_options: &Self::Emulate) -> Self::Wire {
        Self::wire(&Self::Config::default())
    }
    /// [`Kind::validate_emulator`].
    fn validate_emulator(_ctx: &DeviceCtx<'_>, _section: &EmulatorSection) -> Vec<Problem> {
        Vec::new()
    }
}

/// A service client's topics: the profile's overrides, else the side's standard pair.
pub trait ClientTopics {
    /// (command, state) topics on backend dds; `None` where neither gives one (center).
    fn topics(&self, side: Side) -> (Option<String>, Option<String>);
}

/// The profile keys of a service client whose only section is `[devices.dds]`, its keys `D`
/// (declared with [`crate::dds_client_keys!`]): the topic overrides, checked here, and the
/// kind's own, checked by `D` ([`DdsSection`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsProfile<D> {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<D>,
}

/// A kind's `[devices.dds]` keys: its standard topics and its rules beyond the overrides'.
pub trait DdsSection:
    DdsTopicKeys + Default + Clone + PartialEq + fmt::Debug + Serialize + DeserializeOwned + Send + Sync + 'static
{
    /// The service's (command, state) topics for a device on `side` with these keys; `None`
    /// where there are none (center).
    fn standard(&self, side: Side) -> Option<(String, String)>;
    /// Problems with the kind's own keys.
    fn problems(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        Vec::new()
    }
    /// [`Settings::command_element`].
    fn command_element(&self, _ctx: &DeviceCtx<'_>) -> Option<usize> {
        None
    }
    /// [`Settings::summary`].
    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        String::new()
    }
}

impl<D: DdsSection> DdsProfile<D> {
    /// The section as set, an absent one with every key absent.
    pub fn keys(&self) -> D {
        self.dds.clone().unwrap_or_default()
    }
}

impl<D: DdsSection> ClientTopics for DdsProfile<D> {
    fn topics(&self, side: Side) -> (Option<String>, Option<String>) {
        let keys = self.keys();
        keys.topics_or(keys.standard(side))
    }
}

impl<D: DdsSection> Settings for DdsProfile<D> {
    fn check(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let keys = self.keys();
        let mut out = keys.topic_problems();
        out.extend(keys.problems(ctx));
        out
    }
    fn peer_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(self.topics(ctx.side))
    }
    fn command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        self.keys().command_element(ctx)
    }
    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        self.keys().summary(ctx)
    }
}

/// What the device's `[devices.emulator]` section and rate set in an emulated service's
/// configuration.
pub trait EmulatedHand {
    fn seed(&mut self) -> Seed<'_>;
}

/// Implements [`EmulatedHand`] for an emulated service's configuration `$t` whose fields
/// `rate`, `noise` and `topics` are the seed's and whose per-joint arrays are named `$initial`
/// and `$object`.
#[macro_export]
macro_rules! emulated_hand {
    ($t:ty { initial: $initial:ident, object: $object:ident }) => {
        impl $crate::service_client::EmulatedHand for $t {
            fn seed(&mut self) -> $crate::service_client::Seed<'_> {
                $crate::service_client::Seed {
                    rate: &mut self.rate,
                    noise: &mut self.noise,
                    topics: &mut self.topics,
                    initial: &mut self.$initial,
                    object: &mut self.$object,
                }
            }
        }
    };
}

/// An emulated service configuration's fields a device's spec sets, per joint in the kind's
/// joint order.
pub struct Seed<'a> {
    pub rate: &'a mut Hz,
    pub noise: &'a mut Noise,
    pub topics: &'a mut Option<(String, String)>,
    /// Wire position at power-up.
    pub initial: &'a mut [f32],
    /// Wire position at which the joint meets an object while closing.
    pub object: &'a mut [Option<f32>],
}

/// The peer config of service hand `H`.
type PeerOf<H> = <<H as ServiceHand>::Core as ServiceCore>::Config;

impl<H: ServiceHand> Kind for H {
    const FACTS: KindFacts = H::FACTS;
    const EMULATOR_FAULTS: &'static [&'static str] = H::EMULATOR_FAULTS;
    type Config = H::Config;
    type Open = ClientOpen<H::Wire, PeerOf<H>>;
    type Emulate = H::Emulate;

    fn table(&self, side: Side, config: &H::Config) -> DeviceTable {
        H::table(side, config)
    }

    fn configure(&self, spec: &DeviceSpec<'_, H::Config>) -> Result<Self::Open, DeviceError> {
        let name = H::FACTS.name;
        let missing = format!("a {name} hand is left or right (or names dds.cmd_topic and dds.state_topic)");
        let wire = H::wire(spec.config);
        let topics = spec.config.topics(spec.side);
        ClientOpen::of(spec, topics, &missing, wire.clone(), |cmd, state| {
            let mut peer = H::service(spec.side, &wire, spec.emulator.noise_for(spec.name, H::NOISE));
            let seed = peer.seed();
            *seed.rate = Hz(spec.rate_hz);
            *seed.topics = Some((cmd, state));
            for (i, joint) in H::FACTS.joints.iter().enumerate() {
                seed.initial[i] = spec.initial_wire(joint, seed.initial[i]);
                seed.object[i] = spec.object_wire(joint);
            }
            peer
        })
    }

    fn served(&self, open: &Self::Open) -> Vec<Served> {
        open.config.served::<H::Codec>()
    }

    fn open(
        &self,
        open: Self::Open,
        spec: &DeviceSpec<'_, H::Config>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let codec = H::codec(open.codec.clone());
        open.start(codec, spec, env, ServiceEmulator::<H::Core>::start)
    }

    /// One hand's service on its standard topics, on the command line's domain.
    fn emulate(&self, args: &EmulateArgs, options: H::Emulate) -> Result<(String, Emulation), DeviceError> {
        let name = H::FACTS.name;
        let side = args.side(name)?;
        let (Some(cmd), Some(state)) = H::Config::default().topics(side) else {
            return Err(DeviceError::Config(format!("a {name} hand is left or right")));
        };
        let wire = H::emulated_wire(&options);
        let cfg = H::service(side, &wire, args.noise(H::NOISE));
        let what = format!(
            "emulating {} ({side} hand): {cmd}, {state} on DDS domain {}",
            H::SERVICE,
            args.domain
        );
        Ok((
            what,
            emulate_service(args, registered(name)?, &[(side, 0)], |node| {
                ServiceEmulator::<H::Core>::start(node, cfg)
            })?,
        ))
    }

    fn validate_emulator(&self, ctx: &DeviceCtx<'_>, section: &EmulatorSection) -> Vec<Problem> {
        H::validate_emulator(ctx, section)
    }
}
