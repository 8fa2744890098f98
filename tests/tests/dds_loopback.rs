//! Rust writer -> Rust reader over real CycloneDDS, for every Unitree wire type handgate uses.

use std::time::Duration;

use handgate_adapters::dds::{Node, Qos};
use handgate_idl::{unitree_go, unitree_hg};

const T: Duration = Duration::from_secs(10);

#[test]
fn hand_cmd_round_trips_between_rust_endpoints() {
    let node = Node::new(60, None).expect("participant");
    let mut w = node
        .writer::<unitree_hg::HandCmd_>("rt/test/dex3/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    let r = node
        .reader::<unitree_hg::HandCmd_>("rt/test/dex3/cmd", Qos::Reliable { depth: 10 })
        .unwrap();
    w.wait_matched(1, T).unwrap();
    r.wait_matched(1, T).unwrap();
    let mut cmd = unitree_hg::HandCmd_::sdk_default();
    for (i, m) in cmd.motor_cmd.iter_mut().enumerate() {
        m.mode = 0x10 | i as u8;
        m.q = i as f32 * 0.1;
        m.kp = 1.5;
    }
    cmd.reserve = [1, 2, 3, 4];
    w.write(cmd.clone()).unwrap();
    let got = r.wait_take(T).unwrap();
    assert_eq!(got.last().unwrap(), &cmd);
}

#[test]
fn motor_states_round_trip_with_callback_reader() {
    let node = Node::new(61, None).expect("participant");
    let (tx, rx) = std::sync::mpsc::channel();
    let r = node
        .reader_with_callback::<unitree_go::MotorStates_, _>("rt/test/dex1/state", Qos::BestEffort, move |h| {
            let mut v = Vec::new();
            h.take_into(&mut v);
            for s in v {
                let _ = tx.send(s);
            }
        })
        .unwrap();
    let mut w = node
        .writer::<unitree_go::MotorStates_>("rt/test/dex1/state", Qos::BestEffort)
        .unwrap();
    w.wait_matched(1, T).unwrap();
    r.wait_matched(1, T).unwrap();
    let mut st = unitree_go::MotorStates_::with_len(1);
    st.states[0].q = 5.4;
    st.states[0].temperature = 41;
    st.states[0].lost = 0xFFFF_FFFF;
    w.write(st.clone()).unwrap();
    assert_eq!(rx.recv_timeout(T).unwrap(), st);
}

/// A panic in a reader callback is caught in handgate's DDS layer: it never reaches
/// CycloneDDS's C frames (where it would abort the gateway, every device stopped where it is),
/// and the reader keeps delivering: the next sample calls the callback again.
#[test]
fn a_panicking_reader_callback_does_not_stop_the_reader() {
    let node = Node::new(59, None).expect("participant");
    let (tx, rx) = std::sync::mpsc::channel();
    let mut calls = 0u32;
    let r = node
        .reader_with_callback::<unitree_go::MotorStates_, _>(
            "rt/test/panicking",
            Qos::Reliable { depth: 10 },
            move |h| {
                let mut v = Vec::new();
                h.take_into(&mut v);
                calls += 1;
                if calls == 1 {
                    panic!("the first callback panics");
                }
                for s in v {
                    let _ = tx.send(s);
                }
            },
        )
        .unwrap();
    let mut w = node
        .writer::<unitree_go::MotorStates_>("rt/test/panicking", Qos::Reliable { depth: 10 })
        .unwrap();
    w.wait_matched(1, T).unwrap();
    r.wait_matched(1, T).unwrap();
    let mut st = unitree_go::MotorStates_::with_len(1);
    // Written until one arrives after the panic (the first callback may cover several).
    let got = (1..=100).find_map(|k| {
        st.states[0].q = k as f32;
        w.write(st.clone()).unwrap();
        rx.recv_timeout(Duration::from_millis(100)).ok()
    });
    assert!(got.is_some(), "no sample delivered after the callback panicked");
}
