//! EZGripper mapping: the same canonical `jaw` as Dex1 (so a Dex1 client drives it 1:1),
//! wire unit = percent open as SAKE's driver uses it (0 % = closed, `max_open_percent` = open).
//! SAKE's driver maps Dex1 0 rad → 0 % and 5.4 rad → max_open_percent (docs/sources.md §5):
//! `wire_pct = max_open * (range - jaw) / range`.

use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, Side};

/// Dex1-equivalent range of the jaw (rad) the SAKE driver assumes: the Dex1's open position,
/// since its driver maps Dex1 radians onto the EZGripper (docs/sources.md §5).
pub const DEFAULT_RANGE_RAD: f32 = crate::dex1::table::DEFAULT_RANGE_RAD;

/// The EZGripper table. `range` is the canonical jaw range (rad, Dex1-equivalent),
/// `max_open_percent` the wire value at fully open.
pub fn table(side: Side, range: f32, max_open_percent: f32) -> DeviceTable {
    let scale = max_open_percent / range;
    DeviceTable::gripper(
        DeviceKind::Ezgripper,
        side,
        range,
        (scale, max_open_percent),
        (5.0, 0.05),
    )
}
