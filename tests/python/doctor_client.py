#!/usr/bin/env python3
"""A client for `handgate doctor` to find: endpoints made with the official unitree_sdk2py.

Run by tests/tests/doctor.rs. By hand:
    .venv/bin/python tests/python/doctor_client.py --domain 142 \
        --pub rt/dex1/left/cmd=unitree_hg/HandCmd_ --sub rt/dex1/left/state=unitree_hg/HandState_

--pub / --sub make one ChannelPublisher / ChannelSubscriber each (the SDK's default QoS) after
ChannelFactoryInitialize(domain[, interface]); nothing is written on them.
--write-old-hand-cmd TOPIC writes, every 10 ms, a HandCmd_ of 7 motors in the layout
unitree_sdk2 used before December 2024 (no reserve[4]; same type name
unitree_hg::msg::dds_::HandCmd_), declared here for CycloneDDS Python as the SDK declares its
types.
stdout: `READY <pid>` once every endpoint exists. The process runs until killed or --timeout.
"""

import argparse
import os
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
import cyclonedds.idl as idl  # noqa: E402
import cyclonedds.idl.annotations as annotate  # noqa: E402
import cyclonedds.idl.types as types  # noqa: E402
from unitree_sdk2py.core.channel import (  # noqa: E402
    ChannelFactoryInitialize,
    ChannelPublisher,
    ChannelSubscriber,
)
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import MotorCmd_  # noqa: E402


@dataclass
@annotate.final
@annotate.autoid("sequential")
class OldHandCmd_(idl.IdlStruct, typename="unitree_hg.msg.dds_.HandCmd_"):
    """HandCmd_ before December 2024: the motor commands only."""

    motor_cmd: types.sequence["unitree_sdk2py.idl.unitree_hg.msg.dds_.MotorCmd_"]


def pair(text):
    topic, _, type_key = text.rpartition("=")
    if type_key not in ws.CLASSES:
        raise argparse.ArgumentTypeError(f"unknown type {type_key!r}")
    return topic, type_key


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--pub", type=pair, action="append", default=[])
    ap.add_argument("--sub", type=pair, action="append", default=[])
    ap.add_argument("--write-old-hand-cmd", default=None)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()

    threading.Timer(args.timeout, lambda: os._exit(3)).start()
    if args.interface:
        ChannelFactoryInitialize(args.domain, args.interface)
    else:
        ChannelFactoryInitialize(args.domain)
    endpoints = []
    for topic, type_key in args.pub:
        p = ChannelPublisher(topic, ws.CLASSES[type_key])
        p.Init()
        endpoints.append(p)
    for topic, type_key in args.sub:
        s = ChannelSubscriber(topic, ws.CLASSES[type_key])
        s.Init(lambda _msg: None, 0)
        endpoints.append(s)
    old = None
    if args.write_old_hand_cmd:
        old = ChannelPublisher(args.write_old_hand_cmd, OldHandCmd_)
        old.Init()
    print(f"READY {os.getpid()}", flush=True)
    if old is None:
        threading.Event().wait()
    msg = OldHandCmd_(
        motor_cmd=[MotorCmd_(mode=0x10 | i, q=0.0, dq=0.0, tau=0.0, kp=1.5, kd=0.1, reserve=0) for i in range(7)]
    )
    while True:
        old.Write(msg)
        time.sleep(0.01)


if __name__ == "__main__":
    main()
