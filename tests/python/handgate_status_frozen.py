"""FROZEN: handgate's status types as they were when `rt/handgate/status` was frozen (issue #37),
declared for CycloneDDS Python 0.10.2. NEVER EDIT THIS FILE.

This is the reader every robot's tools built against that layout keep using: handgate promises
that such a reader reads every field of every later gateway's `rt/handgate/status`
(docs/wire-types.md, "Status: frozen, and its extension"). tests/tests/status_compat.rs reads
the running gateway's status with these classes (status_compat_peer.py) and publishes them as
an old gateway would. New status fields go into the extension (`GatewayStatusExt_`,
handgate_types.py), never here and never into idl/handgate.idl's GatewayStatus_/DeviceStatus_.
"""

from dataclasses import dataclass

import cyclonedds.idl as idl
import cyclonedds.idl.annotations as annotate
import cyclonedds.idl.types as types


@dataclass
@annotate.final
@annotate.autoid("sequential")
class DeviceStatus_(idl.IdlStruct, typename="handgate.msg.dds_.DeviceStatus_"):
    device: str
    kind: str
    backend: str
    freshness: types.uint8
    safe: bool
    cmd_rate_hz: types.float32
    state_rate_hz: types.float32
    crc_errors: types.uint64
    bad_input: types.uint64
    watchdog_trips: types.uint64
    reconnects: types.uint64
    missed_cycles: types.uint64
    age_ms: types.float32
    foreign_cmd: types.uint64
    duplicate_cmd: types.uint64
    reordered_cmd: types.uint64
    late_cmd: types.uint64
    owner: str
    not_allowed_cmd: types.uint64
    motion: types.uint8
    motion_joint: str
    tracking_error: types.float32
    faults: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class EndpointStatus_(idl.IdlStruct, typename="handgate.msg.dds_.EndpointStatus_"):
    owner: str
    topic: str
    role: str
    matched: types.uint32
    who: types.sequence[str]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class Diagnostic_(idl.IdlStruct, typename="handgate.msg.dds_.Diagnostic_"):
    owner: str
    topic: str
    kind: str
    detail: str
    fix: str


@dataclass
@annotate.final
@annotate.autoid("sequential")
class GatewayStatus_(idl.IdlStruct, typename="handgate.msg.dds_.GatewayStatus_"):
    profile: str
    uptime_ms: types.uint64
    devices: types.sequence[DeviceStatus_]
    endpoints: types.sequence[EndpointStatus_]
    diagnostics: types.sequence[Diagnostic_]
    record_messages: types.uint64
    record_dropped: types.uint64
    domain: types.uint32
    interface: str
    export_domain: types.uint32
    export_interface: str
    namespace: str
    host: str
