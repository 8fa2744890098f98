//! Two DDS sides in one process (issue #28, part 1): a robot PC whose gateway reaches its hand
//! service on the robot's internal network (`[dds]`: domain 0, 192.168.123.0/24) and serves its
//! clients on the lab's (`[export]`: another domain, another interface). An official-SDK client
//! on the lab network drives the hand; a packet capture on each network shows that nothing of
//! the export side's domain crosses the robot's network and nothing of the robot's domain
//! crosses the lab's; `handgate status` on the lab side shows both sides.
//!
//! Three network namespaces made by the test (robot, robot PC, operator) joined by two veth
//! pairs; needs root, elsewhere it says why and passes without running. Nothing leaves the
//! namespaces; they are deleted when the test ends. DDS domains 0 (inside the robot's
//! namespaces only) and 221.

use std::time::Duration;

use handgate_tests::{handgate_bin, handgate_cmd, in_netns, Capture, Emulation, Gateway, Hosts, PyProcess};
use serde_json::Value;

const ROBOT_DOMAIN: u32 = 0;
const LAB_DOMAIN: u32 = 221;

#[test]
fn the_clients_side_and_the_robots_side_stay_on_their_networks() {
    let Some(h) = Hosts::for_test("export", "ex", 3) else {
        return;
    };
    let (robot, pc, op) = (0, 1, 2);
    // The robot's internal network, as on every G1, and the lab's.
    let internal = h.link(0, robot, pc, "192.168.123", (161, 164)).unwrap();
    let lab = h.link(1, pc, op, "10.228.7", (2, 100)).unwrap();
    let ns = |i: usize| Some(h.ns[i].as_str());

    // A capture on each network for the whole run.
    let on_robot = Capture::start(&h.ns[robot], &internal.a_if, Duration::from_secs(300));
    let on_lab = Capture::start(&h.ns[op], &lab.b_if, Duration::from_secs(300));

    // The robot's Dex1 service, on its internal network.
    let service = Emulation::start_in(
        ns(robot),
        &["dex1", "--side", "left", "--domain", "0", "--interface", &internal.a_if],
    );
    // The robot PC's gateway: the hand through the service on the internal network, its
    // clients on the lab's.
    let profile = std::env::temp_dir().join(format!("handgate-export-{}.toml", std::process::id()));
    std::fs::write(
        &profile,
        "name = \"lab-robot\"\n\
         [export]\nnamespace = \"robot_a\"\n\
         [[devices]]\nname = \"left\"\nkind = \"dex1\"\nside = \"left\"\nbackend = \"dds\"\n\
         [[fronts]]\nkind = \"dex1\"\ndevice = \"left\"\n\
         [[fronts]]\nkind = \"canonical\"\ndevice = \"left\"\n",
    )
    .unwrap();
    let profile_arg = profile.display().to_string();
    let lab_domain = LAB_DOMAIN.to_string();
    let gw = Gateway::spawn_in(
        ns(pc),
        ROBOT_DOMAIN,
        &[
            "--profile",
            &profile_arg,
            "--export-domain",
            &lab_domain,
            "--export-interface",
            &lab.a_if,
        ],
        Some(&internal.b_if),
    )
    .expect("start the gateway");
    gw.wait_stdout("handgate serving", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("{e}"));

    // An xr_teleoperate-style Dex1 client on the operator's machine, given only the robot's
    // domain: it closes the gripper to 2 rad through the robot's hand service.
    let client = PyProcess::spawn_in(
        ns(op),
        "e2e_xr_dex1.py",
        &[lab_domain.clone(), "2.0".into(), lab.b_if.clone()],
    )
    .unwrap();
    let done = client
        .wait_line("DONE ", Duration::from_secs(45))
        .unwrap_or_else(|e| panic!("{e}\ngateway:\n{}", gw.transcript()));
    let done: Value = serde_json::from_str(done.trim_start_matches("DONE ")).unwrap();
    assert!(done["samples"].as_u64().unwrap() > 0, "{done}");

    // `handgate status` on the lab network names both sides and the namespace.
    let out = in_netns(ns(op), &handgate_bin())
        .args(["status", "--domain", &lab_domain, "--interface", &lab.b_if])
        .args(["--namespace", "robot_a", "--once", "--timeout", "10"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    let sides = format!(
        "namespace /robot_a  devices: domain 0, interface {}  clients (export): domain {LAB_DOMAIN}, interface {}",
        internal.b_if, lab.a_if
    );
    assert!(text.contains(&sides), "{text}");

    // `handgate doctor` on the robot PC looks at each side: the fronts' clients on the lab
    // network, the robot's hand service on the internal one.
    let out = handgate_cmd(ns(pc))
        .args([
            "doctor",
            "--profile",
            &profile_arg,
            "--domain",
            "0",
            "--interface",
            &internal.b_if,
        ])
        .args(["--export-domain", &lab_domain, "--export-interface", &lab.a_if])
        .args(["--no-scan", "--seconds", "2"])
        .output()
        .unwrap();
    let doctor = String::from_utf8_lossy(&out.stdout);
    let (clients_side, devices_side) = doctor
        .split_once("handgate doctor: profile lab-robot, DDS domain 0 (devices' side)")
        .unwrap_or_else(|| panic!("no devices' side: {doctor}"));
    assert!(
        clients_side.starts_with(&format!(
            "handgate doctor: profile lab-robot, DDS domain {LAB_DOMAIN} (export side: fronts, status)"
        )),
        "{doctor}"
    );
    assert!(
        clients_side.contains("handgate already serving on domain 221"),
        "{doctor}"
    );
    assert!(
        devices_side.contains(&format!("1 matched reader(s): process handgate (pid {})", service.id())),
        "the robot's service found on the internal network: {doctor}"
    );
    assert!(
        devices_side.contains("handgate already serving, its devices on domain 0"),
        "{doctor}"
    );
    assert!(
        !doctor.contains("PROBLEM foreign writer"),
        "the gateway's own device is not foreign: {doctor}"
    );

    // Each network carried its own side and nothing of the other's: the lab's domain never
    // on the robot's network, the robot's never on the lab's, and no participant (the
    // gateway has one per side) sending on both.
    let robot_net = on_robot.finish();
    let lab_net = on_lab.finish();
    assert!(
        robot_net.on_domain(ROBOT_DOMAIN) > 0,
        "the gateway talked to the service: {robot_net:?}"
    );
    assert!(
        lab_net.on_domain(LAB_DOMAIN) > 0,
        "the client talked to the gateway: {lab_net:?}"
    );
    assert_eq!(
        robot_net.on_domain(LAB_DOMAIN),
        0,
        "the lab's domain on the robot's network: {robot_net:?}"
    );
    assert_eq!(
        lab_net.on_domain(ROBOT_DOMAIN),
        0,
        "the robot's domain on the lab network: {lab_net:?}"
    );
    assert!(
        robot_net.participants.len() >= 2 && lab_net.participants.len() >= 2,
        "{robot_net:?} {lab_net:?}"
    );
    let both: Vec<_> = robot_net.participants.intersection(&lab_net.participants).collect();
    assert!(both.is_empty(), "participants sending on both networks: {both:?}");
    let _ = std::fs::remove_file(profile);
}
