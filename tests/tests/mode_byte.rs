//! A Dex3 client that never sets the mode byte (issue #37: ipa-alb/unitree_g1_simulation's
//! `hand_controller.py` leaves `mode` at the SDK's default 0): the front refuses its commands as
//! `mode_unset` (status 0 = lock, so a G1's hand would not move either), says so with the fix
//! once for that client however many it sends, counts each in `bad_input`, and `handgate doctor`
//! reads what the client writes and says the same. Through the real binary on the default
//! profile.
//!
//! Domain 119 (docs/development.md). Needs the binary (`cargo build -p handgate`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::unitree_hg;
use handgate_tests::{interop_interface, node, poll, run_doctor, serial, status_device, Gateway, Latest};

const DOMAIN: u32 = 119;
const DEADLINE: Duration = Duration::from_secs(30);

#[test]
fn a_client_leaving_the_mode_byte_0_is_told_the_lock_and_the_fix_once_and_by_the_doctor() {
    let _g = serial();
    let gw = Gateway::start(DOMAIN, &[]);
    let n = node(DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    // The client: every field set as it sets them, the mode byte left 0.
    let client = std::thread::spawn(move || {
        let n = node(DOMAIN);
        let mut w = n
            .writer::<unitree_hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 1 })
            .unwrap();
        w.wait_matched(1, DEADLINE).expect("the Dex3 front matches");
        let mut c = unitree_hg::HandCmd_::sdk_default();
        for m in &mut c.motor_cmd {
            (m.kp, m.kd) = (1.5, 0.1);
        }
        c.motor_cmd[5].q = -1.0; // index_0 closing
        let mut sent = 0u64;
        while !s.load(Ordering::Relaxed) {
            w.write(c.clone()).unwrap();
            sent += 1;
            std::thread::sleep(Duration::from_millis(10));
        }
        sent
    });
    // Refused, counted.
    let counted = poll(DEADLINE, || {
        status
            .update()
            .map(|s| status_device(s, "dex3_left").bad_input)
            .filter(|b| *b >= 100)
    });
    assert!(
        counted.is_some(),
        "not counted in bad_input: {:?}\n{}",
        status.last,
        gw.transcript()
    );
    // The doctor reads the client's samples and says why and how to fix it.
    let mut args = vec!["--domain", "119", "--seconds", "2", "--no-scan", "--no-sweep"];
    let iface = interop_interface();
    if let Some(i) = iface.as_deref() {
        args.extend(["--interface", i]);
    }
    let (_, doctor) = run_doctor(None, &args);
    stop.store(true, Ordering::Relaxed);
    let sent = client.join().unwrap();
    assert!(
        doctor.contains("sample(s) on rt/dex3/left/cmd (front dex3_left) are refused: entry 1 has mode byte 0: motor id 0 and status 0 (lock)")
            && doctor.contains("fix: set each entry's mode to id | 0x10"),
        "{doctor}"
    );
    // Said once for this client (with the fix), not once a second, and never as a wrong id.
    let log = gw.transcript();
    let said = log.matches("rejects the commands of").count();
    assert_eq!(said, 1, "{sent} commands sent:\n{log}");
    assert!(log.contains("fix: set each entry's mode to id | 0x10"), "{log}");
    assert!(!log.contains("wrong_id") && !log.contains("carries motor id"), "{log}");
    println!("{sent} commands refused, said once; the doctor:\n{doctor}");
}
