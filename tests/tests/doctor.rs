//! `handgate doctor` through the real binary, against clients made with the official
//! unitree_sdk2py (`tests/python/doctor_client.py`). DDS domains 140–149, 83 and 108 (the DDS
//! Security section's test) (docs/development.md); every domain scan stays inside 144–145.

use std::time::Duration;

use handgate_tests::{emulated_device, interop_interface, run_doctor, temp_profile, Gateway, PyProcess};

/// How long the doctor listens in these tests (its own default is 3 s).
const LISTEN: &str = "2";

/// Runs `handgate doctor <args>` (plus `--interface` from `HANDGATE_INTEROP_IFACE` unless the
/// test names one) and returns its exit code and stdout (stderr appended).
fn doctor(args: &[&str]) -> (i32, String) {
    let iface = interop_interface().filter(|_| !args.contains(&"--interface"));
    doctor_on(args, iface.as_deref())
}

/// `handgate doctor <args> [--interface <interface>]`: exit code and output.
fn doctor_on(args: &[&str], interface: Option<&str>) -> (i32, String) {
    let mut all = vec!["--seconds", LISTEN];
    all.extend_from_slice(args);
    if let Some(iface) = interface {
        all.extend(["--interface", iface]);
    }
    run_doctor(None, &all)
}

/// A `doctor_client.py` on `domain` with `args`, once its endpoints exist.
fn client(domain: u32, args: &[&str]) -> PyProcess {
    let mut a = vec!["--domain".to_string(), domain.to_string()];
    if let Some(iface) = interop_interface() {
        a.extend(["--interface".to_string(), iface]);
    }
    a.extend(args.iter().map(|s| s.to_string()));
    let p = PyProcess::spawn("doctor_client.py", &a).expect("doctor_client.py starts");
    p.wait_line("READY", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("doctor_client.py not ready: {e}\n{}", p.transcript()));
    p
}

/// One emulated Dex1 on the left, served by a Dex1 front pinned to the `go` variant.
fn dex1_go_profile() -> std::path::PathBuf {
    temp_profile(
        "doctor",
        "dex1-go",
        &format!(
            "name = \"dex1-go\"\n{}[[fronts]]\nkind = \"dex1\"\ndevice = \"dex1_left\"\nvariant = \"go\"\n",
            emulated_device("dex1_left", "dex1", "left")
        ),
    )
}

#[test]
fn nothing_running_is_no_client_and_service_not_found() {
    let (code, out) = doctor(&["--domain", "140", "--no-scan", "--no-sweep"]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("rt/dex3/left/cmd (reader of unitree_hg::msg::dds_::HandCmd_): no writer"),
        "{out}"
    );
    assert!(
        out.contains("PROBLEM no client on any of the 9 front(s) on domain 140"),
        "{out}"
    );
    assert!(out.contains("CycloneDDS selected: "), "{out}");
    // A profile with DDS-client devices: their service is missing.
    let (code, out) = doctor(&[
        "--profile",
        "g1-dex3",
        "--domain",
        "140",
        "--interface",
        "lo",
        "--no-scan",
        "--no-sweep",
    ]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("PROBLEM service not found for device left_hand"), "{out}");
    assert!(out.contains("CycloneDDS selected: lo"), "{out}");
}

#[test]
fn a_matched_client_is_named_and_exits_0() {
    let c = client(
        141,
        &[
            "--pub",
            "rt/dex3/left/cmd=unitree_hg/HandCmd_",
            "--sub",
            "rt/dex3/left/state=unitree_hg/HandState_",
        ],
    );
    let (code, out) = doctor(&["--domain", "141", "--no-scan"]);
    assert_eq!(code, 0, "{out}");
    let pid = format!("(pid {})", c.id());
    let cmd_line = out
        .lines()
        .find(|l| l.starts_with("  rt/dex3/left/cmd "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        cmd_line.contains("1 matched writer(s)") && cmd_line.contains(&pid),
        "{out}"
    );
    let state_line = out
        .lines()
        .find(|l| l.starts_with("  rt/dex3/left/state "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        state_line.contains("1 matched reader(s)") && state_line.contains(&pid),
        "{out}"
    );
    // The SDK publisher exists but writes nothing: said, not a problem.
    assert!(
        out.contains("note: 1 matched writer(s) on rt/dex3/left/cmd sent no sample in 2.0 s"),
        "{out}"
    );
    assert!(out.contains("doctor: nothing wrong found"), "{out}");
}

#[test]
fn a_wrong_type_client_gets_the_variant_fix() {
    // hg HandCmd_ on a Dex1 front the profile pins to `go`.
    let c = client(
        142,
        &[
            "--pub",
            "rt/dex1/left/cmd=unitree_hg/HandCmd_",
            "--sub",
            "rt/dex1/left/state=unitree_hg/HandState_",
        ],
    );
    let go = dex1_go_profile();
    let (code, out) = doctor(&["--domain", "142", "--no-scan", "--profile", go.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    let problem = out
        .lines()
        .position(|l| l.contains("PROBLEM wrong type") && l.contains("rt/dex1/left/cmd"))
        .unwrap_or_else(|| panic!("{out}"));
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[problem].contains(&format!("(pid {})", c.id())), "{out}");
    assert!(
        lines[problem + 1].contains("fix:") && lines[problem + 1].contains("variant = \"hg\" on front dex1_left"),
        "{out}"
    );

    // The default profile's Dex1 fronts are `auto`: the same client is served, not a problem.
    let (code, out) = doctor(&["--domain", "142", "--no-scan"]);
    assert_eq!(code, 0, "{out}");
    let cmd_line = out
        .lines()
        .find(|l| l.starts_with("  rt/dex1/left/cmd "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        cmd_line.contains("or unitree_hg::msg::dds_::HandCmd_") && cmd_line.contains(&format!("(pid {})", c.id())),
        "{out}"
    );
    assert!(!out.contains("PROBLEM wrong type"), "{out}");
}

#[test]
fn a_near_miss_topic_client_gets_the_right_topic() {
    let c = client(143, &["--pub", "dex3/left/cmd=unitree_hg/HandCmd_"]);
    let (code, out) = doctor(&["--domain", "143", "--no-scan"]);
    assert_eq!(code, 1, "{out}");
    let lines: Vec<&str> = out.lines().collect();
    let problem = lines
        .iter()
        .position(|l| l.contains("PROBLEM near-miss topic") && l.contains("\"dex3/left/cmd\""))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(lines[problem].contains(&format!("(pid {})", c.id())), "{out}");
    assert!(
        lines[problem + 1].contains("fix: correct the topic name in the client to \"rt/dex3/left/cmd\""),
        "{out}"
    );
    drop(c);

    // The actuator interface (older xr_teleoperate) on a profile whose Dex1 fronts are `go`:
    // a related topic, named with the variant that serves it.
    let c = client(
        143,
        &[
            "--pub",
            "rt/unitree_actuator/cmd=unitree_go/MotorCmds_",
            "--sub",
            "rt/unitree_actuator/state=unitree_go/MotorStates_",
        ],
    );
    let go = dex1_go_profile();
    let (code, out) = doctor(&["--domain", "143", "--no-scan", "--profile", go.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    let lines: Vec<&str> = out.lines().collect();
    let problem = lines
        .iter()
        .position(|l| l.contains("PROBLEM near-miss topic") && l.contains("\"rt/unitree_actuator/cmd\""))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(lines[problem].contains(&format!("(pid {})", c.id())), "{out}");
    assert!(lines[problem + 1].contains("variant = \"actuator\""), "{out}");

    // The default profile's `auto` fronts serve that pair once the client is discovered: a
    // note, nothing wrong.
    let (code, out) = doctor(&["--domain", "143", "--no-scan"]);
    assert_eq!(code, 0, "{out}");
    assert!(
        out.lines()
            .any(|l| l.starts_with("  note: 1 writer(s) on \"rt/unitree_actuator/cmd\"")
                && l.contains(&format!("(pid {})", c.id()))),
        "{out}"
    );
    assert!(!out.contains("PROBLEM"), "{out}");
}

#[test]
fn clients_on_another_domain_are_found_by_the_scan() {
    let c = client(
        145,
        &[
            "--pub",
            "rt/dex3/left/cmd=unitree_hg/HandCmd_",
            "--sub",
            "rt/dex3/left/state=unitree_hg/HandState_",
        ],
    );
    let (code, out) = doctor(&["--domain", "144", "--scan", "144-145"]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("domain scan (145):"), "{out}");
    let found = out
        .lines()
        .find(|l| l.starts_with("  domain 145: "))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(found.contains(&format!("(pid {})", c.id())), "{out}");
    assert!(
        out.contains("PROBLEM your clients are on domain 145, the profile uses domain 144"),
        "{out}"
    );
    assert!(out.contains("--domain 145"), "{out}");
}

#[test]
fn a_foreign_writer_of_a_state_topic_is_a_problem() {
    // Another process publishing the state a front would serve (as the G1's resident Dex3
    // service does on rt/dex3/left/state).
    let c = client(146, &["--pub", "rt/dex3/left/state=unitree_hg/HandState_"]);
    let (code, out) = doctor(&["--domain", "146", "--no-scan"]);
    assert_eq!(code, 1, "{out}");
    let lines: Vec<&str> = out.lines().collect();
    let problem = lines
        .iter()
        .position(|l| l.contains("PROBLEM foreign writer") && l.contains("rt/dex3/left/state"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(lines[problem].contains(&format!("(pid {})", c.id())), "{out}");
    assert!(
        lines[problem + 1].contains("fix: two sources publish this topic"),
        "{out}"
    );
}

#[test]
fn interfaces_nonexistent_loopback_only_and_the_sweep() {
    // One domain, one step after the other: each step must not see the others' clients.
    let (code, out) = doctor(&["--domain", "149", "--interface", "nosuch0", "--no-scan", "--no-sweep"]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("PROBLEM interface nosuch0 does not exist on this host"),
        "{out}"
    );
    assert!(
        out.contains("fix: set dds.interface in the profile (or --interface) to one of: "),
        "{out}"
    );

    // lo exists everywhere; with it alone nothing beyond this host is reachable.
    let (code, out) = doctor(&["--domain", "149", "--interface", "lo", "--no-scan"]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("CycloneDDS selected: lo"), "{out}");
    let others = handgate_adapters::netif::list()
        .expect("interfaces")
        .into_iter()
        .any(|i| !i.loopback && i.up && !i.addrs.is_empty());
    // Said when this host has another interface to suggest.
    assert_eq!(
        out.contains("PROBLEM DDS here uses only the loopback interface lo"),
        others,
        "{out}"
    );

    // A client on lo, the doctor on CycloneDDS's own choice: found directly, or by the
    // sweep through lo (a child doctor per other interface).
    let c = client(
        149,
        &["--interface", "lo", "--pub", "rt/dex3/left/cmd=unitree_hg/HandCmd_"],
    );
    let (_, out) = doctor_on(&["--domain", "149", "--no-scan"], None);
    let pid = format!("(pid {})", c.id());
    let direct = out.contains("1 matched writer(s)") && out.contains(&pid);
    let swept = out.contains("interface sweep (domain 149): ")
        && out.contains("lo: 1 participant(s) for this profile")
        && out.contains("PROBLEM nothing for this profile reached this host through ")
        && out.contains("but through lo it does")
        && out.contains("fix: select lo: --interface lo");
    assert!(direct || swept, "{out}");
}

#[test]
fn a_client_writing_the_old_hand_cmd_layout_is_stale() {
    let _c = client(147, &["--write-old-hand-cmd", "rt/dex3/left/cmd"]);
    let (code, out) = doctor(&["--domain", "147", "--no-scan"]);
    assert_eq!(code, 1, "{out}");
    assert!(
        out.contains("PROBLEM stale HandCmd_ layout on rt/dex3/left/cmd (front dex3_left)")
            && out.contains("of 200 bytes: HandCmd_ without reserve[4]")
            && out.contains("before December 2024"),
        "{out}"
    );
}

#[test]
fn a_running_gateway_is_named_and_its_writers_are_not_foreign() {
    let gw = Gateway::start(148, &[]);
    let c = client(
        148,
        &[
            "--pub",
            "rt/dex3/left/cmd=unitree_hg/HandCmd_",
            "--sub",
            "rt/dex3/left/state=unitree_hg/HandState_",
        ],
    );
    let (code, out) = doctor(&["--domain", "148", "--no-scan"]);
    assert!(
        out.contains(&format!(
            "handgate already serving on domain 148: process handgate (pid {})",
            gw.id()
        )),
        "{out}"
    );
    assert!(out.contains("11 of this profile's 11 front state topics"), "{out}");
    assert!(!out.contains("foreign writer"), "{out}");
    assert!(out.contains(&format!("(pid {})", c.id())), "{out}");
    assert_eq!(code, 0, "{out}");
}

/// A hand answering on `topic` with `entries`-entry `HandState_` samples every 10 ms (on lo,
/// domain `domain`) until dropped: a test-side stand-in for another kind's service.
struct HandStateWriter {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl HandStateWriter {
    fn start(domain: u32, topic: &str, entries: usize) -> Self {
        use std::sync::atomic::{AtomicBool, Ordering};
        let node = handgate_adapters::dds::Node::new(domain, Some("lo")).expect("DDS participant");
        let mut w = node
            .writer::<handgate_idl::unitree_hg::HandState_>(topic, handgate_adapters::dds::Qos::Reliable { depth: 1 })
            .expect("writer");
        let mut msg = handgate_idl::unitree_hg::HandState_::with_sizes(entries, 0);
        msg.motor_state.iter_mut().for_each(|m| m.q = 0.1);
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = std::thread::spawn(move || {
            let _node = node;
            while !s.load(Ordering::Relaxed) {
                let _ = w.write(msg.clone());
                std::thread::sleep(Duration::from_millis(10));
            }
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for HandStateWriter {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The doctor's lines about samples of another entry count on `topic`: the problem and its fix.
fn entries_problem(out: &str, topic: &str) -> (String, String) {
    let lines: Vec<&str> = out.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.contains("PROBLEM") && l.contains(&format!("sample(s) on {topic}")) && l.contains("entries"))
        .unwrap_or_else(|| panic!("no entry-count problem on {topic}:\n{out}"));
    (lines[at].to_string(), lines[at + 1].to_string())
}

/// A Dex5-1 answering on a Dex3-1's topics (20 entries where 7 are expected) is named as a
/// hand of kind dex5 for a g1-dex3 profile; a Dex3-1 answering on the Dex5's topics (7
/// where 20 are expected) as a hand of kind dex3 for a g1-dex5 profile. Domain 83.
#[test]
fn another_hand_on_a_hands_topics_is_named_by_its_entry_count() {
    // (profile, the topic the other hand answers on, its entries and kind, the entries expected)
    for (profile, topic, entries, kind, expected) in [
        ("g1-dex3", "rt/dex3/left/state", 20, "dex5", 7),
        ("g1-dex5", "rt/dex5/left/state", 7, "dex3", 20),
    ] {
        let _other = HandStateWriter::start(83, topic, entries);
        let (code, out) = doctor(&[
            "--profile",
            profile,
            "--domain",
            "83",
            "--interface",
            "lo",
            "--no-scan",
            "--no-sweep",
        ]);
        assert_eq!(code, 1, "{out}");
        let (what, fix) = entries_problem(&out, topic);
        let want = format!("(device left_hand) carry {entries} entries of HandState_ where {expected} are expected");
        assert!(what.contains(&want), "{profile}: {out}");
        let want = format!("fix: a hand of kind {kind} carries {entries}: set that kind for device left_hand");
        assert!(fix.contains(&want), "{profile}: {out}");
    }
}

// DDS Security (docs/security-keystore.md, "The doctor's checks"): identities made by
// `handgate security`, checked by the doctor's security section. DDS domain 108 (the doctor
// joins it while it looks; `security_keystore.rs` uses it too, in another test binary).

/// `handgate security ARGS` succeeds.
fn keystore_cmd(args: &[&str]) {
    let out = std::process::Command::new(handgate_tests::handgate_bin())
        .arg("security")
        .args(args)
        .output()
        .expect("handgate security runs");
    assert!(
        out.status.success(),
        "handgate security {args:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A keystore in `dir` with a gateway identity `robot_a`, an expired one `old` and a
/// revoked one `eve`, all for domain 108.
fn lab_keystore(dir: &std::path::Path) -> String {
    let _ = std::fs::remove_dir_all(dir);
    let ks = dir.to_str().unwrap().to_string();
    keystore_cmd(&["init", "--keystore", &ks]);
    for name in ["robot_a", "eve"] {
        keystore_cmd(&["issue", "--keystore", &ks, name, "--role", "gateway", "--robot", "108"]);
    }
    keystore_cmd(&[
        "issue",
        "--keystore",
        &ks,
        "old",
        "--role",
        "gateway",
        "--robot",
        "108",
        "--not-before",
        "2020-01-01T00:00:00Z",
        "--not-after",
        "2021-01-01T00:00:00Z",
    ]);
    keystore_cmd(&["revoke", "--keystore", &ks, "eve"]);
    ks
}

/// The doctor on domain 108 for a profile whose `[export.security]` is `security` (TOML
/// lines); its exit code and the lines of its DDS Security section.
fn doctor_security(name: &str, security: &str) -> (i32, Vec<String>) {
    let profile = temp_profile(
        "doctor-security",
        name,
        &format!(
            "name = \"{name}\"\n[dds]\ndomain = 108\n[export.security]\n{security}\n{}",
            emulated_device("left_hand", "dex3", "left")
        ),
    );
    let (code, out) = run_doctor(
        None,
        &[
            "--profile",
            profile.to_str().unwrap(),
            "--seconds",
            "0.5",
            "--no-scan",
            "--no-sweep",
        ],
    );
    let section: Vec<String> = out
        .lines()
        .skip_while(|l| !l.starts_with("DDS Security [export.security] on domain 108:"))
        .map(str::to_string)
        .collect();
    assert!(!section.is_empty(), "no DDS Security section in:\n{out}");
    (code, section)
}

#[test]
fn doctor_security_says_expired_revoked_and_missing() {
    let dir = std::env::temp_dir().join(format!("handgate-doctor-keystore-{}", std::process::id()));
    let ks = lab_keystore(&dir);
    let crl = format!("{ks}/public/crl.pem");

    // A good identity: every check passes.
    let (_, good) = doctor_security(
        "sec-good",
        &format!("enclave = \"{ks}/enclaves/robot_a\"\ncrl = \"{crl}\""),
    );
    assert!(!good.iter().any(|l| l.contains("PROBLEM")), "{good:#?}");
    assert!(
        good.iter().any(|l| l.contains("OK the permissions are signed by the permissions CA and grant CN=/robot_a domain 108")),
        "{good:#?}"
    );

    // Expired: the dates, and the count in the summary.
    let (code, old) = doctor_security("sec-old", &format!("enclave = \"{ks}/enclaves/old\""));
    assert_eq!(code, 1, "{old:#?}");
    assert!(
        old.iter().any(|l| l.contains(
            "PROBLEM [export.security]: the certificate expired on 2021-01-01T00:00:00Z (valid 2020-01-01T00:00:00Z to 2021-01-01T00:00:00Z)"
        )),
        "{old:#?}"
    );
    assert!(
        old.iter().any(|l| l.contains("permissions: the grant has expired")),
        "{old:#?}"
    );
    assert_eq!(old.last().map(String::as_str), Some("doctor: 2 problem(s)"), "{old:#?}");

    // Revoked by the list the profile gives.
    let (code, eve) = doctor_security("sec-eve", &format!("enclave = \"{ks}/enclaves/eve\"\ncrl = \"{crl}\""));
    assert_eq!(code, 1, "{eve:#?}");
    assert!(
        eve.iter()
            .any(|l| l.contains("PROBLEM [export.security]: the certificate (serial ")
                && l.contains("is revoked by the revocation list")),
        "{eve:#?}"
    );

    // A file given beside the enclave that is not there: named by its profile key.
    let (code, missing) = doctor_security(
        "sec-missing",
        &format!("enclave = \"{ks}/enclaves/robot_a\"\npermissions = \"{ks}/enclaves/robot_a/nope.p7s\""),
    );
    assert_eq!(code, 1, "{missing:#?}");
    assert!(
        missing.iter().any(|l| l.contains(&format!(
            "PROBLEM [export.security]: permissions: {ks}/enclaves/robot_a/nope.p7s cannot be read: No such file"
        ))),
        "{missing:#?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
