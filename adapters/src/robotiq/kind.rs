//! The Robotiq 2F-85, 2F-140 and Hand-E as one registered device kind (the variant is a
//! profile key): its facts, table and how a gripper opens.

use super::config::RobotiqProfile;
use super::open::RobotiqOpen;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    DeviceCtx, DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, Kind, KindFacts, Problem, Rates,
    SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::{Side, GRIPPER_JOINTS};
use crate::open::{DeviceSpec, EmulatorSection, OpenEnv};

impl DeviceKind {
    /// Robotiq adaptive grippers (2F-85, 2F-140, Hand-E) over Modbus RTU.
    #[allow(non_upper_case_globals)]
    pub const Robotiq: DeviceKind = DeviceKind::of(&RobotiqKind);
}

/// The Robotiq grippers.
#[derive(Debug, Clone, Copy)]
pub struct RobotiqKind;

/// The manual's "usual speed": 200 Hz, at least 5 ms between commands.
pub const DEFAULT_RATE_HZ: f64 = 200.0;

impl Kind for RobotiqKind {
    const FACTS: KindFacts = KindFacts {
        fronts: &[crate::front::kind::FrontKind::Robotiq],
        sections: &[SectionSpec {
            key: "robotiq",
            backends: &[Backend::Serial, Backend::Emulator],
        }],
        ..KindFacts::new(
            "robotiq",
            &GRIPPER_JOINTS,
            &[Backend::Serial, Backend::Emulator],
            Rates::fixed(DEFAULT_RATE_HZ),
        )
    };
    type Config = RobotiqProfile;
    type Open = RobotiqOpen;
    type Emulate = RobotiqEmulate;

    fn table(&self, side: Side, config: &RobotiqProfile) -> DeviceTable {
        super::table::table(config.section().variant, side)
    }

    fn configure(&self, spec: &DeviceSpec<'_, RobotiqProfile>) -> Result<RobotiqOpen, DeviceError> {
        super::open::configure(spec)
    }

    fn open(
        &self,
        open: RobotiqOpen,
        spec: &DeviceSpec<'_, RobotiqProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(open, spec, env)
    }

    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &EmulatorSection) -> Vec<Problem> {
        let mut out = Vec::new();
        for (key, set) in [
            ("velocity_noise_rad_s", section.velocity_noise_rad_s.is_some()),
            ("torque_noise_nm", section.torque_noise_nm.is_some()),
        ] {
            if set {
                out.push(Problem::new(
                    &["emulator", key],
                    "has no effect on a robotiq: the gripper reports a position byte and a current byte, \
                     no velocity and no torque (only position_noise_rad jitters its encoder), remove it",
                ));
            }
        }
        out
    }

    fn emulate(&self, args: &EmulateArgs, options: RobotiqEmulate) -> Result<(String, Emulation), DeviceError> {
        super::open::emulate(args, options)
    }
}

/// `handgate emulate robotiq`'s own options.
#[derive(Debug, Default)]
pub struct RobotiqEmulate {
    pub variant: Option<super::table::Variant>,
    /// Where to link the pseudo-terminal (default: a temporary path).
    pub pty: Option<std::path::PathBuf>,
    /// Serve RTU over TCP on this address instead of a pseudo-terminal.
    pub tcp: Option<std::net::SocketAddr>,
    /// Slave id (default 9).
    pub slave: Option<u8>,
    /// `object_at`, position counts 0..=255.
    pub object_at: Option<u8>,
}

impl EmulateOptions for RobotiqEmulate {
    const COMMON: &'static [&'static str] = &["no-noise", "seed"];
    const OPTIONS: &'static [EmulateOption] = &[
        EmulateOption {
            name: "variant",
            value: Some("2f-85|2f-140|hand-e"),
            help: "which gripper (default 2f-85)",
        },
        EmulateOption {
            name: "pty",
            value: Some("PATH"),
            help: "where to link the RTU line's pseudo-terminal (default: a temporary path); give it as robotiq.port",
        },
        EmulateOption {
            name: "tcp",
            value: Some("ADDR"),
            help:
                "serve RTU over TCP on ADDR (e.g. 127.0.0.1:54321) instead of a pseudo-terminal; give it as robotiq.tcp",
        },
        EmulateOption {
            name: "slave",
            value: Some("ID"),
            help: "Modbus slave id (default 9)",
        },
        EmulateOption {
            name: "object-at",
            value: Some("0-255"),
            help: "an object between the fingers at this position (gOBJ 2 when closing onto it)",
        },
    ];

    fn set(&mut self, name: &str, value: Option<&str>) -> Result<(), String> {
        let v = value.unwrap_or_default();
        match name {
            "variant" => {
                self.variant = Some(
                    super::table::Variant::ALL
                        .into_iter()
                        .find(|x| x.name() == v)
                        .ok_or_else(|| format!("`{v}` is not a variant (2f-85, 2f-140, hand-e)"))?,
                )
            }
            "pty" => self.pty = Some(v.into()),
            "tcp" => {
                self.tcp = Some(
                    v.parse()
                        .map_err(|_| format!("`{v}` is not an address (127.0.0.1:54321)"))?,
                )
            }
            "slave" => {
                let id: u8 = v.parse().map_err(|_| format!("`{v}` is not a slave id (1-247)"))?;
                if !(1..=247).contains(&id) {
                    return Err(format!("{id} is not a slave id (1-247)"));
                }
                self.slave = Some(id);
            }
            _ => self.object_at = Some(v.parse().map_err(|_| format!("`{v}` is not a position (0-255)"))?),
        }
        Ok(())
    }
}
