#!/usr/bin/env python3
"""A legacy (xr_teleoperate v1.1-style) Dex1-1 pair client through the official unitree_sdk2py:
one topic pair carries both grippers, unitree_go MotorCmds_ with 2 elements on
rt/unitree_actuator/cmd (element 0 right, element 1 left; docs/sources.md §4) and MotorStates_
with 2 elements on rt/unitree_actuator/state. As that controller does, it waits until state has
arrived, then commands at 200 Hz with kp 5.0, kd 0.05, each element's q clipped to +-0.18 rad
of that element's measured position. Run by tests/tests/fronts_service.rs.

    .venv/bin/python tests/python/xr_actuator_client.py DOMAIN RIGHT_TARGET LEFT_TARGET [IFACE]

stdout protocol (flushed lines):
    READY                 endpoints set up
    DONE <json>           both elements within 0.05 rad of their targets:
                          {"q": [right, left], "min_q_seen": [..], "samples": n, "commands": n}
    FAIL <json>           30 s passed first: {"q": last [right, left] or null, "samples": n}
"""
import json
import sys
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_go_msg_dds__MotorCmd_
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_

TOL = 0.05
STEP = 0.18

domain, targets = int(sys.argv[1]), [float(sys.argv[2]), float(sys.argv[3])]
if len(sys.argv) > 4:
    ChannelFactoryInitialize(domain, sys.argv[4])
else:
    ChannelFactoryInitialize(domain)
seen = {"n": 0, "q": None}


def on_state(m):
    if len(m.states) == 2:
        seen["q"] = [m.states[0].q, m.states[1].q]
        seen["n"] += 1


sub = ChannelSubscriber("rt/unitree_actuator/state", MotorStates_)
sub.Init(on_state, 10)
pub = ChannelPublisher("rt/unitree_actuator/cmd", MotorCmds_)
pub.Init()
print("READY", flush=True)
start, commands = time.time(), 0
min_seen = [float("inf"), float("inf")]
while time.time() - start < 30:
    q = seen["q"]
    if q is None:
        time.sleep(0.005)
        continue
    min_seen = [min(a, b) for a, b in zip(min_seen, q)]
    if all(abs(a - t) < TOL for a, t in zip(q, targets)):
        print("DONE " + json.dumps({"q": q, "min_q_seen": min_seen, "samples": seen["n"], "commands": commands}), flush=True)
        sys.exit(0)
    cmds = []
    for a, t in zip(q, targets):
        c = unitree_go_msg_dds__MotorCmd_()
        c.mode, c.kp, c.kd = 0, 5.0, 0.05
        c.q = max(a - STEP, min(a + STEP, t))
        cmds.append(c)
    pub.Write(MotorCmds_(cmds=cmds))
    commands += 1
    time.sleep(0.005)
print("FAIL " + json.dumps({"q": seen["q"], "samples": seen["n"]}), flush=True)
sys.exit(1)
