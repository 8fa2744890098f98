//! The Foxglove WebSocket live server (`[foxglove]`, docs/foxglove.md) end to end, on DDS
//! domains 77–79, 129 and 188: the real `handgate run` (built with the `foxglove` feature, as
//! [`handgate_bin`] builds it) and a client written against the protocol spec alone
//! (`tests/python/foxglove_client.py`: the websockets package, CDR decoded by hand).

use std::collections::BTreeSet;
use std::net::TcpListener;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::unitree_hg as hg;
use handgate_idl::{ros2, DdsTypeName};
use handgate_tests::{
    default_profile_edited, device_metrics, http_get, node, serial, stream_until, Gateway, GatewayError, Latest,
    PyProcess,
};
use serde_json::Value;

const WAIT: Duration = Duration::from_secs(30);

/// `profiles/default.toml` with `section` (a `[foxglove]` table) before its `[status]` table.
fn profile_with(name: &str, section: &str) -> String {
    default_profile_edited(name, &[("[status]", &format!("{section}\n\n[status]"))])
        .display()
        .to_string()
}

/// The client's next `KIND {json}` line.
fn next(py: &PyProcess, kind: &str) -> Value {
    let rest = py
        .wait_line(&format!("{kind} "), WAIT)
        .unwrap_or_else(|e| panic!("{e}"));
    serde_json::from_str(&rest).unwrap_or_else(|e| panic!("{kind} {rest}: {e}"))
}

/// The next decoded message of `topic` (other topics' messages are skipped).
fn next_msg(py: &PyProcess, topic: &str) -> Value {
    loop {
        let m = next(py, "MSG");
        if m["topic"] == topic {
            return m;
        }
    }
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|s| s.as_str().expect("a string").to_string())
        .collect()
}

/// The default fleet's URDF joint names (docs/sources.md §2: the Dex3-1 URDFs xr_teleoperate
/// uses, left `zero..six` in message order zero, one, two, five, six, three, four, right in
/// order; the Dex1-1 grippers' `<side>_gripper_joint`), written out here, not taken from
/// the tables under test.
const URDF_JOINTS: [&str; 16] = [
    "left_hand_zero_joint",
    "left_hand_one_joint",
    "left_hand_two_joint",
    "left_hand_three_joint",
    "left_hand_four_joint",
    "left_hand_five_joint",
    "left_hand_six_joint",
    "right_hand_zero_joint",
    "right_hand_one_joint",
    "right_hand_two_joint",
    "right_hand_three_joint",
    "right_hand_four_joint",
    "right_hand_five_joint",
    "right_hand_six_joint",
    "left_gripper_joint",
    "right_gripper_joint",
];

/// The left hand's index_0 (message index 5) is the left URDF's `three` joint.
const LEFT_INDEX_0: &str = "left_hand_three_joint";

/// The Dex3 SDK command: every motor in FOC with xr_teleoperate's gains, index_0 at `q`.
fn left_index_cmd(q: f32) -> hg::HandCmd_ {
    let mut cmd = hg::HandCmd_::sdk_default();
    for (i, m) in cmd.motor_cmd.iter_mut().enumerate() {
        m.mode = 0x10 | i as u8;
        m.kp = 1.5;
        m.kd = 0.1;
    }
    cmd.motor_cmd[5].q = q;
    cmd
}

#[test]
fn joint_states_and_front_states_are_live_channels_a_command_moves() {
    let _serial = serial();
    let domain = 77;
    let profile = profile_with("foxglove-live", "[foxglove]\nport = 0");
    let gw = Gateway::start(domain, &["--profile", &profile]);
    let url = gw.foxglove_url().unwrap();
    assert!(url.starts_with("ws://127.0.0.1:"), "{url}");
    assert_ne!(url, "ws://127.0.0.1:0", "port 0 is an ephemeral port, logged as bound");

    let py = PyProcess::spawn(
        "foxglove_client.py",
        &[url.clone(), "/joint_states".into(), "/dex3/left/state".into()],
    )
    .unwrap();
    let info = next(&py, "SERVERINFO");
    // The Foxglove SDK's name for the v1 protocol (docs/foxglove.md, "Clients").
    assert_eq!(info["subprotocol"], "foxglove.sdk.v1", "{info}");
    assert_eq!(info["name"], "handgate default", "{info}");

    let channels = next(&py, "CHANNELS");
    let channels = channels.as_array().expect("a list");
    let topics: Vec<&str> = channels.iter().map(|c| c["topic"].as_str().unwrap()).collect();
    let unique: BTreeSet<&str> = topics.iter().copied().collect();
    assert_eq!(unique.len(), topics.len(), "one channel per name: {topics:?}");
    assert!(
        topics.iter().all(|t| !t.ends_with("/cmd")),
        "no command topic unless [foxglove] topics selects it: {topics:?}"
    );
    for t in [
        "/joint_states",
        "/dex3/left/state",
        "/dex3/right/state",
        "/dex1/left/state",
        "/handgate/dex3_left/state",
        "/handgate/status",
    ] {
        assert!(topics.contains(&t), "{t} advertised: {topics:?}");
    }
    let js = channels.iter().find(|c| c["topic"] == "/joint_states").unwrap();
    let js_schema = handgate_idl::ros2msg::schema(ros2::JointState_::DDS_TYPE_NAME).unwrap();
    assert_eq!(
        (&js["encoding"], &js["schemaEncoding"], &js["schemaName"]),
        (
            &Value::from("cdr"),
            &Value::from("ros2msg"),
            &Value::from("sensor_msgs/msg/JointState")
        ),
        "{js}"
    );
    assert_eq!(js["schema"], js_schema.text, "the record crate's ros2msg text");
    let subscribed = next(&py, "SUBSCRIBED");
    assert!(
        subscribed.get("/joint_states").is_some() && subscribed.get("/dex3/left/state").is_some(),
        "{subscribed}"
    );

    // joint_states: the URDF names, as the gateway publishes them on DDS.
    let first = next_msg(&py, "/joint_states");
    let names = strings(&first["name"]);
    let want: BTreeSet<&str> = URDF_JOINTS.into_iter().collect();
    assert_eq!(
        names.iter().map(String::as_str).collect::<BTreeSet<_>>(),
        want,
        "{first}"
    );
    assert_eq!(names.len(), URDF_JOINTS.len(), "{first}");
    assert_eq!(first["trailing"], 0, "the whole payload is the message: {first}");
    let dds = node(domain);
    let mut on_dds = Latest::<ros2::JointState_>::new(&dds, "rt/joint_states", Qos::Reliable { depth: 1 });
    let published = on_dds.next(WAIT).expect("rt/joint_states on DDS");
    assert_eq!(names, published.name, "the same names, in the same order, as on DDS");
    let at = |m: &Value| {
        let i = strings(&m["name"]).iter().position(|n| n == LEFT_INDEX_0).unwrap();
        m["position"][i].as_f64().unwrap()
    };
    let start = at(&first);

    // A front's state: the Dex3 SDK's HandState, 7 motors, every byte accounted for.
    let dex3 = next_msg(&py, "/dex3/left/state");
    assert_eq!(dex3["motors"], 7, "{dex3}");
    assert_eq!(dex3["q"].as_array().map(Vec::len), Some(7), "{dex3}");
    assert_eq!(dex3["trailing"], 0, "{dex3}");
    assert_eq!(
        dex3["parsed"].as_u64().unwrap() + 4,
        dex3["bytes"].as_u64().unwrap(),
        "the payload is the encapsulation header and the message: {dex3}"
    );

    // A command through the Dex3 front moves the joint the client decodes.
    let target = -1.0_f32;
    let mut w = dds
        .writer::<hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    w.wait_matched(1, WAIT).expect("the Dex3 front's reader");
    let mut last = start;
    let moved = stream_until(&mut w, &left_index_cmd(target), WAIT, || {
        while let Ok(rest) = py.wait_line("MSG ", Duration::ZERO) {
            let m: Value = serde_json::from_str(&rest).unwrap();
            if m["topic"] == "/joint_states" {
                last = at(&m);
            }
        }
        last < start - 0.5
    });
    assert!(
        moved,
        "{LEFT_INDEX_0} stayed at {last} (from {start}) while commanding {target}\n{}",
        py.transcript()
    );
}

#[test]
fn topic_globs_choose_the_channels_commands_included() {
    let _serial = serial();
    let domain = 78;
    let profile = profile_with("foxglove-globs", "[foxglove]\nport = 0\ntopics = [\"/dex3/left/*\"]");
    let gw = Gateway::start(domain, &["--profile", &profile]);
    let url = gw.foxglove_url().unwrap();
    let py = PyProcess::spawn("foxglove_client.py", &[url, "/dex3/left/cmd".into()]).unwrap();
    let channels = next(&py, "CHANNELS");
    let mut topics: Vec<&str> = channels
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["topic"].as_str().unwrap())
        .collect();
    topics.sort_unstable();
    assert_eq!(topics, ["/dex3/left/cmd", "/dex3/left/state"], "{channels}");
    next(&py, "SUBSCRIBED");
    // A client's command reaches the command channel.
    let dds = node(domain);
    let mut w = dds
        .writer::<hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    let mut got = None;
    let seen = stream_until(&mut w, &left_index_cmd(-0.3), WAIT, || {
        if let Ok(rest) = py.wait_line("MSG ", Duration::ZERO) {
            got = Some(rest);
        }
        got.is_some()
    });
    assert!(seen, "no command on /dex3/left/cmd\n{}", py.transcript());
    let m: Value = serde_json::from_str(got.as_deref().unwrap()).unwrap();
    assert_eq!(m["topic"], "/dex3/left/cmd", "{m}");
    assert!(m["bytes"].as_u64().unwrap() > 4, "{m}");
}

#[test]
fn a_taken_port_is_a_warning_by_default_and_an_error_when_the_profile_asks() {
    let _serial = serial();
    let domain = 79;
    // The default port, taken: by this test, or already by another process (either way taken).
    let _default = TcpListener::bind(("127.0.0.1", 8765));
    let gw = Gateway::start(domain, &[]);
    let line = gw.wait_stdout("foxglove: not serving", WAIT).unwrap();
    assert!(line.contains("127.0.0.1:8765"), "{line}");
    drop(gw);

    // A profile's own [foxglove] section: the start fails, naming the address and the fix.
    let taken = TcpListener::bind(("127.0.0.1", 0)).unwrap();
    let port = taken.local_addr().unwrap().port();
    let profile = profile_with("foxglove-taken", &format!("[foxglove]\nport = {port}"));
    let err = Gateway::try_start(domain, &["--profile", &profile]).expect_err("the start fails");
    let text = err.to_string();
    assert!(
        text.contains("[foxglove]") && text.contains(&format!("127.0.0.1:{port}")) && text.contains("port"),
        "{text}"
    );
    assert!(
        matches!(err, GatewayError::Exited { .. }),
        "it exits before serving: {text}"
    );
}

/// What protects the live server from a page of a rebound domain (docs/foxglove.md,
/// "Security"): the foxglove crate has no hook to see the upgrade's `Host` or `Origin`, so such
/// a page connects and reads; the server offers no capability a client could write with, so
/// nothing it sends reaches a device.
#[test]
fn a_rebinding_page_reads_the_live_topics_but_cannot_write_anything() {
    let _serial = serial();
    let domain = 188;
    // The command channel too: the worst case, a command topic in view.
    let profile = profile_with(
        "foxglove-rebinding",
        "[foxglove]\nport = 0\ntopics = [\"/dex3/left/*\"]",
    );
    let gw = Gateway::start(domain, &["--profile", &profile]);
    let url = gw.foxglove_url().unwrap();
    let port = url.rsplit(':').next().unwrap();
    let evil = format!("evil.example:{port}");
    let py = PyProcess::spawn(
        "foxglove_client.py",
        &[
            url.clone(),
            "/dex3/left/state".into(),
            "--as-host".into(),
            "evil.example".into(),
            "--origin".into(),
            format!("http://{evil}"),
            "--try-write".into(),
            "/dex3/left/cmd".into(),
        ],
    )
    .unwrap();
    // Accepted, and it reads: the exposure docs/foxglove.md states.
    let info = next(&py, "SERVERINFO");
    assert_eq!(
        info["capabilities"],
        Value::Array(vec![]),
        "no clientPublish, parameters, services, assets, connectionGraph: {info}"
    );
    py.wait_line("WRITE_TRIED", WAIT).unwrap_or_else(|e| panic!("{e}"));
    // Every write refused by the server, in the order sent.
    let mut said = Vec::new();
    for _ in 0..3 {
        said.push(next(&py, "STATUS")["message"].as_str().unwrap_or_default().to_string());
    }
    let failure = next(&py, "SERVICE_FAILURE");
    assert!(
        said[0].contains("does not support clientPublish")
            && said[1].contains("Unknown channel")
            && said[2].contains("does not support parameters"),
        "{said:?}"
    );
    assert!(
        failure["message"]
            .as_str()
            .unwrap_or_default()
            .contains("does not support services"),
        "{failure}"
    );
    let dex3 = next_msg(&py, "/dex3/left/state");
    assert_eq!(dex3["motors"], 7, "{dex3}");
    // Nothing reached the device.
    let (_, text) = http_get(&gw.http_url().unwrap(), "/metrics");
    let m = device_metrics(&text);
    assert_eq!(
        m[&("handgate_device_commands_total".to_string(), "dex3_left".to_string())],
        0.0,
        "{text}"
    );
}

/// The subprotocol names the live server accepts (docs/foxglove.md, "Clients"), measured: a
/// client offers exactly the names a given viewer release offers, and the handshake's HTTP
/// status and chosen name are recorded (101 and a `serverInfo`, or the refusal's status).
#[test]
fn each_subprotocol_name_a_viewer_offers_is_accepted_or_refused_as_documented() {
    let _serial = serial();
    let domain = 129;
    let profile = profile_with("foxglove-subprotocols", "[foxglove]\nport = 0");
    let gw = Gateway::start(domain, &["--profile", &profile]);
    let url = gw.foxglove_url().unwrap();
    // (offered, in the viewer's order; HTTP status; the name the server chose)
    let cases: [(&str, u16, Option<&str>); 5] = [
        // Foxglove's current app, PlotJuggler 3.16 and later, foxglove_bridge 3.x clients.
        ("foxglove.sdk.v1", 101, Some("foxglove.sdk.v1")),
        // Foxglove Studio 1.x (open source), Lichtblick up to 1.21, @foxglove/ws-protocol.
        ("foxglove.websocket.v1", 400, None),
        // Lichtblick 1.22 and later: both names, the old one first.
        ("foxglove.websocket.v1,foxglove.sdk.v1", 101, Some("foxglove.sdk.v1")),
        // The foxglove crate's schema-table variant.
        ("foxglove.sdk.v1.1", 101, Some("foxglove.sdk.v1.1")),
        ("", 400, None),
    ];
    for (offered, status, chosen) in cases {
        let py = PyProcess::spawn(
            "foxglove_client.py",
            &[
                url.clone(),
                "/handgate/status".into(),
                "--subprotocols".into(),
                offered.into(),
                "--seconds".into(),
                "20".into(),
            ],
        )
        .unwrap();
        let hs = next(&py, "HANDSHAKE");
        eprintln!("offered [{offered}] -> HTTP {} chose {}", hs["status"], hs["chosen"]);
        assert_eq!(hs["status"], status, "[{offered}]: {hs}\n{}", py.transcript());
        assert_eq!(hs["chosen"].as_str(), chosen, "[{offered}]: {hs}");
        if status == 101 {
            let info = next(&py, "SERVERINFO");
            assert_eq!(info["subprotocol"].as_str(), chosen, "{info}");
            assert_eq!(info["name"], "handgate default", "{info}");
        }
    }
}
