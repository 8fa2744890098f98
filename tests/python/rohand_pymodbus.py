"""A ROHand client as OYMotion's own examples write it (pymodbus, RTU, 115200, node id 2),
against `handgate emulate rohand` on a pty: reads ROH_FINGER_POS, closes the hand with
ROH_FINGER_POS_TARGET = 65535, waits for the positions to follow, and reads a register
outside the hand's file (exception 2). Prints one line per step for the Rust test.

Usage: rohand_pymodbus.py PTY
"""

import sys
import time

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient

ROH_FINGER_POS_TARGET0 = 1135
ROH_FINGER_POS0 = 1145
NODE_ID = 2


def main():
    client = ModbusSerialClient(sys.argv[1], framer=FramerType.RTU, baudrate=115200, timeout=1)
    if not client.connect():
        print("error cannot open", sys.argv[1], flush=True)
        return 1
    r = client.read_holding_registers(ROH_FINGER_POS0, count=6, device_id=NODE_ID)
    if r.isError():
        print("error read", r, flush=True)
        return 1
    print("pos", " ".join(str(v) for v in r.registers), flush=True)
    w = client.write_registers(ROH_FINGER_POS_TARGET0, [65535] * 6, device_id=NODE_ID)
    if w.isError():
        print("error write", w, flush=True)
        return 1
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        r = client.read_holding_registers(ROH_FINGER_POS0, count=6, device_id=NODE_ID)
        if not r.isError() and r.registers == [65535] * 6:
            print("closed", " ".join(str(v) for v in r.registers), flush=True)
            break
        time.sleep(0.05)
    else:
        print("error never closed", flush=True)
        return 1
    r = client.read_holding_registers(0x6B, count=2, device_id=NODE_ID)
    print("exception", getattr(r, "exception_code", None), flush=True)
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
