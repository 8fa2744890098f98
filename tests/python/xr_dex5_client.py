#!/usr/bin/env python3
"""A Dex5-1 pair client written as xr_teleoperate's `Dex5_1_Controller`
(teleop/robot_control/robot_hand_unitree.py in the version with Dex5 support; docs/sources.md
§7 "Dex5-1") on the official unitree_sdk2py, driving handgate's `dex5` fronts. Run by
tests/tests/dex5_front.rs.

As that controller does: one unitree_hg `HandCmd_` per hand with 20 entries in the service's
order (index, middle, ring, pinky: spread then the three flex joints each; then the thumb's
four), built from the SDK's default `MotorCmd_`, every entry mode 0x01, q in URDF radians,
kp / kd 0.10 / 0.001 on the fingers' entries and 1.0 / 0.02 on the thumb's, published on
rt/dex5/left/cmd and rt/dex5/right/cmd at 100 Hz; each hand's state is `motor_state[i].q` of
rt/dex5/{left,right}/state, and the controller starts commanding only once both hands report
a state that is not all zero.

    .venv/bin/python tests/python/xr_dex5_client.py DOMAIN LEFT_RAD RIGHT_RAD [IFACE]

LEFT_RAD / RIGHT_RAD: 20 comma-separated URDF radians per hand, in the service's order. The
client streams them until every entry of both hands reads its own target within TOL.

stdout protocol (flushed lines):
    READY            endpoints set up
    DONE <json>      {"left_q": [20], "right_q": [20], "waited_s": s, "commands": n}
    FAIL <json>      30 s passed first: {"phase": .., "left_q": .. or null, "right_q": ..}
"""
import json
import sys
import threading
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_, unitree_hg_msg_dds__MotorCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

FPS = 100.0
TOL = 0.03
ENTRIES = 20
THUMB_FIRST = 16
# The controller's gains ("from the Dex5-1 DDS doc", docs/sources.md §7).
FINGER_KP, FINGER_KD = 0.10, 0.001
THUMB_KP, THUMB_KD = 1.0, 0.02

domain = int(sys.argv[1])
left_rad = [float(x) for x in sys.argv[2].split(",")]
right_rad = [float(x) for x in sys.argv[3].split(",")]
assert len(left_rad) == ENTRIES and len(right_rad) == ENTRIES
if len(sys.argv) > 4:
    ChannelFactoryInitialize(domain, sys.argv[4])
else:
    ChannelFactoryInitialize(domain)

pubs = {}
subs = {}
for side in ("left", "right"):
    pubs[side] = ChannelPublisher(f"rt/dex5/{side}/cmd", HandCmd_)
    pubs[side].Init()
    subs[side] = ChannelSubscriber(f"rt/dex5/{side}/state", HandState_)
    subs[side].Init()
print("READY", flush=True)

lock = threading.Lock()
state = {"left": None, "right": None}


def subscribe(side):
    while True:
        msg = subs[side].Read(1.0)
        if msg is not None and len(msg.motor_state) == ENTRIES:
            with lock:
                state[side] = [m.q for m in msg.motor_state]
        time.sleep(0.002)


for side in ("left", "right"):
    threading.Thread(target=subscribe, args=(side,), daemon=True).start()


def snapshot():
    with lock:
        return state["left"], state["right"]


start = time.time()
while True:
    left, right = snapshot()
    # The controller waits until both hands report a state that is not all zero.
    if left is not None and right is not None and any(left) and any(right):
        break
    if time.time() - start > 30:
        print("FAIL " + json.dumps({"phase": "wait", "left_q": left, "right_q": right}), flush=True)
        sys.exit(1)
    time.sleep(0.1)
waited = time.time() - start


def message(targets):
    msg = unitree_hg_msg_dds__HandCmd_()
    msg.motor_cmd = [unitree_hg_msg_dds__MotorCmd_() for _ in range(ENTRIES)]
    for i, q in enumerate(targets):
        m = msg.motor_cmd[i]
        m.mode = 0x01
        m.q = q
        m.dq = 0.0
        m.tau = 0.0
        m.kp, m.kd = (THUMB_KP, THUMB_KD) if i >= THUMB_FIRST else (FINGER_KP, FINGER_KD)
    return msg


msgs = {"left": message(left_rad), "right": message(right_rad)}
commands = 0
deadline = time.time() + 30
while True:
    for side in ("left", "right"):
        pubs[side].Write(msgs[side])
    commands += 1
    left, right = snapshot()
    ok = all(abs(a - b) < TOL for a, b in zip(left, left_rad)) and all(
        abs(a - b) < TOL for a, b in zip(right, right_rad)
    )
    if ok:
        print("DONE " + json.dumps({"left_q": left, "right_q": right, "waited_s": waited, "commands": commands}), flush=True)
        sys.exit(0)
    if time.time() > deadline:
        print("FAIL " + json.dumps({"phase": "track", "left_q": left, "right_q": right}), flush=True)
        sys.exit(1)
    time.sleep(1.0 / FPS)
