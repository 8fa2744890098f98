//! Two hosts, for real (issue #14): two network namespaces joined by a veth pair, the gateway
//! in one (its DDS bound to its veth, `dds.interface`), an official-SDK client in the other,
//! the client driving a device across the link; then `handgate doctor` on the client's host,
//! pointed at an interface that host does not have, says so.
//!
//! Needs root (network namespaces); elsewhere it says why and passes without running. Traffic
//! stays on the veth pair the test made (no route to the machine's own interfaces); the
//! namespaces are deleted when the test ends. DDS domain 181.

use std::time::Duration;

use handgate_tests::{run_doctor, Gateway, NetNs, NetNsError, PyProcess};
use serde_json::Value;

const DOMAIN: u32 = 181;

fn hosts() -> Option<NetNs> {
    match NetNs::pair("2h") {
        Ok(n) => Some(n),
        Err(e @ NetNsError::NotRoot(_)) => {
            eprintln!("SKIPPED two_hosts: {e}; run `cargo test -p handgate-tests --test two_hosts` as root");
            None
        }
        Err(e) => panic!("could not make the two test hosts: {e}"),
    }
}

#[test]
fn an_sdk_client_on_another_host_drives_a_device_across_the_link() {
    let Some(net) = hosts() else { return };
    let [(gw_ns, gw_if, gw_addr), (cl_ns, cl_if, _)] = &net.hosts;

    // The default fleet (emulated Dex3 pair behind the USB protocol, Dex1 pair) on host A,
    // bound to its veth as a robot PC's gateway binds eth0.
    let gw = Gateway::spawn_in(Some(gw_ns), DOMAIN, &[], Some(gw_if)).expect("start the gateway in its namespace");
    gw.wait_stdout("handgate serving", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("{e}"));

    // xr_teleoperate's Dex3 start-up and stream, on host B, bound to its own veth.
    let args = ["--domain", &DOMAIN.to_string(), "--interface", cl_if, "--timeout", "30"].map(String::from);
    let client = PyProcess::spawn_in(Some(cl_ns), "xr_dex3_client.py", &args).expect("start the client");
    let waited = client
        .wait_line("WAITED ", Duration::from_secs(45))
        .unwrap_or_else(|e| panic!("{e}\ngateway:\n{}", gw.transcript()));
    let waited: Value = serde_json::from_str(waited.trim_start_matches("WAITED ")).unwrap();
    assert_eq!(
        waited["nonzero"], true,
        "the client on host B never received the gateway's state from host A ({gw_addr}): {waited}"
    );
    let result = client.wait_line("RESULT ", Duration::from_secs(45)).unwrap();
    let result: Value = serde_json::from_str(result.trim_start_matches("RESULT ")).unwrap();
    assert_eq!(
        result["converged"], true,
        "the devices on host A did not reach the targets the client on host B sent: {result}"
    );

    // `handgate doctor` on host B. Pointed at eth0, which host B does not have (the usual
    // copy of a robot PC's profile onto a laptop), it says so and names the interface it has.
    let (code, out) = doctor_in(cl_ns, &["--interface", "eth0"]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("PROBLEM interface eth0 does not exist on this host"),
        "{out}"
    );
    let fix = out
        .lines()
        .find(|l| l.contains("fix: set dds.interface in the profile (or --interface) to one of: "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        fix.contains(cl_if.as_str()),
        "the fix names host B's veth {cl_if}: {out}"
    );

    // On host B's own interface, with an idle SDK client there, it finds the gateway on host
    // A at host A's address, and the client matched.
    let idle = PyProcess::spawn_in(
        Some(cl_ns),
        "doctor_client.py",
        &[
            "--domain",
            &DOMAIN.to_string(),
            "--interface",
            cl_if,
            "--pub",
            "rt/dex3/left/cmd=unitree_hg/HandCmd_",
            "--sub",
            "rt/dex3/left/state=unitree_hg/HandState_",
        ]
        .map(String::from),
    )
    .expect("start the idle client");
    idle.wait_line("READY", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("{e}\n{}", idle.transcript()));
    let (code, out) = doctor_in(cl_ns, &["--interface", cl_if]);
    let serving = out
        .lines()
        .find(|l| l.contains("handgate already serving on domain 181: process handgate"))
        .unwrap_or_else(|| panic!("{out}\ngateway:\n{}", gw.transcript()));
    assert!(serving.contains(gw_addr.as_str()), "host A's address {gw_addr}: {out}");
    assert!(out.contains("11 of this profile's 11 front state topics"), "{out}");
    assert!(!out.contains("foreign writer"), "{out}");
    let state = out
        .lines()
        .find(|l| l.starts_with("  rt/dex3/left/state "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        state.contains("1 matched reader(s)") && state.contains(&format!("(pid {})", idle.id())),
        "{out}"
    );
    assert_eq!(code, 0, "{out}");
}

/// `handgate doctor --domain 181 --no-scan --no-sweep --seconds 2 <args>` in namespace `ns`:
/// exit code and output.
fn doctor_in(ns: &str, args: &[&str]) -> (i32, String) {
    let domain = DOMAIN.to_string();
    let mut all = vec!["--domain", &domain, "--no-scan", "--no-sweep", "--seconds", "2"];
    all.extend_from_slice(args);
    run_doctor(Some(ns), &all)
}
