//! The one place that picks a device kind's table. Parameters a profile can change are in
//! [`TableParams`]; everything else is in the kind's own `table.rs`.

use serde::{Deserialize, Serialize};

use crate::mapping::{DeviceTable, Limits, MappingError};
use crate::model::{DeviceKind, Side};

/// Profile-tunable table parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TableParams {
    /// Gripper open position in rad (Dex1 wire / EZGripper Dex1-equivalent).
    pub range_rad: f32,
    /// EZGripper wire value at fully open.
    pub max_open_percent: f32,
    /// Per-step limit relative to the measured position (rad).
    pub max_step: Option<f32>,
    /// Per-joint limit overrides (canonical name → limits).
    pub limits: Vec<(String, Limits)>,
    /// Dex3 closure postures (canonical order), when overridden.
    pub open_posture: Option<Vec<f32>>,
    pub closed_posture: Option<Vec<f32>>,
}

impl Default for TableParams {
    fn default() -> Self {
        Self {
            range_rad: crate::dex1::table::DEFAULT_RANGE_RAD,
            max_open_percent: crate::ezgripper::table::DEFAULT_MAX_OPEN_PERCENT,
            max_step: None,
            limits: Vec::new(),
            open_posture: None,
            closed_posture: None,
        }
    }
}

/// The table of `kind` on `side` with `params` applied.
pub fn table_for(kind: DeviceKind, side: Side, params: &TableParams) -> Result<DeviceTable, MappingError> {
    let mut t = match kind {
        DeviceKind::Dex3 => crate::dex3::table::table(side),
        DeviceKind::Dex1 => crate::dex1::table::table(side, params.range_rad),
        DeviceKind::Ezgripper => crate::ezgripper::table::table(side, params.range_rad, params.max_open_percent),
        DeviceKind::HandSdk => crate::hand_sdk::table::table(side),
    };
    t.max_step = params.max_step;
    for (name, l) in &params.limits {
        t = t.with_limits(name, *l)?;
    }
    if let crate::mapping::ClosureMap::Postures { open, closed, .. } = &mut t.closure {
        if let Some(o) = &params.open_posture {
            *open = o.clone();
        }
        if let Some(c) = &params.closed_posture {
            *closed = c.clone();
        }
        if open.len() != t.joints.len() || closed.len() != t.joints.len() {
            return Err(MappingError::ClosureShape(
                kind,
                t.joints.len(),
                open.len().min(closed.len()),
            ));
        }
    }
    Ok(t)
}
