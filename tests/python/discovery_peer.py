#!/usr/bin/env python3
"""Discovery test peer: endpoints made with the official unitree_sdk2py, nothing written.

Run by adapters/tests/discovery.rs. By hand:
    .venv/bin/python tests/python/discovery_peer.py --domain 210 \
        --pub rt/dex3/left/cmd=unitree_hg/HandCmd_ --sub rt/dex3/left/state=unitree_hg/HandState_

Creates one ChannelPublisher per --pub and one ChannelSubscriber per --sub (the SDK's default
QoS) after ChannelFactoryInitialize(domain). stdout protocol (flushed lines):
    READY <pid>   every endpoint exists
    CLOSED        stdin reached end of file and every endpoint was closed; then it exits 0
With --hold it ignores stdin and keeps its endpoints until it is killed (tests/src's
PyProcess gives it no stdin). It also exits on its own after --timeout seconds.
"""

import argparse
import os
import sys
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
from unitree_sdk2py.core.channel import (  # noqa: E402
    ChannelFactoryInitialize,
    ChannelPublisher,
    ChannelSubscriber,
)


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
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--hold", action="store_true", help="keep the endpoints until killed")
    args = ap.parse_args()

    threading.Timer(args.timeout, lambda: os._exit(3)).start()
    ChannelFactoryInitialize(args.domain, args.interface)
    endpoints = []
    for topic, type_key in args.pub:
        p = ChannelPublisher(topic, ws.CLASSES[type_key])
        p.Init()
        endpoints.append(p)
    for topic, type_key in args.sub:
        s = ChannelSubscriber(topic, ws.CLASSES[type_key])
        s.Init(lambda _msg: None, 0)
        endpoints.append(s)
    print(f"READY {os.getpid()}", flush=True)

    if args.hold:
        threading.Event().wait()
    sys.stdin.read()
    for e in endpoints:
        e.Close()
    print("CLOSED", flush=True)
    os._exit(0)


if __name__ == "__main__":
    main()
