//! The `HandDevice` trait every adapter implements, and what it reports.

use std::sync::Arc;

use async_trait::async_trait;
use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use crate::dds::DdsError;
use crate::emu_common::EmulatorError;
use crate::mapping::{DeviceTable, MappingError};
use crate::model::{DeviceKind, HandCommand, HandState, SafeAction, Side};

/// How the device is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// Dex3-1 USB bulk protocol.
    Usb,
    /// DDS, as a client of a service that owns the device.
    Dds,
    /// A serial bus in the kind's own protocol (Dynamixel, Modbus RTU, a vendor's frames), or
    /// its forwarder over TCP.
    Serial,
    /// An emulated device at the transport seam.
    #[default]
    Emulator,
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Backend {
    pub const ALL: [Backend; 4] = [Backend::Usb, Backend::Dds, Backend::Serial, Backend::Emulator];

    pub fn as_str(self) -> &'static str {
        match self {
            Backend::Usb => "usb",
            Backend::Dds => "dds",
            Backend::Serial => "serial",
            Backend::Emulator => "emulator",
        }
    }
}

/// Identity of a device.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    /// Unique name from the profile.
    pub name: String,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    pub table: Arc<DeviceTable>,
}

/// Counters a device keeps; read by the status publisher, never blocking the device loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DeviceStats {
    /// Commands accepted by [`HandDevice::command`].
    pub commands: u64,
    /// Commands rejected (mapping errors: non-finite values, unknown joints).
    pub rejected: u64,
    /// Commands written to the device (wire frames / samples).
    pub sent: u64,
    /// Measured state samples received.
    pub state_samples: u64,
    pub crc_errors: u64,
    pub reconnects: u64,
    pub missed_cycles: u64,
    /// Setpoints replaced by a hold at the measured position after the link came back.
    pub reseeds: u64,
    pub link_up: bool,
    /// Device-loop iterations so far (a loop that stops counting is hung).
    pub cycles: u64,
    /// The device loop's periods (`/metrics`).
    pub periods: crate::control::PeriodBuckets,
    /// Times the device's published state went from fresh to stale (a link loss, a missed
    /// reply past the stale bound, a peer that fell silent), whatever the kind.
    pub stale_events: u64,
}

/// Device errors. A link failure says whether the link may recover by itself (an unplug, a
/// missed reply: [`DeviceError::transient`]) or needs the setup changed ([`DeviceError::link`]).
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error(transparent)]
    Mapping(#[from] MappingError),
    #[error("{0} is not supported by this device")]
    Unsupported(&'static str),
    #[error("DDS: {0}")]
    Dds(#[from] DdsError),
    #[error("emulator: {0}")]
    Emulator(#[from] EmulatorError),
    /// The link to the device (a transport, a bus) failed.
    #[error("link to the device failed: {source}")]
    Link {
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
        /// The link may come back by itself (reconnect, retry).
        transient: bool,
    },
    /// A validated profile asks for something this device cannot take.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// A configuration value the device cannot take (the value's own error).
    #[error("invalid configuration: {source}")]
    Invalid {
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error("safe state not confirmed within {0:?}")]
    NotConfirmed(std::time::Duration),
    #[error("the device has stopped")]
    Stopped,
}

impl DeviceError {
    /// A link failure that needs the setup changed (wrong port, permissions...).
    pub fn link(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        DeviceError::Link {
            source: Box::new(e),
            transient: false,
        }
    }

    /// A link failure the device may recover from by itself.
    pub fn transient(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        DeviceError::Link {
            source: Box::new(e),
            transient: true,
        }
    }

    /// A configuration value the device cannot take, with the value's own error.
    pub fn config(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        DeviceError::Invalid { source: Box::new(e) }
    }
}

/// One hand or gripper, whatever its transport.
///
/// Commands are canonical ([`HandCommand`]); the device keeps only the latest (never a
/// queue), maps it through its [`DeviceTable`], clamps it against its limits and the
/// measured state, and sends it at its own rate. State is published on a watch channel.
#[async_trait]
pub trait HandDevice: Send + Sync {
    fn info(&self) -> &DeviceInfo;

    /// Replaces the pending command (latest wins). Returns an error, and changes nothing,
    /// when the command cannot be mapped safely (checked here, against the device's table).
    fn command(&self, cmd: HandCommand) -> Result<(), DeviceError>;

    /// Replaces the pending command with one already checked against this device's table
    /// (a front checks each command it routes once: `DeviceTable::checked`); devices take it
    /// without checking again. The default re-checks through [`Self::command`].
    fn command_checked(&self, seq: u64, body: crate::mapping::CheckedBody, tag: u32) -> Result<(), DeviceError> {
        self.command(HandCommand {
            seq,
            body: body.into_body(),
            tag,
        })
    }

    /// The latest canonical state.
    fn state(&self) -> watch::Receiver<HandState>;

    /// Who is told of each state as the device loop publishes it, on the loop's own thread
    /// ([`StateTaps`]); `None`: the device offers none, and readers wait on [`Self::state`].
    fn state_taps(&self) -> Option<&StateTaps> {
        None
    }

    /// The joint positions in force (canonical, the table's joint order): what the device is
    /// commanded to, after clamps and per-step limits; `None` while nothing was commanded.
    fn commanded(&self) -> Option<Vec<f32>> {
        None
    }

    /// Moves to a safe state and stays there until the next command.
    async fn safe_state(&self, action: SafeAction) -> Result<(), DeviceError>;

    /// Counters.
    fn stats(&self) -> DeviceStats {
        DeviceStats::default()
    }

    /// Wiring discovery, when the device can report the (bus, id) slots it answers from.
    fn discovery(&self) -> Option<&dyn Discover> {
        None
    }

    /// Calibration, when the device has one.
    fn calibration(&self) -> Option<&dyn Calibrate> {
        None
    }

    /// Safe state, then release the transport. Called once at gateway shutdown.
    async fn shutdown(&self, action: SafeAction) -> Result<(), DeviceError> {
        self.safe_state(action).await
    }
}

/// A function told of every state a device publishes ([`StateTaps`]).
pub type StateTap = Box<dyn Fn(&HandState) + Send + Sync>;

/// What a device loop tells of each state it publishes, on its own thread, right after the
/// state went into the device's watch channel: a front publishes the state reflecting a
/// command from where it was measured, with no thread hand-off (docs/fronts.md, "Latency").
/// A tap must not block, must not command the device it is told of while it runs, and must
/// not borrow that device's state channel (the state it is given is that channel's, borrowed
/// for the call).
#[derive(Default)]
pub struct StateTaps {
    taps: std::sync::RwLock<Vec<StateTap>>,
    any: std::sync::atomic::AtomicBool,
}

impl StateTaps {
    /// Tells `tap` of every state from now on (taps live as long as the device).
    pub fn add(&self, tap: StateTap) {
        self.taps.write().unwrap_or_else(|p| p.into_inner()).push(tap);
        self.any.store(true, std::sync::atomic::Ordering::Release);
    }

    /// Tells every tap of `st` (the device loop calls it on each state it published; with no
    /// tap it costs one atomic load).
    pub fn run(&self, st: &HandState) {
        if !self.any.load(std::sync::atomic::Ordering::Acquire) {
            return;
        }
        for tap in self.taps.read().unwrap_or_else(|p| p.into_inner()).iter() {
            tap(st);
        }
    }
}

impl std::fmt::Debug for StateTaps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.taps.read().map(|t| t.len()).unwrap_or(0);
        f.debug_struct("StateTaps").field("taps", &n).finish()
    }
}

/// An optional ability: reporting the wiring a device answers from (a profile snippet).
#[async_trait]
pub trait Discover: Send + Sync {
    async fn discover(&self) -> Result<String, DeviceError>;
}

/// An optional ability: running the device's calibration; returns what it found (for the
/// profile).
#[async_trait]
pub trait Calibrate: Send + Sync {
    async fn calibrate(&self) -> Result<String, DeviceError>;
}
