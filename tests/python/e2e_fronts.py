#!/usr/bin/env python3
"""End-to-end client: drives every front of the default profile through the official
unitree_sdk2py (ChannelPublisher / ChannelSubscriber) against a running `handgate run`, and
reports what it read back.

Run by tests/tests/e2e_gateway.rs. By hand, with `make run` (domain 1) in another terminal:
    .venv/bin/python tests/python/e2e_fronts.py --domain 1 [--interface lo] [--timeout 20]

Parts, in order (each streams its command every --period seconds, well inside the gateway's
200 ms watchdog, until the state it reads back meets the condition or --timeout passes):
    dex3       HandCmd_ on rt/dex3/{left,right}/cmd, RIS mode 0x10|i, kp 1.5, kd 0.1, all q 0
               except index_0 (IDL 5): -1.0 left, +1.0 right (closing). Condition: HandState_
               on rt/dex3/{side}/state has motor 5 within 0.05 rad of it, and
               rt/lf/dex3/{side}/state has delivered at least one sample.
    dex1       unitree_go MotorCmds_ (1 element) q 1.0 rad (0 closed, 5.4 open), kp 5, kd 0.05
               on rt/dex1/{left,right}/cmd; condition: MotorStates_ q within 0.05 of 1.0.
    canonical  handgate HandCmd_ closure 1.0 on rt/handgate/dex1_right/cmd; condition:
               rt/handgate/dex1_right/state closure >= 0.95.
    joint_state  sensor_msgs JointState_ on rt/joint_states while dex3 left is commanded as
               above; condition: left_hand_three_joint within 0.05 of -1.0.

stdout protocol (flushed lines):
    READY                   ChannelFactoryInitialize and every endpoint are set up
    RESULT <part> <json>    what was observed (also when the condition was not met:
                            "converged": false), one line per part and side
    DONE                    all parts ran; exit 0 (the Rust test judges the results)
"""

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import handgate_types as hg  # noqa: E402
from unitree_sdk2py.core.channel import (  # noqa: E402
    ChannelFactoryInitialize,
    ChannelPublisher,
    ChannelSubscriber,
)
from unitree_sdk2py.idl.default import (  # noqa: E402
    unitree_go_msg_dds__MotorCmd_,
    unitree_hg_msg_dds__HandCmd_,
)
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_  # noqa: E402
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_  # noqa: E402

TOL = 0.05
INDEX_0 = 5  # IDL index of index_0 (Dex3-1 manual; docs/model.md)


class Latest:
    """Subscriber callback keeping the newest sample and how many arrived."""

    def __init__(self):
        self.lock = threading.Lock()
        self.msg = None
        self.count = 0

    def __call__(self, msg):
        with self.lock:
            self.msg = msg
            self.count += 1

    def get(self):
        with self.lock:
            return self.msg, self.count


def subscribe(topic, cls):
    latest = Latest()
    sub = ChannelSubscriber(topic, cls)
    sub.Init(latest, 0)
    return sub, latest


def publisher(topic, cls):
    pub = ChannelPublisher(topic, cls)
    pub.Init()
    return pub


def stream_until(writes, cond, timeout, period):
    """Writes every (publisher, message) pair each period until cond() or the deadline.
    Returns (met, seconds)."""
    t0 = time.monotonic()
    while True:
        for pub, msg in writes:
            pub.Write(msg)
        if cond():
            return True, time.monotonic() - t0
        if time.monotonic() - t0 > timeout:
            return False, time.monotonic() - t0
        time.sleep(period)


def dex3_cmd(target):
    cmd = unitree_hg_msg_dds__HandCmd_()
    for i, m in enumerate(cmd.motor_cmd):
        m.mode = 0x10 | i  # RIS byte: motor id i, status 1 (FOC), no timeout bit
        m.q = 0.0
        m.kp = 1.5
        m.kd = 0.1
    cmd.motor_cmd[INDEX_0].q = target
    return cmd


def report(part, value):
    print("RESULT %s %s" % (part, json.dumps(value, allow_nan=True)), flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--period", type=float, default=0.01)
    args = ap.parse_args()

    ChannelFactoryInitialize(args.domain, args.interface)
    keep = []  # subscribers must outlive the parts
    sides = {"left": -1.0, "right": 1.0}
    dex3 = {}
    for side, target in sides.items():
        s, state = subscribe("rt/dex3/%s/state" % side, HandState_)
        l, lf = subscribe("rt/lf/dex3/%s/state" % side, HandState_)
        keep += [s, l]
        dex3[side] = (publisher("rt/dex3/%s/cmd" % side, HandCmd_), dex3_cmd(target), state, lf)
    dex1 = {}
    for side in sides:
        s, state = subscribe("rt/dex1/%s/state" % side, MotorStates_)
        keep.append(s)
        cmd = MotorCmds_([unitree_go_msg_dds__MotorCmd_()])
        m = cmd.cmds[0]
        m.q, m.dq, m.tau, m.kp, m.kd = 1.0, 0.0, 0.0, 5.0, 0.05
        dex1[side] = (publisher("rt/dex1/%s/cmd" % side, MotorCmds_), cmd, state)
    s, canon_state = subscribe("rt/handgate/dex1_right/state", hg.HandState_)
    keep.append(s)
    canon_pub = publisher("rt/handgate/dex1_right/cmd", hg.HandCmd_)
    canon_cmd = hg.HandCmd_(seq=1, mode=1, closure=1.0, stiffness=0.0, joints=[])
    s, joints = subscribe("rt/joint_states", hg.RosJointState_)
    keep.append(s)
    print("READY", flush=True)

    # (a) dex3, both hands at once. Each side's report is the sample that met the condition
    # (or the newest one at the deadline): the joint may still ring a little afterwards.
    seen3 = {}

    def dex3_met(side):
        msg, count = dex3[side][2].get()
        _, lf_count = dex3[side][3].get()
        if msg is None:
            return False
        ok = lf_count > 0 and abs(msg.motor_state[INDEX_0].q - sides[side]) < TOL
        if side not in seen3 or not seen3[side][0]:
            seen3[side] = (ok, msg, count, lf_count)
        return ok

    met, secs = stream_until(
        [(p, c) for p, c, _, _ in dex3.values()],
        lambda: all([dex3_met(s) for s in sides]),
        args.timeout,
        args.period,
    )
    for side in sides:
        ok, msg, count, lf_count = seen3.get(side, (False, None, 0, 0))
        report(
            "dex3",
            {
                "side": side,
                "target": sides[side],
                "converged": ok,
                "seconds": secs,
                "state_samples": count,
                "lf_samples": lf_count,
                "q": [m.q for m in msg.motor_state] if msg else None,
                "motors": len(msg.motor_state) if msg else 0,
                "pads": len(msg.press_sensor_state) if msg else 0,
            },
        )

    # (b) dex1, both grippers at once (reports as for dex3).
    seen1 = {}

    def dex1_met(side):
        msg, count = dex1[side][2].get()
        if msg is None:
            return False
        q = msg.states[0].q if len(msg.states) == 1 else None
        ok = q is not None and abs(q - 1.0) < TOL
        if side not in seen1 or not seen1[side][0]:
            seen1[side] = (ok, q, len(msg.states), count)
        return ok

    met, secs = stream_until(
        [(p, c) for p, c, _ in dex1.values()],
        lambda: all([dex1_met(s) for s in sides]),
        args.timeout,
        args.period,
    )
    for side in sides:
        ok, q, elements, count = seen1.get(side, (False, None, 0, 0))
        report(
            "dex1",
            {
                "side": side,
                "converged": ok,
                "seconds": secs,
                "state_samples": count,
                "elements": elements,
                "q": q,
            },
        )

    # (c) canonical front: closure on dex1_right.
    snap = {}

    def canon_met():
        msg, count = canon_state.get()
        snap["canonical"] = (msg, count)
        return msg is not None and msg.closure >= 0.95

    met, secs = stream_until([(canon_pub, canon_cmd)], canon_met, args.timeout, args.period)
    msg, count = snap["canonical"]
    report(
        "canonical",
        {
            "converged": met,
            "seconds": secs,
            "state_samples": count,
            "device": msg.device if msg else None,
            "kind": msg.kind if msg else None,
            "closure": msg.closure if msg else None,
            "joints": {j.name: j.q for j in msg.joints} if msg else None,
        },
    )

    # (d) JointState, while the left hand is commanded closed again.
    def js_met():
        msg, count = joints.get()
        snap["joint_state"] = (msg, count)
        q = dict(zip(msg.name, msg.position)).get("left_hand_three_joint") if msg else None
        return q is not None and abs(q + 1.0) < TOL

    p, c, _, _ = dex3["left"]
    met, secs = stream_until([(p, c)], js_met, args.timeout, args.period)
    msg, count = snap["joint_state"]
    report(
        "joint_state",
        {
            "converged": met,
            "seconds": secs,
            "samples": count,
            "names": list(msg.name) if msg else [],
            "positions": list(msg.position) if msg else [],
        },
    )
    print("DONE", flush=True)
    # Leave without tearing CycloneDDS down from under the listener threads.
    os._exit(0)


if __name__ == "__main__":
    main()
