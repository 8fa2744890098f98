//! A Dex3-1's own profile keys (`[devices.usb]` for the USB backend and its emulator,
//! `[devices.dds]` for a G1's resident service) and their rules.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::dds_client::{self, StateSource};
use super::usb::codec::BUS_COUNT;
use super::usb::Scalings;
use super::{JOINTS, PAD_COUNT};
use crate::kind::{a, center_needs_topics, DdsTopicKeys, DeviceCtx, Problem, Settings};
use crate::model::Side;

/// Where a motor or a pressure pad sits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusSlot {
    /// Bus index, 0..=4.
    pub bus: u8,
    /// Id on that bus: motors 0..=15, sensors 0..=14 (15 is broadcast).
    pub id: u8,
}

/// Dex3 USB wiring: joint -> slot and pad (`pad_0`..`pad_8`) -> slot.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WiringConfig {
    pub joints: BTreeMap<String, BusSlot>,
    pub pads: BTreeMap<String, BusSlot>,
}

/// `[devices.usb]`: Dex3 over USB (also read by the emulator backend, which speaks the same
/// protocol).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UsbConfig {
    /// USB serial number, to tell two hands of the same side apart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    /// Talk to a Dex3-1 MCU emulator process (`handgate emulate dex3 --socket PATH`) over this
    /// Unix socket instead of USB (backend `usb` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub socket: Option<PathBuf>,
    /// Set the motors' timeout-protection bit (motor stops after 1 s without commands).
    pub timeout_bit: bool,
    /// Which bus and id each joint and pressure pad sits on; not public (docs/sources.md §3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wiring: Option<WiringConfig>,
    /// Overrides of the motor-frame scalings (docs/sources.md §3, "scaling conflict").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scalings: Option<Scalings>,
    /// How the device loop's exchanges follow the commands (docs/dex3-usb.md, "Aligning the
    /// exchange to commands").
    pub align: AlignMode,
    /// `early`: never two exchanges closer than this, µs (assumption: what the MCU tolerates).
    pub align_min_gap_us: u64,
    /// `phase`: the most the grid moves in one cycle, µs.
    pub align_max_shift_us: u64,
    /// `phase`: how long before a deadline the commands should arrive, µs.
    pub align_lead_us: u64,
}

/// `usb.align`: the device loop's [`crate::dex3::usb::Align`] without its numbers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AlignMode {
    /// Fixed 1 kHz grid (the loop before alignment existed).
    Off,
    /// Exchange when a new command arrives, `align_min_gap_us` after the previous at the soonest.
    Early,
    /// Fixed period, its phase moved by at most `align_max_shift_us` per cycle.
    Phase,
}

/// The defaults of the `usb.align*` keys (docs/dex3-usb.md has the measurements behind them).
pub mod align_defaults {
    use super::AlignMode;
    pub const MODE: AlignMode = AlignMode::Early;
    /// Assumption: the MCU takes exchanges half a period apart (docs/dex3-usb.md).
    pub const MIN_GAP_US: u64 = 500;
    /// Under the 50 µs jitter target (docs/benchmarks.md §2).
    pub const MAX_SHIFT_US: u64 = 20;
    pub const LEAD_US: u64 = 50;
    /// The smallest `align_min_gap_us` accepted: no exchange storms.
    pub const MIN_GAP_FLOOR_US: u64 = 100;
    /// The largest `align_max_shift_us` and `align_lead_us` accepted.
    pub const SHIFT_CEIL_US: u64 = 500;
}

impl UsbConfig {
    /// The loop's alignment from `align` and its numbers.
    pub fn align(&self) -> crate::dex3::usb::Align {
        use crate::dex3::usb::Align;
        use std::time::Duration;
        match self.align {
            AlignMode::Off => Align::Off,
            AlignMode::Early => Align::Early {
                min_gap: Duration::from_micros(self.align_min_gap_us),
            },
            AlignMode::Phase => Align::Phase {
                max_shift: Duration::from_micros(self.align_max_shift_us),
                lead: Duration::from_micros(self.align_lead_us),
            },
        }
    }
}

impl Default for UsbConfig {
    fn default() -> Self {
        UsbConfig {
            serial: None,
            socket: None,
            timeout_bit: true,
            wiring: None,
            scalings: None,
            align: align_defaults::MODE,
            align_min_gap_us: align_defaults::MIN_GAP_US,
            align_max_shift_us: align_defaults::MAX_SHIFT_US,
            align_lead_us: align_defaults::LEAD_US,
        }
    }
}

crate::dds_client_keys! {
    /// `[devices.dds]` of a Dex3: topic overrides and which state topic to read.
    pub struct DdsConfig {
        /// Read `rt/dex3/{side}/state` (`state`) or `rt/lf/dex3/{side}/state` (`lf`).
        pub state_source: StateSource,
    }
}

/// A Dex3's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Dex3Profile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub usb: Option<UsbConfig>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dds: Option<DdsConfig>,
}

impl Dex3Profile {
    /// The timeout bit: `usb.timeout_bit` (default on).
    pub fn timeout_bit(&self) -> bool {
        self.usb.as_ref().map(|u| u.timeout_bit).unwrap_or(true)
    }

    /// (command, state) topics on backend dds: `dds.cmd_topic` / `dds.state_topic`, else the
    /// resident service's for the side and `dds.state_source`; `None` where the side
    /// (center) gives no default.
    pub fn topics(&self, side: Side) -> (Option<String>, Option<String>) {
        let source = self.dds.as_ref().and_then(|d| d.state_source).unwrap_or_default();
        self.dds
            .clone()
            .unwrap_or_default()
            .topics_or((side != Side::Center).then(|| dds_client::topics(side, source)))
    }
}

impl Settings for Dex3Profile {
    fn check(&self, ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(u) = &self.usb {
            validate_usb(u, &mut out);
        }
        if let Some(x) = &self.dds {
            out.extend(x.topic_problems());
        }
        out.extend(center_needs_topics("dex3", ctx, self.topics(ctx.side)));
        out
    }

    fn peer_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        Some(self.topics(ctx.side))
    }

    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        match self.usb.as_ref().and_then(|u| u.serial.as_ref()) {
            Some(s) => format!(", usb serial {s}"),
            None => String::new(),
        }
    }
}

fn validate_usb(u: &UsbConfig, out: &mut Vec<Problem>) {
    if let Some(s) = &u.serial {
        if s.trim().is_empty() {
            out.push(Problem::new(
                &["usb", "serial"],
                "must not be empty (omit it to take any hand of this side)",
            ));
        }
    }
    if let Some(w) = &u.wiring {
        let mut used: HashMap<(u8, u8, bool), String> = HashMap::new();
        for (j, slot) in &w.joints {
            let key = ["usb", "wiring", "joints", j.as_str()];
            if !JOINTS.contains(&j.as_str()) {
                out.push(Problem::new(
                    &key,
                    format!("unknown joint `{j}` for {} (joints: {})", a("dex3"), JOINTS.join(", ")),
                ));
            }
            slot_rules(&key, *slot, 15, out);
            if let Some(o) = used.insert((slot.bus, slot.id, true), j.clone()) {
                out.push(Problem::new(
                    &key,
                    format!("bus {} id {} is also wired to {o}", slot.bus, slot.id),
                ));
            }
        }
        for (pad, slot) in &w.pads {
            let key = ["usb", "wiring", "pads", pad.as_str()];
            let valid = pad
                .strip_prefix("pad_")
                .and_then(|n| n.parse::<usize>().ok())
                .is_some_and(|n| n < PAD_COUNT && pad == &format!("pad_{n}"));
            if !valid {
                out.push(Problem::new(
                    &key,
                    format!("unknown pad `{pad}` (pads: pad_0 .. pad_{})", PAD_COUNT - 1),
                ));
            }
            slot_rules(&key, *slot, 14, out);
            if let Some(o) = used.insert((slot.bus, slot.id, false), pad.clone()) {
                out.push(Problem::new(
                    &key,
                    format!("bus {} id {} is also wired to {o}", slot.bus, slot.id),
                ));
            }
        }
    }
    if u.align_min_gap_us < align_defaults::MIN_GAP_FLOOR_US {
        out.push(Problem::new(
            &["usb", "align_min_gap_us"],
            format!(
                "must be at least {} µs (exchanges closer than that are a storm, not a schedule), got {}",
                align_defaults::MIN_GAP_FLOOR_US,
                u.align_min_gap_us
            ),
        ));
    }
    for (key, v) in [
        ("align_max_shift_us", u.align_max_shift_us),
        ("align_lead_us", u.align_lead_us),
    ] {
        if v > align_defaults::SHIFT_CEIL_US || (key == "align_max_shift_us" && v == 0) {
            out.push(Problem::new(
                &["usb", key],
                format!(
                    "must be between {} and {} µs, got {v}",
                    (key == "align_max_shift_us") as u8,
                    align_defaults::SHIFT_CEIL_US
                ),
            ));
        }
    }
    if let Some(s) = &u.scalings {
        if let Err(e) = s.validate() {
            out.push(Problem::new(
                &["usb", "scalings", e.field],
                format!("must be a finite number above 0, got {}", e.value),
            ));
        }
    }
}

fn slot_rules(key: &[&str], s: BusSlot, max_id: u8, out: &mut Vec<Problem>) {
    let sub = |k: &str| {
        let mut v: Vec<&str> = key.to_vec();
        v.push(k);
        v.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    if usize::from(s.bus) >= BUS_COUNT {
        out.push(Problem {
            key: sub("bus"),
            message: format!("must be between 0 and {}, got {}", BUS_COUNT - 1, s.bus),
        });
    }
    if s.id > max_id {
        out.push(Problem {
            key: sub("id"),
            message: format!("must be between 0 and {max_id}, got {}", s.id),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dex3::usb::Align;
    use std::time::Duration;

    fn problems(u: UsbConfig) -> Vec<(String, String)> {
        let mut out = Vec::new();
        validate_usb(&u, &mut out);
        out.into_iter().map(|p| (p.key.join("."), p.message)).collect()
    }

    #[test]
    fn align_keys_are_validated_and_mapped() {
        assert!(problems(UsbConfig::default()).is_empty());
        let bad = UsbConfig {
            align_min_gap_us: 10,
            align_max_shift_us: 0,
            align_lead_us: 900,
            ..Default::default()
        };
        let keys: Vec<String> = problems(bad).into_iter().map(|(k, _)| k).collect();
        assert_eq!(
            keys,
            ["usb.align_min_gap_us", "usb.align_max_shift_us", "usb.align_lead_us"]
        );
        let u = UsbConfig {
            align: AlignMode::Phase,
            align_max_shift_us: 30,
            align_lead_us: 40,
            ..Default::default()
        };
        assert_eq!(
            u.align(),
            Align::Phase {
                max_shift: Duration::from_micros(30),
                lead: Duration::from_micros(40)
            }
        );
        let u = UsbConfig {
            align: AlignMode::Off,
            ..Default::default()
        };
        assert_eq!(u.align(), Align::Off);
        assert_eq!(
            UsbConfig::default().align(),
            Align::Early {
                min_gap: Duration::from_micros(align_defaults::MIN_GAP_US)
            }
        );
    }
}
