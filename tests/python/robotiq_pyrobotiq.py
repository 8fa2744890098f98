"""pyRobotiqGripper 3.3.14 (PyPI, unmodified) driving a Robotiq gripper through handgate.

Nobody here wrote the client: this script only calls its public API the way its README does
(connect, activate, close, open) and prints what the gripper reported, one JSON object a line,
for tests/tests/robotiq_peer.rs to check.

    robotiq_pyrobotiq.py --tcp 127.0.0.1:54321     RTU over TCP (GRIPPER_MODE_RTU_VIA_TCP)
    robotiq_pyrobotiq.py --port /tmp/handgate-...  RTU on a serial port (GRIPPER_MODE_RTU)

Events: connected (the status read at construction), activated, closed (position, gOBJ,
current), opened, done. Any exception is printed as {"event": "error", ...} and exits 1.
"""

import argparse
import json
import sys
import time
import warnings

import pyrobotiqgripper as rq


def emit(event, **fields):
    print(json.dumps({"event": event, **fields}), flush=True)


def snapshot(g):
    s = g.status()
    return {k: int(v) for k, v in s.items() if k != "time"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tcp", help="host:port of an RTU-over-TCP server")
    ap.add_argument("--port", help="serial port (a pty) of an RTU server")
    ap.add_argument("--slave", type=int, default=9)
    ap.add_argument("--close-to", type=int, default=255, help="rPR of the close")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    try:
        if args.tcp:
            host, port = args.tcp.rsplit(":", 1)
            g = rq.RobotiqGripper(
                device_id=args.slave,
                connection_type=rq.GRIPPER_MODE_RTU_VIA_TCP,
                tcp_host=host,
                tcp_port=int(port),
            )
        else:
            g = rq.RobotiqGripper(com_port=args.port, device_id=args.slave, connection_type=rq.GRIPPER_MODE_RTU)
        emit("connected", status=snapshot(g))
        t0 = time.monotonic()
        g.activate()
        emit("activated", activated=bool(g.isActivated()), seconds=time.monotonic() - t0, status=snapshot(g))
        g.move(args.close_to, speed=255, force=200)
        emit("closed", position=g.position(), object=int(g.objectDetection()), status=snapshot(g))
        g.open(speed=255, force=200)
        emit("opened", position=g.position(), object=int(g.objectDetection()), status=snapshot(g))
        g.disconnect()
        emit("done")
    except Exception as e:  # the test prints it with the transcript
        emit("error", kind=type(e).__name__, message=str(e))
        sys.exit(1)


if __name__ == "__main__":
    main()
