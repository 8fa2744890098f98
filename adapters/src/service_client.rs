//! The device side of the kit for DDS-service hands: what a client of a robot's hand service
//! opens with ([`ClientOpen`]) and how it opens ([`ClientOpen::start`]). On backend dds the
//! device is a [`DdsDevice`] with the kind's codec on the service's topics; on the emulator
//! backend the same device drives the service's emulator ([`ServiceEmulator`] around the
//! kind's core) on the device's private topics ([`emulator_topics`]), started first and kept
//! with it ([`WithPeer`]); `crate::service_emulator::ServiceEmulator` hosts the kind's core. A kind supplies its topics, its codec and its emulated service's
//! configuration; docs/adapters.md, "Adding a device kind".

use crate::dds::Node;
use crate::dds_device::{emulator_topics, DdsCodec, DdsDevice, DdsDeviceConfig, WithPeer};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::EmulatorError;
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

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
            });
        }
        let (cmd, state) = emulator_topics(spec.name);
        Ok(Self {
            config: spec.dds_client(cmd.clone(), state.clone()),
            codec,
            peer: Some(peer(cmd, state)),
        })
    }

    /// Starts the device with `codec`, and first its emulated service with `start_peer`
    /// (e.g. `ServiceEmulator::<Core>::start`) when there is one.
    pub fn start<D, C, E>(
        self,
        codec: D,
        spec: &DeviceSpec<'_, C>,
        env: &mut OpenEnv<'_>,
        start_peer: impl FnOnce(&Node, P) -> Result<E, EmulatorError>,
    ) -> Result<Box<dyn HandDevice>, DeviceError>
    where
        D: DdsCodec,
        C: ?Sized,
        E: Send + Sync + 'static,
    {
        let peer = self.peer.map(|p| start_peer(env.node, p)).transpose()?;
        let device = DdsDevice::start(env.node, spec.info(), self.config, codec)?;
        Ok(match peer {
            Some(peer) => Box::new(WithPeer::new(device, peer)),
            None => Box::new(device),
        })
    }
}

/// `handgate emulate <kind>` for a service hand: the service `start` starts on the command
/// line's domain, running until the process stops.
pub fn emulate_service<E: Send + 'static>(
    args: &EmulateArgs,
    start: impl FnOnce(&Node) -> Result<E, EmulatorError>,
) -> Result<Emulation, DeviceError> {
    let node = args.node()?;
    let emu = start(&node)?;
    Ok(Emulation::Running(Box::new((emu, node))))
}
