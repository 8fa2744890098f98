#!/usr/bin/env python3
"""Readers and writers of handgate's status from other builds, for tests/tests/status_compat.rs
(docs/wire-types.md, "Status: frozen, and its extension"), with CycloneDDS Python 0.10.2:

* the FROZEN status layout (handgate_status_frozen.py): what a tool built against it reads of
  today's gateway, and what a gateway of that layout publishes;
* the status extension as this version declares it (handgate_types.py, `today`) and as a later
  version might (`later`: members appended to both structs and a new sequence), to show that a
  reader of one layout reads the other.

Modes (stdout protocol: flushed lines):
    encode --layout L --json J      prints HEX <bytes> of J serialised as layout L (no DDS)
    decode --layout L --hex H       prints JSON <sample> of bytes H read as layout L (no DDS)
    decode-status --hex H           prints JSON <sample> of bytes H read as the frozen status
    read-status --topic T           READY <pid>, then STATUS <json> per sample (frozen layout)
    write-status --topic T --json J READY <pid>, then writes J (frozen layout) every 50 ms
    read-ext --layout L --topic T   READY <pid>, then EXT <json> per sample
    write-ext --layout L --topic T --json J
                                    READY <pid>, then writes J as layout L every 50 ms
Non-finite floats appear in JSON as the strings "nan", "inf", "-inf". It exits on its own after
--timeout seconds (exit 3).
"""

import argparse
import dataclasses
import json
import math
import os
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cyclonedds.idl as idl  # noqa: E402
import cyclonedds.idl.annotations as annotate  # noqa: E402
import cyclonedds.idl.types as types  # noqa: E402
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

import handgate_status_frozen as frozen  # noqa: E402
import handgate_types as today  # noqa: E402


# A later version of the extension: members appended at the end of each struct, as
# docs/wire-types.md's rule allows. Same DDS type names.
@dataclass
@annotate.appendable
@annotate.autoid("sequential")
class LaterFrontStatus_(idl.IdlStruct, typename="handgate.msg.dds_.FrontStatus_"):
    name: str
    kind: str
    cmd_rate_hz: types.float32
    state_rate_hz: types.float32
    dropped_cmd: types.uint64
    owner: str
    latency_ms: types.sequence[types.float32]


@dataclass
@annotate.appendable
@annotate.autoid("sequential")
class LaterGatewayStatusExt_(idl.IdlStruct, typename="handgate.msg.dds_.GatewayStatusExt_"):
    version: types.uint32
    fronts: types.sequence[LaterFrontStatus_]
    refused_participants: types.uint32
    load: types.float32
    notes: types.sequence[str]


LAYOUTS = {
    "today": (today.GatewayStatusExt_, today.FrontStatus_),
    "later": (LaterGatewayStatusExt_, LaterFrontStatus_),
}


def plain(v):
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    return v


def to_json(sample):
    return json.dumps(plain(dataclasses.asdict(sample)))


def ext_from(layout, d):
    ext, front = LAYOUTS[layout]
    d = dict(d)
    d["fronts"] = [front(**f) for f in d.get("fronts", [])]
    return ext(**d)


def status_from(d):
    d = dict(d)
    d["devices"] = [frozen.DeviceStatus_(**x) for x in d.get("devices", [])]
    d["endpoints"] = [frozen.EndpointStatus_(**x) for x in d.get("endpoints", [])]
    d["diagnostics"] = [frozen.Diagnostic_(**x) for x in d.get("diagnostics", [])]
    return frozen.GatewayStatus_(**d)


def reliable():
    # What handgate's status writer and readers use: reliable, keep last 1.
    return Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mode")
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--topic")
    ap.add_argument("--layout", choices=sorted(LAYOUTS), default="today")
    ap.add_argument("--json")
    ap.add_argument("--hex")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()

    if args.mode == "encode":
        print("HEX " + ext_from(args.layout, json.loads(args.json)).serialize().hex(), flush=True)
        return
    if args.mode == "decode":
        ext, _ = LAYOUTS[args.layout]
        print("JSON " + to_json(ext.deserialize(bytes.fromhex(args.hex))), flush=True)
        return
    if args.mode == "decode-status":
        print("JSON " + to_json(frozen.GatewayStatus_.deserialize(bytes.fromhex(args.hex))), flush=True)
        return

    threading.Timer(args.timeout, lambda: os._exit(3)).start()
    dp = DomainParticipant(args.domain)
    if args.mode in ("read-status", "read-ext"):
        ty = frozen.GatewayStatus_ if args.mode == "read-status" else LAYOUTS[args.layout][0]
        tag = "STATUS" if args.mode == "read-status" else "EXT"
        r = DataReader(dp, Topic(dp, args.topic, ty), qos=reliable())
        print(f"READY {os.getpid()}", flush=True)
        while True:
            for m in r.take(N=16):
                print(f"{tag} {to_json(m)}", flush=True)
            time.sleep(0.02)
    elif args.mode in ("write-status", "write-ext"):
        d = json.loads(args.json)
        if args.mode == "write-status":
            sample = status_from(d)
        else:
            sample = ext_from(args.layout, d)
        w = DataWriter(dp, Topic(dp, args.topic, type(sample)), qos=reliable())
        print(f"READY {os.getpid()}", flush=True)
        while True:
            w.write(sample)
            time.sleep(0.05)
    else:
        raise SystemExit(f"unknown mode {args.mode}")


if __name__ == "__main__":
    main()
