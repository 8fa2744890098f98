"""handgate's canonical messages (idl/handgate.idl) and the ROS 2 JointState_ chain, declared for
CycloneDDS Python 0.10.2 (final, sequential ids; IDL octet as uint8, which encodes the same
single byte). Used only to produce reference CDR bytes for tests/fixtures/golden/; the IDL file is the
authority, and wire_schema.check_schema() keeps these field lists equal to SCHEMA.
"""

from dataclasses import dataclass

import cyclonedds.idl as idl
import cyclonedds.idl.annotations as annotate
import cyclonedds.idl.types as types
from cyclonedds.core import Policy, Qos
from cyclonedds.util import duration


@dataclass
@annotate.final
@annotate.autoid("sequential")
class JointCmd_(idl.IdlStruct, typename="handgate.msg.dds_.JointCmd_"):
    name: str
    q: types.float32
    dq: types.float32
    tau: types.float32
    kp: types.float32
    kd: types.float32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HandCmd_(idl.IdlStruct, typename="handgate.msg.dds_.HandCmd_"):
    seq: types.uint64
    mode: types.uint8
    closure: types.float32
    stiffness: types.float32
    joints: types.sequence[JointCmd_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class JointState_(idl.IdlStruct, typename="handgate.msg.dds_.JointState_"):
    name: str
    q: types.float32
    dq: types.float32
    tau: types.float32
    temperature: types.float32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HandState_(idl.IdlStruct, typename="handgate.msg.dds_.HandState_"):
    device: str
    kind: str
    side: str
    cmd_seq: types.uint64
    stamp_ns: types.uint64
    freshness: types.uint8
    closure: types.float32
    joints: types.sequence[JointState_]
    pressure: types.sequence[types.float32]
    accelerometer: types.array[types.float32, 3]
    gyroscope: types.array[types.float32, 3]
    power_v: types.float32
    power_a: types.float32
    faults: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class DeviceStatus_(idl.IdlStruct, typename="handgate.msg.dds_.DeviceStatus_"):
    device: str
    kind: str
    backend: str
    freshness: types.uint8
    safe: bool
    cmd_rate_hz: types.float32
    state_rate_hz: types.float32
    crc_errors: types.uint64
    bad_input: types.uint64
    watchdog_trips: types.uint64
    reconnects: types.uint64
    missed_cycles: types.uint64
    age_ms: types.float32
    foreign_cmd: types.uint64
    duplicate_cmd: types.uint64
    reordered_cmd: types.uint64
    late_cmd: types.uint64
    owner: str
    not_allowed_cmd: types.uint64
    motion: types.uint8
    motion_joint: str
    tracking_error: types.float32
    faults: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class EndpointStatus_(idl.IdlStruct, typename="handgate.msg.dds_.EndpointStatus_"):
    owner: str
    topic: str
    role: str
    matched: types.uint32
    who: types.sequence[str]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class Diagnostic_(idl.IdlStruct, typename="handgate.msg.dds_.Diagnostic_"):
    owner: str
    topic: str
    kind: str
    detail: str
    fix: str


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GatewayStatus_(idl.IdlStruct, typename="handgate.msg.dds_.GatewayStatus_"):
    profile: str
    uptime_ms: types.uint64
    devices: types.sequence[DeviceStatus_]
    endpoints: types.sequence[EndpointStatus_]
    diagnostics: types.sequence[Diagnostic_]
    record_messages: types.uint64
    record_dropped: types.uint64
    domain: types.uint32
    interface: str
    export_domain: types.uint32
    export_interface: str
    namespace: str
    host: str


# The status extension (idl/handgate.idl, docs/wire-types.md "Status: frozen, and its
# extension"): @appendable, XCDR2. Not in CLASSES (the golden fixtures are XCDR1 final types);
# tests/tests/status_compat.rs checks handgate's encoding of it against these classes.


@dataclass
@annotate.appendable
@annotate.autoid("sequential")
class FrontStatus_(idl.IdlStruct, typename="handgate.msg.dds_.FrontStatus_"):
    name: str
    kind: str
    cmd_rate_hz: types.float32
    state_rate_hz: types.float32


@dataclass
@annotate.appendable
@annotate.autoid("sequential")
class GatewayStatusExt_(idl.IdlStruct, typename="handgate.msg.dds_.GatewayStatusExt_"):
    version: types.uint32
    fronts: types.sequence[FrontStatus_]
    refused_participants: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class Time_(idl.IdlStruct, typename="builtin_interfaces.msg.dds_.Time_"):
    sec: types.int32
    nanosec: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class Header_(idl.IdlStruct, typename="std_msgs.msg.dds_.Header_"):
    stamp: Time_
    frame_id: str


@dataclass
@annotate.final
@annotate.autoid("sequential")
class RosJointState_(idl.IdlStruct, typename="sensor_msgs.msg.dds_.JointState_"):
    header: Header_
    name: types.sequence[str]
    position: types.sequence[types.float64]
    velocity: types.sequence[types.float64]
    effort: types.sequence[types.float64]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class Gid_(idl.IdlStruct, typename="rmw_dds_common.msg.dds_.Gid_"):
    data: types.array[types.uint8, 16]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class NodeEntitiesInfo_(idl.IdlStruct, typename="rmw_dds_common.msg.dds_.NodeEntitiesInfo_"):
    node_namespace: types.bounded_str[256]
    node_name: types.bounded_str[256]
    reader_gid_seq: types.sequence[Gid_]
    writer_gid_seq: types.sequence[Gid_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class ParticipantEntitiesInfo_(idl.IdlStruct, typename="rmw_dds_common.msg.dds_.ParticipantEntitiesInfo_"):
    """ROS 2 Iron and later (16-byte Gid): what rmw writes on `ros_discovery_info`. Read by
    tests/python/ros_peer.py only (not a golden fixture type, so not in CLASSES)."""

    gid: Gid_
    node_entities_info_seq: types.sequence[NodeEntitiesInfo_]


# ROS 2's health messages (idl/src/ros2.rs): diagnostic_msgs and control_msgs 6.8.0, with the
# DDS type names rmw_cyclonedds gives them. `byte` (DiagnosticStatus.level) is one octet on the
# wire, as uint8.


@dataclass
@annotate.final
@annotate.autoid("sequential")
class KeyValue_(idl.IdlStruct, typename="diagnostic_msgs.msg.dds_.KeyValue_"):
    key: str
    value: str


@dataclass
@annotate.final
@annotate.autoid("sequential")
class DiagnosticStatus_(idl.IdlStruct, typename="diagnostic_msgs.msg.dds_.DiagnosticStatus_"):
    level: types.uint8
    name: str
    message: str
    hardware_id: str
    values: types.sequence[KeyValue_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class DiagnosticArray_(idl.IdlStruct, typename="diagnostic_msgs.msg.dds_.DiagnosticArray_"):
    header: Header_
    status: types.sequence[DiagnosticStatus_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GenericHardwareState_(idl.IdlStruct, typename="control_msgs.msg.dds_.GenericHardwareState_"):
    health_status: types.uint8
    error_domain: types.sequence[types.uint8]
    operational_mode: types.uint8
    power_state: types.uint8
    connectivity_status: types.uint8
    manufacturer: str
    model: str
    firmware_version: str
    state_details: types.sequence[KeyValue_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class CANopenState_(idl.IdlStruct, typename="control_msgs.msg.dds_.CANopenState_"):
    node_id: types.uint8
    nmt_state: types.uint8
    dsp_402_state: types.uint8
    last_emcy_code: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class EtherCATState_(idl.IdlStruct, typename="control_msgs.msg.dds_.EtherCATState_"):
    slave_position: types.uint16
    vendor_id: str
    product_code: str
    al_state: types.uint8
    has_error: bool
    al_status_code: types.uint16


@dataclass
@annotate.final
@annotate.autoid("sequential")
class VDA5050State_(idl.IdlStruct, typename="control_msgs.msg.dds_.VDA5050State_"):
    order_id: str
    action_status: str
    last_node_id: types.uint32
    driving: bool
    battery_charge: types.float64
    operating_mode: str
    error_type: str
    error_description: str


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HardwareDeviceStatus_(idl.IdlStruct, typename="control_msgs.msg.dds_.HardwareDeviceStatus_"):
    header: Header_
    device_id: str
    hardware_status: types.sequence[GenericHardwareState_]
    canopen_states: types.sequence[CANopenState_]
    ethercat_states: types.sequence[EtherCATState_]
    vda5050_states: types.sequence[VDA5050State_]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class HardwareStatus_(idl.IdlStruct, typename="control_msgs.msg.dds_.HardwareStatus_"):
    header: Header_
    hardware_id: str
    hardware_device_states: types.sequence[HardwareDeviceStatus_]


def ros_default_qos():
    """ROS 2's default QoS for topics (rmw's `rmw_qos_profile_default`): reliable, volatile,
    keep last 10; what a ROS node's subscription uses unless told otherwise."""
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )


CLASSES = {
    "handgate/JointCmd_": JointCmd_,
    "handgate/HandCmd_": HandCmd_,
    "handgate/JointState_": JointState_,
    "handgate/HandState_": HandState_,
    "handgate/DeviceStatus_": DeviceStatus_,
    "handgate/EndpointStatus_": EndpointStatus_,
    "handgate/Diagnostic_": Diagnostic_,
    "handgate/GatewayStatus_": GatewayStatus_,
    "builtin_interfaces/Time_": Time_,
    "std_msgs/Header_": Header_,
    "sensor_msgs/JointState_": RosJointState_,
    "diagnostic_msgs/KeyValue_": KeyValue_,
    "diagnostic_msgs/DiagnosticStatus_": DiagnosticStatus_,
    "diagnostic_msgs/DiagnosticArray_": DiagnosticArray_,
    "control_msgs/GenericHardwareState_": GenericHardwareState_,
    "control_msgs/CANopenState_": CANopenState_,
    "control_msgs/EtherCATState_": EtherCATState_,
    "control_msgs/VDA5050State_": VDA5050State_,
    "control_msgs/HardwareDeviceStatus_": HardwareDeviceStatus_,
    "control_msgs/HardwareStatus_": HardwareStatus_,
}
