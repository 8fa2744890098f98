//! A Dex5-1's own profile keys and their rules: `[devices.dds]` (backend dds: overrides of
//! the service's topics) and `[devices.dex5]` (backends dds and emulator: the conventions
//! where the sources disagree or are silent, [`Conventions`], docs/profiles.md
//! "Assumptions").

use serde::{Deserialize, Serialize};

use super::table::{Conventions, WireConfig};
use crate::kind::{DdsTopicKeys, DeviceCtx, Problem, Settings};
use crate::model::Side;
use crate::service_client::ClientTopics;

crate::dds_client_keys! {
    /// `[devices.dds]` of a Dex5: topic overrides.
    pub struct DdsConfig {}
}

/// A Dex5's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Dex5Profile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
    /// `gains`, `urdf_names`, `command_layout`, `coupling`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dex5: Option<Conventions>,
}

impl Dex5Profile {
    /// `[devices.dex5]`, each key absent taking its default.
    pub fn conventions(&self) -> Conventions {
        self.dex5.unwrap_or_default()
    }

    /// What the codec (and the emulated service) take from the conventions.
    pub fn wire(&self) -> WireConfig {
        WireConfig::of(&self.conventions())
    }
}

impl ClientTopics for Dex5Profile {
    fn topics(&self, side: Side) -> (Option<String>, Option<String>) {
        self.dds.clone().unwrap_or_default().topics_or(super::topics(side))
    }
}

impl Settings for Dex5Profile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = self.dds.as_ref().map(DdsConfig::topic_problems).unwrap_or_default();
        if let Some(Err(e)) = self.dex5.map(|c| c.validate()) {
            out.push(Problem::new(&["dex5", "coupling"], e));
        }
        out
    }

    fn peer_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(self.topics(ctx.side))
    }

    /// The conventions in force, since each is an assumption.
    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        let c = self.conventions();
        format!(
            " (gains {}, {} command entries, URDF names {}, coupling {:.3})",
            c.gains.as_str(),
            c.command_layout.entries(),
            c.urdf_names.as_str(),
            c.coupling
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Backend;
    use crate::dex5::table::{CommandLayout, GainSource, UrdfNames, COUPLING};

    const LEFT: DeviceCtx<'static> = DeviceCtx {
        name: "d",
        side: Side::Left,
        backend: Backend::Dds,
    };

    fn parse(toml: &str) -> Result<Dex5Profile, String> {
        use figment::providers::{Format, Toml};
        let v: figment::value::Value = figment::Figment::from(Toml::string(toml))
            .extract()
            .map_err(|e| e.to_string())?;
        v.deserialize().map_err(|e| e.to_string())
    }

    fn problems(toml: &str) -> Vec<(String, String)> {
        parse(toml)
            .unwrap()
            .check(&LEFT)
            .into_iter()
            .map(|p| (p.key.join("."), p.message))
            .collect()
    }

    #[test]
    fn no_keys_are_the_defaults_the_sides_topics_and_no_problem() {
        let p = parse("").unwrap();
        assert_eq!(p.conventions(), Conventions::default());
        assert_eq!(p.wire(), WireConfig::default());
        assert_eq!(
            p.topics(Side::Right),
            (Some("rt/dex5/right/cmd".into()), Some("rt/dex5/right/state".into()))
        );
        assert_eq!(p.peer_topics(&LEFT), Some(p.topics(Side::Left)));
        assert!(p.check(&LEFT).is_empty());
        assert_eq!(
            p.summary(&LEFT),
            format!(" (gains xr_teleoperate, 20 command entries, URDF names unitree_ros, coupling {COUPLING:.3})")
        );
    }

    #[test]
    fn every_key_reaches_the_conventions_and_the_topics() {
        let p = parse(
            "[dds]\ncmd_topic = \"x/cmd\"\n[dex5]\ngains = \"unitree_dds_wrapper\"\nurdf_names = \"xr_teleoperate\"\ncommand_layout = \"motors\"\ncoupling = 1.0\n",
        )
        .unwrap();
        let c = p.conventions();
        assert_eq!(
            (c.gains, c.urdf_names, c.command_layout, c.coupling),
            (
                GainSource::UnitreeDdsWrapper,
                UrdfNames::XrTeleoperate,
                CommandLayout::Motors,
                1.0
            )
        );
        assert_eq!(p.wire().layout, CommandLayout::Motors);
        assert_eq!(
            p.topics(Side::Left),
            (Some("x/cmd".into()), Some("rt/dex5/left/state".into()))
        );
        assert!(p.check(&LEFT).is_empty());
        assert_eq!(
            p.summary(&LEFT),
            " (gains unitree_dds_wrapper, 16 command entries, URDF names xr_teleoperate, coupling 1.000)"
        );
    }

    #[test]
    fn bad_values_are_problems_on_their_keys_and_unknown_keys_are_refused() {
        for k in ["0.0", "-1.0", "2.5", "nan"] {
            let p = problems(&format!("[dex5]\ncoupling = {k}\n"));
            assert_eq!(p.len(), 1, "{k}: {p:?}");
            assert_eq!(p[0].0, "dex5.coupling");
            assert!(p[0].1.starts_with("must be above 0 and at most 2"), "{}", p[0].1);
        }
        assert!(problems("[dex5]\ncoupling = 2.0\n").is_empty());
        let p = problems("[dds]\ncmd_topic = \"/x\"\nstate_topic = \"a b\"\n");
        let keys: Vec<&str> = p.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(keys, ["dds.cmd_topic", "dds.state_topic"]);
        for bad in [
            "[dex5]\ngain = \"xr_teleoperate\"\n",
            "[dex5]\ngains = \"mine\"\n",
            "[dex5]\ncommand_layout = \"motor\"\n",
            "[dds]\nspeed = 1.0\n",
            "[usb]\nserial = \"x\"\n",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }
}
