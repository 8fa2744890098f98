//! A Dex1-1 (right, go variant) as a DDS client of `rt/dex1/right/*`, the device the DDS-client
//! tests drive (`forwarding.rs`, `teardown.rs`): the loop at `rate_hz`, a state stale after 2 s
//! (a 2 Hz loop checks staleness twice a second), commands forwarded as `forward` says.

use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::dds::Node;
use handgate_adapters::dds_device::{DdsDevice, DdsDeviceConfig, Forwarding};
use handgate_adapters::device::{Backend, DeviceInfo};
use handgate_adapters::dex1::adapter::{Dex1GoCodec, Variant};
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{DeviceKind, Side};

pub fn dex1_client(node: &Node, rate_hz: f64, forward: Forwarding) -> DdsDevice {
    let info = DeviceInfo {
        name: "g".into(),
        kind: DeviceKind::Dex1,
        side: Side::Right,
        backend: Backend::Dds,
        table: Arc::new(DeviceKind::Dex1.table(Side::Right, &TableOverrides::default()).unwrap()),
    };
    let cfg = DdsDeviceConfig {
        cmd_topic: "rt/dex1/right/cmd".into(),
        state_topic: Some("rt/dex1/right/state".into()),
        rate_hz,
        stale_after: Duration::from_secs(2),
        forward,
    };
    DdsDevice::start(node, info, cfg, Dex1GoCodec::new(Variant::Go, Side::Right)).unwrap()
}
