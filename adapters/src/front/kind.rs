//! The front registry: one factory per front kind (in that front's module), one static list
//! ([`crate::fronts`]). A front kind owns its topics, its rates, its silence defaults, the
//! profile keys only it takes, its own validation rules, its `handgate check` suffix and its
//! endpoints; the profile, the resolver and the runtime ask it instead of matching on a kind.

use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use std::time::Duration;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::config::{FrontConfig, Silence};
use super::plan::{FrontPlan, SilencePlan};
use super::serve::Endpoints;
use crate::dds::DdsError;
use crate::model::{DeviceKind, SafeAction, Side};
use crate::units::Topic;

/// A registered front kind.
pub trait FrontFactory: Sync + Send + fmt::Debug + 'static {
    /// The name profiles use (`kind = "..."`).
    fn name(&self) -> &'static str;
    /// The device kind whose wire convention (table) this front speaks; `None`: the bound
    /// device's own table.
    fn speaks(&self) -> Option<DeviceKind> {
        None
    }
    /// Takes commands (a command topic, bindings, silence); `false`: publishes state only.
    fn takes_commands(&self) -> bool {
        true
    }
    /// Which of [`super::config::KIND_KEYS`] this kind takes.
    fn keys(&self) -> &'static [&'static str] {
        &[]
    }
    /// Serves one of handgate's own interfaces, whose topics live in the profile's ROS
    /// namespace (`[dds] namespace`); `false`: a device-compatible interface, whose topics are
    /// the device's and never move.
    fn in_namespace(&self) -> bool {
        false
    }
    /// The key naming this kind's state topic (`state_topic`, or joint_state's `topic`).
    fn state_topic_key(&self) -> &'static str {
        "state_topic"
    }
    /// Default (cmd, state, low-frequency state) topics of `f`, serving side `lr` (left or
    /// right; `None` for center) of the device named `device` (`all`: no device).
    fn default_topics(
        &self,
        f: &FrontConfig,
        lr: Option<Side>,
        device: &str,
    ) -> (Option<Topic>, Option<Topic>, Option<Topic>);
    /// Default state rate, given the bound device's rate (`None`: as fast as its bus).
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64;
    /// Default rate of the low-frequency state copy; `None`: the kind has none.
    fn default_lf_state_hz(&self) -> Option<f64> {
        None
    }
    /// The name logs use when the profile sets none and no command topic is overridden.
    fn default_name(&self, f: &FrontConfig, side: &str) -> String;
    /// What silence means on this front (`dog`: the device's, or the front's, watchdog).
    fn silence(&self, mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan {
            mode,
            after: Some(dog),
            timeout_bit: None,
        }
    }
    /// Elements of this front's messages that carry a device.
    fn elements(&self, _f: &FrontConfig) -> usize {
        1
    }
    /// Which of this kind's fronts bind devices by element (`devices = { right, left }`), as
    /// errors name them (`an actuator dex1 front`); `None`: none do.
    fn binds_elements(&self) -> Option<&'static str> {
        None
    }
    /// The element carrying the device served on `side`.
    fn element(&self, _f: &FrontConfig, _side: Side) -> usize {
        0
    }
    /// The kind's own rules: (key, message) pairs. `served` is the served side (`None`:
    /// unknown); `dangling`: the bound device is missing (reported already).
    fn validate(&self, _f: &FrontConfig, _served: Option<Side>, _dangling: bool) -> Vec<(&'static str, String)> {
        vec![]
    }
    /// The joint names a state-only front publishes for `device` (table `table`) in messages
    /// readers key by joint name (ROS 2 JointState); the profile check refuses a front on which
    /// two devices would publish one name. Empty: the front's messages carry no names.
    fn joint_names(&self, _f: &FrontConfig, _device: &str, _table: &crate::mapping::DeviceTable) -> Vec<String> {
        vec![]
    }
    /// Suffix of this front's `handgate check` line.
    fn describe(&self, _f: &FrontConfig) -> Option<String> {
        None
    }
    /// Lines `handgate check` prints under this front about what it serves with no device
    /// (`bound`: the sides of its bound devices).
    fn describe_unbound(&self, _f: &FrontConfig, _bound: &[Side]) -> Vec<String> {
        vec![]
    }
    /// Why two fronts of this kind on one command topic is wrong, beyond the clash itself.
    fn clash_hint(&self, _f: &FrontConfig, _other: &FrontConfig) -> &'static str {
        ""
    }
    /// What the front serves on DDS, for discovery's diagnostics: its command topic (role
    /// reader), its state topics (role writer), each with the type name CycloneDDS registers,
    /// the QoS [`FrontFactory::open`] uses, the other types a client may use there (with the
    /// fix in words) and related topics a client may use instead.
    fn served(&self, plan: &FrontPlan) -> Vec<crate::discovery::diagnose::Served>;
    /// The front's endpoints.
    fn open(
        &self,
        env: &super::serve::FrontEnv,
        plan: &FrontPlan,
        tx: super::serve::Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError>;
}

/// A registered front kind: a handle to its factory. Copy; compared and printed by name;
/// (de)serialised as its name (an unknown name is an unknown variant listing the registered
/// ones).
#[derive(Clone, Copy)]
pub struct FrontKind(&'static dyn FrontFactory);

impl FrontKind {
    /// The handle of `factory` (each front module defines its constant with it).
    pub const fn of(factory: &'static dyn FrontFactory) -> Self {
        FrontKind(factory)
    }

    /// Every registered front kind, in registry order.
    pub fn all() -> &'static [FrontKind] {
        crate::fronts::all()
    }

    /// The kind called `name`.
    pub fn by_name(name: &str) -> Option<FrontKind> {
        Self::all().iter().copied().find(|k| k.as_str() == name)
    }

    /// The registered names, in registry order.
    pub fn names() -> &'static [&'static str] {
        static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
        NAMES.get_or_init(|| Self::all().iter().map(|k| k.as_str()).collect())
    }

    /// The registered names of the kinds taking profile key `key`, joined with " and ".
    pub fn taking(key: &str) -> String {
        let v: Vec<&str> = Self::all()
            .iter()
            .filter(|k| k.factory().keys().contains(&key))
            .map(|k| k.as_str())
            .collect();
        v.join(" and ")
    }

    /// The fronts that bind devices by element, as errors name them (`an actuator dex1 front`).
    pub fn binding_elements() -> String {
        let v: Vec<&str> = Self::all()
            .iter()
            .filter_map(|k| k.factory().binds_elements())
            .collect();
        v.join(" or ")
    }

    pub fn factory(self) -> &'static dyn FrontFactory {
        self.0
    }

    pub fn as_str(self) -> &'static str {
        self.0.name()
    }

    pub fn takes_commands(self) -> bool {
        self.0.takes_commands()
    }
}

impl Default for FrontKind {
    /// handgate's own interface (the first registered front that speaks the device's table).
    fn default() -> Self {
        Self::all()
            .iter()
            .copied()
            .find(|k| k.takes_commands() && k.factory().speaks().is_none())
            .unwrap_or(Self::all()[0])
    }
}

impl PartialEq for FrontKind {
    fn eq(&self, other: &Self) -> bool {
        self.as_str() == other.as_str()
    }
}
impl Eq for FrontKind {}

impl Hash for FrontKind {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.as_str().hash(state)
    }
}

impl fmt::Debug for FrontKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Display for FrontKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for FrontKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for FrontKind {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        FrontKind::by_name(&s).ok_or_else(|| serde::de::Error::unknown_variant(&s, FrontKind::names()))
    }
}
