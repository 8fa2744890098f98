"""inspire-rh56dftp 0.1.0 (PyPI, not written here) driving an RH56 hand over Modbus TCP on a port
handgate serves.

Usage: rh56_dftp.py HOST PORT

Connects (the client writes SPEED_SET and drains the acknowledgement), sends a target with
send_raw, polls ANGLE_ACT with read_holding until the hand is there, reads FORCE_ACT and every
tactile batch the client's scheduler reads (TACTILE_READ_BATCHES), then opens the hand. Prints
`OK ...` and `DONE`; a failure exits 1.
"""

import sys
import time

from inspire_rh56dftp.client import InspireHand
from inspire_rh56dftp.registers import ANGLE_ACT, FORCE_ACT, TACTILE_READ_BATCHES


def main() -> int:
    host, port = sys.argv[1], int(sys.argv[2])
    hand = InspireHand(ip=host, port=port, min_send_interval_s=0.0, timeout=2.0)
    target = [300, 400, 500, 600, 700, 800]
    assert hand.send_raw(target), "send_raw refused"
    deadline = time.monotonic() + 10.0
    angles = None
    while time.monotonic() < deadline:
        angles = hand.read_holding(ANGLE_ACT, 6, name="angle_act")
        if angles is not None and all(abs(a - t) <= 5 for a, t in zip(angles, target)):
            break
        time.sleep(0.02)
    assert angles is not None and all(abs(a - t) <= 5 for a, t in zip(angles, target)), angles
    force = hand.read_holding(FORCE_ACT, 6, name="force_act")
    assert force is not None and len(force) == 6, force
    cells = 0
    for addr, regions in TACTILE_READ_BATCHES:
        count = sum(n for _, n in regions)
        values = hand.read_holding(addr, count, name=f"tactile@{addr}")
        assert values is not None and len(values) == count, (addr, values)
        assert all(0 <= v <= 4095 for v in values), (addr, max(values))
        cells += count
    hand.open_hand()
    print(f"OK angles={angles} force={force} tactile_cells={cells} dead={hand.dead}", flush=True)
    hand.close()
    print("DONE", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
