//! The page's front (`[http] commands = true`): a closure slider and a safe button per
//! device, run by the runtime's one front task like any DDS front: the device's table checks
//! and clamps every command, one page commands at a time (`control = "exclusive"`, each page
//! a writer), and a page that falls silent for `command_watchdog_ms` moves the device to its
//! safe action. A device another front commanded within that time is not taken over.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::WriterInfo;
use handgate_adapters::front::config::{Control, Silence};
use handgate_adapters::front::core::FrontId;
use handgate_adapters::front::serve::{Bound, FrontIo, Incoming, Message, Routed};
use handgate_adapters::front::Rejection;
use handgate_adapters::model::CommandBody;
use serde_json::Value;
use tokio::sync::{mpsc, watch};

use super::Fleet;
use crate::plan::SilencePlan;
use crate::runtime::fronts::{run_front, FrontTask};
use crate::runtime::{DeviceSlot, RuntimeError};

/// The front's name in logs and in `owner`.
pub const NAME: &str = "dashboard";

/// A page's command, as parsed from its frame (checked here, at the edge).
#[derive(Debug, Clone, PartialEq)]
pub enum PageCommand {
    Closure { device: String, closure: f32 },
    Safe { device: String },
}

impl PageCommand {
    pub fn device(&self) -> &str {
        match self {
            PageCommand::Closure { device, .. } | PageCommand::Safe { device } => device,
        }
    }

    /// `{"type":"command","device":D,"closure":C}` or `{"type":"safe","device":D}`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let v: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
        let device = v
            .get("device")
            .and_then(Value::as_str)
            .ok_or("no \"device\"")?
            .to_string();
        match v.get("type").and_then(Value::as_str) {
            Some("command") => {
                let c = v
                    .get("closure")
                    .and_then(Value::as_f64)
                    .ok_or("no numeric \"closure\"")?;
                if !(0.0..=1.0).contains(&c) {
                    return Err(format!("closure must be in [0, 1], got {c}"));
                }
                Ok(PageCommand::Closure {
                    device,
                    closure: c as f32,
                })
            }
            Some("safe") => Ok(PageCommand::Safe { device }),
            other => Err(format!("unknown frame type {other:?} (command, safe)")),
        }
    }
}

/// What the page's queue carries: the bound device's index and the body.
struct PageMsg {
    index: usize,
    body: CommandBody,
}

/// The page front's codec: the body as the edge built it; no state to publish (the page
/// reads the fleet's frames).
struct PageIo;

impl FrontIo for PageIo {
    fn decode(&self, _bound: &[Bound<'_>], msg: &Message) -> Result<Vec<(usize, Routed)>, Rejection> {
        match msg.downcast_ref::<PageMsg>() {
            Some(m) => Ok(vec![(m.index, (m.body.clone(), 0, false))]),
            None => Err(Rejection::WrongCount { got: 0, want: 1 }),
        }
    }

    fn publish(&mut self, _bound: &[Bound<'_>], _lf: bool) {}
}

/// The page front's queue and what the edge checks against.
pub struct PageFront {
    id: FrontId,
    queue: mpsc::Sender<Incoming>,
    devices: HashMap<String, (usize, Arc<DeviceSlot>)>,
    hold: Duration,
}

static NEXT_CONNECTION: AtomicU64 = AtomicU64::new(1);

/// A page connection's writer handle (never a DDS handle: those are CycloneDDS instance
/// handles; the page's carry the top bit).
pub fn next_connection_id() -> u64 {
    (1 << 63) | NEXT_CONNECTION.fetch_add(1, Ordering::Relaxed)
}

impl PageFront {
    /// Hands a page's command to the front task, or says why not.
    pub fn submit(&self, conn: u64, peer: SocketAddr, cmd: PageCommand) -> Result<(), String> {
        let (index, slot) = self
            .devices
            .get(cmd.device())
            .ok_or_else(|| format!("no device {:?}", cmd.device()))?;
        let c = &slot.counters;
        if c.last_front.load(Ordering::Relaxed) != self.id.get() {
            if let Some(since) = c.since_accepted().filter(|s| *s < self.hold) {
                c.foreign_cmd.fetch_add(1, Ordering::Relaxed);
                return Err(format!(
                    "{} is commanded by {} ({} ms ago); the page may command it once that client has been silent for {} ms",
                    cmd.device(),
                    c.owner().unwrap_or_else(|| "another front".into()),
                    since.as_millis(),
                    self.hold.as_millis()
                ));
            }
        }
        let body = match cmd {
            PageCommand::Closure { closure, .. } => CommandBody::Closure {
                closure,
                stiffness: None,
            },
            PageCommand::Safe { .. } => CommandBody::Safe(slot.plan.safe_action),
        };
        let writer = Arc::new(WriterInfo {
            handle: conn,
            label: Some(format!("dashboard page {peer}")),
            ..WriterInfo::default()
        });
        self.queue
            .try_send(Incoming {
                writer,
                msg: Box::new(PageMsg { index: *index, body }),
                taken: Instant::now(),
                // A page's command has no source timestamp: never dropped as out of order.
                stamp: None,
            })
            .map_err(|_| "the dashboard's command queue is full".to_string())
    }
}

/// Starts the page front over every device of the fleet.
pub fn spawn(
    fleet: &Fleet,
    by_name: &HashMap<String, Arc<DeviceSlot>>,
    watchdog: Duration,
    shutdown: watch::Receiver<bool>,
) -> Result<(PageFront, tokio::task::JoinHandle<()>), RuntimeError> {
    let (tx, rx) = mpsc::channel(64);
    let id = FrontId::next();
    let bindings = fleet
        .devices
        .iter()
        .enumerate()
        .map(|(element, d)| {
            let silence = SilencePlan {
                mode: Silence::Watchdog,
                after: Some((watchdog, d.plan.safe_action)),
                timeout_bit: None,
            };
            (d.plan.name.clone(), element, silence, None)
        })
        .collect();
    let task = FrontTask {
        id,
        name: NAME.into(),
        control: Control::Exclusive,
        hold: watchdog,
        state_hz: 1.0,
        max_command_age: None,
        // The page's commands come through the HTTP server's own checks, not from DDS.
        allow: None,
        bindings,
        publishes: false,
        // Counted like a profile's front, not reported in the status extension (not a front
        // of the profile: the dashboard's own).
        tally: Arc::new(crate::runtime::status::FrontTally::named(NAME, "dashboard", false)),
    };
    let (_, handle) = run_front(
        task,
        Box::new(PageIo),
        (tx.clone(), rx),
        Arc::new(AtomicU64::new(0)),
        by_name,
        fleet.discovery.clone(),
        shutdown,
    )?;
    let devices = fleet
        .devices
        .iter()
        .enumerate()
        .map(|(i, d)| (d.plan.name.clone(), (i, d.clone())))
        .collect();
    Ok((
        PageFront {
            id,
            queue: tx,
            devices,
            hold: watchdog,
        },
        handle,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_frames_are_checked_at_the_edge() {
        assert_eq!(
            PageCommand::parse(r#"{"type":"command","device":"a","closure":0.25}"#),
            Ok(PageCommand::Closure {
                device: "a".into(),
                closure: 0.25
            })
        );
        assert_eq!(
            PageCommand::parse(r#"{"type":"safe","device":"a"}"#),
            Ok(PageCommand::Safe { device: "a".into() })
        );
        for bad in [
            r#"{"type":"command","device":"a","closure":1.5}"#,
            r#"{"type":"command","device":"a","closure":"x"}"#,
            r#"{"type":"command","closure":0.5}"#,
            r#"{"type":"fly","device":"a"}"#,
            "not json",
        ] {
            assert!(PageCommand::parse(bad).is_err(), "{bad}");
        }
    }
}
