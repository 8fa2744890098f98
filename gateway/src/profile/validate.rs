//! Semantic checks on a deserialized profile. Every check runs; all problems are returned.

use std::collections::{BTreeMap, HashMap};

use super::error::KeyPath;
use super::schema::*;
use handgate_adapters::kind::{a, check_rate, check_topic, FleetMember};
use handgate_adapters::motion::MotionThresholds;

/// A problem found by [`validate`]: key path and message (the loader adds the origin).
pub type Problem = (KeyPath, String);

/// Checks everything that serde cannot: ranges, names, cross references, topic clashes.
pub fn validate(p: &Profile) -> Vec<Problem> {
    let mut c = Checker::default();
    c.profile(p);
    c.out
}

#[derive(Default)]
struct Checker {
    out: Vec<Problem>,
}

/// What the fronts checked so far hold, against which the next front is checked: each
/// command topic, state topic and front name with the first front's index.
#[derive(Default)]
struct FrontsSeen {
    cmd_topics: BTreeMap<Topic, usize>,
    state_topics: BTreeMap<Topic, usize>,
    names: BTreeMap<String, usize>,
}

fn root() -> KeyPath {
    KeyPath::root()
}

/// `"a K1 or K2"`: `kinds` named with one article.
fn names_phrase(kinds: &[DeviceKind]) -> String {
    let names: Vec<&str> = kinds.iter().map(|k| k.as_str()).collect();
    a(&names.join(" or "))
}

fn is_name(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-')
}

impl Checker {
    fn err(&mut self, key: KeyPath, msg: impl Into<String>) {
        self.out.push((key, msg.into()));
    }

    fn rate(&mut self, key: KeyPath, r: RateHz, max: f64) {
        if let Err(m) = check_rate(r.0, max) {
            self.err(key, m);
        }
    }

    fn topic(&mut self, key: KeyPath, t: &Topic) {
        if let Err(m) = check_topic(t.as_str()) {
            self.err(key, m);
        }
    }

    /// `[realtime]`: a priority exactly with a real-time policy, CPUs this process may use.
    fn realtime(&mut self, r: &RealtimeConfig) {
        let k = root().key("realtime");
        if r.loop_threads > handgate_adapters::loops::MAX_THREADS {
            self.err(
                k.key("loop_threads"),
                format!(
                    "must be 0..={} (0: one thread per device loop), got {}",
                    handgate_adapters::loops::MAX_THREADS,
                    r.loop_threads
                ),
            );
        }
        match (r.policy.is_realtime(), r.priority) {
            (true, None) => self.err(
                k.key("priority"),
                format!(
                    "required with policy = \"{}\" (a real-time priority, {PRIORITY_MIN}..={PRIORITY_MAX})",
                    r.policy
                ),
            ),
            (true, Some(n)) if !(PRIORITY_MIN..=PRIORITY_MAX).contains(&n) => self.err(
                k.key("priority"),
                format!("must be {PRIORITY_MIN}..={PRIORITY_MAX}, got {n}"),
            ),
            (false, Some(n)) => self.err(
                k.key("priority"),
                format!(
                    "only applies to policy = \"fifo\" or \"rr\"; with policy = \"{}\" remove it (got {n})",
                    r.policy
                ),
            ),
            _ => {}
        }
        if r.cpus.is_empty() {
            return;
        }
        let mut seen = std::collections::BTreeSet::new();
        for (i, c) in r.cpus.iter().enumerate() {
            if !seen.insert(*c) {
                self.err(k.key("cpus").index(i), format!("CPU {c} is listed twice"));
            }
        }
        match handgate_adapters::realtime::allowed_cpus() {
            Ok(allowed) => {
                for (i, c) in r.cpus.iter().enumerate() {
                    if !allowed.contains(c) {
                        self.err(
                            k.key("cpus").index(i),
                            format!(
                                "CPU {c} is not one this process may run on (allowed: {})",
                                handgate_adapters::realtime::CpuList(&allowed)
                            ),
                        );
                    }
                }
            }
            Err(e) => self.err(k.key("cpus"), format!("cannot read the CPUs this process may use: {e}")),
        }
    }

    /// `[export]`: each key, and the two sides together: CycloneDDS holds one configuration
    /// per domain id per process, so one domain id cannot be on two interfaces.
    fn export(&mut self, p: &Profile, e: &ExportConfig) {
        let key = |k| root().key("export").key(k);
        if let Some(d) = e.domain.filter(|d| d.0 > MAX_DOMAIN_ID) {
            self.err(
                key("domain"),
                format!("must be between 0 and {MAX_DOMAIN_ID}, got {}", d.0),
            );
        }
        if let Some(i) = &e.interface {
            if i.trim().is_empty() || i.chars().any(char::is_whitespace) {
                self.err(key("interface"), format!("`{i}` is not an interface name"));
            }
        }
        if let Some(n) = &e.namespace {
            if let Err(why) = handgate_adapters::ros::Namespace::parse(n) {
                self.err(key("namespace"), format!("`{n}` is not a ROS namespace: it {why}"));
            } else if p.dds.namespace.is_some() {
                self.err(
                    key("namespace"),
                    "and dds.namespace are both set: handgate's own topics have one namespace; set it in [export]",
                );
            }
        }
        if let Some(s) = &e.security {
            if p.export_side().is_none() {
                self.err(
                    key("security"),
                    "secures the export side, but it has no domain of its own (export.domain): the clients \
                     and the devices would share one participant; use [dds.security] to secure it, or give \
                     [export] a domain",
                );
            } else {
                self.security(key("security"), s);
            }
        }
        for (i, a) in e.allow_commands_from.iter().enumerate() {
            if let Err(why) = handgate_adapters::front::sources::Net::parse(a) {
                self.err(key("allow_commands_from").index(i), why);
            }
        }
        if e.namespace_fronts && p.namespace().is_root() {
            self.err(
                key("namespace_fronts"),
                "prefixes the fronts' topics with the namespace, but there is none: set export.namespace",
            );
        }
        let Some((domain, export_if)) = p.export_target() else {
            return;
        };
        let devices_if = p.dds.interface.as_deref();
        if domain == p.dds.domain && export_if != devices_if {
            self.err(
                if e.domain.is_some() {
                    key("domain")
                } else {
                    key("interface")
                },
                format!(
                    "puts the export side on domain {} like the devices, on interface {} while the devices are on {}: \
                     CycloneDDS holds one configuration per domain id in a process, so one domain cannot be on two \
                     interfaces; give the export side a domain of its own (export.domain)",
                    domain.0,
                    export_if.unwrap_or("(any)"),
                    devices_if.unwrap_or("(any)"),
                ),
            );
        }
    }

    /// The whole profile, section by section (in this order: the errors come out in it).
    fn profile(&mut self, p: &Profile) {
        self.dds(&p.dds);
        if let Some(e) = &p.export {
            self.export(p, e);
        }
        self.discovery(&p.dds);
        self.log(&p.log);
        if let Some(r) = &p.record {
            self.record(r);
        }
        self.http(&p.http);
        self.realtime(&p.realtime);
        if let Some(f) = &p.foxglove {
            self.foxglove(f);
        }
        self.status(&p.status);
        let by_name = self.devices(p);
        self.fleet(p);
        self.fronts(p, &by_name);
    }

    /// `[dds]`: the domain, the namespace and the interface (discovery: [`Self::discovery`]).
    fn dds(&mut self, d: &DdsConfig) {
        let k = root().key("dds");
        if d.domain.0 > MAX_DOMAIN_ID {
            self.err(
                k.key("domain"),
                format!("must be between 0 and {MAX_DOMAIN_ID}, got {}", d.domain.0),
            );
        }
        if let Some(n) = &d.namespace {
            if let Err(e) = handgate_adapters::ros::Namespace::parse(n) {
                self.err(k.key("namespace"), format!("`{n}` is not a ROS namespace: it {e}"));
            }
        }
        if let Some(i) = &d.interface {
            if i.trim().is_empty() || i.chars().any(char::is_whitespace) {
                self.err(k.key("interface"), format!("`{i}` is not an interface name"));
            }
        }
        if let Some(s) = &d.security {
            self.security(k.key("security"), s);
        }
    }

    /// `[dds.security]` / `[export.security]`: every file given (by its key or the enclave)
    /// and readable. What is inside them (dates, signatures, the grant) is `handgate doctor`'s.
    fn security(&mut self, k: KeyPath, s: &SecurityConfig) {
        let files = match s.resolve() {
            Ok(f) => f,
            Err(missing) => {
                self.err(
                    k.key(missing),
                    "is not given, and there is no `enclave` to take it from: set `enclave` to an enclave \
                     directory of the lab's keystore (`handgate security issue`) or give each file",
                );
                return;
            }
        };
        if let Some(dir) = &s.enclave {
            if !std::path::Path::new(dir).is_dir() {
                self.err(k.key("enclave"), format!("`{dir}` is not a directory"));
                return;
            }
        }
        for (role, path) in files.files() {
            // The key the file came from: its own, else the enclave's.
            let key = if s.own(role).is_some() {
                k.key(role)
            } else {
                k.key("enclave")
            };
            if let Err(e) = std::fs::File::open(path) {
                self.err(key, format!("cannot read {} (the {role}): {e}", path.display()));
            }
        }
    }

    /// `[dds]` discovery: the wait bounded, the settling time within it.
    fn discovery(&mut self, d: &DdsConfig) {
        let k = root().key("dds");
        let (settle, max_wait) = (d.discovery_settle_ms.0, d.discovery_max_wait_ms.0);
        if max_wait > MAX_DISCOVERY_WAIT_MS {
            self.err(
                k.key("discovery_max_wait_ms"),
                format!("must be at most {MAX_DISCOVERY_WAIT_MS} ms, got {max_wait}"),
            );
        }
        if settle > max_wait {
            self.err(
                k.key("discovery_settle_ms"),
                format!("must be at most dds.discovery_max_wait_ms ({max_wait} ms), got {settle}"),
            );
        }
    }

    /// `[log]`: a filter tracing understands.
    fn log(&mut self, l: &LogConfig) {
        if let Err(e) = tracing_subscriber::EnvFilter::try_new(&l.level) {
            self.err(
                root().key("log").key("level"),
                format!("`{}` is not a log filter: {e}", l.level),
            );
        }
    }

    /// `[record]`: a directory, positive bounds, zstd only when built in.
    fn record(&mut self, r: &RecordConfig) {
        let k = root().key("record");
        if r.dir.trim().is_empty() {
            self.err(k.key("dir"), "is empty (a directory for the recordings)".to_string());
        }
        for (key, v) in [("max_mb", r.max_mb), ("max_seconds", r.max_seconds)] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    self.err(k.key(key), format!("must be > 0, got {v}"));
                }
            }
        }
        if r.zstd && !cfg!(feature = "zstd") {
            self.err(
                k.key("zstd"),
                "needs handgate built with the `zstd` feature (cargo build --features zstd)".to_string(),
            );
        }
    }

    /// `[http]`: the bind address, the sampling rate, the page's watchdog, the fleet's
    /// domains, the allowed hosts, the token (read here: a missing, short or shared file is
    /// refused; required off loopback).
    fn http(&mut self, h: &HttpConfig) {
        let k = root().key("http");
        if h.bind.parse::<std::net::IpAddr>().is_err() {
            self.err(
                k.key("bind"),
                format!("`{}` is not an IP address (e.g. \"127.0.0.1\")", h.bind),
            );
        }
        self.rate(k.key("sample_hz"), h.sample_hz, MAX_HTTP_SAMPLE_HZ);
        let wd = h.command_watchdog_ms.0;
        if !(MIN_PAGE_WATCHDOG_MS..=MAX_PAGE_WATCHDOG_MS).contains(&wd) {
            self.err(
                k.key("command_watchdog_ms"),
                format!("must be {MIN_PAGE_WATCHDOG_MS}..={MAX_PAGE_WATCHDOG_MS} ms, got {wd}"),
            );
        }
        if let Some(Err(why)) = h.fleet_domains.as_deref().map(crate::doctor::parse_scan) {
            self.err(k.key("fleet_domains"), why);
        }
        for host in &h.allowed_hosts {
            if let Err(e) = crate::http::host::Host::parse(host) {
                self.err(
                    k.key("allowed_hosts"),
                    format!("{e}: each entry is a host name or an IP address, without scheme or port"),
                );
            }
        }
        if !h.enabled {
            return;
        }
        match &h.token_file {
            Some(f) => {
                if let Err(e) = crate::http::token::Token::load(std::path::Path::new(f)) {
                    self.err(k.key("token_file"), e.to_string());
                }
            }
            None => {
                let open = h
                    .bind
                    .parse::<std::net::IpAddr>()
                    .is_ok_and(|ip| !ip.to_canonical().is_loopback());
                if open {
                    self.err(
                        k.key("token_file"),
                        format!(
                            "required: [http] bind = \"{}\" is not a loopback address, so the dashboard, its \
                             WebSocket and /metrics are reachable from the network; name a file holding a token \
                             (docs/dashboard.md, \"Security\"), or bind 127.0.0.1",
                            h.bind
                        ),
                    );
                }
            }
        }
    }

    /// `[foxglove]`: the bind address, the globs, the feature built in unless disabled.
    fn foxglove(&mut self, f: &FoxgloveConfig) {
        let k = root().key("foxglove");
        if f.bind.parse::<std::net::IpAddr>().is_err() {
            self.err(
                k.key("bind"),
                format!("`{}` is not an IP address (e.g. \"127.0.0.1\")", f.bind),
            );
        }
        if f.topics.iter().any(|g| g.trim().is_empty()) {
            self.err(k.key("topics"), "has an empty glob".to_string());
        }
        if !cfg!(feature = "foxglove") && f.enabled != Some(false) {
            let key = if f.enabled.is_some() { k.key("enabled") } else { k };
            self.err(
                key,
                "the Foxglove live server needs handgate built with the `foxglove` feature \
                 (cargo build --release -p handgate --features foxglove, or make run); or set \
                 [foxglove] enabled = false"
                    .to_string(),
            );
        }
    }

    /// `[status]`: its topic and rate.
    fn status(&mut self, s: &StatusConfig) {
        self.topic(root().key("status").key("topic"), &s.topic);
        self.rate(root().key("status").key("rate_hz"), s.rate_hz, MAX_STATUS_RATE_HZ);
    }

    /// `[[devices]]`: names valid and distinct, then each device's own rules. Returns each
    /// name's (first) index.
    fn devices<'p>(&mut self, p: &'p Profile) -> HashMap<&'p str, usize> {
        let mut by_name: HashMap<&str, usize> = HashMap::new();
        for (i, d) in p.devices.iter().enumerate() {
            let k = root().key("devices").index(i);
            if !is_name(d.name.as_str()) {
                self.err(
                    k.key("name"),
                    format!("`{}` is not a device name (use a-z, 0-9, `_`, `-`)", d.name),
                );
            }
            if let Some(first) = by_name.insert(d.name.as_str(), i) {
                by_name.insert(d.name.as_str(), first);
                self.err(
                    k.key("name"),
                    format!("duplicate device name `{}` (also devices[{first}])", d.name),
                );
            }
            self.device(&k, d);
        }
        by_name
    }

    /// `[[fronts]]`: each front's binding, its own rules, its name, and its topics against
    /// the other fronts', the status topic and the DDS devices'.
    fn fronts(&mut self, p: &Profile, by_name: &HashMap<&str, usize>) {
        let mut seen = FrontsSeen::default();
        let known = || {
            let v: Vec<&str> = p.devices.iter().map(|d| d.name.as_str()).collect();
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        for (i, f) in p.fronts.iter().enumerate() {
            let k = root().key("fronts").index(i);
            let missing = match &f.devices {
                Some(FrontDevices::List(list)) => self.device_list(&k, f, list, by_name, &known),
                Some(FrontDevices::Elements(els)) => self.device_elements(&k, f, els, by_name, &known),
                None => false,
            };
            let dev = self.front_device(&k, p, f, by_name, &known);
            let dangling = (f.device.is_some() && dev.is_none()) || missing;
            self.front(&k, f, dev, dangling);
            if dev.is_none() && one_device(f) && (f.devices.is_none() || missing) {
                // Its topics depend on a device that is not there; already reported.
                continue;
            }
            self.front_name(&k, p, i, f, dev, &mut seen);
            let topics = p.front_topics(f, dev);
            // A front binding a list names its devices' joints in the messages it takes.
            if let (false, Some(t)) = (missing, topics.state().or(topics.cmd())) {
                self.joint_names(&k, f, p, t);
            }
            if !missing {
                self.drivable(&k, f, p);
            }
            self.front_topics(&k, p, i, f, &topics, &mut seen);
        }
    }

    /// A front's `devices = { right = "..", left = ".." }`: only on a front binding by
    /// element, not beside `device` or `side`, at least one, distinct, known. Returns whether
    /// a name is missing (reported).
    fn device_elements(
        &mut self,
        k: &KeyPath,
        f: &FrontConfig,
        els: &ElementDevices,
        by_name: &HashMap<&str, usize>,
        known: &dyn Fn() -> String,
    ) -> bool {
        if !f.by_element() {
            self.err(
                k.key("devices"),
                format!(
                    "only {} binds devices by element; use `device`{}",
                    FrontKind::binding_elements(),
                    if f.kind().takes_commands() && !f.kind().factory().facts().binds_list {
                        ""
                    } else {
                        ", or list them: `devices = [\"..\", \"..\"]`"
                    }
                ),
            );
        }
        if f.device.is_some() {
            self.err(
                k.key("devices"),
                "give either `device` (one device, on the front's side) or `devices` (by element), not both",
            );
        }
        if f.side().is_some() {
            let what = f.kind().factory().facts().binds_elements.unwrap_or("this front");
            self.err(
                k.key("side"),
                format!("{what} bound with `devices` serves both elements (0 = right, 1 = left); drop `side`"),
            );
        }
        if els.bound().is_empty() {
            self.err(
                k.key("devices"),
                "bind at least one element: `devices = { right = \"..\", left = \"..\" }`",
            );
        }
        if let (Some(r), Some(l)) = (&els.right, &els.left) {
            if r == l {
                self.err(k.key("devices"), format!("`{r}` is bound to both elements"));
            }
        }
        let mut missing = false;
        for (side, n) in els.bound() {
            if !by_name.contains_key(n.as_str()) {
                missing = true;
                self.err(
                    k.key("devices").key(side.as_str()),
                    format!("no device named `{n}` (devices: {})", known()),
                );
            }
        }
        missing
    }

    /// The device a front's `device` names, if it is there (reported if not, or if a front
    /// driving one device names none).
    fn front_device<'p>(
        &mut self,
        k: &KeyPath,
        p: &'p Profile,
        f: &FrontConfig,
        by_name: &HashMap<&str, usize>,
        known: &dyn Fn() -> String,
    ) -> Option<&'p DeviceConfig> {
        match &f.device {
            Some(n) => match by_name.get(n.as_str()) {
                Some(&di) => Some(&p.devices[di]),
                None => {
                    self.err(k.key("device"), format!("no device named `{n}` (devices: {})", known()));
                    None
                }
            },
            None => {
                if one_device(f) && f.devices.is_none() {
                    self.err(
                        k.key("device"),
                        format!("{} front must name its device", a(f.kind().as_str())),
                    );
                }
                None
            }
        }
    }

    /// A front's name (given or derived): valid, and not another front's.
    fn front_name(
        &mut self,
        k: &KeyPath,
        p: &Profile,
        i: usize,
        f: &FrontConfig,
        dev: Option<&DeviceConfig>,
        seen: &mut FrontsSeen,
    ) {
        let name = f.display_name(dev);
        if f.name.is_some() && !is_name(&name) {
            self.err(
                k.key("name"),
                format!("`{name}` is not a front name (use a-z, 0-9, `_`, `-`)"),
            );
        }
        match seen.names.get(&name) {
            // Two derived names only coincide on fronts serving the same topic: reported below.
            Some(&j) if f.name.is_some() || p.fronts[j].name.is_some() => self.err(
                k.key("name"),
                format!("front name `{name}` is also fronts[{j}]'s; give each front its own `name`"),
            ),
            Some(_) => {}
            None => {
                seen.names.insert(name, i);
            }
        }
    }

    /// A front's topics: none the status topic, no command topic served twice, no state
    /// topic published twice, none a DDS device's on the same domain.
    fn front_topics(
        &mut self,
        k: &KeyPath,
        p: &Profile,
        i: usize,
        f: &FrontConfig,
        topics: &FrontTopics,
        seen: &mut FrontsSeen,
    ) {
        let status_topic = p.status_topic();
        // The status extension beside it (docs/wire-types.md, "Status: frozen, and its extension").
        let status_ext_topic = Topic(handgate_idl::handgate::status_ext_topic(status_topic.as_str()));
        let is_status = |t: &Topic| *t == status_topic || *t == status_ext_topic;
        let mut cmd_clash = None;
        for t in topics.topics.iter().filter(|t| t.role == TopicRole::Command) {
            let Some(topic) = &t.topic else { continue };
            if is_status(topic) {
                self.err(
                    k.key(t.key),
                    format!("command topic `{topic}` is the status topic or its extension"),
                );
            }
            match seen.cmd_topics.get(topic) {
                Some(&j) => {
                    cmd_clash = Some(j);
                    let why = f.clash_hint(&p.fronts[j]);
                    self.err(
                        k.key(t.key),
                        format!("command topic `{topic}` is already served by fronts[{j}]{why}"),
                    );
                }
                None => {
                    seen.cmd_topics.insert(topic.clone(), i);
                }
            }
        }
        // Two publishers of one state topic would interleave two views of the fleet.
        for t in topics.topics.iter().filter(|t| t.role.writes()) {
            let Some(topic) = &t.topic else { continue };
            if is_status(topic) {
                self.err(
                    k.key(t.key),
                    format!("state topic `{topic}` is the status topic or its extension"),
                );
            }
            match seen.state_topics.get(topic) {
                // Same pair of fronts as the command clash: one error is enough.
                Some(&j) if cmd_clash == Some(j) => {}
                Some(&j) => self.err(
                    k.key(t.key),
                    format!("state topic `{topic}` is already published by fronts[{j}]: two fronts would interleave their state on it"),
                ),
                None => {
                    seen.state_topics.insert(topic.clone(), i);
                }
            }
        }
        // A front must not serve a topic handgate itself uses to reach a DDS device on
        // the same domain: it would answer its own commands. With `[export]` on a domain
        // of its own the fronts are on another domain: the robot's service names, served
        // to the lab (the point of exporting).
        let same_domain = p.export_side().is_none();
        for (di, d) in p.devices.iter().enumerate().filter(|_| same_domain) {
            if let Some((dcmd, dstate)) = d.dds_topics() {
                let clash = topics.topics.iter().find_map(|t| {
                    let theirs = if t.role.writes() { &dstate } else { &dcmd };
                    t.topic.as_ref().filter(|t| theirs.as_ref() == Some(*t))
                });
                if let Some(topic) = clash {
                    self.err(
                        k.clone(),
                        format!(
                            "serves `{topic}` which devices[{di}] (`{}`, backend dds) uses to reach the real device on the same domain",
                            d.name
                        ),
                    );
                }
            }
        }
    }

    /// A state-only front's `devices = [..]`: known, distinct, not beside `device`. Returns
    /// whether a name is missing (reported).
    fn device_list(
        &mut self,
        k: &KeyPath,
        f: &FrontConfig,
        list: &[DeviceName],
        by_name: &HashMap<&str, usize>,
        known: &dyn Fn() -> String,
    ) -> bool {
        if one_device(f) {
            let how = match f.kind().factory().facts().binds_elements {
                Some(_) => "bind by element, `devices = { right = \"..\", left = \"..\" }`, or give `device`",
                None => "give `device`",
            };
            self.err(
                k.key("devices"),
                format!(
                    "a list of devices is for fronts that publish state only or name joints (joint_state, joint_state_command); {} takes commands: {how}",
                    a(f.kind().as_str())
                ),
            );
        }
        if f.device.is_some() {
            self.err(
                k.key("devices"),
                "give either `device` (one device) or `devices` (a list), not both",
            );
        }
        if list.is_empty() {
            self.err(
                k.key("devices"),
                "list at least one device, or leave `devices` out to publish every device",
            );
        }
        let mut missing = false;
        let mut seen = std::collections::HashSet::new();
        for (j, n) in list.iter().enumerate() {
            if !by_name.contains_key(n.as_str()) {
                missing = true;
                self.err(
                    k.key("devices").index(j),
                    format!("no device named `{n}` (devices: {})", known()),
                );
            } else if !seen.insert(n.as_str()) {
                self.err(k.key("devices").index(j), format!("`{n}` is listed twice"));
            }
        }
        missing
    }

    /// Every device a front commands must be one it can move (`FrontConfig::cannot_drive`):
    /// reported on the key that binds it (`devices[j]`, `device`, or the front itself when
    /// it binds every device by default).
    fn drivable(&mut self, k: &KeyPath, f: &FrontConfig, p: &Profile) {
        for (_, name) in p.front_bindings(f) {
            let Some(d) = p.devices.iter().find(|d| &d.name == name) else {
                continue;
            };
            let Some(why) = f.cannot_drive(&d.kind.factory().table(d.side, &*d.config)) else {
                continue;
            };
            let listed = f
                .devices
                .as_ref()
                .and_then(|l| l.list())
                .and_then(|l| l.iter().position(|n| n == name));
            let (key, how) = match (listed, &f.device, &f.devices) {
                (Some(j), _, _) => (k.key("devices").index(j), "leave it out of `devices`"),
                (None, Some(_), _) => (k.key("device"), "bind another device"),
                (None, None, None) => (
                    k.clone(),
                    "this front binds every device by default: list the others (`devices = [..]`)",
                ),
                (None, None, Some(_)) => (k.key("devices"), "bind another device"),
            };
            self.err(key, format!("`{name}`: {why}; {how}"));
        }
    }

    /// A front whose messages are keyed by joint name (ROS 2 JointState): no two of its
    /// devices may carry one name, or a reader sees one of them and loses the other (a state
    /// front), or one name would move two joints (a command front).
    fn joint_names(&mut self, k: &KeyPath, f: &FrontConfig, p: &Profile, topic: &Topic) {
        if matches!(f.devices, Some(FrontDevices::Elements(_))) {
            return; // refused for a front that publishes state only
        }
        // A device listed twice is reported by `device_list`, once here.
        let devices = p.published_devices(f);
        // name -> the first device publishing it; per pair of devices, the names both publish.
        let mut first: HashMap<String, usize> = HashMap::new();
        let mut clashes: BTreeMap<(usize, usize), Vec<String>> = BTreeMap::new();
        for (i, d) in devices.iter().enumerate() {
            let table = d.kind.factory().table(d.side, &*d.config);
            for name in f.joint_names(d.name.as_str(), &table) {
                match first.get(&name) {
                    Some(&j) => clashes.entry((j, i)).or_default().push(name),
                    None => {
                        first.insert(name, i);
                    }
                }
            }
        }
        for ((a, b), names) in clashes {
            let shown: Vec<String> = names.iter().take(3).map(|n| format!("`{n}`")).collect();
            let more = match names.len() {
                n if n > 3 => format!(" and {} more", n - 3),
                _ => String::new(),
            };
            let msg = if f.kind().takes_commands() {
                format!(
                    "`{}` and `{}` both have {}{more}: a command on `{topic}` naming it would be ambiguous. Command one of them on its own topic (a second `{}` front with `topic` and `devices = [..]`, and `devices` here), or set `urdf_names = false` (names `<device>/<joint>`)",
                    devices[a].name,
                    devices[b].name,
                    shown.join(", "),
                    f.kind().as_str(),
                )
            } else {
                format!(
                    "`{}` and `{}` would both publish {}{more} on `{topic}`: a reader keyed by joint name (every ROS tool) sees one of them and loses the other. Publish one of them on its own topic (a second `{}` front with `topic` and `devices = [..]`, and `devices` here), or set `urdf_names = false` (names `<device>/<joint>`)",
                    devices[a].name,
                    devices[b].name,
                    shown.join(", "),
                    f.kind().as_str(),
                )
            };
            self.err(k.key("devices"), msg);
        }
    }

    /// `key` extended by a kind's relative key segments.
    fn under(key: &KeyPath, rel: &[String]) -> KeyPath {
        rel.iter().fold(key.clone(), |k, s| k.key(s.clone()))
    }

    fn joint(&mut self, key: KeyPath, d: &DeviceConfig, joint: &str) -> Option<(f64, f64)> {
        let names = d.kind.joint_names();
        if !names.contains(&joint) {
            self.err(
                key,
                format!(
                    "unknown joint `{joint}` for {} (joints: {})",
                    a(d.kind.as_str()),
                    names.join(", ")
                ),
            );
            return None;
        }
        d.kind.factory().hardware_range(d.side, joint)
    }

    fn position(&mut self, key: KeyPath, d: &DeviceConfig, joint: &str, v: Radians) {
        if let Some((lo, hi)) = self.joint(key.clone(), d, joint) {
            if !v.0.is_finite() || v.0 < lo || v.0 > hi {
                self.err(
                    key,
                    format!(
                        "{} is outside the {} {} hardware range [{lo}, {hi}] rad",
                        v.0, d.side, d.kind
                    ),
                );
            }
        }
    }

    fn device(&mut self, k: &KeyPath, d: &DeviceConfig) {
        let kind = d.kind.factory();
        let ok_backends = kind.backends();
        if !ok_backends.contains(&d.backend) {
            let names: Vec<&str> = ok_backends.iter().map(|b| b.as_str()).collect();
            self.err(
                k.key("backend"),
                format!(
                    "{} cannot use backend {} (valid: {})",
                    a(d.kind.as_str()),
                    d.backend,
                    names.join(", ")
                ),
            );
        }
        if let Err(m) = kind.check_side(d.side) {
            self.err(k.key("side"), m);
        }
        if let Some(r) = d.rate_hz {
            self.rate(k.key("rate_hz"), r, MAX_RATE_HZ);
        }
        if let Some(m) = d.max_send_hz {
            self.rate(k.key("max_send_hz"), m, 2.0 * MAX_RATE_HZ);
            if let DeviceRate::Hz(r) = d.rate() {
                if m.0.is_finite() && m.0 < r.0 {
                    self.err(
                        k.key("max_send_hz"),
                        format!(
                            "is {} Hz, below the device's loop rate ({} Hz): the loop's own keep-alive would exceed it; \
                             raise it or lower rate_hz",
                            m.0, r.0
                        ),
                    );
                }
            }
        }

        // limits
        let lk = k.key("limits");
        if let Some(s) = d.limits.max_step {
            if !(s.0.is_finite() && s.0 > 0.0) {
                self.err(lk.key("max_step"), format!("must be above 0 rad, got {}", s.0));
            }
        }
        for (j, lim) in &d.limits.joints {
            let jk = lk.key("joints").key(j.clone());
            let Some((lo, hi)) = self.joint(jk.clone(), d, j) else {
                continue;
            };
            for (which, v) in [("min", lim.min), ("max", lim.max)] {
                if let Some(v) = v {
                    if !v.0.is_finite() || v.0 < lo || v.0 > hi {
                        self.err(
                            jk.key(which),
                            format!(
                                "{} is outside the {} {} hardware range [{lo}, {hi}] rad",
                                v.0, d.side, d.kind
                            ),
                        );
                    }
                }
            }
            let min = lim.min.map_or(lo, |r| r.0);
            let max = lim.max.map_or(hi, |r| r.0);
            if min >= max {
                self.err(jk.clone(), format!("min ({min}) must be below max ({max})"));
            }
        }

        // motion
        let mk = k.key("motion");
        if let Some(t) = d.motion.tolerance {
            let max = f64::from(MotionThresholds::TOLERANCE_MAX);
            if !(t.0.is_finite() && t.0 > 0.0 && t.0 <= max) {
                self.err(
                    mk.key("tolerance"),
                    format!("must be above 0 and at most {max} rad, got {}", t.0),
                );
            }
        }
        match (d.motion.contact, d.motion.contact_effort) {
            (_, Some(e)) if !(e.is_finite() && e > 0.0) => {
                self.err(mk.key("contact_effort"), format!("must be above 0, got {e}"));
            }
            (Some(ContactMode::Effort), None) => self.err(
                mk.key("contact"),
                "\"effort\" needs `contact_effort`, in the kind's own effort unit (docs/profiles.md, `[devices.motion]`)",
            ),
            (Some(m @ (ContactMode::Reported | ContactMode::Unmeasured)), Some(_)) => self.err(
                mk.key("contact_effort"),
                format!("applies to contact = \"effort\", not {:?}: remove it", format!("{m:?}").to_lowercase()),
            ),
            _ => {}
        }
        if let Some(h) = d.motion.hold_ms {
            let (lo, hi) = MotionThresholds::HOLD_MS_RANGE;
            if !(lo..=hi).contains(&u64::from(h.0)) {
                self.err(
                    mk.key("hold_ms"),
                    format!(
                        "must be between {lo} and {hi} ms (a hand that does not move must be reported within a second), got {}",
                        h.0
                    ),
                );
            }
        }

        // watchdog
        let (wlo, whi) = WATCHDOG_MS_RANGE;
        if !(wlo..=whi).contains(&d.watchdog.timeout_ms.0) {
            self.err(
                k.key("watchdog").key("timeout_ms"),
                format!("must be between {wlo} and {whi}, got {}", d.watchdog.timeout_ms.0),
            );
        }

        // closure: postures where the kind has configurable ones, torques where its closure
        // maps to torque.
        let ck = k.key("closure");
        let posture_kinds: Vec<DeviceKind> = DeviceKind::all()
            .iter()
            .copied()
            .filter(|k| k.factory().closure_postures_configurable())
            .collect();
        let torque_kinds: Vec<DeviceKind> = DeviceKind::all()
            .iter()
            .copied()
            .filter(|k| k.factory().closure_is_torque())
            .collect();
        for (which, m) in [("open", &d.closure.open), ("closed", &d.closure.closed)] {
            if posture_kinds.contains(&d.kind) {
                for (j, v) in m {
                    self.position(ck.key(which).key(j.clone()), d, j, *v);
                }
            } else if !m.is_empty() {
                self.err(
                    ck.key(which),
                    format!(
                        "only {} has closure postures, this is {}",
                        names_phrase(&posture_kinds),
                        a(d.kind.as_str())
                    ),
                );
            }
        }
        let torque = torque_kinds.contains(&d.kind);
        for (which, v) in [("tau_open", d.closure.tau_open), ("tau_closed", d.closure.tau_closed)] {
            let Some(v) = v else { continue };
            if !torque {
                self.err(
                    ck.key(which),
                    format!(
                        "only {} device maps closure to torque, this is {}",
                        names_phrase(&torque_kinds),
                        a(d.kind.as_str())
                    ),
                );
            } else if !v.is_finite() || v.abs() > 5.0 {
                self.err(ck.key(which), format!("must be a torque within +-5 N*m, got {v}"));
            }
        }
        if let (true, Some(o), Some(c)) = (torque, d.closure.tau_open, d.closure.tau_closed) {
            if o >= c {
                self.err(
                    ck.key("tau_open"),
                    format!("must be below tau_closed ({o} >= {c}): positive torque closes"),
                );
            }
        }

        // keys of another kind or backend, then the kind's own rules
        for p in &d.misplaced {
            self.err(Self::under(k, &p.key), p.message.clone());
        }
        if d.emulator.is_some() && d.backend != Backend::Emulator {
            self.err(
                k.key("emulator"),
                format!(
                    "[emulator] applies to backend emulator, this is {} on backend {}",
                    a(d.kind.as_str()),
                    d.backend
                ),
            );
        }
        for p in d.config.validate(&d.ctx()) {
            self.err(Self::under(k, &p.key), p.message);
        }
        if let Some(e) = &d.emulator {
            let ek = k.key("emulator");
            for (which, m) in [("initial", &e.initial), ("object_at", &e.object_at)] {
                for (j, v) in m {
                    self.position(ek.key(which).key(j.clone()), d, j, Radians(*v));
                }
            }
            // A stuck joint: one of the kind's, by its canonical or URDF name.
            if let Some(Ok(handgate_adapters::emu_common::FaultArg::Stuck(j))) = e.fault_arg() {
                let t = d.kind.factory().table(d.side, &*d.config);
                if !t.joints.iter().any(|m| m.name == j || m.urdf == j) {
                    self.err(
                        ek.key("fault"),
                        format!(
                            "stuck={j}: no such joint on a {} {} (joints: {})",
                            d.side,
                            d.kind,
                            d.kind.joint_names().join(", ")
                        ),
                    );
                }
            }
            for p in e
                .validate()
                .into_iter()
                .chain(d.kind.factory().validate_emulator(&d.ctx(), e))
            {
                self.err(Self::under(k, &p.key), p.message);
            }
        }
    }

    /// Checks across devices: two devices commanding one DDS topic, and each kind's rules
    /// across its devices (what several of them share).
    fn fleet(&mut self, p: &Profile) {
        // Devices on one command topic: allowed only when each writes its own element of a
        // message carrying several (`KindConfig::dds_command_element`).
        let mut dds_cmd: HashMap<Topic, Vec<(usize, Option<usize>)>> = HashMap::new();
        for (i, d) in p.devices.iter().enumerate() {
            if let Some((Some(cmd), _)) = d.dds_topics() {
                let element = d.config.dds_command_element(&d.ctx());
                let others = dds_cmd.entry(cmd.clone()).or_default();
                if let Some((j, _)) = others
                    .iter()
                    .find(|(_, e)| e.is_none() || element.is_none() || *e == element)
                {
                    self.err(
                        root().key("devices").index(i).key("dds"),
                        format!("devices[{j}] also sends commands on `{cmd}`: two devices would fight over one"),
                    );
                }
                others.push((i, element));
            }
        }
        for kind in DeviceKind::all() {
            let members: Vec<FleetMember<'_>> = p
                .devices
                .iter()
                .enumerate()
                .filter(|(_, d)| d.kind == *kind)
                .map(|(index, d)| FleetMember {
                    index,
                    ctx: d.ctx(),
                    config: &*d.config,
                })
                .collect();
            if members.is_empty() {
                continue;
            }
            for (i, p) in kind.factory().validate_fleet(&members) {
                self.err(Self::under(&root().key("devices").index(i), &p.key), p.message);
            }
        }
    }

    fn front(&mut self, k: &KeyPath, f: &FrontConfig, dev: Option<&DeviceConfig>, dangling: bool) {
        let kind = f.kind();
        // Keys of another front kind (found while parsing), then the kind's own rules.
        for p in &f.misplaced {
            self.err(Self::under(k, &p.key), p.message.clone());
        }
        if !kind.takes_commands() && f.silence != Silence::default() {
            self.err(
                k.key("silence"),
                format!(
                    "{} front takes no commands, so has no silence to handle",
                    a(kind.as_str())
                ),
            );
        }
        if !kind.takes_commands() && f.control != Control::default() {
            self.err(
                k.key("control"),
                format!(
                    "{} front takes no commands, so has no client to give it to",
                    a(kind.as_str())
                ),
            );
        }
        if let Some(w) = f.watchdog_ms {
            let (wlo, whi) = WATCHDOG_MS_RANGE;
            if !(wlo..=whi).contains(&w.0) {
                self.err(
                    k.key("watchdog_ms"),
                    format!("must be between {wlo} and {whi}, got {}", w.0),
                );
            } else if f.silence != Silence::Watchdog {
                self.err(
                    k.key("watchdog_ms"),
                    format!(
                        "applies with silence = \"watchdog\" (this front's silence is \"{}\")",
                        f.silence
                    ),
                );
            }
        }
        if let Some(m) = f.max_command_age_ms {
            let (lo, hi) = MAX_COMMAND_AGE_MS_RANGE;
            if !kind.takes_commands() {
                self.err(
                    k.key("max_command_age_ms"),
                    format!("{} front takes no commands, so has none to age", a(kind.as_str())),
                );
            } else if !(lo..=hi).contains(&m.0) {
                self.err(
                    k.key("max_command_age_ms"),
                    format!("must be between {lo} and {hi}, got {}", m.0),
                );
            }
        }
        if let Some(r) = f.state_hz {
            self.rate(k.key("state_hz"), r, MAX_RATE_HZ);
        }
        for (key, msg) in f.validate_own(f.served_side(dev), dangling) {
            self.err(k.key(key), msg);
        }
    }
}

/// Whether front `f` drives one device named by `device` (or devices by element): a front
/// taking commands that does not bind a list of devices (`FrontFacts::binds_list`).
fn one_device(f: &FrontConfig) -> bool {
    f.kind().takes_commands() && !f.kind().factory().facts().binds_list
}
