//! A LEAP Hand's own profile keys (`[devices.leap]`) and their rules.

use serde::{Deserialize, Serialize};

use super::control_table::{DEFAULT_IDS, GOAL_CURRENT_FULL_MA, GOAL_CURRENT_LITE_MA, MOTORS};
use crate::kind::{DeviceCtx, Problem, Settings};

/// Which LEAP Hand: the goal current its servos get (LEAP_Hand_API readme).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// LEAP Hand Lite: 350 mA.
    #[default]
    Lite,
    /// LEAP Hand (full): 550 mA.
    Full,
}

impl Variant {
    pub fn goal_current_ma(self) -> u16 {
        match self {
            Variant::Lite => GOAL_CURRENT_LITE_MA,
            Variant::Full => GOAL_CURRENT_FULL_MA,
        }
    }
}

/// `[devices.leap]`: a LEAP Hand v1 on a U2D2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeapConfig {
    pub port: String,
    pub baud: u32,
    pub variant: Variant,
    /// Goal current, mA, replacing the variant's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goal_current_ma: Option<u16>,
    /// Servo ids in joint order (index 0-3, middle, ring, thumb); default 0..15.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ids: Option<Vec<u8>>,
    /// Read with Fast Sync Read (0x8A) instead of Sync Read (newer XC330 firmware).
    pub fast_sync_read: bool,
    /// Grace for the replies beyond their wire time, ms (the USB adapter's latency).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response_grace_ms: Option<u64>,
}

impl Default for LeapConfig {
    fn default() -> Self {
        Self {
            port: "/dev/ttyUSB0".into(),
            baud: super::control_table::BAUD,
            variant: Variant::Lite,
            goal_current_ma: None,
            ids: None,
            fast_sync_read: false,
            response_grace_ms: None,
        }
    }
}

impl LeapConfig {
    pub fn ids(&self) -> Vec<u8> {
        self.ids.clone().unwrap_or_else(|| DEFAULT_IDS.to_vec())
    }

    pub fn goal_current_ma(&self) -> u16 {
        self.goal_current_ma.unwrap_or(self.variant.goal_current_ma())
    }
}

/// A LEAP Hand's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeapProfile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leap: Option<LeapConfig>,
}

impl LeapProfile {
    pub fn section(&self) -> LeapConfig {
        self.leap.clone().unwrap_or_default()
    }
}

/// The XC330's largest current limit, mA (its Current Limit (38) initial value, DynamixelSDK's
/// xc330_m288 model; handgate refuses a goal current above it).
pub const MAX_GOAL_CURRENT_MA: u16 = 1750;

impl Settings for LeapProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let Some(c) = &self.leap else { return out };
        if c.port.trim().is_empty() {
            out.push(Problem::new(
                &["leap", "port"],
                "must name a serial port, e.g. /dev/serial/by-id/usb-FTDI_USB__-__Serial_Converter_...",
            ));
        }
        if !crate::ezgripper::config::DYNAMIXEL_BAUDS.contains(&c.baud) {
            out.push(Problem::new(
                &["leap", "baud"],
                format!(
                    "{} is not a Dynamixel baud rate (the LEAP Hand runs at 4000000)",
                    c.baud
                ),
            ));
        }
        if let Some(ma) = c.goal_current_ma {
            if !(1..=MAX_GOAL_CURRENT_MA).contains(&ma) {
                out.push(Problem::new(
                    &["leap", "goal_current_ma"],
                    format!("must be between 1 and {MAX_GOAL_CURRENT_MA} mA, got {ma}"),
                ));
            }
        }
        if let Some(ids) = &c.ids {
            let mut sorted = ids.clone();
            sorted.sort_unstable();
            sorted.dedup();
            if ids.len() != MOTORS || sorted.len() != MOTORS || ids.iter().any(|&i| i > 252) {
                out.push(Problem::new(
                    &["leap", "ids"],
                    format!("must be {MOTORS} distinct servo ids between 0 and 252, got {ids:?}"),
                ));
            }
        }
        out
    }

    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
        match &self.leap {
            Some(c) => format!(
                ", {} @ {} baud, goal current {} mA{}",
                if ctx.backend == crate::device::Backend::Emulator {
                    "emulated bus"
                } else {
                    c.port.as_str()
                },
                c.baud,
                c.goal_current_ma(),
                if c.fast_sync_read { ", fast sync read" } else { "" }
            ),
            None => String::new(),
        }
    }
}
