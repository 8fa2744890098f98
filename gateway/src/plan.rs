//! The resolved fleet the runtime starts: what a validated profile turns into. Kept separate
//! from the profile schema (user-facing, layered, validated) so the runtime only ever sees
//! complete, typed values.

use std::time::Duration;

use std::sync::Arc;

use handgate_adapters::device::Backend;
use handgate_adapters::kind::KindConfigBox;
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::model::{DeviceKind, SafeAction, Side};
use handgate_adapters::open::{DeviceSpec, EmulatorSection};

pub use crate::fronts::FrontKind;
use crate::profile::FrontConfig;

/// One device: everything its kind needs to open it, decided here once.
#[derive(Debug, Clone, PartialEq)]
pub struct DevicePlan {
    pub name: String,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    /// The device's table: its kind's, with the profile's limits, step limit and closure.
    pub table: Arc<DeviceTable>,
    pub rate_hz: f64,
    pub stale_after: Duration,
    pub safe_action: SafeAction,
    /// `[devices.emulator]` (defaults when absent).
    pub emulator: EmulatorSection,
    /// The kind's own profile keys.
    pub config: KindConfigBox,
}

impl DevicePlan {
    /// What the device's kind opens it from.
    pub fn spec(&self) -> DeviceSpec<'_> {
        DeviceSpec {
            name: &self.name,
            kind: self.kind,
            side: self.side,
            backend: self.backend,
            rate_hz: self.rate_hz,
            stale_after: self.stale_after,
            table: &self.table,
            emulator: &self.emulator,
            config: &*self.config,
        }
    }
}

/// What a front does when its client goes silent, resolved for one bound device
/// (docs/fronts.md, "Silence").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SilencePlan {
    /// The semantics in effect (for logs and `handgate check`): the profile's choice, or what
    /// the front kind makes of it.
    pub mode: crate::profile::Silence,
    /// After this long without a command, this action; `None`: the last target is kept.
    pub after: Option<(Duration, SafeAction)>,
    /// After a command that set the Dex3 RIS timeout bit (bit 7): this long, this action.
    pub timeout_bit: Option<(Duration, SafeAction)>,
}

impl SilencePlan {
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
    /// The front's table for this device (the wire convention it speaks, for its side);
    /// `None`: the device's own (fronts that speak no device kind's convention).
    pub table: Option<Arc<DeviceTable>>,
}

/// One front, bound to its devices (one, except a front whose messages carry several, like
/// the Dex1 actuator variant; a state-only front lists its devices in `devices` instead).
#[derive(Debug, Clone, PartialEq)]
pub struct FrontPlan {
    /// The name logs use (profile `name`, or derived).
    pub name: String,
    pub kind: FrontKind,
    /// The front's profile table (its kind's own keys, for its kind to open it).
    pub config: FrontConfig,
    pub bindings: Vec<Binding>,
    /// The low-frequency state copy (topic, Hz), where the kind has one.
    pub lf_state: Option<(String, f64)>,
    /// The devices a state-only front publishes (its device, or every device).
    pub devices: Vec<String>,
    pub cmd_topic: Option<String>,
    pub state_topic: String,
    pub state_hz: f64,
}

impl FrontPlan {
    /// Number of elements in this front's messages that carry a device (2 for an actuator
    /// front, else 1).
    pub fn elements(&self) -> usize {
        self.kind.factory().elements(&self.config)
    }
}

/// The whole fleet.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub profile: String,
    pub domain: u32,
    pub interface: Option<String>,
    pub status_topic: String,
    pub status_hz: f64,
    pub devices: Vec<DevicePlan>,
    pub fronts: Vec<FrontPlan>,
}
