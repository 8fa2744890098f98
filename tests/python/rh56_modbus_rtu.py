"""pymodbus 3.16.1 (PyPI, pyrobotiqgripper's dependency, not written here) as a Modbus RTU master
of an RH56 on a serial port handgate serves (the RH56 front's `serve = "modbus_rtu"`).

Usage: rh56_modbus_rtu.py PORT SLAVE

Writes six angles to ANGLE_SET (FC16 at byte address 1486, one register a finger), polls
ANGLE_ACT (FC03 at 1546) until the hand is there, reads STATUS/TEMP as words, checks a write
to a measured register is exception 2. Prints `OK ...` and `DONE`; a failure exits 1.
"""

import sys
import time

from pymodbus.client import ModbusSerialClient


def main() -> int:
    port, slave = sys.argv[1], int(sys.argv[2])
    c = ModbusSerialClient(port, baudrate=115200, timeout=1.0, retries=1)
    assert c.connect(), "cannot open the port"
    target = [250, 350, 450, 550, 650, 750]
    r = c.write_registers(1486, target, device_id=slave)
    assert not r.isError(), r
    deadline = time.monotonic() + 10.0
    angles = None
    while time.monotonic() < deadline:
        r = c.read_holding_registers(1546, count=6, device_id=slave)
        assert not r.isError(), r
        angles = r.registers
        if all(abs(a - t) <= 5 for a, t in zip(angles, target)):
            break
        time.sleep(0.02)
    assert all(abs(a - t) <= 5 for a, t in zip(angles, target)), angles
    r = c.read_holding_registers(1612, count=6, device_id=slave)
    assert not r.isError() and len(r.registers) == 6, r
    refused = c.write_registers(1546, [0] * 6, device_id=slave)
    assert refused.isError() and getattr(refused, "exception_code", None) == 2, refused
    print(f"OK angles={angles} status_temp_words={r.registers}", flush=True)
    c.close()
    print("DONE", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
