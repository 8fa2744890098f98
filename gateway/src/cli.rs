//! Command line.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::profile::{CliOverrides, LogFormat};

#[derive(Debug, Parser)]
#[command(
    name = "handgate",
    version,
    about = "One gateway for a mixed fleet of robot hands and grippers"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the gateway.
    Run {
        #[command(flatten)]
        profile: ProfileArg,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
    /// Validate a profile and print the resolved fleet (exit 0 valid, 2 invalid).
    Check {
        #[command(flatten)]
        profile: ProfileArg,
        /// List the profiles that can be named instead of checking one.
        #[arg(long, conflicts_with_all = ["profile", "profile_flag"])]
        list: bool,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
    /// Say why clients do not match the profile's gateway ("Waiting to subscribe dds...").
    ///
    /// Joins the profile's DDS domain for a few seconds without serving anything and says,
    /// for every front and DDS device of the profile, which clients and services are there,
    /// what keeps the others from matching and the fix, which interfaces CycloneDDS chose and
    /// whether multicast works on them, and which other domains have the profile's clients
    /// (docs/troubleshooting.md). Exit 0 when nothing is wrong, 1 otherwise, 2 for an invalid
    /// profile.
    Doctor(DoctorCmd),
    /// List every handgate on the lab's DDS domains (docs/deployment.md, "A lab of robots"):
    /// robot namespace, host, both DDS sides, devices with freshness and safe state, who
    /// commands each, from each gateway's status topic. Reads only; commands nothing.
    Fleet {
        /// The domains to look on, `A-B` or `N`.
        #[arg(long, default_value = "10-20")]
        domains: String,
        /// Network interface for DDS (the lab network's), e.g. eth1.
        #[arg(long)]
        interface: Option<String>,
        /// How long to look, seconds (a gateway publishes its status once a second by default).
        #[arg(long, default_value_t = 3.0)]
        seconds: f64,
    },
    /// Show a live table of the running gateway's devices (from its status topic).
    Status {
        #[command(flatten)]
        dds: DdsArgs,
        /// Status topic (`status.topic`), in `--namespace`.
        #[arg(long, default_value = crate::profile::DEFAULT_STATUS_TOPIC)]
        topic: String,
        /// Print one sample and exit.
        #[arg(long)]
        once: bool,
        /// How long to wait for a status sample, seconds.
        #[arg(long, default_value_t = 5.0)]
        timeout: f64,
    },
    /// List the devices attached to this machine that a kind can enumerate (with permission
    /// problems explained).
    List,
    /// Report the wiring a device answers from (for kinds that can discover it: which
    /// (bus, id) each motor and sensor answers on), as a profile snippet to paste. Opens only that device, through
    /// its kind; sends zero-gain frames only: nothing moves.
    Discover {
        /// Device name in the profile.
        device: String,
        /// Profile (as for `run --profile`); without it: the embedded default.
        #[arg(long)]
        profile: Option<String>,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
    /// Run a device's calibration (for kinds that have one; the device may move to a stop to
    /// find its zero)
    /// and print what to put in the profile. Opens only that device, through its kind.
    Calibrate {
        /// Device name in the profile.
        device: String,
        /// Profile (as for `run --profile`); without it: the embedded default.
        #[arg(long)]
        profile: Option<String>,
        #[command(flatten)]
        overrides: OverrideArgs,
    },
    /// Run a kind's emulator as a standalone process: what stands where the hardware or the
    /// robot's service would (each kind takes the options below it needs and refuses the
    /// others; docs/adapters.md lists them per kind), so a profile written for a robot runs
    /// against it on any domain.
    Emulate(EmulateCmd),
    /// Send one command in the canonical model to a named device (bring-up), on handgate's
    /// own interface `rt/handgate/{device}/cmd`.
    Send(SendCmd),
    /// Record the fleet's DDS traffic (every front's command and state topics, the canonical
    /// states, `rt/joint_states`, status) into a rosbag2-shaped MCAP directory NAME
    /// (NAME/NAME_0.mcap + metadata.yaml) until Ctrl-C or --duration (docs/recording.md).
    Record(RecordCmd),
    /// Re-publish a recording's messages on their topics with their original timing.
    Replay(ReplayCmd),
    /// Export a recording's hand streams.
    Export(ExportCmd),
    /// The lab's DDS Security keystore (docs/security-keystore.md): a lab CA, an identity per
    /// gateway and operator with permissions per robot, revocation, renewal; in the SROS2
    /// keystore layout, made with the `openssl` command line.
    #[command(subcommand)]
    Security(SecurityCmd),
}

/// The profile of `run` and `check`, given either way: `handgate check PROFILE` or
/// `handgate check --profile PROFILE` (one of them).
#[derive(Debug, Clone, Default, Args)]
pub struct ProfileArg {
    /// Profile: a shipped name (see `handgate check --list`), NAME for profiles/NAME.toml or
    /// $HANDGATE_PROFILE_DIR/NAME.toml, or a path to a .toml file; also as `--profile
    /// PROFILE`. Without it: the embedded default (the simulated fleet on DDS domain 1).
    #[arg(id = "profile", value_name = "PROFILE")]
    positional: Option<String>,
    /// The profile, as the argument PROFILE.
    #[arg(
        id = "profile_flag",
        long = "profile",
        value_name = "PROFILE",
        conflicts_with = "profile"
    )]
    flag: Option<String>,
}

impl ProfileArg {
    /// The profile named, either way (`None`: the embedded default).
    pub fn into_inner(self) -> Option<String> {
        self.positional.or(self.flag)
    }
}

/// `handgate doctor`.
#[derive(Debug, Clone, Args)]
pub struct DoctorCmd {
    /// Profile (as for `run --profile`); without it: the embedded default.
    #[arg(long)]
    pub profile: Option<String>,
    /// How long to listen, seconds.
    #[arg(long, default_value_t = 3.0)]
    pub seconds: f64,
    /// Other DDS domains to look on at the same time, `A-B` or `N` (default 0-5).
    #[arg(long, conflicts_with = "no_scan")]
    pub scan: Option<String>,
    /// Look on the profile's domain only.
    #[arg(long)]
    pub no_scan: bool,
    /// When nothing for the profile is found, do not look through this host's other
    /// interfaces (by default it does, one child process per interface).
    #[arg(long)]
    pub no_sweep: bool,
    /// Print only `relevant N` (the participants found for the profile); used by the
    /// interface sweep.
    #[arg(long, hide = true)]
    pub count_only: bool,
    #[command(flatten)]
    pub overrides: OverrideArgs,
}

/// `handgate send`.
#[derive(Debug, Clone, Args)]
pub struct SendCmd {
    /// Device name from the profile (e.g. left_hand).
    pub device: String,
    #[command(flatten)]
    pub dds: DdsArgs,
    /// Hand closure in [0, 1] (0 open, 1 closed).
    #[arg(long, conflicts_with = "joint")]
    pub closure: Option<f32>,
    /// A joint target NAME=RAD (canonical frame, positive = closing); repeatable.
    #[arg(long, value_parser = parse_joint)]
    pub joint: Vec<(String, f32)>,
    /// Stiffness for joint targets, N*m/rad.
    #[arg(long, default_value_t = 1.5)]
    pub kp: f32,
    /// Damping for joint targets, N*m*s/rad.
    #[arg(long, default_value_t = 0.1)]
    pub kd: f32,
    /// Move the device to its safe state instead.
    #[arg(long, conflicts_with_all = ["closure", "joint"])]
    pub safe: bool,
    /// How long to wait for the gateway to match, seconds.
    #[arg(long, default_value_t = 5.0)]
    pub timeout: f64,
    /// Keep repeating the command at 50 Hz for this many seconds, so the front's command
    /// watchdog does not stop the motion early (0: send once).
    #[arg(long, default_value_t = 1.0)]
    pub hold: f64,
    /// Take the device's front over from the client commanding it (a front with
    /// `control = "exclusive"` refuses other clients while its owner streams); the
    /// gateway logs who took over from whom.
    #[arg(long)]
    pub force: bool,
}

/// Recording options shared by `handgate record` and the profile's `[record]` section.
#[derive(Debug, Clone, Args)]
pub struct RecordArgs {
    /// Topics to record, as globs on DDS or ROS 2 names (`/handgate/*`); repeatable; default all.
    #[arg(long = "topics")]
    pub topics: Vec<String>,
    /// Start a new file after this many MB of messages.
    #[arg(long)]
    pub max_mb: Option<f64>,
    /// Start a new file after this many seconds.
    #[arg(long)]
    pub max_seconds: Option<f64>,
    /// zstd chunk compression (handgate built with the `zstd` feature).
    #[arg(long)]
    pub zstd: bool,
}

/// `handgate record`.
#[derive(Debug, Clone, Args)]
pub struct RecordCmd {
    /// The recording directory to create (its last component names the files).
    pub name: PathBuf,
    /// Profile whose topics are recorded (as for `run --profile`); default: the embedded one.
    #[arg(long)]
    pub profile: Option<String>,
    #[command(flatten)]
    pub overrides: OverrideArgs,
    #[command(flatten)]
    pub record: RecordArgs,
    /// Stop after this many seconds (default: at Ctrl-C / SIGTERM).
    #[arg(long)]
    pub duration: Option<f64>,
}

/// `handgate replay`.
#[derive(Debug, Clone, Args)]
pub struct ReplayCmd {
    /// A recording directory (or one .mcap file).
    pub dir: PathBuf,
    /// DDS domain to publish on; 0 (a robot's) needs --allow-robot.
    #[arg(long, default_value_t = 1)]
    pub domain: u32,
    /// Network interface for DDS, e.g. eth0.
    #[arg(long)]
    pub interface: Option<String>,
    /// Allow domain 0: replaying commands into a real robot moves it.
    #[arg(long)]
    pub allow_robot: bool,
    /// Speed factor (2: twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Start again at the end, until Ctrl-C.
    #[arg(long = "loop")]
    pub looped: bool,
    /// Topics to replay, as globs on DDS or ROS 2 names (`/handgate/*/cmd`); repeatable;
    /// default all.
    #[arg(long = "topics")]
    pub topics: Vec<String>,
    /// Seconds to wait for the readers on every replayed topic before starting.
    #[arg(long, default_value_t = 5.0)]
    pub wait: f64,
    /// Matched readers to wait for on every replayed topic (e.g. 2: a gateway's front and a
    /// recorder).
    #[arg(long, default_value_t = 1)]
    pub readers: u32,
    /// Milliseconds to wait after the readers matched before the first message, so that they
    /// have discovered the replay's writers too (a best-effort reader drops samples from a
    /// writer it does not know yet).
    #[arg(long = "settle-ms", default_value_t = 200)]
    pub settle_ms: u64,
}

/// `handgate export`.
#[derive(Debug, Clone, Args)]
pub struct ExportCmd {
    /// A recording directory (or one .mcap file).
    pub dir: PathBuf,
    /// xr_teleoperate episode `data.json` hand fields (the only format so far).
    #[arg(long, required = true)]
    pub xr_teleoperate: bool,
    /// Output file (default: stdout).
    #[arg(long, short)]
    pub output: Option<PathBuf>,
    /// Frames per second.
    #[arg(long, default_value_t = 30.0)]
    pub rate: f64,
    /// ROS 2 topic prefix of the left hand's state/cmd topics (default: xr_teleoperate's
    /// G1 hand service).
    #[arg(long, default_value = handgate_record::export::DEFAULT_LEFT)]
    pub left: String,
    /// ROS 2 topic prefix of the right hand's state/cmd topics.
    #[arg(long, default_value = handgate_record::export::DEFAULT_RIGHT)]
    pub right: String,
    /// Export only the left hand.
    #[arg(long, conflicts_with = "only_right")]
    pub only_left: bool,
    /// Export only the right hand.
    #[arg(long)]
    pub only_right: bool,
}

/// `handgate emulate <kind>`.
#[derive(Debug, Clone, Args)]
#[command(after_help = emulate_help())]
pub struct EmulateCmd {
    /// A registered device kind (an unknown one lists them).
    pub kind: String,
    /// left or right (the emulated device's side).
    #[arg(long)]
    pub side: Option<handgate_adapters::model::Side>,
    /// DDS domain of a service emulator [default: 1].
    #[arg(long)]
    pub domain: Option<u32>,
    /// Network interface for DDS, e.g. eth0.
    #[arg(long)]
    pub interface: Option<String>,
    /// Report exact joint values (no measurement noise; the default adds the kind's,
    /// docs/adapters.md).
    #[arg(long)]
    pub no_noise: bool,
    /// Seed of the measurement noise (default fixed, so runs repeat exactly).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Inject a fault (docs/adapters.md, "Motion"): `stuck=<joint>` (that joint stays where
    /// it is whatever the command; the kind's canonical joint name or its URDF name),
    /// `frozen` (the emulator repeats its last state) or `ignore-commands` (the state evolves
    /// as if no command came). Every kind's emulator but hand_sdk's (it publishes no state);
    /// inspire_dfx: a stuck joint on `--side`'s hand (default right); dex1 --variant actuator:
    /// on `--side`'s gripper (default left); ezgripper: on every servo of the bus.
    #[arg(long, value_name = "FAULT")]
    pub fault: Option<handgate_adapters::emu_common::FaultArg>,
    /// The kind's own options (`--name value`; listed below, per kind; another is refused
    /// with the kind's list).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, value_name = "KIND OPTIONS")]
    pub options: Vec<String>,
}

/// Every kind's own `handgate emulate` options, for the help text.
fn emulate_help() -> String {
    let mut s = String::from("Options of each kind (besides those above it takes):\n");
    for kind in handgate_adapters::kind::DeviceKind::all() {
        let opts = kind.factory().emulate_options();
        if opts.is_empty() {
            s.push_str(&format!("  {kind}: none\n"));
        }
        for o in opts {
            let v = o.value.map(|v| format!(" {v}")).unwrap_or_default();
            s.push_str(&format!("  {kind} --{}{v}: {}\n", o.name, o.help));
        }
    }
    s.push_str("Joints --fault stuck=<joint> names (canonical; the URDF names work too):\n");
    for kind in handgate_adapters::kind::DeviceKind::all() {
        s.push_str(&format!("  {kind}: {}\n", kind.joint_names().join(", ")));
    }
    s
}

impl TryFrom<EmulateCmd> for handgate_adapters::kind::EmulateArgs {
    type Error = String;

    fn try_from(mut c: EmulateCmd) -> Result<Self, String> {
        // Common options written after the kind's own land among them: take them back.
        let mut options = Vec::new();
        for (name, value) in handgate_adapters::kind::EmulateArgs::split_options(&c.options)? {
            let bad = |e: String| format!("--{name}: {e}");
            match (name.as_str(), value.as_deref()) {
                ("side", Some(v)) => c.side = Some(v.parse().map_err(|e: String| bad(e))?),
                ("domain", Some(v)) => c.domain = Some(v.parse().map_err(|e| bad(format!("{e}")))?),
                ("interface", Some(v)) => c.interface = Some(v.to_string()),
                ("seed", Some(v)) => c.seed = Some(v.parse().map_err(|e| bad(format!("{e}")))?),
                ("no-noise", None) => c.no_noise = true,
                ("fault", Some(v)) => c.fault = Some(v.parse().map_err(|e: String| bad(e))?),
                _ => options.push((name, value)),
            }
        }
        let common_given = [
            ("side", c.side.is_some()),
            ("domain", c.domain.is_some()),
            ("interface", c.interface.is_some()),
            ("no-noise", c.no_noise),
            ("seed", c.seed.is_some()),
            ("fault", c.fault.is_some()),
        ]
        .into_iter()
        .filter_map(|(n, given)| given.then_some(n))
        .collect();
        Ok(handgate_adapters::kind::EmulateArgs {
            side: c.side,
            domain: c.domain.unwrap_or(1),
            interface: c.interface,
            no_noise: c.no_noise,
            seed: c.seed,
            fault: c.fault,
            common_given,
            options,
        })
    }
}

/// `NAME=RAD` for `send --joint`.
pub fn parse_joint(s: &str) -> Result<(String, f32), String> {
    let (n, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=RAD, got {s:?}"))?;
    let v: f32 = v.trim().parse().map_err(|e| format!("{v:?} is not a number: {e}"))?;
    if !v.is_finite() {
        return Err(format!("{v} is not finite"));
    }
    Ok((n.trim().to_string(), v))
}

/// Where to find a running gateway on DDS (for `status` and `send`).
#[derive(Debug, Clone, Args)]
pub struct DdsArgs {
    /// DDS domain id of the gateway (the simulated fleet uses 1).
    #[arg(long, default_value_t = 1)]
    pub domain: u32,
    /// Network interface for DDS, e.g. eth0.
    #[arg(long)]
    pub interface: Option<String>,
    /// The gateway's ROS namespace (`dds.namespace`): its own topics are inside it.
    #[arg(long, value_parser = handgate_adapters::ros::Namespace::parse)]
    pub namespace: Option<handgate_adapters::ros::Namespace>,
    /// Join a domain secured with DDS Security as this identity: an enclave directory of the
    /// lab's keystore (`handgate security issue`; docs/security.md).
    #[arg(long)]
    pub enclave: Option<std::path::PathBuf>,
    /// With --enclave: the identity CA's revocation list (PEM).
    #[arg(long, requires = "enclave")]
    pub crl: Option<std::path::PathBuf>,
}

impl DdsArgs {
    /// The participant these arguments say: domain, interface and, with `--enclave`, the
    /// identity it joins a secured domain as.
    pub fn node(&self) -> Result<handgate_adapters::dds::Node, handgate_adapters::dds::DdsError> {
        let security = self
            .enclave
            .as_deref()
            .map(|dir| handgate_adapters::dds_security::Security::from_enclave(dir, self.crl.clone()));
        handgate_adapters::dds::Node::with_security(self.domain, self.interface.as_deref(), security.as_ref())
    }

    /// One of handgate's own topics, in `--namespace`.
    pub fn topic(&self, topic: &str) -> String {
        self.namespace.clone().unwrap_or_default().topic(topic)
    }
}

/// Flags that override profile keys (above the profile file and `HANDGATE_*` variables).
#[derive(Debug, Clone, Default, Args)]
pub struct OverrideArgs {
    /// DDS domain id (`dds.domain`).
    #[arg(long)]
    pub domain: Option<u32>,
    /// Network interface for DDS (`dds.interface`), e.g. eth0.
    #[arg(long)]
    pub interface: Option<String>,
    /// Log format (`log.format`).
    #[arg(long, value_enum)]
    pub log_format: Option<LogFormatArg>,
    /// Port of the dashboard's HTTP server (`http.port`; 0: any free port, logged).
    #[arg(long)]
    pub http_port: Option<u16>,
    /// DDS domain of the clients' side (`export.domain`): fronts, status and the ROS node
    /// there, the devices on `--domain`.
    #[arg(long)]
    pub export_domain: Option<u32>,
    /// Network interface of the clients' side (`export.interface`), e.g. eth1.
    #[arg(long)]
    pub export_interface: Option<String>,
    /// ROS namespace of handgate's own topics and node (`export.namespace`), e.g. robot1.
    #[arg(long)]
    pub namespace: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogFormatArg {
    Human,
    Json,
}

impl From<OverrideArgs> for CliOverrides {
    fn from(a: OverrideArgs) -> Self {
        CliOverrides {
            domain: a.domain,
            interface: a.interface,
            log_format: a.log_format.map(|f| match f {
                LogFormatArg::Human => LogFormat::Human,
                LogFormatArg::Json => LogFormat::Json,
            }),
            http_port: a.http_port,
            export_domain: a.export_domain,
            export_interface: a.export_interface,
            namespace: a.namespace,
        }
    }
}

/// The directories `--profile NAME` searches (see `profile::default_search_dirs`).
pub fn profile_dirs() -> Vec<PathBuf> {
    crate::profile::default_search_dirs()
}

/// `handgate security`.
#[derive(Debug, Clone, Subcommand)]
pub enum SecurityCmd {
    /// Create a keystore: the lab CA (ECDSA P-256, SHA-256; one CA as identity and permissions
    /// CA, as SROS2), the governance of every domain signed by it, an empty revocation list.
    /// Refuses a directory that holds a keystore already.
    Init {
        #[command(flatten)]
        keystore: KeystoreArg,
        /// The CA's common name.
        #[arg(long, default_value = crate::security::keystore::DEFAULT_CA_NAME)]
        name: String,
        /// How long the CA is valid, days (every identity and the revocation list end with it).
        #[arg(long, default_value_t = crate::security::keystore::DEFAULT_CA_DAYS)]
        days: u32,
    },
    /// Issue an identity (an SROS2 enclave, enclaves/NAME/): a key, a certificate of subject
    /// `CN=/NAME` and permissions for its role on its robots' DDS domains. Roles: gateway
    /// (publishes and subscribes every topic: it serves the robot's clients); operator
    /// (publishes the fronts' command topics and the ROS 2 bookkeeping topics, subscribes
    /// everything); observer (subscribes everything, publishes only the ROS 2 bookkeeping;
    /// without --robot: every domain).
    Issue {
        #[command(flatten)]
        keystore: KeystoreArg,
        /// The enclave: `robot_a`, `/robot_a`, `ops/alice` (SROS2 enclave path).
        name: String,
        /// What the identity may do.
        #[arg(long, value_enum)]
        role: RoleArg,
        /// A robot's DDS domain the identity may join; repeatable (a gateway and an operator
        /// need one at least).
        #[arg(long = "robot", value_name = "DOMAIN")]
        robots: Vec<u32>,
        /// How long the certificate and permissions are valid, days from now.
        #[arg(long, default_value_t = crate::security::keystore::DEFAULT_DAYS, conflicts_with_all = ["not_before", "not_after"])]
        days: u32,
        /// Start of validity, RFC 3339 (with --not-after; to make expired or not-yet-valid
        /// identities for tests).
        #[arg(long, requires = "not_after")]
        not_before: Option<String>,
        /// End of validity, RFC 3339 (with --not-before).
        #[arg(long, requires = "not_before")]
        not_after: Option<String>,
        /// A subject alternative name, `DNS:NAME` or `IP:ADDRESS` (for TLS uses of the
        /// identity); repeatable.
        #[arg(long = "san", value_name = "DNS:x|IP:y")]
        sans: Vec<String>,
    },
    /// Revoke an identity: every certificate issued to it (renewed ones too) goes on the
    /// identity CA's revocation list, rewritten to public/crl.pem. Participants refuse it once
    /// they are given the new list (`crl` in the profile's security section). Idempotent.
    Revoke {
        #[command(flatten)]
        keystore: KeystoreArg,
        /// The enclave.
        name: String,
    },
    /// Renew an identity: a new key and certificate (new serial and validity, the same
    /// subject, role and robots) and its permissions re-signed. The old certificate keeps
    /// working until it expires unless revoked.
    Renew {
        #[command(flatten)]
        keystore: KeystoreArg,
        /// The enclave.
        name: String,
        /// How long the new certificate and permissions are valid, days from now.
        #[arg(long, default_value_t = crate::security::keystore::DEFAULT_DAYS)]
        days: u32,
    },
    /// List the keystore's enclaves: subject, role, robots, validity, revoked or not.
    List {
        #[command(flatten)]
        keystore: KeystoreArg,
    },
}

/// The keystore directory of `handgate security`.
#[derive(Debug, Clone, Args)]
pub struct KeystoreArg {
    /// The keystore directory (SROS2 layout: public/, private/, enclaves/).
    #[arg(long, value_name = "DIR")]
    pub keystore: PathBuf,
}

/// `--role`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RoleArg {
    Gateway,
    Operator,
    Observer,
}

impl From<RoleArg> for crate::security::xml::Role {
    fn from(r: RoleArg) -> Self {
        match r {
            RoleArg::Gateway => Self::Gateway,
            RoleArg::Operator => Self::Operator,
            RoleArg::Observer => Self::Observer,
        }
    }
}
