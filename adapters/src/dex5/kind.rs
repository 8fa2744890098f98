//! The Dex5-1 as a registered device kind: a client of the robot's Dex5 hand service over
//! DDS, or on the emulator backend of the emulated service on private topics, through the very
//! same codec ([`ServiceHand`]).

use super::adapter::Dex5Codec;
use super::config::Dex5Profile;
use super::emulator::{Dex5Core, Dex5EmuConfig, DEX5_NOISE};
use super::table::{self, Conventions, WireConfig};
use super::{JOINTS, SERVICE_HZ};
use crate::device::Backend;
use crate::front::kind::FrontKind;
use crate::kind::{DeviceCtx, DeviceKind, EmulateOption, EmulateOptions, KindFacts, Problem, SectionSpec};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::EmulatorSection;
use crate::service_client::ServiceHand;
use crate::sim::Noise;

impl DeviceKind {
    /// Unitree Dex5-1 hand, 20 joints (through the robot's hand service over DDS).
    #[allow(non_upper_case_globals)]
    pub const Dex5: DeviceKind = DeviceKind::of(&Dex5Kind);
}

/// The Dex5-1.
#[derive(Debug, Clone, Copy)]
pub struct Dex5Kind;

impl ServiceHand for Dex5Kind {
    /// The service's loop (an assumption, docs/profiles.md); its own interface
    /// `rt/dex5/{side}/*`; `[devices.dex5]`: the conventions, on both backends.
    const FACTS: KindFacts = KindFacts {
        sections: &[
            SectionSpec {
                key: "dds",
                backends: &[Backend::Dds],
            },
            SectionSpec {
                key: "dex5",
                backends: &[Backend::Dds, Backend::Emulator],
            },
        ],
        closure_postures_configurable: true,
        ..KindFacts::hand_service("dex5", &JOINTS, SERVICE_HZ, &[FrontKind::Dex5])
    };
    const SERVICE: &'static str = "the Dex5-1 hand service";
    const NOISE: Noise = DEX5_NOISE;
    type Config = Dex5Profile;
    /// The gains, command layout and coupling.
    type Wire = WireConfig;
    type Codec = Dex5Codec;
    type Emulate = Dex5Emulate;
    type Core = Dex5Core;

    fn table(side: Side, config: &Dex5Profile) -> DeviceTable {
        table::table(side, &config.conventions())
    }
    fn wire(config: &Dex5Profile) -> WireConfig {
        config.wire()
    }
    fn codec(wire: WireConfig) -> Dex5Codec {
        Dex5Codec::new(wire)
    }
    /// The conventions given on the command line (`--gains`, `--command-layout`,
    /// `--coupling`), the defaults' otherwise.
    fn emulated_wire(options: &Dex5Emulate) -> WireConfig {
        WireConfig::of(&options.0)
    }
    fn service(side: Side, wire: &WireConfig, noise: Noise) -> Dex5EmuConfig {
        Dex5EmuConfig {
            wire: *wire,
            noise,
            ..Dex5EmuConfig::new(side)
        }
    }

    /// Positions the emulated hand cannot take: a coupled `Pitch_x4` has no motor of its own
    /// (its position is its `Pitch_x3`'s through the coupling), and no object stops a joint
    /// that closes nothing (the spreads, the thumb's yaw).
    fn validate_emulator(_ctx: &DeviceCtx<'_>, section: &EmulatorSection) -> Vec<Problem> {
        let index = |joint: &String| JOINTS.iter().position(|j| j == joint);
        let mut out = Vec::new();
        for (joint, i) in section.initial.keys().filter_map(|j| Some((j, index(j)?))) {
            if table::is_coupled(i) {
                let driver = JOINTS[table::driver(i)];
                out.push(Problem::new(
                    &["emulator", "initial", joint],
                    format!("has no effect on a dex5: {joint} has no motor of its own, it follows {driver} through the coupling (set {driver})"),
                ));
            }
        }
        for (joint, i) in section.object_at.keys().filter_map(|j| Some((j, index(j)?))) {
            if !table::closes(i) {
                out.push(Problem::new(
                    &["emulator", "object_at", joint],
                    format!("has no effect on a dex5: {joint} closes nothing (a spread or the thumb's yaw), so no object stops it"),
                ));
            }
        }
        out
    }
}

/// `handgate emulate dex5`'s own options: the conventions the emulated service takes where the
/// sources disagree (`[devices.dex5]`'s keys but the URDF names, which the service does not
/// use; docs/profiles.md, "Assumptions").
#[derive(Debug, Default)]
pub struct Dex5Emulate(pub Conventions);

impl EmulateOptions for Dex5Emulate {
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "gains",
            value: Some("xr_teleoperate|unitree_dds_wrapper"),
            help: "the gains its motors move with as measured (default xr_teleoperate's)",
        },
        EmulateOption {
            name: "command-layout",
            value: Some("joints|motors"),
            help: "the commands it takes: 20 entries, one per joint (default), or the wrapper's 16, one per motor",
        },
        EmulateOption {
            name: "coupling",
            value: Some("K"),
            help: "rad of each Pitch_x4 per rad of its Pitch_x3 (default 0.829)",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        use serde::de::IntoDeserializer;
        use serde::Deserialize;
        let v = value.unwrap_or("");
        let bad = |e: serde::de::value::Error| e.to_string();
        match name {
            "gains" => self.0.gains = table::GainSource::deserialize(v.into_deserializer()).map_err(bad)?,
            "command-layout" => {
                self.0.command_layout = table::CommandLayout::deserialize(v.into_deserializer()).map_err(bad)?
            }
            "coupling" => {
                self.0.coupling = v.parse().map_err(|_| format!("`{v}` is not a number"))?;
                self.0.validate()?;
            }
            _ => return Err(format!("--{name} is not an option")),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex5::table::CommandLayout;
    use crate::emu_common::Hz;
    use crate::kind::Kind;
    use crate::mapping::ClosureMap;
    use crate::open::DeviceSpec;
    use std::sync::Arc;

    fn spec_with<'a>(
        backend: Backend,
        table: &'a Arc<DeviceTable>,
        emulator: &'a EmulatorSection,
        config: &'a Dex5Profile,
    ) -> DeviceSpec<'a, Dex5Profile> {
        DeviceSpec {
            name: "hand",
            kind: DeviceKind::Dex5,
            side: Side::Left,
            backend,
            rate_hz: 250.0,
            stale_after: std::time::Duration::from_millis(200),
            forward_on_arrival: true,
            max_send_hz: None,
            table,
            emulator,
            config,
        }
    }

    #[test]
    fn registered_with_its_facts() {
        let k = DeviceKind::by_name("dex5").unwrap();
        assert_eq!(k, DeviceKind::Dex5);
        let f = k.factory();
        assert_eq!(f.joints(), &JOINTS);
        assert_eq!(f.backends(), &[Backend::Dds, Backend::Emulator]);
        assert_eq!(f.default_rate_hz(Backend::Dds), Some(500.0));
        assert_eq!(f.default_rate_hz(Backend::Emulator), Some(500.0));
        assert!(f.check_side(Side::Center).is_err() && f.check_side(Side::Left).is_ok());
        assert!(f.closure_postures_configurable() && !f.closure_is_torque());
        assert_eq!(f.fronts(), &[crate::front::kind::FrontKind::Dex5]);
        assert!(f.pads().is_none());
        assert_eq!(f.hardware_range(Side::Left, "thumb_1"), Some((0.0, 1.8151_f32 as f64)));
        assert_eq!(f.hardware_range(Side::Center, "thumb_1"), None);
    }

    #[test]
    fn the_conventions_reach_the_table_the_codec_and_the_emulated_service() {
        let config = Dex5Profile {
            dex5: Some(table::Conventions {
                urdf_names: table::UrdfNames::XrTeleoperate,
                command_layout: CommandLayout::Motors,
                coupling: 1.0,
                ..Default::default()
            }),
            ..Default::default()
        };
        let t = Kind::table(&Dex5Kind, Side::Left, &config);
        assert_eq!(t.joints[8].urdf, "Roll_41L");
        let ClosureMap::Postures { closed, .. } = &t.closure else {
            panic!("{:?}", t.closure)
        };
        assert_eq!(closed[3], closed[2].min(t.joints[3].limits.max));
        let t = Arc::new(t);
        let mut emulator = EmulatorSection::default();
        emulator.initial.insert("index_2".into(), 0.4);
        emulator.object_at.insert("thumb_1".into(), 0.7);
        emulator.noise = Some(false);
        let open = Dex5Kind
            .configure(&spec_with(Backend::Emulator, &t, &emulator, &config))
            .unwrap();
        assert_eq!(open.codec.layout, CommandLayout::Motors);
        let peer = open.peer.unwrap();
        assert_eq!((peer.wire, peer.rate), (open.codec, Hz(250.0)));
        assert_eq!(
            peer.topics.as_ref().map(|t| t.0.as_str()),
            Some(open.config.cmd_topic.as_str())
        );
        assert_eq!(peer.initial[2], 0.4);
        assert_eq!(
            peer.object_at[17],
            Some(-0.7),
            "the left thumb roll closes negative on the wire"
        );
        assert_eq!(peer.noise, crate::sim::Noise::OFF);
        let open = Dex5Kind
            .configure(&spec_with(Backend::Dds, &t, &emulator, &config))
            .unwrap();
        assert_eq!(open.config.cmd_topic, "rt/dex5/left/cmd");
        assert!(open.peer.is_none());
        let served = Kind::served(&Dex5Kind, &open);
        assert_eq!(served.len(), 2);
        assert!(served.iter().all(|s| s.entries == Some(20)), "{served:?}");
    }

    #[test]
    fn the_emulator_refuses_positions_it_cannot_take() {
        let ctx = DeviceCtx {
            name: "hand",
            side: Side::Right,
            backend: Backend::Emulator,
        };
        let mut s = EmulatorSection::default();
        for j in ["index_0", "index_2", "thumb_0"] {
            s.initial.insert(j.into(), 0.1);
        }
        for j in ["index_3", "thumb_1", "thumb_2"] {
            s.object_at.insert(j.into(), 0.5);
        }
        assert!(Kind::validate_emulator(&Dex5Kind, &ctx, &s).is_empty());
        s.initial.insert("ring_3".into(), 0.1);
        s.object_at.insert("pinky_0".into(), 0.1);
        s.object_at.insert("thumb_0".into(), 0.1);
        let p: Vec<String> = Kind::validate_emulator(&Dex5Kind, &ctx, &s)
            .into_iter()
            .map(|p| format!("{}: {}", p.key.join("."), p.message))
            .collect();
        assert_eq!(p.len(), 3, "{p:?}");
        assert!(p[0].starts_with("emulator.initial.ring_3: has no effect") && p[0].contains("set ring_2"));
        assert!(p[1].starts_with("emulator.object_at.pinky_0: has no effect"));
        assert!(p[2].starts_with("emulator.object_at.thumb_0: has no effect"));
    }

    #[test]
    fn the_emulated_service_takes_the_conventions_on_the_command_line() {
        let mut o = Dex5Emulate::default();
        assert_eq!(Dex5Kind::emulated_wire(&o), WireConfig::of(&Conventions::default()));
        o.set("gains", Some("unitree_dds_wrapper")).unwrap();
        o.set("command-layout", Some("motors")).unwrap();
        o.set("coupling", Some("1.0")).unwrap();
        let c = Conventions {
            gains: table::GainSource::UnitreeDdsWrapper,
            command_layout: CommandLayout::Motors,
            coupling: 1.0,
            ..Default::default()
        };
        assert_eq!(Dex5Kind::emulated_wire(&o), WireConfig::of(&c));
        let e = o.set("gains", Some("mine")).unwrap_err();
        assert!(
            e.starts_with("unknown variant `mine`, expected `xr_teleoperate`"),
            "{e}"
        );
        assert!(o.set("command-layout", Some("motor")).is_err());
        assert!(o.set("coupling", Some("3")).unwrap_err().starts_with("must be above 0"));
        assert!(o.set("coupling", Some("x")).is_err());
        let names: Vec<&str> = Dex5Emulate::OPTIONS.iter().map(|o| o.name).collect();
        assert_eq!(names, ["gains", "command-layout", "coupling"]);
    }
}
