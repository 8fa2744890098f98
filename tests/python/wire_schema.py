"""Shared by gen_golden.py, interop_sub.py and interop_pub.py.

Maps handgate's fixture JSON ("plain" values) to and from the official unitree_sdk2py message
classes. The field lists below restate the layouts of docs/sources.md §1 (unitree_sdk2 / unitree_sdk2py
idl, wire order); `check_schema()` asserts they equal the SDK classes' own field order, so a
drift in the installed SDK fails loudly instead of producing wrong fixtures.

Plain-value conventions (the Rust side in tests/src/lib.rs reads the same):
  * integers are JSON integers, booleans JSON booleans, strings JSON strings (UTF-8 on the wire);
  * f64 values are JSON numbers or "inf"/"-inf"/"nan" (NaN = 0x7ff8000000000000);
  * f32 values are JSON numbers holding the exact (f32-representable) value, -0.0 included;
    the non-finite values are the strings "inf", "-inf" and "nan" (NaN = the quiet NaN
    0x7fc00000 that CPython's struct module writes for float('nan'));
  * fixed arrays and sequences are JSON arrays, nested structs JSON objects.
"""

import math
import struct
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
_REPO = _HERE.parent.parent


def _no_venv_hint():
    return (
        "unitree_sdk2py is not importable with %s. Run scripts/setup.sh (or `make test`) in %s to "
        "create .venv with cyclonedds==0.10.2 and unitree-sdk2==1.0.1." % (sys.executable, _REPO)
    )


try:
    from unitree_sdk2py.idl.unitree_go.msg import dds_ as go
    from unitree_sdk2py.idl.unitree_hg.msg import dds_ as hg
except Exception as exc:  # pragma: no cover - environment problem, explained to the user
    raise SystemExit("%s (%s)" % (_no_venv_hint(), exc))

# Scalar kinds: u8, i16, u32, f32 (and i8, i32, u64, f64, bool, string below). A field kind is
# a scalar, ("array", scalar, n), ("seq", type key or scalar), ("bseq", scalar, bound) for an
# IDL bounded sequence<scalar, bound>, or ("struct", type key).
SCHEMA = {
    "unitree_hg/MotorCmd_": [
        ("mode", "u8"), ("q", "f32"), ("dq", "f32"), ("tau", "f32"), ("kp", "f32"), ("kd", "f32"),
        ("reserve", "u32"),
    ],
    "unitree_hg/MotorState_": [
        ("mode", "u8"), ("q", "f32"), ("dq", "f32"), ("ddq", "f32"), ("tau_est", "f32"),
        ("temperature", ("array", "i16", 2)), ("vol", "f32"), ("sensor", ("array", "u32", 2)),
        ("motorstate", "u32"), ("reserve", ("array", "u32", 4)),
    ],
    "unitree_hg/PressSensorState_": [
        ("pressure", ("array", "f32", 12)), ("temperature", ("array", "f32", 12)), ("lost", "u32"),
        ("reserve", "u32"),
    ],
    "unitree_hg/IMUState_": [
        ("quaternion", ("array", "f32", 4)), ("gyroscope", ("array", "f32", 3)),
        ("accelerometer", ("array", "f32", 3)), ("rpy", ("array", "f32", 3)), ("temperature", "i16"),
    ],
    "unitree_hg/HandCmd_": [
        ("motor_cmd", ("seq", "unitree_hg/MotorCmd_")), ("reserve", ("array", "u32", 4)),
    ],
    "unitree_hg/HandState_": [
        ("motor_state", ("seq", "unitree_hg/MotorState_")),
        ("press_sensor_state", ("seq", "unitree_hg/PressSensorState_")),
        ("imu_state", ("struct", "unitree_hg/IMUState_")),
        ("power_v", "f32"), ("power_a", "f32"), ("system_v", "f32"), ("device_v", "f32"),
        ("error", ("array", "u32", 2)), ("reserve", ("array", "u32", 2)),
    ],
    "unitree_go/MotorCmd_": [
        ("mode", "u8"), ("q", "f32"), ("dq", "f32"), ("tau", "f32"), ("kp", "f32"), ("kd", "f32"),
        ("reserve", ("array", "u32", 3)),
    ],
    "unitree_go/MotorCmds_": [("cmds", ("seq", "unitree_go/MotorCmd_"))],
    "unitree_go/MotorState_": [
        ("mode", "u8"), ("q", "f32"), ("dq", "f32"), ("ddq", "f32"), ("tau_est", "f32"),
        ("q_raw", "f32"), ("dq_raw", "f32"), ("ddq_raw", "f32"), ("temperature", "u8"),
        ("lost", "u32"), ("reserve", ("array", "u32", 2)),
    ],
    "unitree_go/MotorStates_": [("states", ("seq", "unitree_go/MotorState_"))],
}

CLASSES = {
    "unitree_hg/MotorCmd_": hg.MotorCmd_,
    "unitree_hg/MotorState_": hg.MotorState_,
    "unitree_hg/PressSensorState_": hg.PressSensorState_,
    "unitree_hg/IMUState_": hg.IMUState_,
    "unitree_hg/HandCmd_": hg.HandCmd_,
    "unitree_hg/HandState_": hg.HandState_,
    "unitree_go/MotorCmd_": go.MotorCmd_,
    "unitree_go/MotorCmds_": go.MotorCmds_,
    "unitree_go/MotorState_": go.MotorState_,
    "unitree_go/MotorStates_": go.MotorStates_,
}

# handgate's canonical messages (idl/handgate.idl) and the ROS 2 JointState_ (idl/src/ros2.rs).
# unitree_sdk2py has no classes for them; handgate_types.py declares them for CycloneDDS Python,
# which then serves as the reference serialiser.
SCHEMA.update({
    "handgate/JointCmd_": [
        ("name", "string"), ("q", "f32"), ("dq", "f32"), ("tau", "f32"), ("kp", "f32"), ("kd", "f32"),
    ],
    "handgate/HandCmd_": [
        ("seq", "u64"), ("mode", "u8"), ("closure", "f32"), ("stiffness", "f32"),
        ("joints", ("seq", "handgate/JointCmd_")),
    ],
    "handgate/JointState_": [
        ("name", "string"), ("q", "f32"), ("dq", "f32"), ("tau", "f32"), ("temperature", "f32"),
    ],
    "handgate/HandState_": [
        ("device", "string"), ("kind", "string"), ("side", "string"), ("cmd_seq", "u64"),
        ("stamp_ns", "u64"), ("freshness", "u8"), ("closure", "f32"),
        ("joints", ("seq", "handgate/JointState_")), ("pressure", ("seq", "f32")),
        ("accelerometer", ("array", "f32", 3)), ("gyroscope", ("array", "f32", 3)),
        ("power_v", "f32"), ("power_a", "f32"), ("faults", "u32"),
    ],
    "handgate/DeviceStatus_": [
        ("device", "string"), ("kind", "string"), ("backend", "string"), ("freshness", "u8"),
        ("safe", "bool"), ("cmd_rate_hz", "f32"), ("state_rate_hz", "f32"), ("crc_errors", "u64"),
        ("bad_input", "u64"), ("watchdog_trips", "u64"), ("reconnects", "u64"),
        ("missed_cycles", "u64"), ("age_ms", "f32"), ("foreign_cmd", "u64"),
        ("duplicate_cmd", "u64"), ("reordered_cmd", "u64"), ("late_cmd", "u64"), ("owner", "string"),
        ("not_allowed_cmd", "u64"), ("motion", "u8"), ("motion_joint", "string"), ("tracking_error", "f32"),
        ("faults", "u32"),
    ],
    "handgate/EndpointStatus_": [
        ("owner", "string"), ("topic", "string"), ("role", "string"), ("matched", "u32"),
        ("who", ("seq", "string")),
    ],
    "handgate/Diagnostic_": [
        ("owner", "string"), ("topic", "string"), ("kind", "string"), ("detail", "string"),
        ("fix", "string"),
    ],
    "handgate/GatewayStatus_": [
        ("profile", "string"), ("uptime_ms", "u64"), ("devices", ("seq", "handgate/DeviceStatus_")),
        ("endpoints", ("seq", "handgate/EndpointStatus_")),
        ("diagnostics", ("seq", "handgate/Diagnostic_")),
        ("record_messages", "u64"), ("record_dropped", "u64"),
        ("domain", "u32"), ("interface", "string"), ("export_domain", "u32"),
        ("export_interface", "string"), ("namespace", "string"), ("host", "string"),
    ],
    "builtin_interfaces/Time_": [("sec", "i32"), ("nanosec", "u32")],
    "std_msgs/Header_": [("stamp", ("struct", "builtin_interfaces/Time_")), ("frame_id", "string")],
    "sensor_msgs/JointState_": [
        ("header", ("struct", "std_msgs/Header_")), ("name", ("seq", "string")),
        ("position", ("seq", "f64")), ("velocity", ("seq", "f64")), ("effort", ("seq", "f64")),
    ],
})

# ROS 2's health messages (idl/src/ros2.rs): diagnostic_msgs, and control_msgs 6.8.0.
SCHEMA.update({
    "diagnostic_msgs/KeyValue_": [("key", "string"), ("value", "string")],
    "diagnostic_msgs/DiagnosticStatus_": [
        ("level", "u8"), ("name", "string"), ("message", "string"), ("hardware_id", "string"),
        ("values", ("seq", "diagnostic_msgs/KeyValue_")),
    ],
    "diagnostic_msgs/DiagnosticArray_": [
        ("header", ("struct", "std_msgs/Header_")), ("status", ("seq", "diagnostic_msgs/DiagnosticStatus_")),
    ],
    "control_msgs/GenericHardwareState_": [
        ("health_status", "u8"), ("error_domain", ("seq", "u8")), ("operational_mode", "u8"),
        ("power_state", "u8"), ("connectivity_status", "u8"), ("manufacturer", "string"),
        ("model", "string"), ("firmware_version", "string"),
        ("state_details", ("seq", "diagnostic_msgs/KeyValue_")),
    ],
    "control_msgs/CANopenState_": [
        ("node_id", "u8"), ("nmt_state", "u8"), ("dsp_402_state", "u8"), ("last_emcy_code", "u32"),
    ],
    "control_msgs/EtherCATState_": [
        ("slave_position", "u16"), ("vendor_id", "string"), ("product_code", "string"),
        ("al_state", "u8"), ("has_error", "bool"), ("al_status_code", "u16"),
    ],
    "control_msgs/VDA5050State_": [
        ("order_id", "string"), ("action_status", "string"), ("last_node_id", "u32"),
        ("driving", "bool"), ("battery_charge", "f64"), ("operating_mode", "string"),
        ("error_type", "string"), ("error_description", "string"),
    ],
    "control_msgs/HardwareDeviceStatus_": [
        ("header", ("struct", "std_msgs/Header_")), ("device_id", "string"),
        ("hardware_status", ("seq", "control_msgs/GenericHardwareState_")),
        ("canopen_states", ("seq", "control_msgs/CANopenState_")),
        ("ethercat_states", ("seq", "control_msgs/EtherCATState_")),
        ("vda5050_states", ("seq", "control_msgs/VDA5050State_")),
    ],
    "control_msgs/HardwareStatus_": [
        ("header", ("struct", "std_msgs/Header_")), ("hardware_id", "string"),
        ("hardware_device_states", ("seq", "control_msgs/HardwareDeviceStatus_")),
    ],
})

import handgate_types as _hgt  # noqa: E402

CLASSES.update(_hgt.CLASSES)

# The Inspire FTP hand's own messages (module `inspire`, no msg::dds_; idl/inspire.idl, restated
# from inspire_hand_sdk's hand_idl/). Their Python classes are generated by CycloneDDS's own
# `idlc -l py` from that IDL file into tests/python/idl_gen/ (gen_golden.py regenerates them);
# the Inspire package itself is not on PyPI.
sys.path.insert(0, str(_HERE / "idl_gen"))
import inspire as _inspire  # noqa: E402

_TOUCH_SEGMENTS = [
    ("fingerone_tip_touch", 9), ("fingerone_top_touch", 96), ("fingerone_palm_touch", 80),
    ("fingertwo_tip_touch", 9), ("fingertwo_top_touch", 96), ("fingertwo_palm_touch", 80),
    ("fingerthree_tip_touch", 9), ("fingerthree_top_touch", 96), ("fingerthree_palm_touch", 80),
    ("fingerfour_tip_touch", 9), ("fingerfour_top_touch", 96), ("fingerfour_palm_touch", 80),
    ("fingerfive_tip_touch", 9), ("fingerfive_top_touch", 96), ("fingerfive_middle_touch", 9),
    ("fingerfive_palm_touch", 96), ("palm_touch", 112),
]
SCHEMA.update({
    "inspire/inspire_hand_ctrl": [
        ("pos_set", ("bseq", "i16", 6)), ("angle_set", ("bseq", "i16", 6)),
        ("force_set", ("bseq", "i16", 6)), ("speed_set", ("bseq", "i16", 6)), ("mode", "i8"),
    ],
    "inspire/inspire_hand_state": [
        ("pos_act", ("bseq", "i16", 6)), ("angle_act", ("bseq", "i16", 6)),
        ("force_act", ("bseq", "i16", 6)), ("current", ("bseq", "i16", 6)),
        ("err", ("bseq", "u8", 6)), ("status", ("bseq", "u8", 6)), ("temperature", ("bseq", "u8", 6)),
    ],
    "inspire/inspire_hand_touch": [(name, ("bseq", "i16", n)) for name, n in _TOUCH_SEGMENTS],
})
CLASSES.update({
    "inspire/inspire_hand_ctrl": _inspire.inspire_hand_ctrl,
    "inspire/inspire_hand_state": _inspire.inspire_hand_state,
    "inspire/inspire_hand_touch": _inspire.inspire_hand_touch,
})
# Modules whose DDS type names have no `msg::dds_` level.
FLAT_MODULES = ("inspire",)

# Keys whose classes come from the official SDK (the rest are handgate's declarations).
SDK_KEYS = [k for k in SCHEMA if k.startswith("unitree_")]

RANGES = {
    "i8": (-0x80, 0x7F),
    "u8": (0, 0xFF),
    "i16": (-0x8000, 0x7FFF),
    "u16": (0, 0xFFFF),
    "i32": (-0x8000_0000, 0x7FFF_FFFF),
    "u32": (0, 0xFFFF_FFFF),
    "u64": (0, 0xFFFF_FFFF_FFFF_FFFF),
}


def _is_struct_key(k):
    return "/" in k


def dds_type_name(key):
    """unitree_hg/HandCmd_ -> unitree_hg::msg::dds_::HandCmd_ (the name on the wire);
    inspire/inspire_hand_ctrl -> inspire::inspire_hand_ctrl."""
    module, name = key.split("/")
    if module in FLAT_MODULES:
        return "%s::%s" % (module, name)
    return "%s::msg::dds_::%s" % (module, name)


def python_type_name(key):
    """The SDK's dotted spelling, e.g. unitree_hg.msg.dds_.HandCmd_ or inspire.inspire_hand_ctrl."""
    return dds_type_name(key).replace("::", ".")


def check_schema():
    """Fails unless every SDK class has exactly our fields in our order and our type name."""
    for key, fields in SCHEMA.items():
        cls = CLASSES[key]
        sdk_fields = list(cls.__dataclass_fields__.keys())
        ours = [name for name, _ in fields]
        if sdk_fields != ours:
            raise SystemExit("schema drift in %s: SDK has %s, we have %s" % (key, sdk_fields, ours))
        tn = getattr(cls, "__idl_typename__", None)
        if tn is not None and tn != python_type_name(key):
            raise SystemExit("type name drift in %s: SDK says %s" % (key, tn))


def f32(x):
    """Rounds a Python float to the nearest f32 value (as a Python float)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def f32_from_bits(bits):
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def _plain_scalar(kind, v, where):
    if kind == "f64":
        v = float(v)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return v
    if kind == "bool":
        if not isinstance(v, bool):
            raise ValueError("%s: %r is not a bool" % (where, v))
        return v
    if kind == "string":
        if not isinstance(v, str):
            raise ValueError("%s: %r is not a string" % (where, v))
        return v
    if kind == "f32":
        v = float(v)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        if f32(v) != v:
            raise ValueError("%s: %r is not an f32 value" % (where, v))
        return v
    lo, hi = RANGES[kind]
    if not isinstance(v, int) or not lo <= v <= hi:
        raise ValueError("%s: %r out of range for %s" % (where, v, kind))
    return v


def _scalar_from_plain(kind, v, where):
    if kind in ("f32", "f64"):
        if isinstance(v, str):
            return {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}[v]
        return float(v)
    return _plain_scalar(kind, v, where)


def to_plain(key, msg, where=None):
    """SDK message object -> plain JSON-able dict (field order = wire order)."""
    where = where or key
    out = {}
    for name, kind in SCHEMA[key]:
        v = getattr(msg, name)
        w = "%s.%s" % (where, name)
        if isinstance(kind, str):
            out[name] = _plain_scalar(kind, v, w)
        elif kind[0] == "array":
            if len(v) != kind[2]:
                raise ValueError("%s: array length %d, want %d" % (w, len(v), kind[2]))
            out[name] = [_plain_scalar(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)]
        elif kind[0] == "bseq":
            if len(v) > kind[2]:
                raise ValueError("%s: %d elements, bound %d" % (w, len(v), kind[2]))
            out[name] = [_plain_scalar(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)]
        elif kind[0] == "seq" and not _is_struct_key(kind[1]):
            out[name] = [_plain_scalar(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)]
        elif kind[0] == "seq":
            out[name] = [to_plain(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)]
        else:
            out[name] = to_plain(kind[1], v, w)
    return out


def from_plain(key, plain, where=None):
    """Plain dict -> SDK message object. Rejects missing or unknown fields."""
    where = where or key
    names = [name for name, _ in SCHEMA[key]]
    if sorted(plain.keys()) != sorted(names):
        raise ValueError("%s: fields %s, want %s" % (where, sorted(plain.keys()), names))
    args = []
    for name, kind in SCHEMA[key]:
        v = plain[name]
        w = "%s.%s" % (where, name)
        if isinstance(kind, str):
            args.append(_scalar_from_plain(kind, v, w))
        elif kind[0] == "array":
            if len(v) != kind[2]:
                raise ValueError("%s: array length %d, want %d" % (w, len(v), kind[2]))
            args.append([_scalar_from_plain(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)])
        elif kind[0] == "bseq":
            if len(v) > kind[2]:
                raise ValueError("%s: %d elements, bound %d" % (w, len(v), kind[2]))
            args.append([_scalar_from_plain(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)])
        elif kind[0] == "seq" and not _is_struct_key(kind[1]):
            args.append([_scalar_from_plain(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)])
        elif kind[0] == "seq":
            args.append([from_plain(kind[1], x, "%s[%d]" % (w, i)) for i, x in enumerate(v)])
        else:
            args.append(from_plain(kind[1], v, w))
    return CLASSES[key](*args)
