//! Endpoint discovery against live CycloneDDS domains (210..219, one per test): endpoints made
//! by the official Python SDK in another process show up with their topic, `::` type name and
//! QoS and disappear when closed; Rust endpoints of another participant of this process are
//! marked `ThisProcess`, those of the discovering participant `ThisParticipant`; the bounds
//! hold. Every wait is on a published snapshot, never a sleep.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::discovery::diagnose::{diagnose, FindingKind, Served, ServedQos};
use handgate_adapters::discovery::{
    busy_endpoints, Discovery, DiscoveryConfig, Durability, EndpointQos, History, Origin, Reliability, Role, Snapshot,
};
use handgate_idl::unitree_go::MotorCmds_;
use handgate_idl::unitree_hg::HandCmd_;

const DEADLINE: Duration = Duration::from_secs(30);
const HG_CMD: &str = "unitree_hg::msg::dds_::HandCmd_";
const HG_STATE: &str = "unitree_hg::msg::dds_::HandState_";

fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `tests/python/discovery_peer.py` under the interop venv; killed when dropped.
struct Peer {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
}

impl Peer {
    fn spawn(args: &[&str]) -> Self {
        let py = repo_root().join(".venv/bin/python");
        assert!(
            py.exists(),
            "{} missing: run scripts/setup.sh (or make test)",
            py.display()
        );
        let mut child = Command::new(py)
            .arg("-u")
            .arg(repo_root().join("tests/python/discovery_peer.py"))
            .args(args)
            .current_dir(repo_root())
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn the Python peer");
        let stdout = child.stdout.take().expect("piped");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for l in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(l).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take();
        Self { child, stdin, lines }
    }

    fn wait_line(&self, prefix: &str) -> String {
        let end = Instant::now() + DEADLINE;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            let line = self
                .lines
                .recv_timeout(left)
                .unwrap_or_else(|e| panic!("peer: no line {prefix:?} ({e})"));
            if let Some(rest) = line.strip_prefix(prefix) {
                return rest.trim().to_string();
            }
        }
    }

    /// Closes stdin: the peer closes its endpoints, prints CLOSED and exits.
    fn close(&mut self) {
        self.stdin.take();
        self.wait_line("CLOSED");
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn find<'a>(s: &'a Snapshot, topic: &str, role: Role) -> Option<&'a handgate_adapters::discovery::Endpoint> {
    s.endpoints.iter().find(|e| &*e.topic == topic && e.role == role)
}

#[test]
fn python_sdk_endpoints_show_up_with_type_and_qos_then_disappear() {
    let node = Node::new(210, None).unwrap();
    let disc = Discovery::start(&node, DiscoveryConfig::default()).unwrap();
    let mut peer = Peer::spawn(&[
        "--domain",
        "210",
        "--pub",
        "rt/dex3/left/cmd=unitree_hg/HandCmd_",
        "--sub",
        "rt/dex3/left/state=unitree_hg/HandState_",
    ]);
    let pid: u32 = peer.wait_line("READY").parse().unwrap();

    let s = disc
        .wait_for(DEADLINE, |s| {
            find(s, "rt/dex3/left/cmd", Role::Writer).is_some() && find(s, "rt/dex3/left/state", Role::Reader).is_some()
        })
        .unwrap();
    let w = find(&s, "rt/dex3/left/cmd", Role::Writer).unwrap();
    let r = find(&s, "rt/dex3/left/state", Role::Reader).unwrap();
    assert_eq!(&*w.type_name, HG_CMD);
    assert_eq!(&*r.type_name, HG_STATE);
    assert_eq!((w.origin, r.origin), (Origin::Remote, Origin::Remote));
    assert_eq!(w.participant, r.participant, "one SDK participant");
    // The SDK passes no QoS: CycloneDDS's defaults (writer reliable, reader best-effort).
    assert_eq!(
        w.qos,
        EndpointQos {
            reliability: Some(Reliability::Reliable),
            durability: Some(Durability::Volatile),
            history: Some(History::KeepLast(1)),
        }
    );
    assert_eq!(
        r.qos,
        EndpointQos {
            reliability: Some(Reliability::BestEffort),
            durability: Some(Durability::Volatile),
            history: Some(History::KeepLast(1)),
        }
    );

    // What CycloneDDS 0.10.2 reports about the peer's participant (printed for the docs).
    let p = disc
        .wait_for(DEADLINE, |s| s.participant(&w.participant).is_some())
        .unwrap()
        .participant(&w.participant)
        .cloned()
        .unwrap();
    let me = s.participant(&s.this_participant).cloned();
    eprintln!("peer participant: {p:?}\nour participant: {me:?}");
    assert_eq!(p.pid, Some(pid), "__Pid is the peer's process id");
    assert!(p.hostname.is_some() && p.hostname == me.as_ref().and_then(|m| m.hostname.clone()));
    assert!(p.process_name.is_some());
    assert!(p.unicast_address().is_some(), "{:?}", p.network_addresses);

    // The diagnostics see the SDK's writer as this topic's client.
    let served = Served {
        topic: "rt/dex3/left/cmd".into(),
        type_name: HG_CMD.into(),
        role: Role::Reader,
        qos: ServedQos {
            reliability: Reliability::BestEffort,
            durability: Durability::Volatile,
            history: History::KeepLast(1),
        },
        alternatives: Vec::new(),
        related_topics: Vec::new(),
        also: Vec::new(),
        entries: None,
        sample_check: None,
    };
    let report = diagnose(&s, std::slice::from_ref(&served));
    assert_eq!(report.topics[0].matched.len(), 1);
    assert_eq!(report.topics[0].matched[0].pid, Some(pid));

    // Closed endpoints disappear (disposed), then the participant once the process is gone.
    let (wk, rk, pk) = (w.key, r.key, p.key);
    peer.close();
    let t0 = Instant::now();
    disc.wait_for(DEADLINE, |s| s.endpoints.iter().all(|e| e.key != wk && e.key != rk))
        .unwrap();
    eprintln!("endpoints gone {:?} after CLOSED", t0.elapsed());
    disc.wait_for(DEADLINE, |s| s.participant(&pk).is_none()).unwrap();
    eprintln!("participant gone {:?} after CLOSED", t0.elapsed());
    let report = diagnose(&disc.snapshot(), &[served]);
    assert!(matches!(report.topics[0].findings[0].kind, FindingKind::NoCounterpart));
}

#[test]
fn rust_endpoints_of_another_participant_and_our_own_are_marked() {
    let node = Node::new(211, None).unwrap();
    let disc = Discovery::start(&node, DiscoveryConfig::default()).unwrap();
    let own = node
        .writer::<HandCmd_>("rt/own/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    let other = Node::new(211, None).unwrap();
    let w = other
        .writer::<MotorCmds_>("rt/dex1/left/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    let r = other
        .reader::<MotorCmds_>("rt/dex1/left/state", Qos::BestEffort)
        .unwrap();

    let s = disc
        .wait_for(DEADLINE, |s| {
            // Endpoints can be discovered before their participant; until the participant is
            // known its endpoints cannot be told apart from remote ones, so wait for it too.
            let of_known = |topic, role| find(s, topic, role).is_some_and(|e| s.participant(&e.participant).is_some());
            find(s, "rt/own/cmd", Role::Writer).is_some()
                && of_known("rt/dex1/left/cmd", Role::Writer)
                && of_known("rt/dex1/left/state", Role::Reader)
        })
        .unwrap();
    eprintln!("participants: {:?}", s.participants);
    let o = find(&s, "rt/own/cmd", Role::Writer).unwrap();
    assert_eq!(o.origin, Origin::ThisParticipant);
    assert_eq!(o.participant, disc.this_participant());
    let dw = find(&s, "rt/dex1/left/cmd", Role::Writer).unwrap();
    let dr = find(&s, "rt/dex1/left/state", Role::Reader).unwrap();
    assert_eq!((dw.origin, dr.origin), (Origin::ThisProcess, Origin::ThisProcess));
    assert_eq!(&*dw.type_name, "unitree_go::msg::dds_::MotorCmds_");
    assert_eq!(dw.qos.reliability, Some(Reliability::Reliable));
    assert_eq!(dw.qos.history, Some(History::KeepLast(10)));
    assert_eq!(dr.qos.reliability, Some(Reliability::BestEffort));
    assert_eq!(s.remote_endpoints().count(), 0, "nothing remote on this domain");
    // CycloneDDS lists the discovering participant's own three built-in readers as local
    // subscriptions; they are ours.
    let builtin: Vec<_> = s.endpoints.iter().filter(|e| e.topic.starts_with("DCPS")).collect();
    assert_eq!(builtin.len(), 3, "{builtin:?}");
    assert!(builtin
        .iter()
        .all(|e| e.origin == Origin::ThisParticipant && e.role == Role::Reader));

    // Dropping them disposes them.
    let key = dw.key;
    drop((w, r, own));
    disc.wait_for(DEADLINE, |s| s.endpoints.iter().all(|e| e.key != key))
        .unwrap();
}

#[test]
fn bounds_hold_endpoints_dropped_and_strings_cut() {
    let node = Node::new(212, None).unwrap();
    let cfg = DiscoveryConfig {
        max_endpoints: 8,
        max_string_len: 16,
        ..Default::default()
    };
    let disc = Discovery::start(&node, cfg).unwrap();
    let other = Node::new(212, None).unwrap();
    let busy = busy_endpoints(&other, 20, "rt/a/very/long/topic/prefix/").unwrap();
    assert_eq!(busy.len(), 20);
    // 20 busy endpoints + the discovering participant's own 3 built-in readers.
    let s = disc
        .wait_for(DEADLINE, |s| {
            s.endpoints.len() as u64 + s.counters.dropped_endpoints >= 23
        })
        .unwrap();
    assert_eq!(s.endpoints.len(), 8);
    assert_eq!(s.counters.dropped_endpoints, 15);
    assert!(s
        .endpoints
        .iter()
        .all(|e| e.topic.len() <= 16 && e.type_name.len() <= 16));
    assert!(s.counters.truncated_strings >= 16, "{:?}", s.counters);
    assert!(s.endpoints.iter().any(|e| &*e.topic == "rt/a/very/long/t"));
}

#[test]
fn snapshot_reader_does_not_block_and_generation_increases() {
    let node = Node::new(213, None).unwrap();
    let disc = Discovery::start(&node, DiscoveryConfig::default()).unwrap();
    let mut rx = disc.subscribe();
    let g0 = disc.snapshot().generation;
    let other = Node::new(213, None).unwrap();
    let _w = other.writer::<MotorCmds_>("rt/gen/cmd", Qos::BestEffort).unwrap();
    let s = disc
        .wait_for(DEADLINE, |s| find(s, "rt/gen/cmd", Role::Writer).is_some())
        .unwrap();
    assert!(s.generation > g0);
    assert!(rx.has_changed().unwrap(), "the watch channel saw it too");
    assert!(rx.borrow_and_update().generation >= s.generation);
}
