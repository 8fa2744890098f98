//! The README tour's mixed bench: the shipped `mixed-bench` profile (a Robotiq 2F-85, a LEAP
//! Hand, an Inspire RH56 pair on one line and a Dex3-1 pair, all emulated) in the real binary,
//! every new front at the default the profile documents, each driven by the client nobody
//! here wrote that a lab runs against that hand:
//!
//! - pyRobotiqGripper 3.3.14 over Modbus RTU over TCP on 127.0.0.1:54321, and a URCap-style
//!   client on the text socket 127.0.0.1:63352;
//! - a LEAP_Hand_API-style dynamixel-sdk 4.1.0 client on the virtual bus's pty;
//! - pyrh56 0.4.0 on the RH56 serial pty, inspire-rh56dftp 0.1.0 on Modbus TCP 127.0.0.1:6000;
//! - the Dex3 pair's service topics, fresh, beside them.
//!
//! Domain 169 (docs/development.md). One test: the profile's ports and ptys are fixed (what
//! `make run ARGS="--profile mixed-bench"` serves), so nothing else in this binary may bind
//! them. Every wait is on readiness with a deadline.

use std::io::Write;
use std::net::TcpStream;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::unitree_hg as hgm;
use handgate_tests::{node, poll, serial, Gateway, Latest, PyProcess};
use serde_json::Value;

const DOMAIN: u32 = 169;
const DEADLINE: Duration = Duration::from_secs(60);

/// The peer's next `{"event": name, ...}` line.
fn event(py: &PyProcess, name: &str) -> Value {
    let line = py
        .wait_line(&format!("{{\"event\": \"{name}\""), DEADLINE)
        .unwrap_or_else(|e| panic!("{name}: {e}\n{}", py.transcript()));
    serde_json::from_str(&format!("{{\"event\": \"{name}\"{line}")).unwrap_or_else(|e| panic!("{line}: {e}"))
}

/// Runs a peer to its end line (`done` / `DONE`), failing with its transcript otherwise.
fn run_to(py: &PyProcess, end: &str) {
    py.wait_line(end, DEADLINE)
        .unwrap_or_else(|e| panic!("{end}: {e}\n{}", py.transcript()));
}

#[test]
fn the_mixed_bench_serves_every_hand_to_its_own_client() {
    let _g = serial();
    let gw = Gateway::start(DOMAIN, &["--profile", "mixed-bench"]);

    // Robotiq: pyRobotiqGripper activates, closes and opens the emulated 2F-85 over RTU
    // over TCP on UR's forwarder port.
    let py = PyProcess::spawn("robotiq_pyrobotiq.py", &["--tcp".into(), "127.0.0.1:54321".into()])
        .expect("python peer starts");
    let activated = event(&py, "activated");
    assert_eq!(activated["status"]["gSTA"], 3, "{activated}");
    let closed = event(&py, "closed");
    assert_eq!(
        closed["object"], 3,
        "no object: closed at the requested position: {closed}"
    );
    assert!(closed["position"].as_i64().unwrap() >= 220, "{closed}");
    run_to(&py, "{\"event\": \"done\"");

    // The URCap text socket, one request at a time as its Python clients do (`GET <VAR>` is
    // answered `<VAR> <n>`, no line end: docs/robotiq.md).
    let mut s = TcpStream::connect("127.0.0.1:63352").expect("the URCap socket listens");
    s.set_read_timeout(Some(DEADLINE)).unwrap();
    let mut get = |var: &str| {
        s.write_all(format!("GET {var}\n").as_bytes()).unwrap();
        let mut buf = [0u8; 64];
        let n = std::io::Read::read(&mut s, &mut buf).expect("the URCap socket answers");
        String::from_utf8_lossy(&buf[..n]).trim().to_string()
    };
    assert_eq!(get("ACT"), "ACT 1");
    assert_eq!(get("STA"), "STA 3");

    // LEAP: the dynamixel-sdk client inits, reads all 16 and moves them through the virtual bus.
    let py = PyProcess::spawn(
        "leap_client.py",
        &[
            "--port".into(),
            "/tmp/handgate-mixed-leap".into(),
            "--target".into(),
            "3.9".into(),
        ],
    )
    .expect("the LEAP client starts");
    let reached = py
        .wait_line("reached ", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    let reached: Value = serde_json::from_str(&reached).unwrap();
    assert!(reached["max_err"].as_f64().unwrap() <= 0.05, "{reached}");
    run_to(&py, "done");

    // RH56: pyrh56 on the left hand's serial pty; inspire-rh56dftp on the right's Modbus TCP.
    let py = PyProcess::spawn("rh56_pyrh56.py", &["/tmp/handgate-mixed-rh56-left".into(), "1".into()])
        .expect("pyrh56 starts");
    run_to(&py, "DONE");
    assert!(py.transcript().contains("OK 1"), "{}", py.transcript());
    let py = PyProcess::spawn("rh56_dftp.py", &["127.0.0.1".into(), "6000".into()]).expect("the DFTP client starts");
    run_to(&py, "DONE");

    // The Dex3 pair beside them: their service topics fresh.
    let n = node(DOMAIN);
    for side in ["left", "right"] {
        let mut st: Latest<hgm::HandState_> = Latest::new(&n, &format!("rt/dex3/{side}/state"), Qos::BestEffort);
        assert!(
            poll(DEADLINE, || st.update().map(|_| ())).is_some(),
            "rt/dex3/{side}/state\n{}",
            gw.transcript()
        );
    }
    // Each client was its own writer: the gateway logged none of them as refused.
    assert!(!gw.transcript().contains("refused a client"), "{}", gw.transcript());
}
