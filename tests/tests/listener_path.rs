//! The command path in the DDS listener (docs/fronts.md, "Which thread does what"): a front
//! decides and hands each command off in its reader's listener, so a device that stalls must
//! never stall the listener, and with it every other front of the gateway. Two devices stall
//! here at once, each the way its transport can: a Dex3 behind the USB protocol whose MCU stops
//! answering (`handgate emulate dex3 --socket`, SIGSTOP: the device loop blocks in each
//! exchange until its timeout), and a Dex3 that is a client of the G1 hand service whose
//! service stops (`handgate emulate dex3 --service`, SIGSTOP: its reader takes nothing). A
//! client streams to both while another hand's hop (a command to the state that reflects it)
//! is timed against the same hop measured just before the stall.
//!
//! DDS domain 30 (docs/development.md).

use std::time::{Duration, Instant};

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_hg;
use handgate_tests::{closure_cmd, dex3_cmd, node, serial, status_device, temp_profile, Emulation, Gateway, Latest};

const DOMAIN: u32 = 30;
const DEADLINE: Duration = Duration::from_secs(20);

/// `samples` hops on the right hand's Dex3 front: each command's tag, to the first state that
/// carries it; the latencies, sorted.
fn hops(
    w: &mut handgate_adapters::dds::Writer<unitree_hg::HandCmd_>,
    state: &handgate_adapters::dds::Reader<unitree_hg::HandState_>,
    first_tag: u32,
    samples: u32,
) -> Vec<Duration> {
    let mut out = Vec::new();
    for k in 0..samples {
        let tag = first_tag + k;
        let sent = Instant::now();
        w.write(dex3_cmd(0.2 + 0.01 * (k % 10) as f32, tag)).expect("write");
        let mut echoed = None;
        while echoed.is_none() && sent.elapsed() < Duration::from_secs(2) {
            if state.take().iter().any(|s| s.reserve[0] == tag) {
                echoed = Some(sent.elapsed());
            } else {
                std::thread::sleep(Duration::from_micros(200));
            }
        }
        out.push(echoed.unwrap_or_else(|| panic!("command {tag} to the right hand was never reflected")));
    }
    out.sort();
    out
}

/// Sends `signal` (`STOP`, `CONT`) to emulator `e`.
fn signal(e: &Emulation, signal: &str) {
    let st = std::process::Command::new("kill")
        .args(["-s", signal, &e.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(st.success(), "kill -s {signal} {}", e.id());
}

#[test]
fn a_stalled_usb_hand_and_a_stalled_service_never_stall_the_other_fronts() {
    let _g = serial();
    let socket = std::env::temp_dir().join(format!("handgate-listener-{}-dex3.sock", std::process::id()));
    let _ = std::fs::remove_file(&socket);
    let sock = socket.to_str().unwrap();
    let mcu = Emulation::start(&["dex3", "--side", "left", "--socket", sock]);
    let service = Emulation::start(&["dex3", "--service", "--side", "left", "--domain", &DOMAIN.to_string()]);
    let profile = temp_profile(
        "listener",
        "listener-path",
        &format!(
            "name = \"listener-path\"\n[status]\nrate_hz = 10\n\
             [[devices]]\nname = \"usb\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"usb\"\n[devices.usb]\nsocket = \"{sock}\"\n\
             [[devices]]\nname = \"svc\"\nkind = \"dex3\"\nside = \"left\"\nbackend = \"dds\"\n\
             [[devices]]\nname = \"right\"\nkind = \"dex3\"\nside = \"right\"\nbackend = \"emulator\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"usb\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"svc\"\n\
             [[fronts]]\nkind = \"dex3\"\ndevice = \"right\"\n"
        ),
    );
    let gw = Gateway::start(DOMAIN, &["--profile", profile.to_str().unwrap()]);
    let n = node(DOMAIN);
    let mut status: Latest<hg::GatewayStatus_> = Latest::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let fresh = |s: &hg::GatewayStatus_| {
        ["usb", "svc", "right"]
            .iter()
            .all(|d| status_device(s, d).freshness == hg::FRESH)
    };
    let start = Instant::now();
    while !status.update().is_some_and(fresh) {
        assert!(
            start.elapsed() < DEADLINE,
            "every device fresh: {:?}\n{}",
            status.last,
            gw.transcript()
        );
        std::thread::sleep(Duration::from_millis(10));
    }

    let mut right = n
        .writer::<unitree_hg::HandCmd_>("rt/dex3/right/cmd", Qos::Reliable { depth: 16 })
        .expect("writer");
    right.wait_matched(1, DEADLINE).expect("the right front's reader");
    let right_state = n
        .reader::<unitree_hg::HandState_>("rt/dex3/right/state", Qos::BestEffort)
        .expect("reader");
    let mut stalled: Vec<_> = ["usb", "svc"]
        .iter()
        .map(|d| {
            let w = n
                .writer::<hg::HandCmd_>(&format!("rt/handgate/{d}/cmd"), Qos::Reliable { depth: 16 })
                .expect("writer");
            w.wait_matched(1, DEADLINE).expect("the canonical front's reader");
            w
        })
        .collect();
    // Warm-up, then the reference, with every device answering.
    hops(&mut right, &right_state, 1, 20);
    let reference = hops(&mut right, &right_state, 1_000, 40);

    signal(&mcu, "STOP");
    signal(&service, "STOP");
    // Both stalled devices are commanded at 200 Hz while the right hand's hop is timed again.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let streamer = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let (t0, mut seq) = (Instant::now(), 0u64);
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                seq += 1;
                for w in &mut stalled {
                    w.write(closure_cmd(seq, 0.3 + 0.002 * (seq % 100) as f32))
                        .expect("write");
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            seq as f64 / t0.elapsed().as_secs_f64()
        })
    };
    // Both devices seen stalled (stale), the client still streaming to them.
    let start = Instant::now();
    while !status.update().is_some_and(|s| {
        ["usb", "svc"]
            .iter()
            .all(|d| status_device(s, d).freshness == hg::STALE)
    }) {
        assert!(start.elapsed() < DEADLINE, "both devices stale: {:?}", status.last);
        std::thread::sleep(Duration::from_millis(10));
    }
    let during = hops(&mut right, &right_state, 2_000, 40);
    // The gateway's status a second later: the stalled devices' fronts took their commands all
    // along (its command rate is over the last second).
    let until = Instant::now() + Duration::from_millis(1_200);
    while Instant::now() < until {
        status.next(Duration::from_secs(2)).expect("a status");
    }
    let s = status.next(Duration::from_secs(2)).expect("a status");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let client_hz = streamer.join().expect("the streaming thread");
    signal(&mcu, "CONT");
    signal(&service, "CONT");

    let median = |v: &[Duration]| v[v.len() / 2];
    eprintln!(
        "right hand's hop: median {:?} (p90 {:?}) before the stall, {:?} (p90 {:?}) during it",
        median(&reference),
        reference[reference.len() * 9 / 10],
        median(&during),
        during[during.len() * 9 / 10]
    );
    // A listener waiting for a stalled device would add the USB exchange's 20 ms timeout (or a
    // blocked write) to every command behind it.
    assert!(
        median(&during) < median(&reference) + Duration::from_millis(10),
        "the right hand's hop slowed while the other devices stalled: {:?} before, {:?} during\n{}",
        median(&reference),
        median(&during),
        gw.transcript()
    );
    for d in ["usb", "svc"] {
        let dev = status_device(&s, d);
        assert!(
            f64::from(dev.cmd_rate_hz) > client_hz * 0.5,
            "the front of stalled device {d} took its commands at the client's {client_hz:.0} Hz: {dev:?}"
        );
    }
}
