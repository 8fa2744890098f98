//! EZGripper mapping: the same canonical `jaw` as Dex1 (so a Dex1 client drives it 1:1),
//! wire unit = percent open as SAKE's driver uses it (0 % = closed, `max_open_percent` = open).
//! SAKE's driver maps Dex1 0 rad → 0 % and 5.4 rad → max_open_percent (docs/sources.md §5):
//! `wire_pct = max_open * (range - jaw) / range`.

use crate::mapping::{ClosureMap, DeviceTable, JointMap, Limits};
use crate::model::{DeviceKind, Side, GRIPPER_JOINTS};

/// Dex1-equivalent range of the jaw (rad) the SAKE driver assumes: the Dex1's open position,
/// since its driver maps Dex1 radians onto the EZGripper (docs/sources.md §5).
pub const DEFAULT_RANGE_RAD: f32 = crate::dex1::table::DEFAULT_RANGE_RAD;

/// The EZGripper table. `range` is the canonical jaw range (rad, Dex1-equivalent),
/// `max_open_percent` the wire value at fully open.
pub fn table(side: Side, range: f32, max_open_percent: f32) -> DeviceTable {
    let scale = max_open_percent / range;
    DeviceTable {
        kind: DeviceKind::Ezgripper,
        side,
        joints: vec![JointMap {
            name: GRIPPER_JOINTS[0],
            wire_index: 0,
            urdf: format!("{}_gripper_joint", side.as_str()),
            sign: -1.0,
            scale,
            offset: max_open_percent,
            limits: Limits::new(0.0, range),
        }],
        closure: ClosureMap::Postures {
            open: vec![0.0],
            closed: vec![range],
            kp: 5.0,
            kd: 0.05,
        },
        hold_kp: 5.0,
        hold_kd: 0.05,
        max_step: None,
        max_kp: 50.0,
        max_kd: 5.0,
        max_tau: 5.0,
        urdf_frame: crate::mapping::UrdfFrame::Wire,
    }
}
