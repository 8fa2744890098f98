#!/usr/bin/env python3
"""A LEAP_Hand_API-style client written against dynamixel-sdk 4.1.0 (PyPI), for the LEAP
Hand tests (tests/tests/leap*.rs): what a LEAP Hand program does on its U2D2's port.

    leap_client.py --port PATH [--read sync|fast] [--target RAD ...] [--seconds S] [--tol RAD]
                   [--skip-init] [--bad-input]

1. Opens the port at 4 000 000 baud, pings ids 0-15 (prints `pinged <ids>`).
2. Unless --skip-init: the LEAP init as LEAP_Hand_API's main.py does it, each a GroupSyncWrite:
   operating mode (11) = 5, torque (64) on, P (84) 600 (450 on ids 0, 4, 8), I (82) 0, D (80)
   200 (150), goal current (102) 350.
3. Reads present current, velocity and position of the 16 in ONE GroupSyncRead at 126, 10
   bytes (or a Fast Sync Read with --read fast) and prints `read <json>` (LEAP radians,
   rad/s, mA).
4. With --target: 16 LEAP radians (one value: the same for every motor); writes them with a
   GroupSyncWrite at 116 and reads back every cycle until every motor is within --tol, for at most
   --seconds; prints `reached {"cycles": n, "max_err": e, "hz": rate}` or `timeout ...`.
5. With --bad-input: first writes garbage, a frame with a bad CRC and half a frame to the port
   (each then answered by nothing), and checks the bus still answers a ping after them.

Exit 0 on success; every failure prints `error <what>` and exits 1.
"""

import argparse
import json
import math
import sys
import time

import dynamixel_sdk as dxl

IDS = list(range(16))
BAUD = 4_000_000
POS_SCALE = 2.0 * math.pi / 4096  # LEAP radians per tick
VEL_SCALE = 0.229 * 2.0 * math.pi / 60.0
SIDE = (0, 4, 8)


def fail(what):
    print(f"error {what}", flush=True)
    sys.exit(1)


def signed(v, size):
    bits = 8 * size
    return v - (1 << bits) if v & (1 << (bits - 1)) else v


def sync_write(port, ph, addr, size, values):
    w = dxl.GroupSyncWrite(port, ph, addr, size)
    for i, v in zip(IDS, values):
        v = int(v) & ((1 << (8 * size)) - 1)
        if not w.addParam(i, list(v.to_bytes(size, "little"))):
            fail(f"addParam {i}")
    rc = w.txPacket()
    if rc != dxl.COMM_SUCCESS:
        fail(f"sync write {addr}: {ph.getTxRxResult(rc)}")


def make_reader(port, ph):
    r = dxl.GroupSyncRead(port, ph, 126, 10)
    for i in IDS:
        if not r.addParam(i):
            fail(f"sync read addParam {i}")
    return r


def read_all(reader, ph, fast, tries=10):
    for _ in range(tries):
        rc = reader.fastSyncRead() if fast else reader.txRxPacket()
        if rc == dxl.COMM_SUCCESS:
            break
    if rc != dxl.COMM_SUCCESS:
        return None, ph.getTxRxResult(rc)
    pos, vel, cur = [], [], []
    for i in IDS:
        if not reader.isAvailable(i, 126, 10):
            return None, f"id {i} unavailable"
        cur.append(signed(reader.getData(i, 126, 2), 2))
        vel.append(signed(reader.getData(i, 128, 4), 4) * VEL_SCALE)
        pos.append(signed(reader.getData(i, 132, 4), 4) * POS_SCALE)
    return (pos, vel, cur), None


def ping(port, ph, i, tries=10):
    """A ping, retried: the SDK waits about 35 ms for an answer, which a loaded test machine
    can miss (LEAP_Hand_API's reads retry the same way)."""
    for _ in range(tries):
        _, rc, err = ph.ping(port, i)
        if rc == dxl.COMM_SUCCESS:
            return rc, err
    return rc, err


def bad_input(port, ph):
    # Garbage, a ping with a broken CRC, and half a read: none is a request, none is answered.
    port.writePort([0x00, 0x13, 0x37, 0xFF, 0x42])
    port.writePort([0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x00, 0x00])
    port.writePort([0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x07, 0x00, 0x02, 0x84])
    time.sleep(0.1)  # let the half frame go stale on the bus side (its gap rule)
    port.clearPort()
    rc, _ = ping(port, ph, 3)
    if rc != dxl.COMM_SUCCESS:
        fail(f"no ping answer after bad input: {ph.getTxRxResult(rc)}")
    print("bad-input survived", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--port", required=True)
    ap.add_argument("--read", choices=["sync", "fast"], default="sync")
    ap.add_argument("--target", type=float, nargs="*")
    # How long the client keeps commanding before it gives up: a wall-clock budget, not a cycle
    # count (an idle machine runs thousands of cycles before a slower device behind the bus,
    # an Inspire hand at 100 Hz, has closed).
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--tol", type=float, default=0.05)
    ap.add_argument("--skip-init", action="store_true")
    ap.add_argument("--bad-input", action="store_true")
    a = ap.parse_args()

    port = dxl.PortHandler(a.port)
    ph = dxl.PacketHandler(2.0)
    if not port.openPort():
        fail(f"open {a.port}")
    if not port.setBaudRate(BAUD):
        fail("baud")
    if a.bad_input:
        bad_input(port, ph)
    seen = []
    for i in IDS:
        rc, err = ping(port, ph, i)
        if rc == dxl.COMM_SUCCESS and err == 0:
            seen.append(i)
    print(f"pinged {json.dumps(seen)}", flush=True)
    if seen != IDS:
        fail(f"only {seen} answered")
    if not a.skip_init:
        sync_write(port, ph, 11, 1, [5] * 16)
        sync_write(port, ph, 64, 1, [1] * 16)
        sync_write(port, ph, 84, 2, [450 if i in SIDE else 600 for i in IDS])
        sync_write(port, ph, 82, 2, [0] * 16)
        sync_write(port, ph, 80, 2, [150 if i in SIDE else 200 for i in IDS])
        sync_write(port, ph, 102, 2, [350] * 16)
    reader = make_reader(port, ph)
    fast = a.read == "fast"
    got, why = read_all(reader, ph, fast)
    if got is None:
        fail(f"read: {why}")
    print("read " + json.dumps({"pos": got[0], "vel": got[1], "cur": got[2]}), flush=True)
    if a.target:
        target = a.target * 16 if len(a.target) == 1 else a.target
        if len(target) != 16:
            fail("--target takes 1 or 16 values")
        ticks = [round(t / POS_SCALE) for t in target]
        t0 = time.monotonic()
        err = float("inf")
        retried = 0
        n = 0
        while time.monotonic() - t0 < a.seconds:
            n += 1
            sync_write(port, ph, 116, 4, ticks)
            got, why = read_all(reader, ph, fast)
            if got is None:
                retried += 1
                continue
            err = max(abs(p - t) for p, t in zip(got[0], target))
            if err <= a.tol:
                dt = time.monotonic() - t0
                print("reached " + json.dumps({"cycles": n, "retried": retried, "max_err": err, "hz": n / dt, "pos": got[0]}), flush=True)
                break
        else:
            print("timeout " + json.dumps({"max_err": err, "cycles": n}), flush=True)
            sys.exit(1)
    port.closePort()
    print("done", flush=True)


if __name__ == "__main__":
    main()
