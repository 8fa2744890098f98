#!/usr/bin/env python3
"""Shows that unitree_sdk2py's "[Reader] take sample error" comes from the client stack, not
from what a publisher sends (docs/fronts.md, "[Reader] take sample error").

Without handgate: one process publishes HandState_ on rt/dex3/left/state with the SDK's
ChannelPublisher at about 1 kHz; the other creates ChannelSubscribers with a handler (as
every SDK client does) while those samples flow, and reports, for every time the SDK printed
the message, the exception it swallowed.

    .venv/bin/python tests/python/take_sample_error_repro.py pub 153 30 &
    for i in 1 2 3 4 5 6 7 8; do .venv/bin/python tests/python/take_sample_error_repro.py sub 153; done

Each `sub` run prints `SWALLOWED AttributeError("'NoneType' object has no attribute 'take'")`
for every "[Reader] take sample error" (a few runs in eight on the 2-core development VM).
"""

import os
import sys
import time

import unitree_sdk2py.core.channel as channel
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandState_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandState_

TOPIC = "rt/dex3/left/state"


def pub(domain, seconds):
    ChannelFactoryInitialize(domain)
    p = ChannelPublisher(TOPIC, HandState_)
    p.Init()
    msg = unitree_hg_msg_dds__HandState_()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        p.Write(msg)
        time.sleep(0.001)


def sub(domain):
    write = os.write

    # The SDK prints the message from inside its bare `except:`; report what it caught.
    def report(*args, _sys=sys, _write=write):
        exc = _sys.exc_info()[1]
        _write(1, (" ".join(map(str, args)) + "\nSWALLOWED " + repr(exc) + "\n").encode())

    channel.print = report
    ChannelFactoryInitialize(domain)
    subs = []
    for _ in range(10):
        s = ChannelSubscriber(TOPIC, HandState_)
        s.Init(lambda msg: None, 10)
        subs.append(s)
    time.sleep(1.0)
    os._exit(0)


if __name__ == "__main__":
    if sys.argv[1] == "pub":
        pub(int(sys.argv[2]), float(sys.argv[3]))
    else:
        sub(int(sys.argv[2]))
