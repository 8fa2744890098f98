#!/usr/bin/env python3
"""A Dex3 client streaming one pose at 100 Hz through the official unitree_sdk2py, as
xr_teleoperate does, until killed (or --seconds). Run by tests/tests/control_e2e.rs: two of
them on one front are two commanding clients (two processes, two DDS writers).

    .venv/bin/python tests/python/stream_client.py --domain 125 --side left --target -1.0 \
        [--interface lo] [--seconds 60]

It writes HandCmd_ on rt/dex3/{side}/cmd (RIS mode 0x10|i: FOC, no timeout bit; kp 1.5,
kd 0.1; every q 0 except index_0 = --target) every 10 ms, once the gateway's state on
rt/dex3/{side}/state has been seen.

stdout protocol (flushed lines):
    READY                       the gateway's state was seen; streaming starts
    STREAMING                   the first command was written
    DONE <n>                    --seconds passed, n commands written
"""

import argparse
import sys
import threading
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

INDEX_0 = 5  # IDL index of index_0 (Dex3-1 manual; docs/model.md)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--side", choices=["left", "right"], required=True)
    ap.add_argument("--target", type=float, required=True)
    ap.add_argument("--seconds", type=float, default=60.0)
    a = ap.parse_args()

    if a.interface:
        ChannelFactoryInitialize(a.domain, a.interface)
    else:
        ChannelFactoryInitialize(a.domain)
    seen = threading.Event()
    sub = ChannelSubscriber(f"rt/dex3/{a.side}/state", HandState_)
    sub.Init(lambda _s: seen.set(), 10)
    pub = ChannelPublisher(f"rt/dex3/{a.side}/cmd", HandCmd_)
    pub.Init()
    cmd = unitree_hg_msg_dds__HandCmd_()
    for i, m in enumerate(cmd.motor_cmd):
        m.mode, m.kp, m.kd, m.q = 0x10 | i, 1.5, 0.1, 0.0
    cmd.motor_cmd[INDEX_0].q = a.target
    if not seen.wait(20.0):
        print("NO_GATEWAY", flush=True)
        return 1
    print("READY", flush=True)
    start = time.monotonic()
    n = 0
    while time.monotonic() - start < a.seconds:
        pub.Write(cmd)
        n += 1
        if n == 1:
            print("STREAMING", flush=True)
        time.sleep(max(0.0, start + 0.01 * n - time.monotonic()))
    print(f"DONE {n}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
