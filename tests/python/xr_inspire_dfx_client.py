#!/usr/bin/env python3
"""An Inspire DFX pair client written as xr_teleoperate's `Inspire_Controller_DFX`
(teleop/robot_control/robot_hand_inspire.py; docs/sources.md §7) on the official unitree_sdk2py,
driving handgate's `inspire_dfx` front. Run by tests/tests/inspire_dfx_front.rs.

As that controller does: ONE unitree_go `MotorCmds_` with 12 entries on rt/inspire/cmd (0-5
right hand, 6-11 left; within a hand 0 pinky, 1 ring, 2 middle, 3 index, 4 thumb bend, 5 thumb
rotation) built from the SDK's all-zero default `MotorCmd_` with ONLY `q` set, at 100 Hz
(its `fps`); each hand's state is `states[id].q` of rt/inspire/state for the same ids, kept in
an array by a subscriber thread; it waits until the right hand's array is not all zero
(`any(right_hand_state_array)`) before commanding; its targets start all open (q = 1.0), then
follow the retargeted URDF radians, normalised per joint as it does:
q = clip((max - rad) / (max - min), 0, 1), fingers [0, 1.7], thumb bend [0, 0.5], thumb
rotation [-0.1, 1.3] (1 = open).

    .venv/bin/python tests/python/xr_inspire_dfx_client.py DOMAIN RIGHT_RAD LEFT_RAD [IFACE]

RIGHT_RAD / LEFT_RAD: six comma-separated URDF radians per hand (pinky, ring, middle, index,
thumb bend, thumb rotation). The client first streams all-open until every entry reads open
(q > 0.95), then streams the targets until every entry reads its own normalised target.

stdout protocol (flushed lines):
    READY            endpoints set up
    DONE <json>      all 12 entries within TOL of their targets: {"q": [12 state q],
                     "target_q": [12], "open_q": [12 state q when open], "waited_s": s,
                     "commands": n, "samples": n}
    FAIL <json>      30 s passed first: {"phase": .., "q": last [12] or null, "target_q": [12],
                     "samples": n}
"""
import json
import sys
import threading
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_go_msg_dds__MotorCmd_
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_

FPS = 100.0
TOL = 0.02
NUM_MOTORS = 6
RIGHT_IDS = list(range(0, 6))  # Inspire_Right_Hand_JointIndex
LEFT_IDS = list(range(6, 12))  # Inspire_Left_Hand_JointIndex
# (min, max) radians per joint index, as the controller normalises.
RANGES = [(0.0, 1.7)] * 4 + [(0.0, 0.5), (-0.1, 1.3)]


def normalize(val, lo, hi):
    return min(1.0, max(0.0, (hi - val) / (hi - lo)))


domain = int(sys.argv[1])
right_rad = [float(x) for x in sys.argv[2].split(",")]
left_rad = [float(x) for x in sys.argv[3].split(",")]
assert len(right_rad) == NUM_MOTORS and len(left_rad) == NUM_MOTORS
if len(sys.argv) > 4:
    ChannelFactoryInitialize(domain, sys.argv[4])
else:
    ChannelFactoryInitialize(domain)

lock = threading.Lock()
left_state = [0.0] * NUM_MOTORS
right_state = [0.0] * NUM_MOTORS
seen = {"n": 0}


def on_state(msg):
    # The controller reads states[id].q for each hand's ids.
    if len(msg.states) < 12:
        return
    with lock:
        for idx, i in enumerate(LEFT_IDS):
            left_state[idx] = msg.states[i].q
        for idx, i in enumerate(RIGHT_IDS):
            right_state[idx] = msg.states[i].q
        seen["n"] += 1


def state12():
    with lock:
        return right_state[:] + left_state[:] if seen["n"] else None


sub = ChannelSubscriber("rt/inspire/state", MotorStates_)
sub.Init(on_state, 10)
pub = ChannelPublisher("rt/inspire/cmd", MotorCmds_)
pub.Init()
print("READY", flush=True)

start = time.time()
# Wait for the right hand's state, as the controller's constructor does.
while True:
    with lock:
        ready = any(right_state)
    if ready:
        break
    if time.time() - start > 30:
        print("FAIL " + json.dumps({"phase": "wait", "q": state12(), "samples": seen["n"]}), flush=True)
        sys.exit(1)
    time.sleep(0.01)
waited = time.time() - start

hand_msg = MotorCmds_(cmds=[unitree_go_msg_dds__MotorCmd_() for _ in range(len(RIGHT_IDS) + len(LEFT_IDS))])


def ctrl_dual_hand(left_q, right_q):
    for idx, i in enumerate(LEFT_IDS):
        hand_msg.cmds[i].q = left_q[idx]
    for idx, i in enumerate(RIGHT_IDS):
        hand_msg.cmds[i].q = right_q[idx]
    pub.Write(hand_msg)


open_q = [1.0] * NUM_MOTORS
right_q = [normalize(r, *RANGES[i]) for i, r in enumerate(right_rad)]
left_q = [normalize(r, *RANGES[i]) for i, r in enumerate(left_rad)]
target12 = right_q + left_q
commands = 0
opened = None
phase = "open"
while time.time() - start < 30:
    t0 = time.time()
    q = state12()
    if phase == "open":
        if q is not None and all(v > 0.95 for v in q):
            opened, phase = q, "target"
        else:
            ctrl_dual_hand(open_q, open_q)
            commands += 1
    if phase == "target":
        if q is not None and all(abs(a - t) < TOL for a, t in zip(q, target12)):
            print(
                "DONE "
                + json.dumps(
                    {
                        "q": q,
                        "target_q": target12,
                        "open_q": opened,
                        "waited_s": waited,
                        "commands": commands,
                        "samples": seen["n"],
                    }
                ),
                flush=True,
            )
            sys.exit(0)
        ctrl_dual_hand(left_q, right_q)
        commands += 1
    time.sleep(max(0.0, 1.0 / FPS - (time.time() - t0)))
print("FAIL " + json.dumps({"phase": phase, "q": state12(), "target_q": target12, "samples": seen["n"]}), flush=True)
sys.exit(1)
