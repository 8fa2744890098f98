//! The BrainCo Revo2 kind (docs/sources.md §7 "BrainCo Revo2"): its table against an oracle
//! written out from §7, the DDS-client codec, the service emulator over real CycloneDDS, and
//! closure pairing of a BrainCo front with a Dex3 hand, and the registry opening an emulated
//! hand. DDS domains 40, 41, 48 and 49 (the e2e
//! tests in `tests/tests/brainco_e2e.rs` use 92, 93 and 94).

use std::sync::Arc;
use std::time::{Duration, Instant};

use handgate_adapters::brainco::adapter::{decode_state, BraincoCodec};
use handgate_adapters::brainco::emulator::{BraincoConfig, BraincoEmulator};
use handgate_adapters::brainco::front;
use handgate_adapters::control::Active;
use handgate_adapters::dds::{Node, Qos};
use handgate_adapters::dds_device::{DdsCodec, DdsDevice, DdsDeviceConfig};
use handgate_adapters::device::{Backend, DeviceInfo, HandDevice};
use handgate_adapters::mapping::{DeviceTable, TableOverrides};
use handgate_adapters::model::{DeviceKind, Freshness, HandCommand, HandState, JointCommand, SafeAction, Side};
use handgate_adapters::sim::Noise;
use handgate_idl::unitree_go::{MotorCmd_, MotorCmds_, MotorStates_};

const DEADLINE: Duration = Duration::from_secs(20);

fn table(side: Side) -> DeviceTable {
    DeviceKind::Brainco.table(side, &TableOverrides::default()).unwrap()
}

fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + DEADLINE;
    while !cond() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

// ---- (a) the table against an independent oracle ----

/// docs/sources.md §7, written out: (canonical joint, wire index, URDF joint without the side
/// prefix, URDF upper limit in rad). Lower limits are 0 on every joint. 1.0472 is the URDF's
/// literal figure.
#[allow(clippy::approx_constant)]
const ORACLE: [(&str, usize, &str, f32); 6] = [
    ("thumb", 0, "thumb_metacarpal_joint", 1.5184),
    ("thumb_aux", 1, "thumb_proximal_joint", 1.0472),
    ("index", 2, "index_proximal_joint", 1.4661),
    ("middle", 3, "middle_proximal_joint", 1.4661),
    ("ring", 4, "ring_proximal_joint", 1.4661),
    ("pinky", 5, "pinky_proximal_joint", 1.4661),
];

#[test]
#[allow(clippy::approx_constant)] // the URDF's literal 1.0472
fn table_directions_match_the_service_and_the_urdf_on_both_sides() {
    for side in [Side::Left, Side::Right] {
        let t = table(side);
        assert_eq!(t.joints.len(), 6);
        assert_eq!(t.wire_len(), 6);
        for (name, wire, urdf, max) in ORACLE {
            let j = &t.joints[t.joint_by_name(name).unwrap().index()];
            assert_eq!(j.wire_index, wire, "{side} {name}");
            assert_eq!(j.urdf, format!("{side}_{urdf}"));
            // xr_teleoperate sends q = 0.0 for an open hand and 1.0 for a closed one
            // ("1 = closed, 0 = open"); canonical 0 rad is open, the URDF upper limit closed.
            assert_eq!(j.q_to_wire(0.0), 0.0, "{side} {name}: canonical 0 = wire 0 (open)");
            assert!(
                (j.q_to_wire(max) - 1.0).abs() < 1e-5,
                "{side} {name}: URDF max = wire 1 (closed)"
            );
            // rad = min + q * (max - min): wire 0.25 is a quarter of the URDF range.
            assert!((j.q_from_wire(0.25) - 0.25 * max).abs() < 1e-5);
            // Closing is positive on the wire and in canonical (no mirror between hands).
            assert!(j.q_to_wire(0.1) > j.q_to_wire(0.0));
            assert_eq!((j.limits.min, j.limits.max), (0.0, max));
        }
        // Closure 0 = every q 0.0 (xr_teleoperate's "hand home"), closure 1 = every q 1.0.
        let open = t.to_wire(&t.closure_targets(0.0, None).unwrap());
        assert!(open.iter().all(|w| w.q == 0.0), "{open:?}");
        let closed = t.to_wire(&t.closure_targets(1.0, None).unwrap());
        assert!(closed.iter().all(|w| (w.q - 1.0).abs() < 1e-5), "{closed:?}");
    }
}

// ---- (b) the codec ----

fn states(q: [f32; 6]) -> MotorStates_ {
    let mut s = MotorStates_::with_len(6);
    for (m, q) in s.states.iter_mut().zip(q) {
        m.q = q;
        m.dq = 0.5;
        m.tau_est = 0.3;
    }
    s
}

#[test]
fn codec_sends_six_positions_and_the_speed_and_reads_state_back() {
    let t = table(Side::Right);
    let mut c = BraincoCodec::new(0.6);
    assert!(c.encode(&Active::Idle, &t, 0.01).is_none(), "silent without a command");
    let half = t.closure_targets(0.5, None).unwrap();
    let m = c.encode(&Active::Command(half), &t, 0.01).unwrap();
    assert_eq!(m.cmds.len(), 6);
    for e in &m.cmds {
        assert!((e.q - 0.5).abs() < 1e-5, "{e:?}");
        assert_eq!(e.dq, 0.6, "the profile's speed in every entry");
        assert_eq!((e.tau, e.kp, e.kd, e.mode), (0.0, 0.0, 0.0, 0));
    }
    // Beyond the table's limits: the codec never sends outside [0, 1].
    let over = vec![JointCommand::hold(9.0, 1.0, 0.0); 6];
    let m = c.encode(&Active::Command(over), &t, 0.01).unwrap();
    assert!(m.cmds.iter().all(|e| e.q == 1.0));
    // Speed out of range is clamped as the service clamps it.
    assert_eq!(BraincoCodec::new(3.0).speed, 1.0);

    // State: wire q 1.0 on the index = its URDF upper limit; dq and current carried.
    let s = c.decode(&states([0.0, 0.0, 1.0, 0.5, 0.0, 0.0]), &t).unwrap();
    assert!((s.joints[2].q - 1.4661).abs() < 1e-4);
    assert!((s.joints[3].q - 0.73305).abs() < 1e-4);
    assert_eq!(s.joints[2].tau, 0.3);
    // Not this hand's state: wrong entry count or a non-finite position.
    assert!(!decode_state(
        &MotorStates_::with_len(12),
        &t,
        &mut HandState::default()
    ));
    assert!(!decode_state(&MotorStates_::with_len(5), &t, &mut HandState::default()));
    let mut bad = states([0.1; 6]);
    bad.states[4].q = f32::NAN;
    assert!(c.decode(&bad, &t).is_none());
}

#[test]
fn limp_is_the_position_measured_when_it_began_and_never_blind() {
    let t = table(Side::Left);
    let mut c = BraincoCodec::default();
    let limp = Active::Safe(SafeAction::Limp, vec![JointCommand::default(); 6]);
    assert!(c.encode(&limp, &t, 0.01).is_none(), "nothing measured yet: silent");
    c.decode(&states([0.2, 0.3, 0.4, 0.5, 0.6, 0.7]), &t).unwrap();
    let m = c.encode(&limp, &t, 0.01).unwrap();
    let q: Vec<f32> = m.cmds.iter().map(|e| e.q).collect();
    assert_eq!(
        q,
        vec![0.2, 0.3, 0.4, 0.5, 0.6, 0.7],
        "stop where the fingers are, never open"
    );
    // Held where the limp began, whatever is measured afterwards (docs/adapters.md, "Holds").
    c.decode(&states([0.19, 0.29, 0.39, 0.49, 0.59, 0.69]), &t).unwrap();
    let m = c.encode(&limp, &t, 0.01).unwrap();
    assert_eq!(m.cmds.iter().map(|e| e.q).collect::<Vec<_>>(), q, "kept while it sags");
    // The open safe state opens the hand (q 0 everywhere).
    let open = Active::Safe(SafeAction::Open, t.safe_targets(SafeAction::Open, &[]));
    assert!(c.encode(&open, &t, 0.01).unwrap().cmds.iter().all(|e| e.q == 0.0));
}

// ---- closure pairing across kinds ----

#[test]
fn a_brainco_front_closes_a_dex3_hand_through_closure_and_reads_it_back() {
    for side in [Side::Left, Side::Right] {
        let f = table(side);
        let d = DeviceKind::Dex3.table(side, &TableOverrides::default()).unwrap();
        // The gateway pairs joint for joint only when names and limits match
        // (handgate_gateway::router::pairing): these do not, so the pairing is by closure.
        assert!(f.joints.iter().zip(&d.joints).any(|(a, b)| a.name != b.name));
        // An xr_teleoperate BrainCo client closes the hand: q = 1.0 in all six entries.
        let mut msg = MotorCmds_::with_len(6);
        for e in &mut msg.cmds {
            *e = MotorCmd_ {
                q: 1.0,
                dq: 1.0,
                ..Default::default()
            };
        }
        let cmd = front::decode(&msg, &f).unwrap();
        let q: Vec<f32> = cmd.joints.iter().map(|j| j.unwrap().q).collect();
        let closure = f.closure_of(&q);
        assert!((closure - 1.0).abs() < 1e-5, "{closure}");
        // On the Dex3 the same closure is its closed posture: index_0 closes toward the
        // URDF's closing end, negative on the left hand's wire, positive on the right's
        // (docs/sources.md §2).
        let targets = d.closure_targets(closure, None).unwrap();
        let wire = d.to_wire(&targets);
        let idx = &d.joints[d.joint_by_name("index_0").unwrap().index()];
        let w = wire[idx.wire_index].q;
        match side {
            Side::Left => assert!(w < -0.5, "left index_0 closes negative: {w}"),
            _ => assert!(w > 0.5, "right index_0 closes positive: {w}"),
        }
        // Open: q 0.0 everywhere -> closure 0 -> the Dex3's open posture.
        msg.cmds.iter_mut().for_each(|e| e.q = 0.0);
        let q: Vec<f32> = front::decode(&msg, &f)
            .unwrap()
            .joints
            .iter()
            .map(|j| j.unwrap().q)
            .collect();
        assert_eq!(f.closure_of(&q), 0.0);
        // State back: a half-closed Dex3 shows as q = 0.5 in every BrainCo entry.
        let posture = f.closure_targets(0.5, None).unwrap();
        let joints: Vec<_> = posture
            .iter()
            .map(|c| handgate_adapters::model::JointState {
                q: c.q,
                ..Default::default()
            })
            .collect();
        let st = handgate_adapters::model::HandState {
            freshness: Freshness::Fresh,
            ..Default::default()
        };
        let out = front::encode(&f, &joints, &st, Instant::now());
        assert!(out.states.iter().all(|m| (m.q - 0.5).abs() < 1e-5), "{out:?}");
    }
}

// ---- (c) the emulator over DDS ----

fn cmds(q: f32, dq: f32) -> MotorCmds_ {
    MotorCmds_ {
        cmds: vec![
            MotorCmd_ {
                q,
                dq,
                ..Default::default()
            };
            6
        ],
    }
}

/// Takes state samples until `done` holds (or the deadline passes).
fn watch_until(
    r: &handgate_adapters::dds::Reader<MotorStates_>,
    mut done: impl FnMut(&MotorStates_) -> bool,
) -> MotorStates_ {
    let end = Instant::now() + DEADLINE;
    loop {
        let s = r.wait_take(DEADLINE).unwrap().pop().unwrap();
        if done(&s) {
            return s;
        }
        assert!(Instant::now() < end, "condition not reached; last {s:?}");
    }
}

#[test]
fn emulated_service_opens_at_start_follows_commands_holds_on_silence_and_stops_hard() {
    let node = Node::new(40, None).unwrap();
    let cfg = BraincoConfig {
        noise: Noise::OFF,
        ..BraincoConfig::new(Side::Left)
    };
    // A reader on the state topic before the service starts, to see its first samples.
    let r = node
        .reader::<MotorStates_>("rt/brainco/left/state", Qos::Reliable { depth: 64 })
        .unwrap();
    let emu = BraincoEmulator::start(&node, cfg).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    // Start-up: with no client at all the service drives the hand fully open (the start-up
    // posture itself: `the_service_opens_the_hand_from_its_rest_posture_at_start_up`).
    watch_until(&r, |s| s.states.iter().all(|m| m.q == 0.0));
    assert_eq!(emu.snapshot().commands, 0);

    // A client closes to 0.7 at full speed: the fingers move there, closing = q rising.
    let mut w = node
        .writer::<MotorCmds_>("rt/brainco/left/cmd", Qos::Reliable { depth: 4 })
        .unwrap();
    w.wait_matched(1, DEADLINE).unwrap();
    w.write(cmds(0.7, 1.0)).unwrap();
    let mut last = 0.0;
    let s = watch_until(&r, |s| {
        assert!(s.states[3].q >= last - 1e-6, "moves monotonically toward the target");
        last = s.states[3].q;
        s.states.iter().all(|m| (m.q - 0.7).abs() < 1e-3)
    });
    assert!(s.states[3].tau_est >= 0.0);
    // Silence: the service re-sends the last command every cycle; 100 further state samples
    // (a second at its 100 Hz) later the hand is still there.
    for _ in 0..100 {
        let s = watch_until(&r, |_| true);
        assert!(s.states.iter().all(|m| (m.q - 0.7).abs() < 1e-3), "held: {s:?}");
    }
    // Out of range: clamped to 1.0, the hand stops hard at its full travel.
    w.write(cmds(5.0, 7.0)).unwrap();
    watch_until(&r, |s| s.states.iter().all(|m| m.q == 1.0));
    for _ in 0..20 {
        let s = watch_until(&r, |_| true);
        assert!(s.states.iter().all(|m| m.q == 1.0), "beyond the stop: {s:?}");
    }
    let f = emu.finger(0);
    assert_eq!((f.target_q, f.target_speed), (1.0, 1.0));
    // A malformed command (5 entries) is ignored: the hand stays, it is counted.
    w.write(MotorCmds_::with_len(5)).unwrap();
    wait_for("the malformed command counted", || emu.snapshot().rejected >= 1);
    assert_eq!(emu.finger(4).target_q, 1.0);
}

#[test]
fn client_device_drives_the_emulated_service_and_goes_stale_when_it_stops() {
    let node = Node::new(41, None).unwrap();
    let emu = BraincoEmulator::start(&node, BraincoConfig::new(Side::Right)).unwrap();
    let t = Arc::new(table(Side::Right));
    let dev = DdsDevice::start(
        &node,
        DeviceInfo {
            name: "brainco_right".into(),
            kind: DeviceKind::Brainco,
            side: Side::Right,
            backend: Backend::Dds,
            table: t.clone(),
        },
        DdsDeviceConfig {
            cmd_topic: "rt/brainco/right/cmd".into(),
            state_topic: Some("rt/brainco/right/state".into()),
            rate_hz: 100.0,
            stale_after: Duration::from_millis(200),
            forward: handgate_adapters::dds_device::Forwarding::default_for(100.0),
        },
        BraincoCodec::new(0.8),
    )
    .unwrap();
    let mut rx = dev.state();
    wait_for("fresh state", || rx.borrow_and_update().freshness == Freshness::Fresh);
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    wait_for("the closed command at the service", || {
        emu.snapshot()
            .last_command
            .is_some_and(|m| m.cmds.len() == 6 && m.cmds.iter().all(|e| (e.q - 1.0).abs() < 1e-5 && e.dq == 0.8))
    });
    wait_for("every finger closed (canonical = URDF upper limit)", || {
        let s = rx.borrow_and_update();
        s.joints
            .iter()
            .zip(t.joints.iter())
            .all(|(j, m)| (j.q - m.limits.max).abs() < 0.01)
    });
    assert!((rx.borrow().closure - 1.0).abs() < 0.01);
    // A new target: the fingers go back to a quarter closed.
    dev.command(HandCommand::closure(2, 0.25)).unwrap();
    wait_for("quarter closed", || (emu.finger(5).q - 0.25).abs() < 0.01);
    emu.stop();
    wait_for("stale after the service stops", || {
        rx.borrow_and_update().freshness == Freshness::Stale
    });
}

#[test]
fn the_service_opens_the_hand_from_its_rest_posture_at_start_up() {
    let node = Node::new(48, None).unwrap();
    // Slow fingers (a tenth of the default speed) and a hand left half closed, so the opening
    // is long enough to be watched from the first matched sample on.
    let mut cfg = BraincoConfig::new(Side::Right);
    cfg.noise = Noise::OFF;
    cfg.initial = [0.6; 6];
    cfg.tuning.full_speed = 0.1;
    let r = node
        .reader::<MotorStates_>("rt/brainco/right/state", Qos::Reliable { depth: 64 })
        .unwrap();
    let emu = BraincoEmulator::start(&node, cfg).unwrap();
    r.wait_matched(1, DEADLINE).unwrap();
    let first = watch_until(&r, |_| true);
    assert!(first.states.iter().all(|m| m.q > 0.0 && m.q <= 0.6), "{first:?}");
    let mut last = first.states[0].q;
    let s = watch_until(&r, |s| {
        assert!(s.states[0].q <= last + 1e-6, "opening, never closing: {s:?}");
        last = s.states[0].q;
        s.states.iter().all(|m| m.q == 0.0)
    });
    assert!(s.states.iter().all(|m| m.dq <= 0.0));
    let snap = emu.snapshot();
    assert_eq!(snap.commands, 0, "opened without any command");
    assert!(snap.fingers.iter().all(|f| f.target_q == 0.0 && f.target_speed == 1.0));
}

// ---- the registry: the emulator backend as the gateway opens it ----

#[test]
fn the_registry_opens_an_emulated_hand_that_honours_the_profile() {
    use handgate_adapters::brainco::config::BraincoProfile;
    use handgate_adapters::brainco::kind::BraincoKind;
    use handgate_adapters::kind::Kind;
    use handgate_adapters::open::{DeviceSpec, EmulatorSection, OpenEnv, Shared};
    use handgate_adapters::service_client::ClientOpen;

    let node = Node::new(49, None).unwrap();
    let kind = DeviceKind::by_name("brainco").expect("registered");
    let f = kind.factory();
    let table = Arc::new(table(Side::Left));
    let mut emulator = EmulatorSection {
        noise: Some(false),
        ..Default::default()
    };
    emulator.initial.insert("thumb".into(), 0.7592);
    emulator.object_at.insert("index".into(), 0.73305);
    let config = f.default_config();
    let spec = DeviceSpec {
        name: "reg_left",
        kind,
        side: Side::Left,
        backend: Backend::Emulator,
        rate_hz: 100.0,
        stale_after: Duration::from_millis(200),
        forward_on_arrival: true,
        max_send_hz: None,
        table: &table,
        emulator: &emulator,
        config: &*config,
    };
    match BraincoKind.configure(&spec.typed(&BraincoProfile::default())).unwrap() {
        ClientOpen {
            peer: Some(peer),
            config,
            codec: speed,
            ..
        } => {
            assert!((peer.initial[0] - 0.5).abs() < 1e-4, "thumb 0.7592 rad = wire 0.5");
            assert!(
                (peer.object[2].unwrap() - 0.5).abs() < 1e-4,
                "index 0.73305 rad = wire 0.5"
            );
            assert!(peer.noise.is_off());
            assert_eq!(peer.topics.as_ref().unwrap().0, "rt/handgate/emu/reg_left/cmd");
            assert_eq!(config.cmd_topic, "rt/handgate/emu/reg_left/cmd");
            assert_eq!(speed, 1.0);
        }
        other => panic!("{other:?}"),
    }
    let mut shared = Shared::default();
    let mut env = OpenEnv {
        node: &node,
        shared: &mut shared,
    };
    let dev = f.open(&spec, &mut env).unwrap();
    let mut rx = dev.state();
    wait_for("fresh state", || rx.borrow_and_update().freshness == Freshness::Fresh);
    dev.command(HandCommand::closure(1, 1.0)).unwrap();
    // Every finger closes but the index, which stops on the object at half its travel.
    wait_for("closed on the object", || {
        let s = rx.borrow_and_update();
        (s.joints[3].q - 1.4661).abs() < 0.01 && (s.joints[0].q - 1.5184).abs() < 0.01
    });
    let s = rx.borrow().clone();
    assert!((s.joints[2].q - 0.73305).abs() < 0.01, "index on the object: {s:?}");
    assert!(s.joints[2].tau > s.joints[3].tau, "pressing draws more current: {s:?}");
}

#[test]
fn joint_states_carry_the_brainco_urdf_names() {
    use handgate_adapters::front::joint_state;
    for side in [Side::Left, Side::Right] {
        let t = table(side);
        let st = handgate_adapters::model::HandState::empty(6);
        let mut out = joint_state::header(std::time::SystemTime::now(), "");
        joint_state::append(&mut out, &t, &st, true, "");
        let want: Vec<String> = ORACLE.iter().map(|(_, _, urdf, _)| format!("{side}_{urdf}")).collect();
        assert_eq!(out.name, want);
    }
}
