//! The Inspire FTP (RH56DFTP, tactile) hand as a registered device kind: one device per hand,
//! a client of Inspire's DDS driver (docs/sources.md §7). Its facts, and how a hand opens:
//! over DDS as a client of the driver, or on the emulator backend: the driver's emulator on
//! private topics driven by the very same codec.

use super::adapter::{FtpClient, FtpCodec};
use super::config::InspireFtpProfile;
use super::emulator::{FtpConfig, FtpEmulator, FtpTransport, ANGLE_NOISE, REST_ANGLE};
use super::table::JOINTS;
use crate::dds_device::STATE_QOS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::front::kind::FrontKind;
use crate::kind::{
    DeviceCtx, DeviceKind, EmulateArgs, EmulateOption, EmulateOptions, Emulation, Kind, KindFacts, PadLayout, PadPlace,
    PadScale, Problem, Rates, SectionSpec, Sides,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, EmulatorSection, OpenEnv};
use crate::service_client::{emulate_service, ClientOpen};

impl DeviceKind {
    /// Inspire RH56DFTP (tactile) hand, through Inspire's DDS driver.
    #[allow(non_upper_case_globals)]
    pub const InspireFtp: DeviceKind = DeviceKind::of(&InspireFtpKind);
}

/// Where the dashboard draws the FTP's 17 touch segments (right hand, palm towards the
/// viewer, fingers up; a schematic after the segment names of docs/sources.md §7, not a
/// measured drawing).
const PADS: PadLayout = PadLayout {
    right: &[
        PadPlace {
            name: "pinky_tip",
            x: 0.075,
            y: 0.02,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "pinky_top",
            x: 0.04,
            y: 0.08,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "pinky_pad",
            x: 0.05,
            y: 0.25,
            w: 0.12,
            h: 0.12,
        },
        PadPlace {
            name: "ring_tip",
            x: 0.235,
            y: 0.02,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "ring_top",
            x: 0.20,
            y: 0.08,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "ring_pad",
            x: 0.21,
            y: 0.25,
            w: 0.12,
            h: 0.12,
        },
        PadPlace {
            name: "middle_tip",
            x: 0.395,
            y: 0.02,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "middle_top",
            x: 0.36,
            y: 0.08,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "middle_pad",
            x: 0.37,
            y: 0.25,
            w: 0.12,
            h: 0.12,
        },
        PadPlace {
            name: "index_tip",
            x: 0.555,
            y: 0.02,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "index_top",
            x: 0.52,
            y: 0.08,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "index_pad",
            x: 0.53,
            y: 0.25,
            w: 0.12,
            h: 0.12,
        },
        PadPlace {
            name: "thumb_tip",
            x: 0.865,
            y: 0.28,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "thumb_top",
            x: 0.83,
            y: 0.34,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "thumb_middle",
            x: 0.78,
            y: 0.52,
            w: 0.07,
            h: 0.05,
        },
        PadPlace {
            name: "thumb_pad",
            x: 0.74,
            y: 0.58,
            w: 0.14,
            h: 0.15,
        },
        PadPlace {
            name: "palm",
            x: 0.06,
            y: 0.44,
            w: 0.60,
            h: 0.50,
        },
    ],
    // Register values from 0; the full scale is a display choice (assumption: 12-bit taxels,
    // no range is public).
    scale: PadScale {
        valid_min: 0.0,
        zero: 0.0,
        full: 4095.0,
    },
    shape: |name| {
        super::front::SEGMENTS
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(_, r, c)| (*r, *c))
            .unwrap_or((0, 0))
    },
};

/// The Inspire FTP.
#[derive(Debug, Clone, Copy)]
pub struct InspireFtpKind;

/// What an Inspire FTP hand opens with: a client of the driver with its codec and its touch
/// topic where the hand has one (and on the emulator backend, the emulated driver).
pub type FtpOpen = ClientOpen<(FtpCodec, Option<String>), FtpConfig>;

/// Private tactile topic of an in-process emulated driver for `device`.
pub fn emulator_touch_topic(device: &str) -> String {
    format!("rt/handgate/emu/{device}/touch")
}

/// `handgate emulate inspire_ftp`'s own options.
#[derive(Debug, Default)]
pub struct FtpEmulate {
    /// Over RS-485 (state only) instead of Modbus TCP.
    pub rs485: bool,
}

impl EmulateOptions for FtpEmulate {
    const OPTIONS: &'static [EmulateOption] = &[EmulateOption {
        name: "variant",
        value: Some("tcp|rs485"),
        help:
            "the hand's wiring: Modbus TCP (state and touch, about 50 Hz; default) or RS-485 (state only, about 20 Hz)",
    }];

    fn set(&mut self, _name: &str, value: Option<&str>) -> Result<(), String> {
        match value {
            Some("tcp") => self.rs485 = false,
            Some("rs485") => self.rs485 = true,
            other => {
                return Err(format!(
                    "unknown inspire_ftp transport {:?} (tcp or rs485)",
                    other.unwrap_or("")
                ))
            }
        }
        Ok(())
    }
}

impl Kind for InspireFtpKind {
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];
    const FACTS: KindFacts = KindFacts {
        // Inspire's DDS driver's own interface (`rt/inspire_hand/*/{l,r}`, one hand): `super::serve`.
        fronts: &[FrontKind::InspireFtp],
        sides: Sides::LeftOrRight { note: "" },
        sections: &[
            SectionSpec {
                key: "dds",
                backends: &[Backend::Dds],
            },
            SectionSpec {
                key: "driver",
                backends: &[Backend::Emulator],
            },
        ],
        pads: Some(&PADS),
        // 100 Hz: xr_teleoperate's command rate for this hand (docs/sources.md §7).
        ..KindFacts::new(
            "inspire_ftp",
            &JOINTS,
            &[Backend::Dds, Backend::Emulator],
            Rates::fixed(100.0),
        )
    };
    type Config = InspireFtpProfile;
    type Open = FtpOpen;
    type Emulate = FtpEmulate;

    fn table(&self, side: Side, _config: &InspireFtpProfile) -> DeviceTable {
        super::table::table(side)
    }

    /// The driver reports no velocity and no torque in N·m: their noise keys would change
    /// nothing.
    fn validate_emulator(&self, _ctx: &DeviceCtx<'_>, section: &EmulatorSection) -> Vec<Problem> {
        let mut out = Vec::new();
        for (key, set) in [
            ("velocity_noise_rad_s", section.velocity_noise_rad_s.is_some()),
            ("torque_noise_nm", section.torque_noise_nm.is_some()),
        ] {
            if set {
                out.push(Problem::new(
                    &["emulator", key],
                    "has no effect on an inspire_ftp: its driver reports no velocity and no torque \
                     (angle, force and current in the hand's own units), remove it",
                ));
            }
        }
        if section.object_at.contains_key("thumb_rotate") {
            out.push(Problem::new(
                &["emulator", "object_at", "thumb_rotate"],
                "has no effect on an inspire_ftp: the thumb rotation turns the thumb, it never closes on an \
                 object (place it on thumb_bend), remove it",
            ));
        }
        out
    }

    fn configure(&self, spec: &DeviceSpec<'_, InspireFtpProfile>) -> Result<FtpOpen, DeviceError> {
        let t = spec.config.topics(spec.side);
        let touch = match spec.backend {
            Backend::Dds => t.touch.clone(),
            // The emulated driver over Modbus TCP: state and touch, on private topics.
            _ => Some(emulator_touch_topic(spec.name)),
        };
        let codec = (spec.config.codec(), touch.clone());
        ClientOpen::of(spec, (Some(t.cmd), Some(t.state)), "", codec, |cmd, state| {
            let mut peer = FtpConfig::new(spec.side);
            for (i, joint) in JOINTS.iter().enumerate() {
                peer.initial[i] = spec.initial_wire(joint, REST_ANGLE[i]);
                peer.object[i] = spec.object_wire(joint);
            }
            peer.noise = spec.emulator.noise_for(spec.name, ANGLE_NOISE);
            peer.noisy = spec.emulator.noise != Some(false);
            peer.rate = crate::emu_common::Hz(spec.config.driver_hz());
            peer.topics = Some((cmd, state, touch.unwrap_or_default()));
            peer
        })
    }

    /// The client's topics, and its touch reader where the hand has one.
    fn served(&self, open: &FtpOpen) -> Vec<crate::discovery::diagnose::Served> {
        let mut out = open.config.served::<FtpCodec>();
        if let Some(t) = &open.codec.1 {
            out.push(crate::discovery::diagnose::Served::new(
                t,
                crate::dds::type_name::<handgate_idl::inspire::InspireHandTouch>(),
                crate::discovery::Role::Reader,
                STATE_QOS.served(),
            ));
        }
        out
    }

    fn open(
        &self,
        open: FtpOpen,
        spec: &DeviceSpec<'_, InspireFtpProfile>,
        env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        let (codec, touch) = open.codec.clone();
        let client = FtpClient::new(env.node, codec, touch.as_deref())?;
        open.start(client, spec, env, FtpEmulator::start)
    }

    /// `handgate emulate inspire_ftp --side left|right [--variant tcp|rs485]`: Inspire's DDS
    /// driver for one hand, over Modbus TCP (state and touch, about 50 Hz; the default) or
    /// RS-485 (state only, about 20 Hz).
    fn emulate(&self, args: &EmulateArgs, options: FtpEmulate) -> Result<(String, Emulation), DeviceError> {
        let side = args.side("inspire_ftp")?;
        let mut cfg = FtpConfig::new(side);
        if options.rs485 {
            cfg = cfg.rs485();
        }
        cfg.noise = args.noise(ANGLE_NOISE);
        cfg.noisy = !args.no_noise;
        let (ctrl, state, touch) = super::front::topics(side);
        let what = match cfg.transport {
            FtpTransport::Tcp => format!(
                "emulating Inspire's DDS driver (Modbus TCP): {ctrl}, {state}, {touch} on DDS domain {}",
                args.domain
            ),
            FtpTransport::Rs485 => format!(
                "emulating Inspire's DDS driver (RS-485, no touch): {ctrl}, {state} on DDS domain {}",
                args.domain
            ),
        };
        Ok((
            what,
            emulate_service(args, DeviceKind::InspireFtp, &[(side, 0)], |node| {
                FtpEmulator::start(node, cfg)
            })?,
        ))
    }
}
