//! Pure diagnostics over a discovery [`Snapshot`]: given what this process serves (plain
//! data), find the remote counterparts of each served topic and say why a client might be
//! stuck ("Waiting to subscribe dds…"): another type on the topic, QoS that cannot match, a
//! topic name that is almost ours, or a second writer of a topic this process writes.
//!
//! Nothing here knows a device kind: wording specific to a device arrives as data
//! ([`Served::alternatives`], [`Served::related_topics`]). Every finding carries a short fix.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{Durability, Endpoint, EndpointQos, Guid, History, Origin, Reliability, Role, Snapshot};

/// The QoS this process uses on a served endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServedQos {
    pub reliability: Reliability,
    pub durability: Durability,
    pub history: History,
}

/// Another type a client may use on a served topic, and what to tell its user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Alternative {
    pub type_name: String,
    pub hint: String,
}

/// A topic name a client may use instead of a served one (e.g. an older interface), and
/// what to tell its user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RelatedTopic {
    pub topic: String,
    pub hint: String,
    /// The owner serves this topic itself once a client on it is discovered (a Dex1 `auto`
    /// front and the actuator pair): a client there is a note, not a problem.
    pub on_demand: bool,
}

/// One endpoint this process serves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Served {
    pub topic: String,
    pub type_name: String,
    pub role: Role,
    pub qos: ServedQos,
    pub alternatives: Vec<Alternative>,
    pub related_topics: Vec<RelatedTopic>,
    /// Other types served on this topic in this role with this QoS by the same owner (a
    /// front that follows its clients' types, like an `auto` Dex1 front): their
    /// counterparts match as the main type's do.
    pub also: Vec<String>,
    /// The entries (motors) the owner expects in each sample's sequence, where a sample of
    /// another count is another hand on this topic (a Dex5-1's 20 on a Dex3-1's 7): the
    /// doctor reads the counterpart's samples and says which kind answers. `None`: not
    /// checked.
    pub entries: Option<usize>,
    /// A check of a counterpart's sample (its bytes after the encapsulation header) for a
    /// mistake the front would reject it for, in words with its fix: the doctor reads what
    /// clients write and runs it (the Dex3 front: a mode byte left 0). `None`: not checked.
    pub sample_check: Option<SampleCheck>,
}

/// See [`Served::sample_check`]: the rejection of a sample the front refuses for a mistake its
/// client repeats ([`crate::front::Rejection::fix`] says the fix). Two checks compare equal
/// (an endpoint is described by its topic, type, role and QoS; a function's address is not
/// a meaningful identity).
#[derive(Debug, Clone, Copy)]
pub struct SampleCheck(pub fn(&[u8]) -> Option<crate::front::Rejection>);

impl PartialEq for SampleCheck {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Eq for SampleCheck {}

impl Served {
    /// `role` on `topic` with `type_name` and `qos`, no alternatives or related topics.
    pub fn new(topic: &str, type_name: String, role: Role, qos: ServedQos) -> Self {
        Self {
            topic: topic.to_string(),
            type_name,
            role,
            qos,
            alternatives: Vec::new(),
            related_topics: Vec::new(),
            also: Vec::new(),
            entries: None,
            sample_check: None,
        }
    }

    /// Expecting `n` entries in each sample (see [`Served::entries`]).
    pub fn with_entries(mut self, n: usize) -> Self {
        self.entries = Some(n);
        self
    }

    /// Checking the counterpart's samples with `check` (see [`Served::sample_check`]).
    pub fn with_sample_check(mut self, check: fn(&[u8]) -> Option<crate::front::Rejection>) -> Self {
        self.sample_check = Some(SampleCheck(check));
        self
    }

    /// Also serving `type_name` here (see [`Served::also`]).
    pub fn also_serving(mut self, type_name: String) -> Self {
        self.also.push(type_name);
        self
    }

    /// Whether a counterpart of type `type_name` matches this endpoint.
    pub fn serves_type(&self, type_name: &str) -> bool {
        self.type_name == type_name || self.also.iter().any(|t| t == type_name)
    }

    /// With another type a client may use here, and what to tell its user.
    pub fn alternative(mut self, type_name: String, hint: impl Into<String>) -> Self {
        self.alternatives.push(Alternative {
            type_name,
            hint: hint.into(),
        });
        self
    }

    /// With a topic a client may use instead of this one, and what to tell its user.
    pub fn related(mut self, topic: impl Into<String>, hint: impl Into<String>) -> Self {
        self.related_topics.push(RelatedTopic {
            topic: topic.into(),
            hint: hint.into(),
            on_demand: false,
        });
        self
    }

    /// With a topic the owner starts serving itself once a client on it is discovered, and
    /// what to tell its user.
    pub fn related_on_demand(mut self, topic: impl Into<String>, hint: impl Into<String>) -> Self {
        self.related_topics.push(RelatedTopic {
            topic: topic.into(),
            hint: hint.into(),
            on_demand: true,
        });
        self
    }
}

/// A remote endpoint a finding is about, with what its participant reported.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RemoteRef {
    pub endpoint: Guid,
    pub participant: Guid,
    pub role: Role,
    pub topic: Arc<str>,
    pub type_name: Arc<str>,
    pub qos: EndpointQos,
    pub hostname: Option<Arc<str>>,
    pub pid: Option<u32>,
    pub process_name: Option<Arc<str>>,
    pub address: Option<String>,
}

impl RemoteRef {
    fn new(s: &Snapshot, e: &Endpoint) -> Self {
        let p = s.participant(&e.participant);
        Self {
            endpoint: e.key,
            participant: e.participant,
            role: e.role,
            topic: e.topic.clone(),
            type_name: e.type_name.clone(),
            qos: e.qos,
            hostname: p.and_then(|p| p.hostname.clone()),
            pid: p.and_then(|p| p.pid),
            process_name: p.and_then(|p| p.process_name.clone()),
            address: p.and_then(|p| p.unicast_address().map(str::to_string)),
        }
    }

    /// "process NAME (pid P) on HOST at ADDR", with what is known.
    pub fn who(&self) -> String {
        let mut s = match (&self.process_name, self.pid) {
            (Some(n), Some(p)) => format!("process {n} (pid {p})"),
            (Some(n), None) => format!("process {n}"),
            (None, Some(p)) => format!("pid {p}"),
            (None, None) => format!("participant {}", self.participant),
        };
        if let Some(h) = &self.hostname {
            s.push_str(&format!(" on {h}"));
        }
        if let Some(a) = &self.address {
            s.push_str(&format!(" at {a}"));
        }
        s
    }
}

/// What a finding is about.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FindingKind {
    /// No remote endpoint of the counterpart role on the served topic.
    NoCounterpart,
    /// A counterpart on the served topic with another type name.
    TypeMismatch { remote_type: String },
    /// A counterpart with the served type whose QoS cannot match ours.
    QosMismatch { reasons: Vec<String> },
    /// A counterpart-role endpoint, with nothing to match it, on a topic close to a served one.
    NearMissTopic { remote_topic: String, reason: String },
    /// Another process writes a topic this process writes.
    ForeignWriter,
    /// A counterpart-role endpoint on a related topic the owner serves once such a client is
    /// discovered ([`RelatedTopic::on_demand`]): not a problem.
    ServedOnDemand { remote_topic: String },
}

/// One diagnosis about a served topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Finding {
    pub kind: FindingKind,
    pub served_topic: String,
    pub served_role: Role,
    /// Plain-words description.
    pub detail: String,
    /// Plain-words fix.
    pub fix: String,
    /// The remote endpoints concerned (at most [`MAX_REMOTES_PER_FINDING`]).
    pub remotes: Vec<RemoteRef>,
    /// How many remote endpoints are concerned in all.
    pub remote_count: usize,
}

/// Remote endpoints listed per finding (the rest only counted).
pub const MAX_REMOTES_PER_FINDING: usize = 8;

/// Per served endpoint: the remote endpoints it matches, and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicReport {
    pub topic: String,
    pub role: Role,
    pub matched: Vec<RemoteRef>,
    pub findings: Vec<Finding>,
}

/// The diagnosis of a snapshot against what this process serves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Report {
    pub domain_id: u32,
    pub topics: Vec<TopicReport>,
}

impl Report {
    pub fn findings(&self) -> impl Iterator<Item = &Finding> {
        self.topics.iter().flat_map(|t| t.findings.iter())
    }
}

/// The QoS a remote endpoint has, with CycloneDDS's defaults for what it did not carry
/// (writers reliable, readers best-effort, both volatile, keep-last 1).
fn effective(q: &EndpointQos, role: Role) -> ServedQos {
    ServedQos {
        reliability: q.reliability.unwrap_or(match role {
            Role::Writer => Reliability::Reliable,
            Role::Reader => Reliability::BestEffort,
        }),
        durability: q.durability.unwrap_or(Durability::Volatile),
        history: q.history.unwrap_or(History::KeepLast(1)),
    }
}

fn reliability_word(r: Reliability) -> &'static str {
    match r {
        Reliability::BestEffort => "best-effort",
        Reliability::Reliable => "reliable",
    }
}

fn durability_word(d: Durability) -> &'static str {
    match d {
        Durability::Volatile => "volatile",
        Durability::TransientLocal => "transient-local",
        Durability::Transient => "transient",
        Durability::Persistent => "persistent",
    }
}

/// Why a writer and a reader with these QoS cannot match (empty: they can), per the DDS
/// request/offer rule for RELIABILITY and DURABILITY. History never prevents a match.
pub fn qos_incompatibilities(writer: &ServedQos, reader: &ServedQos) -> Vec<String> {
    let mut out = Vec::new();
    if writer.reliability < reader.reliability {
        out.push(format!(
            "the writer is {} and the reader requires {}",
            reliability_word(writer.reliability),
            reliability_word(reader.reliability)
        ));
    }
    if writer.durability < reader.durability {
        out.push(format!(
            "the writer offers {} durability and the reader requests {}",
            durability_word(writer.durability),
            durability_word(reader.durability)
        ));
    }
    out
}

/// Levenshtein distance between `a` and `b` (bytes) if it is at most `k`, computed in a
/// band of width 2k+1 (O(len·k)); None when larger.
pub fn edit_distance_within(a: &str, b: &str, k: usize) -> Option<usize> {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len().abs_diff(b.len()) > k {
        return None;
    }
    let big = k + 1;
    let mut prev: Vec<usize> = (0..=b.len()).map(|j| j.min(big)).collect();
    let mut cur = vec![big; b.len() + 1];
    for i in 1..=a.len() {
        let lo = i.saturating_sub(k).max(1);
        let hi = (i + k).min(b.len());
        cur.iter_mut().for_each(|c| *c = big);
        cur[0] = i.min(big);
        let mut row_min = cur[0];
        for j in lo..=hi {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            let v = sub.min(prev[j] + 1).min(cur[j - 1] + 1).min(big);
            cur[j] = v;
            row_min = row_min.min(v);
        }
        if row_min > k {
            return None;
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    let d = prev[b.len()];
    (d <= k).then_some(d)
}

/// Largest edit distance reported as a near miss.
pub const NEAR_MISS_DISTANCE: usize = 2;

/// Why `remote` looks like a mistyped `served` (None: it does not).
pub fn near_miss_reason(remote: &str, served: &str) -> Option<String> {
    if remote == served {
        return None;
    }
    if remote.trim() == served {
        return Some("surrounding whitespace in the topic name".into());
    }
    if remote.eq_ignore_ascii_case(served) {
        return Some("different letter case".into());
    }
    if served.strip_prefix("rt/") == Some(remote) {
        return Some("missing the rt/ prefix".into());
    }
    if remote.strip_prefix("rt/") == Some(served) {
        return Some("an extra rt/ prefix".into());
    }
    edit_distance_within(remote, served, NEAR_MISS_DISTANCE)
        .map(|d| format!("{d} character{} different", if d == 1 { "" } else { "s" }))
}

fn role_word(r: Role) -> &'static str {
    match r {
        Role::Reader => "reader",
        Role::Writer => "writer",
    }
}

fn finding(kind: FindingKind, served: &Served, detail: String, fix: String, remotes: Vec<RemoteRef>) -> Finding {
    let remote_count = remotes.len();
    let mut remotes = remotes;
    remotes.truncate(MAX_REMOTES_PER_FINDING);
    Finding {
        kind,
        served_topic: served.topic.clone(),
        served_role: served.role,
        detail,
        fix,
        remotes,
        remote_count,
    }
}

/// Diagnoses `snapshot` against what this process serves. Only remote endpoints
/// ([`Origin::Remote`]) count as counterparts; this process's own are ignored.
pub fn diagnose(snapshot: &Snapshot, served: &[Served]) -> Report {
    let remote: Vec<&Endpoint> = snapshot.remote_endpoints().collect();
    // Per (topic, role): the participants with such an endpoint (any origin), built once, so
    // whether a remote endpoint is answered costs a lookup, not a scan of the snapshot.
    let mut by_topic_role: std::collections::HashMap<(&str, Role), Vec<Guid>> = std::collections::HashMap::new();
    for e in &snapshot.endpoints {
        by_topic_role.entry((&e.topic, e.role)).or_default().push(e.participant);
    }
    // Whether another participant answers each remote endpoint (same order as `remote`).
    let answered: Vec<bool> = remote
        .iter()
        .map(|e| {
            by_topic_role
                .get(&(&*e.topic, e.role.counterpart()))
                .is_some_and(|ps| ps.iter().any(|p| *p != e.participant))
        })
        .collect();
    let served_topics: std::collections::HashSet<(&str, Role)> =
        served.iter().map(|s| (s.topic.as_str(), s.role)).collect();
    let mut topics = Vec::with_capacity(served.len());
    for s in served {
        let want = s.role.counterpart();
        let mut matched = Vec::new();
        let mut by_type: BTreeMap<&str, Vec<RemoteRef>> = BTreeMap::new();
        let mut by_qos: BTreeMap<Vec<String>, Vec<RemoteRef>> = BTreeMap::new();
        let mut foreign = Vec::new();
        for e in remote.iter().filter(|e| *e.topic == *s.topic) {
            if e.role == want {
                if !s.serves_type(&e.type_name) {
                    by_type
                        .entry(&e.type_name)
                        .or_default()
                        .push(RemoteRef::new(snapshot, e));
                    continue;
                }
                let theirs = effective(&e.qos, e.role);
                let reasons = match s.role {
                    Role::Reader => qos_incompatibilities(&theirs, &s.qos),
                    Role::Writer => qos_incompatibilities(&s.qos, &theirs),
                };
                if reasons.is_empty() {
                    matched.push(RemoteRef::new(snapshot, e));
                } else {
                    by_qos.entry(reasons).or_default().push(RemoteRef::new(snapshot, e));
                }
            } else if s.role == Role::Writer && e.role == Role::Writer && snapshot.participant(&e.participant).is_some()
            {
                // A writer whose participant is not known yet may be this process's own
                // (discovery can list an endpoint before its participant): not foreign yet.
                foreign.push(RemoteRef::new(snapshot, e));
            }
        }

        let mut findings = Vec::new();
        for (ty, refs) in by_type {
            let alt = s.alternatives.iter().find(|a| a.type_name == ty);
            let detail = format!(
                "{} {}(s) on {} use type {ty}; this process serves {}",
                refs.len(),
                role_word(want),
                s.topic,
                s.type_name
            );
            let fix = match alt {
                Some(a) => a.hint.clone(),
                None => format!(
                    "use type {} on {} in the client (or serve {ty} on this topic); the type names must be identical",
                    s.type_name, s.topic
                ),
            };
            findings.push(finding(
                FindingKind::TypeMismatch {
                    remote_type: ty.to_string(),
                },
                s,
                detail,
                fix,
                refs,
            ));
        }
        for (reasons, refs) in by_qos {
            let detail = format!(
                "{} {}(s) on {} cannot match: {}",
                refs.len(),
                role_word(want),
                s.topic,
                reasons.join("; ")
            );
            let fix = match s.role {
                Role::Reader => "make the client's writer offer at least what this reader requests (reliable, and the durability asked for), or relax the reader".to_string(),
                Role::Writer => format!(
                    "set the client's reader to request at most what this writer offers ({}, {} durability)",
                    reliability_word(s.qos.reliability),
                    durability_word(s.qos.durability)
                ),
            };
            findings.push(finding(FindingKind::QosMismatch { reasons }, s, detail, fix, refs));
        }
        if !foreign.is_empty() {
            let who: Vec<String> = foreign.iter().take(3).map(RemoteRef::who).collect();
            let detail = format!(
                "{} other writer(s) on {}, which this process writes too: {}",
                foreign.len(),
                s.topic,
                who.join(", ")
            );
            let fix = "two sources publish this topic for one device: stop the other one, or move one of them to another topic or domain".to_string();
            findings.push(finding(FindingKind::ForeignWriter, s, detail, fix, foreign));
        }

        // Near misses: counterpart-role remote endpoints on another topic that nothing
        // matches (no endpoint of the other role on that exact topic) and that is not ours.
        let mut near: BTreeMap<(String, String), Vec<RemoteRef>> = BTreeMap::new();
        for (e, _) in remote
            .iter()
            .zip(&answered)
            .filter(|(e, answered)| e.role == want && *e.topic != *s.topic && !**answered)
        {
            if served_topics.contains(&(&*e.topic, s.role)) {
                continue;
            }
            let reason = s
                .related_topics
                .iter()
                .find(|r| *r.topic == *e.topic)
                .map(|r| {
                    let tag = if r.on_demand { "on demand" } else { "related" };
                    format!("{tag}: {}", r.hint)
                })
                .or_else(|| near_miss_reason(&e.topic, &s.topic));
            if let Some(reason) = reason {
                near.entry((e.topic.to_string(), reason))
                    .or_default()
                    .push(RemoteRef::new(snapshot, e));
            }
        }
        for ((remote_topic, reason), refs) in near {
            if let Some(hint) = reason.strip_prefix("on demand: ") {
                let detail = format!(
                    "{} {}(s) on {remote_topic:?}, which this process serves once such a client is discovered",
                    refs.len(),
                    role_word(want),
                );
                findings.push(finding(
                    FindingKind::ServedOnDemand { remote_topic },
                    s,
                    detail,
                    hint.to_string(),
                    refs,
                ));
                continue;
            }
            let (detail, fix) = match reason.strip_prefix("related: ") {
                Some(hint) => (
                    format!(
                        "{} {}(s) on {remote_topic:?}, which this process does not serve (it serves {:?})",
                        refs.len(),
                        role_word(want),
                        s.topic
                    ),
                    hint.to_string(),
                ),
                None => (
                    format!(
                        "{} {}(s) on {remote_topic:?} ({reason}); this process serves {:?}",
                        refs.len(),
                        role_word(want),
                        s.topic
                    ),
                    format!("correct the topic name in the client to {:?}", s.topic),
                ),
            };
            findings.push(finding(
                FindingKind::NearMissTopic { remote_topic, reason },
                s,
                detail,
                fix,
                refs,
            ));
        }

        let explained = findings.iter().any(|f| {
            matches!(
                f.kind,
                FindingKind::TypeMismatch { .. }
                    | FindingKind::QosMismatch { .. }
                    | FindingKind::NearMissTopic { .. }
                    | FindingKind::ServedOnDemand { .. }
            )
        });
        if matched.is_empty() && !explained {
            let detail = format!(
                "no remote {} on {} (domain {})",
                role_word(want),
                s.topic,
                snapshot.domain_id
            );
            let fix = format!(
                "start the client on domain {} with topic {:?}; if it runs, check that both sides use the same network interface",
                snapshot.domain_id, s.topic
            );
            findings.push(finding(FindingKind::NoCounterpart, s, detail, fix, Vec::new()));
        }
        topics.push(TopicReport {
            topic: s.topic.clone(),
            role: s.role,
            matched,
            findings,
        });
    }
    Report {
        domain_id: snapshot.domain_id,
        topics,
    }
}

/// Whether a snapshot endpoint belongs to this process (for callers filtering by hand).
pub fn is_local(e: &Endpoint) -> bool {
    e.origin != Origin::Remote
}

#[cfg(test)]
mod tests {
    use super::super::{Counters, Participant};
    use super::*;

    const HG_CMD: &str = "unitree_hg::msg::dds_::HandCmd_";
    const GO_CMDS: &str = "unitree_go::msg::dds_::MotorCmds_";
    const GO_STATES: &str = "unitree_go::msg::dds_::MotorStates_";

    struct Builder {
        snap: Snapshot,
        next: u8,
    }

    impl Builder {
        fn new() -> Self {
            Self {
                snap: Snapshot {
                    generation: 1,
                    domain_id: 7,
                    this_participant: Guid([0xee; 16]).participant(),
                    participants: Vec::new(),
                    endpoints: Vec::new(),
                    counters: Counters::default(),
                    changed_at: None,
                },
                next: 1,
            }
        }

        /// Adds an endpoint in a new participant of `origin`.
        fn ep(mut self, origin: Origin, role: Role, topic: &str, ty: &str, qos: EndpointQos) -> Self {
            let n = self.next;
            self.next += 1;
            let pkey = Guid([n; 16]).participant();
            self.snap.participants.push(Participant {
                key: pkey,
                hostname: Some(Arc::from("pc2")),
                pid: Some(1000 + u32::from(n)),
                process_name: Some(Arc::from("python3")),
                network_addresses: vec![
                    Arc::from("udp/239.255.0.1:7400@3"),
                    Arc::from("udp/192.168.123.99:7410@3"),
                ],
                origin,
            });
            self.snap.participants.sort_by_key(|a| a.key);
            let mut key = [n; 16];
            key[15] = 0x03;
            self.snap.endpoints.push(Endpoint {
                key: Guid(key),
                participant: pkey,
                role,
                topic: Arc::from(topic),
                type_name: Arc::from(ty),
                qos,
                origin,
            });
            self
        }

        fn remote(self, role: Role, topic: &str, ty: &str) -> Self {
            self.ep(Origin::Remote, role, topic, ty, sdk_qos(role))
        }
    }

    /// What the SDK's ChannelPublisher/Subscriber use (CycloneDDS defaults).
    fn sdk_qos(role: Role) -> EndpointQos {
        EndpointQos {
            reliability: Some(match role {
                Role::Writer => Reliability::Reliable,
                Role::Reader => Reliability::BestEffort,
            }),
            durability: Some(Durability::Volatile),
            history: Some(History::KeepLast(1)),
        }
    }

    fn served(topic: &str, ty: &str, role: Role) -> Served {
        Served {
            topic: topic.into(),
            type_name: ty.into(),
            role,
            qos: ServedQos {
                reliability: Reliability::Reliable,
                durability: Durability::Volatile,
                history: History::KeepLast(10),
            },
            alternatives: Vec::new(),
            related_topics: Vec::new(),
            also: Vec::new(),
            entries: None,
            sample_check: None,
        }
    }

    fn kinds(r: &Report) -> Vec<&FindingKind> {
        r.findings().map(|f| &f.kind).collect()
    }

    #[test]
    fn matched_counterpart_no_findings() {
        let b = Builder::new().remote(Role::Writer, "rt/dex1/left/cmd", GO_CMDS);
        let r = diagnose(&b.snap, &[served("rt/dex1/left/cmd", GO_CMDS, Role::Reader)]);
        assert_eq!(r.topics[0].matched.len(), 1);
        assert!(kinds(&r).is_empty(), "{r:?}");
        let m = &r.topics[0].matched[0];
        assert_eq!(m.address.as_deref(), Some("192.168.123.99"), "multicast group skipped");
        assert!(m.who().contains("python3 (pid 1001) on pc2"));
    }

    #[test]
    fn no_counterpart_when_empty_and_local_ignored() {
        let b = Builder::new().ep(
            Origin::ThisProcess,
            Role::Writer,
            "rt/dex1/left/cmd",
            GO_CMDS,
            sdk_qos(Role::Writer),
        );
        let r = diagnose(&b.snap, &[served("rt/dex1/left/cmd", GO_CMDS, Role::Reader)]);
        assert!(r.topics[0].matched.is_empty());
        assert_eq!(kinds(&r), vec![&FindingKind::NoCounterpart]);
        let f = r.findings().next().unwrap();
        assert!(f.fix.contains("domain 7"), "{}", f.fix);
    }

    #[test]
    fn type_mismatch_generic_and_with_caller_hint() {
        let b = Builder::new().remote(Role::Writer, "rt/dex1/left/cmd", HG_CMD);
        let s = served("rt/dex1/left/cmd", GO_CMDS, Role::Reader);
        let r = diagnose(&b.snap, std::slice::from_ref(&s));
        let f = r.findings().next().unwrap();
        assert_eq!(
            f.kind,
            FindingKind::TypeMismatch {
                remote_type: HG_CMD.into()
            }
        );
        assert!(f.detail.contains(HG_CMD) && f.detail.contains(GO_CMDS), "{}", f.detail);
        assert!(f.fix.contains(GO_CMDS), "{}", f.fix);
        assert_eq!(r.findings().count(), 1, "a type mismatch explains the silence");

        let mut s = s;
        s.alternatives.push(Alternative {
            type_name: HG_CMD.into(),
            hint: "the client speaks the seed-spec variant: set variant = \"hg\"".into(),
        });
        let r = diagnose(&b.snap, &[s]);
        assert!(r.findings().next().unwrap().fix.contains("variant = \"hg\""));
    }

    #[test]
    fn qos_mismatch_reliable_reader_vs_best_effort_writer() {
        let be_writer = EndpointQos {
            reliability: Some(Reliability::BestEffort),
            ..sdk_qos(Role::Writer)
        };
        let b = Builder::new().ep(Origin::Remote, Role::Writer, "rt/x/cmd", GO_CMDS, be_writer);
        let r = diagnose(&b.snap, &[served("rt/x/cmd", GO_CMDS, Role::Reader)]);
        let f = r.findings().next().unwrap();
        match &f.kind {
            FindingKind::QosMismatch { reasons } => {
                assert_eq!(
                    reasons,
                    &vec!["the writer is best-effort and the reader requires reliable".to_string()]
                )
            }
            k => panic!("{k:?}"),
        }
        assert!(r.topics[0].matched.is_empty());
    }

    #[test]
    fn qos_mismatch_durability_request_above_offer() {
        let tl_reader = EndpointQos {
            durability: Some(Durability::TransientLocal),
            ..sdk_qos(Role::Reader)
        };
        let b = Builder::new().ep(Origin::Remote, Role::Reader, "rt/x/state", GO_STATES, tl_reader);
        let r = diagnose(&b.snap, &[served("rt/x/state", GO_STATES, Role::Writer)]);
        let f = r.findings().next().unwrap();
        assert!(matches!(&f.kind, FindingKind::QosMismatch { reasons } if reasons[0].contains("transient-local")));
        assert!(f.fix.contains("volatile"), "{}", f.fix);
    }

    #[test]
    fn best_effort_reader_matches_reliable_writer_and_missing_qos_uses_defaults() {
        let b = Builder::new().remote(Role::Reader, "rt/x/state", GO_STATES).ep(
            Origin::Remote,
            Role::Reader,
            "rt/x/state",
            GO_STATES,
            EndpointQos::default(),
        );
        let r = diagnose(&b.snap, &[served("rt/x/state", GO_STATES, Role::Writer)]);
        assert_eq!(r.topics[0].matched.len(), 2);
        assert!(kinds(&r).is_empty());
    }

    #[test]
    fn qos_rule_table() {
        let q = |r, d| ServedQos {
            reliability: r,
            durability: d,
            history: History::KeepAll,
        };
        use Durability::*;
        use Reliability::*;
        assert!(qos_incompatibilities(&q(Reliable, Volatile), &q(BestEffort, Volatile)).is_empty());
        assert!(qos_incompatibilities(&q(Reliable, TransientLocal), &q(Reliable, Volatile)).is_empty());
        assert_eq!(
            qos_incompatibilities(&q(BestEffort, Volatile), &q(Reliable, Persistent)).len(),
            2
        );
    }

    #[test]
    fn near_miss_cases() {
        assert_eq!(
            near_miss_reason("rt/dex1/left/cmd ", "rt/dex1/left/cmd").unwrap(),
            "surrounding whitespace in the topic name"
        );
        assert_eq!(
            near_miss_reason("dex1/left/cmd", "rt/dex1/left/cmd").unwrap(),
            "missing the rt/ prefix"
        );
        assert_eq!(near_miss_reason("rt/rt/a", "rt/a").unwrap(), "an extra rt/ prefix");
        assert_eq!(
            near_miss_reason("rt/Dex1/left/cmd", "rt/dex1/left/cmd").unwrap(),
            "different letter case"
        );
        assert_eq!(
            near_miss_reason("rt/dex1/lef/cmd", "rt/dex1/left/cmd").unwrap(),
            "1 character different"
        );
        assert_eq!(near_miss_reason("rt/dex1/left/cmd", "rt/dex1/left/cmd"), None);
        assert_eq!(near_miss_reason("rt/dex1/left/state", "rt/dex1/left/cmd"), None);
    }

    #[test]
    fn edit_distance_banded_matches_plain() {
        fn plain(a: &[u8], b: &[u8]) -> usize {
            let mut d: Vec<usize> = (0..=b.len()).collect();
            for i in 1..=a.len() {
                let mut prev = d[0];
                d[0] = i;
                for j in 1..=b.len() {
                    let t = d[j];
                    d[j] = (prev + usize::from(a[i - 1] != b[j - 1]))
                        .min(d[j] + 1)
                        .min(d[j - 1] + 1);
                    prev = t;
                }
            }
            d[b.len()]
        }
        let words = [
            "",
            "a",
            "ab",
            "rt/a",
            "rt/b",
            "rt/ab",
            "tr/a",
            "rt/dex1/left/cmd",
            "rt/dex1/lfet/cmd",
            "rt/dex3/left/cmd",
            "xyz",
        ];
        for a in words {
            for b in words {
                for k in 0..4 {
                    let want = plain(a.as_bytes(), b.as_bytes());
                    let got = edit_distance_within(a, b, k);
                    assert_eq!(got, (want <= k).then_some(want), "{a:?} {b:?} k={k}");
                }
            }
        }
        // Long inputs stay cheap and bounded.
        let long = "x".repeat(10_000);
        assert_eq!(edit_distance_within(&long, &long, 2), Some(0));
        assert_eq!(edit_distance_within(&long, "x", 2), None);
    }

    #[test]
    fn near_miss_findings_only_for_unanswered_topics() {
        let b = Builder::new()
            .remote(Role::Writer, "dex1/left/cmd", GO_CMDS) // missing rt/, nobody reads it
            .remote(Role::Writer, "rt/dex1/left/cmd ", GO_CMDS) // trailing space
            .remote(Role::Writer, "rt/dex3/left/cmd", HG_CMD) // 1 char off but answered:
            .remote(Role::Reader, "rt/dex3/left/cmd", HG_CMD); // someone serves it
        let r = diagnose(&b.snap, &[served("rt/dex1/left/cmd", GO_CMDS, Role::Reader)]);
        let near: Vec<(&str, &str)> = r
            .findings()
            .filter_map(|f| match &f.kind {
                FindingKind::NearMissTopic { remote_topic, reason } => Some((remote_topic.as_str(), reason.as_str())),
                _ => None,
            })
            .collect();
        assert_eq!(
            near,
            vec![
                ("dex1/left/cmd", "missing the rt/ prefix"),
                ("rt/dex1/left/cmd ", "surrounding whitespace in the topic name")
            ]
        );
        assert!(r.findings().all(|f| f.fix.contains("\"rt/dex1/left/cmd\"")));
        assert!(
            !kinds(&r).contains(&&FindingKind::NoCounterpart),
            "a near miss explains it"
        );
    }

    #[test]
    fn related_topic_from_caller_data() {
        let b = Builder::new().remote(Role::Writer, "rt/unitree_actuator/cmd", GO_CMDS);
        let mut s = served("rt/dex1/left/cmd", GO_CMDS, Role::Reader);
        s.related_topics.push(RelatedTopic {
            topic: "rt/unitree_actuator/cmd".into(),
            hint: "the client speaks the legacy actuator interface: serve the actuator variant".into(),
            on_demand: false,
        });
        let r = diagnose(&b.snap, &[s]);
        let f = r.findings().next().unwrap();
        assert!(
            matches!(&f.kind, FindingKind::NearMissTopic { remote_topic, .. } if remote_topic == "rt/unitree_actuator/cmd")
        );
        assert!(f.fix.contains("legacy actuator"), "{}", f.fix);
    }

    #[test]
    fn a_client_on_a_topic_served_on_demand_is_a_note_that_explains_no_counterpart() {
        let b = Builder::new().remote(Role::Writer, "rt/unitree_actuator/cmd", GO_CMDS);
        let s = served("rt/dex1/left/cmd", GO_CMDS, Role::Reader).related_on_demand(
            "rt/unitree_actuator/cmd",
            "the auto front serves the pair once discovered",
        );
        let r = diagnose(&b.snap, &[s]);
        let all: Vec<_> = r.findings().collect();
        assert_eq!(all.len(), 1, "{all:?}");
        assert!(
            matches!(&all[0].kind, FindingKind::ServedOnDemand { remote_topic } if remote_topic == "rt/unitree_actuator/cmd"),
            "{all:?}"
        );
        assert_eq!(all[0].fix, "the auto front serves the pair once discovered");
        assert_eq!(all[0].remote_count, 1);
    }

    #[test]
    fn served_topics_are_not_near_misses_of_each_other() {
        let b = Builder::new().remote(Role::Writer, "rt/dex3/left/cmd", HG_CMD);
        let r = diagnose(
            &b.snap,
            &[
                served("rt/dex1/left/cmd", GO_CMDS, Role::Reader),
                served("rt/dex3/left/cmd", HG_CMD, Role::Reader),
            ],
        );
        assert_eq!(r.topics[1].matched.len(), 1);
        assert_eq!(kinds(&r), vec![&FindingKind::NoCounterpart], "only dex1 lacks a client");
    }

    #[test]
    fn foreign_writer_on_a_topic_we_write() {
        let b = Builder::new()
            .remote(Role::Writer, "rt/dex1/left/state", GO_STATES)
            .remote(Role::Reader, "rt/dex1/left/state", GO_STATES)
            .ep(
                Origin::ThisProcess,
                Role::Writer,
                "rt/dex1/left/state",
                GO_STATES,
                sdk_qos(Role::Writer),
            );
        let r = diagnose(&b.snap, &[served("rt/dex1/left/state", GO_STATES, Role::Writer)]);
        assert_eq!(kinds(&r), vec![&FindingKind::ForeignWriter]);
        let f = r.findings().next().unwrap();
        assert_eq!(f.remote_count, 1, "our own writer is not foreign");
        assert!(f.detail.contains("pid 1001"), "{}", f.detail);
        assert!(f.fix.contains("two sources"));
        assert_eq!(r.topics[0].matched.len(), 1);
    }

    #[test]
    fn no_foreign_writer_before_its_participant_is_known() {
        let mut b = Builder::new().remote(Role::Writer, "rt/dex1/left/state", GO_STATES);
        // Discovery listed the endpoint but not (yet) its participant.
        b.snap.participants.clear();
        let r = diagnose(&b.snap, &[served("rt/dex1/left/state", GO_STATES, Role::Writer)]);
        assert!(!kinds(&r).contains(&&FindingKind::ForeignWriter), "{:?}", kinds(&r));
    }

    #[test]
    fn remotes_per_finding_are_capped_but_counted() {
        let mut b = Builder::new();
        for _ in 0..20 {
            b = b.remote(Role::Writer, "rt/a", "other::T_");
        }
        let r = diagnose(&b.snap, &[served("rt/a", "t::T_", Role::Reader)]);
        let f = r.findings().next().unwrap();
        assert_eq!((f.remotes.len(), f.remote_count), (MAX_REMOTES_PER_FINDING, 20));
    }
}
