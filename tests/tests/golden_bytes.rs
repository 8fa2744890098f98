//! Byte-exact proof against the official Python SDK: every fixture in tests/fixtures/golden/
//! (written by tests/python/gen_golden.py with unitree_sdk2py 1.0.1 + CycloneDDS Python 0.10.2)
//! is rebuilt in Rust from its JSON values, and
//!   * `to_cdr_le` must produce exactly the SDK's bytes,
//!   * `from_cdr` of the SDK's bytes must give the value back,
//!   * `to_cdr_be` output must decode to the same value (cyclonedds-rs writes big-endian),
//!   * every truncation of the SDK's bytes must be a decode error, not a panic,
//!   * `TopicType::typename()` must be the fixture's `unitree_xx::msg::dds_::Type_` name.
//!
//! NaN cases are compared bit-for-bit (re-encoding) because NaN != NaN as a value.
//!
//! handgate's canonical types and the ROS 2 JointState_ chain have no SDK classes; their
//! fixtures come from CycloneDDS Python 0.10.2 serialising handgate's declarations
//! (tests/python/handgate_types.py), an independent XCDR1 implementation (u64/f64 alignment,
//! strings, booleans, sequences of primitives).

use std::fmt::Debug;

use handgate_idl::{from_cdr, handgate, ros2, to_cdr_be, to_cdr_le, unitree_go, unitree_hg, DdsTypeName, TopicType};
use handgate_tests::{golden_fixtures, Fixture, FromPlain};
use serde::{de::DeserializeOwned, Serialize};

const CASES: &[&str] = &["empty", "typical", "extreme", "nan"];

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn fixtures_of(module: &str, type_name: &str) -> Vec<Fixture> {
    let all = golden_fixtures().expect("golden fixtures readable (regenerate with `make fixtures`)");
    let mine: Vec<Fixture> = all
        .into_iter()
        .filter(|f| f.module == module && f.type_name == type_name)
        .collect();
    for case in CASES {
        assert!(
            mine.iter().any(|f| f.case == *case),
            "no {case} fixture for {module}::{type_name}; run `make fixtures`"
        );
    }
    mine
}

fn check_type<T>(module: &str, type_name: &str) -> Vec<(Fixture, T)>
where
    T: FromPlain + Serialize + DeserializeOwned + PartialEq + Debug + TopicType + DdsTypeName,
{
    let expected_name = format!("{module}::msg::dds_::{type_name}");
    assert_eq!(T::typename().to_str().unwrap(), expected_name);
    assert_eq!(T::DDS_TYPE_NAME, expected_name);
    assert!(!T::has_key(), "Unitree types are keyless");

    let mut out = Vec::new();
    for fx in fixtures_of(module, type_name) {
        let label = fx.label();
        assert_eq!(fx.dds_type_name, expected_name, "{label}: fixture type name");
        let has_nan = fx.value.to_string().contains("\"nan\"");
        let v: T = fx.value_as().unwrap_or_else(|e| panic!("{label}: {e}"));

        // Rust encodes exactly what the SDK encoded.
        let le = to_cdr_le(&v).unwrap_or_else(|e| panic!("{label}: {e}"));
        assert_eq!(
            hex(&le),
            hex(&fx.cdr_le),
            "{label}: to_cdr_le differs from unitree_sdk2py"
        );

        // Rust decodes the SDK's bytes to the same value.
        let back: T = from_cdr(&fx.cdr_le).unwrap_or_else(|e| panic!("{label}: decode: {e}"));
        assert_eq!(
            hex(&to_cdr_le(&back).unwrap()),
            hex(&fx.cdr_le),
            "{label}: decode/re-encode is not bit-exact"
        );
        if !has_nan {
            assert_eq!(back, v, "{label}: from_cdr(SDK bytes)");
        }

        // Big-endian (what cyclonedds-rs writes) round-trips to the same bits.
        let be = to_cdr_be(&v).unwrap();
        assert_eq!(&be[..4], &[0, 0, 0, 0], "{label}: big-endian encapsulation header");
        assert_eq!(&fx.cdr_le[..4], &[0, 1, 0, 0], "{label}: SDK wrote little-endian");
        assert_eq!(be.len(), le.len(), "{label}: same size in both byte orders");
        let from_be: T = from_cdr(&be).unwrap_or_else(|e| panic!("{label}: decode BE: {e}"));
        assert_eq!(
            hex(&to_cdr_le(&from_be).unwrap()),
            hex(&fx.cdr_le),
            "{label}: BE round trip"
        );
        if !has_nan {
            assert_eq!(from_be, v, "{label}: BE round trip value");
        }

        // Every strict prefix is an error, never a panic or a silently short value.
        for cut in 0..fx.cdr_le.len() {
            assert!(
                from_cdr::<T>(&fx.cdr_le[..cut]).is_err(),
                "{label}: {cut}-byte prefix decoded"
            );
        }
        out.push((fx, v));
    }
    out
}

fn case<'a, T>(all: &'a [(Fixture, T)], name: &str) -> &'a T {
    &all.iter()
        .find(|(f, _)| f.case == name)
        .unwrap_or_else(|| panic!("no {name} case"))
        .1
}

#[test]
fn hg_motor_cmd() {
    let all = check_type::<unitree_hg::MotorCmd_>("unitree_hg", "MotorCmd_");
    assert_eq!(case(&all, "empty"), &unitree_hg::MotorCmd_::default());
    // One reserve word: 4 header + 1 mode + 3 pad + 5 * 4 + 4.
    assert_eq!(all[0].0.cdr_le.len(), 32);
}

#[test]
fn hg_motor_state() {
    let all = check_type::<unitree_hg::MotorState_>("unitree_hg", "MotorState_");
    assert_eq!(case(&all, "empty"), &unitree_hg::MotorState_::default());
}

#[test]
fn hg_press_sensor_state() {
    let all = check_type::<unitree_hg::PressSensorState_>("unitree_hg", "PressSensorState_");
    assert_eq!(case(&all, "empty"), &unitree_hg::PressSensorState_::default());
}

#[test]
fn hg_imu_state() {
    let all = check_type::<unitree_hg::IMUState_>("unitree_hg", "IMUState_");
    assert_eq!(case(&all, "empty"), &unitree_hg::IMUState_::default());
    // No trailing padding after the final i16: 4 + 13 * 4 + 2.
    assert_eq!(all[0].0.cdr_le.len(), 58);
}

#[test]
fn hg_hand_cmd() {
    let all = check_type::<unitree_hg::HandCmd_>("unitree_hg", "HandCmd_");
    assert_eq!(case(&all, "empty"), &unitree_hg::HandCmd_::default());
    assert_eq!(case(&all, "sdk_default"), &unitree_hg::HandCmd_::sdk_default());
    let typical = case(&all, "typical");
    assert_eq!(typical.motor_cmd.len(), unitree_hg::DEX3_MOTORS);
    for (i, m) in typical.motor_cmd.iter().enumerate() {
        assert_eq!(m.mode, 0x10 | i as u8, "RIS mode byte: FOC, motor id {i}");
    }
    assert_eq!(case(&all, "extreme").motor_cmd.len(), 32);
}

#[test]
fn hg_hand_state() {
    let all = check_type::<unitree_hg::HandState_>("unitree_hg", "HandState_");
    assert_eq!(case(&all, "empty"), &unitree_hg::HandState_::default());
    assert_eq!(case(&all, "sdk_default"), &unitree_hg::HandState_::sdk_default());
    let typical = case(&all, "typical");
    assert_eq!(typical.motor_state.len(), unitree_hg::DEX3_MOTORS);
    assert_eq!(typical.press_sensor_state.len(), unitree_hg::DEX3_PRESS_SENSORS);
    assert!(typical.press_sensor_state[0].pressure[0] >= 100_000.0);
    assert!(typical.imu_state.quaternion[0] > 0.99);
    let extreme = case(&all, "extreme");
    assert_eq!((extreme.motor_state.len(), extreme.press_sensor_state.len()), (32, 32));
}

#[test]
fn go_motor_cmd() {
    let all = check_type::<unitree_go::MotorCmd_>("unitree_go", "MotorCmd_");
    assert_eq!(case(&all, "empty"), &unitree_go::MotorCmd_::default());
    // Three reserve words: 4 header + 1 mode + 3 pad + 5 * 4 + 3 * 4.
    assert_eq!(all[0].0.cdr_le.len(), 40);
}

#[test]
fn go_motor_cmds() {
    let all = check_type::<unitree_go::MotorCmds_>("unitree_go", "MotorCmds_");
    assert_eq!(case(&all, "empty"), &unitree_go::MotorCmds_::default());
    assert_eq!(case(&all, "typical"), &{
        let mut want = unitree_go::MotorCmds_::with_len(7);
        for (i, c) in want.cmds.iter_mut().enumerate() {
            c.q = 0.75 * i as f32;
            c.kp = 5.0;
            c.kd = 0.05;
        }
        want
    });
}

#[test]
fn go_motor_state() {
    let all = check_type::<unitree_go::MotorState_>("unitree_go", "MotorState_");
    assert_eq!(case(&all, "empty"), &unitree_go::MotorState_::default());
}

#[test]
fn go_motor_states() {
    let all = check_type::<unitree_go::MotorStates_>("unitree_go", "MotorStates_");
    assert_eq!(case(&all, "empty"), &unitree_go::MotorStates_::default());
    assert_eq!(case(&all, "extreme").states.len(), 32);
}

#[test]
fn handgate_joint_cmd() {
    let all = check_type::<handgate::JointCmd_>("handgate", "JointCmd_");
    assert_eq!(case(&all, "empty"), &handgate::JointCmd_::default());
}

#[test]
fn handgate_hand_cmd() {
    let all = check_type::<handgate::HandCmd_>("handgate", "HandCmd_");
    assert_eq!(case(&all, "empty"), &handgate::HandCmd_::default());
    // XCDR1 aligns the u64 `seq` to 8 and `closure` after the u8 mode to 4.
    let typical = case(&all, "typical");
    assert_eq!(typical.seq, 42);
    assert_eq!(typical.joints.len(), 7);
}

#[test]
fn handgate_joint_state() {
    let all = check_type::<handgate::JointState_>("handgate", "JointState_");
    assert_eq!(case(&all, "empty"), &handgate::JointState_::default());
}

#[test]
fn handgate_hand_state() {
    let all = check_type::<handgate::HandState_>("handgate", "HandState_");
    assert_eq!(case(&all, "empty"), &handgate::HandState_::default());
    assert_eq!(case(&all, "typical").pressure.len(), 9);
}

#[test]
fn handgate_device_status() {
    let all = check_type::<handgate::DeviceStatus_>("handgate", "DeviceStatus_");
    assert_eq!(case(&all, "empty"), &handgate::DeviceStatus_::default());
}

#[test]
fn handgate_gateway_status() {
    let all = check_type::<handgate::GatewayStatus_>("handgate", "GatewayStatus_");
    assert_eq!(case(&all, "empty"), &handgate::GatewayStatus_::default());
    // Non-ASCII (multi-byte UTF-8) and 300-byte strings survive byte-exactly.
    let extreme = case(&all, "extreme");
    assert!(extreme.devices.iter().any(|d| !d.device.is_ascii()));
    assert!(extreme
        .devices
        .iter()
        .any(|d| d.kind.len() == 300 || d.device.len() == 300));
}

#[test]
fn ros2_time() {
    let all = check_type::<ros2::Time_>("builtin_interfaces", "Time_");
    assert_eq!(case(&all, "empty"), &ros2::Time_::default());
}

#[test]
fn ros2_header() {
    let all = check_type::<ros2::Header_>("std_msgs", "Header_");
    assert_eq!(case(&all, "empty"), &ros2::Header_::default());
}

#[test]
fn ros2_joint_state() {
    let all = check_type::<ros2::JointState_>("sensor_msgs", "JointState_");
    assert_eq!(case(&all, "empty"), &ros2::JointState_::default());
    assert_eq!(case(&all, "typical").name[0], "left_hand_zero");
}

/// Every fixture file belongs to one of the types above (nothing is silently skipped).
#[test]
fn every_fixture_is_checked() {
    let known = [
        ("unitree_hg", "MotorCmd_"),
        ("unitree_hg", "MotorState_"),
        ("unitree_hg", "PressSensorState_"),
        ("unitree_hg", "IMUState_"),
        ("unitree_hg", "HandCmd_"),
        ("unitree_hg", "HandState_"),
        ("unitree_go", "MotorCmd_"),
        ("unitree_go", "MotorCmds_"),
        ("unitree_go", "MotorState_"),
        ("unitree_go", "MotorStates_"),
        ("handgate", "JointCmd_"),
        ("handgate", "HandCmd_"),
        ("handgate", "JointState_"),
        ("handgate", "HandState_"),
        ("handgate", "DeviceStatus_"),
        ("handgate", "GatewayStatus_"),
        ("builtin_interfaces", "Time_"),
        ("std_msgs", "Header_"),
        ("sensor_msgs", "JointState_"),
    ];
    let all = golden_fixtures().unwrap();
    assert!(all.len() >= known.len() * CASES.len());
    for f in &all {
        assert!(
            known.contains(&(f.module.as_str(), f.type_name.as_str())),
            "{} is not checked by any test",
            f.path.display()
        );
        assert!(
            CASES.contains(&f.case.as_str()) || f.case == "sdk_default",
            "{}: unknown case",
            f.path.display()
        );
    }
}
