#!/usr/bin/env python3
"""Close the simulated left hand's index finger through handgate's Dex3 front, with the official
unitree_sdk2py, exactly as a program for a G1's hand would. Start `make run` first, then:
    source .venv/bin/activate && python examples/move_left_hand.py [DOMAIN]   # default 1
Exits 0 once the hand reports the finger closed, 1 if it never does within 5 s."""
import sys, time
from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

domain = int(sys.argv[1]) if len(sys.argv) > 1 else 1  # 1: the default profile's DDS domain
ChannelFactoryInitialize(domain)
seen = {}
sub = ChannelSubscriber("rt/dex3/left/state", HandState_)
sub.Init(lambda s: seen.update(q=s.motor_state[5].q), 10)
pub = ChannelPublisher("rt/dex3/left/cmd", HandCmd_)
pub.Init()
cmd = unitree_hg_msg_dds__HandCmd_()
for i, m in enumerate(cmd.motor_cmd):
    m.mode, m.kp, m.kd = 0x10 | i, 1.5, 0.1  # RIS byte: motor id i, FOC on; PD gains
cmd.motor_cmd[5].q = -1.0  # IDL 5 = left index_0; the left hand closes toward negative
for _ in range(500):  # stream at 100 Hz: the gateway holds the hand after 200 ms of silence
    pub.Write(cmd)
    time.sleep(0.01)
    if abs(seen.get("q", 0.0) + 1.0) < 0.05:
        print(f"left index_0 closed: q = {seen['q']:.3f} rad")
        sys.exit(0)
sys.exit(f"no movement seen (index_0 q = {seen.get('q')}): is `make run` running?")
