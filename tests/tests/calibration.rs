//! A hand calibration that pushes a joint past its range and reads where it stops, run the same
//! way against the Dex3 service emulator (`handgate emulate dex3 --service`) and through
//! `sim-all`'s Dex3 front (issue #37). The routine is the shape of NVIDIA
//! GR00T-WholeBodyControl's `calibrate_hand()` (decoupled_wbc/control/envs/g1/g1_hand.py), which
//! runs on real G1s: every 0.1 s it sends one command, raising thumb_0's target by 10° while
//! the measured thumb is less than 60° behind it, and once it is, stores `60° − measured` as
//! the thumb's offset, which it then subtracts from every later command. Through a front that
//! clamped the target to the stop itself, the thumb crept towards the stop with no torque and
//! the routine stored +0.045 rad. The two offsets must agree within 0.005 rad, and `tau_est`
//! must show the thumb pushing into the stop, through the front as on the service.
//!
//! Domains 116, 117 (docs/development.md). Needs the binary (`cargo build -p handgate`).

use std::time::{Duration, Instant};

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::unitree_hg;
use handgate_tests::{node, Emulation, Gateway, Latest};

/// thumb_0's wire index; its range's upper end on the left hand, the routine's 60°.
const THUMB_0: usize = 0;
const UPPER: f32 = 60.0 * std::f32::consts::PI / 180.0;
/// The routine's ramp: 10° per command, a command every 0.1 s, until the lag is 60°.
const STEP: f32 = 10.0 * std::f32::consts::PI / 180.0;
const PERIOD: Duration = Duration::from_millis(100);
const LAG: f32 = UPPER;
const DEADLINE: Duration = Duration::from_secs(60);

/// What the routine read: the offset it stores, the torque the hand reported at the reading,
/// and how long the push took.
#[derive(Debug)]
struct Reading {
    offset: f32,
    tau_est: f32,
    took: Duration,
}

/// Runs the routine on `domain`'s `rt/dex3/left/*` as the routine's command sender does: every
/// entry `0x90 | i` (FOC, timeout protection on), thumb_0 at kp 2.0 / kd 0.5, the others at kp
/// 1.0 / kd 0.2 with targets 0.
fn calibrate(n: &Node) -> Reading {
    let mut state = Latest::<unitree_hg::HandState_>::new(n, "rt/dex3/left/state", Qos::BestEffort);
    let mut w = n
        .writer::<unitree_hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    w.wait_matched(1, DEADLINE).expect("the command topic matches");
    let mut q = state.next(DEADLINE).expect("a state").motor_state[THUMB_0].q;
    let mut cmd = unitree_hg::HandCmd_::sdk_default();
    for (i, m) in cmd.motor_cmd.iter_mut().enumerate() {
        let (kp, kd) = if i == THUMB_0 { (2.0, 0.5) } else { (1.0, 0.2) };
        *m = unitree_hg::MotorCmd_ {
            mode: 0x90 | i as u8,
            kp,
            kd,
            ..Default::default()
        };
    }
    let start = Instant::now();
    let mut target = q;
    loop {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the lag was never reached: thumb at {q}"
        );
        if target - q >= LAG {
            let tau_est = state.update().map_or(f32::NAN, |s| s.motor_state[THUMB_0].tau_est);
            return Reading {
                offset: UPPER - q,
                tau_est,
                took: start.elapsed(),
            };
        }
        target += STEP;
        cmd.motor_cmd[THUMB_0].q = target;
        w.write(cmd.clone()).expect("write");
        q = state.update().expect("a state").motor_state[THUMB_0].q;
        std::thread::sleep(PERIOD);
    }
}

#[test]
fn a_calibration_pushing_past_the_range_reads_the_same_stop_through_the_front_as_on_the_service() {
    let _serial = handgate_tests::serial();
    let service = {
        let _emu = Emulation::start(&["dex3", "--service", "--side", "left", "--domain", "116"]);
        let r = calibrate(&node(116));
        println!("against the service emulator: {r:?}");
        r
    };
    let front = {
        let gw = Gateway::start(117, &["--profile", "sim-all"]);
        let r = calibrate(&node(117));
        println!(
            "through sim-all's Dex3 front: {r:?}\n{}",
            if r.tau_est < 0.5 {
                gw.transcript()
            } else {
                String::new()
            }
        );
        r
    };
    let (a, b) = (service.offset, front.offset);
    println!(
        "offsets: service {a:+.4} rad (lag reached after {:?}), front {b:+.4} rad (after {:?})",
        service.took, front.took
    );
    assert!(
        (a - b).abs() <= 0.005,
        "the front's calibration stores {b:+.4} rad where the service's gives {a:+.4}: {service:?} {front:?}"
    );
    // The thumb pushes into its stop: the motor's torque (kp 2.0 × the 60° lag, at the
    // motor's 1.5 N·m peak) shows, through the front as on the service.
    assert!(service.tau_est > 0.5, "{service:?}");
    assert!(front.tau_est > 0.5, "the front's tau_est shows no push: {front:?}");
}
