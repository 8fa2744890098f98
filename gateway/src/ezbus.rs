//! EZGripper buses of a plan: every gripper on the same port shares one `EzGripperBus` (one
//! thread, sync read/write for all its servos). An emulated bus is a virtual MX-64 bus on a
//! pseudo-terminal (`handgate_adapters::ezgripper::emulator::VirtualBus`) that the driver opens
//! like a real /dev/ttyUSB0.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use handgate_adapters::ezgripper::driver::{BusConfig, EzGripperBus, GripperConfig};
use handgate_adapters::ezgripper::emulator::{EmulatorConfig, VirtualBus};
use handgate_adapters::ezgripper::ServoId;

use crate::plan::{DevicePlan, Transport};
use crate::runtime::RuntimeError;

/// Open buses by port key.
#[derive(Default)]
pub struct Buses {
    pub buses: BTreeMap<String, Arc<EzGripperBus>>,
    /// Emulated buses (kept alive as long as the runtime).
    pub emulators: BTreeMap<String, VirtualBus>,
}

fn pty_link(key: &str) -> PathBuf {
    let safe: String = key
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    std::env::temp_dir().join(format!("handgate-{}-ezgripper{safe}", std::process::id()))
}

/// Opens every EZGripper bus the plan needs.
pub fn open(devices: &[DevicePlan]) -> Result<Buses, RuntimeError> {
    let mut by_port: BTreeMap<String, Vec<&DevicePlan>> = BTreeMap::new();
    for d in devices {
        if let Transport::EzGripper { port, .. } = &d.transport {
            by_port.entry(port.clone()).or_default().push(d);
        }
    }
    let mut out = Buses::default();
    for (port, devs) in by_port {
        let mut ids = Vec::new();
        let (mut baud, mut emulated, mut calibrate) = (1_000_000, false, false);
        let mut noise = None;
        for d in &devs {
            if let Transport::EzGripper {
                servo_id,
                baud: b,
                emulated: e,
                calibrate_on_start,
                emulator_noise,
                ..
            } = &d.transport
            {
                if *e && noise.is_none() {
                    noise = Some(*emulator_noise);
                }
                ids.push(*servo_id);
                baud = *b;
                emulated |= *e;
                calibrate |= *calibrate_on_start;
            }
        }
        let err = |m: String| RuntimeError::Device(devs[0].name.clone(), m);
        let path = if emulated {
            let link = pty_link(&port);
            let mut cfg = EmulatorConfig::with_ids(&ids);
            cfg.baud = baud;
            if let Some(n) = noise {
                cfg.noise = n;
            }
            let emu = VirtualBus::start(&link, cfg).map_err(|e| err(format!("cannot start the emulated bus: {e}")))?;
            out.emulators.insert(port.clone(), emu);
            link
        } else {
            PathBuf::from(&port)
        };
        let grippers = ids
            .iter()
            .map(|id| {
                ServoId::new(*id)
                    .map(GripperConfig::new)
                    .map_err(|e| err(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let cfg = BusConfig {
            baud,
            grippers,
            calibrate_on_start: calibrate,
            // The same bound as the DDS-side devices: a loaded host must not look like an unplug.
            stale_after_ms: 200,
            ..Default::default()
        };
        let bus = EzGripperBus::open(&path, cfg).map_err(|e| err(format!("{}: {e}", path.display())))?;
        out.buses.insert(port, Arc::new(bus));
    }
    Ok(out)
}
