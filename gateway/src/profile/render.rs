//! The resolved fleet as `handgate check` and `handgate run` print it.

use std::fmt::Write;

use super::error::Origin;
use super::schema::*;

/// A human-readable summary of the resolved profile: DDS, devices with their effective
/// rates and watchdogs, fronts with their topics and bound device.
pub fn render_fleet(p: &Profile, origin: &Origin) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "profile {} ({origin})", p.name);
    if !p.description.is_empty() {
        let _ = writeln!(s, "  {}", p.description);
    }
    let ros_node = if p.dds.ros_node {
        format!(
            "{}/{}",
            p.namespace().ros().trim_end_matches('/'),
            handgate_adapters::ros::NODE_NAME
        )
    } else {
        "off".into()
    };
    let iface = |i: Option<&str>| i.unwrap_or("(any)").to_string();
    match p.export_side() {
        None => {
            let _ = writeln!(
                s,
                "dds: domain {}, interface {}, ROS node {ros_node}",
                p.dds.domain.0,
                iface(p.dds.interface.as_deref()),
            );
        }
        Some((domain, interface)) => {
            let _ = writeln!(
                s,
                "dds (devices): domain {}, interface {}",
                p.dds.domain.0,
                iface(p.dds.interface.as_deref()),
            );
            let _ = writeln!(
                s,
                "export (fronts, status, ROS node {ros_node}): domain {}, interface {}{}",
                domain.0,
                iface(interface.as_deref()),
                if p.export.as_ref().is_some_and(|e| e.namespace_fronts) {
                    ", every front's topics in the namespace"
                } else {
                    ""
                }
            );
        }
    }
    let secured = |what: &str, sec: &Option<crate::profile::SecurityConfig>, s: &mut String| {
        let Some(c) = sec else { return };
        let line = match c.resolve() {
            Ok(f) => format!(
                "{what} security: DDS Security, unauthenticated participants refused; identity {} (CA {}), \
                 permissions {} (CA {}), governance {}{}",
                f.certificate.display(),
                f.identity_ca.display(),
                f.permissions.display(),
                f.permissions_ca.display(),
                f.governance.display(),
                f.crl
                    .as_ref()
                    .map(|c| format!(", revocation list {}", c.display()))
                    .unwrap_or_default(),
            ),
            Err(missing) => format!("{what} security: incomplete ({missing} not given)"),
        };
        let _ = writeln!(s, "{line}");
    };
    let (devices, clients) = if p.export_side().is_some() {
        ("dds (devices)", "export")
    } else {
        ("dds", "export")
    };
    secured(devices, &p.dds.security, &mut s);
    secured(clients, &p.export.as_ref().and_then(|e| e.security.clone()), &mut s);
    let _ = writeln!(s, "log: {} {}", p.log.format, p.log.level);
    let _ = writeln!(s, "status: {} at {}", p.status_topic(), p.status.rate_hz);
    if let Some(r) = &p.record {
        let topics = if r.topics.is_empty() {
            "every topic".to_string()
        } else {
            r.topics.join(" ")
        };
        let _ = writeln!(s, "record: into {}/ ({topics})", r.dir);
    }
    if p.http.enabled {
        let _ = writeln!(
            s,
            "http: dashboard, /metrics, /healthz on {}:{}{}{}{}",
            p.http.bind,
            p.http.port,
            match (p.http.commands, &p.http.token_file) {
                (true, Some(_)) => " (the page may command devices)",
                (true, None) => {
                    " (read-only: WARNING commands = true needs [http] token_file; without a token the \
                     dashboard accepts no command)"
                }
                (false, _) => " (read-only)",
            },
            match &p.http.token_file {
                Some(f) => format!(", token required (from {f})"),
                None => ", no token".to_string(),
            },
            if p.http.allowed_hosts.is_empty() {
                String::new()
            } else {
                format!(", also as {}", p.http.allowed_hosts.join(" "))
            }
        );
    } else {
        let _ = writeln!(s, "http: off");
    }
    let f = p.foxglove();
    if p.foxglove_enabled() {
        let topics = if f.topics.is_empty() {
            "state topics and status".to_string()
        } else {
            f.topics.join(" ")
        };
        let _ = writeln!(s, "foxglove: ws://{} ({topics})", foxglove_addr(&f));
    } else if cfg!(feature = "foxglove") {
        let _ = writeln!(s, "foxglove: off ([foxglove] enabled = false)");
    } else {
        let _ = writeln!(
            s,
            "foxglove: not built in (cargo build --features foxglove, or make run, adds the live server)"
        );
    }
    if p.realtime != RealtimeConfig::default() {
        let r = &p.realtime;
        let mut line = format!("realtime: device loops {}", r.policy.sched_name());
        if let Some(n) = r.priority {
            let _ = write!(line, " priority {n}");
        }
        if !r.cpus.is_empty() {
            let _ = write!(line, ", CPUs {}", handgate_adapters::realtime::CpuList(&r.cpus));
        }
        if r.mlockall {
            line.push_str(", memory locked (mlockall)");
        }
        if r.loop_threads != handgate_adapters::loops::DEFAULT_THREADS {
            match r.loop_threads {
                0 => line.push_str(", a thread per device loop"),
                n => {
                    let _ = write!(line, ", {n} shared loop threads");
                }
            }
        }
        let _ = writeln!(s, "{line}");
    }
    let _ = writeln!(s, "devices ({}):", p.devices.len());
    for d in &p.devices {
        let _ = write!(
            s,
            "  {:<14} {:<9} {:<6} {:<8} rate {}, watchdog {} then {}",
            d.name.as_str(),
            d.kind.as_str(),
            d.side.as_str(),
            d.backend.as_str(),
            d.rate(),
            d.watchdog.timeout_ms,
            d.watchdog.safe_action
        );
        if let Some((cmd, state)) = d.dds_topics() {
            let _ = write!(
                s,
                ", via {} / {}",
                cmd.map(|t| t.0).unwrap_or_else(|| "-".into()),
                state.map(|t| t.0).unwrap_or_else(|| "-".into())
            );
        }
        // What the kind adds: its variant, bus, serial.
        s.push_str(&d.config.describe(&d.ctx()));
        s.push('\n');
    }
    let _ = writeln!(s, "fronts ({}):", p.fronts.len());
    for f in &p.fronts {
        let lookup = |n: &DeviceName| p.devices.iter().find(|d| &d.name == n);
        let dev = f.device.as_ref().and_then(lookup);
        let t = p.front_topics(f, dev);
        let target = match (&f.devices, &f.device) {
            (Some(FrontDevices::Elements(els)), _) => format!(
                "right={}, left={}",
                els.right.as_ref().map_or("-", |d| d.as_str()),
                els.left.as_ref().map_or("-", |d| d.as_str())
            ),
            (Some(FrontDevices::List(l)), _) => l.iter().map(|d| d.as_str()).collect::<Vec<_>>().join(", "),
            (None, Some(n)) => n.0.clone(),
            (None, None) => "all devices".into(),
        };
        let _ = write!(
            s,
            "  {:<20} {:<11} -> {:<14}",
            f.display_name(dev),
            f.kind().as_str(),
            target
        );
        // Each topic by its role; one beside the state is the kind's to describe.
        for topic in &t.topics {
            let Some(name) = &topic.topic else { continue };
            let _ = match (topic.role, t.lf_state_hz) {
                (TopicRole::Command, _) => write!(s, " cmd {name}"),
                (TopicRole::State, _) => write!(s, " state {name} at {}", t.state_hz),
                (TopicRole::LowFrequencyState, Some(hz)) => write!(s, " lf {name} at {hz}"),
                (TopicRole::LowFrequencyState, None) | (TopicRole::Beside, _) => Ok(()),
            };
        }
        if let Some(d) = f.describe() {
            s.push_str(&d);
        }
        if f.kind().takes_commands() {
            let plans: Vec<(String, String)> = p
                .front_bindings(f)
                .into_iter()
                .filter_map(|(_, n)| lookup(n).map(|d| (n.0.clone(), crate::resolve::silence_plan(f, d).to_string())))
                .collect();
            if plans.iter().all(|(_, p)| Some(p) == plans.first().map(|(_, p)| p)) {
                if let Some((_, p)) = plans.first() {
                    let _ = write!(s, ", silence: {p}");
                }
            } else {
                for (n, p) in &plans {
                    let _ = write!(s, ", silence ({n}): {p}");
                }
            }
            let hold = p
                .front_bindings(f)
                .into_iter()
                .filter_map(|(_, n)| lookup(n).map(|d| crate::resolve::hold(f, d)))
                .max()
                .unwrap_or_default();
            match f.control {
                Control::Exclusive => {
                    let _ = write!(s, ", control: exclusive (hold {} ms)", hold.as_millis());
                }
                Control::Shared => s.push_str(", control: shared"),
            }
            if let Some(m) = f.max_command_age_ms {
                let _ = write!(s, ", max command age {} ms", m.0);
            }
        }
        s.push('\n');
        let bound: Vec<Side> = p.front_bindings(f).into_iter().map(|(side, _)| side).collect();
        for line in f.describe_unbound(&bound) {
            let _ = writeln!(s, "    {line}");
        }
    }
    s
}

/// `HOST:PORT` of `[foxglove]` (an IPv6 address in brackets).
pub fn foxglove_addr(f: &FoxgloveConfig) -> String {
    match f.bind.parse::<std::net::IpAddr>() {
        Ok(ip) => std::net::SocketAddr::new(ip, f.port).to_string(),
        Err(_) => format!("{}:{}", f.bind, f.port),
    }
}
