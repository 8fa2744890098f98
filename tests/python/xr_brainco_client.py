#!/usr/bin/env python3
"""A BrainCo Revo2 pair client written as xr_teleoperate's `Brainco_Controller`
(teleop/robot_control/robot_hand_brainco.py; docs/sources.md §7) on the official unitree_sdk2py,
driving handgate's `brainco` fronts. Run by tests/tests/brainco_front.rs.

As that controller does: one unitree_go `MotorCmds_` per hand with 6 entries (0 thumb, 1 thumb
aux, 2 index, 3 middle, 4 ring, 5 pinky) built from the SDK's all-zero default `MotorCmd_`,
with ONLY `q` and `dq` set (`dq = 1.0` once, at construction), published on
rt/brainco/left/cmd and rt/brainco/right/cmd at 100 Hz (its `fps`); each hand's state is
`states[id].q` of rt/brainco/{left,right}/state, read by a thread that takes one sample of
each hand (`ChannelSubscriber.Read`) before the controller starts ("Waiting to subscribe
dds"); its targets start at q = 0 (open), then follow the retargeted URDF radians, normalised
per joint as it does: q = 1 - clip((max - rad) / (max - min), 0, 1) over thumb [0, 1.52],
thumb aux [0, 1.05], fingers [0, 1.47] (1 = closed).

    .venv/bin/python tests/python/xr_brainco_client.py DOMAIN LEFT_RAD RIGHT_RAD [IFACE]

LEFT_RAD / RIGHT_RAD: six comma-separated URDF radians per hand (thumb, thumb aux, index,
middle, ring, pinky). The client first streams q = 0 until every entry reads open (q < 0.05),
then streams the targets until every entry reads its own normalised target.

stdout protocol (flushed lines):
    READY            endpoints set up
    DONE <json>      all 12 entries within TOL of their targets: {"left_q": [6 state q],
                     "right_q": [6], "left_target_q": [6], "right_target_q": [6],
                     "open_q": [12 state q when open, left then right], "waited_s": s,
                     "commands": n, "samples": n}
    FAIL <json>      30 s passed first: {"phase": .., "left_q": .. or null, "right_q": ..,
                     "left_target_q": [6], "right_target_q": [6], "samples": n}
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
HAND_IDS = list(range(NUM_MOTORS))  # Brainco_{Left,Right}_Hand_JointIndex
# The controller's normalisation ranges (rad), per entry.
MAX_RAD = [1.52, 1.05, 1.47, 1.47, 1.47, 1.47]


def normalize(val, lo, hi):
    return 1.0 - min(1.0, max(0.0, (hi - val) / (hi - lo)))


domain = int(sys.argv[1])
left_rad = [float(x) for x in sys.argv[2].split(",")]
right_rad = [float(x) for x in sys.argv[3].split(",")]
assert len(left_rad) == NUM_MOTORS and len(right_rad) == NUM_MOTORS
if len(sys.argv) > 4:
    ChannelFactoryInitialize(domain, sys.argv[4])
else:
    ChannelFactoryInitialize(domain)

left_pub = ChannelPublisher("rt/brainco/left/cmd", MotorCmds_)
left_pub.Init()
right_pub = ChannelPublisher("rt/brainco/right/cmd", MotorCmds_)
right_pub.Init()
left_sub = ChannelSubscriber("rt/brainco/left/state", MotorStates_)
left_sub.Init()
right_sub = ChannelSubscriber("rt/brainco/right/state", MotorStates_)
right_sub.Init()
print("READY", flush=True)

lock = threading.Lock()
left_state = [0.0] * NUM_MOTORS
right_state = [0.0] * NUM_MOTORS
seen = {"n": 0, "ready": False}


def subscribe_hand_state():
    # The controller's `_subscribe_hand_state`: one Read per hand, then both arrays updated.
    # (It reads without a timeout; 1 s here so a silent front ends in FAIL, not a hang.)
    while True:
        left_msg = left_sub.Read(1.0)
        right_msg = right_sub.Read(1.0)
        if left_msg is not None and right_msg is not None:
            with lock:
                for idx, i in enumerate(HAND_IDS):
                    left_state[idx] = left_msg.states[i].q
                for idx, i in enumerate(HAND_IDS):
                    right_state[idx] = right_msg.states[i].q
                seen["n"] += 1
                seen["ready"] = True
        time.sleep(0.002)


threading.Thread(target=subscribe_hand_state, daemon=True).start()


def states():
    with lock:
        return (left_state[:], right_state[:]) if seen["n"] else (None, None)


start = time.time()
while True:
    with lock:
        if seen["ready"]:
            break
    if time.time() - start > 30:
        print("FAIL " + json.dumps({"phase": "wait", "left_q": None, "right_q": None, "samples": 0}), flush=True)
        sys.exit(1)
    time.sleep(0.1)
waited = time.time() - start

# The controller's messages: default entries, q = 0 (open) and dq = 1.0 set once.
left_msg = MotorCmds_(cmds=[unitree_go_msg_dds__MotorCmd_() for _ in HAND_IDS])
right_msg = MotorCmds_(cmds=[unitree_go_msg_dds__MotorCmd_() for _ in HAND_IDS])
for m in (left_msg, right_msg):
    for i in HAND_IDS:
        m.cmds[i].q = 0.0
        m.cmds[i].dq = 1.0


def ctrl_dual_hand(left_q, right_q):
    for idx, i in enumerate(HAND_IDS):
        left_msg.cmds[i].q = left_q[idx]
    for idx, i in enumerate(HAND_IDS):
        right_msg.cmds[i].q = right_q[idx]
    left_pub.Write(left_msg)
    right_pub.Write(right_msg)


open_q = [0.0] * NUM_MOTORS
left_target = [normalize(r, 0.0, MAX_RAD[i]) for i, r in enumerate(left_rad)]
right_target = [normalize(r, 0.0, MAX_RAD[i]) for i, r in enumerate(right_rad)]
commands = 0
opened = None
phase = "open"
while time.time() - start < 30:
    t0 = time.time()
    lq, rq = states()
    if phase == "open":
        if lq is not None and all(v < 0.05 for v in lq + rq):
            opened, phase = lq + rq, "target"
        else:
            ctrl_dual_hand(open_q, open_q)
            commands += 1
    if phase == "target":
        if lq is not None and all(abs(a - t) < TOL for a, t in zip(lq + rq, left_target + right_target)):
            print(
                "DONE "
                + json.dumps(
                    {
                        "left_q": lq,
                        "right_q": rq,
                        "left_target_q": left_target,
                        "right_target_q": right_target,
                        "open_q": opened,
                        "waited_s": waited,
                        "commands": commands,
                        "samples": seen["n"],
                    }
                ),
                flush=True,
            )
            sys.exit(0)
        ctrl_dual_hand(left_target, right_target)
        commands += 1
    time.sleep(max(0.0, 1.0 / FPS - (time.time() - t0)))
lq, rq = states()
print(
    "FAIL "
    + json.dumps(
        {
            "phase": phase,
            "left_q": lq,
            "right_q": rq,
            "left_target_q": left_target,
            "right_target_q": right_target,
            "samples": seen["n"],
        }
    ),
    flush=True,
)
sys.exit(1)
