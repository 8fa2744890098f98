//! The `dex5` front (handgate serving the Dex5-1 hand service's own `rt/dex5/{left,right}/*`,
//! docs/fronts.md) and the `dex5` kind through the real `handgate` binary:
//!
//! - a Dex5 client written as xr_teleoperate's `Dex5_1_Controller` on the official SDK
//!   (tests/python/xr_dex5_client.py) drives the emulated Dex5-1 pair of `sim-all`, every
//!   entry of both hands to its own target;
//! - closure pairing both ways: a Dex5 client closes and opens an emulated Dex3-1 through this
//!   front, and a Dex3 client (`dex3` front) closes and opens an emulated Dex5-1.
//!
//! Domains 26-28 (docs/development.md). Tests take turns ([`serial`]); every wait is on
//! readiness with a deadline. Needs the binary (`cargo build -p handgate`) and `.venv`.

use std::time::Duration;

use handgate_adapters::dds::Qos;
use handgate_adapters::mapping::{ClosureMap, DeviceTable, TableOverrides};
use handgate_adapters::model::{DeviceKind, Side};
use handgate_idl::handgate as hg;
use handgate_idl::unitree_hg;
use handgate_tests::{
    emulated_device, interop_interface, node, poll, serial, stream_until, temp_profile, Gateway, Latest, PyProcess,
};

const DEADLINE: Duration = Duration::from_secs(30);

/// `kind`'s table for the left hand.
fn table(kind: &str) -> DeviceTable {
    DeviceKind::by_name(kind)
        .expect("registered")
        .table(Side::Left, &TableOverrides::default())
        .unwrap()
}

/// The wire positions of `kind`'s left hand at its closed (`closed`) or open posture, in wire
/// order.
fn posture_wire(kind: &str, closed: bool) -> Vec<f32> {
    let t = table(kind);
    let ClosureMap::Postures { open, closed: shut, .. } = &t.closure else {
        panic!("{kind} closes by posture");
    };
    let canonical = if closed { shut } else { open };
    let mut wire = vec![0.0; t.joints.len()];
    for (j, q) in t.joints.iter().zip(canonical) {
        wire[j.wire_index] = j.q_to_wire(*q);
    }
    wire
}

/// A Dex5 client's command (as `Dex5_1_Controller` builds it: 20 entries, mode 0x01, its
/// gains) for the left-hand wire positions `q`.
fn dex5_cmd(q: &[f32]) -> unitree_hg::HandCmd_ {
    unitree_hg::HandCmd_ {
        motor_cmd: q
            .iter()
            .enumerate()
            .map(|(i, q)| unitree_hg::MotorCmd_ {
                mode: 0x01,
                q: *q,
                kp: if i >= 16 { 1.0 } else { 0.10 },
                kd: if i >= 16 { 0.02 } else { 0.001 },
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    }
}

/// A Dex3 client's command (RIS FOC mode with each motor's id, xr_teleoperate's gains) for
/// the left-hand wire positions `q`.
fn dex3_cmd(q: &[f32]) -> unitree_hg::HandCmd_ {
    unitree_hg::HandCmd_ {
        motor_cmd: q
            .iter()
            .enumerate()
            .map(|(i, q)| unitree_hg::MotorCmd_ {
                mode: 0x10 | i as u8,
                q: *q,
                kp: 1.5,
                kd: 0.2,
                ..Default::default()
            })
            .collect(),
        ..Default::default()
    }
}

/// The official-SDK Dex5 client drives both emulated Dex5-1 hands of `sim-all` through the
/// `dex5` fronts, each entry to its own target (so a swapped order, swapped hands or a
/// flipped direction fail), reading them back on the fronts' state in its own order.
#[test]
fn an_xr_teleoperate_dex5_client_drives_the_sim_all_pair() {
    let _serial = serial();
    const DOMAIN: u32 = 26;
    let gw = Gateway::start(DOMAIN, &["--profile", "sim-all"]);
    // URDF radians in the service's order: per long finger its spread, then three flex joints
    // (the last one at the coupling's share of the one before: the emulated linkage moves it,
    // docs/profiles.md "Assumptions"); then the thumb's yaw, roll (negative on the left),
    // and two flex joints.
    let coupling = handgate_adapters::dex5::table::COUPLING;
    let hand = |spread: f32, flex: [f32; 3], roll: f32| {
        let mut v = Vec::new();
        for (k, s) in [spread, -spread, spread / 2.0, -spread / 2.0].into_iter().enumerate() {
            let x3 = flex[1] - 0.1 * k as f32;
            v.extend([s, flex[0] + 0.1 * k as f32, x3, x3 * coupling]);
        }
        v.extend([0.2, roll, flex[0], flex[2]]);
        v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",")
    };
    let left = hand(0.2, [0.4, 1.0, 0.5], -0.6);
    let right = hand(-0.1, [0.9, 0.6, 1.2], 0.9);
    let mut args = vec![DOMAIN.to_string(), left, right];
    if let Some(i) = interop_interface() {
        args.push(i);
    }
    let py = PyProcess::spawn("xr_dex5_client.py", &args).expect("python client");
    py.wait_line("READY", DEADLINE)
        .unwrap_or_else(|e| panic!("{e}\n{}", gw.transcript()));
    py.wait_line("DONE ", DEADLINE * 2)
        .unwrap_or_else(|e| panic!("{e}\n{}\n{}", py.transcript(), gw.transcript()));
}

/// A Dex5 client closes and opens an emulated Dex3-1 left hand through the `dex5` front
/// (closure pairing).
#[test]
fn a_dex5_client_closes_and_opens_a_dex3() {
    let _serial = serial();
    let profile = temp_profile(
        "dex5-front",
        "dex5-front-dex3",
        &format!(
            "name = \"dex5-front-dex3\"\n{}[[fronts]]\nkind = \"dex5\"\ndevice = \"dex3_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"dex3_left\"\n",
            emulated_device("dex3_left", "dex3", "left"),
        ),
    );
    let gw = Gateway::start(27, &["--profile", profile.to_str().unwrap()]);
    let n = node(27);
    let mut w = n
        .writer::<unitree_hg::HandCmd_>("rt/dex5/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex3_left/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    let closed = stream_until(&mut w, &dex5_cmd(&posture_wire("dex5", true)), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(closed, "dex3 did not close: {:?}\n{}", canon.last, gw.transcript());
    let opened = stream_until(&mut w, &dex5_cmd(&posture_wire("dex5", false)), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "dex3 did not open: {:?}\n{}", canon.last, gw.transcript());
}

/// A Dex3 client closes and opens an emulated Dex5-1 left hand through the `dex3` front
/// (closure pairing).
#[test]
fn a_dex3_client_closes_and_opens_a_dex5() {
    let _serial = serial();
    let profile = temp_profile(
        "dex5-front",
        "dex3-front-dex5",
        &format!(
            "name = \"dex3-front-dex5\"\n{}[[fronts]]\nkind = \"dex3\"\ndevice = \"dex5_left\"\n[[fronts]]\nkind = \"canonical\"\ndevice = \"dex5_left\"\n",
            emulated_device("dex5_left", "dex5", "left"),
        ),
    );
    let gw = Gateway::start(28, &["--profile", profile.to_str().unwrap()]);
    let n = node(28);
    let mut w = n
        .writer::<unitree_hg::HandCmd_>("rt/dex3/left/cmd", Qos::Reliable { depth: 1 })
        .unwrap();
    let mut canon = Latest::<hg::HandState_>::new(&n, "rt/handgate/dex5_left/state", Qos::BestEffort);
    w.wait_matched(1, DEADLINE).unwrap();
    poll(DEADLINE, || {
        canon.update().filter(|s| s.freshness == hg::FRESH).cloned()
    })
    .unwrap_or_else(|| panic!("no fresh state\n{}", gw.transcript()));
    let closed = stream_until(&mut w, &dex3_cmd(&posture_wire("dex3", true)), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure > 0.95)
    });
    assert!(closed, "dex5 did not close: {:?}\n{}", canon.last, gw.transcript());
    let opened = stream_until(&mut w, &dex3_cmd(&posture_wire("dex3", false)), DEADLINE, || {
        canon.update().is_some_and(|s| s.closure < 0.05)
    });
    assert!(opened, "dex5 did not open: {:?}\n{}", canon.last, gw.transcript());
}
