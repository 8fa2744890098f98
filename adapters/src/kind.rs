//! Device kinds: what every kind of hand or gripper tells handgate about itself, through one
//! factory per kind folder (the shape of probe-rs's `ProbeFactory` + `DRIVERS`). The static
//! list of every kind is [`crate::kinds::KINDS`]; nothing outside a kind's folder and that
//! list names a kind.
//!
//! A kind owns: its name and canonical joints, its mapping table per side, the backends it
//! supports and their default loop rates, its own profile keys (a typed struct parsed from
//! the `[[devices]]` table, unknown keys refused), their validation rules, and how a device
//! is opened on each backend (docs/adapters.md, "Adding a device kind").

use std::any::Any;
use std::fmt;
use std::hash::{Hash, Hasher};

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::device::{Backend, DeviceError, HandDevice};
use crate::emu_common::Fault;
use crate::mapping::{ClosureMap, DeviceTable, MappingError};
use crate::model::{JointId, Side};
use crate::open::{DeviceSpec, OpenEnv};

/// A profile value as the loader holds it (a figment value: deserialising it keeps the path
/// of a bad key, so errors still name the file and the key).
pub type ConfigValue = figment::value::Value;
/// A structural error in a kind's profile keys (path relative to the device's table).
pub type ConfigError = Box<figment::Error>;

/// A registered device kind: a handle to its factory. Copy; compared, ordered, hashed and
/// printed by name; (de)serialised as its name (an unknown name is an unknown variant
/// listing the registered ones).
#[derive(Clone, Copy)]
pub struct DeviceKind(&'static dyn KindFactory);

impl DeviceKind {
    /// The handle of `factory` (each kind folder defines its constant with it).
    pub const fn of(factory: &'static dyn KindFactory) -> Self {
        DeviceKind(factory)
    }

    /// Every registered kind, in registry order.
    pub const ALL: &'static [DeviceKind] = crate::kinds::KINDS;

    /// Every registered kind, in registry order.
    pub fn all() -> &'static [DeviceKind] {
        Self::ALL
    }

    /// The kind called `name`.
    pub fn by_name(name: &str) -> Option<DeviceKind> {
        Self::all().iter().copied().find(|k| k.as_str() == name)
    }

    /// The registered names, in registry order.
    pub fn names() -> &'static [&'static str] {
        static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
        NAMES.get_or_init(|| Self::all().iter().map(|k| k.as_str()).collect())
    }

    pub fn factory(self) -> &'static dyn KindFactory {
        self.0
    }

    pub fn as_str(self) -> &'static str {
        self.0.name()
    }

    /// Canonical joint names of this kind, in canonical order.
    pub fn joint_names(self) -> &'static [&'static str] {
        self.0.joints()
    }

    pub fn joint_count(self) -> usize {
        self.joint_names().len()
    }

    /// The kind's table for `side` with its default configuration and `overrides`.
    pub fn table(self, side: Side, overrides: &crate::mapping::TableOverrides) -> Result<DeviceTable, MappingError> {
        self.0.table_with(side, &*self.0.default_config(), overrides)
    }

    /// The joint called `name`, if this kind has one.
    pub fn joint(self, name: &str) -> Option<JointId> {
        self.joint_names()
            .iter()
            .position(|n| *n == name)
            .map(|i| JointId(i as u8))
    }
}

impl Default for DeviceKind {
    /// The first registered kind.
    fn default() -> Self {
        Self::all()[0]
    }
}

impl PartialEq for DeviceKind {
    fn eq(&self, other: &Self) -> bool {
        self.as_str() == other.as_str()
    }
}
impl Eq for DeviceKind {}

impl Hash for DeviceKind {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.as_str().hash(state)
    }
}

impl PartialOrd for DeviceKind {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for DeviceKind {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.as_str().cmp(other.as_str())
    }
}

impl fmt::Debug for DeviceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Display for DeviceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for DeviceKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for DeviceKind {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        DeviceKind::by_name(&s).ok_or_else(|| serde::de::Error::unknown_variant(&s, DeviceKind::names()))
    }
}

/// A profile key of a `[[devices]]` table that a kind reads besides the common ones, and
/// the backends it applies to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SectionSpec {
    pub key: &'static str,
    pub backends: &'static [Backend],
}

/// One problem found by a kind's validation: key segments relative to the device's table
/// (`["usb", "wiring", "joints", "thumb_0", "bus"]`) and the message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    pub key: Vec<String>,
    pub message: String,
}

impl Problem {
    pub fn new(key: &[&str], message: impl Into<String>) -> Self {
        Self {
            key: key.iter().map(|s| s.to_string()).collect(),
            message: message.into(),
        }
    }
}

/// Highest rate a device loop or publisher may be configured to, Hz.
pub const MAX_RATE_HZ: f64 = 2000.0;

/// What a kind's validation may look at besides its own keys.
#[derive(Debug, Clone, Copy)]
pub struct DeviceCtx<'a> {
    pub name: &'a str,
    pub side: Side,
    pub backend: Backend,
}

/// A device of some kind in the fleet, for the rules across devices (`validate_fleet`).
#[derive(Debug)]
pub struct FleetMember<'a, C: ?Sized = dyn KindConfig> {
    /// Index in the profile's `devices`.
    pub index: usize,
    pub ctx: DeviceCtx<'a>,
    pub config: &'a C,
}

impl<C: ?Sized> Clone for FleetMember<'_, C> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<C: ?Sized> Copy for FleetMember<'_, C> {}

/// A problem found across devices: the device index, then as [`Problem`].
pub type FleetProblem = (usize, Problem);

/// Where one tactile pad sits on a schematic drawing of the hand (the dashboard's pressure
/// map): the unit square of the hand seen palm towards the viewer, fingers up, `x` to the
/// right, `y` down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PadPlace {
    /// The pad's name, as in [`crate::model::Pad::name`].
    pub name: &'static str,
    pub x: f32,
    pub y: f32,
    pub w: f32,
    pub h: f32,
}

/// How a kind's raw taxel values read on a 0..1 scale: `zero` reads 0, `full` reads 1 (a
/// display scale, not a calibration); values below `valid_min` are "no reading".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PadScale {
    pub valid_min: f32,
    pub zero: f32,
    pub full: f32,
}

impl PadScale {
    /// `v` on the 0..1 scale, or -1 for "no reading".
    pub fn normalise(&self, v: f32) -> f32 {
        if !v.is_finite() || v < self.valid_min {
            return -1.0;
        }
        ((v - self.zero) / (self.full - self.zero)).clamp(0.0, 1.0)
    }
}

/// A kind's tactile pads as the dashboard draws them.
#[derive(Debug, Clone)]
pub struct PadLayout {
    /// Right hand; the left hand is its mirror image (`x` → `1 - x - w`).
    pub right: &'static [PadPlace],
    pub scale: PadScale,
    /// A pad's taxel grid, rows × cols, by its name (known before any state arrives).
    pub shape: fn(&str) -> (u16, u16),
}

impl PadLayout {
    /// The places for `side`.
    pub fn places(&self, side: Side) -> Vec<PadPlace> {
        self.right
            .iter()
            .map(|p| match side {
                Side::Left => PadPlace {
                    x: 1.0 - p.x - p.w,
                    ..*p
                },
                _ => *p,
            })
            .collect()
    }
}

/// The sides a device of a kind may have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sides {
    /// Left, right or center.
    Any,
    /// Left or right only; `note` ends the refusal of center (`", not center"`, or why).
    LeftOrRight { note: &'static str },
}

/// A kind's device loop rates when the profile sets none: `Some(Hz)`, or `None` for "as
/// fast as the bus answers"; `by_backend` overrides `default` on the backends it names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    pub default: Option<f64>,
    pub by_backend: &'static [(Backend, Option<f64>)],
}

impl Rates {
    /// `hz` on every backend.
    pub const fn fixed(hz: f64) -> Self {
        Rates {
            default: Some(hz),
            by_backend: &[],
        }
    }

    /// As fast as the bus answers, on every backend.
    pub const AS_FAST_AS_THE_BUS: Rates = Rates {
        default: None,
        by_backend: &[],
    };

    /// The rate on `backend`.
    pub fn on(&self, backend: Backend) -> Option<f64> {
        self.by_backend
            .iter()
            .find(|(b, _)| *b == backend)
            .map_or(self.default, |(_, hz)| *hz)
    }
}

/// What a kind is, in one constant: everything about it that no profile changes.
#[derive(Debug, Clone, Copy)]
pub struct KindFacts {
    /// The kind's name in profiles (`kind = "..."`), logs and status.
    pub name: &'static str,
    /// Canonical joint names, canonical order.
    pub joints: &'static [&'static str],
    /// The backends a device of this kind can use.
    pub backends: &'static [Backend],
    /// The fronts serving this kind's own interface (its service's topics, so an unmodified
    /// client of this hand can drive any device): registered with the kind
    /// ([`crate::fronts::all`]).
    pub fronts: &'static [crate::front::kind::FrontKind],
    pub sides: Sides,
    /// The device loop rate when the profile sets none.
    pub rates: Rates,
    /// The profile keys this kind reads in a `[[devices]]` table besides the common ones.
    pub sections: &'static [SectionSpec],
    /// Where its tactile pads sit and how their values read (the dashboard); `None`: no
    /// tactile pads.
    pub pads: Option<&'static PadLayout>,
    /// Whether `closure.open` / `closure.closed` postures may be set in a profile.
    pub closure_postures_configurable: bool,
}

impl KindFacts {
    /// Facts with no fronts, any side, no sections, no pads, fixed postures.
    pub const fn new(
        name: &'static str,
        joints: &'static [&'static str],
        backends: &'static [Backend],
        rates: Rates,
    ) -> Self {
        KindFacts {
            name,
            joints,
            backends,
            fronts: &[],
            sides: Sides::Any,
            rates,
            sections: &[],
            pads: None,
            closure_postures_configurable: false,
        }
    }

    /// A client of a hand service running one instance per hand
    /// ([`crate::service_client::ServiceHand`]): backends dds and emulator, a left or a right
    /// hand, a `[devices.dds]` section on backend dds, the service's rate `hz` (the emulated
    /// service runs at the device's), `fronts` serving the service's interface.
    pub const fn hand_service(
        name: &'static str,
        joints: &'static [&'static str],
        hz: f64,
        fronts: &'static [crate::front::kind::FrontKind],
    ) -> Self {
        KindFacts {
            fronts,
            sides: Sides::LeftOrRight { note: "" },
            sections: &[SectionSpec {
                key: "dds",
                backends: &[Backend::Dds],
            }],
            ..KindFacts::new(name, joints, &[Backend::Dds, Backend::Emulator], Rates::fixed(hz))
        }
    }
}

/// A device kind, typed: its facts, its own profile keys ([`Kind::Config`]), what it builds
/// for a device before starting anything ([`Kind::Open`]) and the options of its standalone
/// emulator ([`Kind::Emulate`]). Each kind folder implements it once on a unit struct; one
/// blanket implementation ([`KindFactory`] for every `Kind`) parses, erases, validates and
/// hands each method back its typed configuration, so no kind folder downcasts anything.
pub trait Kind: Sync + Send + fmt::Debug + 'static {
    const FACTS: KindFacts;
    /// The faults its emulator backend's service injects (`[devices.emulator] fault`, the
    /// forms of [`crate::emu_common::FaultArg::form`]); empty: none (the key is refused).
    const EMULATOR_FAULTS: &'static [&'static str] = &[];
    /// The kind's own profile keys (absent keys take their defaults).
    type Config: Settings;
    /// What a device opens with, decided from the profile before anything starts (transport,
    /// loop, peer settings): `handgate check` and the tests look at it.
    type Open: fmt::Debug + 'static;
    /// The options `handgate emulate <kind>` takes besides the common ones.
    type Emulate: EmulateOptions;

    /// The kind's mapping table for `side` with its own configuration applied (the profile's
    /// common overrides come on top: [`crate::mapping::TableOverrides`]).
    fn table(&self, side: Side, config: &Self::Config) -> DeviceTable;

    /// What `spec` opens with.
    fn configure(&self, spec: &DeviceSpec<'_, Self::Config>) -> Result<Self::Open, DeviceError>;

    /// Opens the device `configure` decided.
    fn open(
        &self,
        open: Self::Open,
        spec: &DeviceSpec<'_, Self::Config>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError>;

    /// `handgate emulate <kind>`: what this kind's emulator stands in for (the hardware at
    /// its transport seam, or the robot's service) as a standalone process. Returns the line
    /// to print (socket, pty or topics) and the running emulation.
    fn emulate(&self, args: &EmulateArgs, options: Self::Emulate) -> Result<(String, Emulation), DeviceError>;

    /// What a device opened as `open` serves on DDS as a client of a robot service, for
    /// discovery's diagnostics: its command topic (role writer) and state topics (role
    /// reader), on the emulator backend its in-process peer's private topics. Empty for
    /// devices that reach their hardware without DDS (USB, serial).
    fn served(&self, _open: &Self::Open) -> Vec<crate::discovery::diagnose::Served> {
        Vec::new()
    }

    /// The widest canonical range (rad) a profile may give `joint` (limits, closure
    /// postures, emulator positions); `None` for an unknown joint. Default: the limits of
    /// the kind's default table.
    fn hardware_range(&self, side: Side, joint: &str) -> Option<(f64, f64)> {
        let t = self.table(side, &Self::Config::default());
        let id = t.joint_by_name(joint).ok()?;
        let l = t.joints[id.index()].limits;
        Some((l.min as f64, l.max as f64))
    }

    /// Rules of this kind for its `[devices.emulator]` section (keys relative to the device's
    /// table, e.g. `["emulator", "noise"]`): a key the kind's emulator cannot honour is
    /// refused here rather than accepted and ignored.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, _section: &crate::open::EmulatorSection) -> Vec<Problem> {
        Vec::new()
    }

    /// Rules across the fleet's devices of this kind (`members`: those devices).
    fn validate_fleet(&self, _members: &[FleetMember<'_, Self::Config>]) -> Vec<FleetProblem> {
        Vec::new()
    }

    /// Called once with every device of this kind before any of them is opened: opens what
    /// several devices share (one bus per port) into `env.shared`.
    fn prepare(&self, _devices: &[DeviceSpec<'_, Self::Config>], _env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        Ok(())
    }

    /// `handgate list`: the devices of this kind attached to this machine (one line each,
    /// with what stops handgate from opening one), for kinds that can enumerate them.
    fn list_attached(&self) -> Option<Result<Vec<String>, DeviceError>> {
        None
    }
}

/// A kind's parsed profile keys, typed (the kind's [`Kind::Config`]). Erased once, by the
/// blanket [`KindConfig`] implementation.
pub trait Settings:
    serde::de::DeserializeOwned + Default + Clone + PartialEq + fmt::Debug + Send + Sync + 'static
{
    /// Semantic checks of the kind's keys (keys relative to the device's table).
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        Vec::new()
    }

    /// Topics a device on backend dds uses to reach its peer: (command topic it publishes,
    /// state topic it reads). `None` where the kind has no such peer; an inner `None` where
    /// the default cannot be derived (side center without overrides).
    fn peer_topics(&self, _ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        None
    }

    /// For a command topic that carries several devices in one message (the Dex1 `actuator`
    /// variant, Inspire DFX's 12 entries for both hands): the element this device writes.
    /// Two devices on one command topic are refused unless both name an element and the
    /// elements differ. `None`: the device owns the whole message.
    fn command_element(&self, _ctx: &DeviceCtx<'_>) -> Option<usize> {
        None
    }

    /// What `handgate check` adds after the device's rate and watchdog (starting with `, `
    /// or ` `), empty when nothing.
    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        String::new()
    }

    /// The serial ports a device with these keys owns on the hardware backend (`handgate
    /// doctor` reports another process holding one, and an FTDI adapter's latency timer);
    /// empty for a kind on DDS, USB or TCP.
    fn serial_ports(&self) -> Vec<std::path::PathBuf> {
        Vec::new()
    }
}

/// Options of `handgate emulate <kind>` that only that kind takes, parsed from
/// `--name [value]` pairs (the common ones are in [`EmulateArgs`]).
pub trait EmulateOptions: Default + Sized {
    /// Which of the options every emulator may take ([`COMMON_EMULATE_OPTIONS`]) this one
    /// takes (the others are refused, never ignored).
    const COMMON: &'static [&'static str] = COMMON_EMULATE_OPTIONS;
    /// The kind's own options, in the order help and errors list them.
    const OPTIONS: &'static [EmulateOption];

    /// Sets option `name` (one of [`EmulateOptions::OPTIONS`]) to `value` (`None` for a
    /// switch); `Err(why)` for a value it cannot take.
    fn set(&mut self, name: &str, _value: Option<&str>) -> Result<(), String> {
        Err(format!("--{name} is not an option"))
    }
}

/// No options of its own; every common one.
impl EmulateOptions for () {
    const OPTIONS: &'static [EmulateOption] = &[];
}

/// One option of a kind's emulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmulateOption {
    /// Its name without the leading `--`.
    pub name: &'static str,
    /// The value's placeholder (`PATH`), or `None` for a switch.
    pub value: Option<&'static str>,
    pub help: &'static str,
}

/// The typed view of an erased configuration. Configurations are made only by their kind's
/// [`KindFactory::parse`] / [`KindFactory::default_config`] and the profile keeps each with
/// its kind, so another type here is a bug in handgate, not in a profile: it panics, naming
/// both, here and nowhere else.
fn typed<K: Kind>(config: &dyn KindConfig) -> &K::Config {
    config.as_any().downcast_ref::<K::Config>().unwrap_or_else(|| {
        panic!(
            "internal error: a {} device was given another kind's configuration ({config:?})",
            K::FACTS.name
        )
    })
}

/// Every typed kind is a factory: the one place where configurations are parsed, erased and
/// given back typed.
impl<K: Kind> KindFactory for K {
    fn name(&self) -> &'static str {
        K::FACTS.name
    }

    fn pads(&self) -> Option<&'static PadLayout> {
        K::FACTS.pads
    }

    fn joints(&self) -> &'static [&'static str] {
        K::FACTS.joints
    }

    fn backends(&self) -> &'static [Backend] {
        K::FACTS.backends
    }

    fn fronts(&self) -> &'static [crate::front::kind::FrontKind] {
        K::FACTS.fronts
    }

    fn check_side(&self, side: Side) -> Result<(), String> {
        match (K::FACTS.sides, side) {
            (Sides::LeftOrRight { note }, Side::Center) => {
                Err(format!("{} is a left or a right hand{note}", a(K::FACTS.name)))
            }
            _ => Ok(()),
        }
    }

    fn default_rate_hz(&self, backend: Backend) -> Option<f64> {
        K::FACTS.rates.on(backend)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        K::FACTS.sections
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<K::Config>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(K::Config::default())
    }

    fn table(&self, side: Side, config: &dyn KindConfig) -> DeviceTable {
        Kind::table(self, side, typed::<K>(config))
    }

    fn closure_postures_configurable(&self) -> bool {
        K::FACTS.closure_postures_configurable
    }

    fn hardware_range(&self, side: Side, joint: &str) -> Option<(f64, f64)> {
        self.check_side(side).ok()?;
        Kind::hardware_range(self, side, joint)
    }

    fn validate_emulator(&self, ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem> {
        let mut out = Kind::validate_emulator(self, ctx, section);
        let fault_key = ["emulator", "fault"];
        if !out.iter().any(|p| p.key == fault_key) {
            out.extend(section.fault_problem(K::FACTS.name, K::EMULATOR_FAULTS));
        }
        out
    }

    fn validate_fleet(&self, members: &[FleetMember<'_>]) -> Vec<FleetProblem> {
        let typed: Vec<FleetMember<'_, K::Config>> = members
            .iter()
            .map(|m| FleetMember {
                index: m.index,
                ctx: m.ctx,
                config: typed::<K>(m.config),
            })
            .collect();
        Kind::validate_fleet(self, &typed)
    }

    fn prepare(&self, devices: &[DeviceSpec<'_>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError> {
        let typed: Vec<DeviceSpec<'_, K::Config>> = devices.iter().map(|d| d.typed(typed::<K>(d.config))).collect();
        Kind::prepare(self, &typed, env)
    }

    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn fmt::Debug>, DeviceError> {
        Ok(Box::new(self.configure(&spec.typed(typed::<K>(spec.config)))?))
    }

    fn list_attached(&self) -> Option<Result<Vec<String>, DeviceError>> {
        Kind::list_attached(self)
    }

    fn emulate(&self, args: &EmulateArgs) -> Result<(String, Emulation), DeviceError> {
        let options = args.options_for::<K::Emulate>(K::FACTS.name)?;
        Kind::emulate(self, args, options)
    }

    fn emulate_options(&self) -> &'static [EmulateOption] {
        <K::Emulate as EmulateOptions>::OPTIONS
    }

    fn served(&self, spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
        match self.configure(&spec.typed(typed::<K>(spec.config))) {
            Ok(open) => Kind::served(self, &open),
            Err(_) => Vec::new(),
        }
    }

    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
        let spec = spec.typed(typed::<K>(spec.config));
        let open = self.configure(&spec)?;
        Kind::open(self, open, &spec, env)
    }

    fn served_by_default(&self, side: Side) -> Vec<crate::discovery::diagnose::Served> {
        let backend = Backend::Dds;
        if self.check_side(side).is_err() || !K::FACTS.backends.contains(&backend) {
            return Vec::new();
        }
        let config = K::Config::default();
        let table = std::sync::Arc::new(Kind::table(self, side, &config));
        let emulator = crate::open::EmulatorSection::default();
        let rate_hz = K::FACTS.rates.on(backend).unwrap_or(100.0);
        let spec = DeviceSpec {
            name: K::FACTS.name,
            kind: DeviceKind::by_name(K::FACTS.name).unwrap_or_default(),
            side,
            backend,
            rate_hz,
            stale_after: std::time::Duration::from_millis(200),
            forward_on_arrival: true,
            max_send_hz: None,
            table: &table,
            emulator: &emulator,
            config: &config,
        };
        match self.configure(&spec) {
            Ok(open) => Kind::served(self, &open),
            Err(_) => Vec::new(),
        }
    }
}

/// A registered kind, erased: what the profile, the resolver and the runtime ask of a kind
/// without knowing which it is. Implemented once, for every [`Kind`]; a kind folder
/// implements [`Kind`], never this.
pub trait KindFactory: Sync + Send + fmt::Debug + 'static {
    /// The kind's name in profiles (`kind = "..."`), logs and status.
    fn name(&self) -> &'static str;
    /// [`KindFacts::pads`].
    fn pads(&self) -> Option<&'static PadLayout>;
    /// Canonical joint names, canonical order.
    fn joints(&self) -> &'static [&'static str];
    /// The backends a device of this kind can use.
    fn backends(&self) -> &'static [Backend];
    /// [`KindFacts::fronts`].
    fn fronts(&self) -> &'static [crate::front::kind::FrontKind];
    /// `Err(message)` when a device of this kind cannot have `side`.
    fn check_side(&self, side: Side) -> Result<(), String>;
    /// The device loop rate when the profile sets none: `Some(Hz)`, or `None` for "as fast
    /// as the bus answers".
    fn default_rate_hz(&self, backend: Backend) -> Option<f64>;
    /// The profile keys this kind reads in a `[[devices]]` table besides the common ones.
    fn sections(&self) -> &'static [SectionSpec];
    /// Parses those keys (`value` is a table holding only them; absent keys take defaults).
    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError>;
    /// The configuration of a device that sets none of the kind's keys.
    fn default_config(&self) -> Box<dyn KindConfig>;
    /// [`Kind::table`].
    fn table(&self, side: Side, config: &dyn KindConfig) -> DeviceTable;
    /// Whether `closure.open` / `closure.closed` postures may be set in a profile.
    fn closure_postures_configurable(&self) -> bool;
    /// [`Kind::hardware_range`]; `None` for an impossible side too.
    fn hardware_range(&self, side: Side, joint: &str) -> Option<(f64, f64)>;
    /// [`Kind::validate_emulator`].
    fn validate_emulator(&self, ctx: &DeviceCtx<'_>, section: &crate::open::EmulatorSection) -> Vec<Problem>;
    /// [`Kind::validate_fleet`].
    fn validate_fleet(&self, members: &[FleetMember<'_>]) -> Vec<FleetProblem>;
    /// [`Kind::prepare`].
    fn prepare(&self, devices: &[DeviceSpec<'_>], env: &mut OpenEnv<'_>) -> Result<(), DeviceError>;
    /// What `open` would build for `spec` ([`Kind::configure`]), without starting anything:
    /// the place to see that every profile key reaches the device.
    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn fmt::Debug>, DeviceError>;
    /// [`Kind::list_attached`].
    fn list_attached(&self) -> Option<Result<Vec<String>, DeviceError>>;
    /// [`Kind::emulate`], its own options parsed from `args.options` (an unknown one is
    /// refused with the kind's list).
    fn emulate(&self, args: &EmulateArgs) -> Result<(String, Emulation), DeviceError>;
    /// The options `handgate emulate <kind>` takes besides the common ones.
    fn emulate_options(&self) -> &'static [EmulateOption];
    /// [`Kind::served`] for the device `spec` opens (empty when it cannot open: reported
    /// when opening).
    fn served(&self, spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served>;
    /// Opens one device on its backend (the emulator backend included).
    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError>;
    /// What a device of this kind on `side` with no profile keys of its own serves on
    /// backend dds ([`KindFactory::served`]): what another kind's hand answering on its
    /// topics looks like to the doctor.
    fn served_by_default(&self, side: Side) -> Vec<crate::discovery::diagnose::Served>;
}

impl dyn KindFactory {
    /// Whether closure maps to torque on this kind (`closure.tau_open` / `tau_closed`).
    pub fn closure_is_torque(&self) -> bool {
        let side = [Side::Left, Side::Right, Side::Center]
            .into_iter()
            .find(|s| self.check_side(*s).is_ok())
            .unwrap_or_default();
        matches!(
            self.table(side, &*self.default_config()).closure,
            ClosureMap::Torque { .. }
        )
    }

    /// The device table for `side`: the kind's table with the profile's common overrides.
    pub fn table_with(
        &self,
        side: Side,
        config: &dyn KindConfig,
        overrides: &crate::mapping::TableOverrides,
    ) -> Result<DeviceTable, MappingError> {
        self.table(side, config).with_overrides(overrides)
    }
}

/// Options of `handgate emulate <kind>`: the ones every kind takes, and the kind's own as
/// given (`--name [value]`, parsed by the kind: [`EmulateOptions`]).
#[derive(Debug, Clone, Default)]
pub struct EmulateArgs {
    pub side: Option<Side>,
    /// DDS domain and interface of a service emulator.
    pub domain: u32,
    pub interface: Option<String>,
    /// Exact values instead of the kind's measurement noise.
    pub no_noise: bool,
    /// Seed of the measurement noise.
    pub seed: Option<u64>,
    /// A fault to inject (`--fault`, docs/adapters.md "Motion").
    pub fault: Option<crate::emu_common::FaultArg>,
    /// The common options given on the command line (names without `--`), so a kind's
    /// emulator refuses those it has no use for.
    pub common_given: Vec<&'static str>,
    /// The kind's own options, in order: (name without `--`, value).
    pub options: Vec<(String, Option<String>)>,
}

/// The options every kind's emulator takes, as errors list them.
pub const COMMON_EMULATE_OPTIONS: &[&str] = &["side", "domain", "interface", "no-noise", "seed", "fault"];

impl EmulateArgs {
    /// The measurement noise to emulate, given the kind's figures.
    pub fn noise(&self, kind_default: crate::sim::Noise) -> crate::sim::Noise {
        if self.no_noise {
            crate::sim::Noise::OFF
        } else {
            kind_default.with_seed(self.seed.unwrap_or(crate::sim::Noise::DEFAULT_SEED))
        }
    }

    /// Injects `--fault`, if given, into the emulated service `emu` of the `kind` hands
    /// `hands` ([`Self::fault_on`]).
    pub fn inject_fault<C: crate::service_emulator::ServiceCore>(
        &self,
        emu: &crate::service_emulator::ServiceEmulator<C>,
        kind: DeviceKind,
        hands: &[(Side, usize)],
    ) -> Result<(), DeviceError> {
        if let Some(f) = self.fault_on(kind, hands)? {
            emu.inject(f)?;
        }
        Ok(())
    }

    /// `--fault`, if given, for an emulator that carries the `kind` hands `hands` (each a side
    /// and the wire entry its joints start at; one hand: `[(side, 0)]`): a stuck joint is
    /// looked up on each hand's table in turn, so a canonical name is on the first hand and a
    /// URDF name (which names its side) on its own hand.
    pub fn fault_on(&self, kind: DeviceKind, hands: &[(Side, usize)]) -> Result<Option<Fault>, DeviceError> {
        let Some(f) = &self.fault else {
            return Ok(None);
        };
        let mut first = None;
        for &(side, start) in hands {
            match f.resolve(&kind.table(side, &Default::default())?) {
                Ok(Fault::Stuck(entry)) => return Ok(Some(Fault::Stuck(start + entry))),
                Ok(other) => return Ok(Some(other)),
                Err(e) => {
                    first.get_or_insert(e);
                }
            }
        }
        Err(first.map_or_else(
            || DeviceError::Config(format!("a {kind} emulator carries no hand")),
            Into::into,
        ))
    }

    /// The side, or an error naming the kind that needs it.
    pub fn side(&self, kind: &str) -> Result<Side, DeviceError> {
        self.side
            .ok_or_else(|| DeviceError::Config(format!("emulating a {kind} needs --side left|right")))
    }

    /// A node on the emulation's domain.
    pub fn node(&self) -> Result<crate::dds::Node, DeviceError> {
        Ok(crate::dds::Node::new(self.domain, self.interface.as_deref())?)
    }

    /// Splits `--name [value]` words (what follows the common options on the command line)
    /// into options, a word not starting with `--` being the value of the option before it.
    pub fn split_options(words: &[String]) -> Result<Vec<(String, Option<String>)>, String> {
        let mut out: Vec<(String, Option<String>)> = Vec::new();
        for w in words {
            match w.strip_prefix("--") {
                Some(name) => match name.split_once('=') {
                    Some((n, v)) => out.push((n.to_string(), Some(v.to_string()))),
                    None => out.push((name.to_string(), None)),
                },
                None => match out.last_mut() {
                    Some((_, v @ None)) => *v = Some(w.clone()),
                    _ => return Err(format!("unexpected `{w}` (options are `--name value`)")),
                },
            }
        }
        Ok(out)
    }

    /// The kind's own options, parsed: an option it does not take is refused with the list
    /// of those it does; a switch given a value, or an option missing one, likewise.
    pub fn options_for<O: EmulateOptions>(&self, kind: &str) -> Result<O, DeviceError> {
        let refuse = |name: &str| {
            let all: Vec<String> = O::COMMON
                .iter()
                .copied()
                .chain(O::OPTIONS.iter().map(|s| s.name))
                .map(|n| format!("--{n}"))
                .collect();
            let takes = if all.is_empty() {
                "no options".into()
            } else {
                format!("{} only", join_and(&all))
            };
            DeviceError::Config(format!("emulating {} takes {takes}, not --{name}", a(kind)))
        };
        if let Some(c) = self.common_given.iter().find(|c| !O::COMMON.contains(c)) {
            return Err(refuse(c));
        }
        let mut o = O::default();
        for (name, value) in &self.options {
            let Some(spec) = O::OPTIONS.iter().find(|s| s.name == name) else {
                return Err(refuse(name));
            };
            match (spec.value, value) {
                (Some(v), None) => {
                    return Err(DeviceError::Config(format!("--{name} needs a value ({v})")));
                }
                (None, Some(v)) => {
                    return Err(DeviceError::Config(format!("--{name} takes no value, got `{v}`")));
                }
                _ => {}
            }
            o.set(name, value.as_deref())
                .map_err(|e| DeviceError::Config(format!("--{name}: {e}")))?;
        }
        Ok(o)
    }
}

/// `a, b and c`.
fn join_and(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

/// A running `handgate emulate`.
pub enum Emulation {
    /// A server that runs until the process stops.
    Blocking(Box<dyn FnOnce() -> Result<(), DeviceError> + Send>),
    /// Runs in the background until this is dropped.
    Running(Box<dyn Send>),
}

impl fmt::Debug for Emulation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Emulation::Blocking(_) => "Emulation::Blocking",
            Emulation::Running(_) => "Emulation::Running",
        })
    }
}

/// A kind's parsed profile keys, erased (implemented once, for every [`Settings`]).
pub trait KindConfig: Any + fmt::Debug + Send + Sync {
    /// [`Settings::check`].
    fn validate(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem>;
    /// [`Settings::peer_topics`].
    fn dds_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)>;
    /// [`Settings::command_element`].
    fn dds_command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize>;
    /// [`Settings::summary`].
    fn describe(&self, ctx: &DeviceCtx<'_>) -> String;
    /// [`Settings::serial_ports`].
    fn ports(&self) -> Vec<std::path::PathBuf>;
    fn as_any(&self) -> &dyn Any;
    fn clone_box(&self) -> Box<dyn KindConfig>;
    fn eq_dyn(&self, other: &dyn KindConfig) -> bool;
}

impl<T: Settings> KindConfig for T {
    fn validate(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        self.check(ctx)
    }
    fn dds_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        self.peer_topics(ctx)
    }
    fn dds_command_element(&self, ctx: &DeviceCtx<'_>) -> Option<usize> {
        self.command_element(ctx)
    }
    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        self.summary(ctx)
    }
    fn ports(&self) -> Vec<std::path::PathBuf> {
        self.serial_ports()
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn clone_box(&self) -> Box<dyn KindConfig> {
        Box::new(self.clone())
    }
    fn eq_dyn(&self, other: &dyn KindConfig) -> bool {
        other.as_any().downcast_ref::<T>().is_some_and(|o| o == self)
    }
}

/// A boxed [`KindConfig`] that is `Clone`, `PartialEq` and `Debug`.
#[derive(Debug)]
pub struct KindConfigBox(pub Box<dyn KindConfig>);

impl KindConfigBox {
    /// The config as its concrete type (for tests that look at what a profile parsed to).
    pub fn get<T: KindConfig>(&self) -> Option<&T> {
        self.0.as_any().downcast_ref::<T>()
    }
}

impl std::ops::Deref for KindConfigBox {
    type Target = dyn KindConfig;
    fn deref(&self) -> &Self::Target {
        &*self.0
    }
}

impl Clone for KindConfigBox {
    fn clone(&self) -> Self {
        KindConfigBox(self.0.clone_box())
    }
}

impl PartialEq for KindConfigBox {
    fn eq(&self, other: &Self) -> bool {
        self.0.eq_dyn(&*other.0)
    }
}

/// The topic overrides of a `[devices.dds]` section declared with
/// [`dds_client_keys!`](crate::dds_client_keys).
pub trait DdsTopicKeys {
    /// Problems with the topic overrides (keys `dds.cmd_topic`, `dds.state_topic`).
    fn topic_problems(&self) -> Vec<Problem>;
    /// (command, state) topics: each override, else the standard pair's.
    fn topics_or(&self, standard: Option<(String, String)>) -> (Option<String>, Option<String>);
}

/// Declares the `[devices.dds]` section of a client of a DDS service: `cmd_topic` and
/// `state_topic` (overrides of the service's topics, checked by `topic_problems`, defaulted
/// by `topics_or`), then the kind's own optional keys as written. Every field is optional and
/// unknown keys are refused (the profile's errors name file and key, and list the keys in this
/// order).
#[macro_export]
macro_rules! dds_client_keys {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $f:ident : $t:ty,)* }) => {
        $(#[$m])*
        #[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $name {
            /// Overrides the service's command topic.
            #[serde(skip_serializing_if = "Option::is_none")]
            pub cmd_topic: Option<String>,
            /// Overrides the service's state topic.
            #[serde(skip_serializing_if = "Option::is_none")]
            pub state_topic: Option<String>,
            $($(#[$fm])* #[serde(skip_serializing_if = "Option::is_none")] pub $f: Option<$t>,)*
        }

        impl $crate::kind::DdsTopicKeys for $name {
            fn topic_problems(&self) -> Vec<$crate::kind::Problem> {
                $crate::kind::check_topics(
                    "dds",
                    &[("cmd_topic", self.cmd_topic.as_deref()), ("state_topic", self.state_topic.as_deref())],
                )
            }

            fn topics_or(&self, standard: Option<(String, String)>) -> (Option<String>, Option<String>) {
                $crate::kind::override_topics(self.cmd_topic.as_ref(), self.state_topic.as_ref(), standard)
            }
        }
    };
}

/// A client of a DDS service on backend dds with side center has no standard topics: the
/// problem (key `side`) when `topics` (overrides, else the standard pair) lack either.
pub fn center_needs_topics(
    kind: &str,
    ctx: &DeviceCtx<'_>,
    topics: (Option<String>, Option<String>),
) -> Option<Problem> {
    let missing = topics.0.is_none() || topics.1.is_none();
    (ctx.backend == Backend::Dds && ctx.side == Side::Center && missing).then(|| {
        Problem::new(
            &["side"],
            format!(
                "{} on backend dds with side center needs dds.cmd_topic and dds.state_topic",
                a(kind)
            ),
        )
    })
}

/// `cmd_topic` / `state_topic` of a DDS-client device's section: problems with either
/// (keys `[section, "cmd_topic"]` ...), the one rule every kind with these overrides has.
pub fn check_topics(section: &str, topics: &[(&str, Option<&str>)]) -> Vec<Problem> {
    topics
        .iter()
        .filter_map(|(key, t)| match t.map(check_topic) {
            Some(Err(e)) => Some(Problem::new(&[section, key], e)),
            _ => None,
        })
        .collect()
}

/// (command, state) topics of a DDS-client device: each override, else the standard pair's
/// (`None` where there is no standard pair, e.g. side center).
pub fn override_topics(
    cmd: Option<&String>,
    state: Option<&String>,
    standard: Option<(String, String)>,
) -> (Option<String>, Option<String>) {
    let (c, s) = standard.map_or((None, None), |(c, s)| (Some(c), Some(s)));
    (cmd.cloned().or(c), state.cloned().or(s))
}

/// `"a dex3"`, `"an ezgripper"`.
pub fn a(word: &str) -> String {
    let article = if word.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {word}")
}

/// `Err(message)` unless `s` is a topic name: non-empty, no whitespace, no leading or
/// trailing `/`.
pub fn check_topic(s: &str) -> Result<(), String> {
    if s.is_empty() || s.chars().any(char::is_whitespace) || s.starts_with('/') || s.ends_with('/') {
        Err(format!(
            "`{s}` is not a topic name (non-empty, no spaces, no leading or trailing `/`)"
        ))
    } else {
        Ok(())
    }
}

/// `Err(message)` unless `r` is a rate above 0 and at most `max` Hz.
pub fn check_rate(r: f64, max: f64) -> Result<(), String> {
    if r.is_finite() && r > 0.0 && r <= max {
        Ok(())
    } else {
        Err(format!("must be a rate above 0 and at most {max} Hz, got {r}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stuck joint on an emulator of two hands (DFX_inspire_service's pair, right at 0,
    /// left at 6): a canonical name on the first hand given, a URDF name on its own hand.
    #[test]
    fn a_stuck_joint_is_found_on_the_hand_that_names_it() {
        let hands = [(Side::Left, 6), (Side::Right, 0)];
        let args = |f: &str| EmulateArgs {
            fault: Some(f.parse().unwrap()),
            ..Default::default()
        };
        let kind = DeviceKind::InspireDfx;
        let index = 3; // the table's wire index of `index`
        assert_eq!(
            args("stuck=index").fault_on(kind, &hands).unwrap(),
            Some(Fault::Stuck(6 + index))
        );
        assert_eq!(
            args("stuck=R_index_proximal_joint").fault_on(kind, &hands).unwrap(),
            Some(Fault::Stuck(index))
        );
        assert_eq!(args("frozen").fault_on(kind, &hands).unwrap(), Some(Fault::Frozen));
        let e = args("stuck=wrist").fault_on(kind, &hands).unwrap_err().to_string();
        assert!(e.contains("no such joint") && e.contains("pinky"), "{e}");
        assert_eq!(EmulateArgs::default().fault_on(kind, &hands).unwrap(), None);
    }
}
