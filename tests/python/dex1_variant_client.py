#!/usr/bin/env python3
"""A Dex1-1 client of either per-side wire variant, written only against the official
unitree_sdk2py: `go` (unitree_go MotorCmds_ / MotorStates_, 1 element, as dex1_1_service and
current xr_teleoperate) or `hg` (unitree_hg HandCmd_ / HandState_ with 1 motor, the seed spec)
on rt/dex1/SIDE/{cmd,state}. It waits for state, then commands at 200 Hz with kp 5.0, kd 0.05,
each step clipped to +-0.18 rad of the measured q (as xr_teleoperate does). Run by
tests/tests/dex1_auto.rs against an `auto` Dex1 front.

    .venv/bin/python tests/python/dex1_variant_client.py DOMAIN go|hg SIDE TARGET_RAD [IFACE] [--watch W]

stdout protocol (flushed lines):
    READY             endpoints set up
    DONE <json>       q within 0.05 rad of TARGET: {"q", "samples", "commands", "type"}
                      ("type": the state type received, as the SDK named it)
    SAW <json>        with --watch W: after DONE, it stops commanding and reads state until q
                      is within 0.05 rad of W (another client moved the gripper there):
                      {"q", "samples", "type"}
    FAIL <json>       30 s passed first: {"q": last or null, "samples": n}
"""
import json
import sys
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_go_msg_dds__MotorCmd_, unitree_hg_msg_dds__MotorCmd_
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

TOL = 0.05
STEP = 0.18

argv = sys.argv[1:]
watch = None
if "--watch" in argv:
    i = argv.index("--watch")
    watch = float(argv[i + 1])
    del argv[i : i + 2]
domain, variant, side, target = int(argv[0]), argv[1], argv[2], float(argv[3])
if len(argv) > 4:
    ChannelFactoryInitialize(domain, argv[4])
else:
    ChannelFactoryInitialize(domain)
seen = {"n": 0, "q": None, "type": None}


def on_state(m):
    motors = m.states if variant == "go" else m.motor_state
    if len(motors) == 1:
        seen["q"] = motors[0].q
        seen["type"] = type(m).__name__
        seen["n"] += 1


state_type, cmd_type = (MotorStates_, MotorCmds_) if variant == "go" else (HandState_, HandCmd_)
sub = ChannelSubscriber("rt/dex1/%s/state" % side, state_type)
sub.Init(on_state, 10)
pub = ChannelPublisher("rt/dex1/%s/cmd" % side, cmd_type)
pub.Init()
print("READY", flush=True)
start, commands = time.time(), 0
while time.time() - start < 30:
    q = seen["q"]
    if q is None:
        time.sleep(0.005)
        continue
    if abs(q - target) < TOL:
        print("DONE " + json.dumps({"q": q, "samples": seen["n"], "commands": commands, "type": seen["type"]}), flush=True)
        if watch is None:
            sys.exit(0)
        while time.time() - start < 30:
            if abs(seen["q"] - watch) < TOL:
                print("SAW " + json.dumps({"q": seen["q"], "samples": seen["n"], "type": seen["type"]}), flush=True)
                sys.exit(0)
            time.sleep(0.005)
        break
    step = max(q - STEP, min(q + STEP, target))
    if variant == "go":
        c = unitree_go_msg_dds__MotorCmd_()
        c.mode, c.kp, c.kd, c.q = 0, 5.0, 0.05, step
        pub.Write(MotorCmds_(cmds=[c]))
    else:
        c = unitree_hg_msg_dds__MotorCmd_()
        c.mode, c.kp, c.kd, c.q = 0, 5.0, 0.05, step
        pub.Write(HandCmd_(motor_cmd=[c], reserve=[0, 0, 0, 0]))
    commands += 1
    time.sleep(0.005)
print("FAIL " + json.dumps({"q": seen["q"], "samples": seen["n"]}), flush=True)
sys.exit(1)
