//! Export of a recording's hand streams as the hand fields of xr_teleoperate's episode
//! `data.json` (`teleop/utils/episode_writer.py`): per frame, `states.{left,right}_ee` and
//! `actions.{left,right}_ee`, each `{qpos, qvel, torque}`, sampled at a fixed rate, so they
//! can be merged into camera episodes recorded at the same rate (docs/recording.md has the
//! mapping).
//!
//! A side's states come from its `PREFIX/state` topic, its actions from `PREFIX/cmd` (ROS 2
//! names, e.g. `/dex3/left`): per motor of the message, in the message's order,
//! - `unitree_hg/HandState` / `HandCmd` (Dex3): `motor_state[i].{q, dq, tau_est}`,
//!   `motor_cmd[i].{q, dq, tau}` (xr_teleoperate's own Dex3 fields);
//! - `unitree_go/MotorStates` / `MotorCmds` (Dex1, Inspire DFX, BrainCo services):
//!   `states[i].{q, dq, tau_est}`, `cmds[i].{q, dq, tau}`;
//! - `handgate/HandState` / `HandCmd` (canonical front): `joints[i].{q, dq, tau}`.
//!
//! A frame holds each stream's latest message at or before the frame's time; frames start
//! at the first time every selected state topic has a message.

use serde_json::{json, Value};

use crate::bag::{Bag, BagMessage};
use crate::RecordError;
use handgate_idl::{from_cdr, handgate, unitree_go, unitree_hg, DdsTypeName};

/// The left hand's topic prefix by default: the G1's Dex3 hand service, the hand
/// xr_teleoperate records by default.
pub const DEFAULT_LEFT: &str = "/dex3/left";
/// The right hand's.
pub const DEFAULT_RIGHT: &str = "/dex3/right";

/// One stream's values at one message: (names if the message carries them, q, dq, tau).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Joints {
    pub names: Vec<String>,
    pub q: Vec<f64>,
    pub dq: Vec<f64>,
    pub tau: Vec<f64>,
}

/// The joint values a message carries, for the types export knows.
pub fn joints(m: &BagMessage) -> Result<Option<Joints>, RecordError> {
    let err = |e: handgate_idl::CdrError| RecordError::Decode(m.ros_topic.clone(), e.to_string());
    let f = |x: f32| x as f64;
    let t = m.dds_type.as_str();
    let j = if t == unitree_hg::HandState_::DDS_TYPE_NAME {
        let s: unitree_hg::HandState_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: vec![],
            q: s.motor_state.iter().map(|x| f(x.q)).collect(),
            dq: s.motor_state.iter().map(|x| f(x.dq)).collect(),
            tau: s.motor_state.iter().map(|x| f(x.tau_est)).collect(),
        }
    } else if t == unitree_hg::HandCmd_::DDS_TYPE_NAME {
        let s: unitree_hg::HandCmd_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: vec![],
            q: s.motor_cmd.iter().map(|x| f(x.q)).collect(),
            dq: s.motor_cmd.iter().map(|x| f(x.dq)).collect(),
            tau: s.motor_cmd.iter().map(|x| f(x.tau)).collect(),
        }
    } else if t == unitree_go::MotorStates_::DDS_TYPE_NAME {
        let s: unitree_go::MotorStates_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: vec![],
            q: s.states.iter().map(|x| f(x.q)).collect(),
            dq: s.states.iter().map(|x| f(x.dq)).collect(),
            tau: s.states.iter().map(|x| f(x.tau_est)).collect(),
        }
    } else if t == unitree_go::MotorCmds_::DDS_TYPE_NAME {
        let s: unitree_go::MotorCmds_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: vec![],
            q: s.cmds.iter().map(|x| f(x.q)).collect(),
            dq: s.cmds.iter().map(|x| f(x.dq)).collect(),
            tau: s.cmds.iter().map(|x| f(x.tau)).collect(),
        }
    } else if t == handgate::HandState_::DDS_TYPE_NAME {
        let s: handgate::HandState_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: s.joints.iter().map(|x| x.name.clone()).collect(),
            q: s.joints.iter().map(|x| f(x.q)).collect(),
            dq: s.joints.iter().map(|x| f(x.dq)).collect(),
            tau: s.joints.iter().map(|x| f(x.tau)).collect(),
        }
    } else if t == handgate::HandCmd_::DDS_TYPE_NAME {
        let s: handgate::HandCmd_ = from_cdr(&m.data).map_err(err)?;
        Joints {
            names: s.joints.iter().map(|x| x.name.clone()).collect(),
            q: s.joints.iter().map(|x| f(x.q)).collect(),
            dq: s.joints.iter().map(|x| f(x.dq)).collect(),
            tau: s.joints.iter().map(|x| f(x.tau)).collect(),
        }
    } else {
        return Ok(None);
    };
    Ok(Some(j))
}

/// Export options.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// Frames per second (xr_teleoperate's default is 30).
    pub rate_hz: f64,
    /// ROS 2 topic prefix of the left hand's `state`/`cmd` topics, e.g. `/dex3/left`.
    pub left: Option<String>,
    pub right: Option<String>,
}

/// (time, values) of one topic, in time order.
fn series(bag: &Bag, topic: &str) -> Result<Vec<(u64, Joints)>, RecordError> {
    let mut v = Vec::new();
    for m in bag.messages.iter().filter(|m| m.ros_topic == topic) {
        match joints(m)? {
            Some(j) => v.push((if m.publish_time > 0 { m.publish_time } else { m.log_time }, j)),
            None => {
                return Err(RecordError::Invalid(format!(
                    "topic {topic}: type {} has no joint mapping for export",
                    m.dds_type
                )))
            }
        }
    }
    v.sort_by_key(|(t, _)| *t);
    Ok(v)
}

fn at(s: &[(u64, Joints)], t: u64) -> Option<&Joints> {
    let i = s.partition_point(|(ts, _)| *ts <= t);
    i.checked_sub(1).map(|i| &s[i].1)
}

fn fields(j: Option<&Joints>) -> Value {
    match j {
        Some(j) => json!({"qpos": j.q, "qvel": j.dq, "torque": j.tau}),
        None => json!({"qpos": [], "qvel": [], "torque": []}),
    }
}

/// The episode JSON (`info`, `text`, `data`) of `bag`'s hand streams.
pub fn xr_teleoperate(bag: &Bag, opts: &ExportOptions) -> Result<Value, RecordError> {
    if !(opts.rate_hz.is_finite() && opts.rate_hz > 0.0) {
        return Err(RecordError::Invalid(format!(
            "--rate must be > 0, got {}",
            opts.rate_hz
        )));
    }
    let mut sides = Vec::new();
    for (key, prefix) in [("left_ee", &opts.left), ("right_ee", &opts.right)] {
        let Some(p) = prefix else { continue };
        let p = p.trim_end_matches('/');
        let states = series(bag, &format!("{p}/state"))?;
        let actions = series(bag, &format!("{p}/cmd"))?;
        if states.is_empty() && actions.is_empty() {
            return Err(RecordError::Invalid(format!(
                "no {p}/state or {p}/cmd messages in the recording (recorded: {})",
                bag.topics()
                    .iter()
                    .map(|(t, _)| handgate_idl::ros2msg::ros_topic(t))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        sides.push((key, states, actions));
    }
    if sides.is_empty() {
        return Err(RecordError::Invalid(
            "say which hands to export: --left PREFIX and/or --right PREFIX".into(),
        ));
    }
    // Frames start once every side has a state (or, without states, a command).
    let first = |s: &[(u64, Joints)]| s.first().map(|(t, _)| *t);
    let start = sides
        .iter()
        .filter_map(|(_, s, a)| first(s).or(first(a)))
        .max()
        .unwrap_or(0);
    let end = sides
        .iter()
        .flat_map(|(_, s, a)| s.last().into_iter().chain(a.last()).map(|(t, _)| *t))
        .max()
        .unwrap_or(start);
    let step = 1e9 / opts.rate_hz;
    let mut data = Vec::new();
    let mut k = 0u64;
    loop {
        let t = start + (k as f64 * step) as u64;
        if t > end {
            break;
        }
        let mut states = serde_json::Map::new();
        let mut actions = serde_json::Map::new();
        for (key, s, a) in &sides {
            states.insert(key.to_string(), fields(at(s, t)));
            actions.insert(key.to_string(), fields(at(a, t)));
        }
        data.push(json!({"idx": k, "states": states, "actions": actions}));
        k += 1;
    }
    let mut names = serde_json::Map::new();
    for (key, s, a) in &sides {
        let n = s.iter().chain(a.iter()).map(|(_, j)| &j.names).find(|n| !n.is_empty());
        names.insert(key.to_string(), json!(n.cloned().unwrap_or_default()));
    }
    Ok(json!({
        "info": {
            "version": "1.0.0",
            "author": "handgate export",
            "image": {"fps": opts.rate_hz},
            "joint_names": names,
            "handgate": {
                "start_time_ns": start,
                "rate_hz": opts.rate_hz,
                "sources": sides.iter().map(|(k, _, _)| k.to_string()).collect::<Vec<_>>(),
            },
        },
        "text": {"goal": "", "desc": "hand streams exported from a handgate recording", "steps": ""},
        "data": data,
    }))
}
