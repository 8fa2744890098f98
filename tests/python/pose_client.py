#!/usr/bin/env python3
"""A Dex3 pose client through the official unitree_sdk2py, commanding at a chosen period:
0.01 s streams like xr_teleoperate, 1.0 s sends its pose once per second like the C++ SDK's
g1_dex3_example (GRIP / STOP poses). Run by tests/tests/fronts_service.rs.

    .venv/bin/python tests/python/pose_client.py --domain 1 --side left --period 1.0 \
        --target -1.0 [--interface lo] [--timeout 20] [--hold 1.5]

It writes HandCmd_ on rt/dex3/{side}/cmd (RIS mode 0x10|i: FOC, no timeout bit; kp 1.5,
kd 0.1; every q 0 except index_0 = --target) every --period seconds and reads HandState_ on
rt/dex3/{side}/state. Once index_0 is within 0.05 rad of the target it keeps its period for
--hold more seconds and records how far index_0 strays.

stdout protocol (flushed lines):
    READY                       endpoints set up (the first command goes out after this)
    CONVERGED <json>            {"seconds": since the first command, "commands": sent so far}
    HELD <json>                 {"max_dev": largest |index_0 - target| while holding,
                                 "samples": state samples while holding}
    TIMEOUT <json>              {"q": last index_0, "commands": sent} when --timeout passed
"""

import argparse
import json
import sys
import threading
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

TOL = 0.05
INDEX_0 = 5  # IDL index of index_0 (Dex3-1 manual; docs/model.md)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--side", choices=["left", "right"], required=True)
    ap.add_argument("--period", type=float, required=True)
    ap.add_argument("--target", type=float, required=True)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--hold", type=float, default=1.5)
    a = ap.parse_args()

    if a.interface:
        ChannelFactoryInitialize(a.domain, a.interface)
    else:
        ChannelFactoryInitialize(a.domain)
    lock = threading.Lock()
    seen = {"q": None, "n": 0}

    def on_state(s):
        with lock:
            seen["q"] = s.motor_state[INDEX_0].q
            seen["n"] += 1

    sub = ChannelSubscriber(f"rt/dex3/{a.side}/state", HandState_)
    sub.Init(on_state, 10)
    pub = ChannelPublisher(f"rt/dex3/{a.side}/cmd", HandCmd_)
    pub.Init()
    cmd = unitree_hg_msg_dds__HandCmd_()
    for i, m in enumerate(cmd.motor_cmd):
        m.mode, m.kp, m.kd, m.q = 0x10 | i, 1.5, 0.1, 0.0
    cmd.motor_cmd[INDEX_0].q = a.target
    # Wait for the gateway's state (discovery), so the first command is not lost.
    t_ready = time.monotonic()
    while seen["n"] == 0 and time.monotonic() - t_ready < a.timeout:
        time.sleep(0.01)
    print("READY", flush=True)

    start = time.monotonic()
    next_write = start
    commands = 0
    converged_at = None
    max_dev, hold_samples, hold_from = 0.0, 0, 0
    while True:
        now = time.monotonic()
        if now >= next_write:
            pub.Write(cmd)
            commands += 1
            next_write += a.period
        with lock:
            q, n = seen["q"], seen["n"]
        if converged_at is None:
            if q is not None and abs(q - a.target) < TOL:
                converged_at = now
                hold_from = n
                print("CONVERGED " + json.dumps({"seconds": now - start, "commands": commands}), flush=True)
            elif now - start > a.timeout:
                print("TIMEOUT " + json.dumps({"q": q, "commands": commands}), flush=True)
                return 1
        else:
            if n > hold_from and q is not None:
                max_dev = max(max_dev, abs(q - a.target))
                hold_samples = n - hold_from
            if now - converged_at > a.hold:
                print("HELD " + json.dumps({"max_dev": max_dev, "samples": hold_samples}), flush=True)
                return 0
        time.sleep(0.002)


if __name__ == "__main__":
    sys.exit(main())
