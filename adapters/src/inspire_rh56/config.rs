//! An RH56 hand's own profile keys (`[devices.inspire_rh56]`: the RS-485 line, the hand's id,
//! the settings written at start) and their rules.

use serde::{Deserialize, Serialize};

use crate::kind::{DeviceCtx, Problem, Settings};

/// Baud rates the RH56 takes (BAUD_RATE register, manual V1.09: 115200 default, 57600, 19200,
/// 921600), those the serial transport can set.
pub const RH56_BAUDS: &[u32] = &[19_200, 57_600, 115_200];

/// How the hand is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Protocol {
    /// The hand's own serial protocol (`EB 90 ...`) on RS-485.
    #[default]
    Serial,
    /// Modbus RTU on RS-485.
    ModbusRtu,
    /// Modbus TCP (the RH56DFTP's Ethernet port, 6000): `port` is `host:port`.
    ModbusTcp,
}

/// `[devices.inspire_rh56]`: an RH56 hand on an RS-485 line (or the DFTP's Ethernet port).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rh56Config {
    pub protocol: Protocol,
    /// The serial port of the line (an emulated line is keyed by it too); over Modbus TCP the
    /// hand's `host:port` (e.g. 192.168.11.210:6000).
    pub port: String,
    pub baud: u32,
    /// The hand's id on the line (HAND_ID, 1..=254; 1 by default, the second hand 2).
    pub id: u8,
    /// FORCE_SET written to every finger at start (0..1000, grams); absent: the hand's own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub force_set: Option<i16>,
    /// SPEED_SET written to every finger at start (0..1000); absent: the hand's own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_set: Option<i16>,
    /// Grace for a reply beyond its wire time, ms (turnaround, USB adapter latency).
    pub response_timeout_ms: u64,
    /// Force, status, error and temperature are read every this many rounds (angles every round).
    pub slow_every: u32,
    /// A DFTP: read its 1062 tactile cells, one of 11 batches a round, into the state's pads.
    pub tactile: bool,
}

impl Default for Rh56Config {
    fn default() -> Self {
        Rh56Config {
            port: "/dev/ttyUSB0".into(),
            baud: 115_200,
            id: 1,
            force_set: None,
            speed_set: None,
            protocol: Protocol::Serial,
            response_timeout_ms: 20,
            slow_every: 10,
            tactile: false,
        }
    }
}

/// An RH56's own profile keys.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Rh56Profile {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inspire_rh56: Option<Rh56Config>,
}

impl Rh56Profile {
    /// `[devices.inspire_rh56]` with its defaults.
    pub fn section(&self) -> Rh56Config {
        self.inspire_rh56.clone().unwrap_or_default()
    }
}

impl Settings for Rh56Profile {
    fn check(&self, _ctx: &DeviceCtx<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        let Some(c) = &self.inspire_rh56 else { return out };
        let key = |k: &'static str| ["inspire_rh56", k];
        if c.port.trim().is_empty() {
            out.push(Problem::new(&key("port"), "must name a serial port, e.g. /dev/ttyUSB0"));
        }
        if c.protocol == Protocol::ModbusTcp && c.port.parse::<std::net::SocketAddr>().is_err() {
            out.push(Problem::new(
                &key("port"),
                format!(
                    "`{}` is not the hand's host:port for protocol modbus_tcp, e.g. 192.168.11.210:6000",
                    c.port
                ),
            ));
        }
        if !RH56_BAUDS.contains(&c.baud) {
            let v: Vec<String> = RH56_BAUDS.iter().map(|b| b.to_string()).collect();
            out.push(Problem::new(
                &key("baud"),
                format!(
                    "{} is not an RH56 baud rate handgate can set ({})",
                    c.baud,
                    v.join(", ")
                ),
            ));
        }
        if c.id == 0 || c.id == 255 {
            out.push(Problem::new(
                &key("id"),
                format!("must be between 1 and 254, got {}", c.id),
            ));
        }
        for (k, v) in [("force_set", c.force_set), ("speed_set", c.speed_set)] {
            if let Some(v) = v {
                if !(0..=1000).contains(&v) {
                    out.push(Problem::new(&key(k), format!("must be between 0 and 1000, got {v}")));
                }
            }
        }
        if !(1..=1000).contains(&c.response_timeout_ms) {
            out.push(Problem::new(
                &key("response_timeout_ms"),
                format!("must be between 1 and 1000 ms, got {}", c.response_timeout_ms),
            ));
        }
        if c.slow_every == 0 {
            out.push(Problem::new(&key("slow_every"), "must be at least 1 (every round)"));
        }
        out
    }

    fn summary(&self, _ctx: &DeviceCtx<'_>) -> String {
        match &self.inspire_rh56 {
            Some(c) if c.protocol == Protocol::ModbusTcp => format!(", Modbus TCP {} unit {}", c.port, c.id),
            Some(c) => format!(
                ", {} @ {} baud id {}{}",
                c.port,
                c.baud,
                c.id,
                if c.protocol == Protocol::ModbusRtu {
                    " (Modbus RTU)"
                } else {
                    ""
                }
            ),
            None => String::new(),
        }
    }
}
