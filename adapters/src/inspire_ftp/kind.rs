//! The Inspire FTP (RH56DFTP, tactile) hand as a registered device kind: one device per hand,
//! a client of Inspire's DDS driver (docs/sources.md §7). Its profile keys (`[devices.dds]`:
//! topic overrides, the tactile topic, force limit and speed), their rules, its default rate
//! and table.

use serde::{Deserialize, Serialize};

use super::table::JOINTS;
use crate::device::{Backend, DeviceError, HandDevice};
use crate::kind::{
    a, check_rate, check_topic, ConfigError, ConfigValue, DeviceCtx, DeviceKind, KindConfig, KindFactory, PadLayout,
    PadPlace, PadScale, Problem, SectionSpec,
};
use crate::mapping::DeviceTable;
use crate::model::Side;
use crate::open::{DeviceSpec, EmulatorSection, OpenEnv};

impl DeviceKind {
    /// Inspire RH56DFTP (tactile) hand, through Inspire's DDS driver.
    #[allow(non_upper_case_globals)]
    pub const InspireFtp: DeviceKind = DeviceKind::of(&InspireFtpFactory);
}

/// Where the dashboard draws the FTP's 17 touch segments (right hand, palm towards the
/// viewer, fingers up; a schematic after the segment names of docs/sources.md §7, not a
/// measured drawing).
static PADS: PadLayout = PadLayout {
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

/// The Inspire FTP's factory.
#[derive(Debug, Clone, Copy)]
pub struct InspireFtpFactory;

const NAME: &str = "inspire_ftp";

/// `[devices.dds]` of an Inspire FTP hand.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    /// Default `rt/inspire_hand/ctrl/{l,r}`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cmd_topic: Option<String>,
    /// Default `rt/inspire_hand/state/{l,r}`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_topic: Option<String>,
    /// Whether the hand is wired over Modbus TCP, so its driver publishes the tactile arrays
    /// (default true: the G1's FTP hands are on Ethernet, 192.168.123.210/.211,
    /// docs/sources.md §7). `false`: RS-485, no touch topic.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub touch: Option<bool>,
    /// Default `rt/inspire_hand/touch/{l,r}`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub touch_topic: Option<String>,
    /// `force_set` (0–1000) sent with every command (mode bit 2); unset: not sent, the hand
    /// keeps its own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_limit: Option<i16>,
    /// `speed_set` (0–1000) sent with every command (mode bit 3); unset: not sent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed: Option<i16>,
}

/// `[devices.driver]` of an emulated Inspire FTP hand: the emulated driver.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriverConfig {
    /// The driver's loop and state rate, Hz (default
    /// [`super::emulator::FtpTransport::rate`] over Modbus TCP: an assumption, docs/profiles.md
    /// "Assumptions").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
}

/// An Inspire FTP hand's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InspireFtpProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub driver: Option<DriverConfig>,
}

/// The resolved `[devices.dds]` of a hand on `side`.
#[derive(Debug, Clone, PartialEq)]
pub struct FtpTopics {
    pub cmd: String,
    pub state: String,
    /// `None` over RS-485 (`dds.touch = false`).
    pub touch: Option<String>,
}

impl InspireFtpProfile {
    fn dds(&self) -> DdsConfig {
        self.dds.clone().unwrap_or_default()
    }

    /// The topics a device on `side` uses (overrides, else the driver's for the side).
    pub fn topics(&self, side: Side) -> FtpTopics {
        let d = self.dds();
        let (cmd, state, touch) = super::front::topics(side);
        FtpTopics {
            cmd: d.cmd_topic.unwrap_or(cmd),
            state: d.state_topic.unwrap_or(state),
            touch: d.touch.unwrap_or(true).then(|| d.touch_topic.unwrap_or(touch)),
        }
    }

    /// The emulated driver's loop rate, Hz (`driver.rate_hz`, else the Modbus TCP driver's).
    pub fn driver_hz(&self) -> f64 {
        self.driver
            .as_ref()
            .and_then(|d| d.rate_hz)
            .unwrap_or(super::emulator::FtpTransport::Tcp.rate().0)
    }

    /// The codec for these keys.
    pub fn codec(&self) -> super::adapter::FtpCodec {
        let d = self.dds();
        super::adapter::FtpCodec {
            force_limit: d.force_limit,
            speed: d.speed,
            ..Default::default()
        }
    }
}

impl KindFactory for InspireFtpFactory {
    fn name(&self) -> &'static str {
        NAME
    }

    fn pads(&self) -> Option<&'static PadLayout> {
        Some(&PADS)
    }

    fn joints(&self) -> &'static [&'static str] {
        &JOINTS
    }

    /// Inspire's DDS driver's own interface (`rt/inspire_hand/*/{l,r}`, one hand): `super::serve`.
    fn fronts(&self) -> &'static [crate::front::kind::FrontKind] {
        &[crate::front::kind::FrontKind::InspireFtp]
    }

    fn backends(&self) -> &'static [Backend] {
        &[Backend::Dds, Backend::Emulator]
    }

    fn check_side(&self, side: Side) -> Result<(), String> {
        match side {
            Side::Center => Err(format!("{} is a left or a right hand", a(NAME))),
            _ => Ok(()),
        }
    }

    /// 100 Hz: xr_teleoperate's command rate for this hand (docs/sources.md §7).
    fn default_rate_hz(&self, _backend: Backend) -> Option<f64> {
        Some(100.0)
    }

    fn sections(&self) -> &'static [SectionSpec] {
        &[
            SectionSpec {
                key: "dds",
                backends: &[Backend::Dds],
            },
            SectionSpec {
                key: "driver",
                backends: &[Backend::Emulator],
            },
        ]
    }

    fn parse(&self, value: &ConfigValue) -> Result<Box<dyn KindConfig>, ConfigError> {
        Ok(Box::new(value.deserialize::<InspireFtpProfile>().map_err(Box::new)?))
    }

    fn default_config(&self) -> Box<dyn KindConfig> {
        Box::new(InspireFtpProfile::default())
    }

    fn table(&self, side: Side, _c: &dyn KindConfig) -> DeviceTable {
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

    fn configured(&self, spec: &DeviceSpec<'_>) -> Result<Box<dyn std::fmt::Debug>, DeviceError> {
        Ok(Box::new(super::open::configure(spec)?))
    }

    fn served(&self, spec: &DeviceSpec<'_>) -> Vec<crate::discovery::diagnose::Served> {
        super::open::served(spec)
    }

    fn emulate(&self, args: &crate::kind::EmulateArgs) -> Result<(String, crate::kind::Emulation), DeviceError> {
        super::open::emulate(args)
    }

    fn open(&self, spec: &DeviceSpec<'_>, env: &mut OpenEnv<'_>) -> Result<Box<dyn HandDevice>, DeviceError> {
        super::open::open(spec, env)
    }
}

impl KindConfig for InspireFtpProfile {
    fn validate(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(x) = &self.dds {
            for (key, t) in [
                ("cmd_topic", &x.cmd_topic),
                ("state_topic", &x.state_topic),
                ("touch_topic", &x.touch_topic),
            ] {
                if let Some(Err(e)) = t.as_deref().map(check_topic) {
                    out.push(Problem::new(&["dds", key], e));
                }
            }
            if x.touch == Some(false) && x.touch_topic.is_some() {
                out.push(Problem::new(
                    &["dds", "touch_topic"],
                    "dds.touch is false (RS-485: no tactile topic): touch_topic would have no effect, remove it",
                ));
            }
            for (key, v) in [("force_limit", x.force_limit), ("speed", x.speed)] {
                if let Some(v) = v {
                    if !(0..=1000).contains(&v) {
                        out.push(Problem::new(
                            &["dds", key],
                            format!("must be 0..=1000 (the hand's register range), got {v}"),
                        ));
                    }
                }
            }
        }
        if let Some(hz) = self.driver.as_ref().and_then(|d| d.rate_hz) {
            if let Err(e) = check_rate(hz, 1000.0) {
                out.push(Problem::new(&["driver", "rate_hz"], e));
            }
        }
        out
    }

    fn dds_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        let t = self.topics(ctx.side);
        Some((Some(t.cmd), Some(t.state)))
    }

    fn describe(&self, ctx: &DeviceCtx<'_>) -> String {
        if ctx.backend != Backend::Dds {
            return String::new();
        }
        let t = self.topics(ctx.side);
        let d = self.dds();
        let mut s = match &t.touch {
            Some(touch) => format!(" (Modbus TCP: touch on {touch}"),
            None => " (RS-485: no touch".to_string(),
        };
        if let Some(f) = d.force_limit {
            s.push_str(&format!(", force_set {f}"));
        }
        if let Some(v) = d.speed {
            s.push_str(&format!(", speed_set {v}"));
        }
        s.push(')');
        s
    }

    crate::kind_config_plumbing!();
}
