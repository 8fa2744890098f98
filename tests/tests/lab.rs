//! A simulated lab of robots (issue #28, parts 3 and 6): two G1s whose internal networks are the
//! same (192.168.123.0/24, DDS domain 0, each robot's Dex3 hand service emulated there by
//! `handgate emulate dex3 --service`), each robot PC running handgate on the shipped
//! `lab-g1-dex3` profile between its robot's network and the lab's, and an operator on the lab
//! network. Unmodified official-SDK clients on the operator, given only a robot's domain, drive
//! that robot's hands; `handgate fleet` lists both robots; robot A keeps working while robot
//! B's handgate is killed and restarted; the operator's link cut for 3 s makes both robots hold
//! (the profile's `silence = "watchdog"`) and their clients take over again when it is back; a
//! second operator outside `export.allow_commands_from` sees the state but its commands are
//! refused and counted; a capture on robot A's internal network and on the lab's shows that
//! neither carries the other's domains and no participant sends on both.
//!
//! Seven network namespaces made by the test (two robots, two robot PCs, a lab switch, the
//! operator, the second operator; the switch is a bridge), six veth pairs; needs root,
//! elsewhere it says why and passes without running. Nothing leaves the namespaces; they are
//! deleted when the test ends. DDS domains 0 (inside each robot's namespaces only), 222 (robot
//! A) and 223 (robot B).

use std::time::{Duration, Instant};

use handgate_tests::{handgate_bin, in_netns, Capture, Emulation, Gateway, Hosts, Link, PyProcess};
use serde_json::Value;

const DOMAIN_A: u32 = 222;
const DOMAIN_B: u32 = 223;

const ROBOT_A: usize = 0;
const PC_A: usize = 1;
const ROBOT_B: usize = 2;
const PC_B: usize = 3;
const SWITCH: usize = 4;
const OPERATOR: usize = 5;
/// A second operator on the lab network, not in the robots' `allow_commands_from`.
const STRAY: usize = 6;

/// One robot: its internal network, its hand services, its PC's gateway (restartable).
struct Robot {
    name: &'static str,
    domain: u32,
    pc: usize,
    internal: Link,
    lab: Link,
    _services: Vec<Emulation>,
    gateway: Option<Gateway>,
    profile: std::path::PathBuf,
}

impl Robot {
    fn start(
        h: &Hosts,
        name: &'static str,
        domain: u32,
        (robot, pc): (usize, usize),
        (internal, lab): (Link, Link),
        profile: &std::path::Path,
    ) -> Robot {
        let ns = Some(h.ns[robot].as_str());
        let services = ["left", "right"]
            .map(|side| {
                Emulation::start_in(
                    ns,
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
            .into();
        let mut r = Robot {
            name,
            domain,
            pc,
            internal,
            lab,
            _services: services,
            gateway: None,
            profile: profile.to_path_buf(),
        };
        r.start_gateway(h);
        r
    }

    /// `handgate run` on the lab profile, this robot's domain and namespace given on the
    /// command line as the profile says, both interfaces the PC's veths.
    fn start_gateway(&mut self, h: &Hosts) {
        let profile = self.profile.clone();
        let domain = self.domain.to_string();
        let gw = Gateway::spawn_in(
            Some(&h.ns[self.pc]),
            0,
            &[
                "--profile",
                profile.to_str().unwrap(),
                "--export-domain",
                &domain,
                "--export-interface",
                &self.lab.a_if,
                "--namespace",
                self.name,
            ],
            Some(&self.internal.b_if),
        )
        .expect("start the robot PC's gateway");
        gw.wait_stdout("handgate serving", Duration::from_secs(30))
            .unwrap_or_else(|e| panic!("{}: {e}", self.name));
        self.gateway = Some(gw);
    }

    fn transcript(&self) -> String {
        self.gateway.as_ref().map(|g| g.transcript()).unwrap_or_default()
    }
}

/// `handgate ARGS` run on the operator's machine.
fn on_operator(h: &Hosts, args: &[&str]) -> std::process::Output {
    in_netns(Some(&h.ns[OPERATOR]), &handgate_bin())
        .args(args)
        .output()
        .unwrap()
}

/// `handgate status --once` of `robot`, read on the operator's machine.
fn status_text(h: &Hosts, op_if: &str, robot: (u32, &str)) -> String {
    let domain = robot.0.to_string();
    let args = [
        "status",
        "--domain",
        &domain,
        "--interface",
        op_if,
        "--namespace",
        robot.1,
    ];
    let out = on_operator(h, &[args.as_slice(), &["--once", "--timeout", "5"]].concat());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `handgate fleet` on `domains`, read on the operator's machine.
fn fleet_text(h: &Hosts, op_if: &str, domains: &str, seconds: &str) -> String {
    let out = on_operator(
        h,
        &[
            "fleet",
            "--domains",
            domains,
            "--interface",
            op_if,
            "--seconds",
            seconds,
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    text
}

/// A device's row of `handgate status` read on the operator's machine: (safe, command Hz,
/// watchdog trips), or `None` when no status came.
fn status_row(h: &Hosts, op_if: &str, robot: &Robot, device: &str) -> Option<(bool, f32, u64)> {
    let text = status_text(h, op_if, (robot.domain, robot.name));
    let row = text.lines().find(|l| l.split_whitespace().next() == Some(device))?;
    let w: Vec<&str> = row.split_whitespace().collect();
    Some((w[4] == "yes", w[5].parse().ok()?, w[10].parse().ok()?))
}

/// Polls `handgate status` until `ok` holds for `device` of `robot` (deadline `within`).
fn wait_status(
    h: &Hosts,
    op_if: &str,
    robot: &Robot,
    device: &str,
    within: Duration,
    what: &str,
    ok: impl Fn((bool, f32, u64)) -> bool,
) -> (bool, f32, u64) {
    let start = Instant::now();
    let mut last = None;
    while start.elapsed() < within {
        last = status_row(h, op_if, robot, device);
        if let Some(r) = last.filter(|r| ok(*r)) {
            return r;
        }
    }
    panic!(
        "{}: {what}: last status row of {device}: {last:?}\n{}",
        robot.name,
        robot.transcript()
    );
}

/// An xr_teleoperate-style Dex3 client on the operator, on `robot`'s domain only: both hands'
/// state seen, then index_0 of each closed until it reads back.
fn drive(h: &Hosts, op_if: &str, robot: &Robot) {
    let args = [
        "--domain",
        &robot.domain.to_string(),
        "--interface",
        op_if,
        "--timeout",
        "40",
    ]
    .map(String::from);
    let client = PyProcess::spawn_in(Some(&h.ns[OPERATOR]), "xr_dex3_client.py", &args).expect("start the client");
    let result = client
        .wait_line("RESULT ", Duration::from_secs(60))
        .unwrap_or_else(|e| panic!("{}: {e}\n{}", robot.name, robot.transcript()));
    let result: Value = serde_json::from_str(result.trim_start_matches("RESULT ")).unwrap();
    assert_eq!(
        result["converged"], true,
        "{}: the hands did not reach the operator's targets: {result}",
        robot.name
    );
}

/// A client streaming robot's left hand's pose from the operator, until dropped.
fn stream(h: &Hosts, op_if: &str, robot: &Robot) -> PyProcess {
    let args = [
        "--domain",
        &robot.domain.to_string(),
        "--side",
        "left",
        "--target",
        "-0.6",
        "--interface",
        op_if,
        "--seconds",
        "120",
    ]
    .map(String::from);
    let c = PyProcess::spawn_in(Some(&h.ns[OPERATOR]), "stream_client.py", &args).unwrap();
    c.wait_line("STREAMING", Duration::from_secs(30))
        .unwrap_or_else(|e| panic!("{}: {e}", robot.name));
    c
}

#[test]
fn two_identical_robots_one_operator_each_robot_by_its_domain() {
    let Some(h) = Hosts::for_test("lab", "lab", 7) else {
        return;
    };
    // Each robot's internal network, the same addresses on both (as on every G1).
    let int_a = h.link(0, ROBOT_A, PC_A, "192.168.123", (161, 164)).unwrap();
    let int_b = h.link(1, ROBOT_B, PC_B, "192.168.123", (161, 164)).unwrap();
    // The lab: both PCs and the operator on one switch.
    let lab_a = h.link(2, PC_A, SWITCH, "10.229.0", (11, 0)).unwrap();
    let lab_b = h.link(3, PC_B, SWITCH, "10.229.0", (12, 0)).unwrap();
    let lab_op = h.link(4, OPERATOR, SWITCH, "10.229.0", (100, 0)).unwrap();
    h.bridge(SWITCH, &[&lab_a.b_if, &lab_b.b_if, &lab_op.b_if]).unwrap();
    let op_if = lab_op.a_if.clone();

    // Captures on robot A's internal network and on the operator's link, for the whole run.
    let cap_internal = Capture::start(&h.ns[ROBOT_A], &int_a.a_if, Duration::from_secs(300));
    let cap_lab = Capture::start(&h.ns[OPERATOR], &op_if, Duration::from_secs(300));
    let started = Instant::now();

    let stray = h.link(5, STRAY, SWITCH, "10.229.0", (101, 0)).unwrap();
    h.bridge_add(SWITCH, &stray.b_if).unwrap();

    // The shipped lab profile, commands allowed from the operator's address only.
    let shipped = std::fs::read_to_string(handgate_tests::repo_root().join("profiles/lab-g1-dex3.toml")).unwrap();
    let profile = std::env::temp_dir().join(format!("handgate-lab-{}.toml", std::process::id()));
    let allow = format!("[export]\nallow_commands_from = [\"{}\"]\n", lab_op.a_addr);
    // The dashboard's fleet page lists the lab's two domains.
    let fleet_page = format!("\n[http]\nfleet_domains = \"{DOMAIN_A}-{DOMAIN_B}\"\n");
    std::fs::write(&profile, shipped.replacen("[export]\n", &allow, 1) + &fleet_page).unwrap();
    let a = Robot::start(&h, "robot_a", DOMAIN_A, (ROBOT_A, PC_A), (int_a, lab_a), &profile);
    let mut b = Robot::start(&h, "robot_b", DOMAIN_B, (ROBOT_B, PC_B), (int_b, lab_b), &profile);

    // The operator drives each robot's hands, picking it by domain.
    drive(&h, &op_if, &a);
    drive(&h, &op_if, &b);

    // Both robots streamed to; robot B's handgate killed: robot A keeps being commanded.
    let stream_a = stream(&h, &op_if, &a);
    let _stream_b = stream(&h, &op_if, &b);
    let streaming = |r: (bool, f32, u64)| !r.0 && r.1 > 10.0;
    let (_, _, trips_a) = wait_status(
        &h,
        &op_if,
        &a,
        "left_hand",
        Duration::from_secs(20),
        "commanded",
        streaming,
    );
    wait_status(
        &h,
        &op_if,
        &b,
        "left_hand",
        Duration::from_secs(20),
        "commanded",
        streaming,
    );
    // `handgate fleet` on the operator lists both robots, and who commands each hand.
    let fleet = fleet_text(&h, &op_if, &format!("{DOMAIN_A}-{DOMAIN_B}"), "5");
    assert!(fleet.starts_with("2 gateway(s)\n"), "{fleet}");
    for r in [&a, &b] {
        assert!(
            fleet.contains(&format!("domain {}  /{}  host ", r.domain, r.name)),
            "{fleet}"
        );
        assert!(
            fleet.contains(&format!(
                "  devices on domain 0, interface {}; clients on domain {}, interface {}\n",
                r.internal.b_if, r.domain, r.lab.a_if
            )),
            "{fleet}"
        );
    }
    // And robot A's dashboard, on its fleet page.
    let url = format!("{}fleet", a.gateway.as_ref().unwrap().http_url().unwrap());
    let start = Instant::now();
    loop {
        let out = std::process::Command::new("ip")
            .args(["netns", "exec", &h.ns[PC_A], "python3", "-c"])
            .arg("import sys, urllib.request; print(urllib.request.urlopen(sys.argv[1]).read().decode())")
            .arg(&url)
            .output()
            .unwrap();
        let page = String::from_utf8_lossy(&out.stdout);
        if page.contains("2 gateway(s)") {
            assert!(
                page.contains("domain 222  /robot_a  host ") && page.contains("domain 223  /robot_b  host "),
                "{page}"
            );
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "robot A's fleet page: {page}{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let commanded = fleet
        .lines()
        .filter(|l| l.trim_start().starts_with("left_hand") && l.contains("dex3_left: python pid"))
        .count();
    assert_eq!(
        commanded, 2,
        "each robot's left hand commanded through its dex3 front: {fleet}"
    );

    let mut gw_b = b.gateway.take().unwrap();
    gw_b.child().kill().unwrap(); // SIGKILL: no shutdown, as a crash or a power cut
    assert!(
        gw_b.wait_exit(Duration::from_secs(10)).is_some(),
        "robot B's handgate did not die"
    );
    assert!(
        status_row(&h, &op_if, &b, "left_hand").is_none(),
        "robot B's handgate is gone"
    );
    for _ in 0..3 {
        let row = status_row(&h, &op_if, &a, "left_hand").expect("robot A still answers");
        assert!(
            streaming(row) && row.2 == trips_a,
            "robot A kept being commanded while robot B's handgate was down: {row:?}\n{}",
            a.transcript()
        );
    }
    // Restarted, robot B's handgate serves the client that kept streaming.
    b.start_gateway(&h);
    wait_status(
        &h,
        &op_if,
        &b,
        "left_hand",
        Duration::from_secs(30),
        "commanded after the restart",
        streaming,
    );

    // The operator's cable pulled for 3 s at the lab switch: both robots hold (the profile's
    // silence), then their clients command them again.
    let before: Vec<u64> = [&a, &b]
        .iter()
        .map(|r| status_row(&h, &op_if, r, "left_hand").unwrap().2)
        .collect();
    h.set_link(SWITCH, &lab_op.b_if, false).unwrap();
    std::thread::sleep(Duration::from_secs(3));
    h.set_link(SWITCH, &lab_op.b_if, true).unwrap();
    for (r, trips) in [&a, &b].into_iter().zip(before) {
        let (_, _, after) = wait_status(
            &h,
            &op_if,
            r,
            "left_hand",
            Duration::from_secs(30),
            "held during the cut, commanded again after",
            |row| streaming(row) && row.2 > trips,
        );
        assert_eq!(after, trips + 1, "{}: one hold for one cut", r.name);
        eprintln!("{}: watchdog trips {trips} before the cut, {after} after", r.name);
    }

    // A second operator on the lab network, not in the list: its commands to robot A are
    // refused and counted, the state still reaches it, the first operator keeps the hand.
    let stray_client = {
        let args = [
            "--domain",
            &DOMAIN_A.to_string(),
            "--side",
            "left",
            "--target",
            "0.4",
            "--interface",
            &stray.a_if,
        ]
        .map(String::from);
        let c = PyProcess::spawn_in(Some(&h.ns[STRAY]), "stream_client.py", &args).unwrap();
        c.wait_line("STREAMING", Duration::from_secs(30))
            .unwrap_or_else(|e| panic!("the stray operator never saw robot A's state: {e}"));
        c
    };
    let refused = |h: &Hosts| {
        status_text(h, &op_if, (a.domain, a.name))
            .lines()
            .find_map(|l| {
                l.strip_prefix("left_hand: ")?
                    .split_whitespace()
                    .next()?
                    .parse::<u64>()
                    .ok()
            })
            .unwrap_or(0)
    };
    let start = Instant::now();
    while refused(&h) < 10 {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "robot A never refused the stray operator's commands"
        );
    }
    let fleet = fleet_text(&h, &op_if, &DOMAIN_A.to_string(), "3");
    let owner = fleet
        .lines()
        .find(|l| l.trim_start().starts_with("left_hand"))
        .unwrap_or("");
    assert!(
        owner.contains(&format!("python pid {} ", stream_a.id())),
        "the operator, not the stray client (pid {}), commands robot A's left hand: {fleet}",
        stray_client.id()
    );
    assert_eq!(
        status_row(&h, &op_if, &a, "left_hand").map(|r| r.0),
        Some(false),
        "not held"
    );

    // Each network carried its own domains only (the captures' window covers the whole run).
    assert!(
        started.elapsed() < Duration::from_secs(290),
        "the lab run outlasted its captures"
    );
    let internal = cap_internal.finish();
    let lab = cap_lab.finish();
    eprintln!("robot A's internal network: {internal:?}\nthe lab network: {lab:?}");
    assert!(
        internal.on_domain(0) > 0,
        "robot A's gateway talks to its service: {internal:?}"
    );
    assert!(lab.on_domain(DOMAIN_A) > 0 && lab.on_domain(DOMAIN_B) > 0, "{lab:?}");
    for d in [DOMAIN_A, DOMAIN_B] {
        assert_eq!(
            internal.on_domain(d),
            0,
            "lab domain {d} on robot A's network: {internal:?}"
        );
    }
    assert_eq!(lab.on_domain(0), 0, "a robot's domain on the lab network: {lab:?}");
    let both: Vec<_> = internal.participants.intersection(&lab.participants).collect();
    assert!(
        both.is_empty(),
        "participants sending on robot A's network and the lab's: {both:?}"
    );
    let _ = std::fs::remove_file(profile);
}
