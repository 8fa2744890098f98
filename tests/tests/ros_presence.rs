//! handgate as a ROS 2 node, seen by a ROS 2 node's means (CycloneDDS Python,
//! `tests/python/ros_peer.py`; no ROS installation here): the real binary on the default
//! profile, then with `[dds] namespace`.
//!
//! - `ros_discovery_info` (read after the gateway published it, with rmw's transient-local
//!   QoS) names node `<ns>/handgate` on the gateway's participant, listing every writer the
//!   participant has (DCPSPublication) and nothing else;
//! - the JointState writer carries `typehash=RIHS01_...;` with the published
//!   `sensor_msgs/msg/JointState` hash, and a ROS-default-QoS (reliable) reader receives it;
//! - with a namespace, handgate's own topics move into it and the device topics stay.
//!
//! Domains 204 and 205 (docs/development.md).

use std::collections::BTreeSet;
use std::time::Duration;

use handgate_tests::{default_profile_edited, handgate_bin, serial, Gateway, PyProcess};
use serde_json::Value;

const DEADLINE: Duration = Duration::from_secs(45);

/// REP-2011 hashes as ROS 2's generated code publishes them (docs/sources.md §10).
const JOINT_STATE_HASH: &str = "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e";
const PARTICIPANT_ENTITIES_INFO_HASH: &str = "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e";
const DIAGNOSTIC_ARRAY_HASH: &str = "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e";
const HARDWARE_STATUS_HASH: &str = "RIHS01_d4d081efebdea6d8863855733ea95c58338ac4ffdb501a9524da4cbbad9927a2";

/// What the peer reported: the node message and the participant's writers.
struct Seen {
    node: Value,
    pubs: Vec<Value>,
    joint_names: usize,
}

impl Seen {
    fn by_topic(&self, topic: &str) -> Option<&Value> {
        self.pubs.iter().find(|p| p["topic"] == topic)
    }
    fn topics(&self) -> BTreeSet<String> {
        self.pubs
            .iter()
            .map(|p| p["topic"].as_str().unwrap().to_string())
            .collect()
    }
}

fn peer(gw: &Gateway, joint_states: &str) -> Seen {
    let args = vec![
        "--domain".to_string(),
        gw.domain().to_string(),
        "--joint-states".into(),
        joint_states.into(),
        "--timeout".into(),
        DEADLINE.as_secs().to_string(),
    ];
    let py = PyProcess::spawn("ros_peer.py", &args).unwrap();
    let ctx = || format!("{}\n{}", py.transcript(), gw.transcript());
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
    let node = py
        .wait_line("NODE ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
    let node: Value = serde_json::from_str(&node).unwrap();
    let mut pubs = Vec::new();
    let joint_names;
    loop {
        let line = py.wait_line("", DEADLINE).unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
        if let Some(p) = line.strip_prefix("PUB ") {
            pubs.push(serde_json::from_str(p).unwrap());
        } else if let Some(n) = line.strip_prefix("JOINT_STATE ") {
            joint_names = n.parse().unwrap();
            break;
        } else {
            panic!("unexpected line {line:?}\n{}", ctx());
        }
    }
    py.wait_line("DONE", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
    Seen {
        node,
        pubs,
        joint_names,
    }
}

/// The node is `namespace`/handgate on the writers' participant; it lists exactly the
/// participant's writers except the context's `ros_discovery_info` writer; the graph and
/// JointState writers carry their type hashes and the QoS rmw expects.
fn check_presence(seen: &Seen, namespace: &str, joint_states: &str) {
    let ctx = format!("{}\n{:#?}", seen.node, seen.pubs);
    let nodes = seen.node["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 1, "{ctx}");
    assert_eq!(nodes[0]["name"], "handgate", "{ctx}");
    assert_eq!(nodes[0]["namespace"], namespace, "{ctx}");
    for p in &seen.pubs {
        assert_eq!(p["participant"], seen.node["gid"], "{ctx}");
    }

    let info = seen.by_topic("ros_discovery_info").expect("the graph writer");
    assert_eq!(info["type"], "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_");
    assert_eq!(info["reliability"], "Reliability.Reliable", "{ctx}");
    assert_eq!(info["durability"], "Durability.TransientLocal", "{ctx}");
    assert_eq!(
        info["user_data"],
        format!("typehash={PARTICIPANT_ENTITIES_INFO_HASH};"),
        "{ctx}"
    );

    let listed: BTreeSet<&str> = nodes[0]["writers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    let writers: BTreeSet<&str> = seen
        .pubs
        .iter()
        .filter(|p| p["topic"] != "ros_discovery_info")
        .map(|p| p["key"].as_str().unwrap())
        .collect();
    assert_eq!(listed, writers, "{ctx}");
    assert!(!nodes[0]["readers"].as_array().unwrap().is_empty(), "{ctx}");

    let js = seen.by_topic(joint_states).expect("the JointState writer");
    assert_eq!(js["type"], "sensor_msgs::msg::dds_::JointState_");
    assert_eq!(js["reliability"], "Reliability.Reliable", "{ctx}");
    assert_eq!(js["durability"], "Durability.Volatile", "{ctx}");
    assert_eq!(js["user_data"], format!("typehash={JOINT_STATE_HASH};"), "{ctx}");
    // The default profile's four hands: 7 + 7 + 1 + 1 joints.
    assert_eq!(seen.joint_names, 16, "{ctx}");
}

/// The health writers: `/diagnostics` (global) and `hardware_status` (at `hardware_status`),
/// reliable and volatile like a ROS 2 default publisher, with their type hashes.
fn check_health_writers(seen: &Seen, hardware_status: &str) {
    let ctx = format!("{:#?}", seen.pubs);
    for (topic, ty, hash) in [
        (
            "rt/diagnostics",
            "diagnostic_msgs::msg::dds_::DiagnosticArray_",
            DIAGNOSTIC_ARRAY_HASH,
        ),
        (
            hardware_status,
            "control_msgs::msg::dds_::HardwareStatus_",
            HARDWARE_STATUS_HASH,
        ),
    ] {
        let w = seen
            .by_topic(topic)
            .unwrap_or_else(|| panic!("no {topic} writer: {ctx}"));
        assert_eq!(w["type"], ty, "{ctx}");
        assert_eq!(w["reliability"], "Reliability.Reliable", "{ctx}");
        assert_eq!(w["durability"], "Durability.Volatile", "{ctx}");
        assert_eq!(w["user_data"], format!("typehash={hash};"), "{ctx}");
    }
}

#[test]
fn default_profile_is_a_ros_node_and_joint_states_match_a_default_qos_reader() {
    let _serial = serial();
    let gw = Gateway::start(204, &[]);
    let seen = peer(&gw, "rt/joint_states");
    check_presence(&seen, "/", "rt/joint_states");
    check_health_writers(&seen, "rt/hardware_status");
    let topics = seen.topics();
    for t in [
        "rt/handgate/status",
        "rt/handgate/dex3_left/state",
        "rt/dex3/left/state",
    ] {
        assert!(topics.contains(t), "{t} in {topics:?}");
    }
}

#[test]
fn namespace_moves_handgates_own_topics_and_names_the_node() {
    let _serial = serial();
    let profile = default_profile_edited(
        "ros-namespace",
        &[("# interface = \"lo\"", "namespace = \"robot1\"\n# interface = \"lo\"")],
    );
    let gw = Gateway::start(205, &["--profile", profile.to_str().unwrap()]);
    let seen = peer(&gw, "rt/robot1/joint_states");
    check_presence(&seen, "/robot1", "rt/robot1/joint_states");
    check_health_writers(&seen, "rt/robot1/hardware_status");
    let topics = seen.topics();
    for t in [
        "rt/robot1/handgate/status",
        "rt/robot1/handgate/dex3_left/state",
        "rt/robot1/handgate/dex1_right/state",
        // The device-compatible fronts keep the devices' topics.
        "rt/dex3/left/state",
        "rt/dex1/right/state",
    ] {
        assert!(topics.contains(t), "{t} in {topics:?}");
    }
    for t in [
        "rt/joint_states",
        "rt/handgate/status",
        "rt/handgate/dex3_left/state",
        "rt/hardware_status",
    ] {
        assert!(!topics.contains(t), "{t} in {topics:?}");
    }

    // `handgate status --namespace` finds the namespaced status topic.
    let out = std::process::Command::new(handgate_bin())
        .args([
            "status",
            "--once",
            "--domain",
            "205",
            "--namespace",
            "robot1",
            "--timeout",
            "20",
        ])
        .output()
        .expect("handgate status runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("dex3_left"), "{stdout}");
}
