//! A `[[fronts]]` table as the profile holds it, and what silence from a client means: the
//! keys every front has and those only some front kinds take (each kind says which:
//! `FrontFactory::keys`, the others are refused with a message generated from the registry).

use std::fmt;

use serde::{Deserialize, Serialize};

use super::kind::FrontKind;
use crate::dex1::adapter::Variant as Dex1Variant;
use crate::model::Side;
use crate::units::{DeviceName, Millis, RateHz, Topic};

/// Profile keys of a `[[fronts]]` table that only some front kinds take.
pub const KIND_KEYS: &[&str] = &[
    "side",
    "lf_state_topic",
    "lf_state_hz",
    "variant",
    "topic",
    "urdf_names",
];

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
/// (`{ right = "..", left = ".." }`), or the list of devices a state-only front publishes
/// (`["a", "b"]`).
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

/// One front: an interface handgate serves to clients, bound to a device.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontConfig {
    pub kind: FrontKind,
    /// Name used in logs (`[a-z0-9_-]+`, unique among fronts); default derived from the kind
    /// and what it serves ([`FrontConfig::display_name`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The device this front drives. Required, except for a state-only front (`joint_state`),
    /// which publishes every device unless `device` or `devices` names them, and for a front
    /// bound by element with `devices`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<DeviceName>,
    /// Fronts bound by element (`actuator` dex1, inspire_dfx): the device of each element,
    /// `{ right = "..", left = ".." }`; an element left out is not driven and reports no
    /// measurement. State-only fronts: the devices published, `["..", ".."]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub devices: Option<FrontDevices>,
    /// dex3/dex1 fronts: which topic side to serve (default: the device's side).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<Side>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<Topic>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<Topic>,
    /// dex3 fronts: the low-frequency state copy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_state_topic: Option<Topic>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_hz: Option<RateHz>,
    /// dex3 fronts: rate of the low-frequency copy (default 50).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lf_state_hz: Option<RateHz>,
    /// dex1 fronts: wire variant (default `auto`: follows its clients, `crate::dex1::follow`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<Dex1Variant>,
    /// What silence from the client means (default `service`).
    #[serde(default)]
    pub silence: Silence,
    /// Whether one writer at a time commands the front (default `exclusive`).
    #[serde(default)]
    pub control: Control,
    /// `silence = "watchdog"`: a per-front timeout, shorter than the device's
    /// `watchdog.timeout_ms` (the smaller of the two applies); default: the device's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub watchdog_ms: Option<Millis>,
    /// joint_state fronts: topic (default `rt/joint_states`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic: Option<Topic>,
    /// joint_state fronts: name joints as in the URDF (default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub urdf_names: Option<bool>,
}

impl Default for FrontConfig {
    /// A canonical front with no device (a profile must name one).
    fn default() -> Self {
        FrontConfig {
            kind: FrontKind::default(),
            name: None,
            device: None,
            devices: None,
            side: None,
            cmd_topic: None,
            state_topic: None,
            lf_state_topic: None,
            state_hz: None,
            lf_state_hz: None,
            variant: None,
            silence: Silence::default(),
            control: Control::default(),
            watchdog_ms: None,
            topic: None,
            urdf_names: None,
        }
    }
}

/// A front's topics and rates after defaults are applied.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontTopics {
    /// Topic the front takes commands on (`None` for joint_state).
    pub cmd: Option<Topic>,
    /// Topic the front publishes state on.
    pub state: Option<Topic>,
    /// dex3: the low-frequency state copy.
    pub lf_state: Option<Topic>,
    pub state_hz: RateHz,
    pub lf_state_hz: Option<RateHz>,
}
