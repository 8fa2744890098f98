#!/usr/bin/env python3
"""Drives every front of a running gateway with the official unitree_sdk2py for a while:
writes each front's command at --hz and counts the states it reads back. Used by
scripts/valgrind.sh (the gateway's DDS paths under memcheck, docs/reliability.md §7).

    .venv/bin/python tests/python/drive_fronts.py --set default --domain 1 --seconds 15
    .venv/bin/python tests/python/drive_fronts.py --set sim-all --domain 1 --seconds 30

Sets (the fronts of the profile of the same name):
    default   Dex3 left/right (unitree_hg HandCmd_ / HandState_, also rt/lf/dex3/*/state) and
              Dex1 left/right (unitree_go MotorCmds_ / MotorStates_)
    sim-all   the above, the actuator pair and Inspire DFX (unitree_go), Inspire FTP per side
              (inspire_hand_ctrl 65 B / inspire_hand_state 98 B / inspire_hand_touch 2.2 KB,
              above the default 1344 B fragment size), BrainCo and Dex5-1 per side, every canonical front
              (handgate HandCmd_ / HandState_), rt/joint_states (ROS 2 JointState) and
              rt/handgate/status (GatewayStatus_)

stdout protocol (flushed lines):
    READY            endpoints set up
    STREAMING        every state topic delivered a sample (or --wait passed); --seconds start
    DONE <json>      {"commands": n, "samples": {topic: n}, "silent": [topics with 0 samples]}

--sweep-hz F moves every hand: the canonical fronts' closure follows 0.5 + 0.4 sin(2 pi F t)
(tests/tests/motion.rs: no motion alarm while the hands move).
"""

import argparse
import json
import math
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import handgate_types as hg  # noqa: E402
import wire_schema as ws  # noqa: E402
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber  # noqa: E402
from unitree_sdk2py.idl.default import unitree_go_msg_dds__MotorCmd_, unitree_hg_msg_dds__HandCmd_  # noqa: E402
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_  # noqa: E402
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_  # noqa: E402

FIXTURES = Path(__file__).resolve().parent.parent / "fixtures" / "golden"
SIDES = ("left", "right")
# Devices of profiles/sim-all.toml, each with a canonical front rt/handgate/<device>/*.
SIM_ALL_DEVICES = [
    "%s_%s" % (kind, side)
    for kind in ("dex3", "dex1", "ezgripper", "inspire_dfx", "inspire_ftp", "brainco", "dex5")
    for side in SIDES
] + ["hand_sdk"]


def dex3_cmd():
    cmd = unitree_hg_msg_dds__HandCmd_()
    for i, m in enumerate(cmd.motor_cmd):
        m.mode, m.q, m.kp, m.kd = 0x10 | i, 0.0, 1.5, 0.1  # RIS byte: motor i, FOC
    return cmd


def dex5_cmd():
    # The Dex5-1 service's 20 entries, enabled (mode 1), xr_teleoperate's gains.
    cmd = HandCmd_(motor_cmd=[unitree_hg_msg_dds__HandCmd_().motor_cmd[0] for _ in range(20)], reserve=[0] * 4)
    for m in cmd.motor_cmd:
        m.mode, m.q, m.kp, m.kd = 1, 0.2, 1.5, 0.1
    return cmd


def go_cmds(n, q):
    cmds = [unitree_go_msg_dds__MotorCmd_() for _ in range(n)]
    for m in cmds:
        m.q, m.kp, m.kd = q, 5.0, 0.05
    return MotorCmds_(cmds=cmds)


def fixture(key, case="typical"):
    name = key.replace("/", "__") + "__" + case + ".json"
    with open(FIXTURES / name) as f:
        return ws.from_plain(key, json.load(f)["value"])


def fronts(which):
    """(commands, states): [(topic, class, message)], [(topic, class)]."""
    cmds, states = [], []
    for side in SIDES:
        cmds.append(("rt/dex3/%s/cmd" % side, HandCmd_, dex3_cmd()))
        states += [("rt/dex3/%s/state" % side, HandState_), ("rt/lf/dex3/%s/state" % side, HandState_)]
        cmds.append(("rt/dex1/%s/cmd" % side, MotorCmds_, go_cmds(1, 1.0)))
        states.append(("rt/dex1/%s/state" % side, MotorStates_))
    if which == "default":
        return cmds, states
    cmds += [
        ("rt/unitree_actuator/cmd", MotorCmds_, go_cmds(2, 1.0)),
        ("rt/inspire/cmd", MotorCmds_, go_cmds(12, 0.5)),
    ]
    states += [("rt/unitree_actuator/state", MotorStates_), ("rt/inspire/state", MotorStates_)]
    ctrl_cls = ws.CLASSES["inspire/inspire_hand_ctrl"]
    for s in ("l", "r"):
        cmds.append(("rt/inspire_hand/ctrl/%s" % s, ctrl_cls, fixture("inspire/inspire_hand_ctrl")))
        states.append(("rt/inspire_hand/state/%s" % s, ws.CLASSES["inspire/inspire_hand_state"]))
        states.append(("rt/inspire_hand/touch/%s" % s, ws.CLASSES["inspire/inspire_hand_touch"]))
    for side in SIDES:
        cmds.append(("rt/brainco/%s/cmd" % side, MotorCmds_, go_cmds(6, 0.5)))
        states.append(("rt/brainco/%s/state" % side, MotorStates_))
        cmds.append(("rt/dex5/%s/cmd" % side, HandCmd_, dex5_cmd()))
        states.append(("rt/dex5/%s/state" % side, HandState_))
    for dev in SIM_ALL_DEVICES:
        msg = hg.HandCmd_(seq=1, mode=1, closure=0.5, stiffness=0.0, joints=[])
        cmds.append(("rt/handgate/%s/cmd" % dev, hg.HandCmd_, msg))
        states.append(("rt/handgate/%s/state" % dev, hg.HandState_))
    states += [
        ("rt/joint_states", hg.RosJointState_),
        ("rt/handgate/status", hg.GatewayStatus_),
    ]
    return cmds, states


class Counter:
    def __init__(self):
        self.lock = threading.Lock()
        self.n = 0

    def __call__(self, _msg):
        with self.lock:
            self.n += 1

    def get(self):
        with self.lock:
            return self.n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", choices=["default", "sim-all"], required=True)
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--hz", type=float, default=50.0)
    ap.add_argument("--wait", type=float, default=300.0, help="at most this long for first states")
    ap.add_argument("--sweep-hz", type=float, default=0.0,
                    help="the canonical fronts' closure follows 0.5 + 0.4 sin(2 pi f t) (0: a constant 0.5)")
    a = ap.parse_args()

    ChannelFactoryInitialize(a.domain, a.interface)
    cmds, states = fronts(a.set)
    pubs = []
    for topic, cls, msg in cmds:
        p = ChannelPublisher(topic, cls)
        p.Init()
        pubs.append((p, msg))
    subs, counters = [], {}
    for topic, cls in states:
        counters[topic] = Counter()
        s = ChannelSubscriber(topic, cls)
        s.Init(counters[topic], 0)
        subs.append(s)
    print("READY", flush=True)

    # Commands go out from the start (a front answers a client it has seen), states are
    # awaited before the measured period starts.
    period = 1.0 / a.hz
    written = 0
    t0 = time.monotonic()
    streaming_since = None
    while True:
        closure = 0.5 + 0.4 * math.sin(2.0 * math.pi * a.sweep_hz * (time.monotonic() - t0))
        for p, msg in pubs:
            if a.sweep_hz > 0 and isinstance(msg, hg.HandCmd_) and msg.mode == 1:
                msg.closure = closure
            p.Write(msg)
            written += 1
        now = time.monotonic()
        if streaming_since is None and (all(c.get() for c in counters.values()) or now - t0 > a.wait):
            streaming_since = now
            print("STREAMING", flush=True)
        if streaming_since is not None and now - streaming_since >= a.seconds:
            break
        time.sleep(period)
    samples = {t: c.get() for t, c in counters.items()}
    silent = [t for t, n in samples.items() if n == 0]
    print("DONE " + json.dumps({"commands": written, "samples": samples, "silent": silent}), flush=True)
    sys.stdout.flush()
    # Leave without tearing CycloneDDS down under live listeners (as interop_sub.py does).
    import os

    os._exit(0)


if __name__ == "__main__":
    main()
