//! The `emulator` backend of the DDS-side kinds: the peer's emulator runs in-process on
//! private topics (`rt/handgate/emu/{device}/*`) and the device is the very same DDS adapter
//! a real peer would get, so the emulator sits exactly where the robot's service would.

use std::sync::Arc;

use async_trait::async_trait;
use handgate_adapters::dds::Node;
use handgate_adapters::dds_device::{DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Capabilities, DeviceError, DeviceInfo, DeviceStats, HandDevice};
use handgate_adapters::dex1::adapter::{Dex1GoCodec, Variant};
use handgate_adapters::dex3::dds_client::Dex3DdsCodec;
use handgate_adapters::emu_common::{EmulatorError, Hz};
use handgate_adapters::hand_sdk::adapter::HandSdkCodec;
use handgate_adapters::model::{HandCommand, HandState, SafeAction};
use handgate_adapters::{dex1, dex3, hand_sdk};
use tokio::sync::watch;

use crate::plan::{emulator_topics, DevicePlan, EmulatedPeer};
use crate::runtime::RuntimeError;

/// A DDS adapter and the emulated peer it drives; the peer lives as long as the device.
struct Emulated {
    device: DdsDevice,
    _peer: Box<dyn Send + Sync>,
}

#[async_trait]
impl HandDevice for Emulated {
    fn info(&self) -> &DeviceInfo {
        self.device.info()
    }
    fn command(&self, cmd: HandCommand) -> Result<(), DeviceError> {
        self.device.command(cmd)
    }
    fn state(&self) -> watch::Receiver<HandState> {
        self.device.state()
    }
    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError> {
        self.device.safe_state(action).await
    }
    fn stats(&self) -> DeviceStats {
        self.device.stats()
    }
}

/// Starts the emulated peer and the adapter bound to it.
pub fn build(
    node: &Node,
    p: &DevicePlan,
    peer: &EmulatedPeer,
    base: DeviceInfo,
) -> Result<Arc<dyn HandDevice>, RuntimeError> {
    let (cmd_t, state_t) = emulator_topics(&p.name);
    let emu_err = |e: EmulatorError| RuntimeError::Device(p.name.clone(), e.to_string());
    let cfg = |state: Option<&str>, rate: f64| DdsDeviceConfig {
        cmd_topic: cmd_t.clone(),
        state_topic: state.map(str::to_string),
        rate_hz: rate,
        stale_after: p.stale_after,
    };
    let info = |capabilities: Capabilities| DeviceInfo {
        capabilities,
        ..base.clone()
    };
    let (device, peer): (DdsDevice, Box<dyn Send + Sync>) = match peer {
        EmulatedPeer::Dex3Service {
            initial_q,
            timeout_bit,
            noise,
        } => {
            let mut c = dex3::dds_service_emulator::Dex3ServiceConfig::new(p.side);
            c.initial_q = *initial_q;
            c.noise = *noise;
            c.publish_lf = false;
            c.state_rate = Hz(p.rate_hz.min(1000.0));
            c.topics = Some((cmd_t.clone(), state_t.clone(), format!("{state_t}_lf")));
            let emu = dex3::dds_service_emulator::Dex3ServiceEmulator::start(node, c).map_err(emu_err)?;
            let caps = Capabilities {
                feedback: true,
                pressure: true,
                imu: true,
                power: true,
                ..Default::default()
            };
            let codec = Dex3DdsCodec {
                timeout_bit: *timeout_bit,
            };
            (
                DdsDevice::start(node, info(caps), cfg(Some(&state_t), p.rate_hz), codec)?,
                Box::new(emu),
            )
        }
        EmulatedPeer::Dex1Service {
            initial_q,
            object_q,
            noise,
        } => {
            let mut c = dex1::emulator::Dex1Config::new(Variant::Go, p.side);
            c.initial_q = *initial_q;
            c.noise = *noise;
            c.object = *object_q;
            c.rate = Hz(p.rate_hz);
            c.topics = Some((cmd_t.clone(), state_t.clone()));
            let emu = dex1::emulator::Dex1Emulator::start(node, c).map_err(emu_err)?;
            let caps = Capabilities {
                feedback: true,
                ..Default::default()
            };
            let codec = Dex1GoCodec::new(Variant::Go, p.side);
            (
                DdsDevice::start(node, info(caps), cfg(Some(&state_t), p.rate_hz), codec)?,
                Box::new(emu),
            )
        }
        EmulatedPeer::AiSport { ramp, publish_hz } => {
            let c = hand_sdk::emulator::HandSdkConfig {
                topic: cmd_t.clone(),
                ..Default::default()
            };
            let emu = hand_sdk::emulator::HandSdkEmulator::start(node, c).map_err(emu_err)?;
            let codec = HandSdkCodec::new(*ramp);
            (
                DdsDevice::start(node, info(Capabilities::default()), cfg(None, *publish_hz), codec)?,
                Box::new(emu),
            )
        }
    };
    Ok(Arc::new(Emulated { device, _peer: peer }))
}
