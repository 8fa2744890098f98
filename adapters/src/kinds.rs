//! The one list of device kinds (the shape of probe-rs's `DRIVERS`). Adding a kind: its
//! folder (with its `KindFactory`), `pub mod` in `lib.rs`, and one line here
//! (docs/adapters.md, "Adding a device kind").

use crate::kind::DeviceKind;

/// Every device kind handgate knows, in the order `handgate check` and errors list them.
pub const KINDS: &[DeviceKind] = &[
    DeviceKind::Dex3,
    DeviceKind::Dex1,
    DeviceKind::Ezgripper,
    DeviceKind::HandSdk,
    DeviceKind::InspireDfx,
    DeviceKind::Brainco,
    DeviceKind::InspireFtp,
];
