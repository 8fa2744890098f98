//! The gateway's discovery diagnostics through the real binary (issue #14; docs/discovery.md),
//! with clients made by the official SDK (`tests/python/discovery_peer.py`): a wrong-type
//! client and a near-miss topic are reported with their fixes in `handgate status --once` and
//! the status topic, a matched client shows up with its pid, and another process writing a
//! front's state topic stops `handgate run` (or, with `[dds] foreign_state_writers = "warn"`,
//! is flagged). DDS domains 135–138 (docs/development.md).

use std::process::Command;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{emulated_device, handgate_bin, node, poll, temp_profile, Gateway, Latest, PyProcess};

const DEADLINE: Duration = Duration::from_secs(30);

/// An emulated Dex1 (go front) and Dex3 on the left, on their standard topics.
fn profile(name: &str, extra_dds: &str) -> std::path::PathBuf {
    let text = format!(
        "name = \"{name}\"\n[dds]\n{extra_dds}\n{}{}[[fronts]]\nkind = \"dex1\"\ndevice = \"dex1_left\"\nvariant = \"go\"\n\n[[fronts]]\nkind = \"dex3\"\ndevice = \"dex3_left\"\n",
        emulated_device("dex1_left", "dex1", "left"),
        emulated_device("dex3_left", "dex3", "left"),
    );
    temp_profile("discovery-diag", name, &text)
}

/// The SDK peer with `endpoints` (`--pub TOPIC=TYPE` / `--sub ...`), kept until dropped;
/// returns it with its pid.
fn peer(domain: u32, endpoints: &[&str]) -> (PyProcess, u32) {
    let mut args = vec![
        "--domain".to_string(),
        domain.to_string(),
        "--hold".into(),
        "--timeout".into(),
        "120".into(),
    ];
    args.extend(endpoints.iter().map(|s| s.to_string()));
    let p = PyProcess::spawn("discovery_peer.py", &args).expect("SDK peer starts");
    let pid: u32 = p
        .wait_line("READY ", DEADLINE)
        .expect("SDK peer ready")
        .trim()
        .parse()
        .expect("pid");
    (p, pid)
}

/// `handgate status --once --domain D` output.
fn status_once(domain: u32) -> String {
    let out = Command::new(handgate_bin())
        .args(["status", "--once", "--domain", &domain.to_string(), "--timeout", "5"])
        .output()
        .expect("handgate status runs");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn diagnostic<'a>(s: &'a hg::GatewayStatus_, owner: &str, kind: &str) -> Option<&'a hg::Diagnostic_> {
    s.diagnostics.iter().find(|d| d.owner == owner && d.kind == kind)
}

#[test]
fn wrong_type_and_near_miss_clients_are_reported_with_their_fix_and_a_matched_client_with_its_pid() {
    const DOMAIN: u32 = 135;
    let gw = Gateway::start(DOMAIN, &["--profile", profile("diag", "").to_str().unwrap()]);
    let (_peer, pid) = peer(
        DOMAIN,
        &[
            // The seed-spec hg HandCmd_ on a go Dex1 front's command topic.
            "--pub",
            "rt/dex1/left/cmd=unitree_hg/HandCmd_",
            // The Dex3 command topic without its rt/ prefix.
            "--pub",
            "dex3/left/cmd=unitree_hg/HandCmd_",
            // A client the Dex3 front matches.
            "--sub",
            "rt/dex3/left/state=unitree_hg/HandState_",
        ],
    );
    let n = node(DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let s = poll(DEADLINE, || {
        let s = status.update()?;
        let wanted = diagnostic(s, "front dex1_left", "type_mismatch").is_some()
            && diagnostic(s, "front dex3_left", "near_miss_topic").is_some()
            && s.endpoints
                .iter()
                .any(|e| e.topic == "rt/dex3/left/state" && e.matched == 1);
        wanted.then(|| s.clone())
    })
    .unwrap_or_else(|| {
        panic!(
            "status never reported the three clients: {:?}\n{}",
            status.update(),
            gw.transcript()
        )
    });

    let t = diagnostic(&s, "front dex1_left", "type_mismatch").unwrap();
    assert_eq!(t.topic, "rt/dex1/left/cmd");
    assert!(t.detail.contains("unitree_hg::msg::dds_::HandCmd_"), "{t:?}");
    assert!(t.fix.contains("set variant = \"hg\" on front dex1_left"), "{t:?}");
    let nm = diagnostic(&s, "front dex3_left", "near_miss_topic").unwrap();
    assert_eq!(nm.topic, "rt/dex3/left/cmd");
    assert!(nm.detail.contains("missing the rt/ prefix"), "{nm:?}");
    assert!(nm.fix.contains("\"rt/dex3/left/cmd\""), "{nm:?}");
    let matched = s
        .endpoints
        .iter()
        .find(|e| e.owner == "front dex3_left" && e.topic == "rt/dex3/left/state")
        .unwrap();
    assert_eq!((matched.role.as_str(), matched.matched), ("writer", 1));
    assert!(matched.who[0].contains(&format!("(pid {pid})")), "{matched:?}");
    // The emulated devices' in-process peers are their counterparts: no "no service".
    assert!(
        !s.diagnostics.iter().any(|d| d.kind == "no_counterpart"),
        "{:?}",
        s.diagnostics
    );
    assert!(s
        .endpoints
        .iter()
        .filter(|e| e.owner == "device dex1_left")
        .all(|e| e.matched >= 1 && e.who.iter().all(|w| w.starts_with("this process ("))));

    // The same in `handgate status --once`.
    let text = status_once(DOMAIN);
    assert!(
        text.contains("front dex1_left rt/dex1/left/cmd [type_mismatch]")
            && text.contains(
                "fix: the client speaks the seed-spec unitree_hg variant: set variant = \"hg\" on front dex1_left"
            ),
        "{text}"
    );
    assert!(
        text.contains("front dex3_left rt/dex3/left/cmd [near_miss_topic]"),
        "{text}"
    );
    assert!(text.contains(&format!("process python (pid {pid})")), "{text}");

    // Logged once, not once per snapshot.
    let log = gw.transcript();
    assert_eq!(
        log.matches("discovery: 1 writer(s) on rt/dex1/left/cmd use type")
            .count(),
        1,
        "{log}"
    );
}

#[test]
fn a_go_client_on_a_dex3_front_is_told_where_it_belongs() {
    const DOMAIN: u32 = 136;
    let _gw = Gateway::start(DOMAIN, &["--profile", profile("diag-go", "").to_str().unwrap()]);
    let (_peer, _) = peer(DOMAIN, &["--pub", "rt/dex3/left/cmd=unitree_go/MotorCmds_"]);
    let n = node(DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let d = poll(DEADLINE, || {
        diagnostic(status.update()?, "front dex3_left", "type_mismatch").cloned()
    })
    .expect("type mismatch reported");
    assert!(d.detail.contains("unitree_go::msg::dds_::MotorCmds_"), "{d:?}");
    assert!(d.fix.contains("point it at a dex1 front"), "{d:?}");
}

#[test]
fn a_foreign_state_writer_stops_the_start_unless_the_profile_says_warn() {
    const DOMAIN: u32 = 137;
    // Another process (the SDK) already writes the Dex1 front's state topic.
    let (_peer, pid) = peer(DOMAIN, &["--pub", "rt/dex1/left/state=unitree_go/MotorStates_"]);
    let mut gw = Gateway::spawn(
        DOMAIN,
        &["--profile", profile("diag-refuse", "").to_str().unwrap()],
        None,
    )
    .expect("handgate spawns");
    let st = gw
        .wait_exit(DEADLINE)
        .unwrap_or_else(|| panic!("handgate kept running:\n{}", gw.transcript()));
    assert!(!st.success(), "{}", gw.transcript());
    let t = gw.transcript();
    assert!(
        t.contains("front dex1_left: rt/dex1/left/state already has a writer in another process")
            && t.contains(&format!("(pid {pid})"))
            && t.contains("foreign_state_writers = \"warn\""),
        "{t}"
    );
    assert!(!t.contains("handgate serving"), "{t}");

    // With the warn key it starts, and status flags the other writer.
    const WARN_DOMAIN: u32 = 138;
    let (_peer2, pid2) = peer(WARN_DOMAIN, &["--pub", "rt/dex1/left/state=unitree_go/MotorStates_"]);
    let gw = Gateway::start(
        WARN_DOMAIN,
        &[
            "--profile",
            profile("diag-warn", "foreign_state_writers = \"warn\"")
                .to_str()
                .unwrap(),
        ],
    );
    let n = node(WARN_DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let d = poll(DEADLINE, || {
        diagnostic(status.update()?, "front dex1_left", "foreign_writer").cloned()
    })
    .unwrap_or_else(|| panic!("foreign writer not flagged\n{}", gw.transcript()));
    assert_eq!(d.topic, "rt/dex1/left/state");
    assert!(d.detail.contains(&format!("(pid {pid2})")), "{d:?}");
    assert!(d.fix.contains("stop the other one"), "{d:?}");
}
