"""An xr_teleoperate-style Dex1-1 client, written only against the official unitree_sdk2py:
unitree_go MotorCmds_ with one element on rt/dex1/left/cmd at 200 Hz, kp 5.0, kd 0.05, each
step clipped to +-0.18 rad of the measured position (as xr_teleoperate does), reading
MotorStates_ on rt/dex1/left/state. Usage: e2e_xr_dex1.py DOMAIN TARGET_RAD [IFACE].
Prints READY, then PROGRESS lines, then DONE <json> when |q - target| < 0.05 (or FAIL)."""
import json
import sys
import time

import unitree_sdk2py  # noqa: F401
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_go_msg_dds__MotorCmd_
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_

domain, target = int(sys.argv[1]), float(sys.argv[2])
if len(sys.argv) > 3:
    ChannelFactoryInitialize(domain, sys.argv[3])
else:
    ChannelFactoryInitialize(domain)
seen = {"n": 0}


def on_state(m):
    seen["q"], seen["mode"], seen["lost"] = m.states[0].q, m.states[0].mode, m.states[0].lost
    seen["n"] += 1


sub = ChannelSubscriber("rt/dex1/left/state", MotorStates_)
sub.Init(on_state, 10)
pub = ChannelPublisher("rt/dex1/left/cmd", MotorCmds_)
pub.Init()
print("READY", flush=True)
start = time.time()
max_q = 0.0
while time.time() - start < 30:
    q = seen.get("q")
    if q is None:
        time.sleep(0.005)
        continue
    max_q = max(max_q, q)
    if abs(q - target) < 0.05:
        print("DONE " + json.dumps({"q": q, "mode": seen["mode"], "lost": seen["lost"], "samples": seen["n"], "max_q": max_q}), flush=True)
        sys.exit(0)
    c = unitree_go_msg_dds__MotorCmd_()
    c.mode, c.kp, c.kd = 0, 5.0, 0.05
    c.q = max(q - 0.18, min(q + 0.18, target))
    pub.Write(MotorCmds_(cmds=[c]))
    time.sleep(0.005)
print("FAIL " + json.dumps({"q": seen.get("q"), "samples": seen["n"]}), flush=True)
sys.exit(1)
