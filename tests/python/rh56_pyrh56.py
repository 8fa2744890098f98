"""pyrh56 0.4.0 (PyPI, not written here) driving RH56 hands on a serial port handgate serves.

Usage: rh56_pyrh56.py PORT ID[,ID..] [--object FINGER | --closure]

For each hand id: connect (pyrh56 reads ANGLE_ACT to sync), check the hand is healthy
(STATUS / ERROR), set speed and force, close to a target with move_to, wait with pyrh56's own
wait_until_reached, read force / status / temperature, open again, clear errors. Prints one
`OK <id> ...` line per hand and `DONE`; any pyrh56 exception fails the script (exit 1).
With --object F the finger F is expected to stop on an object (status 3, force > 0) instead.
With --closure the hand behind the port is of another kind, driven through closure: a fist
(the four fingers 0) must bring the four fingers below 300, open (all 1000) above 700.
"""

import sys
import time

from rh56_sdk.driver import RH56Driver


def settled(hand, want, timeout=5.0):
    """STATUS once every finger reports `want` (the last units of a move take a few ms more
    than pyrh56's tolerance)."""
    deadline = time.monotonic() + timeout
    while True:
        status = hand.read_status()
        if all(want(i, s) for i, s in enumerate(status)) or time.monotonic() > deadline:
            return status
        time.sleep(0.01)


def closure(port: str, node: int) -> None:
    hand = RH56Driver(port, node_id=node, timeout=0.5)
    hand.connect()
    hand.move_to([0, 0, 0, 0, 1000, 1000])
    fist = hand.wait_until_reached([150, 150, 150, 150, None, None], timeout=10.0, tolerance=150)
    hand.move_to([1000] * 6)
    opened = hand.wait_until_reached([850, 850, 850, 850, None, None], timeout=10.0, tolerance=150)
    print(f"OK {node} fist={fist} open={opened}", flush=True)
    hand.disconnect()


def main() -> int:
    port = sys.argv[1]
    ids = [int(x) for x in sys.argv[2].split(",")]
    if sys.argv[3:4] == ["--closure"]:
        for node in ids:
            closure(port, node)
        print("DONE", flush=True)
        return 0
    obj = int(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[3] == "--object" else None
    for node in ids:
        hand = RH56Driver(port, node_id=node, timeout=0.5)
        hand.connect()
        hand.check_motion_ready()
        hand.set_speed([1000] * 6)
        hand.set_force_threshold([400] * 6)
        target = [200, 300, 400, 500, 600, 700]
        hand.move_to(target)
        if obj is None:
            reached = hand.wait_until_reached(target, timeout=5.0, tolerance=5)
            status = settled(hand, lambda i, s: s == 2)
            force = hand.read_force()
            assert all(s == 2 for s in status), status
            assert all(abs(a - t) <= 5 for a, t in zip(reached, target)), (reached, target)
        else:
            expect = [t if i != obj else None for i, t in enumerate(target)]
            hand.wait_until_reached(expect, timeout=5.0, tolerance=5)
            status = settled(hand, lambda i, s: s == (3 if i == obj else 2))
            force = hand.read_force()
            assert status[obj] == 3 and force[obj] > 0, (status, force)
        temp = hand.read_temperature()
        hand.move_finger(0, 1000, base="hold")
        hand.open_hand()
        hand.clear_error()
        print(f"OK {node} angle={hand.read_angle()} force={force} status={status} temp={temp}", flush=True)
        hand.disconnect()
    print("DONE", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
