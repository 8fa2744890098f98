//! `handgate fleet`: every handgate seen on the lab's DDS domains, from each gateway's own
//! status topic (docs/deployment.md, "A lab of robots"). It joins each domain, finds the
//! writers of handgate's status type whatever their namespace, reads one sample of each and
//! lists them: robot namespace, host, both DDS sides, devices with freshness and safe state,
//! who commands each device. It reads; it never writes anything.
//!
//! The status topic is frozen (docs/wire-types.md, "Status: frozen, and its extension"): every
//! gateway's is read, whatever its version. A gateway that also publishes the extension
//! (`{status topic}_ext`, this version and later ones) has its fronts' rates read from there;
//! one of an older version, which publishes only the status, is listed without them.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;
use std::time::{Duration, Instant};

use std::sync::Arc;

use handgate_adapters::dds::{Node, Qos, Reader};
use handgate_adapters::discovery::{Discovery, DiscoveryConfig, Role, Snapshot};
use handgate_idl::handgate as hg;
use tokio::sync::watch;

/// One gateway's status as read on `domain`, `topic`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Seen {
    pub domain: u32,
    pub topic: String,
    pub status: hg::GatewayStatus_,
    /// Its status extension (`None`: it publishes none, an older gateway, or none came during
    /// the look).
    pub ext: Option<hg::GatewayStatusExt_>,
}

/// What the look found: each gateway (by domain, then topic), and the domains it could not
/// join (with why).
#[derive(Debug, Default, serde::Serialize)]
pub struct Fleet {
    pub gateways: Vec<Seen>,
    pub errors: Vec<(u32, String)>,
    /// Status writers found but silent for the whole look (domain, topic).
    pub silent: Vec<(u32, String)>,
}

/// One domain to look on: its participant and that participant's discovery.
pub type Side = (u32, Node, watch::Receiver<Arc<Snapshot>>);

/// Joins `domains` (on `interface`) and reads every gateway's status there for up to
/// `listen` ([`look_on`]).
pub fn look(domains: &[u32], interface: Option<&str>, listen: Duration) -> Fleet {
    let (sides, _discoveries, errors) = join(domains, interface);
    let mut fleet = look_on(&sides, listen);
    fleet.errors.extend(errors);
    fleet
}

/// Joins each of `domains` on `interface`: the sides to look on, the discoveries to keep alive
/// as long as they are looked on, and the domains that could not be joined (with why).
pub fn join(domains: &[u32], interface: Option<&str>) -> (Vec<Side>, Vec<Discovery>, Vec<(u32, String)>) {
    let mut sides = Vec::new();
    let mut keep = Vec::new();
    let mut errors = Vec::new();
    for &d in domains {
        match Node::new(d, interface).and_then(|n| Ok((Discovery::start(&n, DiscoveryConfig::default())?, n))) {
            Ok((disc, node)) => {
                sides.push((d, node, disc.subscribe()));
                keep.push(disc);
            }
            Err(e) => errors.push((d, e.to_string())),
        }
    }
    (sides, keep, errors)
}

/// Reads every gateway's status on `sides` for up to `listen`: the writers of handgate's
/// status type as discovery finds them, one sample each; done early once every writer found
/// (after a third of `listen`) has given one.
pub fn look_on(sides: &[Side], listen: Duration) -> Fleet {
    let start = Instant::now();
    let mut fleet = Fleet::default();
    let status_type = handgate_adapters::dds::type_name::<hg::GatewayStatus_>();
    let ext_type = handgate_adapters::dds::type_name::<hg::GatewayStatusExt_>();
    // Readers are made as status writers appear, so a gateway found late is still read.
    let mut readers: Vec<(u32, String, Reader<hg::GatewayStatus_>)> = Vec::new();
    let mut ext_readers: Vec<(u32, String, Reader<hg::GatewayStatusExt_>)> = Vec::new();
    let mut made: BTreeSet<(u32, String)> = BTreeSet::new();
    let mut got: BTreeSet<(u32, String)> = BTreeSet::new();
    let mut ext_made: BTreeSet<(u32, String)> = BTreeSet::new();
    let mut exts: BTreeMap<(u32, String), hg::GatewayStatusExt_> = BTreeMap::new();
    while start.elapsed() < listen {
        for (d, node, disc) in sides {
            let snap = disc.borrow().clone();
            // This process's own writers too (the dashboard's own gateway).
            let writers = |ty: &str| -> BTreeSet<String> {
                snap.endpoints
                    .iter()
                    .filter(|e| e.role == Role::Writer && *e.type_name == *ty)
                    .map(|e| e.topic.to_string())
                    .collect()
            };
            for t in writers(&status_type) {
                if made.insert((*d, t.clone())) {
                    match node.reader::<hg::GatewayStatus_>(&t, Qos::Reliable { depth: 1 }) {
                        Ok(r) => readers.push((*d, t, r)),
                        Err(e) => fleet.errors.push((*d, format!("{t}: {e}"))),
                    }
                }
            }
            for t in writers(&ext_type) {
                if ext_made.insert((*d, t.clone())) {
                    match node.reader::<hg::GatewayStatusExt_>(&t, Qos::Reliable { depth: 1 }) {
                        Ok(r) => ext_readers.push((*d, t, r)),
                        Err(e) => fleet.errors.push((*d, format!("{t}: {e}"))),
                    }
                }
            }
        }
        for (d, t, r) in &readers {
            if got.contains(&(*d, t.clone())) {
                continue;
            }
            if let Some(s) = r.take().pop() {
                got.insert((*d, t.clone()));
                fleet.gateways.push(Seen {
                    domain: *d,
                    topic: t.clone(),
                    status: s,
                    ext: None,
                });
            }
        }
        for (d, t, r) in &ext_readers {
            if let Some(s) = r.take().pop() {
                exts.insert((*d, t.clone()), s);
            }
        }
        // Done early once every status writer gave a sample, and so did every extension
        // writer of those gateways.
        let exts_in = ext_made
            .iter()
            .filter(|k| made.iter().any(|(d, t)| (*d, hg::status_ext_topic(t)) == **k))
            .all(|k| exts.contains_key(k));
        if !made.is_empty() && got.len() == made.len() && exts_in && start.elapsed() > listen / 3 {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for g in &mut fleet.gateways {
        g.ext = exts.remove(&(g.domain, hg::status_ext_topic(&g.topic)));
    }
    fleet.silent = made.difference(&got).cloned().collect();
    fleet
        .gateways
        .sort_by(|a, b| (a.domain, &a.topic).cmp(&(b.domain, &b.topic)));
    fleet
}

/// The fleet as `handgate fleet` prints it: one block per gateway.
pub fn render(f: &Fleet) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{} gateway(s)", f.gateways.len());
    for g in &f.gateways {
        let s = &g.status;
        let host = if s.host.is_empty() { "?" } else { &s.host };
        let fresh = s.devices.iter().filter(|d| d.freshness == hg::FRESH).count();
        let safe = s.devices.iter().filter(|d| d.safe).count();
        let _ = writeln!(
            out,
            "\ndomain {}  {}  host {host}  profile {}  up {:.0} s  devices {fresh}/{} fresh, {safe} safe",
            g.domain,
            if s.namespace.is_empty() { "/" } else { &s.namespace },
            s.profile,
            s.uptime_ms as f64 / 1000.0,
            s.devices.len(),
        );
        if (s.domain, &s.interface) != (s.export_domain, &s.export_interface) {
            let iface = crate::tools::interface_word;
            let _ = writeln!(
                out,
                "  devices on domain {}, interface {}; clients on domain {}, interface {}",
                s.domain,
                iface(&s.interface),
                s.export_domain,
                iface(&s.export_interface)
            );
        }
        for d in &s.devices {
            let state = match d.freshness {
                hg::FRESH => "fresh",
                hg::STALE => "STALE",
                hg::COMMANDED_ONLY => "cmd-only",
                _ => "?",
            };
            let _ = writeln!(
                out,
                "  {:<16} {:<10} {:<8} {:<7} {}",
                d.device,
                d.kind,
                state,
                if d.safe { "SAFE" } else { "-" },
                if d.owner.is_empty() { "no command yet" } else { &d.owner }
            );
        }
        match &g.ext {
            Some(x) => {
                let nw = x.fronts.iter().map(|f| f.name.len()).max().unwrap_or(0);
                let kw = x.fronts.iter().map(|f| f.kind.len()).max().unwrap_or(0);
                for f in &x.fronts {
                    let _ = writeln!(
                        out,
                        "  front {:<nw$} {:<kw$}  client commands {:>7.1} Hz  state published {:>7.1} Hz",
                        f.name, f.kind, f.cmd_rate_hz, f.state_rate_hz
                    );
                }
            }
            None => {
                let _ = writeln!(
                    out,
                    "  (no status extension: a handgate older than fronts' rates, or none yet)"
                );
            }
        }
    }
    for (d, t) in &f.silent {
        let _ = writeln!(out, "\ndomain {d}: {t} has a writer but sent nothing during the look");
    }
    for (d, e) in &f.errors {
        let _ = writeln!(out, "\ndomain {d}: not joined: {e}");
    }
    out
}

/// The dashboard's fleet page (`/fleet`): [`render`]'s text in a page that reloads itself
/// every few seconds. Everything in it is escaped: the texts come from other hosts' status.
pub fn page(f: &Fleet) -> String {
    let text = render(f)
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;");
    format!(
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><meta http-equiv=\"refresh\" content=\"3\">\
         <title>handgate fleet</title></head><body><h1>handgate fleet</h1><p><a href=\"/\">this gateway</a> \
         &middot; <a href=\"/api/fleet\">JSON</a></p><pre>{text}</pre></body></html>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_gateway_with_its_sides_devices_and_who_commands_them() {
        let status = |ns: &str, export: u32, owner: &str| hg::GatewayStatus_ {
            profile: "lab-g1-dex3".into(),
            uptime_ms: 12_000,
            domain: 0,
            interface: "eth0".into(),
            export_domain: export,
            export_interface: "eth1".into(),
            namespace: ns.into(),
            host: "pc2".into(),
            devices: vec![
                hg::DeviceStatus_ {
                    device: "left_hand".into(),
                    kind: "dex3".into(),
                    freshness: hg::FRESH,
                    owner: owner.into(),
                    ..Default::default()
                },
                hg::DeviceStatus_ {
                    device: "right_hand".into(),
                    kind: "dex3".into(),
                    freshness: hg::STALE,
                    safe: true,
                    ..Default::default()
                },
            ],
            ..Default::default()
        };
        let f = Fleet {
            gateways: vec![
                Seen {
                    domain: 11,
                    topic: "rt/robot_a/handgate/status".into(),
                    status: status("/robot_a", 11, "front dex3_left: process xr (pid 7) on op at 10.0.0.5"),
                    ext: Some(hg::GatewayStatusExt_ {
                        version: hg::STATUS_EXT_VERSION,
                        refused_participants: 0,
                        fronts: vec![hg::FrontStatus_ {
                            name: "dex3_left".into(),
                            kind: "dex3".into(),
                            cmd_rate_hz: 100.0,
                            state_rate_hz: 500.0,
                        }],
                    }),
                },
                Seen {
                    domain: 12,
                    topic: "rt/robot_b/handgate/status".into(),
                    status: status("/robot_b", 12, ""),
                    ext: None,
                },
            ],
            errors: vec![(13, "no such interface".into())],
            silent: vec![(14, "rt/handgate/status".into())],
        };
        let t = render(&f);
        assert!(t.starts_with("2 gateway(s)\n"), "{t}");
        assert!(
            t.contains("domain 11  /robot_a  host pc2  profile lab-g1-dex3  up 12 s  devices 1/2 fresh, 1 safe\n"),
            "{t}"
        );
        assert!(
            t.contains("  devices on domain 0, interface eth0; clients on domain 11, interface eth1\n"),
            "{t}"
        );
        assert!(
            t.contains("front dex3_left: process xr (pid 7) on op at 10.0.0.5"),
            "{t}"
        );
        assert!(
            t.contains("right_hand       dex3       STALE    SAFE    no command yet"),
            "{t}"
        );
        assert!(
            t.contains("domain 14: rt/handgate/status has a writer but sent nothing"),
            "{t}"
        );
        assert!(t.contains("domain 13: not joined: no such interface"), "{t}");
        // The fronts' rates from the extension; a gateway without one says so.
        assert!(
            t.contains("  front dex3_left dex3  client commands   100.0 Hz  state published   500.0 Hz\n"),
            "{t}"
        );
        assert!(
            t.contains("  (no status extension: a handgate older than fronts' rates, or none yet)"),
            "{t}"
        );
    }

    #[test]
    fn the_page_escapes_what_other_hosts_send() {
        let f = Fleet {
            gateways: vec![Seen {
                domain: 11,
                topic: "rt/handgate/status".into(),
                status: hg::GatewayStatus_ {
                    profile: "<script>alert(1)</script>".into(),
                    ..Default::default()
                },
                ext: Some(hg::GatewayStatusExt_ {
                    version: 1,
                    refused_participants: 0,
                    fronts: vec![hg::FrontStatus_ {
                        name: "<b>x</b>".into(),
                        ..Default::default()
                    }],
                }),
            }],
            ..Default::default()
        };
        let p = page(&f);
        assert!(p.contains("&lt;script&gt;alert(1)&lt;/script&gt;"), "{p}");
        assert!(p.contains("&lt;b&gt;x&lt;/b&gt;"), "{p}");
        assert!(!p.contains("<script>"), "{p}");
        assert!(p.contains("<meta http-equiv=\"refresh\" content=\"3\">"), "{p}");
    }
}
