//! The emulated hand as a separate process: kill it, start it again, and check the loop
//! reconnects and holds where the hand is measured instead of replaying the old command.

use handgate_adapters::dex3::usb::device_loop::{Dex3UsbLoop, LoopConfig};
use handgate_adapters::dex3::usb::socket::UnixSocketTransport;
use handgate_adapters::dex3::{Dex3Command, Dex3Measurement, Joint, MotorCommand};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::Duration;

mod common;
use common::{wait_for, wait_meas};

const DEADLINE: Duration = Duration::from_secs(30);

struct Emu(Child);

impl Drop for Emu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(path: &Path) -> Emu {
    Emu(Command::new(env!("CARGO_BIN_EXE_dex3-emulator"))
        .args(["--side", "right", "--socket"])
        .arg(path)
        .args(["--initial-q", "0.1,0,0,0,0,0,0"])
        .spawn()
        .expect("start the emulator process"))
}

fn fresh(m: &Dex3Measurement) -> bool {
    !m.stale && m.motors.iter().all(|m| m.present)
}

fn thumb0(base: [f32; 7], q: f32) -> Dex3Command {
    let mut c = Dex3Command::hold(base, 1.5, 0.1);
    *c.motor_mut(Joint::Thumb0) = MotorCommand {
        q,
        kp: 1.5,
        kd: 0.1,
        ..Default::default()
    };
    c
}

#[test]
fn kill_and_restart_the_hand_process() {
    let path: PathBuf = std::env::temp_dir().join(format!("hg-dex3-proc-{}.sock", std::process::id()));
    let mut emu = start(&path);
    let h = Dex3UsbLoop::spawn(UnixSocketTransport::factory(path.clone()), LoopConfig::default()).unwrap();
    let m0 = wait_meas(DEADLINE, &h, "first state", fresh);
    assert!((m0.motor(Joint::Thumb0).q - 0.1).abs() < 0.01);
    h.set_command(thumb0(m0.positions(), 0.8));
    wait_meas(DEADLINE, &h, "thumb_0 at 0.8", |m| {
        (m.motor(Joint::Thumb0).q - 0.8).abs() < 0.02
    });

    // Kill the hand: the loop notices and marks the state stale.
    emu.0.kill().unwrap();
    emu.0.wait().unwrap();
    wait_for(DEADLINE, "disconnect noticed", || (!h.stats().connected).then_some(()));
    assert!(h.latest().stale);

    // A fresh hand process (joints back at their power-up position 0.1).
    let _emu2 = start(&path);
    wait_for(DEADLINE, "reconnected", || (h.stats().reconnects >= 1).then_some(()));
    let m1 = wait_meas(DEADLINE, &h, "fresh after restart", fresh);
    let ex = h.stats().good_frames;
    wait_for(DEADLINE, "300 good frames after the restart", || {
        (h.stats().good_frames > ex + 300).then_some(())
    });
    let m2 = h.latest();
    assert!(!m2.stale);
    for m in [&m1, &m2] {
        let q = m.motor(Joint::Thumb0).q;
        assert!(
            (q - 0.1).abs() < 0.03,
            "after restart thumb_0 went to {q}: the old command was replayed"
        );
    }

    // A new command moves it.
    h.set_command(thumb0(m2.positions(), -0.4));
    wait_meas(DEADLINE, &h, "thumb_0 at -0.4", |m| {
        (m.motor(Joint::Thumb0).q + 0.4).abs() < 0.02
    });
    h.stop();
    let _ = std::fs::remove_file(&path);
}
