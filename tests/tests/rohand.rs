//! The OYMotion ROHand kind end to end through the real `handgate` binary. Domain 139
//! (docs/development.md).
//!
//! `handgate emulate rohand` serves an emulated hand (Modbus RTU, slave 2) on a pty, as a
//! USB RS-485 adapter would present the real one; `handgate run` opens that pty as the
//! device's serial port (backend serial, the real-hardware path) and serves the canonical
//! front. A closure command through the front closes the emulated hand, and the measured
//! state follows. Every wait is on readiness with a deadline.

use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{node, serial, stream_until, temp_profile, Emulation, Gateway, Latest};

const DEADLINE: Duration = Duration::from_secs(30);

fn q(s: &hg::HandState_, joint: &str) -> f32 {
    s.joints.iter().find(|j| j.name == joint).map_or(f32::NAN, |j| j.q)
}

#[test]
fn the_gateway_closes_an_emulated_rohand_over_a_pty() {
    let _g = serial();
    let link = std::env::temp_dir().join(format!("handgate-rohand-e2e-{}", std::process::id()));
    let emu = Emulation::start(&["rohand", "--pty", link.to_str().unwrap()]);
    assert!(
        emu.line.contains("slave(s) 2") && emu.line.contains(link.to_str().unwrap()),
        "{}",
        emu.line
    );
    let p = temp_profile(
        "rohand",
        "rohand-pty",
        &format!(
            "name = \"rohand-pty\"\n\
             [[devices]]\nname = \"hand\"\nkind = \"rohand\"\nside = \"right\"\nbackend = \"serial\"\n\
             [devices.rohand]\nport = \"{}\"\n\
             [devices.watchdog]\ntimeout_ms = 2000\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"hand\"\n",
            link.display()
        ),
    );
    let _gw = Gateway::start(139, &["--profile", p.to_str().unwrap()]);
    let n = node(139);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/hand/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut s: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/hand/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    // Measured open at start (the emulated hand's positions are 0).
    let open = handgate_tests::poll(DEADLINE, || {
        s.update().filter(|s| s.freshness == hg::FRESH).map(|s| q(s, "index"))
    })
    .expect("a fresh state from the hand on the pty");
    assert!(open.abs() < 1e-3, "open at start: {open}");
    let close = hg::HandCmd_ {
        seq: 1,
        mode: hg::MODE_CLOSURE,
        closure: 1.0,
        ..Default::default()
    };
    // The fist: every register at 65535, the index's travel 78.15 deg = 1.364 rad.
    let closed = stream_until(&mut w, &close, DEADLINE, || {
        s.update().is_some_and(|s| {
            s.freshness == hg::FRESH
                && (q(s, "index") - 1.364).abs() < 0.002
                && (q(s, "thumb_rotate") - std::f32::consts::FRAC_PI_2).abs() < 0.002
        })
    });
    assert!(closed, "the hand closed: last {:?}", s.last);
    let st = s.last.clone().unwrap();
    assert_eq!((st.kind.as_str(), st.side.as_str()), ("rohand", "right"));
    assert!((st.closure - 1.0).abs() < 0.01, "{st:?}");
}

/// A client nobody here wrote: pymodbus (as OYMotion's own examples use it) reads
/// ROH_FINGER_POS from `handgate emulate rohand`, closes the hand through
/// ROH_FINGER_POS_TARGET and sees the positions follow, and gets exception 2 for a register
/// outside the hand's file.
#[test]
fn pymodbus_drives_the_emulated_rohand_on_its_pty() {
    let _g = serial();
    let link = std::env::temp_dir().join(format!("handgate-rohand-py-{}", std::process::id()));
    let _emu = Emulation::start(&["rohand", "--pty", link.to_str().unwrap()]);
    let py = handgate_tests::PyProcess::spawn("rohand_pymodbus.py", &[link.display().to_string()])
        .unwrap_or_else(|e| panic!("{e}"));
    let t = Duration::from_secs(20);
    let pos = py
        .wait_line("pos ", t)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    assert_eq!(pos, "0 0 0 0 0 0");
    let closed = py
        .wait_line("closed ", t)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    assert_eq!(closed, "65535 65535 65535 65535 65535 65535");
    let code = py
        .wait_line("exception ", t)
        .unwrap_or_else(|e| panic!("{e}\n{}", py.transcript()));
    assert_eq!(code, "2");
}

/// The shipped `rohand-sim` profile (backend emulator: the kit's virtual RS-485 line in
/// process, at 115200 baud's wire time): the canonical front half-closes the emulated hand.
#[test]
fn the_shipped_sim_profile_closes_the_emulated_hand() {
    let _g = serial();
    let _gw = Gateway::start(139, &["--profile", "rohand-sim"]);
    let n = node(139);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/rohand/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut s: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/rohand/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let half = hg::HandCmd_ {
        seq: 1,
        mode: hg::MODE_CLOSURE,
        closure: 0.5,
        ..Default::default()
    };
    let reached = stream_until(&mut w, &half, DEADLINE, || {
        s.update()
            .is_some_and(|s| s.freshness == hg::FRESH && (q(s, "middle") - 0.683).abs() < 0.002)
    });
    assert!(reached, "half closed: last {:?}", s.last);
}
