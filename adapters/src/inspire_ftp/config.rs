//! An Inspire FTP hand's own profile keys (`[devices.dds]`: topic overrides, the tactile
//! topic, force limit and speed; `[devices.driver]`: the emulated driver) and their rules.

use serde::{Deserialize, Serialize};

use crate::device::Backend;
use crate::kind::{check_rate, check_topics, DeviceCtx, Problem, Settings};
use crate::model::Side;

crate::dds_client_keys! {
    /// `[devices.dds]` of an Inspire FTP hand.
    pub struct DdsConfig {
        /// Whether the hand is wired over Modbus TCP, so its driver publishes the tactile arrays
        /// (default true: the G1's FTP hands are on Ethernet, 192.168.123.210/.211,
        /// docs/sources.md §7). `false`: RS-485, no touch topic.
        pub touch: bool,
        /// Default `rt/inspire_hand/touch/{l,r}`.
        pub touch_topic: String,
        /// `force_set` (0–1000) sent with every command (mode bit 2); unset: not sent, the hand
        /// keeps its own.
        pub force_limit: i16,
        /// `speed_set` (0–1000) sent with every command (mode bit 3); unset: not sent.
        pub speed: i16,
    }
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

impl Settings for InspireFtpProfile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        if let Some(x) = &self.dds {
            out = check_topics(
                "dds",
                &[
                    ("cmd_topic", x.cmd_topic.as_deref()),
                    ("state_topic", x.state_topic.as_deref()),
                    ("touch_topic", x.touch_topic.as_deref()),
                ],
            );
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

    fn peer_topics(&self, ctx: &DeviceCtx<'_>) -> Option<(Option<String>, Option<String>)> {
        let t = self.topics(ctx.side);
        Some((Some(t.cmd), Some(t.state)))
    }

    fn summary(&self, ctx: &DeviceCtx<'_>) -> String {
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
}
