#!/usr/bin/env python3
"""The Python baseline of the shim hop benchmark (handgate-bench shim, make bench): a Dex1 ->
Dex3 shim as integrators write it today with the official unitree_sdk2py (SAKE's EZGripper
driver has the same shape: subscribe the Dex1 topic, map, talk to the device, publish the
state).

- A ChannelSubscriber on rt/dex1/<side>/cmd (unitree_go MotorCmds_, 1 element) whose callback
  maps the jaw position to a Dex3 closure posture and publishes a unitree_hg HandCmd_ on the
  service's rt/dex3/<side>/cmd, remembering the command's tag (cmds[0].reserve[0]).
- A ChannelSubscriber on the service's rt/dex3/<side>/state (HandState_) whose callback
  publishes a MotorStates_ on rt/dex1/<side>/state: the jaw position at the hand's closure,
  reserve[0] = the tag of the last command forwarded before that state arrived.

The mapping's numbers (open and closed wire postures, gains, the Dex1 range) come from the
benchmark (handgate's Dex3 table), so the three shims map alike.

    .venv/bin/python bench/python/shim.py --domain 107 --open ... --closed ... --kp 1.5 --kd 0.2 --range 5.4

Prints READY once its endpoints exist; runs until interrupted.
"""

import argparse
import signal
import sys
import time

from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import (
    unitree_go_msg_dds__MotorState_,
    unitree_hg_msg_dds__HandCmd_,
)
from unitree_sdk2py.idl.unitree_go.msg.dds_ import MotorCmds_, MotorStates_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

MOTORS = 7


def floats(s):
    v = [float(x) for x in s.split(",")]
    if len(v) != MOTORS:
        raise argparse.ArgumentTypeError(f"expected {MOTORS} values, got {len(v)}")
    return v


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--interface", default=None)
    ap.add_argument("--side", default="left", choices=["left", "right"])
    ap.add_argument("--open", type=floats, required=True)
    ap.add_argument("--closed", type=floats, required=True)
    ap.add_argument("--kp", type=float, required=True)
    ap.add_argument("--kd", type=float, required=True)
    ap.add_argument("--range", type=float, required=True)
    a = ap.parse_args()
    if a.interface:
        ChannelFactoryInitialize(a.domain, a.interface)
    else:
        ChannelFactoryInitialize(a.domain)

    to_service = ChannelPublisher(f"rt/dex3/{a.side}/cmd", HandCmd_)
    to_service.Init()
    to_client = ChannelPublisher(f"rt/dex1/{a.side}/state", MotorStates_)
    to_client.Init()
    last_tag = [0]
    spans = [c - o for o, c in zip(a.open, a.closed)]

    def on_cmd(msg):
        if len(msg.cmds) != 1:
            return
        m = msg.cmds[0]
        c = min(1.0, max(0.0, 1.0 - m.q / a.range))
        out = unitree_hg_msg_dds__HandCmd_()
        for i in range(MOTORS):
            mc = out.motor_cmd[i]
            mc.mode = 0x10 | i  # RIS: motor id, status FOC, no timeout
            mc.q = a.open[i] + c * spans[i]
            mc.kp = a.kp
            mc.kd = a.kd
        to_service.Write(out)
        last_tag[0] = m.reserve[0]

    def on_state(st):
        total, n = 0.0, 0
        for i in range(min(MOTORS, len(st.motor_state))):
            if abs(spans[i]) > 1e-6:
                total += min(1.0, max(0.0, (st.motor_state[i].q - a.open[i]) / spans[i]))
                n += 1
        q = a.range * (1.0 - (total / n if n else 0.0))
        s = unitree_go_msg_dds__MotorState_()
        s.q = q
        s.q_raw = q
        s.reserve[0] = last_tag[0]
        to_client.Write(MotorStates_([s]))

    from_service = ChannelSubscriber(f"rt/dex3/{a.side}/state", HandState_)
    from_service.Init(on_state, 10)
    from_client = ChannelSubscriber(f"rt/dex1/{a.side}/cmd", MotorCmds_)
    from_client.Init(on_cmd, 10)
    print("READY", flush=True)
    signal.signal(signal.SIGINT, lambda *_: sys.exit(0))
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    while True:
        time.sleep(1)


if __name__ == "__main__":
    main()
