//! handgate seen by a real ROS 2: Jazzy's rclpy over rmw_fastrtps_cpp (Fast DDS, a second DDS
//! implementation), from the PyPI wheels scripts/setup.sh installs in `.venv`
//! (`tests/python/ros2_real_peer.py`; its environment is `handgate_tests::ros2_env`). No type
//! is declared by hand on the ROS side: the message classes, QoS profiles and graph queries
//! are rclpy's own. Against the real binary on the default profile with a
//! `joint_state_command` front added, then with `[dds] namespace`:
//!
//! - the node `<ns>/handgate` is in rclpy's graph, with its topics and their ROS types;
//! - `/joint_states` (sensor_msgs/msg/JointState) reaches a default-QoS subscription
//!   (reliable, keep-last 10) and a sensor-data one (best effort), with the profile's URDF
//!   joint names; `/diagnostics` (diagnostic_msgs/msg/DiagnosticArray) arrives with one status
//!   per device;
//! - the type hashes Jazzy's graph reads from handgate's endpoints are those of rclpy's own
//!   message classes, of the type description files rosidl generated for them, and of
//!   `idl/src/type_hash.rs`;
//! - JointState commands published as ros2_control's joint_state_topic_hardware_interface
//!   publishes them (`rclcpp::QoS(1)`, every joint's name and position, every 10 ms) close a
//!   Dex3 and a Dex1: every commanded joint reaches its target in `/joint_states`.
//!
//! Domains 34 and 35 (docs/development.md). Every wait is on readiness (the node in the graph,
//! a received sample, a matched subscription) with a deadline. Needs `.venv` with the ROS 2
//! wheels (`scripts/setup.sh`).

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use handgate_adapters::mapping::{ClosureMap, DeviceTable, TableOverrides, UrdfFrame};
use handgate_adapters::model::{DeviceKind, Side};
use handgate_idl::ros2::{self, RosType};
use handgate_tests::{default_profile_edited, ros2_env, serial, Gateway, PyProcess};
use serde_json::Value;

/// Generous: rclpy and a debug gateway start on a shared 2-core machine.
const DEADLINE: Duration = Duration::from_secs(45);
/// How far (rad) a commanded joint may be from its target in `/joint_states` to count as
/// reached: the `joint_state_command.rs` bound for a hand at rest at its target (docs/fronts.md).
const TOLERANCE: f64 = 0.03;

const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
const DIAGNOSTIC_ARRAY: &str = "diagnostic_msgs/msg/DiagnosticArray";
const HARDWARE_STATUS: &str = "control_msgs/msg/HardwareStatus";

/// The default profile's devices, in its order (the order `/joint_states` lists them).
const DEVICES: &[(&str, DeviceKind, Side)] = &[
    ("dex3_left", DeviceKind::Dex3, Side::Left),
    ("dex3_right", DeviceKind::Dex3, Side::Right),
    ("dex1_left", DeviceKind::Dex1, Side::Left),
    ("dex1_right", DeviceKind::Dex1, Side::Right),
];

fn table(kind: DeviceKind, side: Side) -> DeviceTable {
    kind.table(side, &TableOverrides::default()).unwrap()
}

/// Every joint's URDF name, device by device in the profile's order, each in its table's order.
fn urdf_names() -> Vec<String> {
    DEVICES
        .iter()
        .flat_map(|(_, k, s)| table(*k, *s).joints.into_iter().map(|j| j.urdf))
        .collect()
}

/// (URDF name, URDF angle) of each joint of `device` at its table's closed posture: what a
/// controller commands to close the hand, in the frame `/joint_states` publishes.
fn closed(device: &str) -> Vec<(String, f64)> {
    let (_, kind, side) = DEVICES.iter().find(|(d, _, _)| *d == device).unwrap();
    let t = table(*kind, *side);
    let ClosureMap::Postures { closed, .. } = &t.closure else {
        panic!("{kind} closes by posture");
    };
    t.joints
        .iter()
        .zip(closed)
        .map(|(m, q)| {
            let urdf = match t.urdf_frame {
                UrdfFrame::Wire => m.q_to_wire(*q),
                UrdfFrame::Canonical => *q,
            };
            (m.urdf.clone(), f64::from(urdf))
        })
        .collect()
}

/// The default profile with a joint_state_command front on every device (topic
/// `rt/robot_joint_commands`), and `extra` edits.
fn profile(name: &str, extra: &[(&str, &str)]) -> std::path::PathBuf {
    let mut edits = vec![(
        "urdf_names = true",
        "urdf_names = true\n\n[[fronts]]\nkind = \"joint_state_command\"\n",
    )];
    edits.extend_from_slice(extra);
    default_profile_edited(name, &edits)
}

/// What the peer printed: one JSON document per tag.
struct Report(BTreeMap<String, Value>);

impl Report {
    fn get(&self, tag: &str) -> &Value {
        self.0
            .get(tag)
            .unwrap_or_else(|| panic!("the peer printed no {tag}: {:#?}", self.0))
    }

    /// `[[topic, [types]], ...]` of PUBLISHERS or SUBSCRIBERS as a map.
    fn topics(&self, tag: &str) -> BTreeMap<String, Vec<String>> {
        self.get(tag)
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                let types = t[1].as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string());
                (t[0].as_str().unwrap().to_string(), types.collect())
            })
            .collect()
    }

    /// The other nodes' endpoints on `topic` (ENDPOINTS).
    fn endpoints(&self, topic: &str) -> &Vec<Value> {
        self.get("ENDPOINTS")[topic]
            .as_array()
            .unwrap_or_else(|| panic!("no endpoints listed for {topic}: {}", self.get("ENDPOINTS")))
    }
}

/// Runs the peer against `gw` with `args` until it prints DONE; returns its report and how long
/// it took from its start to DONE.
fn peer(gw: &Gateway, args: &[String]) -> (Report, Duration) {
    let mut args = args.to_vec();
    args.extend(["--timeout".into(), DEADLINE.as_secs().to_string()]);
    let logs = std::env::temp_dir().join(format!("handgate-ros2-real-{}", std::process::id()));
    std::fs::create_dir_all(&logs).expect("log dir");
    let domain = gw.domain();
    let start = Instant::now();
    let py = PyProcess::spawn_with(None, "ros2_real_peer.py", &args, |cmd| ros2_env(cmd, domain, &logs))
        .expect("start ros2_real_peer.py");
    let ctx = || {
        format!(
            "{}\n{}\n(the ROS 2 wheels come from scripts/setup.sh)",
            py.transcript(),
            gw.transcript()
        )
    };
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
    let mut out = BTreeMap::new();
    loop {
        let line = py.wait_line("", DEADLINE).unwrap_or_else(|e| panic!("{e}\n{}", ctx()));
        if line == "DONE" {
            break;
        }
        let (tag, json) = line.split_once(' ').unwrap_or((&line, "null"));
        if tag == "NOT_READY" || tag == "GRAPH" {
            panic!("the peer never saw everything it waits for: {line}\n{}", ctx());
        }
        let v: Value = serde_json::from_str(json).unwrap_or_else(|e| panic!("{e}: {line:?}\n{}", ctx()));
        out.insert(tag.to_string(), v);
    }
    (Report(out), start.elapsed())
}

/// Exactly one endpoint of handgate's on `topic` (as Jazzy's graph has it, from another DDS
/// implementation): its kind, node, type, type hash and QoS.
fn check_endpoint(r: &Report, topic: &str, kind: &str, namespace: &str, ty: &str, hash: &str) {
    let eps = r.endpoints(topic);
    assert_eq!(eps.len(), 1, "{topic}: {eps:#?}");
    let e = &eps[0];
    assert_eq!(e["kind"], kind, "{topic}: {e}");
    assert_eq!(e["node"], "handgate", "{topic}: {e}");
    assert_eq!(e["namespace"], namespace, "{topic}: {e}");
    assert_eq!(e["type"], ty, "{topic}: {e}");
    assert_eq!(e["hash"], hash, "{topic}: the type hash Jazzy reads: {e}");
    assert_eq!(e["reliability"], "RELIABLE", "{topic}: {e}");
    assert_eq!(e["durability"], "VOLATILE", "{topic}: {e}");
}

/// The node's topics as `ros2 node info` lists them: `want` are there with exactly these types,
/// `absent` are not.
fn check_topics(r: &Report, tag: &str, want: &[(&str, &str)], absent: &[&str]) {
    let topics = r.topics(tag);
    for (t, ty) in want {
        assert_eq!(
            topics.get(*t).map(Vec::as_slice),
            Some(&[ty.to_string()][..]),
            "{tag}: {t} as {ty} in {topics:#?}"
        );
    }
    for t in absent {
        assert!(!topics.contains_key(*t), "{tag}: {t} in {topics:#?}");
    }
}

/// Both JointState subscriptions (default QoS, sensor-data QoS) received a sample with every
/// URDF name of the profile's devices, in order, with one position each.
fn check_joint_states(r: &Report) {
    let names = urdf_names();
    for tag in ["JOINT_STATES_DEFAULT", "JOINT_STATES_SENSOR_DATA"] {
        let js = r.get(tag);
        let got: Vec<&str> = js["name"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap())
            .collect();
        assert_eq!(got, names, "{tag}");
        assert_eq!(js["position"].as_array().unwrap().len(), names.len(), "{tag}: {js}");
    }
}

/// One DiagnosticStatus per device, named `<hardware id>: <device>`, its hardware_id the device.
fn check_diagnostics(r: &Report, hardware_id: &str) {
    let st = r.get("DIAGNOSTICS").as_array().unwrap();
    assert_eq!(st.len(), DEVICES.len(), "{st:#?}");
    let names: BTreeSet<&str> = st.iter().map(|s| s["name"].as_str().unwrap()).collect();
    let want: BTreeSet<String> = DEVICES.iter().map(|(d, _, _)| format!("{hardware_id}: {d}")).collect();
    assert_eq!(names, want.iter().map(String::as_str).collect(), "{st:#?}");
    for s in st {
        let device = s["name"].as_str().unwrap().rsplit(": ").next().unwrap();
        assert_eq!(s["hardware_id"], device, "{s}");
    }
}

/// The hashes of rclpy's own message classes (its endpoints' hashes) and of the description
/// files rosidl generated for Jazzy's packages are handgate's (`idl/src/type_hash.rs`): the
/// types handgate publishes and takes, those they reference, and the graph message's.
fn check_own_hashes(r: &Report) {
    for (ty, hash) in [
        (JOINT_STATE, ros2::JointState_::DESCRIPTION.type_hash()),
        (DIAGNOSTIC_ARRAY, ros2::DiagnosticArray_::DESCRIPTION.type_hash()),
    ] {
        assert_eq!(r.get("OWN_HASHES")[ty], hash.as_str(), "{ty}: rclpy's own endpoints");
    }
    let generated = r.get("GENERATED_HASHES").as_object().unwrap();
    let ours = [
        ros2::JointState_::DESCRIPTION,
        ros2::Header_::DESCRIPTION,
        ros2::Time_::DESCRIPTION,
        ros2::DiagnosticArray_::DESCRIPTION,
        ros2::DiagnosticStatus_::DESCRIPTION,
        ros2::KeyValue_::DESCRIPTION,
        ros2::ParticipantEntitiesInfo_::DESCRIPTION,
        ros2::NodeEntitiesInfo_::DESCRIPTION,
        ros2::Gid_::DESCRIPTION,
    ];
    assert_eq!(generated.len(), ours.len(), "{generated:#?}");
    for d in ours {
        assert_eq!(
            generated[d.type_name],
            d.type_hash().as_str(),
            "{}: rosidl's description file",
            d.type_name
        );
    }
}

#[test]
fn rclpy_on_fast_dds_sees_the_node_reads_its_topics_and_drives_a_dex3_and_a_dex1() {
    let _serial = serial();
    let profile = profile("ros2-real", &[]);
    let t0 = Instant::now();
    let gw = Gateway::start(34, &["--profile", profile.to_str().unwrap()]);
    let started = t0.elapsed();
    let commanded = ["dex3_left", "dex1_right"].map(|d| (d, closed(d)));
    let targets: Vec<(String, f64)> = commanded.iter().flat_map(|(_, t)| t.clone()).collect();
    let args: Vec<String> = [
        "--joint-states",
        "/joint_states",
        "--hardware-status",
        "/hardware_status",
        "--commands",
        "/robot_joint_commands",
        "--tolerance",
        &TOLERANCE.to_string(),
        "--targets",
        &serde_json::to_string(&targets).unwrap(),
    ]
    .map(String::from)
    .to_vec();
    let (r, took) = peer(&gw, &args);

    let nodes = r.get("NODES").as_array().unwrap();
    assert!(nodes.contains(&serde_json::json!(["handgate", "/"])), "{nodes:?}");
    check_topics(
        &r,
        "PUBLISHERS",
        &[
            ("/joint_states", JOINT_STATE),
            ("/diagnostics", DIAGNOSTIC_ARRAY),
            ("/hardware_status", HARDWARE_STATUS),
            ("/handgate/status", "handgate/msg/GatewayStatus"),
            ("/handgate/dex3_left/state", "handgate/msg/HandState"),
            ("/dex3/left/state", "unitree_hg/msg/HandState"),
            ("/dex1/right/state", "unitree_go/msg/MotorStates"),
        ],
        &[],
    );
    check_topics(
        &r,
        "SUBSCRIBERS",
        &[
            ("/robot_joint_commands", JOINT_STATE),
            ("/handgate/dex1_right/cmd", "handgate/msg/HandCmd"),
            ("/dex3/left/cmd", "unitree_hg/msg/HandCmd"),
        ],
        &[],
    );
    let js_hash = ros2::JointState_::DESCRIPTION.type_hash();
    check_endpoint(&r, "/joint_states", "publisher", "/", JOINT_STATE, &js_hash);
    check_endpoint(&r, "/robot_joint_commands", "subscription", "/", JOINT_STATE, &js_hash);
    check_endpoint(
        &r,
        "/diagnostics",
        "publisher",
        "/",
        DIAGNOSTIC_ARRAY,
        &ros2::DiagnosticArray_::DESCRIPTION.type_hash(),
    );
    check_endpoint(
        &r,
        "/hardware_status",
        "publisher",
        "/",
        HARDWARE_STATUS,
        &ros2::HardwareStatus_::DESCRIPTION.type_hash(),
    );
    check_own_hashes(&r);
    check_joint_states(&r);
    check_diagnostics(&r, "handgate");

    // The command: each hand started away from it (so reaching it means it moved) and every
    // commanded joint reached it in a default-QoS /joint_states sample.
    let start = r.get("START");
    let mut far = Vec::new();
    for (device, t) in &commanded {
        let d = t
            .iter()
            .map(|(n, q)| (start[n].as_f64().unwrap() - q).abs())
            .fold(0.0, f64::max);
        assert!(d > 10.0 * TOLERANCE, "{device} started at the target: {start}");
        far.push(format!("{device} {d:.3} rad"));
    }
    let reached =
        r.0.get("REACHED")
            .unwrap_or_else(|| panic!("the joints never reached the command: {}", r.get("NOT_REACHED")));
    for (n, q) in &targets {
        let p = reached["positions"][n].as_f64().unwrap();
        assert!((p - q).abs() <= TOLERANCE, "{n}: {p} for {q}: {reached}");
    }
    eprintln!(
        "gateway serving after {started:?}; rclpy peer done after {took:?}; commands: {} over {:.2} s, \
         from (largest joint) {}",
        reached["published"],
        reached["seconds"].as_f64().unwrap(),
        far.join(", ")
    );
}

#[test]
fn rclpy_sees_the_namespaced_node_and_its_topics_in_the_namespace() {
    let _serial = serial();
    let profile = profile(
        "ros2-real-namespace",
        &[("# interface = \"lo\"", "namespace = \"robot1\"\n# interface = \"lo\"")],
    );
    let gw = Gateway::start(35, &["--profile", profile.to_str().unwrap()]);
    let args: Vec<String> = [
        "--namespace",
        "/robot1",
        "--joint-states",
        "/robot1/joint_states",
        "--hardware-status",
        "/robot1/hardware_status",
        "--commands",
        "/robot1/robot_joint_commands",
    ]
    .map(String::from)
    .to_vec();
    let (r, took) = peer(&gw, &args);

    let nodes = r.get("NODES").as_array().unwrap();
    assert!(nodes.contains(&serde_json::json!(["handgate", "/robot1"])), "{nodes:?}");
    assert!(!nodes.contains(&serde_json::json!(["handgate", "/"])), "{nodes:?}");
    check_topics(
        &r,
        "PUBLISHERS",
        &[
            ("/robot1/joint_states", JOINT_STATE),
            ("/robot1/hardware_status", HARDWARE_STATUS),
            ("/robot1/handgate/status", "handgate/msg/GatewayStatus"),
            ("/robot1/handgate/dex3_left/state", "handgate/msg/HandState"),
            // Never namespaced: the diagnostic aggregator's topic, the devices' own topics.
            ("/diagnostics", DIAGNOSTIC_ARRAY),
            ("/dex3/left/state", "unitree_hg/msg/HandState"),
        ],
        &["/joint_states", "/hardware_status", "/handgate/status"],
    );
    check_topics(
        &r,
        "SUBSCRIBERS",
        &[("/robot1/robot_joint_commands", JOINT_STATE)],
        &["/robot_joint_commands"],
    );
    let js_hash = ros2::JointState_::DESCRIPTION.type_hash();
    check_endpoint(
        &r,
        "/robot1/joint_states",
        "publisher",
        "/robot1",
        JOINT_STATE,
        &js_hash,
    );
    check_endpoint(
        &r,
        "/robot1/robot_joint_commands",
        "subscription",
        "/robot1",
        JOINT_STATE,
        &js_hash,
    );
    check_joint_states(&r);
    check_diagnostics(&r, "robot1/handgate");
    eprintln!("rclpy peer done after {took:?}");
}
