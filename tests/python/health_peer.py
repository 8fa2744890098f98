#!/usr/bin/env python3
"""ROS 2's view of handgate's health messages, with CycloneDDS Python (no ROS installation):
`/diagnostics` as `diagnostic_msgs::msg::dds_::DiagnosticArray_` and `<ns>/hardware_status` as
`control_msgs::msg::dds_::HardwareStatus_` (control_msgs 6.8.0), read with ROS 2's default QoS
(reliable, volatile, keep-last 10) and type declarations of their own (handgate_types.py).

Run by tests/tests/health_messages.rs. By hand, against a running gateway:
    .venv/bin/python tests/python/health_peer.py --domain 1 --hardware-status rt/hardware_status

stdout protocol (flushed lines):
    READY <pid>
    DIAG <json>   one per DiagnosticArray sample: {"stamp": [sec, nanosec], "status":
                  [{"level", "name", "message", "hardware_id", "values": {key: value}}]}
    HW <json>     one per HardwareStatus sample: {"stamp", "hardware_id", "devices":
                  [{"device_id", "health", "errors", "mode", "power", "connectivity", "model",
                    "details": {key: value}, "canopen", "ethercat", "vda5050"}]}
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

from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

import handgate_types as ht  # noqa: E402


def stamp(h):
    return [h.stamp.sec, h.stamp.nanosec]


def diag(m):
    return {
        "stamp": stamp(m.header),
        "status": [
            {
                "level": s.level,
                "name": s.name,
                "message": s.message,
                "hardware_id": s.hardware_id,
                "values": {kv.key: kv.value for kv in s.values},
            }
            for s in m.status
        ],
    }


def hw(m):
    devices = []
    for d in m.hardware_device_states:
        g = d.hardware_status[0] if d.hardware_status else None
        devices.append({
            "device_id": d.device_id,
            "generic_states": len(d.hardware_status),
            "health": g and g.health_status,
            "errors": g and list(g.error_domain),
            "mode": g and g.operational_mode,
            "power": g and g.power_state,
            "connectivity": g and g.connectivity_status,
            "model": g and g.model,
            "details": g and {kv.key: kv.value for kv in g.state_details},
            "canopen": len(d.canopen_states),
            "ethercat": len(d.ethercat_states),
            "vda5050": len(d.vda5050_states),
        })
    return {"stamp": stamp(m.header), "hardware_id": m.hardware_id, "devices": devices}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--hardware-status", default="rt/hardware_status",
                    help="DDS topic of the HardwareStatus writer")
    ap.add_argument("--diagnostics", default="rt/diagnostics")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()
    threading.Timer(args.timeout, lambda: os._exit(3)).start()

    dp = DomainParticipant(args.domain)
    ros_default = ht.ros_default_qos()
    readers = [
        ("DIAG", DataReader(dp, Topic(dp, args.diagnostics, ht.DiagnosticArray_), qos=ros_default), diag),
        ("HW", DataReader(dp, Topic(dp, args.hardware_status, ht.HardwareStatus_), qos=ros_default), hw),
    ]
    print(f"READY {os.getpid()}", flush=True)
    while True:
        for tag, r, render in readers:
            for m in r.take(N=16):
                print(f"{tag} {json.dumps(render(m))}", flush=True)
        time.sleep(0.02)


if __name__ == "__main__":
    main()
