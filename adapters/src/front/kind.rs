//! The front registry: one typed [`Front`] per front kind (in that front's module), erased
//! once into a [`FrontFactory`] (the kind's static facts, parsing) and a [`FrontOwn`] (the
//! kind's typed config with everything that depends on it), and one static list
//! ([`crate::fronts`]). A front kind owns its topics, its rates, its silence defaults, its own
//! profile keys (a typed struct, unknown keys refused), its own validation rules, its
//! `handgate check` suffix and its endpoints; the profile, the resolver and the runtime ask it
//! instead of matching on a kind.

use std::any::Any;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::marker::PhantomData;
use std::sync::atomic::AtomicU64;
use std::sync::Arc;
use std::time::Duration;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::config::{fields_of, FrontConfig, FrontTopic, ServedSide, Silence, TopicAt, TopicKey};
use super::plan::{FrontPlan, SilencePlan};
use super::serve::{Endpoints, FrontEnv, Queue};
use crate::dds::DdsError;
use crate::discovery::diagnose::Served;
use crate::kind::{check_topic, ConfigError, ConfigValue};
use crate::mapping::DeviceTable;
use crate::model::{DeviceKind, SafeAction, Side};

/// What a front kind is, whatever its configuration.
#[derive(Debug, Clone, Copy)]
pub struct FrontFacts {
    /// The name profiles use (`kind = "..."`).
    pub name: &'static str,
    /// The device kind whose wire convention (table) this front speaks; `None`: the bound
    /// device's own table.
    pub speaks: Option<DeviceKind>,
    /// Takes commands (a command topic, bindings, silence); `false`: publishes state only.
    pub takes_commands: bool,
    /// Serves one of handgate's own interfaces, whose topics live in the profile's ROS
    /// namespace (`[dds] namespace`); `false`: a device-compatible interface, whose topics are
    /// the device's and never move.
    pub in_namespace: bool,
    /// Which of this kind's fronts bind devices by element (`devices = { right, left }`), as
    /// errors name them (`an actuator dex1 front`); `None`: none do.
    pub binds_elements: Option<&'static str>,
    /// Binds a list of devices by name (`devices = [..]`, or `device`, default every device),
    /// each in its own table, and its messages name the joints of the devices they command
    /// (ROS 2 JointState); `false`: one device, or devices by element.
    pub binds_list: bool,
}

impl FrontFacts {
    /// A front taking commands, speaking the convention of `speaks`, in no namespace,
    /// binding no devices by element.
    pub const fn serving(name: &'static str, speaks: Option<DeviceKind>) -> Self {
        FrontFacts {
            name,
            speaks,
            takes_commands: true,
            in_namespace: false,
            binds_elements: None,
            binds_list: false,
        }
    }
}

/// A front kind, typed: its facts, its own profile keys (`Config`, a struct in the kind's
/// module with `#[serde(deny_unknown_fields, default)]`), its topics and what it does with
/// them. Erased once, by the blanket `FrontFactory` and `FrontOwn` implementations below:
/// no front module downcasts anything.
pub trait Front: Sync + Send + fmt::Debug + 'static {
    /// The kind's own keys of a `[[fronts]]` table (besides those every front has).
    type Config: DeserializeOwned
        + Serialize
        + Default
        + Clone
        + PartialEq
        + fmt::Debug
        + ServedSide
        + Send
        + Sync
        + 'static;
    /// The registry's handle of this kind (`FrontKind::of(&TheFront)`).
    const KIND: FrontKind;
    const FACTS: FrontFacts;
    /// Every topic it serves: the key that sets it, its role and default.
    const TOPICS: &'static [TopicKey<Self::Config>];
    /// Its wire side (what it serves, its endpoints).
    type Wire: FrontWire<Self::Config>;

    /// Default state rate, given the bound device's rate (`None`: as fast as its bus).
    fn default_state_hz(device_hz: Option<f64>) -> f64;
    /// The name logs use when the profile sets none and no command topic is overridden
    /// (`f`: the whole table; `side`: the served side, `?` when unknown).
    fn default_name(c: &Self::Config, f: &FrontConfig, side: &str) -> String;
    /// Rate of the low-frequency state copy ([`super::config::TopicRole::LowFrequencyState`]);
    /// `None`: the kind has none.
    fn lf_state_hz(_c: &Self::Config) -> Option<f64> {
        None
    }
    /// What silence means on this front (`dog`: the device's, or the front's, watchdog).
    fn silence(mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        SilencePlan {
            mode,
            after: Some(dog),
            timeout_bit: None,
        }
    }
    /// Elements of this front's messages that carry a device.
    fn elements(_c: &Self::Config) -> usize {
        1
    }
    /// The element carrying the device served on `side`.
    fn element(_c: &Self::Config, _side: Side) -> usize {
        0
    }
    /// The kind's own rules beyond its topic names: (key, message) pairs. `f` is the whole
    /// table, `served` the served side (`None`: unknown); `dangling`: the bound device is
    /// missing (reported already).
    fn validate(
        _c: &Self::Config,
        _f: &FrontConfig,
        _served: Option<Side>,
        _dangling: bool,
    ) -> Vec<(&'static str, String)> {
        vec![]
    }
    /// The joint names the front's messages carry for `device` (table `table`) where they are
    /// keyed by joint name (ROS 2 JointState, published or taken as a command); the profile
    /// check refuses a front on which two devices would have one name. Empty: the front's
    /// messages carry no names.
    fn joint_names(_c: &Self::Config, _device: &str, _table: &DeviceTable) -> Vec<String> {
        vec![]
    }
    /// Why this front cannot move a device whose table is `table` (`None`: it can); the
    /// profile check refuses a front commanding such a device.
    fn cannot_drive(_c: &Self::Config, _table: &DeviceTable) -> Option<String> {
        None
    }
    /// Suffix of this front's `handgate check` line.
    fn describe(_c: &Self::Config) -> Option<String> {
        None
    }
    /// Lines `handgate check` prints under this front about what it serves with no device
    /// (`bound`: the sides of its bound devices).
    fn describe_unbound(_c: &Self::Config, _bound: &[Side]) -> Vec<String> {
        vec![]
    }
    /// Why two fronts on one command topic is wrong, beyond the clash itself (`other`: the
    /// other front's config when it is of this kind too).
    fn clash_hint(_c: &Self::Config, _other: Option<&Self::Config>) -> &'static str {
        ""
    }
}

/// A front kind's wire side: what it serves on DDS and how it opens its endpoints, given its
/// config (`C`). Most kinds' is the generic endpoint, `DdsFront<TheirCodec>`
/// ([`super::endpoint::DdsFront`]).
pub trait FrontWire<C>: 'static {
    /// What the front serves on DDS, for discovery's diagnostics: its command topic (role
    /// reader), its state topics (role writer), each with the type name CycloneDDS registers,
    /// the QoS its endpoints use, the other types a client may use there (with the fix in
    /// words) and related topics a client may use instead.
    fn served(c: &C, plan: &FrontPlan) -> Vec<Served>;
    /// The front's endpoints.
    fn open(c: &C, env: &FrontEnv, plan: &FrontPlan, tx: Queue, dropped: Arc<AtomicU64>)
        -> Result<Endpoints, DdsError>;
}

/// A registered front kind, erased: what it is whatever its configuration, and how it reads
/// its configuration. Implemented once, for every [`Front`].
pub trait FrontFactory: Sync + Send + fmt::Debug + 'static {
    fn facts(&self) -> FrontFacts;
    /// The profile keys this kind takes besides those every front has (its config's fields).
    fn keys(&self) -> &'static [&'static str];
    /// Default state rate, given the bound device's rate (`None`: as fast as its bus).
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64;
    /// What silence means on this front (`dog`: the device's, or the front's, watchdog).
    fn silence(&self, mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan;
    /// Parses this kind's keys (`value` is a table holding only them; absent keys take
    /// defaults; an unknown key is an `UnknownField` error).
    fn parse(&self, value: &ConfigValue) -> Result<FrontOwn, ConfigError>;
    /// The configuration of a front that sets none of the kind's keys.
    fn default_own(&self) -> FrontOwn;
}

impl<F: Front> FrontFactory for F {
    fn facts(&self) -> FrontFacts {
        F::FACTS
    }
    fn keys(&self) -> &'static [&'static str] {
        fields_of::<F::Config>()
    }
    fn default_state_hz(&self, device_hz: Option<f64>) -> f64 {
        F::default_state_hz(device_hz)
    }
    fn silence(&self, mode: Silence, dog: (Duration, SafeAction)) -> SilencePlan {
        F::silence(mode, dog)
    }
    fn parse(&self, value: &ConfigValue) -> Result<FrontOwn, ConfigError> {
        Ok(FrontOwn::new::<F>(value.deserialize().map_err(Box::new)?))
    }
    fn default_own(&self) -> FrontOwn {
        FrontOwn::new::<F>(F::Config::default())
    }
}

/// A front kind's own keys as the profile set them, typed by the kind and held erased: the
/// kind it belongs to travels with it, so a config cannot reach another kind's code.
pub struct FrontOwn(Box<dyn Section>);

/// What depends on a front's own keys; implemented once, by [`Own`].
trait Section: Any + Send + Sync {
    fn kind(&self) -> FrontKind;
    fn side(&self) -> Option<Side>;
    fn topics(&self, at: &TopicAt<'_>) -> Vec<FrontTopic>;
    fn lf_state_hz(&self) -> Option<f64>;
    fn default_name(&self, f: &FrontConfig, side: &str) -> String;
    fn elements(&self) -> usize;
    fn element(&self, side: Side) -> usize;
    fn validate(&self, f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)>;
    fn joint_names(&self, device: &str, table: &DeviceTable) -> Vec<String>;
    fn cannot_drive(&self, table: &DeviceTable) -> Option<String>;
    fn describe(&self) -> Option<String>;
    fn describe_unbound(&self, bound: &[Side]) -> Vec<String>;
    fn clash_hint(&self, other: &FrontOwn) -> &'static str;
    fn served(&self, plan: &FrontPlan) -> Vec<Served>;
    fn open(&self, env: &FrontEnv, plan: &FrontPlan, tx: Queue, dropped: Arc<AtomicU64>)
        -> Result<Endpoints, DdsError>;
    fn to_value(&self) -> Result<ConfigValue, ConfigError>;
    fn as_any(&self) -> &dyn Any;
    fn clone_box(&self) -> Box<dyn Section>;
    fn eq_dyn(&self, other: &dyn Section) -> bool;
    fn fmt_dyn(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result;
}

/// The typed config of front kind `F`: the one place a kind's config is erased.
struct Own<F: Front>(F::Config, PhantomData<fn() -> F>);

impl<F: Front> Own<F> {
    /// `s` as this kind's config: `None` when `s` is another kind's.
    fn of(s: &dyn Section) -> Option<&F::Config> {
        s.as_any().downcast_ref::<Own<F>>().map(|o| &o.0)
    }
}

impl<F: Front> Section for Own<F> {
    fn kind(&self) -> FrontKind {
        F::KIND
    }
    fn side(&self) -> Option<Side> {
        self.0.side()
    }
    fn topics(&self, at: &TopicAt<'_>) -> Vec<FrontTopic> {
        F::TOPICS.iter().map(|k| k.resolve(&self.0, at)).collect()
    }
    fn lf_state_hz(&self) -> Option<f64> {
        F::lf_state_hz(&self.0)
    }
    fn default_name(&self, f: &FrontConfig, side: &str) -> String {
        F::default_name(&self.0, f, side)
    }
    fn elements(&self) -> usize {
        F::elements(&self.0)
    }
    fn element(&self, side: Side) -> usize {
        F::element(&self.0, side)
    }
    /// Every topic the profile sets must be a topic name; then the kind's own rules.
    fn validate(&self, f: &FrontConfig, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        let mut out: Vec<(&'static str, String)> = F::TOPICS
            .iter()
            .filter_map(|k| (k.set)(&self.0).map(|t| (k.key, t)))
            .filter_map(|(key, t)| check_topic(t.as_str()).err().map(|m| (key, m)))
            .collect();
        out.extend(F::validate(&self.0, f, served, dangling));
        out
    }
    fn joint_names(&self, device: &str, table: &DeviceTable) -> Vec<String> {
        F::joint_names(&self.0, device, table)
    }
    fn cannot_drive(&self, table: &DeviceTable) -> Option<String> {
        F::cannot_drive(&self.0, table)
    }
    fn describe(&self) -> Option<String> {
        F::describe(&self.0)
    }
    fn describe_unbound(&self, bound: &[Side]) -> Vec<String> {
        F::describe_unbound(&self.0, bound)
    }
    fn clash_hint(&self, other: &FrontOwn) -> &'static str {
        F::clash_hint(&self.0, Self::of(&*other.0))
    }
    fn served(&self, plan: &FrontPlan) -> Vec<Served> {
        F::Wire::served(&self.0, plan)
    }
    fn open(
        &self,
        env: &FrontEnv,
        plan: &FrontPlan,
        tx: Queue,
        dropped: Arc<AtomicU64>,
    ) -> Result<Endpoints, DdsError> {
        F::Wire::open(&self.0, env, plan, tx, dropped)
    }
    fn to_value(&self) -> Result<ConfigValue, ConfigError> {
        ConfigValue::serialize(&self.0).map_err(Box::new)
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn Section> {
        Box::new(Own::<F>(self.0.clone(), PhantomData))
    }
    fn eq_dyn(&self, other: &dyn Section) -> bool {
        Self::of(other).is_some_and(|o| *o == self.0)
    }
    fn fmt_dyn(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {:?}", F::FACTS.name, self.0)
    }
}

impl FrontOwn {
    /// Config `c` of front kind `F`.
    pub fn new<F: Front>(c: F::Config) -> Self {
        FrontOwn(Box::new(Own::<F>(c, PhantomData)))
    }

    /// The defaults of `kind`.
    pub fn of(kind: FrontKind) -> Self {
        kind.factory().default_own()
    }

    /// The kind this config belongs to.
    pub fn kind(&self) -> FrontKind {
        self.0.kind()
    }

    /// The config as kind `F`'s type; `None` when it belongs to another kind.
    pub fn get<F: Front>(&self) -> Option<&F::Config> {
        Own::<F>::of(&*self.0)
    }

    /// The keys as a profile writes them.
    pub fn to_value(&self) -> Result<ConfigValue, ConfigError> {
        self.0.to_value()
    }
}

impl Default for FrontOwn {
    /// The default front kind's defaults.
    fn default() -> Self {
        FrontOwn::of(FrontKind::default())
    }
}

impl Clone for FrontOwn {
    fn clone(&self) -> Self {
        FrontOwn(self.0.clone_box())
    }
}

impl PartialEq for FrontOwn {
    fn eq(&self, other: &Self) -> bool {
        self.0.eq_dyn(&*other.0)
    }
}

impl fmt::Debug for FrontOwn {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt_dyn(f)
    }
}

/// What depends on a front's kind and own keys, asked of the front's config (its kind
/// answers through [`FrontOwn`]).
impl FrontConfig {
    /// The topic side the config sets (`None`: the bound device's).
    pub fn side(&self) -> Option<Side> {
        self.own.0.side()
    }
    /// Every topic the front serves at `at`, with the profile's overrides.
    pub fn kind_topics(&self, at: &TopicAt<'_>) -> Vec<FrontTopic> {
        self.own.0.topics(at)
    }
    /// Rate of the low-frequency state copy, where the kind has one.
    pub fn lf_state_hz(&self) -> Option<f64> {
        self.own.0.lf_state_hz()
    }
    /// The name logs use when the profile sets none and no command topic is overridden.
    pub fn default_name(&self, side: &str) -> String {
        self.own.0.default_name(self, side)
    }
    /// Elements of this front's messages that carry a device.
    pub fn elements(&self) -> usize {
        self.own.0.elements()
    }
    /// The element carrying the device served on `side`.
    pub fn element(&self, side: Side) -> usize {
        self.own.0.element(side)
    }
    /// The kind's rules on its own keys (its topic names, then its own), as (key, message).
    pub fn validate_own(&self, served: Option<Side>, dangling: bool) -> Vec<(&'static str, String)> {
        self.own.0.validate(self, served, dangling)
    }
    /// The joint names this front's messages carry for `device`.
    pub fn joint_names(&self, device: &str, table: &DeviceTable) -> Vec<String> {
        self.own.0.joint_names(device, table)
    }
    /// Why this front cannot move a device whose table is `table` (`None`: it can).
    pub fn cannot_drive(&self, table: &DeviceTable) -> Option<String> {
        self.own.0.cannot_drive(table)
    }
    /// Suffix of this front's `handgate check` line.
    pub fn describe(&self) -> Option<String> {
        self.own.0.describe()
    }
    /// `handgate check` lines about what the front serves with no device.
    pub fn describe_unbound(&self, bound: &[Side]) -> Vec<String> {
        self.own.0.describe_unbound(bound)
    }
    /// Why this front and `other` on one command topic is wrong, beyond the clash itself.
    pub fn clash_hint(&self, other: &FrontConfig) -> &'static str {
        self.own.0.clash_hint(&other.own)
    }
}

impl FrontPlan {
    /// What this front serves on DDS (its kind's `FrontWire::served`).
    pub fn served(&self) -> Vec<Served> {
        self.config.own.0.served(self)
    }
    /// Opens this front's endpoints (its kind's `FrontWire::open`).
    pub fn open(&self, env: &FrontEnv, tx: Queue, dropped: Arc<AtomicU64>) -> Result<Endpoints, DdsError> {
        self.config.own.0.open(env, self, tx, dropped)
    }
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

    /// The fronts that bind devices by element, as errors name them (`an actuator dex1 front`).
    pub fn binding_elements() -> String {
        let v: Vec<&str> = Self::all()
            .iter()
            .filter_map(|k| k.factory().facts().binds_elements)
            .collect();
        v.join(" or ")
    }

    pub fn factory(self) -> &'static dyn FrontFactory {
        self.0
    }

    pub fn as_str(self) -> &'static str {
        self.0.facts().name
    }

    pub fn takes_commands(self) -> bool {
        self.0.facts().takes_commands
    }
}

impl Default for FrontKind {
    /// handgate's own interface (the first registered front that speaks the device's table).
    fn default() -> Self {
        Self::all()
            .iter()
            .copied()
            .find(|k| k.takes_commands() && k.factory().facts().speaks.is_none())
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

/// What every front kind's unit tests check the same way.
#[cfg(test)]
pub(crate) mod testing {
    use super::*;
    use crate::front::config::Silence;
    use crate::units::Topic;

    /// `kind` is registered by device kind `by` under `name`, speaks `by`'s convention, takes
    /// commands and `keys` (besides those every front has), and binds devices by element as
    /// `binds` names it.
    pub fn assert_registered(kind: FrontKind, name: &str, by: DeviceKind, keys: &[&str], binds: Option<&str>) {
        assert_eq!(FrontKind::by_name(name), Some(kind));
        assert!(by.factory().fronts().contains(&kind), "{by} registers {kind}");
        let f = kind.factory().facts();
        assert_eq!(f.speaks, Some(by));
        assert!(f.takes_commands);
        assert_eq!(kind.factory().keys(), keys);
        assert_eq!(f.binds_elements, binds);
        assert_eq!(FrontConfig::new(kind).kind(), kind);
    }

    /// `kind`'s silence: as its service, the device keeps its last target (the RIS timeout bit
    /// changes nothing); in watchdog mode, the device's watchdog `dog`.
    pub fn assert_keeps_last_target(kind: FrontKind, dog: (Duration, SafeAction)) {
        let s = kind.factory().silence(Silence::Service, dog);
        assert_eq!((s.mode, s.after, s.timeout_bit), (Silence::Service, None, None));
        assert_eq!(s.armed(true), None);
        assert_eq!(s.to_string(), "service: keeps the last target");
        let w = kind.factory().silence(Silence::Watchdog, dog);
        assert_eq!((w.mode, w.after, w.timeout_bit), (Silence::Watchdog, Some(dog), None));
        assert_eq!(w.armed(false), Some(dog));
    }

    /// (key, topic) of each topic front `c` serves on `side` of a device called `x`.
    pub fn topics_at(c: &FrontConfig, side: Option<Side>) -> Vec<(&'static str, Option<Topic>)> {
        c.kind_topics(&TopicAt { side, device: "x" })
            .into_iter()
            .map(|t| (t.key, t.topic))
            .collect()
    }
}
