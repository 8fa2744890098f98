//! The Dex3-1 as a registered device kind: its facts (default rates, table, pads), and how a
//! hand opens (`super::open`): over DDS as a client of a G1's resident service, over USB, or
//! on the emulator backend.

use std::collections::HashMap;

use super::config::Dex3Profile;
use super::dds_client::Dex3DdsCodec;
use super::open::{Dex3Emulate, Dex3Open};
use super::JOINTS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::front::kind::FrontKind;
use crate::kind::{
    DeviceKind, EmulateArgs, Emulation, FleetMember, FleetProblem, Kind, KindFacts, PadLayout, PadPlace, PadScale,
    Problem, Rates, SectionSpec, Sides,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, OpenEnv};

impl DeviceKind {
    /// Unitree Dex3-1, 7 joints (USB, or through a G1's resident service over DDS).
    #[allow(non_upper_case_globals)]
    pub const Dex3: DeviceKind = DeviceKind::of(&Dex3Kind);
}

/// Where the dashboard draws the Dex3-1's nine pads (right hand, palm towards the viewer).
/// Which pad id sits where is not public (docs/sources.md §2): the places follow the
/// emulator's assumed layout (`Dex3Tuning::pads`: 0–1 thumb tip and finger pad, 2–3 middle,
/// 4–5 index, 6–8 palm). Each pad's 12 slots are drawn as a 1 × 12 strip.
const PADS: PadLayout = PadLayout {
    right: &[
        PadPlace {
            name: "pad_0",
            x: 0.72,
            y: 0.28,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_1",
            x: 0.66,
            y: 0.40,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_2",
            x: 0.10,
            y: 0.04,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_3",
            x: 0.10,
            y: 0.18,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_4",
            x: 0.38,
            y: 0.04,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_5",
            x: 0.38,
            y: 0.18,
            w: 0.24,
            h: 0.06,
        },
        PadPlace {
            name: "pad_6",
            x: 0.14,
            y: 0.56,
            w: 0.46,
            h: 0.08,
        },
        PadPlace {
            name: "pad_7",
            x: 0.14,
            y: 0.70,
            w: 0.46,
            h: 0.08,
        },
        PadPlace {
            name: "pad_8",
            x: 0.14,
            y: 0.84,
            w: 0.46,
            h: 0.08,
        },
    ],
    // Raw readings start at PRESS_VALID_MIN (30000 = no reading); the full scale is a display
    // choice: ten times the smallest reading (assumption; no calibration is public).
    scale: PadScale {
        valid_min: super::PRESS_VALID_MIN,
        zero: super::PRESS_VALID_MIN,
        full: 10.0 * super::PRESS_VALID_MIN,
    },
    shape: |_| (1, super::dds_service_emulator::PAD_POINTS as u16),
};

/// The Dex3-1.
#[derive(Debug, Clone, Copy)]
pub struct Dex3Kind;

impl Kind for Dex3Kind {
    const FACTS: KindFacts = KindFacts {
        fronts: &[FrontKind::Dex3],
        sides: Sides::LeftOrRight { note: ", not center" },
        // 1000 Hz over USB and its emulator (the frame loop); 500 Hz over DDS (assumption).
        rates: Rates {
            default: Some(1000.0),
            by_backend: &[(Backend::Dds, Some(super::SERVICE_HZ))],
        },
        sections: &[
            SectionSpec {
                key: "usb",
                backends: &[Backend::Usb, Backend::Emulator],
            },
            SectionSpec {
                key: "dds",
                backends: &[Backend::Dds],
            },
        ],
        pads: Some(&PADS),
        closure_postures_configurable: true,
        ..KindFacts::new(
            "dex3",
            &JOINTS,
            &[Backend::Usb, Backend::Dds, Backend::Emulator],
            Rates::AS_FAST_AS_THE_BUS,
        )
    };
    type Config = Dex3Profile;
    type Open = Dex3Open;
    type Emulate = Dex3Emulate;
    const EMULATOR_FAULTS: &'static [&'static str] = &["stuck", "frozen", "ignore-commands"];

    fn table(&self, side: Side, _config: &Dex3Profile) -> DeviceTable {
        super::table::table(side)
    }

    /// Two hands of one side on USB need their serials.
    fn validate_fleet(&self, members: &[FleetMember<'_, Dex3Profile>]) -> Vec<FleetProblem> {
        let mut out = Vec::new();
        let mut seen: HashMap<(Side, Option<String>), usize> = HashMap::new();
        for m in members.iter().filter(|m| m.ctx.backend == Backend::Usb) {
            let serial = m.config.usb.as_ref().and_then(|u| u.serial.clone());
            if let Some(j) = seen.insert((m.ctx.side, serial.clone()), m.index) {
                out.push((
                    m.index,
                    Problem::new(
                        &["usb", "serial"],
                        format!(
                            "devices[{j}] is also a {} dex3 on usb{}: give each hand its USB serial",
                            m.ctx.side,
                            serial.map(|s| format!(" with serial {s}")).unwrap_or_default()
                        ),
                    ),
                ));
            }
        }
        out
    }

    fn configure(&self, spec: &DeviceSpec<'_, Dex3Profile>) -> Result<Dex3Open, DeviceError> {
        super::open::configure(spec)
    }

    /// Nothing over USB.
    fn served(&self, open: &Dex3Open) -> Vec<crate::discovery::diagnose::Served> {
        match open {
            Dex3Open::Dds { config, .. } => config.served::<Dex3DdsCodec>(),
            Dex3Open::Usb { .. } => Vec::new(),
        }
    }

    /// Dex3-1 hands on USB (VID 0x34B7, PID by side), with permission problems explained.
    fn list_attached(&self) -> Option<Result<Vec<String>, DeviceError>> {
        let hands = match super::usb::list_hands() {
            Ok(h) => h,
            Err(e) => return Some(Err(DeviceError::link(e))),
        };
        if hands.is_empty() {
            return Some(Ok(vec![
                "no Dex3-1 hand on USB (VID 34b7, PID 1010 left / 1011 right)".into()
            ]));
        }
        Some(Ok(hands
            .into_iter()
            .map(|h| {
                let serial = h.serial.as_deref().unwrap_or("?");
                match h.problem {
                    None => format!(
                        "{} hand  serial {serial}  bus {:03} device {:03}",
                        h.side, h.bus, h.address
                    ),
                    Some(p) => format!("{} hand  bus {:03} device {:03}: {p}", h.side, h.bus, h.address),
                }
            })
            .collect()))
    }

    fn emulate(&self, args: &EmulateArgs, options: Dex3Emulate) -> Result<(String, Emulation), DeviceError> {
        super::open::emulate(args, options)
    }

    fn open(
        &self,
        open: Dex3Open,
        spec: &DeviceSpec<'_, Dex3Profile>,
        _env: &mut OpenEnv<'_>,
    ) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(open, spec, _env)
    }
}
