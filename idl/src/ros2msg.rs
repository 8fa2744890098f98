//! The ROS 2 `.msg` definition of every wire type, in the form the MCAP `ros2msg` schema
//! encoding takes (the type's own definition, then each type it uses after a line of 80 `=`
//! and `MSG: pkg/Name`): what a recording stores so that any ROS 2 tool (Foxglove,
//! PlotJuggler, `ros2 bag`, `mcap-ros2-support`, `rosbags`) decodes its CDR messages.
//!
//! One home per schema: the field lists mirror the Rust twins in this crate (which mirror
//! the IDL), field for field in wire order; the interop tests decode recorded messages with
//! the Python `mcap-ros2-support` reader and compare them with the values sent.
//!
//! Names: a DDS type `pkg::msg::dds_::Name_` is the ROS 2 type `pkg/msg/Name` (the Unitree
//! types are Unitree's ROS 2 messages, `unitree_ros2`'s `unitree_hg`/`unitree_go` packages;
//! handgate's own are `handgate/msg/*`). The Inspire FTP types are not ROS types
//! (`inspire::inspire_hand_ctrl`); they get the ROS name `inspire/msg/inspire_hand_ctrl`.

use crate::DdsTypeName;
use crate::{handgate, inspire, ros2, unitree_go, unitree_hg};

/// The `ros2msg` schema of one wire type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgSchema {
    /// The DDS type name (`unitree_hg::msg::dds_::HandCmd_`).
    pub dds_type: &'static str,
    /// The ROS 2 type name (`unitree_hg/msg/HandCmd`), the MCAP schema name.
    pub ros_type: &'static str,
    /// The `.msg` text with its dependencies.
    pub text: &'static str,
}

macro_rules! dep {
    ($name:literal, $body:expr) => {
        concat!(
            "\n================================================================================\nMSG: ",
            $name,
            "\n",
            $body
        )
    };
}

// --- unitree_hg -----------------------------------------------------------------------------

macro_rules! hg_motor_cmd {
    () => {
        "uint8 mode\nfloat32 q\nfloat32 dq\nfloat32 tau\nfloat32 kp\nfloat32 kd\nuint32 reserve\n"
    };
}
macro_rules! hg_motor_state {
    () => {
        "uint8 mode\nfloat32 q\nfloat32 dq\nfloat32 ddq\nfloat32 tau_est\nint16[2] temperature\n\
float32 vol\nuint32[2] sensor\nuint32 motorstate\nuint32[4] reserve\n"
    };
}
macro_rules! hg_press {
    () => {
        "float32[12] pressure\nfloat32[12] temperature\nuint32 lost\nuint32 reserve\n"
    };
}
macro_rules! hg_imu {
    () => {
        "float32[4] quaternion\nfloat32[3] gyroscope\nfloat32[3] accelerometer\nfloat32[3] rpy\nint16 temperature\n"
    };
}

const HG_HAND_CMD: &str = concat!(
    "unitree_hg/MotorCmd[] motor_cmd\nuint32[4] reserve\n",
    dep!("unitree_hg/MotorCmd", hg_motor_cmd!())
);
const HG_HAND_STATE: &str = concat!(
    "unitree_hg/MotorState[] motor_state\nunitree_hg/PressSensorState[] press_sensor_state\n\
unitree_hg/IMUState imu_state\nfloat32 power_v\nfloat32 power_a\nfloat32 system_v\nfloat32 device_v\n\
uint32[2] error\nuint32[2] reserve\n",
    dep!("unitree_hg/MotorState", hg_motor_state!()),
    dep!("unitree_hg/PressSensorState", hg_press!()),
    dep!("unitree_hg/IMUState", hg_imu!())
);

// --- unitree_go -----------------------------------------------------------------------------

macro_rules! go_motor_cmd {
    () => {
        "uint8 mode\nfloat32 q\nfloat32 dq\nfloat32 tau\nfloat32 kp\nfloat32 kd\nuint32[3] reserve\n"
    };
}
macro_rules! go_motor_state {
    () => {
        "uint8 mode\nfloat32 q\nfloat32 dq\nfloat32 ddq\nfloat32 tau_est\nfloat32 q_raw\nfloat32 dq_raw\n\
float32 ddq_raw\nuint8 temperature\nuint32 lost\nuint32[2] reserve\n"
    };
}
const GO_MOTOR_CMDS: &str = concat!(
    "unitree_go/MotorCmd[] cmds\n",
    dep!("unitree_go/MotorCmd", go_motor_cmd!())
);
const GO_MOTOR_STATES: &str = concat!(
    "unitree_go/MotorState[] states\n",
    dep!("unitree_go/MotorState", go_motor_state!())
);

// --- handgate -------------------------------------------------------------------------------

macro_rules! handgate_joint_cmd {
    () => {
        "string name\nfloat32 q\nfloat32 dq\nfloat32 tau\nfloat32 kp\nfloat32 kd\n"
    };
}
macro_rules! handgate_joint_state {
    () => {
        "string name\nfloat32 q\nfloat32 dq\nfloat32 tau\nfloat32 temperature\n"
    };
}
macro_rules! handgate_device_status {
    () => {
        "string device\nstring kind\nstring backend\nuint8 freshness\nbool safe\nfloat32 cmd_rate_hz\n\
float32 state_rate_hz\nuint64 crc_errors\nuint64 bad_input\nuint64 watchdog_trips\nuint64 reconnects\n\
uint64 missed_cycles\nfloat32 age_ms\nuint64 foreign_cmd\nuint64 duplicate_cmd\nuint64 reordered_cmd\n\
uint64 late_cmd\nstring owner\nuint64 not_allowed_cmd\nuint8 motion\nstring motion_joint\nfloat32 tracking_error\nuint32 faults\n"
    };
}
const HANDGATE_HAND_CMD: &str = concat!(
    "uint64 seq\nuint8 mode\nfloat32 closure\nfloat32 stiffness\nhandgate/JointCmd[] joints\n",
    dep!("handgate/JointCmd", handgate_joint_cmd!())
);
const HANDGATE_HAND_STATE: &str = concat!(
    "string device\nstring kind\nstring side\nuint64 cmd_seq\nuint64 stamp_ns\nuint8 freshness\n\
float32 closure\nhandgate/JointState[] joints\nfloat32[] pressure\nfloat32[3] accelerometer\n\
float32[3] gyroscope\nfloat32 power_v\nfloat32 power_a\nuint32 faults\n",
    dep!("handgate/JointState", handgate_joint_state!())
);
const HANDGATE_STATUS: &str = concat!(
    "string profile\nuint64 uptime_ms\nhandgate/DeviceStatus[] devices\nhandgate/EndpointStatus[] endpoints\n\
handgate/Diagnostic[] diagnostics\nuint64 record_messages\nuint64 record_dropped\nuint32 domain\n\
string interface\nuint32 export_domain\nstring export_interface\nstring namespace\nstring host\n",
    dep!("handgate/DeviceStatus", handgate_device_status!()),
    dep!(
        "handgate/EndpointStatus",
        "string owner\nstring topic\nstring role\nuint32 matched\nstring[] who\n"
    ),
    dep!(
        "handgate/Diagnostic",
        "string owner\nstring topic\nstring kind\nstring detail\nstring fix\n"
    )
);

// --- sensor_msgs ----------------------------------------------------------------------------

const JOINT_STATE: &str = concat!(
    "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    dep!("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"),
    dep!("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n")
);

// --- diagnostic_msgs, control_msgs 6.8.0 ----------------------------------------------------

macro_rules! header_deps {
    () => {
        concat!(
            dep!("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"),
            dep!("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n")
        )
    };
}
macro_rules! key_value {
    () => {
        "string key\nstring value\n"
    };
}
const DIAGNOSTIC_ARRAY: &str = concat!(
    "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n",
    header_deps!(),
    dep!(
        "diagnostic_msgs/DiagnosticStatus",
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\n\
string hardware_id\ndiagnostic_msgs/KeyValue[] values\n"
    ),
    dep!("diagnostic_msgs/KeyValue", key_value!())
);
const HARDWARE_STATUS: &str = concat!(
    "std_msgs/Header header\nstring hardware_id\ncontrol_msgs/HardwareDeviceStatus[] hardware_device_states\n",
    header_deps!(),
    dep!(
        "control_msgs/HardwareDeviceStatus",
        "std_msgs/Header header\nstring device_id\ncontrol_msgs/GenericHardwareState[] hardware_status\n\
control_msgs/CANopenState[] canopen_states\ncontrol_msgs/EtherCATState[] ethercat_states\n\
control_msgs/VDA5050State[] vda5050_states\n"
    ),
    dep!(
        "control_msgs/GenericHardwareState",
        "uint8 health_status\nuint8[] error_domain\nuint8 operational_mode\nuint8 power_state\n\
uint8 connectivity_status\nstring manufacturer\nstring model\nstring firmware_version\n\
diagnostic_msgs/KeyValue[] state_details\n"
    ),
    dep!("diagnostic_msgs/KeyValue", key_value!()),
    dep!(
        "control_msgs/CANopenState",
        "uint8 node_id\nuint8 nmt_state\nuint8 dsp_402_state\nuint32 last_emcy_code\n"
    ),
    dep!(
        "control_msgs/EtherCATState",
        "uint16 slave_position\nstring vendor_id\nstring product_code\nuint8 al_state\nbool has_error\n\
uint16 al_status_code\n"
    ),
    dep!(
        "control_msgs/VDA5050State",
        "string order_id\nstring action_status\nuint32 last_node_id\nbool driving\nfloat64 battery_charge\n\
string operating_mode\nstring error_type\nstring error_description\n"
    )
);

// --- inspire --------------------------------------------------------------------------------

const INSPIRE_CTRL: &str =
    "int16[<=6] pos_set\nint16[<=6] angle_set\nint16[<=6] force_set\nint16[<=6] speed_set\nint8 mode\n";
const INSPIRE_STATE: &str = "int16[<=6] pos_act\nint16[<=6] angle_act\nint16[<=6] force_act\nint16[<=6] current\n\
uint8[<=6] err\nuint8[<=6] status\nuint8[<=6] temperature\n";
const INSPIRE_TOUCH: &str = "int16[<=9] fingerone_tip_touch\nint16[<=96] fingerone_top_touch\n\
int16[<=80] fingerone_palm_touch\nint16[<=9] fingertwo_tip_touch\nint16[<=96] fingertwo_top_touch\n\
int16[<=80] fingertwo_palm_touch\nint16[<=9] fingerthree_tip_touch\nint16[<=96] fingerthree_top_touch\n\
int16[<=80] fingerthree_palm_touch\nint16[<=9] fingerfour_tip_touch\nint16[<=96] fingerfour_top_touch\n\
int16[<=80] fingerfour_palm_touch\nint16[<=9] fingerfive_tip_touch\nint16[<=96] fingerfive_top_touch\n\
int16[<=9] fingerfive_middle_touch\nint16[<=96] fingerfive_palm_touch\nint16[<=112] palm_touch\n";

/// Every wire type's schema.
pub const SCHEMAS: &[MsgSchema] = &[
    MsgSchema {
        dds_type: unitree_hg::HandCmd_::DDS_TYPE_NAME,
        ros_type: "unitree_hg/msg/HandCmd",
        text: HG_HAND_CMD,
    },
    MsgSchema {
        dds_type: unitree_hg::HandState_::DDS_TYPE_NAME,
        ros_type: "unitree_hg/msg/HandState",
        text: HG_HAND_STATE,
    },
    MsgSchema {
        dds_type: unitree_go::MotorCmds_::DDS_TYPE_NAME,
        ros_type: "unitree_go/msg/MotorCmds",
        text: GO_MOTOR_CMDS,
    },
    MsgSchema {
        dds_type: unitree_go::MotorStates_::DDS_TYPE_NAME,
        ros_type: "unitree_go/msg/MotorStates",
        text: GO_MOTOR_STATES,
    },
    MsgSchema {
        dds_type: handgate::HandCmd_::DDS_TYPE_NAME,
        ros_type: "handgate/msg/HandCmd",
        text: HANDGATE_HAND_CMD,
    },
    MsgSchema {
        dds_type: handgate::HandState_::DDS_TYPE_NAME,
        ros_type: "handgate/msg/HandState",
        text: HANDGATE_HAND_STATE,
    },
    MsgSchema {
        dds_type: handgate::GatewayStatus_::DDS_TYPE_NAME,
        ros_type: "handgate/msg/GatewayStatus",
        text: HANDGATE_STATUS,
    },
    MsgSchema {
        dds_type: ros2::JointState_::DDS_TYPE_NAME,
        ros_type: "sensor_msgs/msg/JointState",
        text: JOINT_STATE,
    },
    MsgSchema {
        dds_type: ros2::DiagnosticArray_::DDS_TYPE_NAME,
        ros_type: "diagnostic_msgs/msg/DiagnosticArray",
        text: DIAGNOSTIC_ARRAY,
    },
    MsgSchema {
        dds_type: ros2::HardwareStatus_::DDS_TYPE_NAME,
        ros_type: "control_msgs/msg/HardwareStatus",
        text: HARDWARE_STATUS,
    },
    MsgSchema {
        dds_type: inspire::InspireHandCtrl::DDS_TYPE_NAME,
        ros_type: "inspire/msg/inspire_hand_ctrl",
        text: INSPIRE_CTRL,
    },
    MsgSchema {
        dds_type: inspire::InspireHandState::DDS_TYPE_NAME,
        ros_type: "inspire/msg/inspire_hand_state",
        text: INSPIRE_STATE,
    },
    MsgSchema {
        dds_type: inspire::InspireHandTouch::DDS_TYPE_NAME,
        ros_type: "inspire/msg/inspire_hand_touch",
        text: INSPIRE_TOUCH,
    },
];

/// The schema of DDS type `dds_type`, if it is a wire type of this crate.
pub fn schema(dds_type: &str) -> Option<&'static MsgSchema> {
    SCHEMAS.iter().find(|s| s.dds_type == dds_type)
}

/// The schema whose ROS 2 name is `ros_type`.
pub fn by_ros_type(ros_type: &str) -> Option<&'static MsgSchema> {
    SCHEMAS.iter().find(|s| s.ros_type == ros_type)
}

/// The ROS 2 name of a DDS topic: `rt/dex3/left/state` -> `/dex3/left/state` (ROS 2 prefixes
/// its topics with `rt`); a topic without the prefix keeps its name under a leading `/`.
pub fn ros_topic(dds_topic: &str) -> String {
    match dds_topic.strip_prefix("rt/") {
        Some(rest) => format!("/{rest}"),
        None => format!("/{}", dds_topic.trim_start_matches('/')),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_schema_has_its_dependencies_and_a_unique_name() {
        for s in SCHEMAS {
            assert_eq!(SCHEMAS.iter().filter(|o| o.ros_type == s.ros_type).count(), 1);
            // Every non-primitive field type is defined after a separator.
            for line in s
                .text
                .lines()
                .filter(|l| !l.is_empty() && !l.starts_with('=') && !l.starts_with("MSG:"))
            {
                let ty = line.split_whitespace().next().unwrap();
                let base = ty.split('[').next().unwrap();
                if base.contains('/') {
                    assert!(
                        s.text.contains(&format!("{}\nMSG: {base}\n", "=".repeat(80))),
                        "{}: {base}",
                        s.ros_type
                    );
                }
            }
        }
        assert_eq!(
            schema(unitree_hg::HandCmd_::DDS_TYPE_NAME).unwrap().ros_type,
            "unitree_hg/msg/HandCmd"
        );
    }

    /// The field names of a schema's main message and of its dependency `dep` ("" for the
    /// main one), in order.
    fn fields(text: &str, dep: &str) -> Vec<String> {
        let sep = "=".repeat(80);
        let part = if dep.is_empty() {
            text.split(&sep).next().unwrap().to_string()
        } else {
            let head = format!("MSG: {dep}\n");
            let at = text.find(&head).unwrap_or_else(|| panic!("no {dep}"));
            text[at + head.len()..].split(&sep).next().unwrap().to_string()
        };
        part.lines()
            .filter_map(|l| l.split_whitespace().nth(1))
            .map(str::to_string)
            .collect()
    }

    /// The serde field names of `T`, sorted (serde_json's map sorts them).
    fn serde_fields<T: serde::Serialize + Default>() -> Vec<String> {
        let v = serde_json::to_value(T::default()).unwrap();
        v.as_object().unwrap().keys().cloned().collect()
    }

    #[test]
    fn the_status_schemas_name_every_field_of_the_status_types() {
        let text = schema(handgate::GatewayStatus_::DDS_TYPE_NAME).unwrap().text;
        for (dep, want) in [
            ("", serde_fields::<handgate::GatewayStatus_>()),
            ("handgate/DeviceStatus", serde_fields::<handgate::DeviceStatus_>()),
        ] {
            let mut got = fields(text, dep);
            got.sort();
            assert_eq!(got, want, "{dep}: the schema text and the struct differ");
        }
    }

    #[test]
    fn the_health_schemas_name_every_field_of_the_ros_types() {
        // Constant lines (`byte OK=0`) are not fields.
        let fields = |text: &str, dep: &str| -> Vec<String> {
            let mut f: Vec<String> = fields(text, dep).into_iter().filter(|n| !n.contains('=')).collect();
            f.sort();
            f
        };
        let diag = schema(ros2::DiagnosticArray_::DDS_TYPE_NAME).unwrap().text;
        assert_eq!(fields(diag, ""), serde_fields::<ros2::DiagnosticArray_>());
        assert_eq!(
            fields(diag, "diagnostic_msgs/DiagnosticStatus"),
            serde_fields::<ros2::DiagnosticStatus_>()
        );
        assert_eq!(
            fields(diag, "diagnostic_msgs/KeyValue"),
            serde_fields::<ros2::KeyValue_>()
        );
        let hw = schema(ros2::HardwareStatus_::DDS_TYPE_NAME).unwrap().text;
        for (dep, want) in [
            ("", serde_fields::<ros2::HardwareStatus_>()),
            (
                "control_msgs/HardwareDeviceStatus",
                serde_fields::<ros2::HardwareDeviceStatus_>(),
            ),
            (
                "control_msgs/GenericHardwareState",
                serde_fields::<ros2::GenericHardwareState_>(),
            ),
            ("control_msgs/CANopenState", serde_fields::<ros2::CANopenState_>()),
            ("control_msgs/EtherCATState", serde_fields::<ros2::EtherCATState_>()),
            ("control_msgs/VDA5050State", serde_fields::<ros2::VDA5050State_>()),
        ] {
            assert_eq!(fields(hw, dep), want, "{dep}");
        }
    }

    #[test]
    fn ros_topics_drop_the_rt_prefix() {
        assert_eq!(ros_topic("rt/dex3/left/state"), "/dex3/left/state");
        assert_eq!(ros_topic("rt/joint_states"), "/joint_states");
        assert_eq!(ros_topic("plain"), "/plain");
    }
}
