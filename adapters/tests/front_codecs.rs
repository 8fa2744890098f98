//! The front codecs (`handgate_adapters::front`, `handgate_adapters::{dex3,dex1}::front`) through their public API: what docs/fronts.md
//! ("Bad input", "Dex3 front specifics", "Dex1 front specifics"), idl/handgate.idl and
//! docs/wire-types.md promise a client sees. Expected values are written out from those docs
//! (and docs/model.md's tables), never computed by the code under test. Written for the
//! mutation run on the fronts when they lived in `gateway/src/fronts/*.rs` (docs/reliability.md, section 5): each test
//! names the promise it checks.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use handgate_adapters::dex1::adapter::Variant;
use handgate_adapters::front::{canonical, joint_state, Rejection};
use handgate_adapters::mapping::DeviceTable;
use handgate_adapters::mapping::TableOverrides;
use handgate_adapters::model::{
    faults, CommandBody, DeviceKind, Freshness, HandState, JointState, Pad, Power, SafeAction, Side,
};
use handgate_adapters::{dex1::front as dex1, dex3::front as dex3};
use handgate_idl::{handgate as hg, unitree_go, unitree_hg};

fn table(kind: DeviceKind, side: Side) -> DeviceTable {
    kind.table(side, &TableOverrides::default()).unwrap()
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

// ---------------------------------------------------------------------------------------------
// Rejection reasons: the keys a rejected command is logged under (`reason=...`, one log line
// per second per front and reason) and that docs/reliability.md counts by.

#[test]
fn every_rejection_has_its_documented_reason_key() {
    let cases = [
        (Rejection::WrongCount { got: 6, want: 7 }, "wrong_count"),
        (Rejection::NonFinite(2), "non_finite"),
        (Rejection::WrongId { index: 3, id: 4 }, "wrong_id"),
        (Rejection::UnknownStatus { index: 1, status: 6 }, "unknown_status"),
        (Rejection::UnknownMode(9), "unknown_mode"),
        (Rejection::UnknownJoint("pinky".into()), "unknown_joint"),
        (Rejection::DuplicateJoint("jaw".into()), "duplicate_joint"),
        (Rejection::NoJoints, "no_joints"),
        (Rejection::BadClosure(f32::NAN), "bad_closure"),
    ];
    for (r, key) in cases {
        assert_eq!(r.reason(), key, "{r:?}");
    }
}

#[test]
fn rejections_from_the_decoders_carry_their_reason_keys() {
    let left = table(DeviceKind::Dex3, Side::Left);
    let mut short = dex3_cmd();
    short.motor_cmd.pop();
    assert_eq!(
        dex3::decode_cmd(&short, &left, &[]).unwrap_err().reason(),
        "wrong_count"
    );
    let grip = table(DeviceKind::Dex1, Side::Left);
    let mut nan = unitree_go::MotorCmds_::with_len(1);
    nan.cmds[0].dq = f32::NAN;
    assert_eq!(
        dex1::decode_go(&nan, Variant::Go, Side::Left, &grip)
            .unwrap_err()
            .reason(),
        "non_finite"
    );
    let unknown = hg::HandCmd_ {
        mode: 7,
        ..Default::default()
    };
    assert_eq!(
        canonical::decode_cmd(&unknown, &left, SafeAction::Hold)
            .unwrap_err()
            .reason(),
        "unknown_mode"
    );
}

// ---------------------------------------------------------------------------------------------
// Dex3 front.

/// Seven FOC entries (RIS status 1 = 0x10, id = index), as the SDK example sends them.
fn dex3_cmd() -> unitree_hg::HandCmd_ {
    let mut c = unitree_hg::HandCmd_::sdk_default();
    for (i, m) in c.motor_cmd.iter_mut().enumerate() {
        m.mode = 0x10 | i as u8;
        m.kp = 1.5;
        m.kd = 0.2;
    }
    c
}

#[test]
fn dex3_timeout_bit_on_any_entries_asks_for_the_timeout_protection() {
    let left = table(DeviceKind::Dex3, Side::Left);
    assert!(!dex3::decode_cmd(&dex3_cmd(), &left, &[]).unwrap().timeout_bit);
    // Bit 7 on one entry, on two, on all seven: each command asks for the motors' protection.
    for entries in [&[4][..], &[0, 6], &[0, 1, 2, 3, 4, 5, 6]] {
        let mut c = dex3_cmd();
        for &i in entries {
            c.motor_cmd[i].mode |= 0x80;
        }
        assert!(
            dex3::decode_cmd(&c, &left, &[]).unwrap().timeout_bit,
            "bit 7 on entries {entries:?}"
        );
    }
}

fn dex3_state(freshness: Freshness, faults: u32) -> HandState {
    HandState {
        joints: vec![JointState::default(); 7],
        freshness,
        faults,
        cmd_tag: 0xC0FFEE,
        ..Default::default()
    }
}

#[test]
fn dex3_reserve1_is_the_freshness_code_and_error1_bit0_is_set_only_while_stale() {
    let left = table(DeviceKind::Dex3, Side::Left);
    let joints = vec![JointState::default(); 7];
    // docs/fronts.md: reserve[1] 0 fresh, 1 stale, 2 commanded only; error[1] bit 0 while stale;
    // reserve[0] echoes the tag of the last applied command.
    for (freshness, code, stale_bit) in [
        (Freshness::Fresh, 0, 0),
        (Freshness::Stale, 1, 1),
        (Freshness::CommandedOnly, 2, 0),
    ] {
        let out = dex3::encode_state(&left, &joints, &dex3_state(freshness, 0));
        assert_eq!(out.reserve, [0xC0FFEE, code], "{freshness:?}");
        assert_eq!(out.error[1], stale_bit, "{freshness:?}");
    }
}

#[test]
fn dex3_error0_is_the_fault_set_without_the_safe_state_bit() {
    let left = table(DeviceKind::Dex3, Side::Left);
    let joints = vec![JointState::default(); 7];
    // Fault bits (docs/model.md): 0 motor error, 1 timeout, 2 link down, 3 CRC, 4 hardware,
    // 5 safe state. The safe state is the gateway's, not a device error: not in error[0].
    for (faults, error0) in [
        (0, 0),
        (1 << 5, 0),
        ((1 << 2) | (1 << 5), 0b100),
        ((1 << 1) | (1 << 2) | (1 << 3) | (1 << 5), 0b1110),
        (0b01_1111, 0b01_1111),
    ] {
        let out = dex3::encode_state(&left, &joints, &dex3_state(Freshness::Fresh, faults));
        assert_eq!(out.error[0], error0, "faults {faults:#b}");
    }
    assert_eq!(faults::SAFE_STATE, 1 << 5);
}

#[test]
fn dex3_motorstate_is_one_exactly_when_a_motor_reports_an_error() {
    let left = table(DeviceKind::Dex3, Side::Left);
    let joints = vec![JointState::default(); 7];
    // Fault bit 0 = a motor reports an error; no other fault is a motor error.
    for (faults, motorstate) in [
        (0, 0),
        (1 << 0, 1),
        (1 << 2, 0),
        ((1 << 1) | (1 << 4), 0),
        ((1 << 0) | (1 << 2), 1),
    ] {
        let out = dex3::encode_state(&left, &joints, &dex3_state(Freshness::Fresh, faults));
        assert_eq!(out.motor_state.len(), 7);
        for (i, m) in out.motor_state.iter().enumerate() {
            assert_eq!(m.motorstate, motorstate, "faults {faults:#b}, motor {i}");
        }
    }
}

#[test]
fn dex3_state_power_and_pads() {
    let left = table(DeviceKind::Dex3, Side::Left);
    let joints = vec![JointState::default(); 7];
    let mut st = dex3_state(Freshness::Fresh, 0);
    st.power = Some(Power {
        voltage: 24.5,
        current: 0.75,
    });
    st.pads = vec![Pad::dex3(0, [100_000.0; 12], [30.0; 12])];
    let out = dex3::encode_state(&left, &joints, &st);
    assert_eq!((out.power_v, out.power_a), (24.5, 0.75));
    assert!(out.motor_state.iter().all(|m| m.vol == 24.5));
    // Always 9 pads; 30000 = no reading where the device has none.
    assert_eq!(out.press_sensor_state.len(), 9);
    assert_eq!(out.press_sensor_state[0].pressure, [100_000.0; 12]);
    for p in &out.press_sensor_state[1..] {
        assert_eq!(p.pressure, [30_000.0; 12]);
    }
}

// ---------------------------------------------------------------------------------------------
// Dex1 front. Default range 5.4 rad, wire = 5.4 - jaw (docs/model.md): canonical jaw 0 = wire
// 5.4 (open), jaw 5.4 = wire 0 (closed).

fn dex1_state(freshness: Freshness, faults: u32) -> HandState {
    HandState {
        joints: vec![JointState::default()],
        freshness,
        faults,
        mode: 3,
        cmd_tag: 41,
        ..Default::default()
    }
}

#[test]
fn dex1_fresh_state_without_hardware_fault_reports_the_device_mode_and_lost_zero() {
    let grip = table(DeviceKind::Dex1, Side::Right);
    let now = Instant::now();
    let joint = JointState {
        q: 1.4,
        tau: 0.5,
        temperature: Some(36.6),
        ..Default::default()
    };
    // No fault, and faults that are not a hardware fault (bit 4): mode passes through.
    for faults in [0, 1 << 0, (1 << 2) | (1 << 3), 1 << 5] {
        let s = dex1::go_state(&grip, &joint, &dex1_state(Freshness::Fresh, faults), now);
        assert_eq!((s.mode, s.lost), (3, 0), "faults {faults:#b}");
        assert_eq!(s.reserve, [41, 0]);
        assert!(close(s.q, 4.0), "jaw 1.4 = wire 4.0, got {}", s.q);
        assert_eq!(s.q_raw, s.q);
        assert_eq!(s.temperature, 37);
    }
}

#[test]
fn dex1_stale_state_reports_the_age_in_ms_and_reserve1() {
    let grip = table(DeviceKind::Dex1, Side::Left);
    let t0 = Instant::now();
    let now = t0 + Duration::from_millis(250);
    let mut st = dex1_state(Freshness::Stale, 0);
    st.measured_at = Some(t0);
    let s = dex1::go_state(&grip, &JointState::default(), &st, now);
    assert_eq!((s.lost, s.reserve), (250, [41, 1]));
    assert_eq!(s.mode, 3);
    // Never measured: the saturated age.
    st.measured_at = None;
    let s = dex1::go_state(&grip, &JointState::default(), &st, now);
    assert_eq!((s.lost, s.reserve[1]), (0xFFFF_FFFE, 1));
    // The same state while fresh: no age.
    st.measured_at = Some(t0);
    st.freshness = Freshness::Fresh;
    let s = dex1::go_state(&grip, &JointState::default(), &st, now);
    assert_eq!((s.lost, s.reserve[1]), (0, 0));
}

#[test]
fn dex1_hardware_fault_gives_mode_255_and_lost_all_ones_even_while_stale() {
    let grip = table(DeviceKind::Dex1, Side::Left);
    let t0 = Instant::now();
    let mut st = dex1_state(Freshness::Stale, (1 << 4) | (1 << 2));
    st.measured_at = Some(t0);
    let s = dex1::go_state(&grip, &JointState::default(), &st, t0 + Duration::from_millis(30));
    assert_eq!((s.mode, s.lost, s.reserve[1]), (255, 0xFFFF_FFFF, 1));
}

#[test]
fn dex1_go_state_message_has_one_element_with_q_clamped_to_the_range() {
    let grip = table(DeviceKind::Dex1, Side::Left);
    let now = Instant::now();
    let st = dex1_state(Freshness::Fresh, 0);
    // A jaw measured slightly past open (wire 5.4001, the EZGripper's 5.4000001 bug) is
    // reported as 5.4; one past closed as 0.
    for (jaw, wire) in [(-0.0001, 5.4), (-1.0, 5.4), (6.0, 0.0), (2.7, 2.7)] {
        let out = dex1::encode_go(
            &grip,
            &JointState {
                q: jaw,
                ..Default::default()
            },
            &st,
            now,
        );
        assert_eq!(out.states.len(), 1);
        let s = &out.states[0];
        assert!(close(s.q, wire) && s.q <= 5.4 && s.q >= 0.0, "jaw {jaw}: {}", s.q);
        assert_eq!((s.mode, s.lost, s.reserve), (3, 0, [41, 0]));
    }
}

#[test]
fn dex1_hg_variant_state_motorstate_marks_a_hardware_fault_and_reserve_echoes() {
    let grip = table(DeviceKind::Dex1, Side::Left);
    let now = Instant::now();
    let joint = JointState {
        q: 0.4,
        temperature: Some(40.0),
        ..Default::default()
    };
    let fresh = dex1::encode_hg(&grip, &joint, &dex1_state(Freshness::Fresh, 0), now);
    assert_eq!(fresh.motor_state.len(), 1);
    let m = fresh.motor_state[0];
    assert_eq!((m.mode, m.motorstate, m.temperature), (3, 0, [40, 40]));
    assert!(close(m.q, 5.0), "jaw 0.4 = wire 5.0, got {}", m.q);
    assert_eq!(fresh.reserve, [41, 0]);

    let stale = dex1::encode_hg(&grip, &joint, &dex1_state(Freshness::Stale, 0), now);
    assert_eq!(stale.motor_state[0].motorstate, 0);
    assert_eq!(stale.reserve, [41, 1]);

    let fault = dex1::encode_hg(&grip, &joint, &dex1_state(Freshness::Fresh, 1 << 4), now);
    assert_eq!((fault.motor_state[0].mode, fault.motor_state[0].motorstate), (255, 1));
    assert_eq!(fault.reserve, [41, 0]);
}

#[test]
fn dex1_hg_variant_takes_exactly_one_motor_and_echoes_the_tag() {
    let grip = table(DeviceKind::Dex1, Side::Left);
    let mut c = unitree_hg::HandCmd_::with_motors(1);
    c.motor_cmd[0].q = 5.4;
    c.motor_cmd[0].kp = 5.0;
    c.reserve[0] = 1234;
    let d = dex1::decode_hg(&c, &grip).unwrap();
    assert_eq!(d.joints.len(), 1);
    assert!(close(d.joints[0].unwrap().q, 0.0), "wire 5.4 = open = jaw 0");
    assert_eq!(d.tag, 1234);
    c.motor_cmd[0].q = 1.0;
    assert!(close(dex1::decode_hg(&c, &grip).unwrap().joints[0].unwrap().q, 4.4));
    for n in [0, 2, 7] {
        assert_eq!(
            dex1::decode_hg(&unitree_hg::HandCmd_::with_motors(n), &grip),
            Err(Rejection::WrongCount { got: n, want: 1 })
        );
    }
    c.motor_cmd[0].tau = f32::NEG_INFINITY;
    assert_eq!(dex1::decode_hg(&c, &grip), Err(Rejection::NonFinite(0)));
}

#[test]
fn dex1_go_command_tag_is_the_elements_reserve0() {
    let grip = table(DeviceKind::Dex1, Side::Right);
    let mut c = unitree_go::MotorCmds_::with_len(1);
    c.cmds[0].q = 2.4;
    c.cmds[0].reserve = [99, 0, 0];
    let d = dex1::decode_go(&c, Variant::Go, Side::Right, &grip).unwrap();
    assert_eq!(d.tag, 99);
    assert!(close(d.joints[0].unwrap().q, 3.0));
    // Actuator: element 0 right, 1 left.
    let mut a = unitree_go::MotorCmds_::with_len(2);
    a.cmds[0].reserve[0] = 10;
    a.cmds[1].reserve[0] = 11;
    assert_eq!(
        dex1::decode_go(&a, Variant::Actuator, Side::Right, &grip).unwrap().tag,
        10
    );
    assert_eq!(
        dex1::decode_go(&a, Variant::Actuator, Side::Left, &grip).unwrap().tag,
        11
    );
}

// ---------------------------------------------------------------------------------------------
// Canonical front.

#[test]
fn canonical_closure_stiffness_positive_is_used_zero_means_profile_default() {
    let t = table(DeviceKind::Dex1, Side::Left);
    let closure = |closure, stiffness| {
        canonical::decode_cmd(
            &hg::HandCmd_ {
                mode: hg::MODE_CLOSURE,
                closure,
                stiffness,
                ..Default::default()
            },
            &t,
            SafeAction::Hold,
        )
    };
    assert_eq!(
        closure(0.5, 2.5),
        Ok(CommandBody::Closure {
            closure: 0.5,
            stiffness: Some(2.5)
        })
    );
    // idl/handgate.idl: "0 = profile default"; a negative stiffness is no stiffness either.
    for s in [0.0, -0.0, -3.0] {
        assert_eq!(
            closure(0.25, s),
            Ok(CommandBody::Closure {
                closure: 0.25,
                stiffness: None
            }),
            "stiffness {s}"
        );
    }
    assert_eq!(
        closure(-0.5, 1.0).unwrap(),
        CommandBody::Closure {
            closure: 0.0,
            stiffness: Some(1.0)
        }
    );
    assert_eq!(closure(0.5, f32::INFINITY), Err(Rejection::BadClosure(0.5)));
}

#[test]
fn canonical_state_carries_identity_seq_stamp_freshness_joints_and_faults() {
    let t = table(DeviceKind::Dex3, Side::Right);
    let mut st = HandState::empty(7);
    st.joints[6] = JointState {
        q: 1.25,
        dq: -0.5,
        tau: 0.125,
        temperature: Some(41.0),
    };
    st.cmd_seq = 77;
    st.closure = 0.75;
    st.faults = (1 << 2) | (1 << 5);
    st.freshness = Freshness::Fresh;
    st.measured_wall = Some(UNIX_EPOCH + Duration::new(1_700_000_000, 5));
    st.power = Some(Power {
        voltage: 24.0,
        current: 1.5,
    });
    let mut pad = Pad::dex3(0, [0.0; 12], [0.0; 12]);
    pad.pressure[3] = 120_000.0;
    st.pads = vec![pad];
    let out = canonical::encode_state("right_hand", &t, &st);
    assert_eq!(
        (out.device.as_str(), out.kind.as_str(), out.side.as_str()),
        ("right_hand", "dex3", "right")
    );
    assert_eq!((out.cmd_seq, out.stamp_ns), (77, 1_700_000_000_000_000_005));
    assert_eq!((out.freshness, out.closure, out.faults), (0, 0.75, 0b10_0100));
    let names: Vec<&str> = out.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        ["thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1"]
    );
    let j = &out.joints[6];
    assert_eq!((j.q, j.dq, j.tau, j.temperature), (1.25, -0.5, 0.125, 41.0));
    assert!(out.joints[0].temperature.is_nan(), "unknown temperature = NaN");
    assert_eq!(out.pressure, vec![120_000.0]);
    assert_eq!((out.power_v, out.power_a), (24.0, 1.5));

    for (freshness, code) in [(Freshness::Stale, 1), (Freshness::CommandedOnly, 2)] {
        st.freshness = freshness;
        assert_eq!(canonical::encode_state("right_hand", &t, &st).freshness, code);
    }
}

// ---------------------------------------------------------------------------------------------
// JointState front.

#[test]
fn joint_state_header_is_stamped_with_the_given_time_and_frame() {
    let now = UNIX_EPOCH + Duration::new(1_700_000_123, 456_789_012);
    let m = joint_state::header(now, "hands");
    assert_eq!(
        (m.header.stamp.sec, m.header.stamp.nanosec),
        (1_700_000_123, 456_789_012)
    );
    assert_eq!(m.header.frame_id, "hands");
    assert!(m.name.is_empty() && m.position.is_empty() && m.velocity.is_empty() && m.effort.is_empty());
    // Before the epoch: zero, not a panic.
    let early = joint_state::header(UNIX_EPOCH - Duration::from_secs(1), "");
    assert_eq!((early.header.stamp.sec, early.header.stamp.nanosec), (0, 0));
    // A real clock gives a stamp within a second of it.
    let wall = SystemTime::now();
    let secs = wall.duration_since(UNIX_EPOCH).unwrap().as_secs() as i64;
    let m = joint_state::header(wall, "");
    assert!((i64::from(m.header.stamp.sec) - secs).abs() <= 1);
}

/// The canonical front's topics, written out from docs/fronts.md's table:
/// `rt/handgate/{device}/cmd` and `rt/handgate/{device}/state`.
#[test]
fn canonical_topics_are_the_documented_ones() {
    assert_eq!(
        canonical::topics("dex3_left"),
        (
            "rt/handgate/dex3_left/cmd".to_string(),
            "rt/handgate/dex3_left/state".to_string()
        )
    );
    assert_eq!(
        canonical::topics("grip"),
        ("rt/handgate/grip/cmd".to_string(), "rt/handgate/grip/state".to_string())
    );
}
