//! `handgate doctor`: joins a profile's DDS domain for a few seconds without serving anything
//! and says, for what the profile's gateway WOULD serve ([`crate::diagnostics::served`]),
//! which clients and services are there, what keeps the others from matching and how to fix
//! it (issue #14, docs/troubleshooting.md): the domain, the network interfaces CycloneDDS
//! chose and whether multicast works on them, clients on other domains, clients on a subnet
//! the chosen interface does not reach, and samples written in an older Unitree layout.
//!
//! The doctor creates no writer. It reads discovery and, on the topics whose type has a
//! layout history ([`handgate_idl::layout`]), creates a best-effort reader that keeps each
//! sample's bytes (so a client writing there sees one more matched reader).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::net::IpAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::dds::{layout_reader, DdsError, InterfaceTrace, Node, Qos, RawTake};
use handgate_adapters::device::Backend;
use handgate_adapters::discovery::diagnose::{diagnose, FindingKind, RemoteRef, Report, Served};
use handgate_adapters::discovery::{Discovery, DiscoveryConfig, Guid, Origin, Participant, Role, Snapshot};
use handgate_adapters::model::Side;
use handgate_adapters::netif::{self, NetIf};
use handgate_idl::handgate as hgmsg;
use handgate_idl::layout::{self, Verdict};

use crate::diagnostics::{served, Owner, ServedBy};
use crate::plan::Plan;
use crate::profile::MAX_DOMAIN_ID;

/// Failures that stop the doctor before it has anything to say.
#[derive(Debug, thiserror::Error)]
pub enum DoctorError {
    #[error(transparent)]
    Dds(#[from] DdsError),
    #[error("listing this host's network interfaces: {0}")]
    Interfaces(#[source] std::io::Error),
}

/// How the doctor looks.
#[derive(Debug, Clone)]
pub struct Options {
    /// How long to listen on the domains.
    pub listen: Duration,
    /// Other domains to join at the same time, to find clients on the wrong domain (the
    /// profile's own is skipped).
    pub scan: Vec<u32>,
    /// When nothing for the profile is found: look through this host's other interfaces too.
    pub sweep: Option<Sweep>,
}

/// How to look through another interface: a child `handgate doctor --count-only` per
/// interface (one process holds one CycloneDDS configuration per domain, so the doctor cannot
/// join its own domain a second time through another interface).
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The `handgate` executable.
    pub exe: std::path::PathBuf,
    /// The `--profile` argument the doctor was given.
    pub profile: Option<String>,
}

/// What the doctor found: the text to print and the problems (each also in the text).
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    pub text: String,
    pub problems: Vec<String>,
    /// Remote participants with endpoints for the profile on its domain (clients, services,
    /// near misses; a running gateway not counted).
    pub relevant: usize,
    /// The running gateways found, by (host, pid): with `[export]` the devices' side knows
    /// the gateway by the process the clients' side found (its status is published there).
    pub gateways: Vec<(Option<String>, u32)>,
}

impl Outcome {
    fn line(&mut self, s: impl AsRef<str>) {
        self.text.push_str(s.as_ref());
        self.text.push('\n');
    }

    /// A problem: its line (prefixed `PROBLEM`) and its fix.
    fn problem(&mut self, indent: &str, what: impl Into<String>, fix: impl AsRef<str>) {
        let what = what.into();
        let _ = writeln!(self.text, "{indent}PROBLEM {what}");
        let _ = writeln!(self.text, "{indent}  fix: {}", fix.as_ref());
        self.problems.push(what);
    }
}

/// The samples of one topic checked for their layout.
struct Probe {
    owner: Owner,
    topic: String,
    type_name: String,
    reader: Box<dyn RawTake>,
    /// verdict -> (samples, a size seen, the current layout's size for it)
    seen: BTreeMap<String, (usize, usize, Option<usize>)>,
    older: BTreeSet<&'static str>,
    unknown: usize,
    total: usize,
    /// The entries the owner expects in each sample ([`Served::entries`]), and the counts
    /// seen: entries -> samples.
    expected: Option<usize>,
    entries: BTreeMap<usize, usize>,
    /// The front's check of a client's sample ([`Served::sample_check`]), and what it found:
    /// (what is wrong, its fix) -> samples.
    check: Option<handgate_adapters::discovery::diagnose::SampleCheck>,
    mistakes: BTreeMap<(String, String), usize>,
}

impl Probe {
    fn poll(&mut self) {
        for bytes in self.reader.take_bytes() {
            if let Some(r) = self.check.and_then(|check| (check.0)(&bytes)) {
                let fix = r
                    .fix()
                    .unwrap_or("fix the client's message as the line says")
                    .to_string();
                *self.mistakes.entry((r.to_string(), fix)).or_default() += 1;
            }
            let Some(c) = layout::check(&self.type_name, &bytes) else {
                continue;
            };
            self.total += 1;
            if let Some(n) = c.entries {
                *self.entries.entry(n).or_default() += 1;
            }
            let key = match c.verdict {
                Verdict::Current => "current".to_string(),
                Verdict::Older(w) => {
                    self.older.insert(w);
                    w.to_string()
                }
                Verdict::Unknown => {
                    self.unknown += 1;
                    "unknown".to_string()
                }
            };
            let e = self.seen.entry(key).or_insert((0, c.size, c.current_size));
            e.0 += 1;
        }
    }
}

/// One domain joined only to look (the `--scan` range).
struct Scan {
    domain: u32,
    discovery: Discovery,
    _node: Node,
}

/// The remote participants that write the status topic: gateways already running.
fn running_gateways(snap: &Snapshot, status_topic: &str) -> BTreeSet<Guid> {
    snap.on_topic(status_topic)
        .filter(|e| e.origin == Origin::Remote && e.role == Role::Writer)
        .map(|e| e.participant)
        .collect()
}

fn who_participant(p: &Participant) -> String {
    let mut s = match (&p.process_name, p.pid) {
        (Some(n), Some(pid)) => format!("process {n} (pid {pid})"),
        (None, Some(pid)) => format!("pid {pid}"),
        (Some(n), None) => format!("process {n}"),
        (None, None) => format!("participant {}", p.key),
    };
    if let Some(h) = &p.hostname {
        let _ = write!(s, " on {h}");
    }
    if let Some(a) = p.unicast_address() {
        let _ = write!(s, " at {a}");
    }
    s
}

fn role_word(r: Role) -> &'static str {
    match r {
        Role::Reader => "reader",
        Role::Writer => "writer",
    }
}

fn list_refs(refs: &[RemoteRef], count: usize) -> String {
    let mut who: Vec<String> = refs.iter().map(RemoteRef::who).collect();
    who.dedup();
    let mut s = who.join("; ");
    if count > refs.len() {
        let _ = write!(s, " and {} more", count - refs.len());
    }
    s
}

/// The interfaces named in CycloneDDS's `selected interfaces:` line that exist here.
fn selected_names<'a>(trace: &InterfaceTrace, ifs: &'a [NetIf]) -> Vec<&'a NetIf> {
    let Some(sel) = &trace.selected else { return Vec::new() };
    let words: BTreeSet<&str> = sel
        .split(|c: char| c.is_whitespace() || c == ',' || c == '(' || c == ')')
        .collect();
    ifs.iter().filter(|i| words.contains(i.name.as_str())).collect()
}

fn describe_if(i: &NetIf) -> String {
    let addrs: Vec<String> = i.addrs.iter().map(|a| format!("{}/{}", a.ip, a.prefix)).collect();
    let mut s = format!(
        "{} ({})",
        i.name,
        if addrs.is_empty() {
            "no address".into()
        } else {
            addrs.join(", ")
        }
    );
    if !i.up {
        s.push_str(" down");
    }
    s
}

/// Runs the doctor for `plan` (its domain and interface already include the command line's
/// overrides): joins the domains, listens, then writes its report one section after the
/// other (each a function of what was seen).
pub fn run(plan: &Plan, opts: &Options) -> Result<Outcome, DoctorError> {
    let mut out = run_dds(plan, opts)?;
    let ports = serial_ports(plan);
    if !ports.is_empty() {
        // Before the summary line, which then counts the ports' problems too.
        let summary = out.text.trim_end().rfind('\n').map_or(0, |i| i + 1);
        out.text.truncate(summary);
        ports_section(&mut out, &ports, handgate_adapters::serial::holders, |p| {
            handgate_adapters::serial::owner::latency_timer_ms(p)
        });
        summary_section(&mut out);
    }
    Ok(out)
}

/// One DDS Security identity the profile configures: its section (`[export.security]`,
/// `[dds.security]`), the domain that participant joins, and its files (or the key the
/// section lacks).
#[derive(Debug, Clone)]
pub struct SecurityTarget {
    pub section: &'static str,
    pub domain: u32,
    pub identity: Result<handgate_adapters::dds_security::Security, &'static str>,
}

/// The identities of `profile`'s `[export.security]` (on the clients' side's domain) and
/// `[dds.security]` (on the devices' domain) (`plan` is the profile's, with the command
/// line's overrides).
pub fn security_targets(profile: &crate::profile::Profile, plan: &Plan) -> Vec<SecurityTarget> {
    let mut v = Vec::new();
    if let Some(sec) = profile.export.as_ref().and_then(|e| e.security.as_ref()) {
        v.push(SecurityTarget {
            section: "[export.security]",
            domain: plan.clients_side().0,
            identity: sec.resolve(),
        });
    }
    if let Some(sec) = &profile.dds.security {
        v.push(SecurityTarget {
            section: "[dds.security]",
            domain: plan.domain,
            identity: sec.resolve(),
        });
    }
    v
}

/// Adds the DDS Security section (each identity's [`crate::security::diagnose`] findings at
/// `now`) before the summary line, which then counts its problems too. Nothing when the
/// profile configures no identity.
pub fn add_security(out: &mut Outcome, targets: &[SecurityTarget], now: crate::security::time::Unix) {
    if targets.is_empty() {
        return;
    }
    let summary = out.text.trim_end().rfind('\n').map_or(0, |i| i + 1);
    out.text.truncate(summary);
    security_section(out, targets, |s, d| crate::security::diagnose::diagnose(s, d, now));
    summary_section(out);
}

/// Each identity's findings: problems (with their fix), warnings, then the checks passed.
fn security_section(
    out: &mut Outcome,
    targets: &[SecurityTarget],
    diagnose: impl Fn(&handgate_adapters::dds_security::Security, u32) -> Vec<crate::security::diagnose::Finding>,
) {
    use crate::security::diagnose::Severity;
    for t in targets {
        out.line(format!("DDS Security {} on domain {}:", t.section, t.domain));
        let sec = match &t.identity {
            Ok(s) => s,
            Err(key) => {
                out.problem(
                    "  ",
                    format!("{}: no `{key}` and no `enclave` to take it from", t.section),
                    format!(
                        "set `enclave = \"<keystore>/enclaves/<name>\"` (or `{key}`) in {}",
                        t.section
                    ),
                );
                continue;
            }
        };
        let findings = diagnose(sec, t.domain);
        for f in &findings {
            match f.severity() {
                Severity::Problem => out.problem("  ", format!("{}: {f}", t.section), f.fix().unwrap_or_default()),
                Severity::Warning => {
                    out.line(format!("  WARNING {}: {f}", t.section));
                    if let Some(fix) = f.fix() {
                        out.line(format!("    fix: {fix}"));
                    }
                }
                Severity::Ok => out.line(format!("  OK {f}")),
            }
        }
    }
}

/// The serial ports the profile's devices on the serial backend own: (device, port).
fn serial_ports(plan: &Plan) -> Vec<(String, std::path::PathBuf)> {
    plan.devices
        .iter()
        .filter(|d| d.backend == Backend::Serial)
        .flat_map(|d| d.config.ports().into_iter().map(|p| (d.name.clone(), p)))
        .collect()
}

/// Whether a process holding a port is a handgate (the gateway owning it, as it should).
fn is_handgate(h: &handgate_adapters::serial::PortHolder) -> bool {
    h.command
        .split_whitespace()
        .next()
        .and_then(|exe| std::path::Path::new(exe).file_name())
        .is_some_and(|n| n == "handgate")
}

/// The profile's serial ports: who holds each (another program than handgate is a problem:
/// the gateway could not open the port), and an FTDI adapter's latency timer above 1 ms.
fn ports_section(
    out: &mut Outcome,
    ports: &[(String, std::path::PathBuf)],
    holders: impl Fn(&std::path::Path) -> Vec<handgate_adapters::serial::PortHolder>,
    latency_ms: impl Fn(&std::path::Path) -> Option<u32>,
) {
    out.line("serial ports:");
    for (device, port) in ports {
        let shown = port.display();
        if !port.exists() {
            out.line(format!(
                "  {device}: {shown} is not present (adapter unplugged or another path)"
            ));
            continue;
        }
        let held = holders(port);
        let (ours, others): (Vec<_>, Vec<_>) = held.iter().partition(|h| is_handgate(h));
        for h in &ours {
            let how = if h.locked { "owned by" } else { "also open in" };
            out.line(format!("  {device}: {shown} {how} handgate, {h}"));
        }
        if !others.is_empty() {
            let who: Vec<String> = others.iter().map(|h| h.to_string()).collect();
            out.problem(
                "  ",
                format!("{device}: {shown} is held by {}", who.join(", ")),
                "one program owns a serial bus: stop it (a vendor tool, a terminal, another driver) and \
                 connect it to one of handgate's fronts instead (docs/fronts.md)",
            );
        } else if ours.is_empty() {
            out.line(format!("  {device}: {shown} free"));
        }
        if let Some(ms) = latency_ms(port) {
            if ms > 1 {
                out.problem(
                    "  ",
                    format!("{device}: {shown}'s USB adapter has a latency timer of {ms} ms: every reply waits up to {ms} ms"),
                    format!(
                        "install {} (sets 1 ms on plug-in) or `echo 1 | sudo tee /sys/bus/usb-serial/devices/{}/latency_timer`",
                        handgate_adapters::serial::owner::LATENCY_RULE,
                        handgate_adapters::serial::owner::node(port)
                            .file_name()
                            .map(|n| n.to_string_lossy().into_owned())
                            .unwrap_or_else(|| "ttyUSB0".into())
                    ),
                );
            } else {
                out.line(format!("  {device}: {shown} latency timer {ms} ms"));
            }
        }
    }
}

fn run_dds(plan: &Plan, opts: &Options) -> Result<Outcome, DoctorError> {
    if plan.export.is_none() {
        return run_side(plan, served(plan), opts, "", &[], true);
    }
    // `[export]`: each side on its own domain and interface, one after the other (a process
    // holds one CycloneDDS configuration per domain): the fronts' clients on the export side,
    // then the devices' services on the robot's. The interface sweep runs child doctors on
    // the profile's `[dds]` side only, so it is left out here.
    let (fronts, devices): (Vec<ServedBy>, Vec<ServedBy>) = served(plan)
        .into_iter()
        .partition(|s| matches!(s.owner, Owner::Front(_)));
    let (domain, interface) = plan.clients_side();
    let clients = Plan {
        domain,
        interface: interface.map(str::to_string),
        export: None,
        ..plan.clone()
    };
    let no_sweep = Options {
        sweep: None,
        ..opts.clone()
    };
    let mut out = run_side(&clients, fronts, &no_sweep, " (export side: fronts, status)", &[], true)?;
    let robot = Plan {
        export: None,
        ..plan.clone()
    };
    let dev = run_side(&robot, devices, &no_sweep, " (devices' side)", &out.gateways, false)?;
    out.line("");
    out.text.push_str(&dev.text);
    out.problems.extend(dev.problems);
    out.relevant += dev.relevant;
    Ok(out)
}

/// The doctor on one DDS side: `plan`'s domain and interface, what `all` serves there; `side`
/// follows the domain in the first line; `known`: gateway processes found on the other side;
/// `status`: the gateway's status is published on this side (read for [`motion_section`]).
fn run_side(
    plan: &Plan,
    all: Vec<ServedBy>,
    opts: &Options,
    side: &str,
    known: &[(Option<String>, u32)],
    status: bool,
) -> Result<Outcome, DoctorError> {
    let mut out = Outcome::default();
    let ifs = netif::list().map_err(DoctorError::Interfaces)?;
    out.line(format!(
        "handgate doctor: profile {}, DDS domain {}{side}, listening {:.1} s",
        plan.profile,
        plan.domain,
        opts.listen.as_secs_f64()
    ));
    let interface = interface_section(&mut out, plan, &ifs);

    let mut look = Look::join(plan, interface.as_deref(), &all, &opts.scan, status)?;
    look.listen(opts.listen);
    let snap = look.discovery.snapshot();
    let trace = look.trace();

    let gateways = gateways_section(&mut out, plan, &all, &snap, known);
    motion_section(&mut out, &look.statuses);
    let served_list: Vec<Served> = all.iter().map(|s| s.served.clone()).collect();
    let report = diagnose(&snap, &served_list);
    let seen = Seen {
        plan,
        all: &all,
        report: &report,
        gateways: &gateways,
    };
    let clients = owners_section(&mut out, &seen);
    layout_section(&mut out, &seen, &look.probes, opts.listen);
    let selected = selected_names(&trace, &ifs);
    network_section(&mut out, plan, &trace, &selected, &snap);
    let relevant = relevant_participants(&report, &gateways);
    subnet_section(&mut out, &snap, &relevant, &selected, &ifs);
    let scanned: Vec<(u32, Arc<Snapshot>)> = look.scans.iter().map(|s| (s.domain, s.discovery.snapshot())).collect();
    let elsewhere = scan_section(&mut out, &scanned, &look.scan_errors, &served_list);
    if clients.missing_any() {
        elsewhere_section(
            &mut out,
            plan,
            &elsewhere,
            relevant.is_empty(),
            &selected,
            &ifs,
            |sel: &[&str]| match &opts.sweep {
                Some(sw) => sweep(sw, plan, opts.listen, &ifs, sel),
                None => Vec::new(),
            },
        );
    }

    out.relevant = relevant.len();
    summary_section(&mut out);
    drop(look);
    Ok(out)
}

/// What the doctor keeps joined while it listens: the profile's domain (discovery and the
/// layout probes) and the scanned domains. Fields drop in order: the readers first, the
/// participant last.
struct Look {
    probes: Vec<Probe>,
    /// The running gateways' status (`status_topic`), when read on this side, and the
    /// newest sample of each gateway (by profile and host).
    status: Option<handgate_adapters::dds::Reader<hgmsg::GatewayStatus_>>,
    statuses: BTreeMap<(String, String), hgmsg::GatewayStatus_>,
    scans: Vec<Scan>,
    scan_errors: Vec<String>,
    discovery: Discovery,
    _node: Node,
    /// CycloneDDS's trace of its interface choice (read, then removed, by [`Look::trace`]).
    trace_file: std::path::PathBuf,
}

impl Look {
    /// Joins `plan`'s domain through `interface` (with CycloneDDS's trace of its interface
    /// choice), a layout probe on each topic where the profile reads a type with a layout
    /// history, and the `scan` domains other than the profile's.
    fn join(
        plan: &Plan,
        interface: Option<&str>,
        all: &[ServedBy],
        scan: &[u32],
        status: bool,
    ) -> Result<Look, DoctorError> {
        let trace_file =
            std::env::temp_dir().join(format!("handgate-doctor-{}-{}.log", std::process::id(), plan.domain));
        let node = match Node::with_trace(plan.domain, interface, &trace_file) {
            // A temporary directory CycloneDDS's XML cannot name: look without the trace (the
            // network section then says it could not read CycloneDDS's choice).
            Err(DdsError::BadTracePath(_)) => Node::new(plan.domain, interface)?,
            r => r?,
        };
        let discovery = Discovery::start(&node, DiscoveryConfig::default())?;
        let mut probes = Vec::new();
        for s in all {
            // Samples come from the counterpart: layouts of what clients write to a front and of
            // what a service writes to a device. Readers send none (see docs/troubleshooting.md).
            if s.served.role != Role::Reader || is_emulated(plan, &s.owner) {
                continue;
            }
            if let Some(reader) = layout_reader(&node, &s.served.topic, &s.served.type_name)? {
                probes.push(Probe {
                    owner: s.owner.clone(),
                    topic: s.served.topic.clone(),
                    type_name: s.served.type_name.clone(),
                    reader,
                    seen: BTreeMap::new(),
                    older: BTreeSet::new(),
                    unknown: 0,
                    total: 0,
                    expected: s.served.entries,
                    entries: BTreeMap::new(),
                    check: s.served.sample_check,
                    mistakes: BTreeMap::new(),
                });
            }
        }
        let status = if status {
            Some(node.reader::<hgmsg::GatewayStatus_>(&plan.status_topic, Qos::BestEffort)?)
        } else {
            None
        };
        let mut scans = Vec::new();
        let mut scan_errors = Vec::new();
        for &d in scan.iter().filter(|&&d| d != plan.domain) {
            match Node::new(d, interface).and_then(|n| Ok((Discovery::start(&n, DiscoveryConfig::default())?, n))) {
                Ok((discovery, n)) => scans.push(Scan {
                    domain: d,
                    discovery,
                    _node: n,
                }),
                Err(e) => scan_errors.push(format!("domain {d}: {e}")),
            }
        }
        Ok(Look {
            probes,
            status,
            statuses: BTreeMap::new(),
            scans,
            scan_errors,
            discovery,
            _node: node,
            trace_file,
        })
    }

    /// Listens for `listen`, the probes reading the samples as they come.
    fn listen(&mut self, listen: Duration) {
        let start = Instant::now();
        while start.elapsed() < listen {
            self.poll();
            std::thread::sleep(Duration::from_millis(50).min(listen.saturating_sub(start.elapsed())));
        }
        self.poll();
    }

    fn poll(&mut self) {
        for p in &mut self.probes {
            p.poll();
        }
        if let Some(r) = &self.status {
            for s in r.take() {
                self.statuses.insert((s.profile.clone(), s.host.clone()), s);
            }
        }
    }

    /// CycloneDDS's interface choice, from its trace (empty when it could not be read); the
    /// trace file is removed.
    fn trace(&self) -> InterfaceTrace {
        let trace = InterfaceTrace::parse(&std::fs::read_to_string(&self.trace_file).unwrap_or_default());
        let _ = std::fs::remove_file(&self.trace_file);
        trace
    }
}

/// What the doctor saw on the profile's domain, as the sections of its report read it.
struct Seen<'a> {
    plan: &'a Plan,
    /// What the profile's gateway would serve ([`served`]).
    all: &'a [ServedBy],
    /// [`diagnose`] of `all` (its topics in the order of `all`).
    report: &'a Report,
    /// Gateways already running ([`running_gateways`]): their endpoints are not the profile's
    /// clients.
    gateways: &'a BTreeSet<Guid>,
}

/// How the fronts and devices fared ([`owners_section`]).
#[derive(Debug, Default, Clone, PartialEq, Eq)]
struct Clients {
    fronts: usize,
    fronts_with_client: usize,
    /// Fronts without a client and devices without their service.
    missing: usize,
}

impl Clients {
    /// Something the profile needs was found nowhere on its domain: worth looking on the
    /// other domains and interfaces.
    fn missing_any(&self) -> bool {
        self.missing > 0 || (self.fronts > 0 && self.fronts_with_client == 0)
    }
}

/// The interface the profile asks for: a problem when it does not exist here, is down or has
/// no address (the doctor then looks through CycloneDDS's own choice). Returns the interface
/// to look through.
fn interface_section(out: &mut Outcome, plan: &Plan, ifs: &[NetIf]) -> Option<String> {
    let name = plan.interface.as_ref()?;
    let others: Vec<String> = ifs
        .iter()
        .filter(|i| i.up && !i.addrs.is_empty())
        .map(describe_if)
        .collect();
    let bad = match ifs.iter().find(|i| &i.name == name) {
        None => Some(format!("interface {name} does not exist on this host")),
        Some(i) if !i.up => Some(format!("interface {name} is down")),
        Some(i) if i.addrs.is_empty() => Some(format!("interface {name} has no IP address")),
        Some(_) => None,
    };
    let Some(what) = bad else {
        return Some(name.clone());
    };
    out.problem(
        "",
        what,
        format!(
            "set dds.interface in the profile (or --interface) to one of: {}; the doctor looks with CycloneDDS's own choice instead",
            others.join(", ")
        ),
    );
    None
}

/// A gateway already running on the domain (a remote writer of the status topic): one line
/// each. Returns them.
fn gateways_section(
    out: &mut Outcome,
    plan: &Plan,
    all: &[ServedBy],
    snap: &Snapshot,
    known: &[(Option<String>, u32)],
) -> BTreeSet<Guid> {
    let gateways = running_gateways(snap, &plan.status_topic);
    // A known gateway's participant on this side (its devices', status elsewhere).
    let by_process: BTreeSet<Guid> = snap
        .participants
        .iter()
        .filter(|p| p.origin == Origin::Remote && !gateways.contains(&p.key))
        .filter(|p| {
            let host = p.hostname.as_deref().map(str::to_string);
            p.pid.is_some_and(|pid| known.contains(&(host, pid)))
        })
        .map(|p| p.key)
        .collect();
    for g in &by_process {
        let who = snap
            .participant(g)
            .map_or_else(|| format!("participant {g}"), who_participant);
        out.line(format!(
            "handgate already serving, its devices on domain {}: {who} (the gateway found on the export side); its writers are not counted as foreign below",
            plan.domain
        ));
    }
    for g in &gateways {
        if let Some(p) = snap.participant(g) {
            if let Some(pid) = p.pid {
                out.gateways.push((p.hostname.as_deref().map(str::to_string), pid));
            }
        }
        let who = snap
            .participant(g)
            .map_or_else(|| format!("participant {g}"), who_participant);
        let writes: BTreeSet<&str> = snap
            .endpoints
            .iter()
            .filter(|e| e.participant == *g && e.role == Role::Writer)
            .map(|e| &*e.topic)
            .collect();
        let ours = all
            .iter()
            .filter(|s| matches!(s.owner, Owner::Front(_)) && s.served.role == Role::Writer)
            .filter(|s| writes.contains(s.served.topic.as_str()))
            .count();
        let total = all
            .iter()
            .filter(|s| matches!(s.owner, Owner::Front(_)) && s.served.role == Role::Writer)
            .count();
        out.line(format!(
            "handgate already serving on domain {}: {who} (writes {}; {ours} of this profile's {total} front state topics); its writers are not counted as foreign below",
            plan.domain, plan.status_topic
        ));
    }
    gateways.into_iter().chain(by_process).collect()
}

/// Whether the running gateways' devices follow their commands (their status's `motion`,
/// docs/adapters.md "Motion"): a device that reports but does not move is a problem.
fn motion_section(out: &mut Outcome, statuses: &BTreeMap<(String, String), hgmsg::GatewayStatus_>) {
    for s in statuses.values() {
        // Holding an object is what a hand is for: a line, not a problem.
        for d in s.devices.iter().filter(|d| d.motion == hgmsg::MOTION_HOLDING) {
            out.line(format!(
                "motion: device {}: {}",
                d.device,
                crate::tools::motion_sentence(d)
            ));
        }
        let moving: Vec<&hgmsg::DeviceStatus_> = s
            .devices
            .iter()
            .filter(|d| d.motion != hgmsg::MOTION_OK && d.motion != hgmsg::MOTION_HOLDING)
            .collect();
        if moving.is_empty() {
            out.line(format!(
                "motion: every device of gateway {} on {} follows its command",
                s.profile, s.host
            ));
        }
        for d in moving {
            out.problem(
                "",
                format!(
                    "motion: device {}: {} (tracking error {:.3} rad)",
                    d.device,
                    crate::tools::motion_sentence(d),
                    d.tracking_error
                ),
                match d.motion {
                    hgmsg::MOTION_FROZEN => "the device's service or firmware repeats one state: restart the service, check its bus and the hand's power",
                    hgmsg::MOTION_JOINT_STUCK => "the joint is blocked or its motor faulted: check the finger for an obstacle or a broken tendon, the motor's error bits and temperature",
                    _ => "the device takes no command: check that its service receives this gateway's commands (topic, domain), its mode and that its motors are enabled",
                },
            );
        }
    }
}

/// Each front and device of the profile ([`owner_section`]); a device without its service is
/// a problem, and so is no client on any front.
fn owners_section(out: &mut Outcome, seen: &Seen<'_>) -> Clients {
    let plan = seen.plan;
    let mut owners: Vec<&Owner> = Vec::new();
    for s in seen.all {
        if !owners.contains(&&s.owner) {
            owners.push(&s.owner);
        }
    }
    let mut clients = Clients::default();
    let mut front_findings = 0usize;
    for owner in owners {
        if is_emulated(plan, owner) {
            out.line(format!(
                "{owner}: emulated inside `handgate run` (its service is the gateway's own, nothing to find on DDS)"
            ));
            continue;
        }
        out.line(owner.describe());
        let o = owner_section(out, seen, owner);
        match owner {
            Owner::Front(_) => {
                clients.fronts += 1;
                front_findings += o.findings;
                if o.any_matched {
                    clients.fronts_with_client += 1;
                } else if o.on_demand {
                    clients.fronts_with_client += 1;
                    out.line("  a client, on topics served once it is discovered (notes above)");
                } else {
                    out.line("  no client");
                    clients.missing += o.unmatched.len();
                }
            }
            Owner::Device(name) => {
                if !o.any_matched {
                    out.problem(
                        "  ",
                        format!(
                            "service not found for device {name} (nothing answers on {})",
                            o.unmatched.join(", ")
                        ),
                        format!(
                            "start the robot's service on domain {} (or point the device at the domain and topics it uses); check the interface below",
                            plan.domain
                        ),
                    );
                    clients.missing += 1;
                }
            }
        }
    }
    // Clients that are there but do not match were each reported above.
    if clients.fronts > 0 && clients.fronts_with_client == 0 && front_findings == 0 {
        out.problem(
            "",
            format!(
                "no client on any of the {} front(s) on domain {}",
                clients.fronts, plan.domain
            ),
            "start the client on this domain with the front's topics (`handgate check` lists them); see the domain scan and interfaces below",
        );
    }
    clients
}

/// What one front's or device's endpoints showed ([`owner_section`]).
#[derive(Debug, Default)]
struct OwnerSeen {
    /// A counterpart matched one of its endpoints.
    any_matched: bool,
    /// A client on a topic the front serves once it is discovered (an `auto` front's
    /// actuator pair): a client, on topics not served yet.
    on_demand: bool,
    /// Its topics nothing matched.
    unmatched: Vec<String>,
    /// Problems reported for near misses (wrong type, QoS, topic; a foreign writer).
    findings: usize,
}

/// One front's or device's endpoints: per endpoint, who matches it, and what keeps each near
/// miss from matching (a problem with its fix).
fn owner_section(out: &mut Outcome, seen: &Seen<'_>, owner: &Owner) -> OwnerSeen {
    let mut o = OwnerSeen::default();
    for (s, t) in seen
        .all
        .iter()
        .zip(&seen.report.topics)
        .filter(|(s, _)| &s.owner == owner)
    {
        let want = role_word(s.served.role.counterpart());
        // A front that follows its clients' types (a variant `auto`) serves several.
        let types = std::iter::once(&s.served.type_name)
            .chain(&s.served.also)
            .map(String::as_str)
            .collect::<Vec<_>>()
            .join(" or ");
        let matched: Vec<&RemoteRef> = t
            .matched
            .iter()
            .filter(|r| !seen.gateways.contains(&r.participant))
            .collect();
        if matched.is_empty() {
            out.line(format!(
                "  {} ({} of {types}): no {want}",
                s.served.topic,
                role_word(s.served.role),
            ));
            o.unmatched.push(s.served.topic.clone());
        } else {
            o.any_matched = true;
            let who: Vec<String> = matched.iter().map(|r| r.who()).collect();
            out.line(format!(
                "  {} ({} of {types}): {} matched {want}(s): {}",
                s.served.topic,
                role_word(s.served.role),
                matched.len(),
                who.join("; ")
            ));
        }
        for f in &t.findings {
            let label = match &f.kind {
                FindingKind::NoCounterpart => continue,
                FindingKind::TypeMismatch { .. } => "wrong type",
                FindingKind::QosMismatch { .. } => "QoS mismatch",
                FindingKind::NearMissTopic { .. } => "near-miss topic",
                FindingKind::ServedOnDemand { .. } => {
                    o.on_demand = true;
                    let detail = f.detail.replace("this process serves", "the profile's gateway serves");
                    out.line(format!(
                        "  note: {detail} ({}): {}",
                        list_refs(&f.remotes, f.remote_count),
                        f.fix
                    ));
                    continue;
                }
                FindingKind::ForeignWriter => {
                    if f.remotes.iter().all(|r| seen.gateways.contains(&r.participant))
                        && f.remote_count == f.remotes.len()
                    {
                        continue;
                    }
                    "foreign writer"
                }
            };
            // `diagnose` words its details for the process that serves; the doctor
            // speaks for the profile's gateway, which is not running here.
            let detail = f
                .detail
                .replace("this process does not serve", "the profile does not serve")
                .replace("this process serves", "the profile serves")
                .replace(
                    "which this process writes too",
                    "which the profile's gateway would write too",
                );
            let named = f.remotes.first().is_some_and(|r| detail.contains(&r.who()));
            let who = if named {
                String::new()
            } else {
                format!(" ({})", list_refs(&f.remotes, f.remote_count))
            };
            out.problem("  ", format!("{label}: {detail}{who}"), &f.fix);
            o.findings += 1;
        }
    }
    o
}

/// The layout of the samples each probe read: a problem for samples in an older (or an
/// unknown) layout, a note for matched writers that sent nothing.
fn layout_section(out: &mut Outcome, seen: &Seen<'_>, probes: &[Probe], listen: Duration) {
    let Seen {
        all, report, gateways, ..
    } = *seen;
    for p in probes {
        if p.total == 0 {
            let writers: Vec<String> = all
                .iter()
                .zip(&report.topics)
                .filter(|(s, _)| s.owner == p.owner && s.served.topic == p.topic && s.served.role == Role::Reader)
                .flat_map(|(_, t)| {
                    t.matched
                        .iter()
                        .filter(|r| !gateways.contains(&r.participant))
                        .map(RemoteRef::who)
                })
                .collect();
            if !writers.is_empty() {
                out.line(format!(
                    "note: {} matched writer(s) on {} sent no sample in {:.1} s ({}): the client exists but does not write (idle, or its send loop failed)",
                    writers.len(),
                    p.topic,
                    listen.as_secs_f64(),
                    writers.join("; ")
                ));
            }
            continue;
        }
        entries_problem(out, p);
        mistakes_problem(out, p);
        let older: Vec<&str> = p.older.iter().copied().collect();
        if !older.is_empty() || p.unknown > 0 {
            let sizes: Vec<String> = p
                .seen
                .iter()
                .map(|(k, (n, size, cur))| match cur {
                    Some(c) => format!("{n} sample(s) of {size} bytes: {k} (the current layout: {c} bytes)"),
                    None => format!("{n} sample(s) of {size} bytes: {k}"),
                })
                .collect();
            let what = if older.is_empty() {
                format!(
                    "samples on {} ({}) of {} do not have the current {} layout: {}",
                    p.topic,
                    p.owner,
                    p.type_name,
                    short_type(&p.type_name),
                    sizes.join(", ")
                )
            } else {
                format!(
                    "stale {} layout on {} ({}): {}",
                    short_type(&p.type_name),
                    p.topic,
                    p.owner,
                    sizes.join(", ")
                )
            };
            let fix = match p.owner {
                Owner::Front(_) => "update the client's unitree_sdk2 / unitree_sdk2py (or its copy of the hg IDL) to the current layout (docs/sources.md §1): the type name is the same, so DDS matches it but the fields land in the wrong places; a client on the old SDK also cannot read the current HandState_",
                Owner::Device(_) => "the service writes an older layout than handgate reads: update the robot's service (firmware) or ask its vendor; handgate follows unitree_sdk2's current IDL",
            };
            out.problem("", what, fix);
        } else {
            out.line(format!(
                "layout: {} sample(s) on {} have the current {} layout",
                p.total,
                p.topic,
                short_type(&p.type_name)
            ));
        }
    }
    if all
        .iter()
        .any(|s| s.served.role == Role::Writer && layout::checked_types().any(|t| t == s.served.type_name))
    {
        out.line(
            "layout: the HandState_ layout of client readers cannot be checked (a reader sends no samples); a client on an older SDK shows through the HandCmd_ it writes",
        );
    }
}

/// Samples a front refuses for a mistake their client repeats ([`Served::sample_check`]: a
/// Dex3 client that never sets the mode byte), with the fix.
fn mistakes_problem(out: &mut Outcome, p: &Probe) {
    for ((what, fix), n) in &p.mistakes {
        out.problem(
            "",
            format!(
                "{n} of {} sample(s) on {} ({}) are refused: {what}",
                p.total, p.topic, p.owner
            ),
            fix,
        );
    }
}

/// Samples of a probe carrying another number of entries than its owner expects: another
/// hand answers (or commands) on these topics. Names the registered kinds whose hands carry
/// that many entries of this type ([`KindFactory::served_by_default`]), so a Dex5-1 answering
/// on a Dex3-1's topics is told from a Dex3-1, and the reverse.
///
/// [`KindFactory::served_by_default`]: handgate_adapters::kind::KindFactory::served_by_default
fn entries_problem(out: &mut Outcome, p: &Probe) {
    let Some(want) = p.expected else { return };
    let other: Vec<(usize, usize)> = p
        .entries
        .iter()
        .filter(|(n, _)| **n != want)
        .map(|(n, c)| (*n, *c))
        .collect();
    if other.is_empty() {
        return;
    }
    for (n, samples) in other {
        let kinds: Vec<String> = handgate_adapters::kind::DeviceKind::all()
            .iter()
            .filter(|k| {
                [Side::Left, Side::Right].into_iter().any(|side| {
                    k.factory()
                        .served_by_default(side)
                        .iter()
                        .any(|s| s.serves_type(&p.type_name) && s.entries == Some(n))
                })
            })
            .map(|k| k.to_string())
            .collect();
        let what = format!(
            "{samples} sample(s) on {} ({}) carry {n} entries of {} where {want} are expected: another hand answers here",
            p.topic,
            p.owner,
            short_type(&p.type_name)
        );
        let fix = match kinds.as_slice() {
            [] => "no registered kind uses that many entries: check which hand or service writes this topic".to_string(),
            ks => format!(
                "a hand of kind {} carries {n}: set that kind for {} (its own topics are the kind's default; `handgate check` shows them), or point this {} at its own hand's topics",
                ks.join(" or "),
                p.owner,
                match p.owner {
                    Owner::Front(_) => "client",
                    Owner::Device(_) => "device",
                }
            ),
        };
        out.problem("", what, fix);
    }
}

/// `network:`: the interfaces CycloneDDS found and selected (its trace), whether multicast
/// works on the selected ones (a loopback probe), and the remote participants and hosts
/// discovery reached.
fn network_section(out: &mut Outcome, plan: &Plan, trace: &InterfaceTrace, selected: &[&NetIf], snap: &Snapshot) {
    out.line("network:");
    match &trace.found {
        Some(f) => out.line(format!("  CycloneDDS found: {f}")),
        None => out.line("  CycloneDDS's interface trace was not readable"),
    }
    if let Some(sel) = &trace.selected {
        out.line(format!("  CycloneDDS selected: {sel}"));
    }
    for n in &trace.notes {
        out.line(format!("  CycloneDDS: {n}"));
    }
    for i in selected {
        match (i.ipv4(), i.multicast) {
            (_, false) => out.line(format!(
                "  multicast on {}: the interface has no MULTICAST flag; CycloneDDS then discovers by unicast only (configured peers, or this host)",
                i.name
            )),
            (None, true) => out.line(format!("  multicast on {}: no IPv4 address to probe from", i.name)),
            (Some(ip), true) => match netif::multicast_loopback_probe(ip, Duration::from_millis(500)) {
                Ok(rtt) => out.line(format!(
                    "  multicast on {}: loopback probe ok ({:.2} ms to {}; proves this host sends and receives multicast on {}, not that the network beyond forwards it)",
                    i.name,
                    rtt.as_secs_f64() * 1e3,
                    netif::PROBE_GROUP,
                    i.name
                )),
                Err(e) => out.problem(
                    "  ",
                    format!("multicast on {} does not work here: {e}", i.name),
                    "enable multicast on the interface (`ip link set IF multicast on`, a route for 224.0.0.0/4) or configure CycloneDDS peers",
                ),
            },
        }
    }
    let my_host = snap
        .participant(&snap.this_participant)
        .and_then(|p| p.hostname.clone());
    let remote: Vec<&Participant> = snap
        .participants
        .iter()
        .filter(|p| p.origin == Origin::Remote)
        .collect();
    let other_hosts: BTreeSet<&str> = remote
        .iter()
        .filter_map(|p| p.hostname.as_deref())
        .filter(|h| Some(*h) != my_host.as_deref())
        .collect();
    out.line(format!(
        "  {} remote participant(s) on domain {}{}",
        remote.len(),
        plan.domain,
        if other_hosts.is_empty() {
            String::new()
        } else {
            format!(
                ", from other hosts: {} (discovery reaches them)",
                other_hosts.iter().copied().collect::<Vec<_>>().join(", ")
            )
        }
    ));
}

/// The remote participants with endpoints for the profile (matched or near misses), running
/// gateways left out.
fn relevant_participants(report: &Report, gateways: &BTreeSet<Guid>) -> BTreeSet<Guid> {
    report
        .topics
        .iter()
        .flat_map(|t| {
            t.matched
                .iter()
                .map(|r| r.participant)
                .chain(t.findings.iter().flat_map(|f| f.remotes.iter().map(|r| r.participant)))
        })
        .filter(|g| !gateways.contains(g))
        .collect()
}

/// A problem for each `relevant` participant whose address is on none of the `selected`
/// interfaces' subnets ([`subnet_problem`]).
fn subnet_section(out: &mut Outcome, snap: &Snapshot, relevant: &BTreeSet<Guid>, selected: &[&NetIf], ifs: &[NetIf]) {
    if selected.is_empty() {
        return;
    }
    for g in relevant {
        let Some(p) = snap.participant(g) else { continue };
        let Some(ip) = p.unicast_address().and_then(|a| a.parse::<IpAddr>().ok()) else {
            continue;
        };
        if let Some((what, fix)) = subnet_problem(&who_participant(p), ip, selected, ifs) {
            out.problem("  ", what, fix);
        }
    }
}

/// `domain scan (...)`: per scanned domain (its snapshot), the endpoints it has for the
/// profile, or how many other participants; the domains that could not be joined. Returns
/// the domains with endpoints for the profile.
fn scan_section(
    out: &mut Outcome,
    scanned: &[(u32, Arc<Snapshot>)],
    scan_errors: &[String],
    served_list: &[Served],
) -> Vec<u32> {
    if !scanned.is_empty() || !scan_errors.is_empty() {
        let doms: Vec<String> = scanned.iter().map(|(d, _)| d.to_string()).collect();
        out.line(format!("domain scan ({}):", doms.join(", ")));
    }
    let mut elsewhere = Vec::new();
    for (domain, snap) in scanned {
        let r = diagnose(snap, served_list);
        let mut clients: Vec<String> = Vec::new();
        let mut n = 0usize;
        for t in &r.topics {
            let near: Vec<&RemoteRef> = t
                .findings
                .iter()
                .filter(|f| !matches!(f.kind, FindingKind::NoCounterpart | FindingKind::ForeignWriter))
                .flat_map(|f| f.remotes.iter())
                .collect();
            for r in t.matched.iter().chain(near) {
                n += 1;
                let w = format!("{} {} ({})", r.topic, role_word(r.role), r.who());
                if !clients.contains(&w) {
                    clients.push(w);
                }
            }
        }
        if n > 0 {
            out.line(format!(
                "  domain {domain}: {n} endpoint(s) for this profile: {}",
                clients.join("; ")
            ));
            elsewhere.push(*domain);
        } else {
            let others = snap.participants.iter().filter(|p| p.origin == Origin::Remote).count();
            out.line(format!(
                "  domain {domain}: nothing for this profile ({others} other participant(s))"
            ));
        }
    }
    for e in scan_errors {
        out.line(format!("  could not join {e}"));
    }
    elsewhere
}

/// Where the missing clients and services may be: a problem per domain where the scan found
/// them (`elsewhere`); when none was found anywhere (`nothing_here`), the look through this
/// host's other interfaces (`sweep`, given the selected interfaces' names: each interface's
/// count of participants for the profile) and what it says, or a hint.
fn elsewhere_section(
    out: &mut Outcome,
    plan: &Plan,
    elsewhere: &[u32],
    nothing_here: bool,
    selected: &[&NetIf],
    ifs: &[NetIf],
    sweep: impl FnOnce(&[&str]) -> Vec<(String, Result<usize, String>)>,
) {
    for d in elsewhere {
        out.problem(
            "",
            format!("your clients are on domain {d}, the profile uses domain {}", plan.domain),
            format!(
                "run handgate on domain {d} (dds.domain = {d} in the profile, or --domain {d}; a robot's own services use 0), or start the clients on domain {} (ChannelFactoryInitialize({}, ...))",
                plan.domain, plan.domain
            ),
        );
    }
    if !(elsewhere.is_empty() && nothing_here) {
        return;
    }
    let sel: Vec<&str> = selected.iter().map(|i| i.name.as_str()).collect();
    let alternatives: Vec<String> = ifs
        .iter()
        .filter(|i| i.up && !i.addrs.is_empty() && !sel.contains(&i.name.as_str()))
        .map(describe_if)
        .collect();
    let through = if sel.is_empty() {
        "CycloneDDS's interface".to_string()
    } else {
        sel.join(", ")
    };
    let swept = sweep(&sel);
    let found: Vec<&(String, Result<usize, String>)> =
        swept.iter().filter(|(_, r)| matches!(r, Ok(n) if *n > 0)).collect();
    if !swept.is_empty() {
        let each: Vec<String> = swept
            .iter()
            .map(|(name, r)| match r {
                Ok(n) => format!("{name}: {n} participant(s) for this profile"),
                Err(e) => format!("{name}: {e}"),
            })
            .collect();
        out.line(format!("interface sweep (domain {}): {}", plan.domain, each.join("; ")));
    }
    if let Some((name, _)) = found.first() {
        out.problem(
            "",
            format!("nothing for this profile reached this host through {through}, but through {name} it does"),
            format!("select {name}: --interface {name} (dds.interface = \"{name}\" in the profile)"),
        );
    } else if !selected.is_empty() && selected.iter().all(|i| i.loopback) && !alternatives.is_empty() {
        out.problem(
            "",
            format!(
                "DDS here uses only the loopback interface {}: nothing on another host can be seen, and nothing for this profile was seen on this one",
                sel.join(", ")
            ),
            format!(
                "select the interface of the clients' network: --interface NAME (dds.interface) with one of: {}",
                alternatives.join(", ")
            ),
        );
    } else if !alternatives.is_empty() {
        out.line(format!(
            "hint: nothing for this profile reached this host through {through}; if the clients run elsewhere, their network may be on another interface here: {} (--interface NAME)",
            alternatives.join(", ")
        ));
    }
}

/// The last line: nothing wrong, or how many problems.
fn summary_section(out: &mut Outcome) {
    if out.problems.is_empty() {
        out.line("doctor: nothing wrong found");
    } else {
        out.line(format!("doctor: {} problem(s)", out.problems.len()));
    }
}

/// Runs `handgate doctor --count-only` on the profile's domain through each up interface with
/// an address that is not one of `selected`, all at once, and returns each one's count of
/// participants for the profile (or why it could not look).
fn sweep(
    sw: &Sweep,
    plan: &Plan,
    listen: Duration,
    ifs: &[NetIf],
    selected: &[&str],
) -> Vec<(String, Result<usize, String>)> {
    let children: Vec<(String, std::io::Result<std::process::Child>)> = ifs
        .iter()
        .filter(|i| i.up && i.ipv4().is_some() && !selected.contains(&i.name.as_str()))
        .map(|i| {
            let mut cmd = std::process::Command::new(&sw.exe);
            cmd.arg("doctor");
            if let Some(p) = &sw.profile {
                cmd.arg("--profile").arg(p);
            }
            let child = cmd
                .arg("--domain")
                .arg(plan.domain.to_string())
                .arg("--interface")
                .arg(&i.name)
                .arg("--no-scan")
                .arg("--seconds")
                .arg(listen.as_secs_f64().to_string())
                .arg("--count-only")
                .stdin(std::process::Stdio::null())
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::null())
                .spawn();
            (i.name.clone(), child)
        })
        .collect();
    children
        .into_iter()
        .map(|(name, child)| {
            let r = child
                .and_then(|c| c.wait_with_output())
                .map_err(|e| e.to_string())
                .and_then(|o| {
                    String::from_utf8_lossy(&o.stdout)
                        .lines()
                        .find_map(|l| l.strip_prefix("relevant ").and_then(|n| n.trim().parse().ok()))
                        .ok_or_else(|| format!("the look through it failed ({})", o.status))
                });
            (name, r)
        })
        .collect()
}

/// When a client at `ip` is on none of the `selected` interfaces' subnets: what to say and
/// the fix (another interface of this host has its subnet, or none does).
fn subnet_problem(who: &str, ip: IpAddr, selected: &[&NetIf], ifs: &[NetIf]) -> Option<(String, String)> {
    if selected.is_empty() || ip.is_loopback() && selected.iter().any(|i| i.loopback) {
        return None;
    }
    if selected.iter().any(|i| i.on_subnet(ip)) {
        return None;
    }
    let sel: Vec<&str> = selected.iter().map(|i| i.name.as_str()).collect();
    Some(match ifs.iter().find(|i| i.on_subnet(ip)) {
        Some(other) => (
            format!("{who} is on {}'s subnet, but DDS here uses {}", other.name, sel.join(", ")),
            format!(
                "use the same interface on both sides: --interface {} (dds.interface = \"{}\"), or move the client to {}",
                other.name,
                other.name,
                sel.join(", ")
            ),
        ),
        None => (
            format!("{who} is on a subnet none of this host's interfaces has"),
            "put this host and the client on one subnet (e.g. 192.168.123.0/24 on a Unitree robot's network) and select that interface".to_string(),
        ),
    })
}

/// `<package>::msg::dds_::<Type>` -> `<Type>`.
fn short_type(t: &str) -> &str {
    t.rsplit("::").next().unwrap_or(t)
}

/// Whether `owner` is a device whose service runs inside `handgate run` (the emulator
/// backend): the doctor has nothing to look for on DDS then.
fn is_emulated(plan: &Plan, owner: &Owner) -> bool {
    match owner {
        Owner::Device(name) => plan
            .devices
            .iter()
            .any(|d| &d.name == name && d.backend == Backend::Emulator),
        Owner::Front(_) => false,
    }
}

/// `A-B` or `N` (domains), each at most [`MAX_DOMAIN_ID`].
pub fn parse_scan(s: &str) -> Result<Vec<u32>, String> {
    let (a, b) = match s.split_once('-') {
        Some((a, b)) => (a.trim(), b.trim()),
        None => (s.trim(), s.trim()),
    };
    let a: u32 = a.parse().map_err(|e| format!("{a:?} is not a domain id: {e}"))?;
    let b: u32 = b.parse().map_err(|e| format!("{b:?} is not a domain id: {e}"))?;
    if a > b {
        return Err(format!("{a}-{b}: the range is empty"));
    }
    if b > MAX_DOMAIN_ID {
        return Err(format!(
            "domain {b} is above {MAX_DOMAIN_ID}, the highest CycloneDDS's port mapping allows"
        ));
    }
    if b - a > 31 {
        return Err(format!("{a}-{b}: at most 32 domains at once"));
    }
    Ok((a..=b).collect())
}

/// The default scan: domains 0–5 (a robot's services use 0).
pub fn default_scan() -> Vec<u32> {
    (0..=5).collect()
}

/// Keeps the listen window sane.
pub fn listen_time(seconds: f64) -> Result<Duration, String> {
    if !(seconds.is_finite() && (0.2..=60.0).contains(&seconds)) {
        return Err(format!("{seconds} s: listen between 0.2 and 60 s"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

#[cfg(test)]
mod tests {

    #[test]
    fn a_port_held_by_another_program_is_a_problem_naming_it_and_a_slow_ftdi_timer_too() {
        use handgate_adapters::serial::PortHolder;
        let port = std::env::temp_dir().join(format!("handgate-doctor-port-{}", std::process::id()));
        std::fs::write(&port, b"").unwrap();
        let ports = vec![("gripper".to_string(), port.clone())];
        let held = |_: &std::path::Path| {
            vec![
                PortHolder {
                    pid: 7,
                    command: "/usr/bin/handgate run --profile lab".into(),
                    locked: true,
                },
                PortHolder {
                    pid: 9,
                    command: "minicom -D /dev/ttyUSB0".into(),
                    locked: false,
                },
            ]
        };
        let mut out = Outcome::default();
        ports_section(&mut out, &ports, held, |_| Some(16));
        assert!(out.text.contains("owned by handgate, pid 7"), "{}", out.text);
        assert_eq!(out.problems.len(), 2, "{}", out.text);
        assert!(
            out.problems[0].contains("is held by pid 9 (minicom -D /dev/ttyUSB0)"),
            "{}",
            out.text
        );
        assert!(out.problems[1].contains("latency timer of 16 ms"), "{}", out.text);
        assert!(out.text.contains("99-handgate-ftdi-latency.rules"), "{}", out.text);
        let mut out = Outcome::default();
        ports_section(&mut out, &ports, |_| Vec::new(), |_| Some(1));
        assert!(out.problems.is_empty(), "{}", out.text);
        assert!(
            out.text.contains("free") && out.text.contains("latency timer 1 ms"),
            "{}",
            out.text
        );
        std::fs::remove_file(&port).unwrap();
        let mut out = Outcome::default();
        ports_section(&mut out, &ports, held, |_| Some(16));
        assert!(
            out.problems.is_empty() && out.text.contains("is not present"),
            "{}",
            out.text
        );
    }

    #[test]
    fn the_real_holder_of_a_pty_is_found_and_reported() {
        let pty = handgate_adapters::serial::Pty::open().unwrap();
        let mut child = std::process::Command::new("flock")
            .arg(pty.slave_path())
            .args(["sleep", "30"])
            .spawn()
            .expect("flock(1) from util-linux");
        let ports = vec![("hand".to_string(), pty.slave_path().to_path_buf())];
        let deadline = Instant::now() + Duration::from_secs(10);
        let out = loop {
            let mut out = Outcome::default();
            ports_section(&mut out, &ports, handgate_adapters::serial::holders, |_| None);
            if !out.problems.is_empty() || Instant::now() > deadline {
                break out;
            }
            std::thread::yield_now();
        };
        child.kill().unwrap();
        child.wait().unwrap();
        assert_eq!(out.problems.len(), 1, "{}", out.text);
        assert!(
            out.problems[0].contains(&format!("pid {} (flock", child.id())),
            "{}",
            out.text
        );
    }

    /// A probe of `topic` owned by `owner`, expecting `expected` entries, that saw `seen`
    /// (entries, samples).
    fn entries_probe(owner: Owner, topic: &str, expected: usize, seen: &[(usize, usize)]) -> Probe {
        struct NoSamples;
        impl RawTake for NoSamples {
            fn take_bytes(&self) -> Vec<Vec<u8>> {
                Vec::new()
            }
        }
        Probe {
            owner,
            topic: topic.into(),
            type_name: handgate_adapters::dds::type_name::<handgate_idl::unitree_hg::HandState_>(),
            reader: Box::new(NoSamples),
            seen: BTreeMap::new(),
            older: BTreeSet::new(),
            unknown: 0,
            total: seen.iter().map(|(_, n)| n).sum(),
            expected: Some(expected),
            entries: seen.iter().copied().collect(),
            check: None,
            mistakes: BTreeMap::new(),
        }
    }

    /// A Dex3 client that leaves the mode byte 0 (issue #37: ipa-alb/unitree_g1_simulation's
    /// hand controller) is told why its commands are refused (the lock status, not a wrong
    /// motor id) and how to fix it; one that sets `id | 0x10` is not.
    #[test]
    fn a_dex3_client_leaving_the_mode_byte_0_is_told_the_lock_and_the_fix() {
        struct Samples(Vec<Vec<u8>>);
        impl RawTake for Samples {
            fn take_bytes(&self) -> Vec<Vec<u8>> {
                self.0.clone()
            }
        }
        let body = |mode: fn(u8) -> u8| {
            let mut c = handgate_idl::unitree_hg::HandCmd_::sdk_default();
            for (i, m) in c.motor_cmd.iter_mut().enumerate() {
                m.mode = mode(i as u8);
            }
            handgate_idl::cdr_codec::to_cdr_le(&c).unwrap()[4..].to_vec()
        };
        let probe = |samples: Vec<Vec<u8>>| {
            // The default profile's Dex3 front, as the doctor sees it.
            let served = crate::diagnostics::served(&crate::resolve::default_plan())
                .into_iter()
                .find(|s| s.served.topic == "rt/dex3/left/cmd" && s.served.role == Role::Reader)
                .and_then(|s| s.served.sample_check);
            assert!(served.is_some(), "the Dex3 front checks its clients' samples");
            let mut p = entries_probe(Owner::Front("dex3_left".into()), "rt/dex3/left/cmd", 7, &[]);
            p.type_name = handgate_adapters::dds::type_name::<handgate_idl::unitree_hg::HandCmd_>();
            p.reader = Box::new(Samples(samples));
            p.check = served;
            p.poll();
            let mut out = Outcome::default();
            mistakes_problem(&mut out, &p);
            out
        };
        let out = probe(vec![body(|_| 0); 3]);
        assert_eq!(out.problems.len(), 1, "{}", out.text);
        assert!(
            out.text.contains("3 of 3 sample(s) on rt/dex3/left/cmd")
                && out.text.contains("status 0 (lock)")
                && out.text.contains("fix: set each entry's mode to id | 0x10"),
            "{}",
            out.text
        );
        let out = probe(vec![body(|i| 0x10 | i); 3]);
        assert!(out.problems.is_empty(), "{}", out.text);
    }

    /// A hand of another kind on a device's topics is named by the kind whose hands carry
    /// its entry count; the owner's own count is no problem.
    #[test]
    fn samples_of_another_entry_count_name_the_kind_that_carries_it() {
        let mut out = Outcome::default();
        entries_problem(
            &mut out,
            &entries_probe(Owner::Device("left".into()), "rt/x/left/state", 7, &[(7, 40)]),
        );
        assert!(out.problems.is_empty(), "{}", out.text);
        let mut out = Outcome::default();
        entries_problem(
            &mut out,
            &entries_probe(Owner::Device("left".into()), "rt/x/left/state", 20, &[(7, 12), (20, 3)]),
        );
        assert_eq!(out.problems.len(), 1, "{}", out.text);
        assert!(
            out.text.contains(
                "12 sample(s) on rt/x/left/state (device left) carry 7 entries of HandState_ where 20 are expected"
            ),
            "{}",
            out.text
        );
        assert!(out.text.contains("a hand of kind dex3 carries 7"), "{}", out.text);
        let mut out = Outcome::default();
        entries_problem(
            &mut out,
            &entries_probe(Owner::Device("left".into()), "rt/x/left/state", 7, &[(3, 1)]),
        );
        assert!(
            out.text.contains("no registered kind uses that many entries"),
            "{}",
            out.text
        );
    }
    use super::*;
    use crate::diagnostics::tests::snapshots::snap;
    use crate::profile::{load, EnvLayer, LoadOptions};

    const HG_CMD: &str = "unitree_hg::msg::dds_::HandCmd_";
    const HG_STATE: &str = "unitree_hg::msg::dds_::HandState_";
    const CANONICAL_CMD: &str = "handgate::msg::dds_::HandCmd_";

    /// The shipped profile `name`'s plan.
    fn shipped_plan(name: &str) -> Plan {
        let l = load(&LoadOptions {
            profile: Some(name.into()),
            env: EnvLayer::Ignore,
            search_dirs: Some(vec![]),
            ..LoadOptions::default()
        })
        .unwrap();
        crate::resolve::plan(&l.profile).unwrap()
    }

    /// `owners_section` of `plan` on `snap` (participants in `gateways` a running gateway).
    fn owners(plan: &Plan, snap: &Snapshot, gateways: &[u8]) -> (Outcome, Clients) {
        let all = served(plan);
        let served_list: Vec<Served> = all.iter().map(|s| s.served.clone()).collect();
        let report = diagnose(snap, &served_list);
        let gateways: BTreeSet<Guid> = gateways.iter().map(|p| Guid([*p; 16]).participant()).collect();
        let seen = Seen {
            plan,
            all: &all,
            report: &report,
            gateways: &gateways,
        };
        let mut out = Outcome::default();
        let clients = owners_section(&mut out, &seen);
        (out, clients)
    }

    fn netif(name: &str, ip: &str, loopback: bool) -> NetIf {
        NetIf {
            name: name.into(),
            up: true,
            loopback,
            multicast: !loopback,
            addrs: vec![netif::IfAddr {
                ip: ip.parse().unwrap(),
                prefix: 24,
            }],
        }
    }

    #[test]
    fn nothing_on_the_domain_is_a_problem_per_device_and_one_for_the_fronts() {
        let plan = shipped_plan("g1-dex3");
        let (out, clients) = owners(&plan, &snap(&[]), &[]);
        assert_eq!(
            out.problems,
            vec![
                "service not found for device left_hand (nothing answers on rt/dex3/left/cmd, rt/dex3/left/state)",
                "service not found for device right_hand (nothing answers on rt/dex3/right/cmd, rt/dex3/right/state)",
                "no client on any of the 3 front(s) on domain 0",
            ]
        );
        assert_eq!((clients.fronts, clients.fronts_with_client), (3, 0));
        assert!(clients.missing_any());
        assert!(out.text.contains("front joint_state\n  rt/joint_states (writer of sensor_msgs::msg::dds_::JointState_): no reader\n  no client\n"), "{}", out.text);
    }

    #[test]
    fn a_service_and_a_client_match_but_a_running_gateway_is_no_client() {
        use handgate_adapters::discovery::Origin::Remote;
        let plan = shipped_plan("g1-dex3");
        let snap = snap(&[
            // The left hand's service.
            (2, Remote, Role::Reader, "rt/dex3/left/cmd", HG_CMD),
            (2, Remote, Role::Writer, "rt/dex3/left/state", HG_STATE),
            // A client of the left hand's canonical front.
            (3, Remote, Role::Writer, "rt/handgate/left_hand/cmd", CANONICAL_CMD),
        ]);
        let (out, clients) = owners(&plan, &snap, &[]);
        assert_eq!(
            out.problems,
            vec!["service not found for device right_hand (nothing answers on rt/dex3/right/cmd, rt/dex3/right/state)"]
        );
        assert_eq!((clients.fronts, clients.fronts_with_client), (3, 1));
        assert!(
            clients.missing_any(),
            "the right hand's service and two fronts' clients are missing"
        );
        assert!(
            out.text.contains("  rt/handgate/left_hand/cmd (reader of handgate::msg::dds_::HandCmd_): 1 matched writer(s): process python (pid 103)"),
            "{}",
            out.text
        );
        // The same writer from a gateway already running is not a client of this profile.
        let (out, clients) = owners(&plan, &snap, &[3]);
        assert_eq!(clients.fronts_with_client, 0);
        assert_eq!(
            out.problems.last().unwrap(),
            "no client on any of the 3 front(s) on domain 0"
        );
    }

    #[test]
    fn a_bad_interface_is_a_problem_and_the_doctor_looks_without_it() {
        let mut plan = shipped_plan("g1-dex3");
        let ifs = vec![netif("lo", "127.0.0.1", true), netif("eth1", "192.168.123.5", false)];
        let mut out = Outcome::default();
        assert_eq!(interface_section(&mut out, &plan, &ifs), None);
        assert_eq!(out.problems, vec!["interface eth0 does not exist on this host"]);
        assert!(
            out.text.contains("one of: lo (127.0.0.1/24), eth1 (192.168.123.5/24);"),
            "{}",
            out.text
        );
        plan.interface = Some("eth1".into());
        let mut out = Outcome::default();
        assert_eq!(interface_section(&mut out, &plan, &ifs).as_deref(), Some("eth1"));
        assert_eq!(out.text, "");
    }

    #[test]
    fn the_scan_names_the_domains_with_the_profiles_endpoints() {
        use handgate_adapters::discovery::Origin::Remote;
        let plan = shipped_plan("g1-dex3");
        let served_list: Vec<Served> = served(&plan).into_iter().map(|s| s.served).collect();
        let scanned = vec![
            (
                3,
                Arc::new(snap(&[(
                    2,
                    Remote,
                    Role::Writer,
                    "rt/handgate/left_hand/cmd",
                    CANONICAL_CMD,
                )])),
            ),
            (
                4,
                Arc::new(snap(&[(2, Remote, Role::Writer, "rt/other", CANONICAL_CMD)])),
            ),
        ];
        let mut out = Outcome::default();
        let elsewhere = scan_section(&mut out, &scanned, &["domain 5: refused".into()], &served_list);
        assert_eq!(elsewhere, vec![3]);
        assert_eq!(
            out.text,
            "domain scan (3, 4):\n  domain 3: 1 endpoint(s) for this profile: rt/handgate/left_hand/cmd writer (process python (pid 102) on vm)\n  domain 4: nothing for this profile (1 other participant(s))\n  could not join domain 5: refused\n"
        );
        assert!(out.problems.is_empty());
    }

    #[test]
    fn clients_elsewhere_name_their_domain_or_the_interface_that_reaches_them() {
        let plan = shipped_plan("g1-dex3");
        let ifs = vec![netif("lo", "127.0.0.1", true), netif("eth1", "192.168.123.5", false)];
        let lo = [&ifs[0]];
        let no_sweep =
            |_: &[&str]| -> Vec<(String, Result<usize, String>)> { panic!("no sweep when a domain has them") };
        let mut out = Outcome::default();
        elsewhere_section(&mut out, &plan, &[3], true, &lo, &ifs, no_sweep);
        assert_eq!(
            out.problems,
            vec!["your clients are on domain 3, the profile uses domain 0"]
        );

        let mut out = Outcome::default();
        elsewhere_section(&mut out, &plan, &[], true, &lo, &ifs, |sel| {
            assert_eq!(sel, ["lo"]);
            vec![("eth1".into(), Ok(2))]
        });
        assert!(
            out.text
                .starts_with("interface sweep (domain 0): eth1: 2 participant(s) for this profile\n"),
            "{}",
            out.text
        );
        assert_eq!(
            out.problems,
            vec!["nothing for this profile reached this host through lo, but through eth1 it does"]
        );

        // Nothing through the other interfaces either: DDS on loopback only is the problem.
        let mut out = Outcome::default();
        elsewhere_section(&mut out, &plan, &[], true, &lo, &ifs, |_| vec![("eth1".into(), Ok(0))]);
        assert_eq!(
            out.problems,
            vec!["DDS here uses only the loopback interface lo: nothing on another host can be seen, and nothing for this profile was seen on this one"]
        );

        // Participants for the profile on this domain (near misses): no interface advice.
        let mut out = Outcome::default();
        elsewhere_section(&mut out, &plan, &[], false, &lo, &ifs, no_sweep);
        assert_eq!((out.text.as_str(), out.problems.len()), ("", 0));
    }

    #[test]
    fn scan_ranges() {
        assert_eq!(parse_scan("140-142").unwrap(), vec![140, 141, 142]);
        assert_eq!(parse_scan("7").unwrap(), vec![7]);
        assert!(parse_scan("5-3").is_err());
        assert!(parse_scan("230-240").is_err());
        assert!(parse_scan("0-100").is_err());
        assert!(parse_scan("x").is_err());
        assert!(listen_time(0.0).is_err());
        assert!(listen_time(3.0).is_ok());
    }

    #[test]
    fn selected_interface_names_from_the_trace() {
        let ifs = vec![
            NetIf {
                name: "lo".into(),
                up: true,
                loopback: true,
                multicast: false,
                addrs: vec![],
            },
            NetIf {
                name: "eth0".into(),
                up: true,
                loopback: false,
                multicast: true,
                addrs: vec![],
            },
        ];
        let t = InterfaceTrace {
            selected: Some("eth0 (index 4 priority 0)".into()),
            ..Default::default()
        };
        let names: Vec<&str> = selected_names(&t, &ifs).iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, vec!["eth0"]);
    }

    #[test]
    fn clients_on_another_subnet() {
        let ifa = |name: &str, ip: &str, prefix: u8, lo: bool| NetIf {
            name: name.into(),
            up: true,
            loopback: lo,
            multicast: !lo,
            addrs: vec![netif::IfAddr {
                ip: ip.parse().unwrap(),
                prefix,
            }],
        };
        let ifs = vec![
            ifa("lo", "127.0.0.1", 8, true),
            ifa("eth0", "10.0.0.5", 24, false),
            ifa("eth1", "192.168.123.222", 24, false),
        ];
        let eth0 = [&ifs[1]];
        let ip = |s: &str| s.parse::<IpAddr>().unwrap();
        assert!(subnet_problem("c", ip("10.0.0.9"), &eth0, &ifs).is_none());
        let (what, fix) = subnet_problem("c", ip("192.168.123.161"), &eth0, &ifs).unwrap();
        assert_eq!(what, "c is on eth1's subnet, but DDS here uses eth0");
        assert!(fix.contains("--interface eth1"), "{fix}");
        let (what, _) = subnet_problem("c", ip("172.16.0.1"), &eth0, &ifs).unwrap();
        assert!(what.contains("none of this host's interfaces"), "{what}");
        // A client on this host using lo, while DDS here uses eth0.
        let (what, _) = subnet_problem("c", ip("127.0.0.1"), &eth0, &ifs).unwrap();
        assert!(what.contains("lo's subnet"), "{what}");
        assert!(subnet_problem("c", ip("127.0.0.1"), &[&ifs[0]], &ifs).is_none());
    }

    #[test]
    fn security_section_prints_and_counts() {
        use crate::security::diagnose::Finding;
        use handgate_adapters::dds_security::Security;
        let sec = Security::from_enclave(std::path::Path::new("/k/enclaves/robot_a"), None);
        let targets = vec![
            SecurityTarget {
                section: "[export.security]",
                domain: 11,
                identity: Ok(sec),
            },
            SecurityTarget {
                section: "[dds.security]",
                domain: 3,
                identity: Err("certificate"),
            },
        ];
        let mut out = Outcome::default();
        security_section(&mut out, &targets, |s, d| {
            assert_eq!(
                (s.certificate.as_path(), d),
                (std::path::Path::new("/k/enclaves/robot_a/cert.pem"), 11)
            );
            vec![
                Finding::KeyMismatch,
                Finding::KeyReadable {
                    path: "/k/key.pem".into(),
                    mode: 0o100640,
                },
                Finding::Passed("the certificate was issued by the identity CA CN=lab".into()),
            ]
        });
        assert_eq!(out.problems.len(), 2, "{}", out.text);
        assert!(
            out.text.starts_with("DDS Security [export.security] on domain 11:\n"),
            "{}",
            out.text
        );
        assert!(
            out.text
                .contains("  PROBLEM [export.security]: the private key does not match the certificate"),
            "{}",
            out.text
        );
        assert!(out.text.contains("  WARNING [export.security]: private_key: /k/key.pem is readable by its group (mode 640)\n    fix: chmod 600 /k/key.pem"), "{}", out.text);
        assert!(
            out.text
                .contains("  OK the certificate was issued by the identity CA CN=lab"),
            "{}",
            out.text
        );
        assert!(
            out.text
                .contains("PROBLEM [dds.security]: no `certificate` and no `enclave` to take it from"),
            "{}",
            out.text
        );
    }
}
