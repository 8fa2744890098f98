#!/usr/bin/env python3
"""The Python baseline of the end-to-end hop benchmark (make bench): a relay as users write it
today with the official unitree_sdk2py. It subscribes to unitree_hg HandCmd_ and, in the
subscriber callback, publishes a HandState_ (7 motors, 9 pads) whose reserve[0] echoes the
command's reserve[0].

    .venv/bin/python bench/python/relay.py --domain 102 [--interface lo]

Prints READY once its endpoints exist; runs until interrupted.
"""

import argparse
import signal
import sys
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import (
    unitree_hg_msg_dds__HandState_,
    unitree_hg_msg_dds__PressSensorState_,
)
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--cmd-topic", default="rt/dex3/left/cmd")
    ap.add_argument("--state-topic", default="rt/dex3/left/state")
    a = ap.parse_args()
    if a.interface:
        ChannelFactoryInitialize(a.domain, a.interface)
    else:
        ChannelFactoryInitialize(a.domain)
    pub = ChannelPublisher(a.state_topic, HandState_)
    pub.Init()

    def on_cmd(cmd):
        st = unitree_hg_msg_dds__HandState_()
        # The SDK's default factory builds 7 pads; a Dex3-1 reports 9.
        st.press_sensor_state = [unitree_hg_msg_dds__PressSensorState_() for _ in range(9)]
        st.reserve[0] = cmd.reserve[0]
        pub.Write(st)

    sub = ChannelSubscriber(a.cmd_topic, HandCmd_)
    sub.Init(on_cmd, 10)
    print("READY", flush=True)
    signal.signal(signal.SIGINT, lambda *_: sys.exit(0))
    while True:
        time.sleep(1)


if __name__ == "__main__":
    main()
