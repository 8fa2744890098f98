#!/usr/bin/env python3
"""Writes the golden CDR fixtures in tests/fixtures/golden/ with the OFFICIAL Python SDK.

How to run (from the repository root):
    make fixtures                         # runs scripts/setup.sh first, then this script
    .venv/bin/python tests/python/gen_golden.py   # if .venv already exists

What it does: for each of the ten Unitree wire types handgate speaks (unitree_hg MotorCmd_,
MotorState_, PressSensorState_, IMUState_, HandCmd_, HandState_; unitree_go MotorCmd_,
MotorCmds_, MotorState_, MotorStates_) and each case (empty, typical, extreme, nan, plus
sdk_default for HandCmd_/HandState_) it builds the message with unitree_sdk2py's idl classes
(unitree-sdk2 1.0.1) and serialises it with CycloneDDS Python 0.10.2 (`msg.serialize()`, plain
CDR / XCDR1, little-endian, with the 4-byte encapsulation header 00 01 00 00). It writes
`<module>__<Type>__<case>.json` holding the values and the hex of those bytes. The Rust test
tests/tests/golden_bytes.rs rebuilds each value in Rust and requires byte equality.

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
              sequences of 32 elements.
  nan         every f32 field NaN (CPython writes the quiet NaN 0x7fc00000); 2-element
              sequences. Compared bit-for-bit on the Rust side (NaN != NaN as a value).
"""

import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
from wire_schema import f32, f32_from_bits  # noqa: E402

REPO = Path(__file__).resolve().parent.parent.parent
OUT = REPO / "tests" / "fixtures" / "golden"

# --- typical values ---------------------------------------------------------------------------

# Left Dex3-1 joint targets (rad) inside the URDF limits of FACTS §2, message order
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
    # Raw readings: >= 100000 is a valid contact reading, 30000 means "no reading" (FACTS §2).
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


def typical(key):
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
INT_EXTREMES = {
    "u8": [255, 0, 0x80],
    "i16": [-32768, 32767, -1],
    "u32": [0xFFFF_FFFF, 0, 0x8000_0000],
}


class Filler:
    """Builds a message by walking the schema; scalars come from per-kind generators."""

    def __init__(self, scalar, seq_len):
        self.scalar = scalar
        self.seq_len = seq_len

    def build(self, key):
        plain = self.plain(key)
        return ws.from_plain(key, plain)

    def plain(self, key):
        out = {}
        for name, kind in ws.SCHEMA[key]:
            if isinstance(kind, str):
                out[name] = self.scalar(kind)
            elif kind[0] == "array":
                out[name] = [self.scalar(kind[1]) for _ in range(kind[2])]
            elif kind[0] == "seq":
                out[name] = [self.plain(kind[1]) for _ in range(self.seq_len)]
            else:
                out[name] = self.plain(kind[1])
        return out


def zero_scalar(kind):
    return 0.0 if kind == "f32" else 0


def cycling_extremes():
    counters = {}

    def scalar(kind):
        values = F32_EXTREMES if kind == "f32" else INT_EXTREMES[kind]
        i = counters.get(kind, 0)
        counters[kind] = i + 1
        v = values[i % len(values)]
        return ws._plain_scalar(kind, v, kind)

    return scalar


def nan_scalar(kind):
    return "nan" if kind == "f32" else 0


def build(key, case):
    if case == "empty":
        return Filler(zero_scalar, 0).build(key)
    if case == "typical":
        return typical(key)
    if case == "extreme":
        return Filler(cycling_extremes(), 32).build(key)
    if case == "nan":
        return Filler(nan_scalar, 2).build(key)
    if case == "sdk_default":
        from unitree_sdk2py.idl import default

        if key == "unitree_hg/HandCmd_":
            return default.unitree_hg_msg_dds__HandCmd_()
        if key == "unitree_hg/HandState_":
            return default.unitree_hg_msg_dds__HandState_()
    raise KeyError((key, case))


def cases_for(key):
    cases = ["empty", "typical", "extreme", "nan"]
    if key in ("unitree_hg/HandCmd_", "unitree_hg/HandState_"):
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
        "generator": "tests/python/gen_golden.py with unitree-sdk2 1.0.1 idl classes, "
        "cyclonedds (Python) 0.10.2 IdlStruct.serialize()",
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
