#!/usr/bin/env python3
"""Interop helper: publish a fixture's value with the official unitree_sdk2py, repeatedly.

Run by tests/tests/interop_python.rs (Python writer -> Rust reader). By hand:
    .venv/bin/python tests/python/interop_pub.py --domain 11 --topic rt/dex3/left/cmd \
        --type unitree_hg/HandCmd_ --fixture tests/fixtures/golden/unitree_hg__HandCmd___typical.json

The value comes from the fixture's "value" (plain values, see wire_schema.py), is built into the
SDK's message class and written every --period seconds through ChannelPublisher until the test
kills the process or --timeout passes. stdout protocol (flushed lines):
    SENT <json>   the value as the SDK object holds it (after building), once
    READY         once ChannelFactoryInitialize + ChannelPublisher.Init are done
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--topic", required=True)
    ap.add_argument("--type", required=True, choices=sorted(ws.CLASSES))
    ap.add_argument("--fixture", required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--period", type=float, default=0.01)
    ap.add_argument("--timeout", type=float, default=30.0)
    args = ap.parse_args()

    with open(args.fixture) as f:
        value = json.load(f)["value"]
    msg = ws.from_plain(args.type, value)
    print("SENT " + json.dumps(ws.to_plain(args.type, msg), allow_nan=False), flush=True)

    ChannelFactoryInitialize(args.domain, args.interface)
    pub = ChannelPublisher(args.topic, ws.CLASSES[args.type])
    pub.Init()
    print("READY", flush=True)

    deadline = time.monotonic() + args.timeout
    while time.monotonic() < deadline:
        if not pub.Write(msg):
            print("WRITE_FAILED", flush=True)
        time.sleep(args.period)
    print("TIMEOUT", flush=True)
    os._exit(3)


if __name__ == "__main__":
    main()
