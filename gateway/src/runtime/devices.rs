//! Device start-up: every device of a plan opened through its kind (the kind's shared
//! resources first), or one device alone for the tools that drive a single device.

use std::sync::Arc;

use handgate_adapters::dds::Node;
use handgate_adapters::device::HandDevice;
use handgate_adapters::model::DeviceKind;
use handgate_adapters::open::{DeviceSpec, OpenEnv, Shared};

use super::RuntimeError;
use crate::plan::{DevicePlan, Plan};

/// Opens every device of `plan` through its kind: first each kind's shared resources
/// (`KindFactory::prepare`, with all its devices), then each device.
pub fn open_devices(node: &Node, plan: &Plan, shared: &mut Shared) -> Result<Vec<Arc<dyn HandDevice>>, RuntimeError> {
    let mut env = OpenEnv { node, shared };
    for kind in DeviceKind::all() {
        let specs: Vec<DeviceSpec<'_>> = plan
            .devices
            .iter()
            .filter(|p| p.kind == *kind)
            .map(DevicePlan::spec)
            .collect();
        if let Some(first) = specs.first() {
            kind.factory()
                .prepare(&specs, &mut env)
                .map_err(|source| RuntimeError::Device {
                    device: first.name.to_string(),
                    source,
                })?;
        }
    }
    plan.devices
        .iter()
        .map(|p| {
            p.kind
                .factory()
                .open(&p.spec(), &mut env)
                .map(Arc::from)
                .map_err(|source| RuntimeError::Device {
                    device: p.name.clone(),
                    source,
                })
        })
        .collect()
}

/// Opens the one device of `plan` called `name` (and what its kind shares for it), for the
/// tools that drive a single device (`handgate discover`, `handgate calibrate`).
pub fn open_device(
    node: &Node,
    plan: &Plan,
    name: &str,
    shared: &mut Shared,
) -> Result<Arc<dyn HandDevice>, RuntimeError> {
    let one = Plan {
        devices: plan.devices.iter().filter(|d| d.name == name).cloned().collect(),
        fronts: Vec::new(),
        ..plan.clone()
    };
    open_devices(node, &one, shared)?
        .pop()
        .ok_or_else(|| RuntimeError::UnknownDevice(name.to_string()))
}
