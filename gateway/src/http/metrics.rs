//! `/metrics` (Prometheus text format 0.0.4) and `/healthz`.

use std::fmt::Write;
use std::sync::atomic::Ordering;
use std::time::Instant;

use handgate_adapters::control::PERIOD_BOUNDS_S;
use handgate_adapters::model::Freshness;

use super::Fleet;

/// A label value escaped for the text format (`\`, `"`, newline).
fn esc(v: &str) -> String {
    v.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}

/// One metric family: its HELP and TYPE lines, then its samples.
struct Family<'a> {
    out: &'a mut String,
}

impl<'a> Family<'a> {
    fn new(out: &'a mut String, name: &str, kind: &str, help: &str) -> Self {
        let _ = writeln!(out, "# HELP {name} {help}");
        let _ = writeln!(out, "# TYPE {name} {kind}");
        Self { out }
    }

    fn sample(&mut self, name: &str, labels: &str, v: f64) {
        let v = if v.is_finite() {
            format!("{v}")
        } else if v.is_nan() {
            "NaN".into()
        } else if v > 0.0 {
            "+Inf".into()
        } else {
            "-Inf".into()
        };
        if labels.is_empty() {
            let _ = writeln!(self.out, "{name} {v}");
        } else {
            let _ = writeln!(self.out, "{name}{{{labels}}} {v}");
        }
    }
}

/// What `/metrics` reads of a device's state.
struct Seen {
    freshness: Freshness,
    age: Option<std::time::Duration>,
    faults: u32,
    /// The motion verdict (`MOTION_*`) and the joint it names.
    motion: u8,
    motion_joint: Option<usize>,
    /// Per joint |target - measured|, rad (empty while nothing is commanded).
    errors: Vec<f32>,
}

/// The whole exposition.
pub fn render(fleet: &Fleet, commands: bool) -> String {
    let status = fleet.status.borrow().clone();
    let now = Instant::now();
    let mut out = String::with_capacity(16 * 1024);
    let devs: Vec<_> = fleet
        .devices
        .iter()
        .map(|d| {
            let labels = format!(
                "device=\"{}\",kind=\"{}\",backend=\"{}\"",
                esc(&d.plan.name),
                esc(d.plan.kind.as_str()),
                esc(d.plan.backend.as_str())
            );
            // What the families below read of the state (no copy of its pads).
            let st = {
                let rx = d.device.state();
                let st = rx.borrow();
                Seen {
                    freshness: st.freshness,
                    age: st.age(now),
                    faults: st.faults,
                    motion: st.motion.verdict.code(),
                    motion_joint: st.motion.joint,
                    errors: st.motion.errors.iter().map(|e| e.abs()).collect(),
                }
            };
            let s = d.device.stats();
            let row = status.devices.iter().find(|r| r.device == d.plan.name).cloned();
            (d, labels, st, s, row)
        })
        .collect();

    let mut f = Family::new(&mut out, "handgate_up", "gauge", "1 while the gateway serves.");
    f.sample("handgate_up", "", 1.0);
    let mut f = Family::new(
        &mut out,
        "handgate_uptime_seconds",
        "gauge",
        "Seconds since the gateway started.",
    );
    f.sample("handgate_uptime_seconds", "", fleet.started.elapsed().as_secs_f64());
    let mut f = Family::new(
        &mut out,
        "handgate_dashboard_clients",
        "gauge",
        "Dashboard pages connected.",
    );
    f.sample(
        "handgate_dashboard_clients",
        "",
        fleet.clients.load(Ordering::Relaxed) as f64,
    );
    let mut f = Family::new(
        &mut out,
        "handgate_dashboard_commands_enabled",
        "gauge",
        "1 when the profile lets the dashboard command devices ([http] commands).",
    );
    f.sample("handgate_dashboard_commands_enabled", "", commands as u8 as f64);
    let mut f = Family::new(
        &mut out,
        "handgate_http_refused_total",
        "counter",
        "Requests refused for their Host (not a name of this server, or malformed), opening the WebSocket their Origin, or without the right token ([http] token_file).",
    );
    for (reason, n) in [
        ("host", &fleet.refused.host),
        ("origin", &fleet.refused.origin),
        ("token", &fleet.refused.token),
    ] {
        f.sample(
            "handgate_http_refused_total",
            &format!("reason=\"{reason}\""),
            n.load(Ordering::Relaxed) as f64,
        );
    }

    let mut f = Family::new(
        &mut out,
        "handgate_device_fresh",
        "gauge",
        "1 when the device's state is fresh (or, without feedback, commanded-only).",
    );
    for (_, l, st, _, _) in &devs {
        f.sample(
            "handgate_device_fresh",
            l,
            (st.freshness != Freshness::Stale) as u8 as f64,
        );
    }
    let mut f = Family::new(
        &mut out,
        "handgate_device_state_age_seconds",
        "gauge",
        "Age of the last measured state (NaN: never measured).",
    );
    for (_, l, st, _, _) in &devs {
        f.sample(
            "handgate_device_state_age_seconds",
            l,
            st.age.map(|a| a.as_secs_f64()).unwrap_or(f64::NAN),
        );
    }
    let mut f = Family::new(
        &mut out,
        "handgate_device_safe",
        "gauge",
        "1 while a safe state or silence action holds the device.",
    );
    for (_, l, _, _, row) in &devs {
        f.sample(
            "handgate_device_safe",
            l,
            row.as_ref().is_some_and(|r| r.safe) as u8 as f64,
        );
    }
    let mut f = Family::new(
        &mut out,
        "handgate_device_link_up",
        "gauge",
        "1 while the link to the device is up.",
    );
    for (_, l, _, s, _) in &devs {
        f.sample("handgate_device_link_up", l, s.link_up as u8 as f64);
    }
    let mut f = Family::new(
        &mut out,
        "handgate_device_faults",
        "gauge",
        "The device's fault bits (docs/model.md).",
    );
    for (_, l, st, _, _) in &devs {
        f.sample("handgate_device_faults", l, st.faults as f64);
    }
    let mut f = Family::new(
        &mut out,
        "handgate_device_motion",
        "gauge",
        "Whether the device follows its command: 0 ok, 1 frozen (state samples repeat while commanded to move), \
         2 joint_stuck (label joint), 3 not_following, 4 holding (an object: not a fault; docs/adapters.md, \"Motion\").",
    );
    for (d, l, st, _, _) in &devs {
        let joint = st
            .motion_joint
            .and_then(|j| d.plan.kind.joint_names().get(j))
            .copied()
            .unwrap_or("");
        f.sample(
            "handgate_device_motion",
            &format!("{l},joint=\"{}\"", esc(joint)),
            f64::from(st.motion),
        );
    }
    let mut f = Family::new(
        &mut out,
        "handgate_joint_tracking_error_radians",
        "gauge",
        "|target in force - measured position| per joint, canonical rad (no sample while nothing is commanded).",
    );
    for (d, l, st, _, _) in &devs {
        for (name, e) in d.plan.kind.joint_names().iter().zip(&st.errors) {
            f.sample(
                "handgate_joint_tracking_error_radians",
                &format!("{l},joint=\"{}\"", esc(name)),
                f64::from(*e),
            );
        }
    }
    for (name, help, get) in [
        (
            "handgate_device_cmd_rate_hz",
            "Commands written to the device per second (status window).",
            (|r: &handgate_idl::handgate::DeviceStatus_| r.cmd_rate_hz) as fn(&_) -> f32,
        ),
        (
            "handgate_device_state_rate_hz",
            "Measured states per second (status window).",
            |r| r.state_rate_hz,
        ),
    ] {
        let mut f = Family::new(&mut out, name, "gauge", help);
        for (_, l, _, _, row) in &devs {
            f.sample(name, l, row.as_ref().map(|r| get(r) as f64).unwrap_or(f64::NAN));
        }
    }
    // Per front, from the status extension: what its clients send, what it publishes.
    let ext = fleet.status_ext.borrow().clone();
    for (name, help, get) in [
        (
            "handgate_front_cmd_rate_hz",
            "Command samples the front received from its clients per second (status window).",
            (|f: &handgate_idl::handgate::FrontStatus_| f.cmd_rate_hz) as fn(&_) -> f32,
        ),
        (
            "handgate_front_state_rate_hz",
            "Samples of the front's state topic it published per second, not the rt/lf copy (status window).",
            |f| f.state_rate_hz,
        ),
    ] {
        let mut fam = Family::new(&mut out, name, "gauge", help);
        for f in &ext.fronts {
            let labels = format!("front=\"{}\",kind=\"{}\"", esc(&f.name), esc(&f.kind));
            fam.sample(name, &labels, f64::from(get(f)));
        }
    }
    type Counter = fn(&handgate_adapters::device::DeviceStats, &crate::runtime::FrontCounters) -> u64;
    let counters: [(&str, &str, Counter); 16] = [
        (
            "handgate_device_commands_total",
            "Commands accepted from fronts.",
            |_, c| c.accepted.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_sent_total",
            "Commands written to the device.",
            |s, _| s.sent,
        ),
        (
            "handgate_device_state_samples_total",
            "Measured states received.",
            |s, _| s.state_samples,
        ),
        (
            "handgate_device_crc_errors_total",
            "Frames or packets that failed their CRC.",
            |s, _| s.crc_errors,
        ),
        (
            "handgate_device_bad_input_total",
            "Commands rejected (malformed, out of model).",
            |s, c| s.rejected + c.rejected.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_foreign_cmd_total",
            "Commands refused: another client owns the front.",
            |_, c| c.foreign_cmd.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_duplicate_cmd_total",
            "Commands dropped: the same source timestamp as their writer's last accepted one.",
            |_, c| c.duplicate_cmd.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_reordered_cmd_total",
            "Commands dropped: older than their writer's last accepted one.",
            |_, c| c.reordered_cmd.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_late_cmd_total",
            "Commands dropped: older than the front's max_command_age_ms on arrival.",
            |_, c| c.late_cmd.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_not_allowed_cmd_total",
            "Commands refused: their host is not in export.allow_commands_from.",
            |_, c| c.not_allowed_cmd.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_watchdog_trips_total",
            "Silence actions run.",
            |_, c| c.watchdog_trips.load(Ordering::Relaxed),
        ),
        (
            "handgate_device_stale_events_total",
            "Times the device's state went from fresh to stale.",
            |s, _| s.stale_events,
        ),
        (
            "handgate_device_reconnects_total",
            "Link re-opens after the first.",
            |s, _| s.reconnects,
        ),
        (
            "handgate_device_missed_cycles_total",
            "Device-loop deadlines missed.",
            |s, _| s.missed_cycles,
        ),
        (
            "handgate_device_reseeds_total",
            "Setpoints replaced by a hold after the link came back.",
            |s, _| s.reseeds,
        ),
        (
            "handgate_device_loop_cycles_total",
            "Device-loop iterations.",
            |s, _| s.cycles,
        ),
    ];
    for (name, help, get) in counters {
        let mut f = Family::new(&mut out, name, "counter", help);
        for (d, l, _, s, _) in &devs {
            f.sample(name, l, get(s, &d.counters) as f64);
        }
    }
    let name = "handgate_device_loop_period_seconds";
    let mut f = Family::new(&mut out, name, "histogram", "Device-loop cycle-to-cycle periods.");
    for (_, l, _, s, _) in &devs {
        let p = s.periods;
        let mut acc = 0u64;
        for (i, c) in p.counts.iter().enumerate() {
            acc += c;
            let le = PERIOD_BOUNDS_S
                .get(i)
                .map(|b| format!("{b}"))
                .unwrap_or_else(|| "+Inf".into());
            f.sample(&format!("{name}_bucket"), &format!("{l},le=\"{le}\""), acc as f64);
        }
        f.sample(&format!("{name}_sum"), l, p.sum_ns as f64 * 1e-9);
        f.sample(&format!("{name}_count"), l, p.count() as f64);
    }
    let mut f = Family::new(
        &mut out,
        "handgate_diagnostics",
        "gauge",
        "Discovery findings now (handgate doctor's), by severity.",
    );
    for sev in ["problem", "note"] {
        let n = status
            .diagnostics
            .iter()
            .filter(|d| crate::diagnostics::severity(&d.kind) == sev)
            .count();
        f.sample("handgate_diagnostics", &format!("severity=\"{sev}\""), n as f64);
    }
    let mut f = Family::new(
        &mut out,
        "handgate_record_messages_total",
        "counter",
        "Messages [record] wrote.",
    );
    f.sample("handgate_record_messages_total", "", status.record_messages as f64);
    let mut f = Family::new(
        &mut out,
        "handgate_record_dropped_total",
        "counter",
        "Messages [record] dropped (disk slower than the stream).",
    );
    f.sample("handgate_record_dropped_total", "", status.record_dropped as f64);
    stream_families(&mut out);
    security_families(&mut out);
    out
}

/// DDS Security's refusals (docs/security.md), per secured domain: the distinct remote
/// participants refused, by reason, and every refusal CycloneDDS logged (a refused peer
/// retries its handshake about once a second).
fn security_families(out: &mut String) {
    use handgate_adapters::dds_security::{secured, Refusal};
    let domains = secured();
    if domains.is_empty() {
        return;
    }
    let mut f = Family::new(
        out,
        "handgate_dds_security_refused_participants_total",
        "counter",
        "Remote participants a secured DDS domain refused, by reason (unauthenticated, unknown_ca, revoked, expired, not_yet_valid, handshake, not_allowed).",
    );
    for (domain, r) in &domains {
        for reason in Refusal::ALL {
            f.sample(
                "handgate_dds_security_refused_participants_total",
                &format!("domain=\"{domain}\",reason=\"{}\"", reason.label()),
                r.participants.get(&reason).copied().unwrap_or(0) as f64,
            );
        }
    }
    let mut f = Family::new(
        out,
        "handgate_dds_security_refusals_total",
        "counter",
        "Refusals a secured DDS domain logged, retries included.",
    );
    for (domain, r) in &domains {
        f.sample(
            "handgate_dds_security_refusals_total",
            &format!("domain=\"{domain}\""),
            r.attempts as f64,
        );
    }
}

/// The byte-stream fronts' families (a device's own interface over TCP or a pty:
/// docs/fronts.md), one sample per running server.
fn stream_families(out: &mut String) {
    let streams = handgate_adapters::front::stream::running();
    if streams.is_empty() {
        return;
    }
    let label = |e: &handgate_adapters::front::stream::StreamEntry| {
        format!("front=\"{}\",at=\"{}\"", esc(&e.front), esc(&e.at))
    };
    let mut f = Family::new(
        out,
        "handgate_stream_clients",
        "gauge",
        "Clients connected to a stream front now.",
    );
    for e in &streams {
        f.sample(
            "handgate_stream_clients",
            &label(e),
            e.counters.open.load(Ordering::Relaxed) as f64,
        );
    }
    let mut f = Family::new(
        out,
        "handgate_stream_accepted_total",
        "counter",
        "Connections a stream front accepted.",
    );
    for e in &streams {
        f.sample(
            "handgate_stream_accepted_total",
            &label(e),
            e.counters.accepted.load(Ordering::Relaxed) as f64,
        );
    }
    let mut f = Family::new(
        out,
        "handgate_stream_commands_total",
        "counter",
        "Commands a stream front's clients wrote (before the front's checks).",
    );
    for e in &streams {
        f.sample(
            "handgate_stream_commands_total",
            &label(e),
            e.counters.commands.load(Ordering::Relaxed) as f64,
        );
    }
    let mut f = Family::new(
        out,
        "handgate_stream_refused_total",
        "counter",
        "Input or clients a stream front refused, by reason (garbage, bad_crc, partial_frame, overlong, idle, too_many_clients, ...).",
    );
    for e in &streams {
        for (reason, n) in e.counters.refused() {
            f.sample(
                "handgate_stream_refused_total",
                &format!("{},reason=\"{reason}\"", label(e)),
                n as f64,
            );
        }
    }
}

/// `/healthz`: healthy when every device is fresh (a device without feedback counts when it
/// reports what is commanded) and its last measurement is within its stale bound; else the
/// reason, naming each device that is not.
pub fn health(fleet: &Fleet, now: Instant) -> (bool, String) {
    let mut bad = Vec::new();
    for d in &fleet.devices {
        let (freshness, age) = {
            let rx = d.device.state();
            let st = rx.borrow();
            (st.freshness, st.age(now))
        };
        match freshness {
            Freshness::CommandedOnly => continue,
            Freshness::Fresh => {
                if let Some(age) = age.filter(|a| *a > d.plan.stale_after) {
                    bad.push(format!("{}: no state for {} ms", d.plan.name, age.as_millis()));
                }
            }
            Freshness::Stale => bad.push(match age {
                Some(age) => format!("{}: stale (last state {} ms ago)", d.plan.name, age.as_millis()),
                None => format!("{}: stale (never measured)", d.plan.name),
            }),
        }
    }
    if bad.is_empty() {
        (true, format!("ok: {} devices fresh\n", fleet.devices.len()))
    } else {
        (false, format!("unhealthy: {}\n", bad.join("; ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn label_values_are_escaped() {
        assert_eq!(esc("a\"b\\c\nd"), "a\\\"b\\\\c\\nd");
    }
}
