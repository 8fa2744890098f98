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
use std::time::{Duration, Instant};

use handgate_adapters::dds::{layout_reader, DdsError, InterfaceTrace, Node, RawTake};
use handgate_adapters::device::Backend;
use handgate_adapters::discovery::diagnose::{diagnose, FindingKind, RemoteRef, Served};
use handgate_adapters::discovery::{Discovery, DiscoveryConfig, Guid, Origin, Participant, Role, Snapshot};
use handgate_adapters::netif::{self, NetIf};
use handgate_idl::layout::{self, Verdict};

use crate::diagnostics::{served, Owner};
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
}

impl Probe {
    fn poll(&mut self) {
        for bytes in self.reader.take_bytes() {
            let Some(c) = layout::check(&self.type_name, &bytes) else {
                continue;
            };
            self.total += 1;
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
/// overrides).
pub fn run(plan: &Plan, opts: &Options) -> Result<Outcome, DoctorError> {
    let mut out = Outcome::default();
    let all = served(plan);
    let ifs = netif::list().map_err(DoctorError::Interfaces)?;

    out.line(format!(
        "handgate doctor: profile {}, DDS domain {}, listening {:.1} s",
        plan.profile,
        plan.domain,
        opts.listen.as_secs_f64()
    ));

    // --- The interface the profile asks for.
    let mut interface = plan.interface.clone();
    if let Some(name) = &plan.interface {
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
        if let Some(what) = bad {
            out.problem(
                "",
                what,
                format!(
                    "set dds.interface in the profile (or --interface) to one of: {}; the doctor looks with CycloneDDS's own choice instead",
                    others.join(", ")
                ),
            );
            interface = None;
        }
    }

    // --- Join the domain (with CycloneDDS's trace of its interface choice) and the scan.
    let trace_file = std::env::temp_dir().join(format!("handgate-doctor-{}-{}.log", std::process::id(), plan.domain));
    let node = match Node::with_trace(plan.domain, interface.as_deref(), &trace_file) {
        // A temporary directory CycloneDDS's XML cannot name: look without the trace (the
        // network section then says it could not read CycloneDDS's choice).
        Err(DdsError::BadTracePath(_)) => Node::new(plan.domain, interface.as_deref())?,
        r => r?,
    };
    let discovery = Discovery::start(&node, DiscoveryConfig::default())?;
    let mut probes = Vec::new();
    for s in &all {
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
            });
        }
    }
    let mut scans = Vec::new();
    let mut scan_errors = Vec::new();
    for &d in opts.scan.iter().filter(|&&d| d != plan.domain) {
        match Node::new(d, interface.as_deref())
            .and_then(|n| Ok((Discovery::start(&n, DiscoveryConfig::default())?, n)))
        {
            Ok((discovery, n)) => scans.push(Scan {
                domain: d,
                discovery,
                _node: n,
            }),
            Err(e) => scan_errors.push(format!("domain {d}: {e}")),
        }
    }

    let start = Instant::now();
    while start.elapsed() < opts.listen {
        for p in &mut probes {
            p.poll();
        }
        std::thread::sleep(Duration::from_millis(50).min(opts.listen.saturating_sub(start.elapsed())));
    }
    for p in &mut probes {
        p.poll();
    }
    let snap = discovery.snapshot();
    let trace = InterfaceTrace::parse(&std::fs::read_to_string(&trace_file).unwrap_or_default());
    let _ = std::fs::remove_file(&trace_file);

    // --- A gateway already running.
    let gateways = running_gateways(&snap, &plan.status_topic);
    for g in &gateways {
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

    // --- Fronts and devices.
    let served_list: Vec<Served> = all.iter().map(|s| s.served.clone()).collect();
    let report = diagnose(&snap, &served_list);
    let mut owners: Vec<Owner> = Vec::new();
    for s in &all {
        if !owners.contains(&s.owner) {
            owners.push(s.owner.clone());
        }
    }
    let mut fronts_with_client = 0;
    let mut front_findings = 0usize;
    let mut fronts = 0;
    let mut missing_anywhere: Vec<&str> = Vec::new();
    for owner in &owners {
        if is_emulated(plan, owner) {
            out.line(format!(
                "{owner}: emulated inside `handgate run` (its service is the gateway's own, nothing to find on DDS)"
            ));
            continue;
        }
        out.line(owner.describe());
        let mut any_matched = false;
        // A client on a topic the front serves once it is discovered (an `auto` front's
        // actuator pair): a client, on topics not served yet.
        let mut on_demand = false;
        let mut unmatched: Vec<String> = Vec::new();
        for (s, t) in all.iter().zip(&report.topics).filter(|(s, _)| &s.owner == owner) {
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
                .filter(|r| !gateways.contains(&r.participant))
                .collect();
            if matched.is_empty() {
                out.line(format!(
                    "  {} ({} of {types}): no {want}",
                    s.served.topic,
                    role_word(s.served.role),
                ));
                unmatched.push(s.served.topic.clone());
            } else {
                any_matched = true;
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
                        on_demand = true;
                        let detail = f.detail.replace("this process serves", "the profile's gateway serves");
                        out.line(format!(
                            "  note: {detail} ({}): {}",
                            list_refs(&f.remotes, f.remote_count),
                            f.fix
                        ));
                        continue;
                    }
                    FindingKind::ForeignWriter => {
                        if f.remotes.iter().all(|r| gateways.contains(&r.participant))
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
                front_findings += usize::from(matches!(owner, Owner::Front(_)));
            }
        }
        match owner {
            Owner::Front(_) => {
                fronts += 1;
                if any_matched {
                    fronts_with_client += 1;
                } else if on_demand {
                    fronts_with_client += 1;
                    out.line("  a client, on topics served once it is discovered (notes above)");
                } else {
                    out.line("  no client");
                    missing_anywhere.extend(unmatched.iter().map(|_| owner.name()));
                }
            }
            Owner::Device(name) => {
                if !any_matched {
                    out.problem(
                        "  ",
                        format!("service not found for device {name} (nothing answers on {})", unmatched.join(", ")),
                        format!(
                            "start the robot's service on domain {} (or point the device at the domain and topics it uses); check the interface below",
                            plan.domain
                        ),
                    );
                    missing_anywhere.push(name);
                }
            }
        }
    }
    // Clients that are there but do not match were each reported above.
    if fronts > 0 && fronts_with_client == 0 && front_findings == 0 {
        out.problem(
            "",
            format!("no client on any of the {fronts} front(s) on domain {}", plan.domain),
            "start the client on this domain with the front's topics (`handgate check` lists them); see the domain scan and interfaces below",
        );
    }

    // --- Layout of the samples read.
    for p in &probes {
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
                    opts.listen.as_secs_f64(),
                    writers.join("; ")
                ));
            }
            continue;
        }
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

    // --- Interfaces and multicast.
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
    let selected = selected_names(&trace, &ifs);
    for i in &selected {
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
    // Clients whose address is on none of the selected interfaces' subnets.
    let relevant: BTreeSet<Guid> = report
        .topics
        .iter()
        .flat_map(|t| {
            t.matched
                .iter()
                .map(|r| r.participant)
                .chain(t.findings.iter().flat_map(|f| f.remotes.iter().map(|r| r.participant)))
        })
        .filter(|g| !gateways.contains(g))
        .collect();
    if !selected.is_empty() {
        for g in &relevant {
            let Some(p) = snap.participant(g) else { continue };
            let Some(ip) = p.unicast_address().and_then(|a| a.parse::<IpAddr>().ok()) else {
                continue;
            };
            if let Some((what, fix)) = subnet_problem(&who_participant(p), ip, &selected, &ifs) {
                out.problem("  ", what, fix);
            }
        }
    }

    // --- Other domains.
    if !scans.is_empty() || !scan_errors.is_empty() {
        let doms: Vec<String> = scans.iter().map(|s| s.domain.to_string()).collect();
        out.line(format!("domain scan ({}):", doms.join(", ")));
    }
    let mut elsewhere = Vec::new();
    for s in &scans {
        let snap = s.discovery.snapshot();
        let r = diagnose(&snap, &served_list);
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
                "  domain {}: {n} endpoint(s) for this profile: {}",
                s.domain,
                clients.join("; ")
            ));
            elsewhere.push(s.domain);
        } else {
            let others = snap.participants.iter().filter(|p| p.origin == Origin::Remote).count();
            out.line(format!(
                "  domain {}: nothing for this profile ({others} other participant(s))",
                s.domain
            ));
        }
    }
    for e in &scan_errors {
        out.line(format!("  could not join {e}"));
    }
    if !missing_anywhere.is_empty() || (fronts > 0 && fronts_with_client == 0) {
        for d in &elsewhere {
            out.problem(
                "",
                format!("your clients are on domain {d}, the profile uses domain {}", plan.domain),
                format!(
                    "run handgate on domain {d} (dds.domain = {d} in the profile, or --domain {d}; a robot's own services use 0), or start the clients on domain {} (ChannelFactoryInitialize({}, ...))",
                    plan.domain, plan.domain
                ),
            );
        }
        if elsewhere.is_empty() && relevant.is_empty() {
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
            let swept = match &opts.sweep {
                Some(sw) => sweep(sw, plan, opts.listen, &ifs, &sel),
                None => Vec::new(),
            };
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
    }

    out.relevant = relevant.len();
    if out.problems.is_empty() {
        out.line("doctor: nothing wrong found");
    } else {
        out.line(format!("doctor: {} problem(s)", out.problems.len()));
    }
    drop(probes);
    drop(scans);
    Ok(out)
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
    use super::*;

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
}
