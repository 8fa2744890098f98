//! Profile → plan: turns a validated [`Profile`] into the typed [`Plan`] the runtime starts.
//! Everything a profile leaves out gets its documented default here or in the schema.

use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::mapping::{ClosureMap, Limits, MappingError, TableOverrides};

use crate::plan::{Binding, DevicePlan, FrontPlan, Plan, PlanTopic, SilencePlan};
use crate::profile::{DeviceConfig, DeviceRate, FrontConfig, FrontConfigExt, Profile, Radians, TopicRole};

/// Why a profile could not become a plan (after validation these indicate a gap between the
/// validator and the runtime; they are reported like validation errors).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResolveError {
    #[error("devices[{index}] ({device}): {source}")]
    Device {
        index: usize,
        device: String,
        #[source]
        source: MappingError,
    },
    #[error("fronts[{0}]: {1}")]
    Front(usize, String),
}

/// How long without a state sample before a device's state is stale.
pub const DEFAULT_STALE_AFTER: Duration = Duration::from_millis(200);

/// The profile's common table keys (limits, max_step, closure) as overrides of the kind's
/// table; a bound a profile omits keeps the kind's.
fn overrides(d: &DeviceConfig) -> TableOverrides {
    let base = d.kind.factory().table(d.side, &*d.config);
    let limits = d
        .limits
        .joints
        .iter()
        .map(|(name, l)| {
            let hw = base
                .joint_by_name(name)
                .map(|id| base.joints[id.index()].limits)
                .unwrap_or(Limits::new(f32::NEG_INFINITY, f32::INFINITY));
            let min = l.min.map(|v| v.0 as f32).unwrap_or(hw.min);
            let max = l.max.map(|v| v.0 as f32).unwrap_or(hw.max);
            (name.clone(), Limits::new(min, max))
        })
        .collect();
    // Postures: the kind's, with the joints the profile names replaced.
    let posture = |m: &std::collections::BTreeMap<String, Radians>, closed: bool| -> Option<Vec<f32>> {
        let ClosureMap::Postures { open, closed: c, .. } = &base.closure else {
            return None;
        };
        if m.is_empty() {
            return None;
        }
        let mut v = if closed { c.clone() } else { open.clone() };
        for (n, r) in m {
            if let Ok(id) = base.joint_by_name(n) {
                v[id.index()] = r.0 as f32;
            }
        }
        Some(v)
    };
    TableOverrides {
        max_step: d.limits.max_step.map(|r| r.0 as f32),
        limits,
        open_posture: posture(&d.closure.open, false),
        closed_posture: posture(&d.closure.closed, true),
        tau_open: d.closure.tau_open.map(|v| v as f32),
        tau_closed: d.closure.tau_closed.map(|v| v as f32),
        motion_tolerance: d.motion.tolerance.map(|r| r.0 as f32),
        motion_hold: d.motion.hold_ms.map(|m| m.as_duration()),
        motion_contact: {
            use crate::profile::ContactMode;
            use handgate_adapters::motion::Contact;
            match (d.motion.contact, d.motion.contact_effort) {
                (Some(ContactMode::Reported), _) => Some(Contact::Reported),
                (Some(ContactMode::Unmeasured), _) => Some(Contact::Unmeasured),
                (_, Some(e)) => Some(Contact::Effort(e as f32)),
                (Some(ContactMode::Effort), None) | (None, None) => None,
            }
        },
    }
}

fn device(i: usize, d: &DeviceConfig) -> Result<DevicePlan, ResolveError> {
    let rate_hz = match d.rate() {
        DeviceRate::Hz(r) => r.0,
        DeviceRate::AsFastAsBus => 1000.0,
    };
    let table = d
        .kind
        .factory()
        .table_with(d.side, &*d.config, &overrides(d))
        .map_err(|source| ResolveError::Device {
            index: i,
            device: d.name.to_string(),
            source,
        })?;
    Ok(DevicePlan {
        name: d.name.to_string(),
        kind: d.kind,
        side: d.side,
        backend: d.backend,
        table: Arc::new(table),
        rate_hz,
        forward_on_arrival: d.forward_on_arrival.unwrap_or(true),
        max_send_hz: d.max_send_hz.map(|r| r.0),
        stale_after: DEFAULT_STALE_AFTER,
        safe_action: d.watchdog.safe_action,
        emulator: d.emulator.clone().unwrap_or_default(),
        config: d.config.clone(),
    })
}

/// The watchdog of front `f` driving device `d`: the device's, or the front's where shorter.
fn watchdog(f: &FrontConfig, d: &DeviceConfig) -> (std::time::Duration, handgate_adapters::model::SafeAction) {
    let t = d.watchdog.timeout_ms.as_duration();
    let t = f.watchdog_ms.map_or(t, |w| t.min(w.as_duration()));
    (t, d.watchdog.safe_action)
}

/// What silence means for front `f` driving device `d` (docs/fronts.md, "Silence").
pub fn silence_plan(f: &FrontConfig, d: &DeviceConfig) -> SilencePlan {
    f.kind().factory().silence(f.silence, watchdog(f, d))
}

/// How long a silent owner keeps front `f` as far as device `d` goes (docs/fronts.md, "One
/// commanding client per front"): the time the front's silence waits before it acts on the
/// device, or, where silence keeps the last target, the watchdog time.
pub fn hold(f: &FrontConfig, d: &DeviceConfig) -> std::time::Duration {
    silence_plan(f, d).after.map_or(watchdog(f, d).0, |(t, _)| t)
}

/// The table of the wire convention front `f` speaks to device `d` on `side`: the served
/// kind's table (with the device's own configuration when the device is of that kind, so a
/// front on a device of its own kind pairs joint for joint whatever the device's profile
/// keys); `None` for fronts that speak the device's own table (`FrontFacts::speaks`).
fn front_table(
    f: &FrontConfig,
    side: handgate_adapters::model::Side,
    d: &DeviceConfig,
) -> Option<Arc<handgate_adapters::mapping::DeviceTable>> {
    let served = f.kind().factory().facts().speaks?;
    let k = served.factory();
    let table = if d.kind == served {
        k.table(side, &*d.config)
    } else {
        k.table(side, &*k.default_config())
    };
    Some(Arc::new(table))
}

fn front(i: usize, f: &FrontConfig, p: &Profile) -> Result<FrontPlan, ResolveError> {
    let lookup = |n: &crate::profile::DeviceName| p.devices.iter().find(|d| &d.name == n);
    let dev = f.device.as_ref().and_then(lookup);
    let topics = p.front_topics(f, dev);
    let mut bindings = Vec::new();
    let takes_commands = f.kind().takes_commands();
    if takes_commands {
        for (side, n) in p.front_bindings(f) {
            let d = lookup(n).ok_or_else(|| ResolveError::Front(i, format!("no device named {n}")))?;
            bindings.push(Binding {
                device: n.to_string(),
                side,
                element: f.element(side),
                silence: silence_plan(f, d),
                hold: hold(f, d),
                table: front_table(f, side, d),
            });
        }
        if bindings.is_empty() {
            return Err(ResolveError::Front(i, "a device is required".into()));
        }
    }
    // Every topic the kind serves; its command and state topics are required.
    let mut planned = Vec::new();
    for t in topics.topics {
        let what = match (t.topic, t.role) {
            (Some(topic), role) => {
                planned.push(PlanTopic {
                    key: t.key,
                    role,
                    topic: topic.0,
                });
                continue;
            }
            (None, TopicRole::Command) => "command",
            (None, TopicRole::State) => "state",
            (None, TopicRole::LowFrequencyState | TopicRole::Beside) => continue,
        };
        return Err(ResolveError::Front(i, format!("no {what} topic (side center?)")));
    }
    let devices = p.published_devices(f).iter().map(|d| d.name.to_string()).collect();
    Ok(FrontPlan {
        name: f.display_name(dev),
        config: f.clone(),
        bindings,
        devices,
        topics: planned,
        state_hz: topics.state_hz.0,
        lf_state_hz: topics.lf_state_hz.map(|r| r.0),
    })
}

/// The plan for a validated profile.
pub fn plan(p: &Profile) -> Result<Plan, Vec<ResolveError>> {
    let mut errors = Vec::new();
    let devices: Vec<DevicePlan> = p
        .devices
        .iter()
        .enumerate()
        .filter_map(|(i, d)| device(i, d).map_err(|e| errors.push(e)).ok())
        .collect();
    let fronts: Vec<FrontPlan> = p
        .fronts
        .iter()
        .enumerate()
        .filter_map(|(i, f)| front(i, f, p).map_err(|e| errors.push(e)).ok())
        .collect();
    if !errors.is_empty() {
        return Err(errors);
    }
    Ok(Plan {
        profile: p.name.clone(),
        domain: p.dds.domain.0,
        interface: p.dds.interface.clone(),
        status_topic: p.status_topic().0,
        namespace: p.dds.ros_node.then(|| p.namespace()),
        own_namespace: p.namespace(),
        allow_sources: p
            .export
            .as_ref()
            .filter(|e| !e.allow_commands_from.is_empty())
            .map(|e| {
                // Validated: every entry parses.
                let nets = e
                    .allow_commands_from
                    .iter()
                    .filter_map(|a| handgate_adapters::front::sources::Net::parse(a).ok());
                handgate_adapters::front::sources::Sources::new(nets.collect())
            }),
        export: p.export_side().map(|(domain, interface)| crate::plan::ExportPlan {
            domain: domain.0,
            interface,
            security: p
                .export
                .as_ref()
                .and_then(|e| e.security.as_ref())
                .and_then(|s| s.resolve().ok()),
        }),
        security: p.dds.security.as_ref().and_then(|s| s.resolve().ok()),
        status_hz: p.status.rate_hz.0,
        foreign_state_writers: p.dds.foreign_state_writers,
        discovery_settle: p.dds.discovery_settle_ms.as_duration(),
        discovery_max_wait: p.dds.discovery_max_wait_ms.as_duration(),
        record: p.record.as_ref().map(|r| crate::plan::RecordPlan {
            dir: std::path::Path::new(&r.dir).join(format!(
                "{}_{}",
                p.name,
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map(|d| d.as_secs())
                    .unwrap_or(0)
            )),
            topics: r.topics.clone(),
            max_mb: r.max_mb,
            max_seconds: r.max_seconds,
            zstd: r.zstd,
        }),
        http: p.http.enabled.then(|| crate::plan::HttpPlan {
            // Validated: an IP address.
            addr: std::net::SocketAddr::new(
                p.http.bind.parse().unwrap_or(std::net::Ipv4Addr::LOCALHOST.into()),
                p.http.port,
            ),
            // Commands only with a token (docs/dashboard.md, "Security").
            commands: p.http.commands && p.http.token_file.is_some(),
            commands_need_token: p.http.commands && p.http.token_file.is_none(),
            token_file: p.http.token_file.as_ref().map(std::path::PathBuf::from),
            sample_hz: p.http.sample_hz.0,
            command_watchdog: p.http.command_watchdog_ms.as_duration(),
            // Validated: each a host name or an IP address.
            allowed_hosts: p
                .http
                .allowed_hosts
                .iter()
                .filter_map(|h| crate::http::host::Host::parse(h).ok())
                .collect(),
            // Validated: parses.
            fleet_domains: p
                .http
                .fleet_domains
                .as_deref()
                .and_then(|d| crate::doctor::parse_scan(d).ok())
                .unwrap_or_default(),
        }),
        foxglove: p.foxglove_enabled().then(|| {
            let f = p.foxglove();
            crate::plan::FoxglovePlan {
                // Validated: an IP address.
                addr: std::net::SocketAddr::new(f.bind.parse().unwrap_or(std::net::Ipv4Addr::LOCALHOST.into()), f.port),
                topics: f.topics,
                required: p.foxglove.is_some(),
            }
        }),
        realtime: handgate_adapters::realtime::Settings {
            policy: p.realtime.policy,
            // Validated: present with a real-time policy, absent otherwise.
            priority: p.realtime.priority.unwrap_or(0),
            cpus: p.realtime.cpus.clone(),
            mlockall: p.realtime.mlockall,
        },
        loop_threads: p.realtime.loop_threads,
        devices,
        fronts,
    })
}

/// The embedded default profile's plan (no environment, no search path): for tests.
#[cfg(test)]
pub(crate) fn default_plan() -> Plan {
    let loaded = crate::profile::load(&crate::profile::LoadOptions {
        env: crate::profile::EnvLayer::Ignore,
        search_dirs: Some(vec![]),
        ..Default::default()
    })
    .expect("the embedded default profile is valid");
    plan(&loaded.profile).expect("the embedded default profile resolves")
}
