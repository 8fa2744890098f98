//! A `[[fronts]]` table as the profile holds it: the keys every front has ([`FrontConfig`]),
//! its kind's own keys (a typed struct in the kind's module, parsed by the kind and held
//! erased in [`FrontOwn`]), the topics a kind serves ([`TopicKey`]) and what silence from a
//! client means.

use std::fmt;

use figment::value::{Dict, Value};
use serde::{Deserialize, Serialize};

use super::kind::{FrontKind, FrontOwn};
use crate::kind::{a, ConfigError, ConfigValue, Problem};
use crate::model::Side;
use crate::units::{DeviceName, Millis, RateHz, Topic};

/// What a front does when its client goes silent (docs/fronts.md, "Silence").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Silence {
    /// What the served interface's real service does (each front kind says:
    /// `FrontFactory::silence`); handgate's canonical interface is the strict watchdog below.
    #[default]
    Service,
    /// After the bound device's `watchdog.timeout_ms`, its `watchdog.safe_action`.
    Watchdog,
}

impl Silence {
    /// Every value, in declaration order.
    pub const ALL: &'static [Silence] = &[Silence::Service, Silence::Watchdog];
    /// The spelling used in profile files.
    pub fn as_str(self) -> &'static str {
        match self {
            Silence::Service => "service",
            Silence::Watchdog => "watchdog",
        }
    }
}

impl fmt::Display for Silence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Who may command a front (docs/fronts.md, "One commanding client per front").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Control {
    /// One writer at a time: the first writer whose command is accepted owns the front until
    /// it has been silent for the front's hold time; other writers' samples are refused.
    #[default]
    Exclusive,
    /// Every writer's commands are taken, the latest wins.
    Shared,
}

impl Control {
    /// Every value, in declaration order.
    pub const ALL: &'static [Control] = &[Control::Exclusive, Control::Shared];
    /// The spelling used in profile files.
    pub fn as_str(self) -> &'static str {
        match self {
            Control::Exclusive => "exclusive",
            Control::Shared => "shared",
        }
    }
}

impl fmt::Display for Control {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The grippers of an `actuator` Dex1 front, by message element (0 = right, 1 = left).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ElementDevices {
    /// Element 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub right: Option<DeviceName>,
    /// Element 1.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left: Option<DeviceName>,
}

/// A front's `devices`: the grippers of a message carrying several, by element
/// (`{ right = "..", left = ".." }`), or the list of devices a state-only front publishes or a
/// front binding a list drives (`["a", "b"]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum FrontDevices {
    Elements(ElementDevices),
    List(Vec<DeviceName>),
}

impl FrontDevices {
    /// The by-element form, if this is it.
    pub fn elements(&self) -> Option<&ElementDevices> {
        match self {
            FrontDevices::Elements(e) => Some(e),
            FrontDevices::List(_) => None,
        }
    }

    /// The list form, if this is it.
    pub fn list(&self) -> Option<&[DeviceName]> {
        match self {
            FrontDevices::List(l) => Some(l),
            FrontDevices::Elements(_) => None,
        }
    }
}

impl<'de> Deserialize<'de> for FrontDevices {
    /// A table is the by-element form, an array the list form; each is parsed by its own type,
    /// so its errors (an unknown element, a bad name) keep their key path.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = FrontDevices;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a table of elements (`{ right = \"..\", left = \"..\" }`) or a list of device names")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, m: A) -> Result<Self::Value, A::Error> {
                ElementDevices::deserialize(serde::de::value::MapAccessDeserializer::new(m)).map(FrontDevices::Elements)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, s: A) -> Result<Self::Value, A::Error> {
                Vec::<DeviceName>::deserialize(serde::de::value::SeqAccessDeserializer::new(s)).map(FrontDevices::List)
            }
        }
        d.deserialize_any(V)
    }
}

impl ElementDevices {
    /// (side, device) for every bound element, in element order.
    pub fn bound(&self) -> Vec<(Side, &DeviceName)> {
        [(Side::Right, &self.right), (Side::Left, &self.left)]
            .into_iter()
            .filter_map(|(s, d)| d.as_ref().map(|d| (s, d)))
            .collect()
    }
}

/// One front: an interface handgate serves to clients, bound to a device. The keys every
/// front has are fields here; the kind's own (its topics, `side`, a wire variant...) are its
/// typed config in [`FrontConfig::own`], which also says the kind.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrontConfig {
    /// The front's kind and its own keys (default: a canonical front's defaults).
    pub own: FrontOwn,
    /// Name used in logs (`[a-z0-9_-]+`, unique among fronts); default derived from the kind
    /// and what it serves (`handgate_gateway`'s `display_name`).
    pub name: Option<String>,
    /// The device this front drives. Required, except for a state-only front (`joint_state`),
    /// which publishes every device unless `device` or `devices` names them, a front binding a
    /// list (`joint_state_command`, `FrontFacts::binds_list`), which drives every device unless
    /// they are named the same way, and a front bound by element with `devices`.
    pub device: Option<DeviceName>,
    /// Fronts bound by element (`actuator` dex1, inspire_dfx): the device of each element,
    /// `{ right = "..", left = ".." }`; an element left out is not driven and reports no
    /// measurement. State-only fronts: the devices published, `["..", ".."]`; fronts binding a
    /// list: the devices driven, `["..", ".."]`.
    pub devices: Option<FrontDevices>,
    /// Rate of the state topic (default: the kind's, `FrontFactory::default_state_hz`).
    pub state_hz: Option<RateHz>,
    /// What silence from the client means (default `service`).
    pub silence: Silence,
    /// Whether one writer at a time commands the front (default `exclusive`).
    pub control: Control,
    /// `silence = "watchdog"`: a per-front timeout, shorter than the device's
    /// `watchdog.timeout_ms` (the smaller of the two applies); default: the device's.
    pub watchdog_ms: Option<Millis>,
    /// Commands older than this on arrival (this host's clock against the source timestamp
    /// their writer's clock put on them) are dropped and counted `late`; default none: it
    /// needs the clocks synchronised (docs/fronts.md, "Commands in order").
    pub max_command_age_ms: Option<Millis>,
    /// Keys of this table that another front kind takes (found while parsing; validation
    /// reports them with the other semantic errors, naming the kinds that take them).
    pub misplaced: Vec<Problem>,
}

/// The keys every `[[fronts]]` table may have, as deserialized (the rest are the kind's).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Common {
    kind: FrontKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    device: Option<DeviceName>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    devices: Option<FrontDevices>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    state_hz: Option<RateHz>,
    #[serde(default)]
    silence: Silence,
    #[serde(default)]
    control: Control,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    watchdog_ms: Option<Millis>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_command_age_ms: Option<Millis>,
}

/// The keys every `[[fronts]]` table may have, in the order errors list them.
pub fn common_keys() -> &'static [&'static str] {
    fields_of::<Common>()
}

impl FrontConfig {
    /// A front of `kind` with its defaults and no device.
    pub fn new(kind: FrontKind) -> Self {
        FrontConfig {
            own: FrontOwn::of(kind),
            ..Default::default()
        }
    }

    /// The front's kind.
    pub fn kind(&self) -> FrontKind {
        self.own.kind()
    }

    /// Parses one `[[fronts]]` table: the keys every front has here, the rest by the front's
    /// kind ([`super::kind::FrontFactory::parse`]). Errors keep figment's path (relative to the
    /// table). A key another front kind takes is not an error here: it is kept in
    /// [`FrontConfig::misplaced`]; a key no front kind takes is, listing the keys this one
    /// takes.
    pub fn from_value(v: &ConfigValue) -> Result<Self, ConfigError> {
        let dict: Dict = v.deserialize().map_err(Box::new)?;
        let common = common_keys();
        let (c, mut rest): (Dict, Dict) = dict.into_iter().partition(|(k, _)| common.contains(&k.as_str()));
        let c: Common = Value::from(c).deserialize().map_err(Box::new)?;
        let kind = c.kind;
        let mut misplaced = Vec::new();
        let own = loop {
            let e = match kind.factory().parse(&Value::from(rest.clone())) {
                Ok(own) => break own,
                Err(e) => e,
            };
            let figment::error::Kind::UnknownField(field, _) = &e.kind else {
                return Err(e);
            };
            let owners: Vec<&str> = FrontKind::all()
                .iter()
                .filter(|k| k.factory().keys().contains(&field.as_str()))
                .map(|k| k.as_str())
                .collect();
            if owners.is_empty() || rest.remove(field).is_none() {
                let keys: Vec<&str> = common.iter().chain(kind.factory().keys()).copied().collect();
                return Err(Box::new(
                    figment::Error::from(format!("unknown key (expected one of: {})", keys.join(", ")))
                        .with_path(field),
                ));
            }
            misplaced.push(Problem::new(
                &[field],
                format!(
                    "only {} fronts take `{field}`, this is {} front",
                    and_list(&owners),
                    a(kind.as_str())
                ),
            ));
        };
        Ok(FrontConfig {
            own,
            name: c.name,
            device: c.device,
            devices: c.devices,
            state_hz: c.state_hz,
            silence: c.silence,
            control: c.control,
            watchdog_ms: c.watchdog_ms,
            max_command_age_ms: c.max_command_age_ms,
            misplaced,
        })
    }

    /// The front's table as a profile writes it (what [`FrontConfig::from_value`] reads back).
    pub fn to_value(&self) -> Result<ConfigValue, ConfigError> {
        let common = Common {
            kind: self.kind(),
            name: self.name.clone(),
            device: self.device.clone(),
            devices: self.devices.clone(),
            state_hz: self.state_hz,
            silence: self.silence,
            control: self.control,
            watchdog_ms: self.watchdog_ms,
            max_command_age_ms: self.max_command_age_ms,
        };
        let mut dict: Dict = Value::serialize(&common)
            .map_err(Box::new)?
            .deserialize()
            .map_err(Box::new)?;
        let own: Dict = self.own.to_value()?.deserialize().map_err(Box::new)?;
        dict.extend(own);
        // A key left unset (`None`) is left out, as a profile leaves it out.
        dict.retain(|_, v| !matches!(v, Value::Empty(..)));
        Ok(Value::from(dict))
    }
}

impl Serialize for FrontConfig {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_value().map_err(serde::ser::Error::custom)?.serialize(s)
    }
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(words: &[&str]) -> String {
    match words {
        [] => String::new(),
        [one] => (*one).to_string(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

/// The field names of struct `T` as its `Deserialize` implementation knows them (serde
/// passes them to `deserialize_struct`): the keys of a kind's config, with no second list to
/// keep in step.
pub(crate) fn fields_of<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    struct Fields(&'static [&'static str]);
    impl<'de> serde::Deserializer<'de> for &mut Fields {
        type Error = serde::de::value::Error;
        fn deserialize_any<V: serde::de::Visitor<'de>>(self, _v: V) -> Result<V::Value, Self::Error> {
            Err(serde::de::Error::custom("not a struct"))
        }
        fn deserialize_struct<V: serde::de::Visitor<'de>>(
            self,
            _name: &'static str,
            fields: &'static [&'static str],
            _v: V,
        ) -> Result<V::Value, Self::Error> {
            self.0 = fields;
            Err(serde::de::Error::custom("fields read"))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
            option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
            ignored_any
        }
    }
    let mut f = Fields(&[]);
    let _ = T::deserialize(&mut f);
    f.0
}

/// What a front does on one of its topics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopicRole {
    /// Takes commands there (its reader).
    Command,
    /// Publishes its state there, at the front's state rate.
    State,
    /// Publishes a low-frequency copy of its state there, at its kind's own rate (the Dex3
    /// service's `rt/lf/dex3/{side}/state`).
    LowFrequencyState,
    /// Publishes a message of its own beside the state, in the same tick (Inspire FTP's
    /// touch); `handgate check` leaves it to the kind's description.
    Beside,
}

impl TopicRole {
    /// The front writes this topic (every role but [`TopicRole::Command`]).
    pub fn writes(self) -> bool {
        self != TopicRole::Command
    }
}

/// Where a front's default topics are derived from.
#[derive(Debug, Clone, Copy)]
pub struct TopicAt<'a> {
    /// The served side, left or right; `None`: center, or no device.
    pub side: Option<Side>,
    /// The bound device's name (`all`: a state-only front over every device).
    pub device: &'a str,
}

/// One topic a front kind serves: the profile key that sets it (a field of the kind's
/// config), what the front does there, and its default. A kind lists its topics in its
/// `Front::TOPICS`, in the order `handgate check` and discovery show them.
pub struct TopicKey<C> {
    pub key: &'static str,
    pub role: TopicRole,
    /// The topic the profile sets, if it does.
    pub set: fn(&C) -> Option<&Topic>,
    /// The default; `None` where it cannot be derived (a per-side topic of a device of side
    /// center: the kind's validation says what to set).
    pub default: fn(&C, &TopicAt<'_>) -> Option<Topic>,
}

impl<C> TopicKey<C> {
    /// The command topic, set by `cmd_topic`.
    pub const fn cmd_topic(set: fn(&C) -> Option<&Topic>, default: fn(&C, &TopicAt<'_>) -> Option<Topic>) -> Self {
        TopicKey {
            key: "cmd_topic",
            role: TopicRole::Command,
            set,
            default,
        }
    }

    /// The state topic, set by `state_topic`.
    pub const fn state_topic(set: fn(&C) -> Option<&Topic>, default: fn(&C, &TopicAt<'_>) -> Option<Topic>) -> Self {
        TopicKey {
            key: "state_topic",
            role: TopicRole::State,
            set,
            default,
        }
    }

    /// The topic of config `c` at `at`: the profile's, else the default.
    pub fn resolve(&self, c: &C, at: &TopicAt<'_>) -> FrontTopic {
        let set = (self.set)(c);
        FrontTopic {
            key: self.key,
            role: self.role,
            topic: set.cloned().or_else(|| (self.default)(c, at)),
            set: set.is_some(),
        }
    }
}

/// Defines a front kind's config struct (its own keys, `#[serde(deny_unknown_fields,
/// default)]`) that starts with the keys of a front serving a command and a state topic per
/// side: `side`, `cmd_topic`, `state_topic`; then the kind's other keys.
#[macro_export]
macro_rules! side_topics_config {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $f:ident: $t:ty,)* }) => {
        $(#[$m])*
        #[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $name {
            /// The side served (default: the bound device's).
            pub side: Option<$crate::model::Side>,
            pub cmd_topic: Option<$crate::units::Topic>,
            pub state_topic: Option<$crate::units::Topic>,
            $($(#[$fm])* pub $f: $t,)*
        }

        impl $crate::front::config::ServedSide for $name {
            fn side(&self) -> Option<$crate::model::Side> {
                self.side
            }
        }
    };
}

/// The topic side a front's config says to serve (its `side` key), for the kinds that have
/// one ([`side_topics_config!`](crate::side_topics_config)); `None`: the bound device's.
pub trait ServedSide {
    fn side(&self) -> Option<Side> {
        None
    }
}

side_topics_config! {
    /// The keys of a front serving one command and one state topic per side, the served side
    /// picking the defaults (BrainCo's and Inspire DFX's fronts): `side` and both topics.
    pub struct SideTopics {}
}

/// The side rule of the fronts serving `rt/.../{left,right}/...` (`kind`'s): a device of
/// side center is served on a side given explicitly, unless every topic is overridden
/// (`topics_given`); a front addressing elements 0 = right, 1 = left (`actuator`) always
/// needs a side.
pub fn side_rule(kind: &str, served: Option<Side>, topics_given: bool, actuator: bool) -> Vec<(&'static str, String)> {
    if served != Some(Side::Center) || (!actuator && topics_given) {
        return vec![];
    }
    let why = if actuator {
        "the actuator variant addresses element 0 = right, 1 = left"
    } else {
        "its topics are rt/.../{left,right}/...; set the topics explicitly to serve another"
    };
    vec![(
        "side",
        format!("a {kind} front serves side left or right ({why}); set `side` (the device's side is center)"),
    )]
}

/// One of a front's topics after defaults are applied.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontTopic {
    /// The profile key that sets it (errors about it name this key).
    pub key: &'static str,
    pub role: TopicRole,
    /// `None`: the default cannot be derived (reported by validation).
    pub topic: Option<Topic>,
    /// The profile sets it.
    pub set: bool,
}

/// A front's topics and rates after defaults are applied.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontTopics {
    /// Every topic the front serves, in its kind's order.
    pub topics: Vec<FrontTopic>,
    pub state_hz: RateHz,
    /// Rate of the low-frequency state copy, where the kind has one.
    pub lf_state_hz: Option<RateHz>,
}

impl FrontTopics {
    /// The first topic of `role`.
    pub fn first(&self, role: TopicRole) -> Option<&Topic> {
        self.topics
            .iter()
            .find(|t| t.role == role)
            .and_then(|t| t.topic.as_ref())
    }

    /// The command topic (`None` for a state-only front).
    pub fn cmd(&self) -> Option<&Topic> {
        self.first(TopicRole::Command)
    }

    /// The state topic.
    pub fn state(&self) -> Option<&Topic> {
        self.first(TopicRole::State)
    }

    /// The low-frequency state copy's topic, where the kind has one.
    pub fn lf_state(&self) -> Option<&Topic> {
        self.first(TopicRole::LowFrequencyState)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(toml: &str) -> ConfigValue {
        use figment::providers::{Format, Toml};
        figment::Figment::from(Toml::string(toml)).extract().unwrap()
    }

    #[test]
    fn the_keys_are_the_structs_fields() {
        assert_eq!(
            common_keys(),
            [
                "kind",
                "name",
                "device",
                "devices",
                "state_hz",
                "silence",
                "control",
                "watchdog_ms",
                "max_command_age_ms"
            ]
        );
        assert_eq!(fields_of::<SideTopics>(), ["side", "cmd_topic", "state_topic"]);
        assert_eq!(fields_of::<Side>(), [] as [&str; 0], "not a struct");
    }

    #[test]
    fn a_key_of_another_kind_is_kept_as_misplaced_and_an_unknown_one_refused() {
        let f = FrontConfig::from_value(&table("kind = \"canonical\"\nside = \"left\"\nvariant = \"hg\"")).unwrap();
        assert_eq!(f.kind(), FrontKind::Canonical);
        let got: Vec<(Vec<String>, &str)> = f
            .misplaced
            .iter()
            .map(|p| (p.key.clone(), p.message.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (
                    vec!["side".to_string()],
                    "only dex3, dex1, inspire_dfx, brainco, inspire_ftp and dex5 fronts take `side`, this is a canonical front"
                ),
                (vec!["variant".to_string()], "only dex1 fronts take `variant`, this is a canonical front")
            ]
        );
        // Without the misplaced keys, what the canonical kind makes of the rest.
        assert_eq!(f.own, FrontOwn::of(FrontKind::Canonical));

        let e = FrontConfig::from_value(&table("kind = \"dex3\"\nlf_topic = \"x\"")).unwrap_err();
        assert_eq!(e.path, ["lf_topic"]);
        assert!(
            e.to_string()
                .contains("cmd_topic, state_topic, lf_state_topic, lf_state_hz"),
            "{e}"
        );
        // A bad value of the kind's own key keeps its path.
        let e = FrontConfig::from_value(&table("kind = \"dex3\"\nlf_state_hz = \"fast\"")).unwrap_err();
        assert_eq!(e.path, ["lf_state_hz"]);
    }

    #[test]
    fn and_lists_read_as_prose() {
        assert_eq!(and_list(&["a"]), "a");
        assert_eq!(and_list(&["a", "b"]), "a and b");
        assert_eq!(and_list(&["a", "b", "c"]), "a, b and c");
    }
}
