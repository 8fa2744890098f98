#!/usr/bin/env python3
"""The subscriptions a ROS 2 node sees on one topic, with CycloneDDS Python (no ROS needed).

Run by tests/tests/joint_state_command.rs. By hand, against a running gateway:
    .venv/bin/python tests/python/ros_subscription_peer.py --domain 1 --topic rt/robot_joint_commands

Reads DCPSSubscription, as rmw_cyclonedds's graph cache does, and prints the first reader on
--topic with what a ROS 2 node takes from it: its type name, its USER_DATA (where Iron and later
read the REP-2011 type hash) and its reliability.

stdout protocol (flushed lines):
    READY <pid>
    SUB <json>          {"topic", "type", "user_data", "reliability"}
    DONE
It exits on its own after --timeout seconds (exit 3).
"""

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsSubscription  # noqa: E402
from cyclonedds.core import Policy  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402

from ros_peer import policy_name, user_data  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--topic", required=True, help="DDS topic of the reader")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()
    threading.Timer(args.timeout, lambda: os._exit(3)).start()

    dp = DomainParticipant(args.domain)
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    print(f"READY {os.getpid()}", flush=True)
    while True:
        for s in subs.take(N=64):
            if s.topic_name != args.topic:
                continue
            sub = {
                "topic": s.topic_name,
                "type": s.type_name,
                "user_data": user_data(s.qos),
                "reliability": policy_name(s.qos, Policy.Reliability),
            }
            print("SUB " + json.dumps(sub), flush=True)
            print("DONE", flush=True)
            os._exit(0)
        time.sleep(0.02)


if __name__ == "__main__":
    try:
        main()
    except Exception:  # the timer thread would keep the process alive until the timeout
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        os._exit(2)
