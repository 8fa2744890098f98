#!/usr/bin/env python3
"""A real ROS 2 node (Jazzy rclpy over rmw_fastrtps_cpp, from the PyPI wheels) looking at handgate.

Run by tests/tests/ros2_real.rs, which sets the environment (ROS_DOMAIN_ID,
RMW_IMPLEMENTATION, AMENT_PREFIX_PATH, ...; docs/development.md "The Python environment").
Nothing here declares a ROS type by hand: every message class, QoS and graph query is rclpy's.

What it does:
- waits until node `<ns>/handgate` is in the ROS graph, with a publisher on the JointState
  topic, the `/diagnostics` and hardware_status topics, and (with --commands) a subscription
  on the command topic;
- subscribes to the JointState topic twice, with ROS 2's default QoS (reliable, keep-last 10)
  and with the sensor-data QoS (best effort, keep-last 5), and to `/diagnostics` (default QoS);
- reads the endpoints' type hashes, types and QoS as Jazzy's graph has them
  (`get_publishers_info_by_topic`, `get_subscriptions_info_by_topic`), and the hashes of
  rclpy's own message classes (its own endpoints on those topics, and the type description
  files the message packages install);
- with --commands and --targets: behaves as ros2_control's joint_state_topic_hardware_interface
  (docs/sources.md §10) while its joints are farther than its threshold from the command:
  every 10 ms one sensor_msgs/JointState on the command topic with every joint's name and
  position command (QoS `rclcpp::QoS(1)`: reliable, volatile, keep-last 1; stamped now;
  velocity and effort empty), once its state has been read from the JointState topic with the
  sensor-data QoS; until a default-QoS sample shows every joint within --tolerance of its
  target (or the deadline).

stdout protocol (one JSON document per line after the tag):
    READY <pid>
    NODES [[name, namespace], ...]
    PUBLISHERS [[topic, [types]], ...]       handgate's, by node
    SUBSCRIBERS [[topic, [types]], ...]
    ENDPOINTS {topic: [{kind, node, namespace, type, hash, reliability, durability}]}
    OWN_HASHES {type: hash}                  rclpy's own endpoints of each type
    GENERATED_HASHES {type: hash}            share/<pkg>/msg/<Type>.json, as installed, of GENERATED
    JOINT_STATES_DEFAULT {"name": [...], "position": [...]}
    JOINT_STATES_SENSOR_DATA {"name": [...], "position": [...]}
    DIAGNOSTICS [{"name", "hardware_id", "level", "message"}]
    START {joint: position}                  (--commands) the targets' joints before commanding
    REACHED {"positions": {joint: pos}, "published": n, "seconds": s}
       or NOT_REACHED {...}                  (--commands) the first default-QoS sample within
                                             tolerance of every target, or the last one seen
    DONE
It exits on its own after --timeout seconds (exit 3).
"""

import argparse
import json
import os
import sys
import threading
import time

import rclpy
from ament_index_python.packages import get_package_share_directory
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState

JOINT_STATE = "sensor_msgs/msg/JointState"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
# The types whose generated hashes are reported: the messages handgate publishes and takes,
# the types they reference, and the graph message's (ros_discovery_info).
GENERATED = (
    JOINT_STATE,
    "std_msgs/msg/Header",
    "builtin_interfaces/msg/Time",
    DIAGNOSTIC_ARRAY,
    "diagnostic_msgs/msg/DiagnosticStatus",
    "diagnostic_msgs/msg/KeyValue",
    "rmw_dds_common/msg/ParticipantEntitiesInfo",
    "rmw_dds_common/msg/NodeEntitiesInfo",
    "rmw_dds_common/msg/Gid",
)


def emit(tag, value):
    print(f"{tag} {json.dumps(value)}", flush=True)


def generated_hash(type_name):
    """The hash rosidl generated for `pkg/msg/Type`, from the type description file it installs."""
    pkg, _, name = type_name.split("/")
    path = os.path.join(get_package_share_directory(pkg), "msg", f"{name}.json")
    with open(path, encoding="utf-8") as f:
        hashes = json.load(f)["type_hashes"]
    return next(h["hash_string"] for h in hashes if h["type_name"] == type_name)


def endpoint(kind, info):
    q = info.qos_profile
    return {
        "kind": kind,
        "node": info.node_name,
        "namespace": info.node_namespace,
        "type": info.topic_type,
        "hash": str(info.topic_type_hash),
        "reliability": q.reliability.name,
        "durability": q.durability.name,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--namespace", default="/", help="handgate's node namespace")
    ap.add_argument("--joint-states", required=True, help="ROS name of the JointState topic")
    ap.add_argument("--hardware-status", required=True, help="ROS name of the hardware_status topic")
    ap.add_argument("--commands", help="ROS name of the command topic (the joint_state_command front)")
    ap.add_argument("--targets", help="JSON [[joint, position], ...]: command these (URDF names, radians)")
    ap.add_argument("--tolerance", type=float, default=0.03, help="rad per joint for REACHED")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()
    threading.Timer(args.timeout, lambda: os._exit(3)).start()
    deadline = time.monotonic() + args.timeout - 1.0

    rclpy.init()
    node = rclpy.create_node("ros2_real_peer")
    me = node.get_name()
    latest = {"default": None, "sensor_data": None, "diagnostics": None}
    fresh = []  # default-QoS samples, for the command phase

    def on_default(m):
        latest["default"] = m
        fresh.append(m)

    def on_sensor_data(m):
        latest["sensor_data"] = m

    def on_diagnostics(m):
        latest["diagnostics"] = m

    # rclpy's depth-only QoS is ROS 2's default: reliable, keep-last, volatile.
    node.create_subscription(JointState, args.joint_states, on_default, QoSProfile(depth=10))
    node.create_subscription(JointState, args.joint_states, on_sensor_data, qos_profile_sensor_data)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, QoSProfile(depth=10))
    commands = None
    if args.commands:
        commands = node.create_publisher(JointState, args.commands, QoSProfile(depth=1))
    print(f"READY {os.getpid()}", flush=True)

    def handgate_on(topic, infos):
        return any(i.node_name == "handgate" and i.node_namespace == args.namespace for i in infos(topic))

    def ready():
        if ("handgate", args.namespace) not in node.get_node_names_and_namespaces():
            return False
        if any(v is None for v in latest.values()):
            return False
        pubs = node.get_publishers_info_by_topic
        if not all(handgate_on(t, pubs) for t in (args.joint_states, "/diagnostics", args.hardware_status)):
            return False
        if commands is not None:
            if not handgate_on(args.commands, node.get_subscriptions_info_by_topic):
                return False
            if commands.get_subscription_count() < 1:  # matched
                return False
        return True

    while not ready():
        if time.monotonic() > deadline:
            print(f"NOT_READY {json.dumps({k: v is not None for k, v in latest.items()})}", flush=True)
            print(f"GRAPH {node.get_node_names_and_namespaces()}", flush=True)
            os._exit(4)
        rclpy.spin_once(node, timeout_sec=0.05)

    emit("NODES", [list(n) for n in node.get_node_names_and_namespaces()])
    emit("PUBLISHERS", node.get_publisher_names_and_types_by_node("handgate", args.namespace))
    emit("SUBSCRIBERS", node.get_subscriber_names_and_types_by_node("handgate", args.namespace))
    topics = [args.joint_states, "/diagnostics", args.hardware_status] + ([args.commands] if commands else [])
    eps = {}
    own = {}
    for t in topics:
        infos = [endpoint("publisher", i) for i in node.get_publishers_info_by_topic(t)]
        infos += [endpoint("subscription", i) for i in node.get_subscriptions_info_by_topic(t)]
        eps[t] = [e for e in infos if e["node"] != me]
        for e in infos:
            if e["node"] == me:
                own.setdefault(e["type"], set()).add(e["hash"])
    emit("ENDPOINTS", eps)
    emit("OWN_HASHES", {t: sorted(h)[0] if len(h) == 1 else sorted(h) for t, h in own.items()})
    emit("GENERATED_HASHES", {t: generated_hash(t) for t in GENERATED})
    for tag, key in (("JOINT_STATES_DEFAULT", "default"), ("JOINT_STATES_SENSOR_DATA", "sensor_data")):
        m = latest[key]
        emit(tag, {"name": list(m.name), "position": list(m.position)})
    emit(
        "DIAGNOSTICS",
        [
            {"name": s.name, "hardware_id": s.hardware_id, "level": int.from_bytes(s.level, "little"), "message": s.message}
            for s in latest["diagnostics"].status
        ],
    )

    if commands is not None and args.targets:
        command(node, commands, latest, fresh, json.loads(args.targets), args.tolerance, deadline)
    print("DONE", flush=True)
    os._exit(0)


def command(node, commands, latest, fresh, targets, tolerance, deadline):
    """The plugin's control loop at 100 Hz: read the sensor-data state, write every joint's
    position command; ends when a default-QoS sample has every joint within `tolerance`."""
    names = [n for n, _ in targets]
    want = dict(targets)

    def positions(m):
        by = dict(zip(m.name, m.position))
        return {n: by.get(n) for n in names}

    emit("START", positions(latest["sensor_data"]))
    published = 0

    def cycle():
        nonlocal published
        # read(): the plugin needs a state for its joints before the controllers run.
        if latest["sensor_data"] is None:
            return
        msg = JointState()
        msg.header.stamp = node.get_clock().now().to_msg()
        msg.name = names
        msg.position = [float(want[n]) for n in names]
        commands.publish(msg)
        published += 1

    start = time.monotonic()
    timer = node.create_timer(0.01, cycle)
    fresh.clear()
    last = None
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
        while fresh:
            last = positions(fresh.pop(0))
            if all(p is not None and abs(p - want[n]) <= tolerance for n, p in last.items()):
                node.destroy_timer(timer)
                emit("REACHED", {"positions": last, "published": published, "seconds": time.monotonic() - start})
                return
    node.destroy_timer(timer)
    emit("NOT_REACHED", {"positions": last, "published": published, "seconds": time.monotonic() - start})


if __name__ == "__main__":
    try:
        main()
    except Exception:  # the timer thread would keep the process alive until the timeout
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        os._exit(2)
