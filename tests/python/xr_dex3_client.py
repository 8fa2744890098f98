#!/usr/bin/env python3
"""An xr_teleoperate-style Dex3-1 client on the official unitree_sdk2py, for the end-to-end
tests (tests/tests/e2e_realism.rs).

It behaves as xr_teleoperate's Dex3_1_Controller does at start-up: subscribe
rt/dex3/{left,right}/state, keep the 7 joint positions of each hand in an array, and wait
until BOTH arrays are not all zero (`any(state_array)`) before commanding anything. Against an
emulator that starts at exactly 0.0 everywhere that wait never ends; here it has a deadline
and reports how it ended. Then it streams HandCmd_ on rt/dex3/{left,right}/cmd (RIS mode
0x10|i, kp 1.5, kd 0.2: xr_teleoperate's gains), every joint held where it was first read
except index_0 (IDL 5) closing to -0.8 (left) / +0.8 (right), until the state reads it back.

stdout (flushed lines):
    READY                     subscribers and publishers set up
    WAITED <json>             {"nonzero": bool, "seconds": s, "left": [7 q], "right": [7 q]}
    RESULT <json>             {"converged": bool, "seconds": s, "left": [7 q], "right": [7 q]}
    DONE
"""

import argparse
import json
import sys
import threading
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

INDEX_0 = 5
TARGET = {"left": -0.8, "right": 0.8}
TOL = 0.05


class HandState:
    def __init__(self):
        self.lock = threading.Lock()
        self.q = [0.0] * 7

    def __call__(self, msg):
        with self.lock:
            for i in range(7):
                self.q[i] = float(msg.motor_state[i].q)

    def get(self):
        with self.lock:
            return list(self.q)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--period", type=float, default=0.01)
    args = ap.parse_args()
    ChannelFactoryInitialize(args.domain, args.interface)
    states, subs, pubs = {}, [], {}
    for side in ("left", "right"):
        states[side] = HandState()
        s = ChannelSubscriber(f"rt/dex3/{side}/state", HandState_)
        s.Init(states[side], 0)
        subs.append(s)
        p = ChannelPublisher(f"rt/dex3/{side}/cmd", HandCmd_)
        p.Init()
        pubs[side] = p
    print("READY", flush=True)

    # xr_teleoperate: wait until both hands report a state that is not all zero.
    t0 = time.monotonic()
    nonzero = False
    while time.monotonic() - t0 < args.timeout:
        if any(states["left"].get()) and any(states["right"].get()):
            nonzero = True
            break
        time.sleep(0.01)
    first = {side: states[side].get() for side in ("left", "right")}
    print("WAITED " + json.dumps({"nonzero": nonzero, "seconds": time.monotonic() - t0, **first}), flush=True)
    if not nonzero:
        print("DONE", flush=True)
        return 0

    msgs = {}
    for side in ("left", "right"):
        cmd = unitree_hg_msg_dds__HandCmd_()
        for i, m in enumerate(cmd.motor_cmd):
            m.mode = 0x10 | i
            m.q = first[side][i]
            m.kp, m.kd = 1.5, 0.2
        cmd.motor_cmd[INDEX_0].q = TARGET[side]
        msgs[side] = cmd
    t0 = time.monotonic()
    converged = False
    while time.monotonic() - t0 < args.timeout:
        for side in ("left", "right"):
            pubs[side].Write(msgs[side])
        if all(abs(states[s].get()[INDEX_0] - TARGET[s]) < TOL for s in ("left", "right")):
            converged = True
            break
        time.sleep(args.period)
    last = {side: states[side].get() for side in ("left", "right")}
    print("RESULT " + json.dumps({"converged": converged, "seconds": time.monotonic() - t0, **last}), flush=True)
    print("DONE", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
