//! The typed profile: what a TOML profile file deserializes into.
//!
//! Every struct denies unknown keys and has a `Default`. Values whose default depends on
//! other keys (a device's rate depends on its kind and backend, a front's topics on its
//! kind, side and variant) are `Option`s here and resolved by the methods below, so the
//! runtime asks the config instead of re-deriving the rules.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

/// Highest DDS domain id the standard RTPS port mapping allows (7400 + 250 * 232 + 1 < 65535).
pub const MAX_DOMAIN_ID: u32 = 232;
/// Highest status publish rate, Hz (the status topic is a slow heartbeat).
pub const MAX_STATUS_RATE_HZ: f64 = 10.0;
/// Highest `http.sample_hz` (a browser draws at 60 Hz at best).
pub const MAX_HTTP_SAMPLE_HZ: f64 = 200.0;
/// Range of `http.command_watchdog_ms` (the page re-sends every 100 ms).
pub const MIN_PAGE_WATCHDOG_MS: u32 = 200;
pub const MAX_PAGE_WATCHDOG_MS: u32 = 10_000;
/// Watchdog timeouts must lie in this range, ms.
pub const WATCHDOG_MS_RANGE: (u32, u32) = (10, 10_000);
/// A front's `max_command_age_ms` must lie in this range, ms.
pub const MAX_COMMAND_AGE_MS_RANGE: (u32, u32) = (1, 60_000);

/// A DDS domain id (0..=232).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct DomainId(pub u32);

pub use handgate_adapters::units::{DeviceName, Millis, Radians, RateHz, Topic};

pub use handgate_adapters::device::Backend;
pub use handgate_adapters::kind::{DeviceCtx, KindConfigBox, Problem, MAX_RATE_HZ};
pub use handgate_adapters::model::{DeviceKind, SafeAction, Side};

use figment::value::{Dict, Value};

macro_rules! snake_enum {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident => $s:literal),+ $(,)? } default $d:ident) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum $name { $($(#[$vm])* $v),+ }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$v),+];
            /// The spelling used in profile files.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$v => $s),+ }
            }
        }

        impl Default for $name {
            fn default() -> Self { $name::$d }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

snake_enum!(
    /// How log lines are printed.
    LogFormat { Human => "human", Json => "json" } default Human
);

snake_enum!(
    /// What `handgate run` does when another process already writes a state topic one of its
    /// fronts would write (another service for the same hand, a second handgate).
    ForeignStateWriters {
        /// Refuse to start, naming the topic and the other process.
        Refuse => "refuse",
        /// Start anyway; log a warning and flag it in status.
        Warn => "warn",
    } default Refuse
);

pub use handgate_adapters::front::config::{Control, Silence};
pub use handgate_adapters::ros::Namespace;

/// Which interface a front serves to clients: a handle into the front registry.
pub use handgate_adapters::front::kind::FrontKind;

/// The whole profile.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Profile {
    /// Short name, shown by `handgate check`.
    pub name: String,
    /// One line saying what setup this profile is for.
    pub description: String,
    pub dds: DdsConfig,
    /// `[export]`: the fronts, status, `rt/joint_states` and the ROS node on a second DDS
    /// participant (the lab's network) while the devices stay on `[dds]` (the robot's);
    /// `None`: one participant (docs/deployment.md, "A lab of robots").
    pub export: Option<ExportConfig>,
    pub log: LogConfig,
    pub status: StatusConfig,
    /// `[record]`: record from start-up (docs/recording.md).
    pub record: Option<RecordConfig>,
    /// `[http]`: the dashboard, `/metrics`, `/healthz` (docs/dashboard.md).
    pub http: HttpConfig,
    /// `[foxglove]`: the Foxglove WebSocket live server (docs/foxglove.md); `None`: the
    /// section is absent (the server runs with its defaults when handgate is built with it).
    pub foxglove: Option<FoxgloveConfig>,
    /// `[realtime]`: scheduling, CPU affinity and memory locking of the device loops
    /// (docs/deployment.md, "Real-time"); the defaults change nothing.
    pub realtime: RealtimeConfig,
    pub devices: Vec<DeviceConfig>,
    pub fronts: Vec<FrontConfig>,
}

/// The profile as deserialized: each `[[devices]]` and `[[fronts]]` table still a raw value,
/// parsed by [`DeviceConfig::from_value`] and [`FrontConfig::from_value`] (its common keys,
/// then its kind's own).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawProfile {
    pub name: String,
    pub description: String,
    pub dds: DdsConfig,
    pub export: Option<ExportConfig>,
    pub log: LogConfig,
    pub status: StatusConfig,
    pub record: Option<RecordConfig>,
    pub http: HttpConfig,
    pub foxglove: Option<FoxgloveConfig>,
    pub realtime: RealtimeConfig,
    pub devices: Vec<Value>,
    pub fronts: Vec<Value>,
}

impl Profile {
    /// The devices a state-only front publishes, or a front binding a list of devices
    /// (`FrontFacts::binds_list`) drives, in its order: `devices = [..]` (each once; a name no
    /// device has is left out, validation reports it), else `device`, else every device.
    pub fn published_devices(&self, f: &FrontConfig) -> Vec<&DeviceConfig> {
        let by_name = |n: &DeviceName| self.devices.iter().find(|d| &d.name == n);
        match (f.devices.as_ref().and_then(|d| d.list()), &f.device) {
            (Some(list), _) => {
                let mut out: Vec<&DeviceConfig> = Vec::new();
                for d in list.iter().filter_map(by_name) {
                    if !out.iter().any(|o| o.name == d.name) {
                        out.push(d);
                    }
                }
                out
            }
            (None, Some(n)) => by_name(n).into_iter().collect(),
            (None, None) => self.devices.iter().collect(),
        }
    }

    /// The devices front `f` drives, with the side whose wire convention each is served in:
    /// a front binding a list of devices (`FrontFacts::binds_list`) drives each listed device
    /// (or every device) on its own side; any other front, its `bindings`. Empty for a front
    /// taking no commands.
    pub fn front_bindings<'a>(&'a self, f: &'a FrontConfig) -> Vec<(Side, &'a DeviceName)> {
        if !f.kind().takes_commands() {
            return vec![];
        }
        if f.kind().factory().facts().binds_list {
            return self
                .published_devices(f)
                .into_iter()
                .map(|d| (d.side, &d.name))
                .collect();
        }
        f.bindings(|n| self.devices.iter().find(|d| &d.name == n))
    }

    /// The namespace of handgate's own topics and ROS node: `export.namespace`, else
    /// `dds.namespace` (validation refuses both), else the root.
    pub fn namespace(&self) -> Namespace {
        match self.export.as_ref().and_then(|e| e.namespace.as_deref()) {
            Some(n) => Namespace::parse(n).unwrap_or_default(),
            None => self.dds.namespace(),
        }
    }

    /// `[export]`'s domain and interface with their defaults (`[dds]`'s); `None` without it.
    pub fn export_target(&self) -> Option<(DomainId, Option<&str>)> {
        let e = self.export.as_ref()?;
        let interface = e.interface.as_deref().or(self.dds.interface.as_deref());
        Some((e.domain.unwrap_or(self.dds.domain), interface))
    }

    /// The export side: its domain and interface when it is a second participant (another
    /// domain id than `[dds]`'s); `None` when everything runs on the devices' participant
    /// (no `[export]`, or one that sets only the namespace).
    pub fn export_side(&self) -> Option<(DomainId, Option<String>)> {
        let (domain, interface) = self.export_target()?;
        (domain != self.dds.domain).then(|| (domain, interface.map(str::to_string)))
    }

    /// Front `f`'s topics and rates (`device`: its bound device), with handgate's own
    /// interfaces' topics in the profile's namespace (`FrontFacts::in_namespace`), and every
    /// front's with `export.namespace_fronts`.
    pub fn front_topics(&self, f: &FrontConfig, device: Option<&DeviceConfig>) -> FrontTopics {
        let mut t = f.topics(device);
        let every = self.export.as_ref().is_some_and(|e| e.namespace_fronts);
        if every || f.kind().factory().facts().in_namespace {
            let ns = self.namespace();
            for x in t.topics.iter_mut().filter_map(|t| t.topic.as_mut()) {
                *x = Topic(ns.topic(x.as_str()));
            }
        }
        t
    }

    /// The status topic, in the profile's namespace.
    pub fn status_topic(&self) -> Topic {
        Topic(self.namespace().topic(self.status.topic.as_str()))
    }

    /// The `[foxglove]` settings in force: the section, or its defaults when absent.
    pub fn foxglove(&self) -> FoxgloveConfig {
        self.foxglove.clone().unwrap_or_default()
    }

    /// Whether `handgate run` serves Foxglove: built with the `foxglove` feature and not
    /// `enabled = false`.
    pub fn foxglove_enabled(&self) -> bool {
        cfg!(feature = "foxglove") && self.foxglove().enabled.unwrap_or(true)
    }
}

impl RawProfile {
    /// The profile with its devices and fronts parsed.
    pub fn into_profile(self, devices: Vec<DeviceConfig>, fronts: Vec<FrontConfig>) -> Profile {
        Profile {
            name: self.name,
            description: self.description,
            dds: self.dds,
            export: self.export,
            log: self.log,
            status: self.status,
            record: self.record,
            http: self.http,
            foxglove: self.foxglove,
            realtime: self.realtime,
            devices,
            fronts,
        }
    }
}

/// DDS participant settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DdsConfig {
    pub domain: DomainId,
    /// Network interface to bind, like unitree_sdk2's `ChannelFactoryInitialize(0, "eth0")`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface: Option<String>,
    /// Another process already writing a front's state topic at start-up: refuse or warn.
    pub foreign_state_writers: ForeignStateWriters,
    /// Start-up: discovery counts as settled after this long without a change...
    pub discovery_settle_ms: Millis,
    /// ...or after this long in all, whichever comes first.
    pub discovery_max_wait_ms: Millis,
    /// ROS namespace of handgate's own topics (canonical, joint_state, status) and of its ROS
    /// node: `robot1` makes `rt/joint_states` `rt/robot1/joint_states` (docs/fronts.md, "ROS 2").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub namespace: Option<String>,
    /// Announce handgate as ROS node `<namespace>/handgate` on `ros_discovery_info`.
    pub ros_node: bool,
    /// `[dds.security]`: the devices' participant joins its domain with DDS Security (a
    /// gateway whose devices are DDS clients of another gateway's secured export side: an
    /// operator station, docs/security.md). Off: plain DDS, as a robot's own network is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub security: Option<SecurityConfig>,
}

/// `[dds.security]` / `[export.security]`: the identity a participant joins a secured domain
/// with (docs/security.md). Either `enclave`, a directory in the SROS2 keystore layout
/// (`handgate security issue` or `ros2 security create_enclave` writes one), or each file;
/// a file given beside `enclave` replaces the enclave's.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SecurityConfig {
    /// `<keystore>/enclaves/<name>`: `identity_ca.cert.pem`, `cert.pem`, `key.pem`,
    /// `permissions_ca.cert.pem`, `governance.p7s`, `permissions.p7s`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub enclave: Option<String>,
    /// The identity CA's certificate (PEM).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identity_ca: Option<String>,
    /// This gateway's certificate (PEM), issued by the identity CA.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub certificate: Option<String>,
    /// Its private key (PEM, unencrypted; readable by handgate only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub private_key: Option<String>,
    /// The permissions CA's certificate (PEM): it signed the governance and the permissions.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub permissions_ca: Option<String>,
    /// The domain's governance document, signed (S/MIME, `.p7s`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub governance: Option<String>,
    /// This identity's permissions document, signed (S/MIME, `.p7s`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub permissions: Option<String>,
    /// The identity CA's certificate revocation list (PEM; `handgate security revoke`
    /// writes `<keystore>/public/crl.pem`): a listed identity is refused.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crl: Option<String>,
}

impl SecurityConfig {
    /// The identity's files, each from its own key or else from the enclave; the key of the
    /// first one missing when neither gives it.
    pub fn resolve(&self) -> Result<handgate_adapters::dds_security::Security, &'static str> {
        use handgate_adapters::dds_security::ENCLAVE_FILES;
        let enclave = self.enclave.as_deref().map(std::path::Path::new);
        let pick = |i: usize| -> Result<std::path::PathBuf, &'static str> {
            let (role, file) = ENCLAVE_FILES[i];
            match (self.own(role), enclave) {
                (Some(p), _) => Ok(p.into()),
                (None, Some(dir)) => Ok(dir.join(file)),
                (None, None) => Err(role),
            }
        };
        Ok(handgate_adapters::dds_security::Security {
            identity_ca: pick(0)?,
            certificate: pick(1)?,
            private_key: pick(2)?,
            permissions_ca: pick(3)?,
            governance: pick(4)?,
            permissions: pick(5)?,
            crl: self.crl.as_ref().map(Into::into),
        })
    }

    /// The path the profile gives under its own key for the file `role`
    /// ([`handgate_adapters::dds_security::Security::files`]' names); `None`: not given (the
    /// enclave's, if any, is used).
    pub fn own(&self, role: &str) -> Option<&str> {
        match role {
            "identity_ca" => self.identity_ca.as_deref(),
            "certificate" => self.certificate.as_deref(),
            "private_key" => self.private_key.as_deref(),
            "permissions_ca" => self.permissions_ca.as_deref(),
            "governance" => self.governance.as_deref(),
            "permissions" => self.permissions.as_deref(),
            "crl" => self.crl.as_deref(),
            _ => None,
        }
    }
}

impl DdsConfig {
    /// The namespace (validated by `handgate check`; the root namespace when absent).
    pub fn namespace(&self) -> Namespace {
        self.namespace
            .as_deref()
            .and_then(|n| Namespace::parse(n).ok())
            .unwrap_or_default()
    }
}

impl Default for DdsConfig {
    /// Domain 1, as Unitree's simulators use, so a default run cannot move a robot on 0.
    fn default() -> Self {
        DdsConfig {
            domain: DomainId(1),
            interface: None,
            foreign_state_writers: ForeignStateWriters::default(),
            discovery_settle_ms: Millis(DEFAULT_DISCOVERY_SETTLE_MS),
            discovery_max_wait_ms: Millis(DEFAULT_DISCOVERY_MAX_WAIT_MS),
            namespace: None,
            ros_node: true,
            security: None,
        }
    }
}

/// `[export]`: where handgate serves its clients when that is not where its devices are (a
/// robot PC's second network interface on the lab's network, another DDS domain per robot).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExportConfig {
    /// The clients' DDS domain (default: `dds.domain`, which makes `[export]` a namespace only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub domain: Option<DomainId>,
    /// The clients' network interface (default: `dds.interface`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interface: Option<String>,
    /// ROS namespace of handgate's own topics (canonical, `rt/joint_states`, status) and of
    /// its ROS node, as `dds.namespace` (one of the two).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub namespace: Option<String>,
    /// Also prefix the device-compatible fronts' topics (`rt/dex3/left/cmd` becomes
    /// `rt/<namespace>/dex3/left/cmd`): off by default, since unmodified clients use the
    /// standard names and pick the robot by domain.
    pub namespace_fronts: bool,
    /// Who may command the fronts: addresses or `ADDRESS/PREFIX` networks of the clients'
    /// hosts (empty: anyone on the network). A command from a participant with no address in
    /// the list is refused and counted; states still flow.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub allow_commands_from: Vec<String>,
    /// `[export.security]`: the clients' side joins its domain with DDS Security, refusing
    /// every participant without an identity of the lab's CA whose permissions grant it
    /// (docs/security.md). The devices' side (`[dds]`) stays plain.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub security: Option<SecurityConfig>,
}

/// Default `dds.discovery_settle_ms`.
pub const DEFAULT_DISCOVERY_SETTLE_MS: u32 = 100;
/// Default `dds.discovery_max_wait_ms`.
pub const DEFAULT_DISCOVERY_MAX_WAIT_MS: u32 = 500;
/// Largest `dds.discovery_max_wait_ms`.
pub const MAX_DISCOVERY_WAIT_MS: u32 = 10_000;

/// Logging.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LogConfig {
    pub format: LogFormat,
    /// A tracing `EnvFilter` directive: `info`, `debug`, `handgate=debug,warn`, ...
    pub level: String,
}

impl Default for LogConfig {
    fn default() -> Self {
        LogConfig {
            format: LogFormat::Human,
            level: "info".into(),
        }
    }
}

/// Default `status.topic`, and the topic `handgate status` reads by default.
pub const DEFAULT_STATUS_TOPIC: &str = "rt/handgate/status";

/// The gateway's own status heartbeat.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StatusConfig {
    pub topic: Topic,
    pub rate_hz: RateHz,
}

impl Default for StatusConfig {
    fn default() -> Self {
        StatusConfig {
            topic: Topic::new(DEFAULT_STATUS_TOPIC),
            rate_hz: RateHz(1.0),
        }
    }
}

/// `[record]`: the gateway records its topics from start-up into a new directory
/// `DIR/<profile>_<unix seconds>` (docs/recording.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Directory that receives one recording per gateway start.
    pub dir: String,
    /// Topic globs (DDS or ROS 2 names); empty: every served topic and status.
    pub topics: Vec<String>,
    /// Start a new file after this many MB of messages.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_mb: Option<f64>,
    /// Start a new file after this many seconds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_seconds: Option<f64>,
    /// zstd chunk compression (handgate built with the `zstd` feature).
    pub zstd: bool,
}

impl Default for RecordConfig {
    fn default() -> Self {
        RecordConfig {
            dir: "recordings".into(),
            topics: Vec::new(),
            max_mb: None,
            max_seconds: None,
            zstd: false,
        }
    }
}

/// `[http]`: the gateway's HTTP server: the live dashboard, its WebSocket, `/metrics` and
/// `/healthz` (docs/dashboard.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HttpConfig {
    pub enabled: bool,
    /// Address to bind: loopback unless the profile chooses another (logged at start).
    pub bind: String,
    /// TCP port; 0: any free port (the log names it).
    pub port: u16,
    /// The page may command devices (a closure slider and a safe button per device), through
    /// the same rules as any front. Off: the server accepts no command. Needs `token_file`:
    /// without a token the server accepts no command either (`handgate check` says so).
    pub commands: bool,
    /// A file holding the token every request must present (`Authorization: Bearer`, or the
    /// page's cookie once opened with `?token=`): one line, at least 16 bytes, no access for
    /// group or others. Required when `bind` is not a loopback address (docs/dashboard.md,
    /// "Security").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub token_file: Option<String>,
    /// Joint samples pushed to each page per second.
    pub sample_hz: RateHz,
    /// Commands from the page: after this long without one, the device's safe action.
    pub command_watchdog_ms: Millis,
    /// Host names (or IP addresses) a request's `Host` may name besides `localhost`, the
    /// loopback addresses and the address the connection reached (DNS rebinding:
    /// docs/dashboard.md, "Security").
    pub allowed_hosts: Vec<String>,
    /// The lab's DDS domains whose gateways the fleet page (`/fleet`) lists, `A-B` or `N`
    /// (looked on through the clients' interface); unset: no fleet page.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fleet_domains: Option<String>,
}

/// The dashboard's default port.
pub const HTTP_DEFAULT_PORT: u16 = 8880;

impl Default for HttpConfig {
    fn default() -> Self {
        HttpConfig {
            enabled: true,
            bind: "127.0.0.1".into(),
            port: HTTP_DEFAULT_PORT,
            commands: false,
            token_file: None,
            sample_hz: RateHz(50.0),
            command_watchdog_ms: Millis(500),
            allowed_hosts: Vec::new(),
            fleet_domains: None,
        }
    }
}

/// `[foxglove]`: the Foxglove WebSocket live server (`foxglove.websocket.v1`): the served
/// topics as live channels (ROS 2 names, `cdr` messages, `ros2msg` schemas), for Foxglove and
/// PlotJuggler without ROS (docs/foxglove.md). Needs handgate built with the `foxglove`
/// feature (`make run` builds it so).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FoxgloveConfig {
    /// Serve it; unset: yes when handgate is built with the `foxglove` feature. Without the
    /// feature, a profile that enables it (a `[foxglove]` section not saying `enabled =
    /// false`) is an error naming the build flag.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub enabled: Option<bool>,
    /// Address to listen on: loopback unless the profile chooses another (logged at warn).
    pub bind: String,
    /// TCP port; 0: any free port (the start-up log names it).
    pub port: u16,
    /// Topic globs (DDS or ROS 2 names, as `[record] topics`) over every topic the gateway
    /// serves, commands included; empty: every state topic (each front's state, the canonical
    /// states, `rt/joint_states`, a DDS-client device's robot state) and status, no commands.
    pub topics: Vec<String>,
}

/// The Foxglove WebSocket protocol's customary port (Foxglove's own bridges use it).
pub const FOXGLOVE_DEFAULT_PORT: u16 = 8765;

impl Default for FoxgloveConfig {
    fn default() -> Self {
        FoxgloveConfig {
            enabled: None,
            bind: "127.0.0.1".into(),
            port: FOXGLOVE_DEFAULT_PORT,
            topics: Vec::new(),
        }
    }
}

/// `[realtime]`: how the device-loop threads run (docs/deployment.md, "Real-time"). Opt-in:
/// the defaults leave every thread as the kernel starts it. Applied to the device loops only,
/// never to the tokio workers, the DDS threads or the emulators.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RealtimeConfig {
    /// `other` (default: time-sharing, as without the section), `fifo` or `rr`.
    pub policy: RealtimePolicy,
    /// Real-time priority, 1..=99; required with `fifo` / `rr`, refused with `other`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub priority: Option<u32>,
    /// CPUs the device loops may run on; empty: not pinned.
    pub cpus: Vec<usize>,
    /// Lock the whole process's memory at start (`mlockall(MCL_CURRENT | MCL_FUTURE)`).
    pub mlockall: bool,
    /// Threads the non-blocking device loops (every DDS-client device) share; 0: one thread
    /// per device (docs/deployment.md, "Loop threads").
    pub loop_threads: usize,
}

impl Default for RealtimeConfig {
    fn default() -> Self {
        Self {
            policy: RealtimePolicy::default(),
            priority: None,
            cpus: Vec::new(),
            mlockall: false,
            loop_threads: handgate_adapters::loops::DEFAULT_THREADS,
        }
    }
}

pub use handgate_adapters::realtime::{Policy as RealtimePolicy, PRIORITY_MAX, PRIORITY_MIN};

/// How fast a device loop runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DeviceRate {
    /// A fixed loop rate.
    Hz(RateHz),
    /// As fast as the bus answers (a kind with no default rate: `KindFactory::default_rate_hz`).
    AsFastAsBus,
}

impl fmt::Display for DeviceRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceRate::Hz(r) => r.fmt(f),
            DeviceRate::AsFastAsBus => f.write_str("as fast as the bus"),
        }
    }
}

/// One device of the fleet: the keys every device has, and its kind's own keys
/// ([`DeviceConfig::config`], the kind folder's typed struct: its `[devices.<section>]` tables).
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceConfig {
    pub name: DeviceName,
    pub kind: DeviceKind,
    pub side: Side,
    pub backend: Backend,
    /// Device loop / publish rate; `None` = the kind's default (see [`DeviceConfig::rate`]).
    pub rate_hz: Option<RateHz>,
    /// A client of a DDS service publishes an accepted command at once (default), or only at
    /// its loop's next tick (`false`).
    pub forward_on_arrival: Option<bool>,
    /// The most samples a second such a device publishes to its service, ticks included;
    /// `None` = four times the loop rate.
    pub max_send_hz: Option<RateHz>,
    pub limits: LimitsConfig,
    pub watchdog: WatchdogConfig,
    pub closure: ClosureConfig,
    pub emulator: Option<EmulatorConfig>,
    /// The motion detector's thresholds (`[devices.motion]`; omitted: the kind's table's).
    pub motion: MotionConfig,
    /// The kind's own keys, parsed by the kind (`KindFactory::parse`).
    pub config: KindConfigBox,
    /// Keys this device's table sets that belong to another kind or backend (found while
    /// parsing; `validate` reports them with the other semantic errors).
    pub misplaced: Vec<Problem>,
}

/// The keys every `[[devices]]` table may have; the others are the kind's.
pub const COMMON_DEVICE_KEYS: &[&str] = &[
    "name",
    "kind",
    "side",
    "backend",
    "rate_hz",
    "forward_on_arrival",
    "max_send_hz",
    "limits",
    "watchdog",
    "closure",
    "emulator",
    "motion",
];

/// The common keys as deserialized.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceCommon {
    name: DeviceName,
    kind: DeviceKind,
    side: Side,
    backend: Backend,
    #[serde(default)]
    rate_hz: Option<RateHz>,
    #[serde(default)]
    forward_on_arrival: Option<bool>,
    #[serde(default)]
    max_send_hz: Option<RateHz>,
    #[serde(default)]
    limits: LimitsConfig,
    #[serde(default)]
    watchdog: WatchdogConfig,
    #[serde(default)]
    closure: ClosureConfig,
    #[serde(default)]
    emulator: Option<EmulatorConfig>,
    #[serde(default)]
    motion: MotionConfig,
}

impl Default for DeviceConfig {
    /// An emulated left device called `hand`, of the first registered kind.
    fn default() -> Self {
        let kind = DeviceKind::default();
        DeviceConfig {
            name: DeviceName("hand".into()),
            kind,
            side: Side::Left,
            backend: Backend::Emulator,
            rate_hz: None,
            forward_on_arrival: None,
            max_send_hz: None,
            limits: LimitsConfig::default(),
            watchdog: WatchdogConfig::default(),
            closure: ClosureConfig::default(),
            emulator: None,
            motion: MotionConfig::default(),
            config: KindConfigBox(kind.factory().default_config()),
            misplaced: Vec::new(),
        }
    }
}

/// `"a K1 or K2"`: `kinds` named with one article.
fn kinds_phrase(kinds: &[DeviceKind]) -> String {
    let names: Vec<&str> = kinds.iter().map(|k| k.as_str()).collect();
    handgate_adapters::kind::a(&names.join(" or "))
}

/// Removes the value at `path` from `dict` (nested tables).
fn remove_path(dict: &mut Dict, path: &[String]) {
    match path {
        [] => {}
        [k] => {
            dict.remove(k);
        }
        [k, rest @ ..] => {
            if let Some(Value::Dict(_, d)) = dict.get_mut(k) {
                remove_path(d, rest);
            }
        }
    }
}

/// A table holding only the value at `path` of `dict`.
fn subtree(dict: &Dict, path: &[String]) -> Option<Value> {
    let (k, rest) = path.split_first()?;
    let v = dict.get(k)?;
    let inner = if rest.is_empty() {
        v.clone()
    } else {
        match v {
            Value::Dict(_, d) => subtree(d, rest)?,
            _ => return None,
        }
    };
    let mut out = Dict::new();
    out.insert(k.clone(), inner);
    Some(Value::from(out))
}

impl DeviceConfig {
    /// Parses one `[[devices]]` table: the common keys here, the rest by the device's kind.
    /// Errors keep figment's path (relative to the table). A key that belongs to another
    /// kind or backend is not an error here: it is kept in [`DeviceConfig::misplaced`].
    pub fn from_value(v: &Value) -> Result<Self, Box<figment::Error>> {
        let dict: Dict = v.deserialize().map_err(Box::new)?;
        let (common, mut rest): (Dict, Dict) = dict
            .into_iter()
            .partition(|(k, _)| COMMON_DEVICE_KEYS.contains(&k.as_str()));
        let c: DeviceCommon = Value::from(common).deserialize().map_err(Box::new)?;
        let kind = c.kind;
        let mut misplaced = Vec::new();
        // Sections of another backend of this kind, or of other kinds.
        for key in rest.keys().cloned().collect::<Vec<_>>() {
            if kind
                .factory()
                .sections()
                .iter()
                .any(|s| s.key == key && s.backends.contains(&c.backend))
            {
                continue;
            }
            let owners: Vec<DeviceKind> = DeviceKind::all()
                .iter()
                .copied()
                .filter(|k| k.factory().sections().iter().any(|s| s.key == key))
                .collect();
            if owners.is_empty() {
                continue; // unknown everywhere: the kind's parse reports it
            }
            let backends: Vec<&str> = Backend::ALL
                .iter()
                .filter(|b| {
                    owners.iter().any(|k| {
                        k.factory()
                            .sections()
                            .iter()
                            .any(|s| s.key == key && s.backends.contains(b))
                    })
                })
                .map(|b| b.as_str())
                .collect();
            misplaced.push(Problem::new(
                &[&key],
                format!(
                    "[{key}] applies to {} on backend {}, this is {} on backend {}",
                    kinds_phrase(&owners),
                    backends.join(" or "),
                    handgate_adapters::kind::a(kind.as_str()),
                    c.backend
                ),
            ));
            rest.remove(&key);
        }
        let config = loop {
            let e = match kind.factory().parse(&Value::from(rest.clone())) {
                Ok(cfg) => break cfg,
                Err(e) => e,
            };
            let figment::error::Kind::UnknownField(field, _) = &e.kind else {
                return Err(e);
            };
            let mut path = e.path.clone();
            if path.last() != Some(field) {
                path.push(field.clone());
            }
            if path.len() == 1 {
                let mut keys: Vec<&str> = COMMON_DEVICE_KEYS.to_vec();
                keys.extend(kind.factory().sections().iter().map(|s| s.key));
                return Err(Box::new(
                    figment::Error::from(format!("unknown key (expected one of: {})", keys.join(", ")))
                        .with_path(field),
                ));
            }
            // A key of this kind's section that another kind's section has.
            let owners: Vec<DeviceKind> = subtree(&rest, &path)
                .map(|sub| {
                    DeviceKind::all()
                        .iter()
                        .copied()
                        .filter(|k| *k != kind && k.factory().parse(&sub).is_ok())
                        .collect()
                })
                .unwrap_or_default();
            if owners.is_empty() {
                return Err(e);
            }
            misplaced.push(Problem {
                key: path.clone(),
                message: format!("only {} has `{field}`", kinds_phrase(&owners)),
            });
            remove_path(&mut rest, &path);
        };
        Ok(DeviceConfig {
            name: c.name,
            kind,
            side: c.side,
            backend: c.backend,
            rate_hz: c.rate_hz,
            forward_on_arrival: c.forward_on_arrival,
            max_send_hz: c.max_send_hz,
            limits: c.limits,
            watchdog: c.watchdog,
            closure: c.closure,
            emulator: c.emulator,
            motion: c.motion,
            config: KindConfigBox(config),
            misplaced,
        })
    }

    /// What the kind's own rules see of this device.
    pub fn ctx(&self) -> DeviceCtx<'_> {
        DeviceCtx {
            name: self.name.as_str(),
            side: self.side,
            backend: self.backend,
        }
    }

    /// The device loop rate: `rate_hz` if set, else the kind's default for the backend.
    pub fn rate(&self) -> DeviceRate {
        if let Some(r) = self.rate_hz {
            return DeviceRate::Hz(r);
        }
        match self.kind.factory().default_rate_hz(self.backend) {
            Some(hz) => DeviceRate::Hz(RateHz(hz)),
            None => DeviceRate::AsFastAsBus,
        }
    }

    /// The topics handgate uses to reach a DDS-backed device: (command topic it publishes,
    /// state topic it subscribes). `None` for other backends, or where the default cannot be
    /// derived (side `center` and no override).
    pub fn dds_topics(&self) -> Option<(Option<Topic>, Option<Topic>)> {
        if self.backend != Backend::Dds {
            return None;
        }
        let (cmd, state) = self.config.dds_topics(&self.ctx())?;
        Some((cmd.map(Topic), state.map(Topic)))
    }
}

/// Per-joint limit overrides and the per-command step limit.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest allowed distance, per command, between the commanded and the measured position.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_step: Option<Radians>,
    /// Joint name -> bounds, narrowing the device's hardware range.
    pub joints: BTreeMap<String, JointLimit>,
}

/// Bounds of one joint; an omitted bound keeps the hardware bound.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointLimit {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min: Option<Radians>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max: Option<Radians>,
}

/// `[devices.motion]`: when a device that reports but does not move is reported
/// (docs/adapters.md, "Motion"). Omitted keys keep the kind's table's values (assumptions:
/// docs/profiles.md, "Assumptions").
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionConfig {
    /// An error between the target in force and the measured position above this is a
    /// demand to move, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<Radians>,
    /// How long a demanded joint may make no progress before it is reported, ms.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hold_ms: Option<Millis>,
    /// What shows that a joint stopped short of a closing target holds an object (the kind's
    /// rule when omitted; `effort` needs `contact_effort`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactMode>,
    /// The closing effort from which a joint counts as in contact, in the kind's own effort
    /// unit (N·m; A on a BrainCo; effort % / 10 on an EZGripper).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_effort: Option<f64>,
}

/// `[devices.motion] contact` (docs/adapters.md, "Motion").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactMode {
    /// The joint's effort at least `contact_effort` towards closing.
    Effort,
    /// What the device reports per joint (the Inspire FTP's status and force).
    Reported,
    /// Nothing measured: a closing joint stopped short is taken as holding.
    Unmeasured,
}

/// Device watchdog: what happens when no command arrives in time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WatchdogConfig {
    pub timeout_ms: Millis,
    pub safe_action: SafeAction,
}

impl Default for WatchdogConfig {
    fn default() -> Self {
        WatchdogConfig {
            timeout_ms: Millis(200),
            safe_action: SafeAction::Hold,
        }
    }
}

/// How the scalar "closure" (0 = open, 1 = closed) maps to the device.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClosureConfig {
    /// Kinds whose postures are configurable (`KindFactory::closure_postures_configurable`):
    /// joint -> rad at closure 0 (omitted joints: 0 rad).
    pub open: BTreeMap<String, Radians>,
    /// The same kinds: joint -> rad at closure 1 (omitted joints: the kind table's default
    /// closed posture).
    pub closed: BTreeMap<String, Radians>,
    /// Kinds whose closure is a torque (`closure_is_torque`): feed-forward torque at closure
    /// 0 (negative opens), N*m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tau_open: Option<f64>,
    /// The same kinds: feed-forward torque at closure 1 (positive closes), N*m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tau_closed: Option<f64>,
}

/// Options for an emulated device (`[devices.emulator]`, every kind): the adapters' section.
pub use handgate_adapters::open::EmulatorSection as EmulatorConfig;

pub use handgate_adapters::front::config::{
    ElementDevices, FrontConfig, FrontDevices, FrontTopic, FrontTopics, TopicAt, TopicRole,
};

/// What the profile derives for a front from its bound device (its side, name, topics and
/// rates): the front kind's defaults applied to the device's configuration.
pub trait FrontConfigExt {
    fn served_side(&self, device: Option<&DeviceConfig>) -> Option<Side>;
    fn by_element(&self) -> bool;
    fn bindings<'a>(&'a self, lookup: impl Fn(&DeviceName) -> Option<&'a DeviceConfig>) -> Vec<(Side, &'a DeviceName)>;
    fn display_name(&self, device: Option<&DeviceConfig>) -> String;
    fn topics(&self, device: Option<&DeviceConfig>) -> FrontTopics;
}

impl FrontConfigExt for FrontConfig {
    /// The topic side a front with per-side topics serves: `side` or the bound device's.
    fn served_side(&self, device: Option<&DeviceConfig>) -> Option<Side> {
        self.side().or(device.map(|d| d.side))
    }

    /// A front whose messages carry several devices, bound by element (`devices`: one topic
    /// pair, element 0 right, 1 left; `Front::elements`).
    fn by_element(&self) -> bool {
        self.elements() > 1
    }

    /// The devices this front drives, with the side whose wire convention each is served in:
    /// a by-element front's elements (`devices`, or `device` on the served side), otherwise
    /// `device` on the served side. Names only; `lookup` finds a device's config.
    fn bindings<'a>(&'a self, lookup: impl Fn(&DeviceName) -> Option<&'a DeviceConfig>) -> Vec<(Side, &'a DeviceName)> {
        if let Some(d) = self.devices.as_ref().and_then(|d| d.elements()) {
            return d.bound();
        }
        match &self.device {
            Some(n) => vec![(self.served_side(lookup(n)).unwrap_or_default(), n)],
            None => vec![],
        }
    }

    /// The name logs use: `name`, else derived from what the front serves: an overridden
    /// command topic as it is, else the kind's (`Front::default_name`: e.g. the kind and
    /// the served side). Two fronts cannot derive the same name: they would serve the same
    /// topic.
    fn display_name(&self, device: Option<&DeviceConfig>) -> String {
        if let Some(n) = &self.name {
            return n.clone();
        }
        let lr = self.served_side(device).filter(|s| *s != Side::Center);
        let at = TopicAt { side: lr, device: "" };
        let cmd_set = self
            .kind_topics(&at)
            .into_iter()
            .find(|t| t.role == TopicRole::Command && t.set);
        if let Some(t) = cmd_set.and_then(|t| t.topic) {
            return t.0;
        }
        let side = self.served_side(device).map_or("?", |s| s.as_str());
        self.default_name(side)
    }

    /// Topics and rates with defaults applied. `device` is the bound device (`None` for a
    /// state-only front over every device). A default that cannot be derived (per-side
    /// topics for a device of side `center`) is `None`; validation reports it.
    fn topics(&self, device: Option<&DeviceConfig>) -> FrontTopics {
        // Left/right: the standard topics are per side.
        let at = TopicAt {
            side: self.served_side(device).filter(|s| *s != Side::Center),
            device: device.map(|d| d.name.as_str()).unwrap_or("all"),
        };
        let device_hz = device.and_then(|d| match d.rate() {
            DeviceRate::Hz(r) => Some(r.0),
            DeviceRate::AsFastAsBus => None,
        });
        FrontTopics {
            topics: self.kind_topics(&at),
            state_hz: self
                .state_hz
                .unwrap_or(RateHz(self.kind().factory().default_state_hz(device_hz))),
            lf_state_hz: self.lf_state_hz().map(RateHz),
        }
    }
}
