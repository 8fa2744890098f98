#!/usr/bin/env python3
"""A ROS 2 node's view of handgate, with CycloneDDS Python (no ROS installation needed).

Run by tests/tests/ros_presence.rs. By hand, against a running gateway:
    .venv/bin/python tests/python/ros_peer.py --domain 1 --joint-states rt/joint_states

What it does, as a ROS 2 (Iron or later) node on rmw_cyclonedds would:
- reads `ros_discovery_info` (rmw_dds_common ParticipantEntitiesInfo, 16-byte Gid) with rmw's
  QoS (reliable, transient-local, keep-last 1), joining after the gateway published it;
- subscribes to the JointState topic with ROS 2's default QoS (reliable, keep-last 10,
  volatile);
- reads DCPSPublication for the endpoints of the participant that announced a node.

stdout protocol (flushed lines):
    READY <pid>
    NODE <json>         {"gid": hex, "nodes": [{"namespace", "name", "readers": [hex], "writers": [hex]}]}
    PUB <json>          one per writer of that participant:
                        {"key", "participant", "topic", "type", "user_data", "reliability", "durability"}
    JOINT_STATE <n>     a sample arrived on the JointState reader (n joint names)
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

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication  # noqa: E402
from cyclonedds.core import Qos, Policy  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

import handgate_types as ht  # noqa: E402


def policy_name(qos, policy):
    try:
        p = qos[policy]
    except KeyError:
        return None
    if p is None:
        return None
    return p.__name__ if isinstance(p, type) else type(p).__name__


def user_data(qos):
    """An endpoint's USER_DATA as text (where ROS 2 puts its type hash), or None."""
    try:
        u = qos[Policy.Userdata]
    except KeyError:
        return None
    return None if u is None else bytes(u.data).decode("utf-8", "replace")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--joint-states", required=True, help="DDS topic of the JointState writer")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()
    threading.Timer(args.timeout, lambda: os._exit(3)).start()

    dp = DomainParticipant(args.domain)
    info_qos = Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
    )
    info = DataReader(dp, Topic(dp, "ros_discovery_info", ht.ParticipantEntitiesInfo_), qos=info_qos)
    ros_default = ht.ros_default_qos()
    js = DataReader(dp, Topic(dp, args.joint_states, ht.RosJointState_), qos=ros_default)
    pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    print(f"READY {os.getpid()}", flush=True)

    node = None
    seen = {}
    joint_names = None
    while True:
        for s in info.take(N=16):
            nodes = [
                {
                    "namespace": n.node_namespace,
                    "name": n.node_name,
                    "readers": [bytes(g.data).hex() for g in n.reader_gid_seq],
                    "writers": [bytes(g.data).hex() for g in n.writer_gid_seq],
                }
                for n in s.node_entities_info_seq
            ]
            if nodes:
                node = {"gid": bytes(s.gid.data).hex(), "nodes": nodes}
        for s in js.take(N=16):
            joint_names = len(s.name)
        for p in pubs.take(N=64):
            seen[p.key.bytes.hex()] = {
                "key": p.key.bytes.hex(),
                "participant": p.participant_key.bytes.hex(),
                "topic": p.topic_name,
                "type": p.type_name,
                "user_data": user_data(p.qos),
                "reliability": policy_name(p.qos, Policy.Reliability),
                "durability": policy_name(p.qos, Policy.Durability),
            }
        if node is not None and joint_names is not None:
            writers = set(w for n in node["nodes"] for w in n["writers"])
            mine = [e for e in seen.values() if e["participant"] == node["gid"]]
            # Every writer the node lists, and the context's ros_discovery_info writer.
            if writers <= set(e["key"] for e in mine) and any(e["topic"] == "ros_discovery_info" for e in mine):
                print("NODE " + json.dumps(node), flush=True)
                for e in mine:
                    print("PUB " + json.dumps(e), flush=True)
                print(f"JOINT_STATE {joint_names}", flush=True)
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
