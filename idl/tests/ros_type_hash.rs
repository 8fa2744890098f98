//! The REP-2011 hashes handgate computes from its type descriptions against the values ROS 2's
//! own generator published in generated code (docs/sources.md §9): `rosidl_generator_c`'s
//! `<type>__description.c` files, `get_type_hash` and the `EXPECTED_HASH` constants of the
//! referenced types, e.g. `sensor_msgs/msg/detail/joint_state__description.c`.

use handgate_idl::ros2::{self, RosType};
use handgate_idl::type_hash::user_data;

/// (type, published hash).
const PUBLISHED: &[(&str, &str)] = &[
    (
        "sensor_msgs/msg/JointState",
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    ),
    (
        "std_msgs/msg/Header",
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
    ),
    (
        "builtin_interfaces/msg/Time",
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    ),
    (
        "rmw_dds_common/msg/ParticipantEntitiesInfo",
        "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
    ),
    (
        "rmw_dds_common/msg/NodeEntitiesInfo",
        "RIHS01_8ffef65ee2d088c63b1e8fcd31e800ba9fc8dbe0ee15ca60d1676de5218087a7",
    ),
    (
        "rmw_dds_common/msg/Gid",
        "RIHS01_ab6f21cfbb0a6dbb837161e1110c2051a2850ed9f9c53944d7115d9bcebedf71",
    ),
    // diagnostic_msgs: `diagnostic_array__description.c` (ROS 2 Jazzy and later).
    (
        "diagnostic_msgs/msg/DiagnosticArray",
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e",
    ),
    (
        "diagnostic_msgs/msg/DiagnosticStatus",
        "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4",
    ),
    (
        "diagnostic_msgs/msg/KeyValue",
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42",
    ),
    // control_msgs 6.5.0 to 6.8.0: `hardware_status__description.c`.
    (
        "control_msgs/msg/HardwareStatus",
        "RIHS01_d4d081efebdea6d8863855733ea95c58338ac4ffdb501a9524da4cbbad9927a2",
    ),
    (
        "control_msgs/msg/HardwareDeviceStatus",
        "RIHS01_ecbdff2572d29afc687e31fe6e2006c95eda8d7bb5bb98fca1a262942c5e96cd",
    ),
    (
        "control_msgs/msg/GenericHardwareState",
        "RIHS01_bcaf0de2186757418ed4bb211738c0bb59fccb10f0612660e2c5048eb567d7bc",
    ),
    (
        "control_msgs/msg/CANopenState",
        "RIHS01_9a99909feb08be78066dc0922dad6d98e4e156883bca5bfac6f69d7cfa0d8c59",
    ),
    (
        "control_msgs/msg/EtherCATState",
        "RIHS01_baea23cdc1772b7c5b012bcaadee0a763b02938b9bc463fe5898a0021c7b1e09",
    ),
    (
        "control_msgs/msg/VDA5050State",
        "RIHS01_f80ff130c012ef7efd918e8056bb914b38fb36e84339d889bca5fc5681414a34",
    ),
];

fn published(type_name: &str) -> &'static str {
    PUBLISHED.iter().find(|(t, _)| *t == type_name).unwrap().1
}

#[test]
fn joint_state_hash_is_the_published_one() {
    assert_eq!(
        ros2::JointState_::DESCRIPTION.type_hash(),
        published("sensor_msgs/msg/JointState")
    );
    assert_eq!(
        user_data(ros2::JointState_::DESCRIPTION),
        b"typehash=RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e;".to_vec()
    );
}

#[test]
fn every_described_type_hashes_to_its_published_value() {
    let all = [
        ros2::JointState_::DESCRIPTION,
        ros2::Header_::DESCRIPTION,
        ros2::Time_::DESCRIPTION,
        ros2::ParticipantEntitiesInfo_::DESCRIPTION,
        ros2::NodeEntitiesInfo_::DESCRIPTION,
        ros2::Gid_::DESCRIPTION,
        ros2::DiagnosticArray_::DESCRIPTION,
        ros2::DiagnosticStatus_::DESCRIPTION,
        ros2::KeyValue_::DESCRIPTION,
        ros2::HardwareStatus_::DESCRIPTION,
        ros2::HardwareDeviceStatus_::DESCRIPTION,
        ros2::GenericHardwareState_::DESCRIPTION,
        ros2::CANopenState_::DESCRIPTION,
        ros2::EtherCATState_::DESCRIPTION,
        ros2::VDA5050State_::DESCRIPTION,
    ];
    assert_eq!(all.len(), PUBLISHED.len());
    for d in all {
        assert_eq!(d.type_hash(), published(d.type_name), "{}", d.type_name);
    }
}

#[test]
fn references_are_transitive_and_sorted() {
    let names: Vec<_> = ros2::JOINT_STATE.referenced().iter().map(|t| t.type_name).collect();
    assert_eq!(names, ["builtin_interfaces/msg/Time", "std_msgs/msg/Header"]);
    let names: Vec<_> = ros2::PARTICIPANT_ENTITIES_INFO
        .referenced()
        .iter()
        .map(|t| t.type_name)
        .collect();
    assert_eq!(names, ["rmw_dds_common/msg/Gid", "rmw_dds_common/msg/NodeEntitiesInfo"]);
}

/// The DDS type names rmw_cyclonedds gives these types (`<pkg>::msg::dds_::<Type>_`) follow
/// from the ROS names.
#[test]
fn dds_type_names_follow_the_ros_names() {
    use handgate_idl::DdsTypeName;
    fn dds(ros: &str) -> String {
        let mut p = ros.split('/');
        let (pkg, sub, ty) = (p.next().unwrap(), p.next().unwrap(), p.next().unwrap());
        format!("{pkg}::{sub}::dds_::{ty}_")
    }
    assert_eq!(dds(ros2::JOINT_STATE.type_name), ros2::JointState_::DDS_TYPE_NAME);
    assert_eq!(
        dds(ros2::PARTICIPANT_ENTITIES_INFO.type_name),
        ros2::ParticipantEntitiesInfo_::DDS_TYPE_NAME
    );
    assert_eq!(
        dds(ros2::DIAGNOSTIC_ARRAY.type_name),
        ros2::DiagnosticArray_::DDS_TYPE_NAME
    );
    assert_eq!(
        dds(ros2::HARDWARE_STATUS.type_name),
        ros2::HardwareStatus_::DDS_TYPE_NAME
    );
}
