//! Unplugging and replugging a bus hand's adapter (issue #38 part 6, "recovers as the
//! EZGripper does"), for every kind on the serial kit, through the real binaries: `handgate
//! emulate <kind> --pty LINK` stands in for the USB adapter and the hand; killing it closes
//! the pty and removes the link (an unplug), starting it again on the same link is the replug.
//! `handgate run` drives the hand on backend serial through its canonical front. After the
//! unplug the state goes stale; a command sent while unplugged is never sent after the replug
//! (the device holds where it measures the hand, as after any reconnect); a new command then
//! moves it.
//!
//! Domain 39 (docs/development.md). Tests take turns ([`serial`]); every wait is on readiness
//! (a fresh sample, a count of samples) with a deadline.

use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_tests::{node, poll, serial, stream_until, temp_profile, Emulation, Gateway, Latest};

const DOMAIN: u32 = 39;
const DEADLINE: Duration = Duration::from_secs(45);

fn closure(c: f32, seq: u64) -> hg::HandCmd_ {
    hg::HandCmd_ {
        seq,
        mode: hg::MODE_CLOSURE,
        closure: c,
        ..Default::default()
    }
}

/// One kind's replug: `kind` (its profile section `section`, with `port` set to the link),
/// emulated by `handgate emulate <emulate> --pty LINK`.
fn replug(kind: &str, section: &str, emulate: &[&str]) {
    let _g = serial();
    let link = std::env::temp_dir().join(format!("handgate-replug-{kind}-{}", std::process::id()));
    let link_s = link.to_str().unwrap().to_string();
    let emu_args: Vec<&str> = emulate.iter().copied().chain(["--pty", link_s.as_str()]).collect();
    let emu = Emulation::start(&emu_args);
    let p = temp_profile(
        "replug",
        kind,
        &format!(
            "name = \"replug-{kind}\"\n\
             [[devices]]\nname = \"hand\"\nkind = \"{kind}\"\nside = \"right\"\nbackend = \"serial\"\n\
             [devices.{kind}]\nport = \"{link_s}\"\n{section}\n\
             [devices.watchdog]\ntimeout_ms = 10000\nsafe_action = \"hold\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"hand\"\n"
        ),
    );
    let gw = Gateway::start(DOMAIN, &["--profile", p.to_str().unwrap()]);
    let n = node(DOMAIN);
    let mut w = n
        .writer::<hg::HandCmd_>("rt/handgate/hand/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut s: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/hand/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    let fresh_at = |s: &hg::HandState_, c: f32| s.freshness == hg::FRESH && (s.closure - c).abs() < 0.08;
    assert!(
        stream_until(&mut w, &closure(0.5, 1), DEADLINE, || s
            .update()
            .is_some_and(|s| fresh_at(s, 0.5))),
        "{kind}: half closed before the unplug: {:?}\n{}",
        s.last,
        gw.transcript()
    );

    // Unplug: the state goes stale.
    drop(emu);
    poll(DEADLINE, || s.update().filter(|s| s.freshness != hg::FRESH).map(|_| ()))
        .unwrap_or_else(|| panic!("{kind}: stale after the unplug: {:?}\n{}", s.last, gw.transcript()));
    // A client commands the hand closed while it is unplugged.
    w.write(closure(1.0, 2)).unwrap();

    // Replug: a fresh hand (the emulator starts open) on the same link.
    let _emu = Emulation::start(&emu_args);
    let back = poll(DEADLINE, || {
        s.update().filter(|s| s.freshness == hg::FRESH).map(|s| s.closure)
    })
    .unwrap_or_else(|| panic!("{kind}: fresh again after the replug\n{}", gw.transcript()));
    // 200 fresh samples after it: the target sent while unplugged never reaches the hand.
    let mut seen = 0;
    let mut most = back;
    poll(DEADLINE, || {
        if let Some(st) = s.update().filter(|s| s.freshness == hg::FRESH) {
            seen += 1;
            most = most.max(st.closure);
        }
        (seen >= 200).then_some(())
    })
    .unwrap_or_else(|| panic!("{kind}: 200 fresh samples after the replug ({seen})"));
    assert!(
        most < back + 0.2,
        "{kind}: closed from {back} to {most} after the replug: the target sent while unplugged was replayed\n{}",
        gw.transcript()
    );
    // A new command moves it.
    assert!(
        stream_until(&mut w, &closure(0.5, 3), DEADLINE, || s
            .update()
            .is_some_and(|s| fresh_at(s, 0.5))),
        "{kind}: a new command after the replug: {:?}\n{}",
        s.last,
        gw.transcript()
    );
}

#[test]
fn a_robotiq_recovers_from_an_unplug_without_replaying() {
    replug("robotiq", "", &["robotiq"]);
}

#[test]
fn a_leap_hand_recovers_from_an_unplug_without_replaying() {
    replug("leap", "", &["leap"]);
}

#[test]
fn an_inspire_rh56_recovers_from_an_unplug_without_replaying() {
    replug("inspire_rh56", "id = 1", &["inspire-rh56"]);
}

#[test]
fn a_rohand_recovers_from_an_unplug_without_replaying() {
    replug("rohand", "", &["rohand"]);
}

/// One owner of a port (issue #38 part 6): while a gateway drives a hand on a port, a client
/// that asks for the port exclusively the way pyserial does (`exclusive=True`, the lock
/// `flock(2)` takes) is refused, and `handgate doctor` on a profile naming that port says who
/// owns it (the gateway's pid and command line).
#[test]
fn an_owned_port_is_refused_to_a_second_opener_and_the_doctor_names_its_owner() {
    let _g = serial();
    let link = std::env::temp_dir().join(format!("handgate-owned-pty-{}", std::process::id()));
    let link_s = link.to_str().unwrap().to_string();
    let _emu = Emulation::start(&["rohand", "--pty", link_s.as_str()]);
    let p = temp_profile(
        "owned",
        "owned",
        &format!(
            "name = \"owned\"\n\
             [[devices]]\nname = \"hand\"\nkind = \"rohand\"\nside = \"right\"\nbackend = \"serial\"\n\
             [devices.rohand]\nport = \"{link_s}\"\n\
             [[fronts]]\nkind = \"canonical\"\ndevice = \"hand\"\n"
        ),
    );
    let gw = Gateway::start(DOMAIN, &["--profile", p.to_str().unwrap()]);
    let n = node(DOMAIN);
    let mut s: Latest<hg::HandState_> = Latest::new(&n, "rt/handgate/hand/state", Qos::BestEffort);
    poll(DEADLINE, || s.update().filter(|s| s.freshness == hg::FRESH).map(|_| ()))
        .unwrap_or_else(|| panic!("the gateway drives the hand\n{}", gw.transcript()));

    // pyserial, as LEAP_Hand_API's and the Robotiq tools' ports are opened, asking for the
    // port exclusively.
    let out = std::process::Command::new(handgate_tests::venv_python())
        .args([
            "-c",
            "import sys, serial\n\
             try:\n    serial.Serial(sys.argv[1], 115200, exclusive=True)\n    print('OPENED')\n\
             except serial.SerialException as e:\n    print('REFUSED', e)\n",
            &link_s,
        ])
        .output()
        .expect("python runs");
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.starts_with("REFUSED"), "pyserial: {said}");

    // The doctor names the owner.
    let out = handgate_tests::handgate_cmd(None)
        .args([
            "doctor",
            "--profile",
            p.to_str().unwrap(),
            "--domain",
            &DOMAIN.to_string(),
            "--seconds",
            "1",
            "--no-scan",
            "--no-sweep",
        ])
        .output()
        .expect("handgate doctor runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("{link_s} owned by handgate, pid {} (", gw.id())),
        "{text}"
    );
    let last = text.trim_end().lines().last().unwrap_or("");
    assert!(last.starts_with("doctor: "), "the summary comes last: {text}");
}
