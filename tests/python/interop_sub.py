#!/usr/bin/env python3
"""Interop helper: subscribe with the official unitree_sdk2py and print the first sample.

Run by tests/tests/interop_python.rs (Rust writer -> Python reader). By hand:
    .venv/bin/python tests/python/interop_sub.py --domain 10 --topic rt/dex3/left/cmd \
        --type unitree_hg/HandCmd_ [--interface lo] [--timeout 30]

Protocol on stdout (one line each, flushed):
    READY              once ChannelFactoryInitialize + ChannelSubscriber.Init are done
    SAMPLE <json>      the first valid sample, as plain values (see wire_schema.py); exit 0
    TIMEOUT            nothing arrived within --timeout seconds; exit 3
"""

import argparse
import json
import os
import sys
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelSubscriber  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--topic", required=True)
    ap.add_argument("--type", required=True, choices=sorted(ws.CLASSES))
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=30.0)
    args = ap.parse_args()

    ChannelFactoryInitialize(args.domain, args.interface)
    received = []
    got = threading.Event()

    def on_sample(msg):
        if not got.is_set():
            received.append(msg)
            got.set()

    sub = ChannelSubscriber(args.topic, ws.CLASSES[args.type])
    sub.Init(on_sample, 0)
    print("READY", flush=True)

    if not got.wait(args.timeout):
        print("TIMEOUT", flush=True)
        os._exit(3)
    line = json.dumps(ws.to_plain(args.type, received[0]), allow_nan=False)
    print("SAMPLE " + line, flush=True)
    # Leave without tearing down CycloneDDS from the listener's process state; the peer
    # notices the participant leaving through its lease.
    os._exit(0)


if __name__ == "__main__":
    main()
