#!/usr/bin/env python3
"""Writes the golden CDR fixtures in tests/fixtures/golden/ with the OFFICIAL Python SDK.

How to run (from the repository root):
    make fixtures                         # runs scripts/setup.sh first, then this script
    .venv/bin/python tests/python/gen_golden.py   # if .venv already exists

What it does: for each of the ten Unitree wire types handgate speaks (unitree_hg MotorCmd_,
MotorState_, PressSensorState_, IMUState_, HandCmd_, HandState_; unitree_go MotorCmd_,
MotorCmds_, MotorState_, MotorStates_) -- plus handgate's canonical types (idl/handgate.idl) and
the ROS 2 JointState_ chain and health messages (diagnostic_msgs, control_msgs 6.8.0), declared for CycloneDDS Python in handgate_types.py -- and each case (empty, typical, extreme, nan, plus
sdk_default for HandCmd_/HandState_) it builds the message with unitree_sdk2py's idl classes
(unitree-sdk2 1.0.1; handgate_types.py for the non-Unitree types) and serialises it with CycloneDDS Python 0.10.2 (`msg.serialize()`, plain
CDR / XCDR1, little-endian, with the 4-byte encapsulation header 00 01 00 00). It writes
`<module>__<Type>__<case>.json` holding the values and the hex of those bytes. The Rust test
tests/tests/golden_bytes.rs rebuilds each value in Rust and requires byte equality.

The Inspire FTP types (inspire::inspire_hand_ctrl/state/touch, idl/inspire.idl) have no installable
SDK: this script first regenerates their Python classes with CycloneDDS's own `idlc -l py` into
tests/python/idl_gen/ and serialises those (cases as above; "extreme" fills each bounded sequence
exactly to its bound, "sdk_default" is every sequence at its bound with zeros).

Deterministic: values are fixed or computed from indices, JSON is written with a fixed layout,
and files are rewritten only when their content changes. Re-running gives identical files.

Cases:
  empty       zero values; sequences empty (for the leaf structs this equals the SDK default
              factory, e.g. unitree_hg_msg_dds__MotorCmd_()).
  sdk_default the SDK default factory for HandCmd_ (7 zeroed motors) and HandState_ (7 motors,
              7 pads) -- differs from `empty` only for those two.
  typical     realistic values: 7 motors, RIS mode bytes 0x10|i, q in rad inside the Dex3-1
              limits, kp 1.5 kd 0.1, 9 pressure pads with raw readings >= 100000 (and one
              30000 "no reading"), a unit quaternion, power_v 24.x.
  extreme     f32 max/-max/min normal/subnormals/-0.0/+-inf, u32 max, i16 min/max, u8 255,
              sequences of 32 elements, 3 inside a sequence's element (f64/u64/i32/bool/string extremes for the canonical
              types: empty, non-ASCII and 300-byte strings).
  nan         every f32/f64 field NaN (CPython writes the quiet NaNs 0x7fc00000 and
              0x7ff8000000000000); 2-element sequences. Compared bit-for-bit on the Rust side (NaN != NaN as a value).
"""

import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

REPO = Path(__file__).resolve().parent.parent.parent
OUT = REPO / "tests" / "fixtures" / "golden"
IDL_GEN = REPO / "tests" / "python" / "idl_gen"
# IDL files whose Python classes CycloneDDS's own IDL compiler generates (idlc -l py).
IDL_FOR_PYTHON = [REPO / "idl" / "inspire.idl"]


def regenerate_idl_python():
    """Runs `idlc -l py -x final` (cyclonedds-tools 0.10.2 with the Python backend that ships in
    the venv's cyclonedds package) on IDL_FOR_PYTHON and updates tests/python/idl_gen/ where the
    output differs. -x final states idlc 0.10's default for unannotated structs (the public
    Inspire IDL has no annotation) and silences its warning about it."""
    import filecmp
    import os
    import shutil
    import subprocess
    import tempfile

    idlc = shutil.which("idlc")
    if idlc is None:
        raise SystemExit("idlc not found: run scripts/setup.sh (installs cyclonedds-tools)")
    env = dict(os.environ)
    # idlc's py backend runs `python3 -m cyclonedds.__idlc__`: make that the venv's Python.
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    changed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for idl_file in IDL_FOR_PYTHON:
            subprocess.run([idlc, "-l", "py", "-x", "final", str(idl_file)], cwd=tmp, env=env, check=True)
        for src in sorted(Path(tmp).rglob("*")):
            if not src.is_file():
                continue
            dst = IDL_GEN / src.relative_to(tmp)
            if dst.exists() and filecmp.cmp(src, dst, shallow=False):
                continue
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
            changed += 1
    print("gen_golden: idlc -l py: %d generated file(s) updated in %s" % (changed, IDL_GEN))


if __name__ == "__main__":
    regenerate_idl_python()

import wire_schema as ws  # noqa: E402
from wire_schema import f32, f32_from_bits  # noqa: E402

# --- typical values ---------------------------------------------------------------------------

# Left Dex3-1 joint targets (rad) inside the URDF limits of docs/sources.md §2, message order
# thumb_0, thumb_1, thumb_2, middle_0, middle_1, index_0, index_1.
LEFT_Q = [0.25, -0.35, 1.2, -0.9, -1.1, -0.75, -1.3]


def hg_motor_cmd_typical(i):
    return ws.hg.MotorCmd_(
        mode=0x10 | i, q=f32(LEFT_Q[i % 7]), dq=f32(0.05 * (i - 3)), tau=f32(0.02 * i),
        kp=f32(1.5), kd=f32(0.1), reserve=0,
    )


def hg_motor_state_typical(i):
    return ws.hg.MotorState_(
        mode=0x10 | i, q=f32(LEFT_Q[i % 7] - 0.01), dq=f32(-0.02 * i), ddq=f32(0.5 - 0.1 * i),
        tau_est=f32(0.11 * (i + 1)), temperature=[34 + i, 37 + i], vol=f32(24.3), sensor=[1200 + i, 3400 + i],
        motorstate=0, reserve=[0, 0, 0, 0],
    )


def hg_press_typical(pad):
    # Raw readings: >= 100000 is a valid contact reading, 30000 means "no reading" (docs/sources.md §2).
    pressure = [f32(100000.0 + 1250.5 * pad + 731.25 * k) for k in range(12)]
    pressure[11] = f32(30000.0)
    temperature = [f32(30.5 + 0.25 * k + 0.5 * pad) for k in range(12)]
    return ws.hg.PressSensorState_(pressure=pressure, temperature=temperature, lost=0, reserve=0)


def hg_imu_typical():
    half = 0.05  # a 0.1 rad roll
    return ws.hg.IMUState_(
        quaternion=[f32(math.cos(half)), f32(math.sin(half)), f32(0.0), f32(0.0)],
        gyroscope=[f32(0.012), f32(-0.021), f32(0.003)],
        accelerometer=[f32(0.12), f32(-0.98), f32(9.76)],
        rpy=[f32(0.1), f32(0.0), f32(-0.002)],
        temperature=38,
    )


def go_motor_cmd_typical(i):
    # Dex1-1 style (xr_teleoperate: kp 5.0, kd 0.05, mode 0; 0 rad closed, ~5.4 rad open).
    return ws.go.MotorCmd_(
        mode=0, q=f32(0.75 * i), dq=f32(0.0), tau=f32(0.0), kp=f32(5.0), kd=f32(0.05), reserve=[0, 0, 0],
    )


def go_motor_state_typical(i):
    return ws.go.MotorState_(
        mode=i % 4, q=f32(0.75 * i + 0.01), dq=f32(0.02 * i), ddq=f32(0.0), tau_est=f32(0.45),
        q_raw=f32(0.75 * i + 0.0125), dq_raw=f32(0.021 * i), ddq_raw=f32(0.0), temperature=41,
        lost=0, reserve=[0, 0],
    )


DEX3_JOINTS = ["thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1"]


def hg_device_status_typical(i):
    c = ws.CLASSES["handgate/DeviceStatus_"]
    kinds = [("left_dex3", "dex3", "usb"), ("right_dex1", "dex1", "dds"), ("center_ezgripper", "ezgripper", "serial")]
    device, kind, backend = kinds[i % 3]
    return c(
        device=device, kind=kind, backend=backend, freshness=i % 2, safe=(i == 2),
        cmd_rate_hz=f32(500.0 - 470.0 * (i == 2)), state_rate_hz=f32(500.0 - 300.0 * (i == 1)),
        crc_errors=3 * i, bad_input=i, watchdog_trips=0, reconnects=1, missed_cycles=12 + i,
        age_ms=f32(1.5 + 4.0 * i), foreign_cmd=7 * i, duplicate_cmd=5 * i, reordered_cmd=2 * i,
        late_cmd=i, owner=["front dex3_left: process xr_teleoperate (pid 4242) on op-laptop at 10.0.0.5", "", "front canonical"][i % 3],
        not_allowed_cmd=4 * i, motion=[0, 2, 1][i % 3], motion_joint=["", "jaw", "jaw"][i % 3],
        tracking_error=f32([0.012, 0.8, 1.25][i % 3]), faults=[0, 1 << 4, (1 << 0) | (1 << 5)][i % 3],
    )


def hg_endpoint_status_typical():
    return ws.CLASSES["handgate/EndpointStatus_"](
        owner="front dex1_left", topic="rt/dex1/left/cmd", role="reader", matched=1,
        who=["process python (pid 4242) on vm at 192.0.2.2"],
    )


def hg_diagnostic_typical():
    return ws.CLASSES["handgate/Diagnostic_"](
        owner="front dex1_left", topic="rt/dex1/left/cmd", kind="type_mismatch",
        detail="1 writer(s) on rt/dex1/left/cmd use type unitree_hg::msg::dds_::HandCmd_; "
               "this process serves unitree_go::msg::dds_::MotorCmds_",
        fix='the client speaks the seed-spec unitree_hg variant: set variant = "hg" on front dex1_left',
    )


def canonical_typical(key):
    c = ws.CLASSES
    if key == "handgate/JointCmd_":
        return c[key](name="index_0", q=f32(0.8), dq=f32(0.0), tau=f32(0.1), kp=f32(1.5), kd=f32(0.1))
    if key == "handgate/HandCmd_":
        joints = [c["handgate/JointCmd_"](n, f32(0.2 * i), f32(0.0), f32(0.0), f32(1.5), f32(0.1))
                  for i, n in enumerate(DEX3_JOINTS)]
        return c[key](seq=42, mode=0, closure=f32(0.0), stiffness=f32(0.0), joints=joints)
    if key == "handgate/JointState_":
        return c[key](name="thumb_1", q=f32(0.3), dq=f32(-0.02), tau=f32(0.12), temperature=f32(36.5))
    if key == "handgate/HandState_":
        joints = [c["handgate/JointState_"](n, f32(0.2 * i - 0.01), f32(-0.02 * i), f32(0.11 * i), f32(35.0 + i))
                  for i, n in enumerate(DEX3_JOINTS)]
        return c[key](
            device="left_dex3", kind="dex3", side="left", cmd_seq=42, stamp_ns=1_763_712_000_123_456_789,
            freshness=0, closure=f32(0.35), joints=joints, pressure=[f32(10.0 + 0.5 * p) for p in range(9)],
            accelerometer=[f32(0.12), f32(-0.98), f32(9.76)], gyroscope=[f32(0.012), f32(-0.021), f32(0.003)],
            power_v=f32(24.6), power_a=f32(0.85), faults=0,
        )
    if key == "handgate/DeviceStatus_":
        return hg_device_status_typical(0)
    if key == "handgate/EndpointStatus_":
        return hg_endpoint_status_typical()
    if key == "handgate/Diagnostic_":
        return hg_diagnostic_typical()
    if key == "handgate/GatewayStatus_":
        return c[key](profile="default", uptime_ms=3_600_000, devices=[hg_device_status_typical(i) for i in range(3)],
                      endpoints=[hg_endpoint_status_typical()], diagnostics=[hg_diagnostic_typical()],
                      record_messages=1_234_567, record_dropped=3, domain=0, interface="eth0",
                      export_domain=10, export_interface="eth1", namespace="/robot1", host="g1-pc2")
    if key == "builtin_interfaces/Time_":
        return c[key](sec=1_763_712_000, nanosec=123_456_789)
    if key == "std_msgs/Header_":
        return c[key](stamp=c["builtin_interfaces/Time_"](1_763_712_000, 123_456_789), frame_id="left_hand_base")
    if key == "sensor_msgs/JointState_":
        names = ["left_hand_" + n for n in ["zero", "one", "two", "three", "four", "five", "six"]]
        return c[key](
            header=c["std_msgs/Header_"](c["builtin_interfaces/Time_"](1_763_712_000, 5_000_000), ""),
            name=names, position=[0.1 * i for i in range(7)], velocity=[-0.01 * i for i in range(7)],
            effort=[],
        )
    if key.startswith(("diagnostic_msgs/", "control_msgs/")):
        return health_typical(key)
    raise KeyError(key)


def health_typical(key):
    """What handgate's health messages carry for a fresh and a stale hand (gateway/src/health.rs)."""
    c = ws.CLASSES
    stamp = c["std_msgs/Header_"](c["builtin_interfaces/Time_"](1_763_712_000, 250_000_000), "")
    kv = c["diagnostic_msgs/KeyValue_"]
    details = [kv("freshness", "fresh"), kv("safe", "false"), kv("state_rate_hz", "500.0"), kv("owner", "")]
    if key == "diagnostic_msgs/KeyValue_":
        return kv("state_rate_hz", "500.0")
    if key == "diagnostic_msgs/DiagnosticStatus_":
        return c[key](level=2, name="robot1/handgate: left_hand", message="stale: no state for 812 ms",
                      hardware_id="left_hand", values=details)
    if key == "diagnostic_msgs/DiagnosticArray_":
        return c[key](header=stamp, status=[
            c["diagnostic_msgs/DiagnosticStatus_"](0, "handgate: left_hand", "ok", "left_hand", details),
            c["diagnostic_msgs/DiagnosticStatus_"](1, "handgate: right_hand", "safe state", "right_hand", []),
        ])
    if key == "control_msgs/GenericHardwareState_":
        return c[key](health_status=4, error_domain=[2, 8], operational_mode=3, power_state=0,
                      connectivity_status=2, manufacturer="", model="dex3", firmware_version="",
                      state_details=details)
    if key == "control_msgs/CANopenState_":
        return c[key](node_id=3, nmt_state=5, dsp_402_state=4, last_emcy_code=0x8130)
    if key == "control_msgs/EtherCATState_":
        return c[key](slave_position=2, vendor_id="0x0000009a", product_code="0x00030924", al_state=8,
                      has_error=False, al_status_code=0)
    if key == "control_msgs/VDA5050State_":
        return c[key](order_id="order-7", action_status="RUNNING", last_node_id=12, driving=True,
                      battery_charge=87.5, operating_mode="AUTOMATIC", error_type="", error_description="")
    generic = c["control_msgs/GenericHardwareState_"](1, [0], 2, 0, 1, "", "dex3", "", details)
    if key == "control_msgs/HardwareDeviceStatus_":
        return c[key](header=stamp, device_id="left_hand", hardware_status=[generic], canopen_states=[],
                      ethercat_states=[], vda5050_states=[])
    if key == "control_msgs/HardwareStatus_":
        dev = c["control_msgs/HardwareDeviceStatus_"]
        return c[key](header=stamp, hardware_id="handgate", hardware_device_states=[
            dev(stamp, "left_hand", [generic], [], [], []),
            dev(stamp, "right_hand", [c["control_msgs/GenericHardwareState_"](4, [2], 2, 0, 2, "", "dex3", "", [])],
                [], [], []),
        ])
    raise KeyError(key)


# Inspire FTP: register units 0..1000 (angle 1000 = finger straight/open, 0 = closed), order
# pinky, ring, middle, index, thumb bend, thumb rotation (docs/sources.md §7).
def inspire_typical(key):
    c = ws.CLASSES[key]
    if key == "inspire/inspire_hand_ctrl":
        # Angle + force + speed (mode 0b1101): a half-closed grasp with a force limit.
        return c(pos_set=[0] * 6, angle_set=[400, 420, 450, 500, 600, 900], force_set=[500] * 6,
                 speed_set=[1000, 1000, 1000, 1000, 800, 800], mode=0b1101)
    if key == "inspire/inspire_hand_state":
        return c(pos_act=[1220, 1180, 1105, 1003, 845, 210], angle_act=[402, 421, 449, 501, 598, 899],
                 force_act=[12, -3, 0, 47, 130, 5], current=[35, 33, 30, 41, 88, 12],
                 err=[0, 0, 0, 0, 1, 0], status=[2, 2, 2, 3, 1, 2], temperature=[36, 36, 37, 38, 41, 35])
    if key == "inspire/inspire_hand_touch":
        fields = {}
        for seg, (name, kind) in enumerate(ws.SCHEMA[key]):
            fields[name] = [(37 * k + 101 * seg) % 4096 for k in range(kind[2])]
        return c(**fields)
    raise KeyError(key)


def typical(key):
    if key.startswith("inspire/"):
        return inspire_typical(key)
    if not key.startswith("unitree_"):
        return canonical_typical(key)
    if key == "unitree_hg/MotorCmd_":
        return hg_motor_cmd_typical(3)
    if key == "unitree_hg/MotorState_":
        return hg_motor_state_typical(2)
    if key == "unitree_hg/PressSensorState_":
        return hg_press_typical(0)
    if key == "unitree_hg/IMUState_":
        return hg_imu_typical()
    if key == "unitree_hg/HandCmd_":
        return ws.hg.HandCmd_(motor_cmd=[hg_motor_cmd_typical(i) for i in range(7)], reserve=[0, 0, 0, 0])
    if key == "unitree_hg/HandState_":
        return ws.hg.HandState_(
            motor_state=[hg_motor_state_typical(i) for i in range(7)],
            press_sensor_state=[hg_press_typical(p) for p in range(9)],
            imu_state=hg_imu_typical(),
            power_v=f32(24.6), power_a=f32(0.85), system_v=f32(24.5), device_v=f32(12.1),
            error=[0, 0], reserve=[0, 0],
        )
    if key == "unitree_go/MotorCmd_":
        return go_motor_cmd_typical(3)
    if key == "unitree_go/MotorCmds_":
        return ws.go.MotorCmds_(cmds=[go_motor_cmd_typical(i) for i in range(7)])
    if key == "unitree_go/MotorState_":
        return go_motor_state_typical(3)
    if key == "unitree_go/MotorStates_":
        return ws.go.MotorStates_(states=[go_motor_state_typical(i) for i in range(7)])
    raise KeyError(key)


# --- generic fillers (empty / extreme / nan) --------------------------------------------------

F32_EXTREMES = [
    f32_from_bits(0x7F7F_FFFF),  # f32::MAX
    f32_from_bits(0xFF7F_FFFF),  # f32::MIN (most negative)
    f32_from_bits(0x0080_0000),  # smallest positive normal
    f32_from_bits(0x0000_0001),  # smallest positive subnormal
    f32_from_bits(0x007F_FFFF),  # largest subnormal
    -0.0,
    math.inf,
    -math.inf,
    f32_from_bits(0x8000_0001),  # smallest negative subnormal
    f32(-1.5),
]
F64_EXTREMES = [
    1.7976931348623157e308,  # f64::MAX
    -1.7976931348623157e308,
    2.2250738585072014e-308,  # smallest positive normal
    5e-324,  # smallest positive subnormal
    -0.0,
    math.inf,
    -math.inf,
    0.1,
]
INT_EXTREMES = {
    "i8": [-128, 127, -1],
    "u8": [255, 0, 0x80],
    "i16": [-32768, 32767, -1],
    "u16": [0xFFFF, 0, 0x8000],
    "i32": [-0x8000_0000, 0x7FFF_FFFF, -1],
    "u32": [0xFFFF_FFFF, 0, 0x8000_0000],
    "u64": [0xFFFF_FFFF_FFFF_FFFF, 0, 0x8000_0000_0000_0000],
    "bool": [True, False],
    # Empty, non-ASCII (UTF-8 on the wire) and long strings.
    "string": ["", "d\u00e9j\u00e0_\u2713_\U0001f91a", "n" * 300],
}


class Filler:
    """Builds a message by walking the schema; scalars come from per-kind generators."""

    def __init__(self, scalar, seq_len, inner_seq_len=None):
        self.scalar = scalar
        self.seq_len = seq_len
        # Sequences nest (GatewayStatus_ -> DeviceStatus_/EndpointStatus_ -> sequences of
        # strings): filling every level to `seq_len` multiplies sizes (495 KB for one status),
        # so sequences inside an element of a sequence get `inner_seq_len` elements.
        self.inner_seq_len = seq_len if inner_seq_len is None else inner_seq_len

    def build(self, key):
        plain = self.plain(key)
        return ws.from_plain(key, plain)

    def plain(self, key, inner=False):
        n = self.inner_seq_len if inner else self.seq_len
        out = {}
        for name, kind in ws.SCHEMA[key]:
            if isinstance(kind, str):
                out[name] = self.scalar(kind)
            elif kind[0] == "array":
                out[name] = [self.scalar(kind[1]) for _ in range(kind[2])]
            elif kind[0] == "bseq":
                # Bounded: never more than the bound ("extreme" fills it exactly).
                out[name] = [self.scalar(kind[1]) for _ in range(min(n, kind[2]))]
            elif kind[0] == "seq" and "/" not in kind[1]:
                out[name] = [self.scalar(kind[1]) for _ in range(n)]
            elif kind[0] == "seq":
                out[name] = [self.plain(kind[1], inner=True) for _ in range(n)]
            else:
                out[name] = self.plain(kind[1], inner)
        return out


ZEROS = {"f32": 0.0, "f64": 0.0, "bool": False, "string": ""}


def zero_scalar(kind):
    return ZEROS.get(kind, 0)


def cycling_extremes():
    counters = {}

    def scalar(kind):
        values = {"f32": F32_EXTREMES, "f64": F64_EXTREMES}.get(kind) or INT_EXTREMES[kind]
        i = counters.get(kind, 0)
        counters[kind] = i + 1
        v = values[i % len(values)]
        return ws._plain_scalar(kind, v, kind)

    return scalar


def nan_scalar(kind):
    return "nan" if kind in ("f32", "f64") else zero_scalar(kind)


def build(key, case):
    if case == "empty":
        return Filler(zero_scalar, 0).build(key)
    if case == "typical":
        return typical(key)
    if case == "extreme":
        # 32 elements (3 inside an element of a sequence); a bounded sequence gets exactly its
        # bound.
        if key.startswith("inspire/"):
            return Filler(cycling_extremes(), 1 << 16).build(key)
        if key == "control_msgs/HardwareStatus_":
            # Sequences three levels deep: 32 devices of 3 x 3 elements would be 650 KB.
            return Filler(cycling_extremes(), 4, 3).build(key)
        return Filler(cycling_extremes(), 32, 3).build(key)
    if case == "nan":
        return Filler(nan_scalar, 2).build(key)
    if case == "sdk_default" and key.startswith("inspire/"):
        # What inspire_sdkpy's get_inspire_hand_ctrl/state/touch() build: every sequence at its
        # bound, zeros, mode 0 (restated; that package is not installable here).
        plain = {name: [0] * kind[2] if kind[0] == "bseq" else 0 for name, kind in ws.SCHEMA[key]}
        return ws.from_plain(key, plain)
    if case == "sdk_default":
        from unitree_sdk2py.idl import default

        if key == "unitree_hg/HandCmd_":
            return default.unitree_hg_msg_dds__HandCmd_()
        if key == "unitree_hg/HandState_":
            return default.unitree_hg_msg_dds__HandState_()
    raise KeyError((key, case))


def cases_for(key):
    cases = ["empty", "typical", "extreme", "nan"]
    if key in ("unitree_hg/HandCmd_", "unitree_hg/HandState_") or key.startswith("inspire/"):
        cases.append("sdk_default")
    return cases


# Leaf structs whose SDK default factory must equal our `empty` case (checked below).
SDK_LEAF_DEFAULTS = {
    "unitree_hg/MotorCmd_": "unitree_hg_msg_dds__MotorCmd_",
    "unitree_hg/MotorState_": "unitree_hg_msg_dds__MotorState_",
    "unitree_hg/PressSensorState_": "unitree_hg_msg_dds__PressSensorState_",
    "unitree_hg/IMUState_": "unitree_hg_msg_dds__IMUState_",
    "unitree_go/MotorCmd_": "unitree_go_msg_dds__MotorCmd_",
    "unitree_go/MotorState_": "unitree_go_msg_dds__MotorState_",
}


def same_plain(a, b):
    # NaN is encoded as the string "nan", so plain values compare bit-for-bit at the JSON level.
    return json.dumps(a, sort_keys=False) == json.dumps(b, sort_keys=False)


GEN_SDK = ("tests/python/gen_golden.py with unitree-sdk2 1.0.1 idl classes, "
           "cyclonedds (Python) 0.10.2 IdlStruct.serialize()")
GEN_OWN = ("tests/python/gen_golden.py with handgate's declarations in tests/python/handgate_types.py, "
           "cyclonedds (Python) 0.10.2 IdlStruct.serialize()")
GEN_IDLC = ("tests/python/gen_golden.py with classes generated by idlc -l py (CycloneDDS 0.10.2) from "
            "idl/inspire.idl into tests/python/idl_gen/, cyclonedds (Python) 0.10.2 IdlStruct.serialize()")


def fixture(key, case):
    msg = build(key, case)
    plain = ws.to_plain(key, msg)
    data = msg.serialize()
    if data[:4] != b"\x00\x01\x00\x00":
        raise SystemExit("%s/%s: expected a little-endian CDR header, got %s" % (key, case, data[:4].hex()))
    # The SDK's own decoder must give the same values back.
    back = ws.to_plain(key, ws.CLASSES[key].deserialize(data))
    if not same_plain(back, plain):
        raise SystemExit("%s/%s: SDK round trip changed the value" % (key, case))
    if case == "empty" and key in SDK_LEAF_DEFAULTS:
        from unitree_sdk2py.idl import default

        sdk = getattr(default, SDK_LEAF_DEFAULTS[key])()
        if sdk.serialize() != data:
            raise SystemExit("%s: SDK default factory differs from the zero value" % key)
    module, name = key.split("/")
    return {
        "module": module,
        "type": name,
        "case": case,
        "dds_type_name": ws.dds_type_name(key),
        "python_type_name": ws.python_type_name(key),
        "generator": GEN_SDK if key in ws.SDK_KEYS else GEN_IDLC if key.startswith("inspire/") else GEN_OWN,
        "encoding": "plain CDR (XCDR1), little-endian, 4-byte encapsulation header 00 01 00 00",
        "value": plain,
        "cdr_le_len": len(data),
        "cdr_le_hex": data.hex(),
    }


def main():
    ws.check_schema()
    OUT.mkdir(parents=True, exist_ok=True)
    written = unchanged = 0
    expected_files = set()
    for key in ws.SCHEMA:
        for case in cases_for(key):
            module, name = key.split("/")
            path = OUT / ("%s__%s__%s.json" % (module, name, case))
            expected_files.add(path.name)
            text = json.dumps(fixture(key, case), indent=1, allow_nan=False) + "\n"
            if path.exists() and path.read_text() == text:
                unchanged += 1
                continue
            path.write_text(text)
            written += 1
    stale = sorted(p.name for p in OUT.glob("*.json") if p.name not in expected_files)
    for name in stale:
        (OUT / name).unlink()
    print("gen_golden: %d written, %d unchanged, %d stale removed in %s" % (written, unchanged, len(stale), OUT))


if __name__ == "__main__":
    main()
