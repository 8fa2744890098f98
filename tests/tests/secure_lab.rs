//! The secured lab (issue #39, parts 1, 3 and 5; docs/security.md): a G1 whose handgate serves
//! its fronts on the lab network with DDS Security (`[export.security]`, the shipped
//! `lab-g1-dex3` profile with the robot's identity and the lab's revocation list), its Dex3
//! hand services emulated on the robot's own plain network (domain 0, as on every G1).
//!
//! - The permitted path: an operator station runs the shipped `station-dex3` profile (its
//!   devices DDS clients of the robot's fronts as the station's lab identity, its fronts the
//!   same service topics on the station's own loopback), and the xr_teleoperate-style Dex3
//!   client (unitree_sdk2py, unmodified) on the station drives the robot's hands through the
//!   secured domain; `handgate send` as the station's identity is accepted too.
//! - The refused: a participant without security (the official SDK's client streaming
//!   commands on the robot's lab domain), an identity from another CA, a read-only identity
//!   writing a command topic, a revoked identity (the robot's CRL), an expired certificate
//!   (a client whose clock says it is still valid: libfaketime). For each, the robot's left hand
//!   accepts no command (`handgate_device_commands_total` unchanged) and the robot's `/metrics`
//!   counts the refusal by its reason (the read-only identity is refused by its own access
//!   control plugin before anything reaches the robot: the client fails, naming it).
//!
//! Five network namespaces made by the test (the robot, its PC, the lab switch, the operator
//! station, a stray machine on the lab network), four veth pairs; needs root, elsewhere it says
//! why and passes without running. DDS domains 0 (inside the robot's namespaces) and 229 (the
//! robot's lab domain, inside the namespaces). The keystores are made by `handgate security`.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

use handgate_tests::{handgate_cmd, handgate_cmd_under, Emulation, Gateway, Hosts, PyProcess};
use serde_json::Value;

const LAB: u32 = 229;

const ROBOT: usize = 0;
const PC: usize = 1;
const SWITCH: usize = 2;
const STATION: usize = 3;
const STRAY: usize = 4;

/// `handgate security ARGS` (files only, on the host).
fn security(args: &[&str]) {
    let out = handgate_cmd(None).arg("security").args(args).output().unwrap();
    assert!(
        out.status.success(),
        "handgate security {}: {}{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The robot gateway's `/metrics`, read inside its PC's namespace.
fn metrics(h: &Hosts, gw: &Gateway) -> Value {
    let url = gw.http_url().unwrap();
    let probe = PyProcess::spawn_in(Some(&h.ns[PC]), "http_probe.py", &["metrics".into(), url]).unwrap();
    let line = probe.wait_line("{", Duration::from_secs(30)).unwrap();
    serde_json::from_str(&format!("{{{line}")).unwrap_or_else(|e| panic!("{e}: {line}"))
}

/// The sample of `family` whose labels contain every one of `labels` (0 when absent).
fn sample(m: &Value, family: &str, labels: &[&str]) -> f64 {
    m["samples"]
        .as_object()
        .unwrap()
        .iter()
        .find(|(k, _)| k.starts_with(&format!("{family}{{")) && labels.iter().all(|l| k.contains(l)))
        .and_then(|(_, v)| v.as_f64())
        .unwrap_or(0.0)
}

/// Commands robot A's left hand accepted.
fn commands(m: &Value) -> f64 {
    sample(m, "handgate_device_commands_total", &["device=\"left_hand\""])
}

/// Participants robot A's lab domain refused for `reason`.
fn refused(m: &Value, reason: &str) -> f64 {
    let domain = format!("domain=\"{LAB}\"");
    let reason = format!("reason=\"{reason}\"");
    sample(
        m,
        "handgate_dds_security_refused_participants_total",
        &[domain.as_str(), reason.as_str()],
    )
}

/// Polls robot A's `/metrics` until `ok` holds (deadline `within`); the last reading.
fn wait_metrics(h: &Hosts, gw: &Gateway, within: Duration, what: &str, ok: impl Fn(&Value) -> bool) -> Value {
    let start = Instant::now();
    loop {
        let m = metrics(h, gw);
        if ok(&m) {
            return m;
        }
        assert!(
            start.elapsed() < within,
            "{what}: not within {within:?}; robot's log:\n{}",
            gw.transcript()
        );
    }
}

/// `handgate send left_hand` to robot A from the stray machine, as the identity in `enclave`
/// (none: plain DDS), closing the hand for 2 s; `prefix`: a program to run it under.
fn send_from_stray(h: &Hosts, stray_if: &str, enclave: Option<&Path>, prefix: &[&str]) -> Output {
    let mut cmd = handgate_cmd_under(Some(&h.ns[STRAY]), prefix);
    let lab = LAB.to_string();
    cmd.args([
        "send",
        "left_hand",
        "--domain",
        &lab,
        "--interface",
        stray_if,
        "--namespace",
        "robot_a",
        "--closure",
        "1",
        "--hold",
        "2",
        "--timeout",
        "4",
    ]);
    if let Some(e) = enclave {
        cmd.arg("--enclave").arg(e);
    }
    cmd.output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A refused client: it fails, robot A's left hand took no command meanwhile, and the robot
/// counted it under `reason` (`None`: refused before reaching the robot).
fn assert_refused(h: &Hosts, gw: &Gateway, what: &str, out: &Output, reason: Option<&str>, before: &Value) {
    assert!(!out.status.success(), "{what}: the client succeeded:\n{}", text(out));
    let after = match reason {
        Some(r) => wait_metrics(
            h,
            gw,
            Duration::from_secs(20),
            &format!("{what}: counted as {r}; client:\n{}", text(out)),
            |m| refused(m, r) > refused(before, r),
        ),
        None => metrics(h, gw),
    };
    assert_eq!(
        commands(&after),
        commands(before),
        "{what}: robot A's left hand accepted commands; client:\n{}",
        text(out)
    );
    eprintln!(
        "{what}: refused ({}), robot A's left hand accepted no command ({} before and after)",
        reason.map_or_else(
            || "by the client's own access control".to_string(),
            |r| format!("counted as {r}: {} -> {}", refused(before, r), refused(&after, r))
        ),
        commands(before)
    );
}

#[test]
fn only_the_labs_identities_command_a_hand() {
    let Some(h) = Hosts::for_test("secure_lab", "sec", 5) else {
        return;
    };
    let internal = h.link(0, ROBOT, PC, "192.168.123", (161, 164)).unwrap();
    let lab_pc = h.link(1, PC, SWITCH, "10.229.0", (11, 0)).unwrap();
    let lab_st = h.link(2, STATION, SWITCH, "10.229.0", (100, 0)).unwrap();
    let lab_x = h.link(3, STRAY, SWITCH, "10.229.0", (101, 0)).unwrap();
    h.bridge(SWITCH, &[&lab_pc.b_if, &lab_st.b_if, &lab_x.b_if]).unwrap();

    // The lab's keystore, and an intruder's of its own.
    let dir = std::env::temp_dir().join(format!("handgate-secure-lab-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let ks = dir.join("keystore");
    let other = dir.join("other");
    let k = ks.to_str().unwrap();
    let lab = LAB.to_string();
    security(&["init", "--keystore", k]);
    for (name, role) in [
        ("robot_a", "gateway"),
        ("station", "operator"),
        ("observer", "observer"),
        ("revoked", "operator"),
    ] {
        security(&["issue", "--keystore", k, name, "--role", role, "--robot", &lab]);
    }
    // An identity that expired: valid from an hour before the CA to 10 s after it; by the
    // time its client runs (after everything above and below), it has expired. Its client's
    // clock is then set (libfaketime) to 3 s after the CA's start, when both were valid.
    let ca_start = not_before(&ks.join("public/ca.cert.pem"));
    security(&[
        "issue",
        "--keystore",
        k,
        "expired",
        "--role",
        "operator",
        "--robot",
        &lab,
        "--not-before",
        &rfc3339(ca_start - 3600),
        "--not-after",
        &rfc3339(ca_start + 10),
    ]);
    security(&["revoke", "--keystore", k, "revoked"]);
    security(&["init", "--keystore", other.to_str().unwrap(), "--name", "intruder CA"]);
    security(&[
        "issue",
        "--keystore",
        other.to_str().unwrap(),
        "intruder",
        "--role",
        "operator",
        "--robot",
        &lab,
    ]);
    let enclave = |ks: &Path, n: &str| -> PathBuf { ks.join("enclaves").join(n) };
    let crl = ks.join("public/crl.pem");

    // Robot A: its hand services on its own network, its gateway on the shipped lab profile
    // with the robot's identity on the lab side.
    let ns_robot = Some(h.ns[ROBOT].as_str());
    let _services: Vec<Emulation> = ["left", "right"]
        .iter()
        .map(|side| {
            Emulation::start_in(
                ns_robot,
                &[
                    "dex3",
                    "--service",
                    "--side",
                    side,
                    "--domain",
                    "0",
                    "--interface",
                    &internal.a_if,
                ],
            )
        })
        .collect();
    let root = handgate_tests::repo_root();
    let robot_profile = dir.join("robot_a.toml");
    std::fs::write(
        &robot_profile,
        std::fs::read_to_string(root.join("profiles/lab-g1-dex3.toml")).unwrap()
            + &format!(
                "\n[export.security]\nenclave = \"{}\"\ncrl = \"{}\"\n",
                enclave(&ks, "robot_a").display(),
                crl.display()
            ),
    )
    .unwrap();
    let robot = Gateway::spawn_in(
        Some(&h.ns[PC]),
        0,
        &[
            "--profile",
            robot_profile.to_str().unwrap(),
            "--export-domain",
            &lab,
            "--export-interface",
            &lab_pc.a_if,
            "--namespace",
            "robot_a",
        ],
        Some(&internal.b_if),
    )
    .unwrap();
    robot
        .wait_stdout("handgate serving", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("robot: {e}\n{}", robot.transcript()));

    // The permitted path: the operator station's handgate, and the unmodified SDK client on
    // the station's loopback.
    let station_profile = dir.join("station.toml");
    std::fs::write(
        &station_profile,
        std::fs::read_to_string(root.join("profiles/station-dex3.toml")).unwrap()
            + &format!(
                "\n[dds.security]\nenclave = \"{}\"\ncrl = \"{}\"\n",
                enclave(&ks, "station").display(),
                crl.display()
            ),
    )
    .unwrap();
    let before = metrics(&h, &robot);
    let station = Gateway::spawn_in(
        Some(&h.ns[STATION]),
        LAB,
        &["--profile", station_profile.to_str().unwrap()],
        Some(&lab_st.a_if),
    )
    .unwrap();
    station
        .wait_stdout("handgate serving", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("station: {e}\n{}", station.transcript()));
    let client = PyProcess::spawn_in(
        Some(&h.ns[STATION]),
        "xr_dex3_client.py",
        &["--domain", "0", "--interface", "lo", "--timeout", "40"].map(String::from),
    )
    .unwrap();
    let result = client
        .wait_line("RESULT ", Duration::from_secs(90))
        .unwrap_or_else(|e| {
            panic!(
                "{e}\nclient:\n{}\nstation:\n{}\nrobot:\n{}",
                client.transcript(),
                station.transcript(),
                robot.transcript()
            )
        });
    let result: Value = serde_json::from_str(result.trim_start_matches("RESULT ")).unwrap();
    assert_eq!(
        result["converged"],
        true,
        "the station's SDK client did not drive robot A's hands: {result}\nstation:\n{}",
        station.transcript()
    );
    let m = metrics(&h, &robot);
    assert!(
        commands(&m) > commands(&before),
        "robot A took none of the station's commands"
    );
    let total_refused = |m: &Value| {
        [
            "unauthenticated",
            "unknown_ca",
            "revoked",
            "expired",
            "not_yet_valid",
            "handshake",
            "not_allowed",
        ]
        .iter()
        .map(|r| refused(m, r))
        .sum::<f64>()
    };
    assert_eq!(
        total_refused(&m),
        0.0,
        "the permitted station was refused: {}",
        m["samples"]
    );
    eprintln!(
        "permitted: the station's SDK client converged in {} s through the secured domain; robot A's left hand took {} commands",
        result["seconds"],
        commands(&m) - commands(&before)
    );
    drop(client);
    drop(station);

    // handgate send as the station's identity, from the stray machine: accepted.
    let base = metrics(&h, &robot);
    let ok = send_from_stray(&h, &lab_x.a_if, Some(&enclave(&ks, "station")), &[]);
    assert!(
        ok.status.success(),
        "the station's identity was refused:\n{}",
        text(&ok)
    );
    let m = metrics(&h, &robot);
    assert!(commands(&m) > commands(&base), "robot A took none of `send`'s commands");

    // 1. A participant without security: the official SDK's ChannelPublisher writing the
    // left hand's command topic every 10 ms.
    let base = metrics(&h, &robot);
    let fixture = root.join("tests/fixtures/golden/unitree_hg__HandCmd___typical.json");
    let plain = PyProcess::spawn_in(
        Some(&h.ns[STRAY]),
        "interop_pub.py",
        &[
            "--domain",
            &lab,
            "--topic",
            "rt/dex3/left/cmd",
            "--type",
            "unitree_hg/HandCmd_",
            "--fixture",
            fixture.to_str().unwrap(),
            "--interface",
            &lab_x.a_if,
            "--timeout",
            "30",
        ]
        .map(String::from),
    )
    .unwrap();
    plain.wait_line("READY", Duration::from_secs(30)).unwrap();
    let m = wait_metrics(
        &h,
        &robot,
        Duration::from_secs(20),
        "an SDK writer without security counted",
        |m| refused(m, "unauthenticated") > refused(&base, "unauthenticated"),
    );
    assert_eq!(
        commands(&m),
        commands(&base),
        "robot A's left hand took the SDK writer's commands:\n{}",
        plain.transcript()
    );
    eprintln!(
        "an SDK writer without security: refused, counted as unauthenticated ({} -> {}), no command taken",
        refused(&base, "unauthenticated"),
        refused(&m, "unauthenticated")
    );
    drop(plain);
    // And a plain `handgate send`.
    let out = send_from_stray(&h, &lab_x.a_if, None, &[]);
    assert_refused(
        &h,
        &robot,
        "a participant without security",
        &out,
        Some("unauthenticated"),
        &m,
    );

    // 2. An identity from another CA.
    let base = metrics(&h, &robot);
    let out = send_from_stray(&h, &lab_x.a_if, Some(&enclave(&other, "intruder")), &[]);
    assert_refused(
        &h,
        &robot,
        "an identity from another CA",
        &out,
        Some("unknown_ca"),
        &base,
    );

    // 3. A read-only identity writing a command topic.
    let base = metrics(&h, &robot);
    let out = send_from_stray(&h, &lab_x.a_if, Some(&enclave(&ks, "observer")), &[]);
    assert!(
        text(&out).to_lowercase().contains("security"),
        "the observer's writer was not refused by security:\n{}",
        text(&out)
    );
    assert_refused(
        &h,
        &robot,
        "a read-only identity writing a command topic",
        &out,
        None,
        &base,
    );

    // 4. A revoked identity: the robot's CRL lists it.
    let base = metrics(&h, &robot);
    let out = send_from_stray(&h, &lab_x.a_if, Some(&enclave(&ks, "revoked")), &[]);
    assert_refused(&h, &robot, "a revoked identity", &out, Some("revoked"), &base);

    // 5. An expired certificate: refused by the client itself, and by the robot when the
    // client's clock says it is still valid.
    let out = send_from_stray(&h, &lab_x.a_if, Some(&enclave(&ks, "expired")), &[]);
    assert!(!out.status.success(), "an expired identity joined:\n{}", text(&out));
    let base = metrics(&h, &robot);
    let now = || {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_secs() as i64
    };
    assert!(
        now() > ca_start + 10,
        "the test ran in under 10 s: the expired identity is still valid"
    );
    let fake = format!("@{}", rfc3339(ca_start + 3).replace('T', " ").trim_end_matches('Z'));
    let out = send_from_stray(
        &h,
        &lab_x.a_if,
        Some(&enclave(&ks, "expired")),
        &[
            "env",
            "TZ=UTC",
            "FAKETIME_DONT_FAKE_MONOTONIC=1",
            "faketime",
            "-f",
            &fake,
        ],
    );
    assert_refused(&h, &robot, "an expired certificate", &out, Some("expired"), &base);

    // `handgate status` on the lab, as the read-only identity: the robot's refusals.
    let out = handgate_cmd(Some(&h.ns[STRAY]))
        .args([
            "status",
            "--domain",
            &lab,
            "--interface",
            &lab_x.a_if,
            "--namespace",
            "robot_a",
            "--enclave",
            enclave(&ks, "observer").to_str().unwrap(),
            "--once",
            "--timeout",
            "10",
        ])
        .output()
        .unwrap();
    let status = text(&out);
    assert!(
        status.contains("DDS Security: ") && status.contains("remote participant(s) refused"),
        "handgate status shows no refusal:\n{status}"
    );
    eprintln!(
        "handgate status (as the observer): {}",
        status.lines().find(|l| l.contains("DDS Security")).unwrap_or_default()
    );

    let _ = std::fs::remove_dir_all(&dir);
}

/// A certificate's notBefore, seconds since the epoch (`openssl x509`, `date -d`).
fn not_before(cert: &Path) -> i64 {
    let out = std::process::Command::new("openssl")
        .args(["x509", "-noout", "-startdate", "-in"])
        .arg(cert)
        .output()
        .unwrap();
    let line = String::from_utf8_lossy(&out.stdout);
    let when = line.trim().trim_start_matches("notBefore=");
    let out = std::process::Command::new("date")
        .args(["-u", "-d", when, "+%s"])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .unwrap_or_else(|e| panic!("{e}: notBefore {when:?}"))
}

/// `t` (seconds since the epoch, UTC) as RFC 3339 (`2026-11-19T12:00:00Z`), by `date`.
fn rfc3339(t: i64) -> String {
    let out = std::process::Command::new("date")
        .args(["-u", "-d", &format!("@{t}"), "+%Y-%m-%dT%H:%M:%SZ"])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}
