//! Discovery diagnostics for the running gateway (issue #14): what every front and DDS-client
//! device of a plan serves on DDS ([`served`]), asked of their kinds; the diagnosis of a
//! discovery snapshot against it ([`diagnose_all`]); the task that watches discovery, logs
//! each finding once per change and hands the latest [`Diagnosis`] to the status publisher
//! ([`spawn`]); the start-up check for foreign state writers ([`foreign_state_writers`]).
//! docs/discovery.md.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use handgate_adapters::discovery::diagnose::{diagnose, Finding, FindingKind, RemoteRef, Served};
use handgate_adapters::discovery::{Role, Snapshot};
use tokio::sync::watch;

use crate::plan::Plan;

/// Who serves an endpoint: a front or a device, by its name in the plan.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Owner {
    Front(String),
    Device(String),
}

impl Owner {
    /// The owner's name in the plan.
    pub fn name(&self) -> &str {
        match self {
            Owner::Front(n) | Owner::Device(n) => n,
        }
    }

    /// `front NAME` / `device NAME`.
    pub fn describe(&self) -> String {
        match self {
            Owner::Front(n) => format!("front {n}"),
            Owner::Device(n) => format!("device {n}"),
        }
    }
}

impl std::fmt::Display for Owner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}

/// One endpoint the gateway serves, and who serves it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServedBy {
    pub owner: Owner,
    pub served: Served,
}

/// Everything `plan` serves on DDS: each front's endpoints (its kind's
/// [`handgate_adapters::front::kind::Front::served`]), then each device's as a client
/// of a robot service ([`handgate_adapters::kind::KindFactory::served`]; none for devices that
/// reach their hardware without DDS). Plan order.
pub fn served(plan: &Plan) -> Vec<ServedBy> {
    let fronts = plan.fronts.iter().flat_map(|f| {
        f.served().into_iter().map(|served| ServedBy {
            owner: Owner::Front(f.name.clone()),
            served,
        })
    });
    let devices = plan.devices.iter().flat_map(|d| {
        d.kind.factory().served(&d.spec()).into_iter().map(|served| ServedBy {
            owner: Owner::Device(d.name.clone()),
            served,
        })
    });
    fronts.chain(devices).collect()
}

/// Counterparts listed by name per endpoint (the rest only counted).
pub const MAX_WHO: usize = 8;

/// One served endpoint and the counterparts that match it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EndpointDiagnosis {
    pub owner: Owner,
    pub topic: String,
    pub role: Role,
    /// How many counterparts match (type and QoS).
    pub matched: usize,
    /// The first [`MAX_WHO`] of them ([`RemoteRef::who`]; `this process (...)` for a
    /// device's in-process peer).
    pub who: Vec<String>,
}

/// A finding about an endpoint of `owner`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OwnedFinding {
    pub owner: Owner,
    pub finding: Finding,
}

impl OwnedFinding {
    /// What identifies the finding across snapshots (not its wording, whose counts change).
    pub fn key(&self) -> String {
        format!(
            "{}|{}|{:?}|{:?}",
            self.owner, self.finding.served_topic, self.finding.served_role, self.finding.kind
        )
    }
}

/// The status topic's spelling of a finding kind.
pub fn kind_str(k: &FindingKind) -> &'static str {
    match k {
        FindingKind::NoCounterpart => "no_counterpart",
        FindingKind::TypeMismatch { .. } => "type_mismatch",
        FindingKind::QosMismatch { .. } => "qos_mismatch",
        FindingKind::NearMissTopic { .. } => "near_miss_topic",
        FindingKind::ForeignWriter => "foreign_writer",
        FindingKind::ServedOnDemand { .. } => "served_on_demand",
    }
}

/// `problem` or `note` (a finding that is no fault: a client a front serves on demand), for
/// a finding kind as [`kind_str`] names it.
pub fn severity(kind: &str) -> &'static str {
    if kind == "served_on_demand" {
        "note"
    } else {
        "problem"
    }
}

/// What the gateway reports about discovery: per served endpoint its counterparts, and the
/// findings with their fixes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Diagnosis {
    /// Snapshot generation this was computed from.
    pub generation: u64,
    pub endpoints: Vec<EndpointDiagnosis>,
    pub findings: Vec<OwnedFinding>,
}

fn role_str(r: Role) -> &'static str {
    match r {
        Role::Reader => "reader",
        Role::Writer => "writer",
    }
}

/// `who` of a counterpart; a participant of this process (a device's in-process service
/// peer) says so.
fn who(s: &Snapshot, r: &RemoteRef) -> String {
    let local =
        r.participant == s.this_participant || s.participant(&r.participant).is_some_and(|p| p.origin.is_local());
    if local {
        format!("this process ({})", r.who())
    } else {
        r.who()
    }
}

/// Diagnoses `snapshot` against everything served.
///
/// - Fronts: only other processes' endpoints count ([`diagnose`]). A front nobody talks to
///   is no finding (its endpoint shows 0 matched); what is reported is why a client that is
///   there does not match (type, QoS, near-miss topic) and another writer of its state.
/// - Devices (clients of a robot service): endpoints of this process of the counterpart role
///   on the device's own topics count too: on the emulator backend the service's emulator
///   runs in-process (on the gateway's participant) and is the device's real peer. A device
///   without any counterpart is reported (`no_counterpart`: no service).
pub fn diagnose_all(snapshot: &Snapshot, served: &[ServedBy]) -> Diagnosis {
    let (fronts, devices): (Vec<&ServedBy>, Vec<&ServedBy>) =
        served.iter().partition(|s| matches!(s.owner, Owner::Front(_)));
    let mut out = Diagnosis {
        generation: snapshot.generation,
        ..Default::default()
    };
    // Devices see their in-process peers as counterparts.
    let counterparts: BTreeSet<(&str, Role)> = devices
        .iter()
        .map(|s| (s.served.topic.as_str(), s.served.role.counterpart()))
        .collect();
    let device_view;
    let views: [(&[&ServedBy], &Snapshot); 2] = [
        (&fronts, snapshot),
        (&devices, {
            let mut v = snapshot.clone();
            for e in v.endpoints.iter_mut() {
                if e.origin.is_local() && counterparts.contains(&(&*e.topic, e.role)) {
                    e.origin = handgate_adapters::discovery::Origin::Remote;
                }
            }
            device_view = v;
            &device_view
        }),
    ];
    for (group, snap) in views {
        if group.is_empty() {
            continue;
        }
        let list: Vec<Served> = group.iter().map(|s| s.served.clone()).collect();
        let report = diagnose(snap, &list);
        for (by, t) in group.iter().zip(report.topics) {
            out.endpoints.push(EndpointDiagnosis {
                owner: by.owner.clone(),
                topic: t.topic,
                role: t.role,
                matched: t.matched.len(),
                who: t.matched.iter().take(MAX_WHO).map(|r| who(snapshot, r)).collect(),
            });
            for finding in t.findings {
                if matches!(by.owner, Owner::Front(_)) && finding.kind == FindingKind::NoCounterpart {
                    continue;
                }
                out.findings.push(OwnedFinding {
                    owner: by.owner.clone(),
                    finding,
                });
            }
        }
    }
    out
}

/// The status topic's view of `d`.
pub fn to_status(
    d: &Diagnosis,
) -> (
    Vec<handgate_idl::handgate::EndpointStatus_>,
    Vec<handgate_idl::handgate::Diagnostic_>,
) {
    use handgate_idl::handgate as hg;
    let endpoints = d
        .endpoints
        .iter()
        .map(|e| hg::EndpointStatus_ {
            owner: e.owner.describe(),
            topic: e.topic.clone(),
            role: role_str(e.role).into(),
            matched: u32::try_from(e.matched).unwrap_or(u32::MAX),
            who: e.who.clone(),
        })
        .collect();
    let diagnostics = d
        .findings
        .iter()
        .map(|f| hg::Diagnostic_ {
            owner: f.owner.describe(),
            topic: f.finding.served_topic.clone(),
            kind: kind_str(&f.finding.kind).into(),
            detail: f.finding.detail.clone(),
            fix: f.finding.fix.clone(),
        })
        .collect();
    (endpoints, diagnostics)
}

/// Logs what changed from `prev` to `next`: each finding when it appears (warning, with its
/// fix) and when it goes away; each endpoint's matched counterparts when they change.
pub fn log_changes(prev: &Diagnosis, next: &Diagnosis) {
    let before: BTreeMap<String, &OwnedFinding> = prev.findings.iter().map(|f| (f.key(), f)).collect();
    let after: BTreeMap<String, &OwnedFinding> = next.findings.iter().map(|f| (f.key(), f)).collect();
    for (k, f) in &after {
        if before.contains_key(k) {
            continue;
        }
        if matches!(f.finding.kind, FindingKind::ServedOnDemand { .. }) {
            // Not a problem: the front opens those topics for the client.
            tracing::info!(
                owner = %f.owner,
                topic = %f.finding.served_topic,
                kind = kind_str(&f.finding.kind),
                "discovery: {}: {}",
                f.finding.detail,
                f.finding.fix
            );
        } else {
            tracing::warn!(
                owner = %f.owner,
                topic = %f.finding.served_topic,
                kind = kind_str(&f.finding.kind),
                fix = %f.finding.fix,
                "discovery: {}",
                f.finding.detail
            );
        }
    }
    for (k, f) in &before {
        if !after.contains_key(k) {
            tracing::info!(
                owner = %f.owner,
                topic = %f.finding.served_topic,
                kind = kind_str(&f.finding.kind),
                "discovery: resolved: {}",
                f.finding.detail
            );
        }
    }
    let was: BTreeMap<(&Owner, &str, Role), &EndpointDiagnosis> = prev
        .endpoints
        .iter()
        .map(|e| ((&e.owner, e.topic.as_str(), e.role), e))
        .collect();
    for e in &next.endpoints {
        let old = was.get(&(&e.owner, e.topic.as_str(), e.role));
        let changed = old.map_or(e.matched > 0, |o| o.matched != e.matched || o.who != e.who);
        if changed {
            tracing::info!(
                owner = %e.owner,
                topic = %e.topic,
                role = role_str(e.role),
                matched = e.matched,
                "discovery: {} {} matched: {}",
                role_str(e.role),
                e.topic,
                if e.who.is_empty() { "none".to_string() } else { e.who.join(", ") }
            );
        }
    }
}

/// Least time between two diagnoses: snapshots arriving faster are coalesced (the latest
/// wins), so a busy domain costs at most one diagnosis per interval.
pub const MIN_DIAGNOSIS_INTERVAL: std::time::Duration = std::time::Duration::from_millis(100);

/// Starts the diagnostics task (a tokio task that computes on the blocking pool, never on a
/// device path or a front's worker): on every new discovery snapshot of a side (at most one
/// per [`MIN_DIAGNOSIS_INTERVAL`]), diagnoses what that side serves, logs the changes and
/// publishes the sides' diagnoses as one on the returned channel (read by the status
/// publisher). One side, or with `[export]` two: the fronts' on the clients' domain, the
/// devices' on the robot's. Ends on `shutdown`.
pub fn spawn(
    sides: Vec<Side>,
    mut shutdown: watch::Receiver<bool>,
) -> (tokio::task::JoinHandle<()>, watch::Receiver<Arc<Diagnosis>>) {
    let mut served = Vec::new();
    let mut snapshots = Vec::new();
    for (s, r) in sides {
        served.push(Arc::new(s));
        snapshots.push(r);
    }
    let mut each: Vec<Diagnosis> = served
        .iter()
        .zip(snapshots.iter_mut())
        .map(|(s, r)| diagnose_all(&r.borrow_and_update(), s))
        .collect();
    let first = Arc::new(merged(&each));
    log_changes(&Diagnosis::default(), &first);
    let (tx, rx) = watch::channel(first);
    let task = tokio::spawn(async move {
        loop {
            // The first side whose discovery changed.
            let changed = futures_select_changed(&mut snapshots);
            let i = tokio::select! {
                r = changed => match r {
                    Some(i) => i,
                    None => break,
                },
                _ = shutdown.changed() => break,
            };
            let snap = snapshots[i].borrow_and_update().clone();
            let s = Arc::clone(&served[i]);
            let Ok(next) = tokio::task::spawn_blocking(move || diagnose_all(&snap, &s)).await else {
                break;
            };
            each[i] = next;
            let next = merged(&each);
            let prev = tx.borrow().clone();
            if next.endpoints != prev.endpoints || next.findings != prev.findings {
                log_changes(&prev, &next);
                let _ = tx.send(Arc::new(next));
            }
            tokio::select! {
                _ = tokio::time::sleep(MIN_DIAGNOSIS_INTERVAL) => {}
                _ = shutdown.changed() => break,
            }
        }
    });
    (task, rx)
}

/// Waits until one of `rx` changes; its index, or `None` once every sender is gone.
async fn futures_select_changed(rx: &mut [watch::Receiver<Arc<Snapshot>>]) -> Option<usize> {
    let mut live: Vec<(usize, &mut watch::Receiver<Arc<Snapshot>>)> = rx.iter_mut().enumerate().collect();
    loop {
        if live.is_empty() {
            return None;
        }
        let futs = live.iter_mut().map(|(i, r)| {
            let i = *i;
            Box::pin(async move { (i, r.changed().await.is_ok()) })
        });
        let ((i, ok), _, _) = futures_util::future::select_all(futs).await;
        if ok {
            return Some(i);
        }
        live.retain(|(j, _)| *j != i);
    }
}

/// The diagnoses of each side as one: endpoints and findings in side order, the generation
/// the sum of the sides' (it changes whenever one does).
fn merged(each: &[Diagnosis]) -> Diagnosis {
    Diagnosis {
        generation: each.iter().map(|d| d.generation).sum(),
        endpoints: each.iter().flat_map(|d| d.endpoints.iter().cloned()).collect(),
        findings: each.iter().flat_map(|d| d.findings.iter().cloned()).collect(),
    }
}

/// One DDS side of the gateway: what it serves there, and that side's discovery.
pub type Side = (Vec<ServedBy>, watch::Receiver<Arc<Snapshot>>);

/// Another process's writer on a state topic a front writes: (front, topic, the finding).
pub fn foreign_state_writers(snapshot: &Snapshot, served: &[ServedBy]) -> Vec<OwnedFinding> {
    let fronts: Vec<ServedBy> = served
        .iter()
        .filter(|s| matches!(s.owner, Owner::Front(_)) && s.served.role == Role::Writer)
        .cloned()
        .collect();
    diagnose_all(snapshot, &fronts)
        .findings
        .into_iter()
        .filter(|f| f.finding.kind == FindingKind::ForeignWriter)
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use handgate_adapters::dex1::serve::Dex1Front;
    use handgate_adapters::discovery::Role;
    use handgate_adapters::front::kind::FrontOwn;
    use handgate_idl::{handgate, inspire, ros2, unitree_go, unitree_hg, DdsTypeName};

    fn sim_all() -> Plan {
        let loaded = crate::profile::load(&crate::profile::LoadOptions {
            profile: Some(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../profiles/sim-all.toml")
                    .display()
                    .to_string(),
            ),
            overrides: Default::default(),
            env: crate::profile::EnvLayer::Ignore,
            search_dirs: Some(vec![]),
        })
        .expect("sim-all loads");
        crate::resolve::plan(&loaded.profile).expect("sim-all resolves")
    }

    /// (topic, type, role) of what `owner` serves.
    fn of(all: &[ServedBy], owner: &Owner) -> Vec<(String, String, Role)> {
        all.iter()
            .filter(|s| &s.owner == owner)
            .map(|s| (s.served.topic.clone(), s.served.type_name.clone(), s.served.role))
            .collect()
    }

    fn t<T: DdsTypeName>() -> String {
        T::DDS_TYPE_NAME.to_string()
    }

    /// Hand-built discovery snapshots (also for the doctor's tests).
    pub(crate) mod snapshots {
        use std::sync::Arc;

        use handgate_adapters::discovery::{
            Counters, Endpoint, EndpointQos, Guid, Origin, Participant, Role, Snapshot,
        };

        /// A snapshot whose participant 1 is ours; `eps`: (participant, origin, role, topic, type).
        pub fn snap(eps: &[(u8, Origin, Role, &str, &str)]) -> Snapshot {
            let mut participants: Vec<Participant> = Vec::new();
            let mut endpoints = Vec::new();
            for (i, (p, origin, role, topic, ty)) in eps.iter().enumerate() {
                let key = Guid([*p; 16]).participant();
                if !participants.iter().any(|x| x.key == key) {
                    participants.push(Participant {
                        key,
                        hostname: Some(Arc::from("vm")),
                        pid: Some(100 + u32::from(*p)),
                        process_name: Some(Arc::from(if *p == 1 { "handgate" } else { "python" })),
                        network_addresses: vec![],
                        origin: *origin,
                    });
                }
                let mut g = [*p; 16];
                g[12] = i as u8 + 1;
                g[15] = 0x03;
                endpoints.push(Endpoint {
                    key: Guid(g),
                    participant: key,
                    role: *role,
                    topic: Arc::from(*topic),
                    type_name: Arc::from(*ty),
                    qos: EndpointQos::default(),
                    origin: *origin,
                });
            }
            participants.sort_by_key(|p| p.key);
            Snapshot {
                generation: 1,
                domain_id: 9,
                this_participant: Guid([1; 16]).participant(),
                participants,
                endpoints,
                counters: Counters::default(),
                changed_at: None,
            }
        }
    }

    fn served_by(owner: Owner, topic: &str, ty: &str, role: Role) -> ServedBy {
        ServedBy {
            owner,
            served: Served::new(
                topic,
                ty.to_string(),
                role,
                handgate_adapters::dds::Qos::Reliable { depth: 1 }.served(),
            ),
        }
    }

    #[test]
    fn a_device_counts_its_in_process_peer_and_a_front_only_other_processes() {
        use handgate_adapters::discovery::Origin::*;
        let s = snapshots::snap(&[
            // The device's writer and its in-process emulator's reader, on our participant.
            (1, ThisParticipant, Role::Writer, "rt/handgate/emu/d/cmd", "go::Cmds_"),
            (1, ThisParticipant, Role::Reader, "rt/handgate/emu/d/cmd", "go::Cmds_"),
            // The front's reader; its client in another process.
            (1, ThisParticipant, Role::Reader, "rt/f/cmd", "go::Cmds_"),
            (2, Remote, Role::Writer, "rt/f/cmd", "go::Cmds_"),
        ]);
        let served = vec![
            served_by(Owner::Front("f".into()), "rt/f/cmd", "go::Cmds_", Role::Reader),
            served_by(Owner::Front("f".into()), "rt/f/state", "go::States_", Role::Writer),
            served_by(
                Owner::Device("d".into()),
                "rt/handgate/emu/d/cmd",
                "go::Cmds_",
                Role::Writer,
            ),
            served_by(Owner::Device("d2".into()), "rt/x/cmd", "go::Cmds_", Role::Writer),
        ];
        let d = diagnose_all(&s, &served);
        let ep = |o: &Owner, t: &str| d.endpoints.iter().find(|e| &e.owner == o && e.topic == t).unwrap();
        let f_cmd = ep(&Owner::Front("f".into()), "rt/f/cmd");
        assert_eq!(f_cmd.matched, 1);
        assert!(f_cmd.who[0].starts_with("process python (pid 102)"), "{:?}", f_cmd.who);
        let dev = ep(&Owner::Device("d".into()), "rt/handgate/emu/d/cmd");
        assert_eq!(dev.matched, 1, "the in-process emulator is the device's peer");
        assert!(dev.who[0].starts_with("this process ("), "{:?}", dev.who);
        // A front with nobody on its state topic is no finding; a device with no service is.
        let kinds: Vec<(String, &str)> = d
            .findings
            .iter()
            .map(|f| (f.owner.describe(), kind_str(&f.finding.kind)))
            .collect();
        assert_eq!(kinds, vec![("device d2".to_string(), "no_counterpart")]);
        let (eps, diags) = to_status(&d);
        assert_eq!(eps.len(), 4);
        assert_eq!(diags[0].owner, "device d2");
        assert!(!diags[0].fix.is_empty());
    }

    #[test]
    fn findings_keep_their_key_when_their_counts_change() {
        use handgate_adapters::discovery::Origin::*;
        let served = vec![served_by(
            Owner::Front("f".into()),
            "rt/f/cmd",
            "go::Cmds_",
            Role::Reader,
        )];
        let one = snapshots::snap(&[(2, Remote, Role::Writer, "rt/f/cmd", "hg::HandCmd_")]);
        let two = snapshots::snap(&[
            (2, Remote, Role::Writer, "rt/f/cmd", "hg::HandCmd_"),
            (3, Remote, Role::Writer, "rt/f/cmd", "hg::HandCmd_"),
        ]);
        let (a, b) = (diagnose_all(&one, &served), diagnose_all(&two, &served));
        assert_eq!(kind_str(&a.findings[0].finding.kind), "type_mismatch");
        assert_ne!(a.findings[0].finding.detail, b.findings[0].finding.detail);
        assert_eq!(a.findings[0].key(), b.findings[0].key(), "logged once, not per count");
    }

    #[test]
    fn foreign_state_writers_are_other_processes_writing_a_front_state_topic() {
        use handgate_adapters::discovery::Origin::*;
        let served = vec![
            served_by(Owner::Front("f".into()), "rt/f/state", "go::States_", Role::Writer),
            served_by(Owner::Device("d".into()), "rt/svc/cmd", "go::Cmds_", Role::Writer),
        ];
        let s = snapshots::snap(&[
            (2, Remote, Role::Writer, "rt/f/state", "go::States_"),
            (3, Remote, Role::Writer, "rt/svc/cmd", "go::Cmds_"),
        ]);
        let found = foreign_state_writers(&s, &served);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].owner, Owner::Front("f".into()));
        assert!(found[0].finding.remotes[0].who().contains("pid 102"));
        // Our own writer (another participant of this process) is not foreign.
        let s = snapshots::snap(&[(2, ThisProcess, Role::Writer, "rt/f/state", "go::States_")]);
        assert!(foreign_state_writers(&s, &served).is_empty());
    }

    #[test]
    fn every_front_of_sim_all_serves_its_topics_with_the_idl_type_names() {
        let plan = sim_all();
        let all = served(&plan);
        for f in &plan.fronts {
            let got = of(&all, &Owner::Front(f.name.clone()));
            let (cmd, state): (Option<String>, String) = match f.kind().as_str() {
                "dex3" | "dex5" => (Some(t::<unitree_hg::HandCmd_>()), t::<unitree_hg::HandState_>()),
                "dex1" | "inspire_dfx" | "brainco" => {
                    (Some(t::<unitree_go::MotorCmds_>()), t::<unitree_go::MotorStates_>())
                }
                "inspire_ftp" => (Some(t::<inspire::InspireHandCtrl>()), t::<inspire::InspireHandState>()),
                "canonical" => (Some(t::<handgate::HandCmd_>()), t::<handgate::HandState_>()),
                "joint_state" => (None, t::<ros2::JointState_>()),
                "joint_state_command" => {
                    // Commands only: its reader, nothing written (its client reads a
                    // joint_state front's topic).
                    let topic = f.cmd_topic().expect("its command topic").to_string();
                    assert_eq!(got, [(topic, t::<ros2::JointState_>(), Role::Reader)], "{}", f.name);
                    continue;
                }
                other => panic!("front kind {other} of sim-all has no expectation here"),
            };
            match cmd {
                Some(ty) => {
                    let topic = f
                        .cmd_topic()
                        .expect("a commanded front has a command topic")
                        .to_string();
                    assert!(got.contains(&(topic, ty, Role::Reader)), "{}: {got:?}", f.name);
                }
                None => assert!(got.iter().all(|g| g.2 == Role::Writer), "{}: {got:?}", f.name),
            }
            assert!(
                got.contains(&(f.state_topic().to_string(), state.clone(), Role::Writer)),
                "{}: {got:?}",
                f.name
            );
            if let Some((lf, _)) = f.lf_state() {
                assert!(
                    got.contains(&(lf.to_string(), state, Role::Writer)),
                    "{}: {got:?}",
                    f.name
                );
            }
            if f.kind().as_str() == "inspire_ftp" {
                assert!(
                    got.iter()
                        .any(|g| g.1 == t::<inspire::InspireHandTouch>() && g.2 == Role::Writer),
                    "{}: {got:?}",
                    f.name
                );
            }
        }
    }

    #[test]
    fn a_go_dex1_front_names_the_hg_type_and_the_actuator_topics_with_their_fixes() {
        let mut plan = sim_all();
        // sim-all's per-side Dex1 fronts are auto (the default): this one set to go.
        for f in plan.fronts.iter_mut() {
            if f.cmd_topic() == Some("rt/dex1/left/cmd") {
                let mut c = f.config.own.get::<Dex1Front>().cloned().expect("a dex1 front");
                c.variant = Some(handgate_adapters::dex1::adapter::Variant::Go);
                f.config.own = FrontOwn::new::<Dex1Front>(c);
            }
        }
        let all = served(&plan);
        let f = plan
            .fronts
            .iter()
            .find(|f| f.kind().as_str() == "dex1" && f.cmd_topic() == Some("rt/dex1/left/cmd"))
            .expect("sim-all serves rt/dex1/left/cmd");
        let cmd = all
            .iter()
            .find(|s| s.owner == Owner::Front(f.name.clone()) && s.served.role == Role::Reader)
            .unwrap();
        let alt = cmd
            .served
            .alternatives
            .iter()
            .find(|a| a.type_name == t::<unitree_hg::HandCmd_>())
            .expect("hg HandCmd_ is an alternative");
        assert!(
            alt.hint.contains(&format!("set variant = \"hg\" on front {}", f.name)),
            "{}",
            alt.hint
        );
        assert!(cmd
            .served
            .related_topics
            .iter()
            .any(|r| r.topic == "rt/unitree_actuator/cmd" && r.hint.contains("variant = \"actuator\"")));
    }

    /// A snapshot with one remote writer per (topic, type) given.
    fn remote_writers(writers: &[(&str, String)]) -> handgate_adapters::discovery::Snapshot {
        use handgate_adapters::discovery::{Endpoint, EndpointQos, Guid, Origin, Snapshot};
        let mut s = Snapshot::empty(1, Guid::default());
        s.endpoints = writers
            .iter()
            .enumerate()
            .map(|(i, (topic, ty))| Endpoint {
                key: Guid([i as u8 + 1; 16]),
                participant: Guid([i as u8 + 1; 16]).participant(),
                role: Role::Writer,
                topic: (*topic).into(),
                type_name: ty.as_str().into(),
                qos: EndpointQos::default(),
                origin: Origin::Remote,
            })
            .collect();
        s
    }

    #[test]
    fn an_auto_dex1_front_matches_go_and_hg_clients_and_names_a_foreign_type() {
        use handgate_adapters::discovery::diagnose::{diagnose, FindingKind};
        let plan = sim_all();
        let f = plan
            .fronts
            .iter()
            .find(|f| f.cmd_topic() == Some("rt/dex1/left/cmd"))
            .expect("sim-all serves rt/dex1/left/cmd");
        assert_eq!(
            f.config.own.get::<Dex1Front>().map(|c| c.variant),
            Some(None),
            "sim-all's per-side dex1 fronts are auto (the default)"
        );
        let mine: Vec<_> = served(&plan)
            .into_iter()
            .filter(|s| s.owner == Owner::Front(f.name.clone()))
            .map(|s| s.served)
            .collect();
        let topic = "rt/dex1/left/cmd";
        let snap = remote_writers(&[
            (topic, t::<unitree_go::MotorCmds_>()),
            (topic, t::<unitree_hg::HandCmd_>()),
        ]);
        let report = diagnose(&snap, &mine);
        let cmd = report.topics.iter().find(|t| t.topic == topic).unwrap();
        assert_eq!(cmd.matched.len(), 2, "{cmd:?}");
        assert!(cmd.findings.is_empty(), "{:?}", cmd.findings);
        // A type auto never serves is still a mismatch.
        let snap = remote_writers(&[(topic, t::<handgate::HandCmd_>())]);
        let report = diagnose(&snap, &mine);
        let cmd = report.topics.iter().find(|t| t.topic == topic).unwrap();
        assert!(
            cmd.findings
                .iter()
                .any(|f| matches!(f.kind, FindingKind::TypeMismatch { .. })),
            "{cmd:?}"
        );
        // The actuator pair is named as what the auto front serves once a client appears.
        let c = mine.iter().find(|s| s.role == Role::Reader).unwrap();
        assert!(
            c.related_topics
                .iter()
                .any(|r| r.topic == "rt/unitree_actuator/cmd" && r.hint.contains("(auto) serves its element")),
            "{c:?}"
        );
    }

    #[test]
    fn dds_client_devices_serve_their_peer_topics_and_others_nothing() {
        let plan = sim_all();
        let all = served(&plan);
        for d in &plan.devices {
            let got = of(&all, &Owner::Device(d.name.clone()));
            let kind = d.kind.as_str();
            match kind {
                // USB and serial hands: nothing on DDS.
                "dex3" | "ezgripper" => assert!(got.is_empty(), "{}: {got:?}", d.name),
                _ => {
                    // On the emulator backend: the in-process peer's private topics.
                    assert!(
                        got.iter()
                            .any(|g| g.2 == Role::Writer && g.0.starts_with("rt/handgate/emu/")),
                        "{}: {got:?}",
                        d.name
                    );
                    let cmd = got.iter().find(|g| g.2 == Role::Writer).unwrap();
                    let want = match kind {
                        "inspire_ftp" => t::<inspire::InspireHandCtrl>(),
                        "dex5" => t::<unitree_hg::HandCmd_>(),
                        _ => t::<unitree_go::MotorCmds_>(),
                    };
                    assert_eq!(cmd.1, want, "{}", d.name);
                    if kind != "hand_sdk" {
                        assert!(got.iter().any(|g| g.2 == Role::Reader), "{}: {got:?}", d.name);
                    }
                }
            }
        }
    }
}
