//! The Inspire FTP kind (docs/sources.md §7, "Inspire FTP"): (a) its table against an
//! independent oracle written out from §7, (b) the client codec, (c) the driver emulator over
//! real CycloneDDS. DDS domains 62–64, each private to this process (CycloneDDS
//! `Discovery/Tag`), so a concurrent run elsewhere on the host cannot cross-talk.

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::control::Active;
use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_device::{DdsCodec, DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::inspire_ftp::adapter::{FtpClient, FtpCodec};
use handgate_adapters::inspire_ftp::emulator::{status, FtpConfig, FtpEmulator};
use handgate_adapters::inspire_ftp::front;
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{faults, DeviceKind, Freshness, HandCommand, JointCommand, Side};
use handgate_idl::inspire::{InspireHandCtrl, InspireHandState, InspireHandTouch, MODE_ANGLE};

const DEADLINE: Duration = Duration::from_secs(20);

fn table(side: Side) -> DeviceTable {
    DeviceKind::InspireFtp.table(side, &TableOverrides::default()).unwrap()
}

/// Makes DDS domain `id` private to this process (see `emu_common::isolated_test_domain`).
fn isolated(id: u32) {
    let cfg = format!(
        "<CycloneDDS><Domain Id=\"any\"><Discovery><Tag>handgate-ftp-test-{}-{id}</Tag></Discovery></Domain></CycloneDDS>",
        std::process::id()
    );
    let d = cyclonedds_rs::dds_domain::DdsDomain::create(id, Some(&cfg)).expect("isolated domain");
    std::mem::forget(d);
}

fn wait_for<T>(what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + DEADLINE;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn angles_for(t: &DeviceTable, q: [f32; 6]) -> Vec<i16> {
    let targets: Vec<JointCommand> = q.iter().map(|&q| JointCommand::hold(q, 1.0, 0.1)).collect();
    FtpCodec::default()
        .encode(&Active::Command(targets), t, 0.01)
        .unwrap()
        .angle_set
}

// ---- (a) the table against docs/sources.md §7, literal numbers -------------------------------

/// xr_teleoperate (§7): `angle = 1000 · (max − rad) / (max − min)`, truncated, with index 0–3
/// [0, 1.7], thumb bend [0, 0.5], thumb rotation [−0.1, 1.3]; 1000 = open. Canonical = URDF rad.
#[test]
fn a_directions_per_joint_and_side_match_the_documented_angles() {
    for side in [Side::Left, Side::Right] {
        let t = table(side);
        // Open hand: every angle 1000 (xr_teleoperate starts there); canonical closure 0.
        let open = FtpCodec::default()
            .encode(&Active::Command(t.closure_targets(0.0, None).unwrap()), &t, 0.01)
            .unwrap();
        assert_eq!(open.angle_set, vec![1000, 1000, 1000, 1000, 1000, 1000], "{side}");
        assert_eq!(open.mode, 1, "angle mode only, as xr_teleoperate");
        // Canonical closure 1: Unitree's fist, [0, 0, 0, 0, 1000, 1000].
        let fist = FtpCodec::default()
            .encode(&Active::Command(t.closure_targets(1.0, None).unwrap()), &t, 0.01)
            .unwrap();
        assert_eq!(fist.angle_set, vec![0, 0, 0, 0, 1000, 1000], "{side}");
        // Mid-range points, worked by hand from the formula.
        assert_eq!(angles_for(&t, [0.85, 0.85, 0.85, 0.85, 0.25, 0.6]), vec![500; 6]);
        assert_eq!(
            angles_for(&t, [1.7, 0.0, 0.425, 1.275, 0.5, 1.3]),
            vec![0, 1000, 750, 250, 0, 0]
        );
        assert_eq!(angles_for(&t, [0.0, 0.0, 0.0, 0.0, 0.0, -0.1])[5], 1000);
        // thumb_rotate at 0 rad: 1000 · 1.3 / 1.4 = 928.57 → 928.
        assert_eq!(angles_for(&t, [0.0; 6])[5], 928);
        // Positive = closing on every joint: more canonical q, smaller angle.
        for j in 0..6 {
            let mut lo = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let mut hi = lo;
            lo[j] = 0.1;
            hi[j] = 0.4;
            assert!(angles_for(&t, hi)[j] < angles_for(&t, lo)[j], "{side} joint {j}");
        }
        // Limits are the URDF's, on both hands (no mirror image).
        let lim: Vec<(f32, f32)> = t.joints.iter().map(|j| (j.limits.min, j.limits.max)).collect();
        assert_eq!(
            lim,
            vec![(0.0, 1.7), (0.0, 1.7), (0.0, 1.7), (0.0, 1.7), (0.0, 0.5), (-0.1, 1.3)]
        );
        let p = if side == Side::Left { "L_" } else { "R_" };
        let urdf: Vec<&str> = t.joints.iter().map(|j| j.urdf.as_str()).collect();
        assert_eq!(
            urdf,
            [
                format!("{p}pinky_proximal_joint"),
                format!("{p}ring_proximal_joint"),
                format!("{p}middle_proximal_joint"),
                format!("{p}index_proximal_joint"),
                format!("{p}thumb_proximal_pitch_joint"),
                format!("{p}thumb_proximal_yaw_joint"),
            ]
        );
        let names: Vec<&str> = t.joints.iter().map(|j| j.name).collect();
        assert_eq!(
            names,
            ["pinky", "ring", "middle", "index", "thumb_bend", "thumb_rotate"]
        );
    }
}

// ---- (b) the client codec ----------------------------------------------------------------------

fn state(angle: Vec<i16>) -> InspireHandState {
    InspireHandState {
        angle_act: angle,
        temperature: vec![33, 34, 35, 36, 37, 38],
        ..InspireHandState::sdk_default()
    }
}

#[test]
fn b_codec_round_trips_and_fault_rules() {
    let t = table(Side::Right);
    let mut c = FtpCodec::default();
    // angle_act 1000 = open = canonical 0 (thumb rotation −0.1); 0 = closed at the URDF max.
    let s = c.decode(&state(vec![1000, 0, 500, 250, 0, 0]), &t).unwrap();
    let q: Vec<f32> = s.joints.iter().map(|j| j.q).collect();
    for (got, want) in q.iter().zip([0.0, 1.7, 0.85, 1.275, 0.5, 1.3]) {
        assert!((got - want).abs() < 1e-5, "{q:?}");
    }
    assert_eq!(s.joints[5].temperature, Some(38.0));
    assert_eq!(s.faults, 0);
    // Canonical → wire → canonical within one register unit.
    let q0 = [0.3, 1.1, 1.69, 0.01, 0.33, 0.77];
    let a = angles_for(&t, q0);
    let back = c.decode(&state(a), &t).unwrap();
    for ((j, want), map) in back.joints.iter().zip(q0).zip(&t.joints) {
        assert!(
            (j.q - want).abs() <= 1.0 / map.scale + 1e-5,
            "{} {} vs {want}",
            map.name,
            j.q
        );
    }
    // Not this hand's shape: ignored.
    assert!(c.decode(&state(vec![0; 5]), &t).is_none());
    // err ≠ 0 → motor error; err bit 3 or status 7 / 255 → hardware.
    let mut e = state(vec![1000; 6]);
    e.err[2] = 1;
    assert_eq!(c.decode(&e, &t).unwrap().faults, faults::MOTOR_ERROR);
    e.err[2] = 8;
    assert_eq!(c.decode(&e, &t).unwrap().faults, faults::MOTOR_ERROR | faults::HARDWARE);
    let mut e = state(vec![1000; 6]);
    e.status[4] = 7;
    assert_eq!(c.decode(&e, &t).unwrap().faults, faults::HARDWARE);
    e.status[4] = 255;
    assert_eq!(c.decode(&e, &t).unwrap().faults, faults::HARDWARE);
    // Nothing commanded: nothing sent.
    assert!(c.encode(&Active::Idle, &t, 0.01).is_none());
}

// ---- (c) the emulator over DDS -----------------------------------------------------------------

fn info(side: Side) -> DeviceInfo {
    DeviceInfo {
        name: format!("ftp_{side}"),
        kind: DeviceKind::InspireFtp,
        side,
        backend: Backend::Dds,
        table: Arc::new(table(side)),
    }
}

/// A client device on the driver's standard topics moves the emulated fingers (closure 1 =
/// the fist), reads them back canonical with the tactile pads, and goes stale when the driver
/// stops.
#[test]
fn c_client_device_drives_the_emulated_driver_and_goes_stale_without_it() {
    isolated(62);
    let node = Node::new(62, None).unwrap();
    let emu = FtpEmulator::start(&node, FtpConfig::new(Side::Left).exact()).unwrap();
    let (ctrl, st, touch) = front::topics(Side::Left);
    assert_eq!(
        (ctrl.as_str(), st.as_str(), touch.as_str()),
        (
            "rt/inspire_hand/ctrl/l",
            "rt/inspire_hand/state/l",
            "rt/inspire_hand/touch/l"
        )
    );
    let codec = FtpClient::new(&node, FtpCodec::default(), Some(&touch)).unwrap();
    let dev = DdsDevice::start(
        &node,
        info(Side::Left),
        DdsDeviceConfig {
            cmd_topic: ctrl,
            state_topic: Some(st),
            rate_hz: 100.0,
            stale_after: Duration::from_millis(200),
            forward: handgate_adapters::dds_device::Forwarding::default_for(100.0),
        },
        codec,
    )
    .unwrap();
    let mut rx = dev.state();
    // Start-up: the hand where it was left (900 = 0.17 rad on a finger), measured.
    let s = wait_for("a fresh first state", || {
        let s = rx.borrow_and_update().clone();
        (s.freshness == Freshness::Fresh).then_some(s)
    });
    assert!((s.joints[3].q - 0.17).abs() < 1e-4, "{:?}", s.joints[3]);
    assert_eq!(emu.snapshot().commands, 0, "silent until commanded");
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    let s = wait_for("the fist", || {
        let s = rx.borrow_and_update().clone();
        (s.joints[3].q > 1.69 && s.pads.len() == 17).then_some(s)
    });
    assert!(s.joints[4].q.abs() < 1e-4, "thumb straight in the fist");
    assert!(s.closure > 0.99);
    let last = emu.snapshot().last_command.unwrap();
    assert_eq!(
        (last.mode, last.angle_set.clone()),
        (MODE_ANGLE, vec![0, 0, 0, 0, 1000, 1000])
    );
    wait_for("the pinky settled on its target", || {
        (emu.angle(0) == 0.0).then_some(())
    });
    assert_eq!(s.pads.iter().map(|p| p.pressure.len()).sum::<usize>(), 1062);
    // The driver goes away: stale, link down.
    emu.stop();
    wait_for("stale after the driver stopped", || {
        let s = rx.borrow_and_update().clone();
        (s.freshness == Freshness::Stale && s.faults & faults::LINK_DOWN != 0).then_some(())
    });
}

/// A raw client of the emulated driver: start-up state with noise, per-mode semantics, no
/// timeout (the hand keeps its targets through silence), hard stops at 0 and 1000.
#[test]
fn c_raw_client_sees_startup_modes_silence_and_hard_stops() {
    isolated(63);
    let node = Node::new(63, None).unwrap();
    let emu = FtpEmulator::start(&node, FtpConfig::new(Side::Right)).unwrap();
    let (ctrl, st, _) = front::topics(Side::Right);
    let mut w = node
        .writer::<InspireHandCtrl>(&ctrl, Qos::Reliable { depth: 8 })
        .unwrap();
    let r = node.reader::<InspireHandState>(&st, Qos::BestEffort).unwrap();
    w.wait_matched(1, DEADLINE).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    // Start-up: near the rest posture (900), noisy, never all zero.
    let first = r.wait_take(DEADLINE).unwrap().pop().unwrap();
    assert!(first.angle_act.iter().all(|a| (880..=920).contains(a)), "{first:?}");
    let mut seen = Vec::new();
    while seen.len() < 20 {
        seen.extend(r.wait_take(DEADLINE).unwrap().into_iter().map(|s| s.angle_act));
    }
    assert!(seen.iter().any(|a| a != &seen[0]), "measurement noise at rest");
    // mode 0: a no-op.
    let mut c = InspireHandCtrl::sdk_default();
    c.angle_set = vec![0; 6];
    w.write(c.clone()).unwrap();
    wait_for("the no-op", || (emu.snapshot().noops == 1).then_some(()));
    assert_eq!(emu.snapshot().actuators[0].angle_set, 900.0);
    // Angle mode, written once; out-of-range values stop at the hard stops.
    c.mode = MODE_ANGLE;
    c.angle_set = vec![-500, 2000, 300, 300, 300, 300];
    w.write(c).unwrap();
    let reached = |s: &InspireHandState| {
        s.angle_act[0].abs() <= 6 && (s.angle_act[1] - 1000).abs() <= 6 && (s.angle_act[3] - 300).abs() <= 6
    };
    let mut n = 0;
    loop {
        let s = r.wait_take(DEADLINE).unwrap().pop().unwrap();
        if reached(&s) {
            break;
        }
        n += 1;
        assert!(n < 2000, "never reached: {s:?}");
    }
    wait_for("the closed and the open stop", || {
        (emu.angle(0) == 0.0 && emu.angle(1) == 1000.0).then_some(())
    });
    // Silence: 75 more states (1.5 s at 50 Hz) without a command, the hand stays put.
    let mut samples = 0;
    while samples < 75 {
        for s in r.wait_take(DEADLINE).unwrap() {
            assert!(reached(&s), "moved without a command: {s:?}");
            assert_eq!(s.status[3], status::AT_POSITION);
            samples += 1;
        }
    }
    assert_eq!(emu.snapshot().commands, 2);
}

/// An object blocks the index: it stops at force_set, its fingertip pad lights up, the other
/// pads read noise only. Over RS-485 the driver publishes no touch topic.
#[test]
fn c_object_raises_force_and_tactile_pressure_and_rs485_has_no_touch() {
    isolated(64);
    let node = Node::new(64, None).unwrap();
    let mut cfg = FtpConfig::new(Side::Left);
    cfg.object[3] = Some(600.0);
    let _emu = FtpEmulator::start(&node, cfg).unwrap();
    let (ctrl, st, touch) = front::topics(Side::Left);
    let mut w = node
        .writer::<InspireHandCtrl>(&ctrl, Qos::Reliable { depth: 8 })
        .unwrap();
    let r = node.reader::<InspireHandState>(&st, Qos::BestEffort).unwrap();
    let tr = node.reader::<InspireHandTouch>(&touch, Qos::BestEffort).unwrap();
    w.wait_matched(1, DEADLINE).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    tr.wait_matched(1, DEADLINE).unwrap();
    // At rest: every taxel near 0 (noise of a few units).
    let rest = tr.wait_take(DEADLINE).unwrap().pop().unwrap();
    let rest_pads = front::pads_from_touch(&rest);
    assert!(rest_pads.iter().all(|p| p.pressure.iter().all(|v| *v < 10.0)));
    let mut c = InspireHandCtrl::sdk_default();
    c.mode = MODE_ANGLE | handgate_idl::inspire::MODE_FORCE;
    c.angle_set = vec![0, 0, 0, 0, 1000, 1000];
    c.force_set = vec![400; 6];
    w.write(c).unwrap();
    let s = wait_for("the index stopped at force", || {
        r.take()
            .into_iter()
            .rev()
            .find(|s| s.status[3] == status::AT_FORCE && s.angle_act[2] < 10)
    });
    // 400 force units at 20 per angle unit: 20 units past the object at 600.
    assert!((575..=585).contains(&s.angle_act[3]), "{s:?}");
    assert!((390..=410).contains(&s.force_act[3]), "{s:?}");
    assert!(s.force_act[2].abs() < 10, "the middle finger closed freely");
    let t = wait_for("a pressed touch sample", || {
        tr.take()
            .into_iter()
            .last()
            .filter(|t| t.fingerfour_top_touch.iter().any(|v| *v > 300))
    });
    let pads = front::pads_from_touch(&t);
    let peak = |name: &str| {
        pads.iter()
            .find(|p| p.name == name)
            .unwrap()
            .pressure
            .iter()
            .cloned()
            .fold(0.0f32, f32::max)
    };
    assert!(peak("index_top") > 700.0, "{}", peak("index_top"));
    assert!(peak("index_tip") > 200.0 && peak("index_pad") > 100.0);
    assert!(peak("middle_top") < 10.0 && peak("palm") < 10.0);
    // RS-485: state, no touch publisher (on its own topics in the same domain).
    let mut rs = FtpConfig::new(Side::Right).rs485();
    rs.topics = Some(("ftp/rs/ctrl".into(), "ftp/rs/state".into(), "ftp/rs/touch".into()));
    let _rs_emu = FtpEmulator::start(&node, rs).unwrap();
    let rs_state = node
        .reader::<InspireHandState>("ftp/rs/state", Qos::BestEffort)
        .unwrap();
    let rs_touch = node
        .reader::<InspireHandTouch>("ftp/rs/touch", Qos::BestEffort)
        .unwrap();
    rs_state.wait_matched(1, DEADLINE).unwrap();
    let mut got = 0;
    while got < 10 {
        got += rs_state.wait_take(DEADLINE).unwrap().len();
    }
    assert_eq!(rs_touch.matched(), 0, "no touch publisher over RS-485");
    assert!(rs_touch.take().is_empty());
}
