//! Bring-up tools behind the CLI: `handgate status` (a live table from the gateway's status
//! topic) and `handgate send` (one command in the canonical model to a named device).

use std::fmt::Write as _;
use std::time::Duration;

use handgate_adapters::dds::{DdsError, EndpointOptions, Node, Qos};
use handgate_adapters::front::serve::FORCE_USER_DATA;
use handgate_idl::handgate as hg;

/// A device's freshness as the status tables print it.
pub fn freshness_word(f: u8) -> &'static str {
    match f {
        hg::FRESH => "fresh",
        hg::STALE => "STALE",
        hg::COMMANDED_ONLY => "cmd-only",
        _ => "?",
    }
}

/// A status's interface name as the tables print it ("" is any).
pub fn interface_word(i: &str) -> &str {
    if i.is_empty() {
        "(any)"
    } else {
        i
    }
}

/// Renders one status sample as a table.
pub fn render_status(s: &hg::GatewayStatus_) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "profile {}  uptime {:.1} s",
        s.profile,
        s.uptime_ms as f64 / 1000.0
    );
    let iface = interface_word;
    let host = if s.host.is_empty() { "?" } else { &s.host };
    if (s.domain, &s.interface) == (s.export_domain, &s.export_interface) {
        let _ = writeln!(
            out,
            "host {host}  namespace {}  DDS domain {}, interface {}",
            s.namespace,
            s.domain,
            iface(&s.interface)
        );
    } else {
        let _ = writeln!(
            out,
            "host {host}  namespace {}  devices: domain {}, interface {}  clients (export): domain {}, interface {}",
            s.namespace,
            s.domain,
            iface(&s.interface),
            s.export_domain,
            iface(&s.export_interface)
        );
    }
    let _ = writeln!(
        out,
        "{:<16} {:<10} {:<9} {:<9} {:>5} {:>10} {:>9} {:>8} {:>6} {:>6} {:>6} {:>6} {:>9} {:>7} {:>9}  motion",
        "device",
        "kind",
        "backend",
        "state",
        "safe",
        // The commands handgate sends the device per second; the clients' command rates are
        // the fronts' ([`render_fronts`]).
        "dev cmd Hz",
        "state Hz",
        "age ms",
        "crc",
        "bad",
        "wdog",
        "recon",
        "missed",
        "foreign",
        "track rad",
    );
    for d in &s.devices {
        let fresh = freshness_word(d.freshness);
        let _ = writeln!(
            out,
            "{:<16} {:<10} {:<9} {:<9} {:>5} {:>10.1} {:>9.1} {:>8.1} {:>6} {:>6} {:>6} {:>6} {:>9} {:>7} {:>9.3}  {}",
            d.device,
            d.kind,
            d.backend,
            fresh,
            if d.safe { "yes" } else { "no" },
            d.cmd_rate_hz,
            d.state_rate_hz,
            d.age_ms,
            d.crc_errors,
            d.bad_input,
            d.watchdog_trips,
            d.reconnects,
            d.missed_cycles,
            d.foreign_cmd,
            d.tracking_error,
            motion_word(d)
        );
    }
    // Devices that report but do not move (docs/adapters.md, "Motion"), when any.
    for d in s.devices.iter().filter(|d| d.motion != hg::MOTION_OK) {
        let _ = writeln!(
            out,
            "\n{}: {} (tracking error {:.3} rad)",
            d.device,
            motion_sentence(d),
            d.tracking_error
        );
    }
    // Commands dropped by their source timestamps (docs/fronts.md, "Commands in order"): a
    // table of its own, only when any was, so the device table keeps its columns.
    let dropped: Vec<&hg::DeviceStatus_> = s
        .devices
        .iter()
        .filter(|d| d.duplicate_cmd + d.reordered_cmd + d.late_cmd > 0)
        .collect();
    if !dropped.is_empty() {
        let _ = writeln!(
            out,
            "\ncommands dropped by source timestamp\n  {:<16} {:>9} {:>9} {:>9}",
            "device", "duplicate", "reordered", "late"
        );
        for d in dropped {
            let _ = writeln!(
                out,
                "  {:<16} {:>9} {:>9} {:>9}",
                d.device, d.duplicate_cmd, d.reordered_cmd, d.late_cmd
            );
        }
    }
    // Commands from a host not in `export.allow_commands_from`, when any were.
    for d in s.devices.iter().filter(|d| d.not_allowed_cmd > 0) {
        let _ = writeln!(
            out,
            "\n{}: {} command(s) refused: their host is not in export.allow_commands_from",
            d.device, d.not_allowed_cmd
        );
    }
    if !s.endpoints.is_empty() {
        let _ = writeln!(out, "\nendpoints (matched counterparts)");
        for e in &s.endpoints {
            let who = if e.who.is_empty() {
                String::new()
            } else {
                format!(": {}", e.who.join(", "))
            };
            let _ = writeln!(
                out,
                "  {:<28} {:<6} {:<36} {:>3}{who}",
                e.owner, e.role, e.topic, e.matched
            );
        }
    }
    let _ = writeln!(
        out,
        "\ndiagnostics:{}",
        if s.diagnostics.is_empty() { " none" } else { "" }
    );
    for d in &s.diagnostics {
        let _ = writeln!(out, "  {} {} [{}]: {}", d.owner, d.topic, d.kind, d.detail);
        let _ = writeln!(out, "    fix: {}", d.fix);
    }
    if s.record_messages > 0 || s.record_dropped > 0 {
        let _ = writeln!(
            out,
            "recording: {} message(s) written, {} dropped",
            s.record_messages, s.record_dropped
        );
    }
    out
}

/// The fronts' table, from the status extension (`None`: the gateway publishes none, an
/// older handgate): per front, the command samples its clients sent per second beside the
/// state samples it published per second.
pub fn render_fronts(ext: Option<&hg::GatewayStatusExt_>) -> String {
    let mut out = String::new();
    let Some(x) = ext else {
        let _ = writeln!(
            out,
            "\nfronts: no status extension (the gateway is a handgate older than fronts' rates)"
        );
        return out;
    };
    if x.refused_participants > 0 {
        let _ = writeln!(
            out,
            "\nDDS Security: {} remote participant(s) refused (by reason: /metrics \
             handgate_dds_security_refused_participants_total, docs/security.md)",
            x.refused_participants
        );
    }
    if x.fronts.is_empty() {
        return out;
    }
    // Columns as wide as the longest name and kind.
    let nw = x.fronts.iter().map(|f| f.name.len()).max().unwrap_or(0).max(5);
    let kw = x.fronts.iter().map(|f| f.kind.len()).max().unwrap_or(0).max(4);
    let _ = writeln!(
        out,
        "\nfronts\n  {:<nw$} {:<kw$} {:>13} {:>13}",
        "front", "kind", "client cmd Hz", "state pub Hz"
    );
    for f in &x.fronts {
        let _ = writeln!(
            out,
            "  {:<nw$} {:<kw$} {:>13.1} {:>13.1}",
            f.name, f.kind, f.cmd_rate_hz, f.state_rate_hz
        );
    }
    out
}

/// A gateway's status and its extension, read together (`handgate status`).
pub struct StatusReader {
    status: handgate_adapters::dds::Reader<hg::GatewayStatus_>,
    ext: handgate_adapters::dds::Reader<hg::GatewayStatusExt_>,
    last_ext: Option<hg::GatewayStatusExt_>,
}

impl StatusReader {
    /// Readers of `topic` and of its extension ([`hg::status_ext_topic`]).
    pub fn new(node: &Node, topic: &str) -> Result<Self, DdsError> {
        Ok(Self {
            status: node.reader(topic, Qos::Reliable { depth: 1 })?,
            ext: node.reader(&hg::status_ext_topic(topic), Qos::Reliable { depth: 1 })?,
            last_ext: None,
        })
    }

    /// The next status sample (an error after `timeout` without one) and the latest extension
    /// (`None` while the gateway publishes none: when its extension writer is matched, the
    /// first extension sample is waited for, up to `timeout`).
    pub fn next(&mut self, timeout: Duration) -> Result<(hg::GatewayStatus_, Option<hg::GatewayStatusExt_>), DdsError> {
        let s = self
            .status
            .wait_take(timeout)?
            .pop()
            .expect("wait_take returns at least one sample");
        if let Some(x) = self.ext.take().pop() {
            self.last_ext = Some(x);
        } else if self.last_ext.is_none() && self.ext.matched() > 0 {
            self.last_ext = self.ext.wait_take(timeout).ok().and_then(|mut v| v.pop());
        }
        Ok((s, self.last_ext.clone()))
    }
}

/// How `handgate send` sends: how long to wait for the gateway, how long to repeat the
/// command, whether to take the front over from its owner.
#[derive(Debug, Clone, Copy)]
pub struct SendOptions {
    pub timeout: Duration,
    pub hold: Duration,
    /// Writes with handgate's take-over marker ([`FORCE_USER_DATA`]) as its USER_DATA.
    pub force: bool,
}

/// Publishes a command to handgate's own interface `rt/handgate/{device}/cmd` after the gateway's reader has
/// matched, repeating it at 50 Hz for `hold` (the front's watchdog holds the device once the
/// stream stops). Returns how many samples were written.
/// `ns`: the gateway's ROS namespace (docs/fronts.md, "ROS 2").
pub fn send(
    node: &Node,
    ns: &handgate_adapters::ros::Namespace,
    device: &str,
    cmd: hg::HandCmd_,
    o: SendOptions,
) -> Result<u64, DdsError> {
    let SendOptions { timeout, hold, force } = o;
    let topic = ns.topic(&handgate_adapters::fronts::own_topics(device).0);
    let qos = Qos::Reliable { depth: 1 };
    let opts = if force {
        EndpointOptions::default().user_data(FORCE_USER_DATA)
    } else {
        EndpointOptions::default()
    };
    let mut w = node.writer_with::<hg::HandCmd_>(&topic, qos, &opts)?;
    w.wait_matched(1, timeout)?;
    let start = std::time::Instant::now();
    let mut n: u64 = 0;
    loop {
        w.write(hg::HandCmd_ {
            seq: n + 1,
            ..cmd.clone()
        })?;
        n += 1;
        let next = start + Duration::from_millis(20) * n as u32;
        if next.duration_since(start) > hold {
            break;
        }
        std::thread::sleep(next.saturating_duration_since(std::time::Instant::now()));
    }
    Ok(n)
}

/// The motion column: the verdict's word, with the joint it names (`joint_stuck:thumb_1`).
pub fn motion_word(d: &hg::DeviceStatus_) -> String {
    let w = handgate_adapters::motion::Verdict::word(d.motion);
    if d.motion_joint.is_empty() {
        w.to_string()
    } else {
        format!("{w}:{}", d.motion_joint)
    }
}

/// The motion verdict as a sentence (`handgate status`, `handgate doctor`).
pub fn motion_sentence(d: &hg::DeviceStatus_) -> String {
    let j = &d.motion_joint;
    match d.motion {
        hg::MOTION_OK => "follows its command".into(),
        hg::MOTION_FROZEN => format!(
            "reports but does not move: its state samples repeat while it is commanded to move (largest error at {j})"
        ),
        hg::MOTION_JOINT_STUCK => format!("joint {j} does not follow its target while the other joints do"),
        hg::MOTION_NOT_FOLLOWING => format!(
            "does not follow its command: the state varies but no joint approaches its target (largest error at {j})"
        ),
        hg::MOTION_HOLDING => format!("holding an object: stopped closing in contact (largest error at {j})"),
        other => format!("unknown motion verdict {other}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_row_per_device() {
        let s = hg::GatewayStatus_ {
            profile: "default".into(),
            uptime_ms: 1500,
            devices: vec![hg::DeviceStatus_ {
                device: "left_hand".into(),
                kind: handgate_adapters::kind::DeviceKind::default().as_str().into(),
                freshness: hg::STALE,
                ..Default::default()
            }],
            ..Default::default()
        };
        let t = render_status(&s);
        assert!(t.contains("left_hand") && t.contains("STALE") && t.contains("uptime 1.5 s"));
        assert!(t.contains("diagnostics: none"), "{t}");
        assert!(!t.contains("recording"));
        let t = render_status(&hg::GatewayStatus_ {
            record_messages: 10,
            record_dropped: 2,
            ..s
        });
        assert!(t.contains("recording: 10 message(s) written, 2 dropped"), "{t}");
        let one = render_status(&hg::GatewayStatus_ {
            domain: 0,
            interface: "eth0".into(),
            export_domain: 0,
            export_interface: "eth0".into(),
            namespace: "/".into(),
            host: "pc2".into(),
            ..Default::default()
        });
        assert!(
            one.contains("host pc2  namespace /  DDS domain 0, interface eth0\n"),
            "{one}"
        );
        let two = render_status(&hg::GatewayStatus_ {
            domain: 0,
            interface: "eth0".into(),
            export_domain: 10,
            export_interface: "eth1".into(),
            namespace: "/robot1".into(),
            host: "pc2".into(),
            ..Default::default()
        });
        assert!(
            two.contains(
                "host pc2  namespace /robot1  devices: domain 0, interface eth0  clients (export): domain 10, interface eth1\n"
            ),
            "{two}"
        );
    }

    /// The fronts' table: each front's client command rate beside its state rate, columns as
    /// wide as the longest name; a gateway without the extension says so.
    #[test]
    fn renders_the_fronts_rates_from_the_extension() {
        let x = hg::GatewayStatusExt_ {
            version: hg::STATUS_EXT_VERSION,
            refused_participants: 0,
            fronts: vec![
                hg::FrontStatus_ {
                    name: "dex3_left".into(),
                    kind: "dex3".into(),
                    cmd_rate_hz: 99.96,
                    state_rate_hz: 500.04,
                },
                hg::FrontStatus_ {
                    name: "canonical_inspire_dfx_right".into(),
                    kind: "canonical".into(),
                    cmd_rate_hz: 0.0,
                    state_rate_hz: 100.0,
                },
            ],
        };
        let t = render_fronts(Some(&x));
        assert!(
            t.contains("\nfronts\n  front                       kind      client cmd Hz  state pub Hz\n"),
            "{t}"
        );
        assert!(
            t.contains("\n  dex3_left                   dex3              100.0         500.0\n"),
            "{t}"
        );
        assert!(
            t.contains("\n  canonical_inspire_dfx_right canonical           0.0         100.0\n"),
            "{t}"
        );
        assert!(render_fronts(None).contains("fronts: no status extension"));
        // The devices' table says its command rate is what handgate sends the device.
        assert!(render_status(&hg::GatewayStatus_::default()).contains(" dev cmd Hz "));
    }

    /// The commands dropped by their source timestamps get a table of their own, only for
    /// the devices with any; the device table keeps its columns.
    /// The motion column names the verdict and its joint; a device that reports but does not
    /// move gets a sentence under the table, the others none.
    #[test]
    fn renders_the_motion_verdict_with_its_joint() {
        let dev = |name: &str, motion: u8, joint: &str, err: f32| hg::DeviceStatus_ {
            device: name.into(),
            kind: "dex3".into(),
            backend: "dds".into(),
            motion,
            motion_joint: joint.into(),
            tracking_error: err,
            ..Default::default()
        };
        let s = hg::GatewayStatus_ {
            devices: vec![
                dev("left_hand", hg::MOTION_JOINT_STUCK, "thumb_1", 0.8),
                dev("right_hand", hg::MOTION_OK, "", f32::NAN),
            ],
            ..Default::default()
        };
        let t = render_status(&s);
        let row = |name: &str| -> Vec<String> {
            t.lines()
                .find(|l| l.starts_with(name))
                .unwrap()
                .split_whitespace()
                .map(str::to_string)
                .collect()
        };
        assert_eq!(row("left_hand")[14..], ["0.800", "joint_stuck:thumb_1"], "{t}");
        assert_eq!(row("right_hand")[14..], ["NaN", "ok"], "{t}");
        assert!(
            t.contains("left_hand: joint thumb_1 does not follow its target while the other joints do (tracking error 0.800 rad)"),
            "{t}"
        );
        assert!(!t.contains("right_hand:"), "{t}");
    }

    #[test]
    fn renders_the_commands_dropped_by_source_timestamp_only_when_there_are_some() {
        let dev = |name: &str| hg::DeviceStatus_ {
            device: name.into(),
            kind: "dex3".into(),
            backend: "emulator".into(),
            ..Default::default()
        };
        let mut s = hg::GatewayStatus_ {
            devices: vec![dev("left_hand"), dev("right_hand")],
            ..Default::default()
        };
        let t = render_status(&s);
        assert!(!t.contains("commands dropped"), "{t}");
        s.devices[0].duplicate_cmd = 3;
        s.devices[0].late_cmd = 1;
        let t = render_status(&s);
        let table: Vec<Vec<&str>> = t
            .lines()
            .skip_while(|l| !l.starts_with("commands dropped by source timestamp"))
            .skip(1)
            .take_while(|l| !l.is_empty())
            .map(|l| l.split_whitespace().collect())
            .collect();
        assert_eq!(
            table,
            [
                vec!["device", "duplicate", "reordered", "late"],
                vec!["left_hand", "3", "0", "1"]
            ],
            "{t}"
        );
        let first = t.lines().find(|l| l.starts_with("left_hand")).unwrap();
        // device kind backend state safe cmdHz stateHz age crc bad wdog recon missed foreign track motion
        assert_eq!(first.split_whitespace().count(), 16, "{t}");
    }

    #[test]
    fn renders_endpoints_and_diagnostics_with_their_fixes() {
        let s = hg::GatewayStatus_ {
            endpoints: vec![hg::EndpointStatus_ {
                owner: "front f1".into(),
                topic: "rt/a/cmd".into(),
                role: "reader".into(),
                matched: 1,
                who: vec!["process python (pid 7) on vm".into()],
            }],
            diagnostics: vec![hg::Diagnostic_ {
                owner: "front f1".into(),
                topic: "rt/a/cmd".into(),
                kind: "type_mismatch".into(),
                detail: "1 writer(s) use type x::T_".into(),
                fix: "set variant".into(),
            }],
            ..Default::default()
        };
        let t = render_status(&s);
        assert!(t.contains("front f1") && t.contains("pid 7"), "{t}");
        assert!(
            t.contains("[type_mismatch]: 1 writer(s) use type x::T_") && t.contains("fix: set variant"),
            "{t}"
        );
    }
}
