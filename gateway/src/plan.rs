//! The resolved fleet the runtime starts: what a validated profile turns into. Kept separate
//! from the profile schema (user-facing, layered, validated) so the runtime only ever sees
//! complete, typed values.

use std::time::Duration;

use std::sync::Arc;

use handgate_adapters::device::Backend;
use handgate_adapters::kind::KindConfigBox;
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::model::{DeviceKind, SafeAction, Side};
use handgate_adapters::open::{DeviceSpec, EmulatorSection};

pub use handgate_adapters::front::kind::FrontKind;

/// One device: everything its kind needs to open it, decided here once.
#[derive(Debug, Clone, PartialEq)]
pub struct DevicePlan {
    pub name: String,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    /// The device's table: its kind's, with the profile's limits, step limit and closure.
    pub table: Arc<DeviceTable>,
    pub rate_hz: f64,
    /// A client of a DDS service publishes commands on arrival (`[[devices]] forward_on_arrival`).
    pub forward_on_arrival: bool,
    /// `[[devices]] max_send_hz` (`None`: four times the loop rate).
    pub max_send_hz: Option<f64>,
    pub stale_after: Duration,
    pub safe_action: SafeAction,
    /// `[devices.emulator]` (defaults when absent).
    pub emulator: EmulatorSection,
    /// The kind's own profile keys.
    pub config: KindConfigBox,
}

impl DevicePlan {
    /// What the device's kind opens it from.
    pub fn spec(&self) -> DeviceSpec<'_> {
        DeviceSpec {
            name: &self.name,
            kind: self.kind,
            side: self.side,
            backend: self.backend,
            rate_hz: self.rate_hz,
            stale_after: self.stale_after,
            forward_on_arrival: self.forward_on_arrival,
            max_send_hz: self.max_send_hz,
            table: &self.table,
            emulator: &self.emulator,
            config: &*self.config,
        }
    }
}

pub use handgate_adapters::front::plan::{Binding, FrontPlan, PlanTopic, SilencePlan};

/// The gateway's own recording (`[record]`).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordPlan {
    /// The recording directory of this start (`DIR/<profile>_<unix seconds>`).
    pub dir: std::path::PathBuf,
    pub topics: Vec<String>,
    pub max_mb: Option<f64>,
    pub max_seconds: Option<f64>,
    pub zstd: bool,
}

/// The gateway's HTTP server (`[http]`).
#[derive(Debug, Clone, PartialEq)]
pub struct HttpPlan {
    pub addr: std::net::SocketAddr,
    /// The page may command devices: `[http] commands = true` and a token configured.
    pub commands: bool,
    /// `[http] commands = true` without a token: commands stay off (logged at start).
    pub commands_need_token: bool,
    /// `[http] token_file`: read at bind time; every request must present its token.
    pub token_file: Option<std::path::PathBuf>,
    pub sample_hz: f64,
    pub command_watchdog: Duration,
    /// `[http] allowed_hosts`: names and addresses a request's `Host` may name besides the
    /// loopback ones and the address the connection reached.
    pub allowed_hosts: Vec<crate::http::host::Host>,
    /// `[http] fleet_domains`: the lab's domains the fleet page looks on (empty: no page).
    pub fleet_domains: Vec<u32>,
}

/// The gateway's Foxglove WebSocket live server (`[foxglove]`, docs/foxglove.md).
#[derive(Debug, Clone, PartialEq)]
pub struct FoxglovePlan {
    pub addr: std::net::SocketAddr,
    /// Topic globs; empty: the state topics and status.
    pub topics: Vec<String>,
    /// The profile has a `[foxglove]` section: a server that cannot listen stops the start.
    /// Without one (the defaults), it is a warning and the gateway runs without it (a second
    /// gateway on the machine, a test's gateways).
    pub required: bool,
}

/// The clients' side of a gateway whose devices are on another DDS domain (`[export]`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportPlan {
    pub domain: u32,
    pub interface: Option<String>,
    /// `[export.security]`: the identity the clients' side joins with (DDS Security).
    pub security: Option<handgate_adapters::dds_security::Security>,
}

impl Plan {
    /// The clients' side, where the fronts, status and ROS node are: `[export]`'s domain and
    /// interface, else the devices'.
    pub fn clients_side(&self) -> (u32, Option<&str>) {
        match &self.export {
            Some(e) => (e.domain, e.interface.as_deref()),
            None => (self.domain, self.interface.as_deref()),
        }
    }
}

/// The whole fleet.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub profile: String,
    pub domain: u32,
    pub interface: Option<String>,
    /// `[dds.security]`: the identity the devices' side joins with (DDS Security).
    pub security: Option<handgate_adapters::dds_security::Security>,
    pub status_topic: String,
    pub status_hz: f64,
    /// Start-up: another process already writing a front's state topic refuses the start or
    /// is a warning (`dds.foreign_state_writers`).
    pub foreign_state_writers: crate::profile::ForeignStateWriters,
    /// Start-up: how long discovery must stay unchanged to count as settled, and the most
    /// the start waits for it (`dds.discovery_settle_ms`, `dds.discovery_max_wait_ms`).
    pub discovery_settle: Duration,
    pub discovery_max_wait: Duration,
    /// Announce handgate as a ROS node in this namespace (`[dds] ros_node`); `None`: not.
    pub namespace: Option<handgate_adapters::ros::Namespace>,
    /// `export.allow_commands_from`: the only hosts whose commands the fronts take (`None`:
    /// anyone's).
    pub allow_sources: Option<handgate_adapters::front::sources::Sources>,
    /// The namespace of handgate's own topics (status, canonical, `rt/joint_states`).
    pub own_namespace: handgate_adapters::ros::Namespace,
    /// `[export]` on a domain of its own: the second participant, which the fronts, status,
    /// the ROS node, the recorder and the live server use; `None`: everything on the devices'
    /// participant (`domain`, `interface`).
    pub export: Option<ExportPlan>,
    /// `[record]`: record from start-up.
    pub record: Option<RecordPlan>,
    /// `[http]`; `None`: off.
    pub http: Option<HttpPlan>,
    /// `[foxglove]`; `None`: off (or not built in).
    pub foxglove: Option<FoxglovePlan>,
    /// `[realtime]`: what the device-loop threads run with (default: unchanged).
    pub realtime: handgate_adapters::realtime::Settings,
    /// `[realtime] loop_threads`: threads the DDS-client device loops share (0: one each).
    pub loop_threads: usize,
    pub devices: Vec<DevicePlan>,
    pub fronts: Vec<FrontPlan>,
}
