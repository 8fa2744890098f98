#!/usr/bin/env python3
"""A Foxglove WebSocket protocol client (foxglove.websocket.v1, the ws-protocol spec) written
against the protocol spec alone, and a CDR decoder written by hand: the peer of
tests/tests/foxglove.rs.

It offers the subprotocols `foxglove.sdk.v1` and `foxglove.websocket.v1`: the Foxglove SDK's
server (the foxglove crate handgate uses, like foxglove_bridge 3.x) accepts only the first,
Foxglove's new name for the same v1 protocol, and refuses a client offering only the second
(HTTP 400). Which one the server chose is printed.

    foxglove_client.py URL TOPIC [TOPIC ...] [--seconds N] [--quiet]
                       [--as-host NAME] [--origin ORIGIN] [--try-write TOPIC]
                       [--subprotocols NAME[,NAME...]]

TOPIC `*` subscribes every advertised channel. `--quiet` (the benchmark's viewer,
bench/dashboard_cost.py): no MSG lines; `READY` at the first message, `COUNT n` at the end.
`--as-host NAME`: the request names NAME (and URL's port) in `Host`, as a browser does for a
page of a domain rebound to the server's address; it still connects to URL's address.
`--origin ORIGIN`: the `Origin` such a page sends. `--try-write TOPIC`: once the channels are
advertised, try every way the protocol has to send the server something: advertise a client
channel on TOPIC and publish a message on it, set a parameter, call a service; prints
`WRITE_TRIED`, then the server's answers as STATUS / SERVICE_FAILURE lines.
`--subprotocols`: offer these names instead (comma-separated, in order; an empty value offers
none), as a given viewer release does; the handshake's outcome is the HANDSHAKE line.

It connects with the subprotocol, reads serverInfo and the advertised channels, subscribes the
channels of the given topics and decodes each message. Prints one line per event:

    HANDSHAKE {"offered": [...], "status": HTTP status (101 or the refusal's), "chosen": ...}
    SERVERINFO {"name": ..., "capabilities": [...], "subprotocol": ...}
    CHANNELS [{"id", "topic", "encoding", "schemaName", "schemaEncoding", "schema"}, ...]
    SUBSCRIBED {"TOPIC": subscription id, ...}
    MSG {"topic": ..., "time": ns, "bytes": payload size, ...the decoded fields}
    STATUS {the server's status message}      SERVICE_FAILURE {its serviceCallFailure}
    ERROR text

Decoded: sensor_msgs/msg/JointState (stamp, frame_id, name, position, velocity, effort) and
unitree_hg/msg/HandState (motors, q of each motor, press sensors, bytes parsed), both as
little-endian CDR with its 4-byte encapsulation header. Exits after --seconds (default 60) or
when the server closes the connection.
"""
import asyncio
import json
import struct
import sys
import urllib.parse

import websockets

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
OP_MESSAGE_DATA = 0x01
# Client to server binary opcodes (ws-protocol spec).
OP_CLIENT_MESSAGE_DATA = 0x01
OP_SERVICE_CALL_REQUEST = 0x02


class Cdr:
    """Little-endian CDR reader; alignment counts from the end of the encapsulation header."""

    def __init__(self, data):
        if len(data) < 4:
            raise ValueError("shorter than the encapsulation header")
        # Representation id: 0x0001 is CDR little endian (plain, not parameter lists).
        if data[0:2] != b"\x00\x01":
            raise ValueError(f"not CDR_LE: header {data[0:4].hex()}")
        self.body = data[4:]
        self.pos = 0

    def align(self, n):
        self.pos += (-self.pos) % n

    def take(self, fmt, size):
        self.align(size)
        if self.pos + size > len(self.body):
            raise ValueError(f"read past the end at {self.pos}")
        (v,) = struct.unpack_from("<" + fmt, self.body, self.pos)
        self.pos += size
        return v

    def u8(self):
        return self.take("B", 1)

    def i16(self):
        return self.take("h", 2)

    def u32(self):
        return self.take("I", 4)

    def i32(self):
        return self.take("i", 4)

    def f32(self):
        return self.take("f", 4)

    def f64(self):
        return self.take("d", 8)

    def string(self):
        n = self.u32()  # length including the terminating NUL
        if n == 0 or self.pos + n > len(self.body):
            raise ValueError(f"bad string length {n} at {self.pos}")
        raw = self.body[self.pos : self.pos + n]
        self.pos += n
        if raw[-1] != 0:
            raise ValueError("string without its NUL")
        return raw[:-1].decode("utf-8")

    def seq(self, item):
        return [item() for _ in range(self.u32())]

    def left(self):
        return len(self.body) - self.pos


def joint_state(c):
    stamp = [c.i32(), c.u32()]
    frame_id = c.string()
    return {
        "stamp": stamp,
        "frame_id": frame_id,
        "name": c.seq(c.string),
        "position": c.seq(c.f64),
        "velocity": c.seq(c.f64),
        "effort": c.seq(c.f64),
    }


def hg_hand_state(c):
    def motor():
        m = {"mode": c.u8(), "q": c.f32(), "dq": c.f32(), "ddq": c.f32(), "tau_est": c.f32()}
        m["temperature"] = [c.i16(), c.i16()]
        m["vol"] = c.f32()
        m["sensor"] = [c.u32(), c.u32()]
        m["motorstate"] = c.u32()
        m["reserve"] = [c.u32() for _ in range(4)]
        return m

    def press():
        p = {"pressure": [c.f32() for _ in range(12)], "temperature": [c.f32() for _ in range(12)]}
        p["lost"], p["reserve"] = c.u32(), c.u32()
        return p

    motors = c.seq(motor)
    presses = c.seq(press)
    imu = {
        "quaternion": [c.f32() for _ in range(4)],
        "gyroscope": [c.f32() for _ in range(3)],
        "accelerometer": [c.f32() for _ in range(3)],
        "rpy": [c.f32() for _ in range(3)],
        "temperature": c.i16(),
    }
    power = [c.f32() for _ in range(4)]  # power_v, power_a, system_v, device_v
    error = [c.u32(), c.u32()]
    reserve = [c.u32(), c.u32()]
    return {
        "motors": len(motors),
        "q": [m["q"] for m in motors],
        "press": len(presses),
        "imu_quaternion": imu["quaternion"],
        "power": power,
        "error": error,
        "reserve": reserve,
    }


DECODERS = {
    "sensor_msgs/msg/JointState": joint_state,
    "unitree_hg/msg/HandState": hg_hand_state,
}


def decode(channel, payload):
    out = {"topic": channel["topic"], "bytes": len(payload)}
    decoder = DECODERS.get(channel["schemaName"])
    if decoder is None:
        return out
    c = Cdr(payload)
    out.update(decoder(c))
    # Everything the schema describes, and nothing more, up to the alignment padding a writer
    # may add at the end.
    out["parsed"] = c.pos
    out["trailing"] = c.left()
    return out


def emit(kind, value):
    print(kind, json.dumps(value, separators=(",", ":")), flush=True)


QUIET = {"on": False, "count": 0}
OPTS = {"as_host": None, "origin": None, "try_write": None, "subprotocols": None}


async def try_write(ws, topic):
    """Every way a client may send the server data: a client channel and a message on it, a
    parameter, a service call."""
    ch = {"id": 1, "topic": topic, "encoding": "cdr", "schemaName": "unitree_hg/msg/HandCmd"}
    await ws.send(json.dumps({"op": "advertise", "channels": [ch]}))
    # CDR_LE encapsulation header and a few zero bytes.
    await ws.send(struct.pack("<BI", OP_CLIENT_MESSAGE_DATA, 1) + b"\x00\x01\x00\x00" + bytes(8))
    await ws.send(json.dumps({"op": "setParameters", "parameters": [{"name": "closure", "value": 1.0}]}))
    enc = b"cdr"
    await ws.send(struct.pack("<BIII", OP_SERVICE_CALL_REQUEST, 1, 1, len(enc)) + enc + bytes(4))
    print("WRITE_TRIED", flush=True)


async def run(url, topics):
    kwargs = {}
    if OPTS["as_host"]:
        # Connect to URL's address while the request names another host.
        target = urllib.parse.urlsplit(url)
        kwargs.update(host=target.hostname, port=target.port, proxy=None)
        url = f"ws://{OPTS['as_host']}:{target.port}"
    if OPTS["origin"]:
        kwargs["origin"] = OPTS["origin"]
    offered = SUBPROTOCOLS if OPTS["subprotocols"] is None else [s for s in OPTS["subprotocols"].split(",") if s]
    try:
        conn = await websockets.connect(url, subprotocols=offered or None, max_size=None, **kwargs)
    except websockets.exceptions.InvalidStatus as e:
        emit("HANDSHAKE", {"offered": offered, "status": e.response.status_code, "chosen": None})
        return None
    emit("HANDSHAKE", {"offered": offered, "status": 101, "chosen": conn.subprotocol})
    async with conn as ws:
        subscribed = {}  # subscription id -> advertised channel
        info = None
        async for frame in ws:
            if isinstance(frame, str):
                msg = json.loads(frame)
                op = msg.get("op")
                if op == "serverInfo":
                    info = msg
                    emit(
                        "SERVERINFO",
                        {
                            "name": msg.get("name"),
                            "capabilities": msg.get("capabilities"),
                            "subprotocol": ws.subprotocol,
                        },
                    )
                elif op == "advertise":
                    if info is None:
                        emit("ERROR", "advertise before serverInfo")
                    emit(
                        "CHANNELS",
                        [
                            {k: ch.get(k) for k in ("id", "topic", "encoding", "schemaName", "schemaEncoding", "schema")}
                            for ch in msg["channels"]
                        ],
                    )
                    subs = []
                    for ch in msg["channels"]:
                        if ch["topic"] in topics or "*" in topics:
                            sid = len(subscribed) + 1
                            subscribed[sid] = ch
                            subs.append({"id": sid, "channelId": ch["id"]})
                    if subs:
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                        emit("SUBSCRIBED", {ch["topic"]: sid for sid, ch in subscribed.items()})
                    if OPTS["try_write"]:
                        topic, OPTS["try_write"] = OPTS["try_write"], None
                        await try_write(ws, topic)
                elif op == "status":
                    emit("STATUS", msg)
                elif op == "serviceCallFailure":
                    emit("SERVICE_FAILURE", msg)
            else:
                if len(frame) < 13 or frame[0] != OP_MESSAGE_DATA:
                    continue
                sid, time_ns = struct.unpack_from("<IQ", frame, 1)
                channel = subscribed.get(sid)
                if QUIET["on"] and channel is not None:
                    QUIET["count"] += 1
                    if QUIET["count"] == 1:
                        print("READY", flush=True)
                    continue
                if channel is None:
                    emit("ERROR", f"message data for unknown subscription {sid}")
                    continue
                try:
                    out = decode(channel, frame[13:])
                except ValueError as e:
                    emit("ERROR", f"{channel['topic']}: {e}")
                    continue
                out["time"] = time_ns
                emit("MSG", out)
    return None


def main():
    args = sys.argv[1:]
    seconds = 60.0
    if "--seconds" in args:
        i = args.index("--seconds")
        seconds = float(args[i + 1])
        del args[i : i + 2]
    if "--quiet" in args:
        args.remove("--quiet")
        QUIET["on"] = True
    for opt in ("--as-host", "--origin", "--try-write", "--subprotocols"):
        if opt in args:
            i = args.index(opt)
            OPTS[opt[2:].replace("-", "_")] = args[i + 1]
            del args[i : i + 2]
    url, topics = args[0], set(args[1:])
    try:
        asyncio.run(asyncio.wait_for(run(url, topics), seconds))
    except asyncio.TimeoutError:
        pass
    except (OSError, websockets.exceptions.WebSocketException) as e:
        emit("ERROR", f"{type(e).__name__}: {e}")
    if QUIET["on"]:
        print("COUNT", QUIET["count"], flush=True)


if __name__ == "__main__":
    main()
