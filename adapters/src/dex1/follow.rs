//! The `auto` Dex1 front's choice of what to serve, from what discovery sees (pure: a
//! snapshot in, the variants to serve out).
//!
//! A client is a remote endpoint (another process: `Origin::Remote`) that writes the front's
//! command topic, or reads its state topic, with a Dex1 variant's type: unitree_go
//! `MotorCmds_` / `MotorStates_` (`go`), unitree_hg `HandCmd_` / `HandState_` (`hg`), or
//! unitree_go on `rt/unitree_actuator/{cmd,state}` (`actuator`, the 2-element pair). `go` is
//! served until a per-side client appears; an `auto` front then serves every variant its
//! clients speak, at once.

use std::collections::BTreeMap;

use handgate_idl::{unitree_go, unitree_hg, DdsTypeName};

use super::adapter::Variant;
use crate::discovery::{Endpoint, Origin, Role, Snapshot};

/// The topics an `auto` front watches.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Watched {
    /// Its own command and state topics (`rt/dex1/{side}/*` unless overridden).
    pub cmd: String,
    pub state: String,
    /// `rt/unitree_actuator/{cmd,state}`, when the front serves a left or right gripper
    /// (the 2-element pair's element of that side); `None`: no actuator clients followed.
    pub actuator: Option<(String, String)>,
}

/// The remote endpoint that shows a client of a variant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Client {
    pub endpoint: Endpoint,
    /// "process NAME (pid P) on HOST", with what its participant reported.
    pub who: String,
}

/// The variant whose client `e` would be on the watched topics, if any.
fn variant_of(w: &Watched, e: &Endpoint) -> Option<Variant> {
    let (topic, ty) = (&*e.topic, &*e.type_name);
    match e.role {
        Role::Writer if topic == w.cmd => match ty {
            unitree_go::MotorCmds_::DDS_TYPE_NAME => Some(Variant::Go),
            unitree_hg::HandCmd_::DDS_TYPE_NAME => Some(Variant::Hg),
            _ => None,
        },
        Role::Reader if topic == w.state => match ty {
            unitree_go::MotorStates_::DDS_TYPE_NAME => Some(Variant::Go),
            unitree_hg::HandState_::DDS_TYPE_NAME => Some(Variant::Hg),
            _ => None,
        },
        Role::Writer => w
            .actuator
            .as_ref()
            .filter(|a| topic == a.0 && ty == unitree_go::MotorCmds_::DDS_TYPE_NAME)
            .map(|_| Variant::Actuator),
        Role::Reader => w
            .actuator
            .as_ref()
            .filter(|a| topic == a.1 && ty == unitree_go::MotorStates_::DDS_TYPE_NAME)
            .map(|_| Variant::Actuator),
    }
}

fn who(s: &Snapshot, e: &Endpoint) -> String {
    let p = s.participant(&e.participant);
    let mut out = match (p.and_then(|p| p.process_name.as_deref()), p.and_then(|p| p.pid)) {
        (Some(n), Some(pid)) => format!("process {n} (pid {pid})"),
        (Some(n), None) => format!("process {n}"),
        (None, Some(pid)) => format!("pid {pid}"),
        (None, None) => format!("participant {}", e.participant),
    };
    if let Some(h) = p.and_then(|p| p.hostname.as_deref()) {
        out.push_str(&format!(" on {h}"));
    }
    out
}

/// The process name CycloneDDS reports (`__ProcessName`) for the handgate binary.
pub const HANDGATE_PROCESS: &str = "handgate";

/// The clients on the watched topics, one (the first in the snapshot's order: writers
/// before readers of a topic) per variant.
///
/// A reader in a handgate process ([`HANDGATE_PROCESS`]: `handgate record`, `handgate doctor`)
/// is an observer, not a client: it reads whatever the front serves, and following it would
/// make a recording change what it records (an `hg` state stream nobody asked for). A
/// handgate that drives this front as a device writes its command topic, and is followed.
pub fn clients(s: &Snapshot, w: &Watched) -> BTreeMap<Variant, Client> {
    let observer = |e: &Endpoint| {
        e.role == Role::Reader
            && s.participant(&e.participant).and_then(|p| p.process_name.as_deref()) == Some(HANDGATE_PROCESS)
    };
    let mut out = BTreeMap::new();
    for e in s
        .endpoints
        .iter()
        .filter(|e| e.origin == Origin::Remote && !observer(e))
    {
        if let Some(v) = variant_of(w, e) {
            out.entry(v).or_insert_with(|| Client {
                endpoint: e.clone(),
                who: who(s, e),
            });
        }
    }
    out
}

/// The variants an `auto` front serves given its clients: each client's, and `go` while no
/// client of its own topics (`go` or `hg`) is there.
pub fn to_serve(clients: &BTreeMap<Variant, Client>) -> Vec<Variant> {
    let mut v: Vec<Variant> = clients.keys().copied().collect();
    if !v.iter().any(|v| matches!(v, Variant::Go | Variant::Hg)) {
        v.push(Variant::Go);
    }
    v.sort();
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::{EndpointQos, Guid, Participant};
    use std::sync::Arc;

    fn watched(actuator: bool) -> Watched {
        Watched {
            cmd: "rt/dex1/left/cmd".into(),
            state: "rt/dex1/left/state".into(),
            actuator: actuator.then(|| ("rt/unitree_actuator/cmd".into(), "rt/unitree_actuator/state".into())),
        }
    }

    fn ep(n: u8, role: Role, topic: &str, ty: &str, origin: Origin) -> Endpoint {
        let mut key = [n; 16];
        key[15] = 2;
        Endpoint {
            key: Guid(key),
            participant: Guid([n; 16]).participant(),
            role,
            topic: Arc::from(topic),
            type_name: Arc::from(ty),
            qos: EndpointQos::default(),
            origin,
        }
    }

    fn snap(endpoints: Vec<Endpoint>) -> Snapshot {
        let mut s = Snapshot::empty(130, Guid::default());
        s.participants = [(7, "python3"), (9, HANDGATE_PROCESS)]
            .map(|(n, name)| Participant {
                key: Guid([n; 16]).participant(),
                hostname: Some(Arc::from("pc")),
                pid: Some(4242),
                process_name: Some(Arc::from(name)),
                network_addresses: vec![],
                origin: Origin::Remote,
            })
            .to_vec();
        s.endpoints = endpoints;
        s
    }

    const GO_CMD: &str = unitree_go::MotorCmds_::DDS_TYPE_NAME;
    const GO_STATE: &str = unitree_go::MotorStates_::DDS_TYPE_NAME;
    const HG_CMD: &str = unitree_hg::HandCmd_::DDS_TYPE_NAME;
    const HG_STATE: &str = unitree_hg::HandState_::DDS_TYPE_NAME;

    fn served(endpoints: Vec<Endpoint>, actuator: bool) -> Vec<Variant> {
        to_serve(&clients(&snap(endpoints), &watched(actuator)))
    }

    #[test]
    fn type_names_are_the_wire_types_as_discovery_reports_them() {
        assert_eq!(GO_CMD, "unitree_go::msg::dds_::MotorCmds_");
        assert_eq!(HG_CMD, "unitree_hg::msg::dds_::HandCmd_");
    }

    #[test]
    fn no_client_serves_go() {
        assert_eq!(served(vec![], true), vec![Variant::Go]);
    }

    #[test]
    fn an_hg_writer_on_the_command_topic_is_served_hg_alone() {
        let e = ep(7, Role::Writer, "rt/dex1/left/cmd", HG_CMD, Origin::Remote);
        let c = clients(&snap(vec![e.clone()]), &watched(true));
        assert_eq!(to_serve(&c), vec![Variant::Hg]);
        assert_eq!(c[&Variant::Hg].endpoint, e);
        assert_eq!(c[&Variant::Hg].who, "process python3 (pid 4242) on pc");
    }

    #[test]
    fn a_state_reader_alone_is_a_client_too() {
        let e = ep(7, Role::Reader, "rt/dex1/left/state", HG_STATE, Origin::Remote);
        assert_eq!(served(vec![e], false), vec![Variant::Hg]);
        let e = ep(7, Role::Reader, "rt/dex1/left/state", GO_STATE, Origin::Remote);
        assert_eq!(served(vec![e], false), vec![Variant::Go]);
    }

    #[test]
    fn a_handgate_observer_reading_state_is_no_client_but_a_handgate_writing_commands_is() {
        // `handgate record` / `doctor` in another process: readers of both types.
        let observers = vec![
            ep(9, Role::Reader, "rt/dex1/left/state", HG_STATE, Origin::Remote),
            ep(9, Role::Reader, "rt/unitree_actuator/state", GO_STATE, Origin::Remote),
        ];
        assert_eq!(served(observers.clone(), true), vec![Variant::Go]);
        // A handgate device on this front writes its command topic (e.g. `handgate replay`).
        let mut with_writer = observers;
        with_writer.push(ep(9, Role::Writer, "rt/dex1/left/cmd", HG_CMD, Origin::Remote));
        assert_eq!(served(with_writer, true), vec![Variant::Hg]);
    }

    #[test]
    fn clients_of_both_per_side_variants_are_served_both() {
        let v = served(
            vec![
                ep(7, Role::Writer, "rt/dex1/left/cmd", GO_CMD, Origin::Remote),
                ep(8, Role::Writer, "rt/dex1/left/cmd", HG_CMD, Origin::Remote),
            ],
            true,
        );
        assert_eq!(v, vec![Variant::Go, Variant::Hg]);
    }

    #[test]
    fn an_actuator_client_adds_actuator_and_keeps_go_for_the_own_topics() {
        let a = ep(7, Role::Writer, "rt/unitree_actuator/cmd", GO_CMD, Origin::Remote);
        assert_eq!(served(vec![a.clone()], true), vec![Variant::Go, Variant::Actuator]);
        // Not followed by a front that serves no left/right gripper.
        assert_eq!(served(vec![a], false), vec![Variant::Go]);
        let r = ep(7, Role::Reader, "rt/unitree_actuator/state", GO_STATE, Origin::Remote);
        assert_eq!(served(vec![r], true), vec![Variant::Go, Variant::Actuator]);
    }

    #[test]
    fn our_own_endpoints_wrong_roles_topics_and_types_are_not_clients() {
        let v = served(
            vec![
                // Ours (the gateway's own reader and a second participant of this process).
                ep(1, Role::Writer, "rt/dex1/left/cmd", HG_CMD, Origin::ThisParticipant),
                ep(2, Role::Writer, "rt/dex1/left/cmd", HG_CMD, Origin::ThisProcess),
                // Another publisher of the state topic is not a client of the front.
                ep(7, Role::Writer, "rt/dex1/left/state", HG_STATE, Origin::Remote),
                // A reader of the command topic neither.
                ep(7, Role::Reader, "rt/dex1/left/cmd", HG_CMD, Origin::Remote),
                // The other side's topics.
                ep(7, Role::Writer, "rt/dex1/right/cmd", HG_CMD, Origin::Remote),
                // A state type on the command topic, a foreign type.
                ep(7, Role::Writer, "rt/dex1/left/cmd", HG_STATE, Origin::Remote),
                ep(
                    7,
                    Role::Writer,
                    "rt/dex1/left/cmd",
                    "std_msgs::msg::dds_::String_",
                    Origin::Remote,
                ),
                // hg on the actuator pair is no variant.
                ep(7, Role::Writer, "rt/unitree_actuator/cmd", HG_CMD, Origin::Remote),
            ],
            true,
        );
        assert_eq!(v, vec![Variant::Go]);
    }
}
