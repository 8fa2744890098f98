//! The canonical front: `rt/handgate/{device}/cmd` and `/state` with handgate's own IDL
//! (`idl/handgate.idl`): named joints or a closure, for any device.

use crate::mapping::DeviceTable;
use crate::model::{CommandBody, Freshness, HandState, JointCommand, SafeAction};
use handgate_idl::handgate as hg;

use crate::front::Rejection;

/// Decodes a canonical command against the bound device's table.
pub fn decode_cmd(msg: &hg::HandCmd_, device: &DeviceTable, safe: SafeAction) -> Result<CommandBody, Rejection> {
    match msg.mode {
        hg::MODE_JOINTS => {
            let mut out = Vec::with_capacity(msg.joints.len());
            for (i, j) in msg.joints.iter().enumerate() {
                let id = device
                    .joint_by_name(&j.name)
                    .map_err(|_| Rejection::UnknownJoint(j.name.clone()))?;
                let c = JointCommand {
                    q: j.q,
                    dq: j.dq,
                    tau: j.tau,
                    kp: j.kp,
                    kd: j.kd,
                };
                if !c.is_finite() {
                    return Err(Rejection::NonFinite(i));
                }
                out.push((id, c));
            }
            Ok(CommandBody::Joints(out))
        }
        hg::MODE_CLOSURE => {
            if !msg.closure.is_finite() || !msg.stiffness.is_finite() {
                return Err(Rejection::BadClosure(msg.closure));
            }
            let stiffness = (msg.stiffness > 0.0).then_some(msg.stiffness);
            Ok(CommandBody::Closure {
                closure: msg.closure.clamp(0.0, 1.0),
                stiffness,
            })
        }
        hg::MODE_SAFE => Ok(CommandBody::Safe(safe)),
        m => Err(Rejection::UnknownMode(m)),
    }
}

/// Encodes a device's canonical state.
pub fn encode_state(name: &str, device: &DeviceTable, st: &HandState) -> hg::HandState_ {
    let stamp_ns = st
        .measured_wall
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_nanos().min(u64::MAX as u128) as u64)
        .unwrap_or(0);
    hg::HandState_ {
        device: name.to_string(),
        kind: device.kind.as_str().to_string(),
        side: device.side.as_str().to_string(),
        cmd_seq: st.cmd_seq,
        stamp_ns,
        freshness: match st.freshness {
            Freshness::Fresh => hg::FRESH,
            Freshness::Stale => hg::STALE,
            Freshness::CommandedOnly => hg::COMMANDED_ONLY,
        },
        closure: st.closure,
        joints: device
            .joints
            .iter()
            .zip(&st.joints)
            .map(|(m, j)| hg::JointState_ {
                name: m.name.to_string(),
                q: j.q,
                dq: j.dq,
                tau: j.tau,
                temperature: j.temperature.unwrap_or(f32::NAN),
            })
            .collect(),
        pressure: st
            .pads
            .iter()
            .map(|p| p.pressure.iter().cloned().fold(f32::NAN, f32::max))
            .collect(),
        accelerometer: st.imu.map(|i| i.accelerometer).unwrap_or_default(),
        gyroscope: st.imu.map(|i| i.gyroscope).unwrap_or_default(),
        power_v: st.power.map(|p| p.voltage).unwrap_or(f32::NAN),
        power_a: st.power.map(|p| p.current).unwrap_or(f32::NAN),
        faults: st.faults,
    }
}

/// The canonical front's topics for a device.
pub fn topics(device: &str) -> (String, String) {
    (
        format!("rt/handgate/{device}/cmd"),
        format!("rt/handgate/{device}/state"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::TableOverrides;
    use crate::model::{DeviceKind, Side};

    #[test]
    fn joints_by_name_closure_and_rejections() {
        let t = DeviceKind::Dex3.table(Side::Right, &TableOverrides::default()).unwrap();
        let msg = hg::HandCmd_ {
            mode: hg::MODE_JOINTS,
            joints: vec![hg::JointCmd_ {
                name: "index_1".into(),
                q: 0.5,
                kp: 1.0,
                ..Default::default()
            }],
            ..Default::default()
        };
        match decode_cmd(&msg, &t, SafeAction::Hold).unwrap() {
            CommandBody::Joints(v) => assert_eq!(v[0].0, t.joint_by_name("index_1").unwrap()),
            b => panic!("{b:?}"),
        }
        let mut bad = msg.clone();
        bad.joints[0].name = "pinky".into();
        assert_eq!(
            decode_cmd(&bad, &t, SafeAction::Hold),
            Err(Rejection::UnknownJoint("pinky".into()))
        );
        let c = hg::HandCmd_ {
            mode: hg::MODE_CLOSURE,
            closure: 2.0,
            ..Default::default()
        };
        assert_eq!(
            decode_cmd(&c, &t, SafeAction::Hold),
            Ok(CommandBody::Closure {
                closure: 1.0,
                stiffness: None
            })
        );
        let n = hg::HandCmd_ {
            mode: hg::MODE_CLOSURE,
            closure: f32::NAN,
            ..Default::default()
        };
        assert!(decode_cmd(&n, &t, SafeAction::Hold).is_err());
        assert_eq!(
            decode_cmd(
                &hg::HandCmd_ {
                    mode: 9,
                    ..Default::default()
                },
                &t,
                SafeAction::Hold
            ),
            Err(Rejection::UnknownMode(9))
        );
    }
}
