//! The shipped `sim-all` profile: every device kind emulated at once, every front at its
//! standard topic. Through the real binary on DDS domain 95 (docs/development.md): every
//! device reports fresh in `handgate status`, and each hand's own interface publishes state
//! of the layout its clients expect.

use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_idl::handgate as hg;
use handgate_idl::{inspire, ros2, unitree_go, unitree_hg};
use handgate_tests::{interop_interface, node, poll, Gateway, Latest, PyProcess};

const DOMAIN: u32 = 95;
/// Generous: 11+ devices start on a shared 2-core machine (the EZGrippers calibrate first).
const DEADLINE: Duration = Duration::from_secs(60);

/// The devices of profiles/sim-all.toml, with their joint counts (docs/profiles.md).
const DEVICES: &[(&str, &str, usize)] = &[
    ("dex3_left", "dex3", 7),
    ("dex3_right", "dex3", 7),
    ("dex1_left", "dex1", 1),
    ("dex1_right", "dex1", 1),
    ("ezgripper_left", "ezgripper", 1),
    ("ezgripper_right", "ezgripper", 1),
    ("inspire_dfx_left", "inspire_dfx", 6),
    ("inspire_dfx_right", "inspire_dfx", 6),
    ("inspire_ftp_left", "inspire_ftp", 6),
    ("inspire_ftp_right", "inspire_ftp", 6),
    ("brainco_left", "brainco", 6),
    ("brainco_right", "brainco", 6),
    ("dex5_left", "dex5", 20),
    ("dex5_right", "dex5", 20),
    ("hand_sdk", "hand_sdk", 4),
];

#[test]
fn every_kind_of_sim_all_is_fresh_and_every_front_publishes() {
    let gw = Gateway::start(DOMAIN, &["--profile", "sim-all"]);
    let n = node(DOMAIN);
    let mut status = Latest::<hg::GatewayStatus_>::new(&n, "rt/handgate/status", Qos::Reliable { depth: 1 });
    // Every device reported fresh (hand_sdk: commanded only, its interface is one-way) in a
    // status sample; each device's own sample counts, so a gripper that misses one reply on a
    // loaded machine does not hide the others.
    let mut seen: std::collections::BTreeMap<String, (String, u8)> = Default::default();
    let done = poll(DEADLINE, || {
        status.update_with(|s| {
            for d in &s.devices {
                let ok = d.freshness == hg::FRESH || (d.kind == "hand_sdk" && d.freshness == hg::COMMANDED_ONLY);
                let e = seen.entry(d.device.clone()).or_insert((d.kind.clone(), d.freshness));
                if ok {
                    e.1 = d.freshness;
                }
            }
        });
        let all = DEVICES.iter().all(|(name, kind, _)| {
            seen.get(*name).is_some_and(|(k, f)| {
                k == kind && (*f == hg::FRESH || (*kind == "hand_sdk" && *f == hg::COMMANDED_ONLY))
            })
        });
        all.then_some(())
    });
    assert!(
        done.is_some(),
        "not every device fresh: {seen:?}\nlast: {:?}\n{}",
        status.last,
        gw.transcript()
    );
    assert_eq!(seen.len(), DEVICES.len(), "{seen:?}");

    // Each hand's own interface, in the layout its clients read.
    let mut dex3 = Latest::<unitree_hg::HandState_>::new(&n, "rt/dex3/left/state", Qos::BestEffort);
    let s = dex3.next(DEADLINE).expect("rt/dex3/left/state");
    assert_eq!(s.motor_state.len(), 7);
    let mut dex1 = Latest::<unitree_go::MotorStates_>::new(&n, "rt/dex1/right/state", Qos::BestEffort);
    assert_eq!(dex1.next(DEADLINE).expect("rt/dex1/right/state").states.len(), 1);
    let mut act = Latest::<unitree_go::MotorStates_>::new(&n, "rt/unitree_actuator/state", Qos::BestEffort);
    let a = act.next(DEADLINE).expect("rt/unitree_actuator/state");
    assert_eq!(a.states.len(), 2);
    assert!(a.states.iter().all(|m| m.lost == 0), "both grippers measured: {a:?}");
    let mut dfx = Latest::<unitree_go::MotorStates_>::new(&n, "rt/inspire/state", Qos::BestEffort);
    let d = dfx.next(DEADLINE).expect("rt/inspire/state");
    assert_eq!(d.states.len(), 12);
    // At rest the Inspire fingers are nearly open (q near 1 = open).
    assert!(d.states.iter().all(|m| m.q > 0.8), "{d:?}");
    // Inspire's FTP driver: state and the tactile arrays (1062 values per hand).
    let mut ftp = Latest::<inspire::InspireHandState>::new(&n, "rt/inspire_hand/state/r", Qos::BestEffort);
    assert_eq!(ftp.next(DEADLINE).expect("rt/inspire_hand/state/r").angle_act.len(), 6);
    let mut touch = Latest::<inspire::InspireHandTouch>::new(&n, "rt/inspire_hand/touch/l", Qos::BestEffort);
    touch.next(DEADLINE).expect("rt/inspire_hand/touch/l");
    // The BrainCo service opens the hand at start-up (q near 0 = open).
    let mut bc = Latest::<unitree_go::MotorStates_>::new(&n, "rt/brainco/left/state", Qos::BestEffort);
    let b = bc.next(DEADLINE).expect("rt/brainco/left/state");
    assert_eq!(b.states.len(), 6);

    // The three JointState topics together carry every joint of every device, each name
    // once per topic (the Inspire FTP and EZGripper pairs share URDF names with the Inspire
    // DFX and Dex1 pairs: they publish on their own topics).
    let mut joints = 0;
    for topic in [
        "rt/joint_states",
        "rt/inspire_ftp/joint_states",
        "rt/ezgripper/joint_states",
    ] {
        let mut js = Latest::<ros2::JointState_>::new(&n, topic, Qos::BestEffort);
        let j = js.next(DEADLINE).unwrap_or_else(|| panic!("{topic}"));
        let unique: std::collections::BTreeSet<&String> = j.name.iter().collect();
        assert_eq!(unique.len(), j.name.len(), "{topic} names a joint twice: {:?}", j.name);
        assert!(j.position.iter().all(|q| q.is_finite()), "{j:?}");
        joints += j.name.len();
    }
    assert_eq!(joints, DEVICES.iter().map(|(_, _, n)| n).sum::<usize>());
}

/// The official-SDK clients of the three G1 hands handgate serves besides Dex3 and Dex1,
/// written as xr_teleoperate's controllers write them (tests/python/xr_*_client.py: their
/// topics, messages, rates, waiting for state first), drive the emulated hands of `sim-all`
/// one after the other, every finger of both hands to its own target; each client reads the
/// state back in its own joint order and direction and prints DONE only when every entry
/// reads its own target. Domain 91 (one gateway; the clients take turns).
#[test]
fn xr_teleoperate_clients_of_the_new_hands_drive_sim_all() {
    const SDK_DOMAIN: u32 = 91;
    let gw = Gateway::start(SDK_DOMAIN, &["--profile", "sim-all"]);
    let csv = |v: &[f64; 6]| v.map(|x| x.to_string()).join(",");
    // (script, first hand's URDF radians, second hand's), in each client's argument order.
    let runs: [(&str, [f64; 6], [f64; 6]); 3] = [
        // DFX: RIGHT_RAD LEFT_RAD (pinky, ring, middle, index, thumb bend, thumb rotation).
        (
            "xr_inspire_dfx_client.py",
            [1.5, 1.1, 0.7, 0.3, 0.4, 0.2],
            [0.2, 0.6, 1.0, 1.4, 0.1, 1.0],
        ),
        // FTP: LEFT_RAD RIGHT_RAD (same joints).
        (
            "xr_inspire_ftp_client.py",
            [0.2, 0.6, 1.3, 1.05, 0.1, 1.0],
            [1.5, 1.1, 0.7, 0.3, 0.4, 0.2],
        ),
        // BrainCo: LEFT_RAD RIGHT_RAD (thumb, thumb aux, index, middle, ring, pinky).
        (
            "xr_brainco_client.py",
            [1.2, 0.3, 0.5, 0.9, 1.3, 0.1],
            [0.4, 0.8, 1.4, 0.2, 0.6, 1.0],
        ),
    ];
    for (script, a, b) in runs {
        let mut args = vec![SDK_DOMAIN.to_string(), csv(&a), csv(&b)];
        if let Some(i) = interop_interface() {
            args.push(i);
        }
        let py = PyProcess::spawn(script, &args).expect("python client");
        py.wait_line("READY", DEADLINE)
            .unwrap_or_else(|e| panic!("{script}: {e}\n{}", gw.transcript()));
        py.wait_line("DONE ", DEADLINE * 2)
            .unwrap_or_else(|e| panic!("{script}: {e}\n{}\n{}", py.transcript(), gw.transcript()));
    }
}
