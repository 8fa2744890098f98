#!/usr/bin/env python3
"""Echo peer: reads every wire type with the official unitree_sdk2py (CycloneDDS Python for the
types the SDK has no class for) and writes each sample back unchanged. Run by
tests/tests/dds_binding.rs (`every_wire_type_round_trips_through_the_sdk`): the Rust side writes
a value of each type on `rt/handgate/test/echo/<key>/to_py` and reads it back from
`.../to_rs`, so each type is written and read both ways by both sides. Under valgrind
(scripts/valgrind.sh wire) it is the peer of the binding's checked run.

    .venv/bin/python tests/python/echo_peer.py --domain 218 [--interface lo] [--timeout 600]

stdout protocol (flushed lines):
    READY              every reader and writer is set up
    GOT <key> <json>   the first sample of <key> as plain values (wire_schema.py); printed
                       before that sample is written back
"""

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import wire_schema as ws  # noqa: E402
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber  # noqa: E402

# The types handgate puts on the wire as topics (docs/wire-types.md), by wire_schema key.
KEYS = [
    "unitree_hg/HandCmd_",
    "unitree_hg/HandState_",
    "unitree_go/MotorCmds_",
    "unitree_go/MotorStates_",
    "inspire/inspire_hand_ctrl",
    "inspire/inspire_hand_state",
    "inspire/inspire_hand_touch",
    "handgate/HandCmd_",
    "handgate/HandState_",
    "handgate/GatewayStatus_",
    "sensor_msgs/JointState_",
]


def topic(key, direction):
    return "rt/handgate/test/echo/%s/%s" % (key.replace("/", "_"), direction)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--timeout", type=float, default=600.0)
    a = ap.parse_args()

    ChannelFactoryInitialize(a.domain, a.interface)
    lock = threading.Lock()
    seen = set()
    keep = []
    for key in KEYS:
        pub = ChannelPublisher(topic(key, "to_rs"), ws.CLASSES[key])
        pub.Init()

        def echo(msg, key=key, pub=pub):
            with lock:
                first = key not in seen
                seen.add(key)
            if first:
                print("GOT %s %s" % (key, json.dumps(ws.to_plain(key, msg), allow_nan=False)), flush=True)
            pub.Write(msg)

        sub = ChannelSubscriber(topic(key, "to_py"), ws.CLASSES[key])
        sub.Init(echo, 10)
        keep += [pub, sub]
    print("READY", flush=True)
    time.sleep(a.timeout)
    os._exit(0)


if __name__ == "__main__":
    main()
