//! Dex1-1 gripper mapping: one canonical joint `jaw` measured from open, positive = closing.
//!
//! Wire: 0.0 rad = closed, `range` rad = open (docs/sources.md §4: about 5.4 rad in xr_teleoperate, the
//! EZGripper driver and dex1_1_service's internal branch; dex1_1_service calibrates 5.62 rad;
//! the seed spec says 2π). So `wire_q = range - jaw`, and a closure c maps to `jaw = c * range`.

use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, Side};

/// Open position used by real systems (rad), as a profile states it.
pub const DEFAULT_RANGE: f64 = 5.4;
/// [`DEFAULT_RANGE`] as the tables use it.
pub const DEFAULT_RANGE_RAD: f32 = DEFAULT_RANGE as f32;
/// The seed spec's range (rad).
pub const SEED_SPEC_RANGE_RAD: f32 = std::f32::consts::TAU;
/// xr_teleoperate's Dex1 gains (docs/sources.md §4).
pub const KP: f32 = 5.0;
pub const KD: f32 = 0.05;

/// The Dex1-1 table for one side and open position `range` (rad).
pub fn table(side: Side, range: f32) -> DeviceTable {
    DeviceTable::gripper(DeviceKind::Dex1, side, range, (1.0, range), (KP, KD))
}
