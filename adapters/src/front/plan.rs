//! A front as the runtime opens it: bound to its devices, its silence resolved, its topics
//! and rates decided (the gateway's resolver builds it from the profile, once).

use std::sync::Arc;
use std::time::Duration;

use super::config::{FrontConfig, Silence, TopicRole};
use super::kind::FrontKind;
use crate::mapping::DeviceTable;
use crate::model::{SafeAction, Side};

/// What a front does when its client goes silent, resolved for one bound device
/// (docs/fronts.md, "Silence").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SilencePlan {
    /// The semantics in effect (for logs and `handgate check`): the profile's choice, or what
    /// the front kind makes of it.
    pub mode: Silence,
    /// After this long without a command, this action; `None`: the last target is kept.
    pub after: Option<(Duration, SafeAction)>,
    /// After a command that set the Dex3 RIS timeout bit (bit 7): this long, this action.
    pub timeout_bit: Option<(Duration, SafeAction)>,
}

impl SilencePlan {
    /// The silence of a service with no timeout of its own, whose hand keeps its last target
    /// (Inspire's and BrainCo's): `service` keeps the last target, `watchdog` is the device's
    /// watchdog `dog`.
    pub fn keeps_last_target(mode: Silence, dog: (Duration, SafeAction)) -> Self {
        Self {
            mode,
            after: match mode {
                Silence::Watchdog => Some(dog),
                Silence::Service => None,
            },
            timeout_bit: None,
        }
    }

    /// The silence action armed by a command (whether it set the RIS timeout bit): the
    /// earlier of the two, or `None` when silence keeps the last target.
    pub fn armed(&self, timeout_bit: bool) -> Option<(Duration, SafeAction)> {
        let bit = self.timeout_bit.filter(|_| timeout_bit);
        match (self.after, bit) {
            (Some(a), Some(b)) => Some(if b.0 < a.0 { b } else { a }),
            (a, b) => a.or(b),
        }
    }
}

impl std::fmt::Display for SilencePlan {
    /// E.g. `service: keeps the last target (limp 1000 ms after a command with the RIS
    /// timeout bit)`, `watchdog: hold after 200 ms`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: ", self.mode)?;
        match (self.after, self.timeout_bit) {
            (Some((t, a)), None) => write!(f, "{a} after {} ms", t.as_millis()),
            (Some((t, a)), Some((tb, ab))) => write!(
                f,
                "{a} after {} ms ({ab} after {} ms after a command with the RIS timeout bit)",
                t.as_millis(),
                tb.min(t).as_millis()
            ),
            (None, Some((tb, ab))) => write!(
                f,
                "keeps the last target ({ab} {} ms after a command with the RIS timeout bit)",
                tb.as_millis()
            ),
            (None, None) => f.write_str("keeps the last target"),
        }
    }
}

/// One device a front drives.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    pub device: String,
    /// The side whose wire convention the front speaks for this device.
    pub side: Side,
    /// Element of the front's messages that carries this device (actuator: 0 right, 1 left;
    /// otherwise 0).
    pub element: usize,
    pub silence: SilencePlan,
    /// How long a writer that owns the front keeps it, silent, as far as this device goes
    /// (`control = "exclusive"`): when the front's silence acts on the device, the time it
    /// waits; when it keeps the last target, the device's watchdog time (the front's own
    /// `watchdog_ms` where smaller). The front's hold is the longest over its bindings
    /// ([`FrontPlan::hold`]).
    pub hold: Duration,
    /// The front's table for this device (the wire convention it speaks, for its side);
    /// `None`: the device's own (fronts that speak no device kind's convention).
    pub table: Option<Arc<DeviceTable>>,
}

/// One of a front's topics, resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanTopic {
    /// The profile key that sets it (its kind's `Front::TOPICS`).
    pub key: &'static str,
    pub role: TopicRole,
    pub topic: String,
}

/// One front, bound to its devices (one, except a front whose messages carry several, like
/// the Dex1 actuator variant, or name their joints, like joint_state_command; a state-only
/// front lists its devices in `devices` instead).
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPlan {
    /// The name logs use (profile `name`, or derived).
    pub name: String,
    /// The front's profile table (its kind, and its kind's own keys for its kind to open it).
    pub config: FrontConfig,
    pub bindings: Vec<Binding>,
    /// The devices a state-only front publishes, or a front binding a list drives (its
    /// device, its list, or every device).
    pub devices: Vec<String>,
    /// Every topic the front serves, in its kind's order.
    pub topics: Vec<PlanTopic>,
    pub state_hz: f64,
    /// Rate of the low-frequency state copy, where the kind has one.
    pub lf_state_hz: Option<f64>,
}

impl FrontPlan {
    pub fn kind(&self) -> FrontKind {
        self.config.kind()
    }

    /// Number of elements in this front's messages that carry a device (2 for an actuator
    /// front, else 1).
    pub fn elements(&self) -> usize {
        self.config.elements()
    }

    /// How long the writer owning this front keeps it after its last accepted command
    /// (`control = "exclusive"`): the longest of its bindings' holds.
    pub fn hold(&self) -> Duration {
        self.bindings.iter().map(|b| b.hold).max().unwrap_or_default()
    }

    /// The topic set by profile key `key` (or its default).
    pub fn topic(&self, key: &str) -> Option<&str> {
        self.topics.iter().find(|t| t.key == key).map(|t| t.topic.as_str())
    }

    /// The first topic of `role`.
    pub fn first(&self, role: TopicRole) -> Option<&str> {
        self.topics.iter().find(|t| t.role == role).map(|t| t.topic.as_str())
    }

    /// The command topic (`None`: a state-only front).
    pub fn cmd_topic(&self) -> Option<&str> {
        self.first(TopicRole::Command)
    }

    /// The state topic (every front has one but a command-only front: empty there).
    pub fn state_topic(&self) -> &str {
        self.first(TopicRole::State).unwrap_or_default()
    }

    /// Whether the front publishes its devices' state: it has a state topic (a command-only
    /// front, `joint_state_command`, has none; its client reads another front's topic).
    pub fn publishes_state(&self) -> bool {
        self.first(TopicRole::State).is_some()
    }

    /// The low-frequency state copy (topic, Hz), where the kind has one.
    pub fn lf_state(&self) -> Option<(&str, f64)> {
        self.first(TopicRole::LowFrequencyState).zip(self.lf_state_hz)
    }
}
