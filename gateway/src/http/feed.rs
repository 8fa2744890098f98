//! The dashboard's JSON frames (docs/dashboard.md, "Protocol"): `hello` per connection;
//! `samples`, `pads` and `status` built once per tick for every page (a broadcast), only while
//! a page is connected.

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::model::{faults, Freshness};
use handgate_idl::handgate as hg;
use serde_json::{json, Map, Value};
use tokio::sync::{broadcast, watch};

use super::Fleet;

/// The protocol's version (`hello.protocol`).
pub const PROTOCOL: u32 = 1;
/// Pads frames per second.
const PADS_HZ: f64 = 10.0;

/// Fault bit names, as the page shows them (`model::faults::NAMES`).
pub fn fault_names(bits: u32) -> Vec<&'static str> {
    faults::names(bits)
}

/// A float for the page: 5 significant decimals are plenty on a plot; NaN/inf as null.
fn num(v: f32) -> Value {
    if v.is_finite() {
        json!((v as f64 * 1e5).round() / 1e5)
    } else {
        Value::Null
    }
}

fn nums(v: impl IntoIterator<Item = f32>) -> Value {
    Value::Array(v.into_iter().map(num).collect())
}

/// The `hello` frame: the fleet, its joints and limits, pads and their places, the fronts.
pub fn hello(fleet: &Fleet, commands: bool, sample_hz: f64) -> String {
    let devices: Vec<Value> = fleet
        .devices
        .iter()
        .map(|d| {
            let p = &d.plan;
            let joints: Vec<Value> = p
                .table
                .joints
                .iter()
                .map(|j| json!({"name": j.name, "min": num(j.limits.min), "max": num(j.limits.max)}))
                .collect();
            let pads: Vec<Value> = match p.kind.factory().pads() {
                Some(layout) => layout
                    .places(p.side)
                    .iter()
                    .map(|place| {
                        let (rows, cols) = (layout.shape)(place.name);
                        json!({"name": place.name, "rows": rows, "cols": cols,
                            "x": num(place.x), "y": num(place.y), "w": num(place.w), "h": num(place.h)})
                    })
                    .collect(),
                None => Vec::new(),
            };
            json!({
                "name": p.name, "kind": p.kind.as_str(), "backend": p.backend.as_str(), "side": p.side.as_str(),
                "safe_action": p.safe_action.as_str(), "joints": joints, "pads": pads,
            })
        })
        .collect();
    let fronts: Vec<Value> = fleet
        .fronts
        .iter()
        .map(|f| {
            json!({"name": f.name, "kind": f.kind, "cmd_topic": f.cmd_topic,
                "state_topic": f.state_topic, "devices": f.devices})
        })
        .collect();
    json!({
        "type": "hello", "protocol": PROTOCOL, "profile": fleet.profile,
        "version": env!("CARGO_PKG_VERSION"), "commands": commands, "sample_hz": sample_hz,
        "devices": devices, "fronts": fronts,
    })
    .to_string()
}

fn freshness(f: u8) -> &'static str {
    match f {
        hg::FRESH => "fresh",
        hg::COMMANDED_ONLY => "commanded_only",
        _ => "stale",
    }
}

/// The `status` frame: the status task's latest numbers (those of `handgate status`), with
/// each device's faults, closure and who commands it.
pub fn status(fleet: &Fleet) -> String {
    let st = fleet.status.borrow().clone();
    let devices: Vec<Value> = st
        .devices
        .iter()
        .map(|d| {
            let slot = fleet.devices.iter().find(|s| s.plan.name == d.device);
            // Only the fault bits and the closure: no copy of the whole state (pads).
            let state = slot.map(|s| {
                let rx = s.device.state();
                let st = rx.borrow();
                (st.faults, st.closure)
            });
            json!({
                "device": d.device, "kind": d.kind, "backend": d.backend,
                "freshness": freshness(d.freshness), "safe": d.safe,
                "age_ms": num(d.age_ms), "cmd_rate_hz": num(d.cmd_rate_hz), "state_rate_hz": num(d.state_rate_hz),
                "crc_errors": d.crc_errors, "bad_input": d.bad_input, "watchdog_trips": d.watchdog_trips,
                "reconnects": d.reconnects, "missed_cycles": d.missed_cycles, "foreign_cmd": d.foreign_cmd,
                "duplicate_cmd": d.duplicate_cmd, "reordered_cmd": d.reordered_cmd, "late_cmd": d.late_cmd,
                "not_allowed_cmd": d.not_allowed_cmd,
                "motion": handgate_adapters::motion::Verdict::word(d.motion), "motion_joint": d.motion_joint,
                "tracking_error": num(d.tracking_error),
                "faults": state.map(|(f, _)| fault_names(f)).unwrap_or_default(),
                "closure": state.map(|(_, c)| num(c)).unwrap_or(Value::Null),
                "owner": slot.and_then(|s| s.counters.owner()),
            })
        })
        .collect();
    let endpoints: Vec<Value> = st
        .endpoints
        .iter()
        .map(|e| json!({"owner": e.owner, "topic": e.topic, "role": e.role, "matched": e.matched, "who": e.who}))
        .collect();
    let diagnostics: Vec<Value> = st
        .diagnostics
        .iter()
        .map(|d| {
            json!({"severity": crate::diagnostics::severity(&d.kind), "kind": d.kind, "owner": d.owner,
                "topic": d.topic, "detail": d.detail, "fix": d.fix})
        })
        .collect();
    json!({
        "type": "status", "profile": st.profile, "uptime_ms": st.uptime_ms,
        "record_messages": st.record_messages, "record_dropped": st.record_dropped,
        "clients": fleet.clients.load(Ordering::Relaxed),
        "devices": devices, "endpoints": endpoints, "diagnostics": diagnostics,
    })
    .to_string()
}

/// The `samples` frame at `now`: each device's measured joints and the targets in force.
pub fn samples(fleet: &Fleet, now: Instant) -> String {
    let mut devices = Map::new();
    for d in &fleet.devices {
        let q: Vec<f32> = d.device.state().borrow().joints.iter().map(|j| j.q).collect();
        let cmd = d.device.commanded().map(nums).unwrap_or(Value::Null);
        devices.insert(d.plan.name.clone(), json!({"q": nums(q), "cmd": cmd}));
    }
    let t = now.saturating_duration_since(fleet.started).as_secs_f64();
    json!({"type": "samples", "t": (t * 1e4).round() / 1e4, "devices": devices}).to_string()
}

/// The `pads` frame: each tactile device's pads on its kind's 0..1 scale (-1: no reading),
/// in the order of `hello`'s pads; `None` when no device has pads.
pub fn pads(fleet: &Fleet) -> Option<String> {
    let mut devices = Map::new();
    for d in &fleet.devices {
        let Some(layout) = d.plan.kind.factory().pads() else {
            continue;
        };
        // The raw taxels only, copied while the state is borrowed (the device loop waits for
        // the borrow to end before it publishes); scaled and encoded after.
        let raw: Vec<Option<Vec<f32>>> = {
            let rx = d.device.state();
            let state = rx.borrow();
            let stale = state.freshness == Freshness::Stale;
            layout
                .right
                .iter()
                .map(|place| {
                    state
                        .pads
                        .iter()
                        .find(|p| p.name == place.name && !stale)
                        .map(|p| p.pressure.clone())
                })
                .collect()
        };
        let arrays: Vec<Value> = raw
            .into_iter()
            .map(|p| match p {
                Some(p) => nums(p.into_iter().map(|v| layout.scale.normalise(v))),
                None => Value::Array(Vec::new()),
            })
            .collect();
        devices.insert(d.plan.name.clone(), Value::Array(arrays));
    }
    (!devices.is_empty()).then(|| json!({"type": "pads", "devices": devices}).to_string())
}

/// Builds the frames every page gets, while at least one is connected.
pub fn spawn(
    fleet: Arc<Fleet>,
    sample_hz: f64,
    frames: broadcast::Sender<Arc<str>>,
    mut shutdown: watch::Receiver<bool>,
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut samples_tick = tokio::time::interval(Duration::from_secs_f64(1.0 / sample_hz.max(1.0)));
        samples_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut pads_tick = tokio::time::interval(Duration::from_secs_f64(1.0 / PADS_HZ));
        pads_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut status = fleet.status.clone();
        loop {
            let frame = tokio::select! {
                _ = samples_tick.tick() => (frames.receiver_count() > 0).then(|| samples(&fleet, Instant::now())),
                _ = pads_tick.tick() => if frames.receiver_count() > 0 { pads(&fleet) } else { None },
                r = status.changed() => {
                    if r.is_err() { break; }
                    (frames.receiver_count() > 0).then(|| self::status(&fleet))
                }
                _ = shutdown.changed() => break,
            };
            if let Some(f) = frame {
                let _ = frames.send(Arc::from(f));
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_rounded_and_non_finite_ones_are_null() {
        assert_eq!(num(0.1234567), json!(0.12346));
        assert_eq!(num(f32::NAN), Value::Null);
        assert_eq!(num(f32::INFINITY), Value::Null);
        assert_eq!(
            fault_names(faults::LINK_DOWN | faults::SAFE_STATE),
            ["link_down", "safe_state"]
        );
    }
}
