//! Opening an Inspire FTP hand: over DDS as a client of Inspire's DDS driver, or on the
//! emulator backend: the driver's emulator on private topics driven by the very same codec.

use super::adapter::{FtpClient, FtpCodec};
use super::emulator::{FtpConfig, FtpEmulator, FtpTransport, ANGLE_NOISE, REST_ANGLE};
use super::kind::{FtpTopics, InspireFtpProfile};
use super::table::JOINTS;
use crate::dds::Node;
use crate::dds_device::{emulator_topics, DdsDevice, DdsDeviceConfig, WithPeer, STATE_QOS};
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{EmulateArgs, Emulation};
use crate::open::{DeviceSpec, OpenEnv};

/// What an Inspire FTP hand opens with: decided from the profile, before anything starts.
#[derive(Debug, Clone, PartialEq)]
pub enum FtpOpen {
    /// A client of the driver on `topics`.
    Dds {
        config: DdsDeviceConfig,
        codec: FtpCodec,
        topics: FtpTopics,
    },
    /// The driver's emulator (`peer`, on private topics) and the client of it.
    Emulated {
        peer: Box<FtpConfig>,
        config: DdsDeviceConfig,
        codec: FtpCodec,
        topics: FtpTopics,
    },
}

/// Private tactile topic of an in-process emulated driver for `device`.
pub fn emulator_touch_topic(device: &str) -> String {
    format!("rt/handgate/emu/{device}/touch")
}

/// What `spec` opens with.
pub fn configure(spec: &DeviceSpec<'_>) -> Result<FtpOpen, DeviceError> {
    let profile = spec.config::<InspireFtpProfile>().cloned().unwrap_or_default();
    let cfg = |t: &FtpTopics| DdsDeviceConfig {
        cmd_topic: t.cmd.clone(),
        state_topic: Some(t.state.clone()),
        rate_hz: spec.rate_hz,
        stale_after: spec.stale_after,
        forward: spec.forwarding(spec.rate_hz),
    };
    let codec = profile.codec();
    if spec.backend == Backend::Dds {
        let topics = profile.topics(spec.side);
        return Ok(FtpOpen::Dds {
            config: cfg(&topics),
            codec,
            topics,
        });
    }
    // Emulator backend: the driver over Modbus TCP (state and touch) on private topics.
    let (cmd, state) = emulator_topics(spec.name);
    let topics = FtpTopics {
        cmd,
        state,
        touch: Some(emulator_touch_topic(spec.name)),
    };
    let mut peer = FtpConfig::new(spec.side);
    for (i, joint) in JOINTS.iter().enumerate() {
        peer.initial[i] = spec.initial_wire(joint, REST_ANGLE[i]);
        peer.object[i] = spec.object_wire(joint);
    }
    peer.noise = spec.emulator.noise_for(spec.name, ANGLE_NOISE);
    peer.noisy = spec.emulator.noise != Some(false);
    peer.rate = crate::emu_common::Hz(profile.driver_hz());
    peer.topics = Some((
        topics.cmd.clone(),
        topics.state.clone(),
        topics.touch.clone().unwrap_or_default(),
    ));
    Ok(FtpOpen::Emulated {
        peer: Box::new(peer),
        config: cfg(&topics),
        codec,
        topics,
    })
}

/// What an Inspire FTP hand opened from `spec` serves on DDS: the client's topics, and its
/// touch reader where the topics have one.
pub fn served(spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
    let (config, topics) = match configure(spec) {
        Ok(FtpOpen::Dds { config, topics, .. } | FtpOpen::Emulated { config, topics, .. }) => (config, topics),
        Err(_) => return Vec::new(),
    };
    let mut out = config.served::<FtpCodec>();
    if let Some(t) = &topics.touch {
        out.push(crate::discovery::diagnose::Served::new(
            t,
            crate::dds::type_name::<handgate_idl::inspire::InspireHandTouch>(),
            crate::discovery::Role::Reader,
            STATE_QOS.served(),
        ));
    }
    out
}

/// The client of the driver (and its touch reader when the topics have one).
fn client(node: &Node, codec: FtpCodec, topics: &FtpTopics) -> Result<FtpClient, DeviceError> {
    Ok(FtpClient::new(node, codec, topics.touch.as_deref())?)
}

/// Opens an Inspire FTP hand on its backend.
pub fn open(spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
    Ok(match configure(spec)? {
        FtpOpen::Dds { config, codec, topics } => {
            let c = client(env.node, codec, &topics)?;
            Box::new(DdsDevice::start(env.node, spec.info(), config, c)?)
        }
        FtpOpen::Emulated {
            peer,
            config,
            codec,
            topics,
        } => {
            let peer = FtpEmulator::start(env.node, *peer)?;
            let c = client(env.node, codec, &topics)?;
            let device = DdsDevice::start(env.node, spec.info(), config, c)?;
            Box::new(WithPeer::new(device, peer))
        }
    })
}

/// `handgate emulate inspire_ftp --side left|right [--variant tcp|rs485]`: Inspire's DDS
/// driver for one hand, over Modbus TCP (state and touch, about 50 Hz; the default) or RS-485
/// (state only, about 20 Hz).
pub fn emulate(args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
    let side = args.side("inspire_ftp")?;
    let mut cfg = FtpConfig::new(side);
    match args.variant.as_deref().unwrap_or("tcp") {
        "tcp" => {}
        "rs485" => cfg = cfg.rs485(),
        other => {
            return Err(DeviceError::Config(format!(
                "unknown inspire_ftp transport {other:?} (--variant tcp or rs485)"
            )))
        }
    }
    cfg.noise = args.noise(ANGLE_NOISE);
    cfg.noisy = !args.no_noise;
    let node = args.node()?;
    let (ctrl, state, touch) = super::front::topics(side);
    let what = match cfg.transport {
        FtpTransport::Tcp => format!(
            "emulating Inspire's DDS driver (Modbus TCP): {ctrl}, {state}, {touch} on DDS domain {}",
            args.domain
        ),
        FtpTransport::Rs485 => format!(
            "emulating Inspire's DDS driver (RS-485, no touch): {ctrl}, {state} on DDS domain {}",
            args.domain
        ),
    };
    let emu = FtpEmulator::start(&node, cfg)?;
    Ok((what, Emulation::Running(Box::new((emu, node)))))
}
