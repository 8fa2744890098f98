#!/usr/bin/env python3
"""The measuring half of the two-site Zenoh run (`scripts/zenoh-sites.sh --measure`, run by
`make fleet`; docs/benchmarks.md "Sites over Zenoh", docs/deployment.md "Sites over Zenoh").
scripts/zenoh-sites.sh starts each piece in the site it belongs to; this file only measures.

    latency     an official-SDK (unitree_sdk2py) Dex3 client that streams commands, each with a
                tag of its own in HandCmd_.reserve[0], and times each until the hand's state
                reflects it (below)
    observe     at the robot site: when the hand's state first shows each command tag, and how far
                its joints moved meanwhile
    blind       an operator-site client that streams tagged Dex3 commands without waiting for any
                state (the negative tests: a site the robot refuses never sees a state)
    echo-server / echo-client
                TCP round trips across the link itself, at the same rate as the commands
    cpu         CPU seconds (utime + stime, /proc/PID/stat) of processes, now
    metrics     the gateway's per-device counters, from its /metrics
    summarize   the run's figures, from its logs (JSON)
    report      docs/benchmarks.md's section from those figures (--into: replace or add it)

Latency of a command: from the client's write of command k (tag base + k, tags increasing by
one) until the first state sample the client receives whose HandState_.reserve[0] is at least
that tag, i.e. the first state that reflects this command or a newer one (the Dex3 front echoes
the tag of the last command applied, docs/fronts.md "Dex3 front specifics"). Both times are
taken by the client's own clock (time.monotonic()), so the figure is a round trip: command to
the robot, the state back. A client that streams faster than the device applies commands sees
some tags superseded rather than echoed; they count at the first state that reflects a newer
one, which is when the hand's state shows the client's intent to have reached it. How many were
echoed exactly is reported too.

stdout (flushed lines) of latency:
    READY               the hand's state was seen
    ECHOED              the state reflected one of this client's commands (the stream does
                        not wait for it: a pause would trip a watchdog front)
    RESULT <json>       {"count", "reflected", "exact", "median_ms", "p99_ms", ...}
    DONE
latency stops after --count commands, or on SIGTERM (then it writes what it has). observe
prints READY at the first state and writes its file on SIGTERM.
"""

import argparse
import datetime
import json
import os
import re
import signal
import socket
import statistics
import struct
import sys
import threading
import time
import urllib.request

INDEX_0 = 5
TICK = os.sysconf("SC_CLK_TCK")
SECTION = "## 8. Sites over Zenoh"


def quantile(sorted_values, q):
    """The nearest-rank quantile q (0..1) of sorted values (None when empty)."""
    if not sorted_values:
        return None
    k = max(0, min(len(sorted_values) - 1, int(round(q * len(sorted_values) + 0.5)) - 1))
    return sorted_values[k]


def describe(values_ms):
    v = sorted(values_ms)
    if not v:
        return {"n": 0}
    return {
        "n": len(v),
        "median_ms": statistics.median(v),
        "p90_ms": quantile(v, 0.90),
        "p99_ms": quantile(v, 0.99),
        "max_ms": v[-1],
        "min_ms": v[0],
    }


def stop_on_term():
    """A flag set by SIGTERM or SIGINT."""
    flag = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: flag.set())
    signal.signal(signal.SIGINT, lambda *_: flag.set())
    return flag


def dds(domain, interface):
    from unitree_sdk2py.core.channel import ChannelFactoryInitialize

    ChannelFactoryInitialize(domain, interface)


def quit_now(code):
    """Exits without the interpreter's teardown: the results are written, and the Python
    CycloneDDS binding's teardown at exit now and then ends in SIGSEGV (docs/development.md's
    known flake), which would fail a run whose measurement is complete."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def cmd_latency(a):
    from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_, HandState_

    stop = stop_on_term()
    dds(a.domain, a.interface)
    n = a.count
    writes = [None] * n  # monotonic write time of command k (tag base + 1 + k)
    writes_wall = [None] * n
    reflected = [None] * n  # monotonic time of the first state reflecting it
    exact = [False] * n
    lock = threading.Lock()
    seen = {"next": 0, "q": None, "echoed": threading.Event(), "state": threading.Event()}

    def on_state(msg):
        now = time.monotonic()
        tag = int(msg.reserve[0])
        with lock:
            if seen["q"] is None:
                seen["q"] = [float(msg.motor_state[i].q) for i in range(7)]
                seen["state"].set()
            k = tag - a.tag_base - 1
            if k < 0 or k >= n:
                return
            while seen["next"] <= k and writes[seen["next"]] is not None:
                i = seen["next"]
                reflected[i] = now
                exact[i] = i == k
                seen["next"] += 1
            if not seen["echoed"].is_set():
                seen["echoed"].set()
                print("ECHOED", flush=True)

    sub = ChannelSubscriber(f"rt/dex3/{a.side}/state", HandState_)
    sub.Init(on_state, 0)
    pub = ChannelPublisher(f"rt/dex3/{a.side}/cmd", HandCmd_)
    pub.Init()
    if not seen["state"].wait(a.timeout):
        print("RESULT " + json.dumps({"error": f"no state on rt/dex3/{a.side}/state within {a.timeout} s"}), flush=True)
        return 1
    print("READY", flush=True)

    cmd = unitree_hg_msg_dds__HandCmd_()
    with lock:
        hold = list(seen["q"])
    for i, m in enumerate(cmd.motor_cmd):
        # xr_teleoperate's Dex3 command: RIS mode 0x10|i (FOC, no timeout bit), kp 1.5, kd 0.2;
        # every joint held where it was first measured.
        m.mode = 0x10 | i
        m.q = hold[i]
        m.kp, m.kd = 1.5, 0.2
    period = 1.0 / a.rate
    start = time.monotonic()
    sent = 0
    for k in range(n):
        if stop.is_set():
            break
        due = start + k * period
        wait = due - time.monotonic()
        if wait > 0:
            stop.wait(wait)  # the stream's own pace, not a readiness wait
            if stop.is_set():
                break
        cmd.reserve[0] = a.tag_base + 1 + k
        with lock:
            writes[k] = time.monotonic()
            writes_wall[k] = time.time()
        pub.Write(cmd)
        sent += 1
    # The last commands' states are still on their way: wait for them, with a deadline.
    end = time.monotonic() + a.drain
    while time.monotonic() < end and not stop.is_set():
        with lock:
            if seen["next"] >= sent:
                break
        time.sleep(0.01)
    with lock:
        lat = [(reflected[k] - writes[k]) * 1000.0 for k in range(sent) if reflected[k] is not None]
        out = {
            "side": a.side,
            "rate_hz": a.rate,
            "tag_base": a.tag_base,
            "sent": sent,
            "reflected": len(lat),
            "exact": sum(exact[:sent]),
            "write_wall": writes_wall[:sent],
            "latency_ms": [None if reflected[k] is None else round((reflected[k] - writes[k]) * 1000.0, 3) for k in range(sent)],
        }
    out.update(describe(lat))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(out, f)
    summary = {k: v for k, v in out.items() if k not in ("write_wall", "latency_ms")}
    print("RESULT " + json.dumps(summary), flush=True)
    print("DONE", flush=True)
    quit_now(0 if sent > 0 and len(lat) > 0 else 1)


def cmd_observe(a):
    from unitree_sdk2py.core.channel import ChannelSubscriber
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandState_

    stop = stop_on_term()
    dds(a.domain, a.interface)
    changes = []  # [wall, monotonic, tag] whenever the echoed tag changes
    lock = threading.Lock()
    first = threading.Event()
    q = {"first": None, "last": None, "moved": [0.0] * 7, "samples": 0}
    watch = {"shown": False, "moved": False}

    def on_state(msg):
        wall, mono = time.time(), time.monotonic()
        tag = int(msg.reserve[0])
        now_q = [float(msg.motor_state[i].q) for i in range(7)]
        with lock:
            if not changes or changes[-1][2] != tag:
                changes.append([wall, mono, tag])
            if q["first"] is None:
                q["first"] = now_q
            q["last"] = now_q
            q["samples"] += 1
            q["moved"] = [max(m, abs(x - f)) for m, x, f in zip(q["moved"], now_q, q["first"])]
            shown = a.watch_from is not None and tag >= a.watch_from and not watch["shown"]
            if shown:
                watch["shown"] = True
            moved = a.watch_move is not None and q["moved"][INDEX_0] >= a.watch_move and not watch["moved"]
            if moved:
                watch["moved"] = True
        first.set()
        if shown:
            print(f"SHOWN {tag}", flush=True)
        if moved:
            print(f"MOVED {now_q[INDEX_0]:.4f}", flush=True)

    sub = ChannelSubscriber(f"rt/dex3/{a.side}/state", HandState_)
    sub.Init(on_state, 0)
    if not first.wait(a.timeout):
        print(f"ERROR no state on rt/dex3/{a.side}/state within {a.timeout} s", flush=True)
        return 1
    with lock:
        print("READY " + json.dumps({"tag": changes[-1][2], "q": q["first"]}), flush=True)
    stop.wait()
    with lock:
        out = {
            "side": a.side,
            "changes": list(changes),
            "samples": q["samples"],
            "q_first": q["first"],
            "q_last": q["last"],
            "max_abs_move": q["moved"],
        }
    with open(a.out, "w") as f:
        json.dump(out, f)
    print(f"DONE {len(out['changes'])}", flush=True)
    quit_now(0)


def cmd_blind(a):
    """Streams Dex3 commands (tags tag_base + 1, + 2, ...; every joint's target from --q, index_0
    from --index0) at --rate until SIGTERM, never waiting for a state: a client at a site whose
    link the robot refuses sees none. Writes how many it sent."""
    from unitree_sdk2py.core.channel import ChannelPublisher
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__HandCmd_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import HandCmd_

    stop = stop_on_term()
    dds(a.domain, a.interface)
    pub = ChannelPublisher(f"rt/dex3/{a.side}/cmd", HandCmd_)
    pub.Init()
    cmd = unitree_hg_msg_dds__HandCmd_()
    for i, m in enumerate(cmd.motor_cmd):
        m.mode = 0x10 | i
        m.q = a.q[i]
        m.kp, m.kd = 1.5, 0.2
    cmd.motor_cmd[INDEX_0].q = a.index0
    print("STREAMING", flush=True)
    period = 1.0 / a.rate
    start = time.monotonic()
    sent = 0
    while not stop.is_set():
        wait = start + sent * period - time.monotonic()
        if wait > 0 and stop.wait(wait):  # the stream's own pace, not a readiness wait
            break
        cmd.reserve[0] = a.tag_base + 1 + sent
        pub.Write(cmd)
        sent += 1
    out = {"side": a.side, "tag_base": a.tag_base, "sent": sent, "rate_hz": a.rate, "index0": a.index0}
    with open(a.out, "w") as f:
        json.dump(out, f)
    print("RESULT " + json.dumps(out), flush=True)
    quit_now(0)


RECORD = struct.Struct("!Qd")  # sequence number, padding to 16 bytes


def cmd_judge(a):
    """One negative test (or the control) of the sites' identity: did the robot's hand take any
    of this site's commands, and how many refusals did the robot's zenohd count meanwhile."""
    obs = load(a.observe)
    blind = load(a.blind)
    lo, hi = blind["tag_base"] + 1, blind["tag_base"] + blind["sent"]
    shown = [t for _, _, t in obs["changes"] if lo <= t <= hi]
    moved = obs["max_abs_move"][INDEX_0]
    out = {
        "name": a.name,
        "what": a.what,
        "expect": a.expect,
        "sent": blind["sent"],
        "rate_hz": blind["rate_hz"],
        "tags_shown": len(shown),
        "index0_moved_rad": round(moved, 4),
        "index0_target": blind["index0"],
        "index0_first": obs["q_first"][INDEX_0],
        "index0_last": obs["q_last"][INDEX_0],
        "state_samples": obs["samples"],
        "refusals": {k: int(v) for k, v in (x.split("=", 1) for x in a.refusals)},
        "refused_detail": [x for x in a.detail.split(";") if x],
    }
    if a.expect == "refused":
        # Not moved, no command of this site applied, and refused by the guard named.
        ok = not shown and moved < a.still_rad and out["refusals"].get(a.counted, 0) > 0
    else:
        # The control: moved, commands applied, nothing refused.
        ok = bool(shown) and moved >= a.moved_rad and sum(out["refusals"].values()) == 0
    out["counted"] = a.counted
    out["ok"] = ok
    with open(a.out, "w") as f:
        json.dump(out, f)
    print(("PASS " if ok else "FAIL ") + json.dumps(out), flush=True)
    return 0 if ok else 1


def cmd_echo_server(a):
    host, port = a.listen.rsplit(":", 1)
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind((host, int(port)))
    srv.listen(1)
    print("READY", flush=True)
    conn, _ = srv.accept()
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    while True:
        data = conn.recv(65536)
        if not data:
            break
        conn.sendall(data)
    print("DONE", flush=True)
    return 0


def cmd_echo_client(a):
    host, port = a.to.rsplit(":", 1)
    s = socket.create_connection((host, int(port)), timeout=a.timeout)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    s.settimeout(None)
    n = a.count
    sent_at = [None] * n
    back_at = [None] * n
    lock = threading.Lock()

    def reader():
        buf = b""
        got = 0
        while got < n:
            data = s.recv(65536)
            if not data:
                return
            now = time.monotonic()
            buf += data
            while len(buf) >= RECORD.size:
                seq, _ = RECORD.unpack(buf[: RECORD.size])
                buf = buf[RECORD.size:]
                with lock:
                    back_at[seq] = now
                got += 1

    t = threading.Thread(target=reader, daemon=True)
    t.start()
    period = 1.0 / a.rate
    start = time.monotonic()
    for k in range(n):
        wait = start + k * period - time.monotonic()
        if wait > 0:
            time.sleep(wait)  # the stream's own pace
        with lock:
            sent_at[k] = time.monotonic()
        s.sendall(RECORD.pack(k, 0.0))
    t.join(a.drain)
    s.close()
    with lock:
        rtt = [(back_at[k] - sent_at[k]) * 1000.0 for k in range(n) if back_at[k] is not None]
    out = {"sent": n, "returned": len(rtt), "rate_hz": a.rate, "rtt_ms": [round(x, 3) for x in rtt]}
    out.update(describe(rtt))
    with open(a.out, "w") as f:
        json.dump(out, f)
    print("RESULT " + json.dumps({k: v for k, v in out.items() if k != "rtt_ms"}), flush=True)
    return 0 if rtt else 1


def proc_cpu(pid):
    """(utime + stime in seconds, seconds since the process started)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # After the command name: fields 3.. of stat, so utime (14) and stime (15) are at 11 and 12,
    # starttime (22) at 19.
    cpu = (int(fields[11]) + int(fields[12])) / TICK
    with open("/proc/uptime") as f:
        up = float(f.read().split()[0])
    return cpu, up - int(fields[19]) / TICK


def cmd_cpu(a):
    out = {"monotonic": time.monotonic(), "procs": {}}
    for item in a.procs:
        name, pid = item.split("=", 1)
        cpu, age = proc_cpu(int(pid))
        out["procs"][name] = {"pid": int(pid), "cpu_s": cpu, "age_s": age}
    with open(a.out, "w") as f:
        json.dump(out, f)
    return 0


METRIC = re.compile(r'^handgate_device_([a-z_]+?)(?:_total)?\{device="([^"]+)"[^}]*\} (\S+)$')
COUNTERS = ("commands", "foreign_cmd", "duplicate_cmd", "reordered_cmd", "late_cmd", "watchdog_trips", "safe")


def read_metrics(url):
    text = urllib.request.urlopen(url.rstrip("/") + "/metrics", timeout=10).read().decode()
    out = {}
    for line in text.splitlines():
        m = METRIC.match(line)
        if m and m.group(1) in COUNTERS:
            out.setdefault(m.group(2), {})[m.group(1)] = float(m.group(3))
    return out


def cmd_metrics(a):
    out = {"wall": time.time(), "devices": read_metrics(a.url)}
    with open(a.out, "w") as f:
        json.dump(out, f)
    return 0


def load(path):
    with open(path) as f:
        return json.load(f)


def log_events(path, device):
    """(wall time, message) of the gateway's silence and resume lines for `device` (JSON log)."""
    out = []
    with open(path) as f:
        for line in f:
            if not line.startswith("{"):
                continue
            try:
                ev = json.loads(line)
            except ValueError:
                continue
            fields = ev.get("fields", {})
            msg = fields.get("message", "")
            if fields.get("device") != device:
                continue
            if msg.startswith("no command: moving the device to its silence action") or msg.startswith(
                "commands resumed after the silence action"
            ):
                ts = datetime.datetime.fromisoformat(ev["timestamp"].replace("Z", "+00:00")).timestamp()
                out.append((ts, msg))
    return out


def link_lines(path):
    """The shaped link's (or the script's) CUT/RESTORED wall times and its STATS."""
    cuts, restores, stats = [], [], None
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "CUT":
                cuts.append(float(parts[1]))
            elif parts[0] == "RESTORED":
                restores.append(float(parts[1]))
            elif parts[0] == "STATS":
                stats = json.loads(line[len("STATS "):])
    return cuts, restores, stats


def cpu_pct(a, b):
    dt = b["monotonic"] - a["monotonic"]
    return {
        name: round(100.0 * (b["procs"][name]["cpu_s"] - p["cpu_s"]) / dt, 2)
        for name, p in a["procs"].items()
        if name in b["procs"]
    }, dt


def cmd_summarize(a):
    d = a.logs
    j = lambda name: load(os.path.join(d, name))
    r = {
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "command": a.command,
        "uptime_before": a.uptime_before,
        "uptime_after": a.uptime_after,
        "nproc": os.cpu_count(),
        "kernel": os.uname().release,
        "shaped": a.shaped,
        "shape": a.shape,
        "domain": a.domain,
    }
    strip = lambda x, keys: {k: v for k, v in x.items() if k not in keys}
    direct = j("latency-direct.json")
    zenoh = j("latency-zenoh.json")
    echo = j("echo.json")
    r["latency"] = {
        "direct": strip(direct, ("write_wall",)),
        "zenoh": strip(zenoh, ("write_wall",)),
        "link_rtt": echo,
        "added_median_ms": zenoh["median_ms"] - direct["median_ms"],
        "added_p99_ms": zenoh["p99_ms"] - direct["p99_ms"],
    }
    pct, secs = cpu_pct(j("cpu-latency-start.json"), j("cpu-latency-end.json"))
    end = j("cpu-end.json")
    r["cpu"] = {
        "latency_phase": {"seconds": round(secs, 1), "pct": pct},
        "whole_run": {
            name: {"pct": round(100.0 * p["cpu_s"] / p["age_s"], 2), "seconds": round(p["age_s"], 1)}
            for name, p in end["procs"].items()
        },
    }
    final = j("metrics-final.json")["devices"]
    r["counters"] = final
    cuts, restores, stats = link_lines(os.path.join(d, "link.log"))
    r["link_stats"] = stats

    # The cut: the robot's right hand, silence = "watchdog".
    dev = a.cut_device
    before_stream = j("metrics-stream.json")["devices"][dev]
    before_cut = j("metrics-before-cut.json")["devices"][dev]
    after = j("metrics-after-cut.json")["devices"][dev]
    cut, restore = cuts[-1], restores[-1]
    events = log_events(os.path.join(d, "handgate.log"), dev)
    held = next((t for t, m in events if t >= cut and m.startswith("no command")), None)
    resumed = next((t for t, m in events if held is not None and t >= held and m.startswith("commands resumed")), None)
    stream = j("stream-cut.json")
    observed = j("observe-cut.json")["changes"]
    base = stream["tag_base"]
    write_wall = {base + 1 + k: w for k, w in enumerate(stream["write_wall"])}
    # Tags of this stream the robot's state showed after the restore, with when they were written.
    after_restore = [(w, t) for w, _, t in observed if w >= restore and t in write_wall]
    during_cut = [t for _, t in after_restore if cut <= write_wall[t] < restore]
    first = after_restore[0] if after_restore else None
    # The first command written after the restore that the state showed: the operator's present.
    current = next(((w, t) for w, t in after_restore if write_wall[t] >= restore), None)
    before = [w for w, _, t in observed if w < cut and t in write_wall]
    # Until the present is reached, the oldest command the hand was given.
    replayed = [w - write_wall[t] for w, t in after_restore if current is None or w <= current[0]]
    r["cut"] = {
        "device": dev,
        "cut_seconds": round(restore - cut, 3),
        "trips_streaming_before_cut": after_trips(before_stream, before_cut),
        "trips_cut_to_resumed": after_trips(before_cut, after),
        "held_after_cut_ms": None if held is None else round((held - cut) * 1000.0, 1),
        "resumed_after_restore_ms": None if resumed is None else round((resumed - restore) * 1000.0, 1),
        "first_applied_after_restore": None
        if first is None
        else {
            "after_restore_ms": round((first[0] - restore) * 1000.0, 1),
            "written_before_applied_ms": round((first[0] - write_wall[first[1]]) * 1000.0, 1),
            "written_during_cut": cut <= write_wall[first[1]] < restore,
        },
        "last_applied_before_cut_ms": round((before[-1] - cut) * 1000.0, 1) if before else None,
        "current_after_restore_ms": None if current is None else round((current[0] - restore) * 1000.0, 1),
        "oldest_applied_after_restore_ms": round(max(replayed) * 1000.0, 1) if replayed else None,
        "tags_written_during_cut_shown_after_restore": len(during_cut),
        "tags_written_during_cut": sum(1 for w in write_wall.values() if cut <= w < restore),
        "late_cmd_during_cut": after.get("late_cmd", 0) - before_cut.get("late_cmd", 0),
    }
    with open(os.path.join(d, "status.txt")) as f:
        r["status_text"] = f.read()
    # The identity tests (scripts/zenoh-sites.sh, identity_test): one file each.
    r["identity"] = [
        load(os.path.join(d, f"identity-{n}.json")) for n in "abcd" if os.path.exists(os.path.join(d, f"identity-{n}.json"))
    ]
    with open(a.out, "w") as f:
        json.dump(r, f, indent=1)
    print(json.dumps({k: v for k, v in r.items() if k not in ("latency", "status_text", "identity")}, indent=1))
    lat = r["latency"]
    print(
        f"latency: direct median {lat['direct']['median_ms']:.2f} ms p99 {lat['direct']['p99_ms']:.2f} ms; "
        f"zenoh median {lat['zenoh']['median_ms']:.1f} ms p99 {lat['zenoh']['p99_ms']:.1f} ms; "
        f"link TCP rtt median {echo['median_ms']:.1f} ms p99 {echo['p99_ms']:.1f} ms"
    )
    return 0


def after_trips(a, b):
    return b.get("watchdog_trips", 0) - a.get("watchdog_trips", 0)


def fmt(v, digits=1):
    return "–" if v is None else f"{v:.{digits}f}"


def report(r):
    lat = r["latency"]
    d, z, e = lat["direct"], lat["zenoh"], lat["link_rtt"]
    link = "the shaped link" if r["shaped"] else "a plain veth pair"
    out = ["", SECTION, ""]
    out.append(
        f"Run {r['date_utc']} UTC by `{r['command']}`, on {r['nproc']} cores (kernel {r['kernel']}); "
        f"`uptime` before: `{r['uptime_before']}`; after: `{r['uptime_after']}`. Two network namespaces "
        "joined only by one Zenoh link"
        + (", TLS 1.3 with mutual authentication and the robot's access control" if r.get("identity") else ", plain TCP")
        + " (zenohd and zenoh-plugin-dds 1.10.2 at each site, "
        "`profiles/zenoh/*.json5`; docs/deployment.md \"Sites over Zenoh\"), the robot site running "
        "`handgate run --profile profiles/zenoh/sites-robot.toml` (two emulated Dex3 hands, release build), "
        f"the operator site an official-SDK client (unitree_sdk2py); the link is {link}"
        + (f" (`{r['shape']}`, in user space: tests/python/shaped_link.py)" if r["shaped"] else "")
        + f", DDS domain {r['domain']}. Measured by `tests/python/sites_measure.py`."
    )
    out.append("")
    out.append("### Latency: a command to the state that reflects it")
    out.append("")
    out.append(
        f"The client streams Dex3 commands at {z['rate_hz']:.0f} Hz (xr_teleoperate's Dex3 rate), each "
        "tagged in `HandCmd_.reserve[0]`; a command's latency is the time from its write to the "
        "first `rt/dex3/left/state` sample the client receives that echoes its tag or a newer one "
        "(`HandState_.reserve[0]`, docs/fronts.md), both on the client's clock: a round trip. "
        "Baseline, in the same run: the same client and gateway with no Zenoh, the client in the "
        "robot's namespace on handgate's own network. The link's own TCP round trip, at the same "
        "rate (16-byte messages, `TCP_NODELAY`, no TLS), across the same link."
    )
    out.append("")
    out.append("| path | samples | median ms | p90 ms | p99 ms | max ms |")
    out.append("|---|---|---|---|---|---|")
    out.append(
        f"| direct (no Zenoh) | {d['n']} of {d['sent']} | {fmt(d['median_ms'], 2)} | {fmt(d['p90_ms'], 2)} | "
        f"{fmt(d['p99_ms'], 2)} | {fmt(d['max_ms'], 2)} |"
    )
    out.append(
        f"| across Zenoh, {'shaped' if r['shaped'] else 'plain'} link | {z['n']} of {z['sent']} | {fmt(z['median_ms'])} | "
        f"{fmt(z['p90_ms'])} | {fmt(z['p99_ms'])} | {fmt(z['max_ms'])} |"
    )
    out.append(
        f"| the link alone (TCP echo) | {e['n']} of {e['sent']} | {fmt(e['median_ms'])} | {fmt(e['p90_ms'])} | "
        f"{fmt(e['p99_ms'])} | {fmt(e['max_ms'])} |"
    )
    out.append("")
    out.append(
        f"Added by the sites (Zenoh path minus direct): **{lat['added_median_ms']:.1f} ms median, "
        f"{lat['added_p99_ms']:.1f} ms p99**; of it the link's own round trip is {e['median_ms']:.1f} ms "
        f"median, {e['p99_ms']:.1f} ms p99 (the rest: Zenoh, the two plugins' DDS hops, and the state "
        "crossing at 50 Hz, up to 20 ms older than on the robot). Echoed exactly (not superseded by a newer command before "
        f"a state showed it): {d['exact']} of {d['sent']} direct, {z['exact']} of {z['sent']} across Zenoh."
    )
    out.append("")
    out.append("### CPU")
    out.append("")
    cl = r["cpu"]["latency_phase"]
    out.append(
        f"utime + stime from `/proc/PID/stat`, % of one core: over the latency phase ({cl['seconds']:.0f} s, "
        "the client streaming to one hand at 100 Hz, both hands' states crossing to the operator at the "
        "robot config's 50 Hz) "
        "and over each process's whole life in the run."
        + (
            " The robot's zenohd checks every message against its access control and, in this run, "
            "logs each decision at trace level (to count the refusals below): both are in its figure."
            if r.get("identity")
            else ""
        )
    )
    out.append("")
    out.append("| process | latency phase % | whole run % (s) |")
    out.append("|---|---|---|")
    names = {
        "zenohd_robot": "zenohd + DDS plugin, robot site",
        "zenohd_operator": "zenohd + DDS plugin, operator site",
        "handgate": "handgate (two emulated Dex3 at 1 kHz)",
        "shaped_link": "shaped_link.py (the link, not part of a deployment)",
    }
    for k, label in names.items():
        w = r["cpu"]["whole_run"].get(k)
        if w is None:
            continue
        out.append(f"| {label} | {fmt(cl['pct'].get(k))} | {w['pct']:.1f} ({w['seconds']:.0f}) |")
    out.append("")
    out.append("### Duplicates, reorders, late commands")
    out.append("")
    out.append(
        "The gateway's counters at the end of the run (`/metrics`), per device (watchdog trips: every "
        "silence action of the run, one each time a client of the `silence = \"watchdog\"` front "
        "stopped or was cut off):"
    )
    out.append("")
    out.append("| device | commands | duplicate_cmd | reordered_cmd | late_cmd (max_command_age_ms = 100) | watchdog trips |")
    out.append("|---|---|---|---|---|---|")
    for dev, c in sorted(r["counters"].items()):
        out.append(
            f"| {dev} | {c.get('commands', 0):.0f} | {c.get('duplicate_cmd', 0):.0f} | {c.get('reordered_cmd', 0):.0f} | "
            f"{c.get('late_cmd', 0):.0f} | {c.get('watchdog_trips', 0):.0f} |"
        )
    s = r.get("link_stats")
    if s:
        out.append("")
        out.append("The link's own counts over the whole run (packets, each direction):")
        out.append("")
        out.append("| direction | read | lost | duplicated | sent early (reorder) | overtaken | cut |")
        out.append("|---|---|---|---|---|---|---|")
        names = {"zw-rb->zw-op": "robot → operator", "zw-op->zw-rb": "operator → robot"}
        for name, c in s.items():
            out.append(
                f"| {names.get(name, name)} | {c['read']} | {c['lost']} | {c['duplicated']} | {c['reorder_early']} | "
                f"{c['overtaken']} | {c.get('cut', 0)} |"
            )
    dropped = sum(c.get("duplicate_cmd", 0) + c.get("reordered_cmd", 0) + c.get("late_cmd", 0) for c in r["counters"].values())
    out.append("")
    out.append(
        f"Commands dropped by the gateway's ordering and age rules: {dropped:.0f}. The link's duplicates and "
        "reorders are of TCP segments: TCP delivers the byte stream once and in order, so Zenoh "
        "never sees them; and the robot-side plugin writes every command again with a DDS writer "
        "of its own, stamped with its own clock at that write, so the gateway sees one writer "
        "whose samples are in order and fresh, whatever the operator's client stamped "
        "(docs/fronts.md \"Commands in order\")."
    )
    c = r["cut"]
    out.append("")
    out.append(f"### A {c['cut_seconds']:.0f} s link cut")
    out.append("")
    f = c["first_applied_after_restore"]
    out.append(
        f"The client streams to the right hand (front `silence = \"watchdog\"`, the device's watchdog "
        f"200 ms, `hold`) when the link is cut both ways for {c['cut_seconds']:.2f} s "
        "(nothing delivered, as a cable pulled), then restored; the client streams on throughout. "
        "Times from the cut's and the restore's moments to the gateway's log lines (`no command: "
        "moving the device to its silence action`, `commands resumed after the silence action`) "
        "and to the robot's state showing the client's commands again (a subscriber at the robot "
        "site)."
    )
    out.append("")
    out.append("| | |")
    out.append("|---|---|")
    out.append(f"| watchdog trips while streaming, before the cut | {c['trips_streaming_before_cut']:.0f} |")
    out.append(f"| watchdog trips from the cut to the resumption | {c['trips_cut_to_resumed']:.0f} |")
    if c["last_applied_before_cut_ms"] is not None:
        out.append(f"| the last command applied before the cut | {-c['last_applied_before_cut_ms']:.0f} ms before it |")
    out.append(f"| the hand held (the silence action) | {fmt(c['held_after_cut_ms'], 0)} ms after the cut |")
    out.append(f"| commands applied again (the gateway's log) | {fmt(c['resumed_after_restore_ms'], 0)} ms after the restore |")
    if f:
        out.append(
            f"| the first command applied after the restore | written {f['written_before_applied_ms']:.0f} ms "
            f"before ({'during' if f['written_during_cut'] else 'not during'} the cut) |"
        )
    out.append(
        f"| the first command written after the restore, applied | {fmt(c['current_after_restore_ms'], 0)} ms after the restore |"
    )
    out.append(
        f"| the oldest command applied after the restore | {fmt(c['oldest_applied_after_restore_ms'], 0)} ms old |"
    )
    out.append(
        f"| commands written during the cut that the robot's state showed after the restore | "
        f"{c['tags_written_during_cut_shown_after_restore']} of {c['tags_written_during_cut']} |"
    )
    out.append(f"| counted late meanwhile (max_command_age_ms = 100) | {c['late_cmd_during_cut']:.0f} |")
    ids = r.get("identity") or []
    if ids:
        out.append("")
        out.append("### Identity: TLS and access control")
        out.append("")
        out.append(
            "The run's own keystore: one lab CA, the robot's zenohd `/robot` (its certificate naming "
            "10.77.0.2), the operator's `/operator`, a third lab identity `/student`; and a second "
            "CA that issues another `/operator`. After the measurements the operator's zenohd stops "
            "and each test is a zenohd of its own at the operator site, with an SDK client streaming "
            "tagged commands to the left hand through it at "
            f"{ids[0]['rate_hz']:.0f} Hz without waiting for any state; a subscriber at the robot site "
            "watches the hand's state (the tags it echoes, index_0's position). The refusals are "
            "counted in the robot's zenohd log: refused TLS handshakes, and puts on "
            "`rt/dex3/left/cmd` its `access_control` refused on arrival (trace level). Each test "
            "streams until the robot's zenohd has counted its refusal (two more refused handshakes "
            "once the test site's bridge had the commands; 100 refused puts), the control until the "
            "hand moved."
        )
        out.append("")
        out.append("| test | commands sent | shown in the hand's state | index_0 moved (rad) | refused handshakes | refused puts | result |")
        out.append("|---|---|---|---|---|---|---|")
        for t in ids:
            rf = t["refusals"]
            out.append(
                f"| {t['name']}. {t['what']} | {t['sent']} | {t['tags_shown']} | {t['index0_moved_rad']:.3f} | "
                f"{rf.get('tls_handshakes', 0)} | {rf.get('acl_puts', 0)} | "
                f"{'pass' if t['ok'] else 'FAIL'} ({'refused' if t['expect'] == 'refused' else 'moved'}) |"
            )
    out.append("")
    out.append("`handgate status --once` at the operator site, across the link, at the end:")
    out.append("")
    out.append("```")
    out.append(r["status_text"].rstrip("\n"))
    out.append("```")
    if "[foreign_writer]" in r["status_text"]:
        out.append("")
        out.append(
            "The `foreign_writer` diagnostic above is the robot-side zenohd: the plugin makes a DDS "
            "writer for every allowed topic that has a reader at its site, and the run's own "
            "subscriber at the robot site reads `rt/dex3/right/state` (docs/deployment.md \"Sites "
            "over Zenoh\")."
        )
    return "\n".join(out) + "\n"


def cmd_report(a):
    text = report(load(a.results))
    if not a.into:
        sys.stdout.write(text)
        return 0
    with open(a.into) as f:
        doc = f.read()
    # Replace this section (up to the next "## ") or add it before the closing "## Running".
    i = doc.find("\n" + SECTION + "\n")
    if i >= 0:
        j = doc.find("\n## ", i + 1)
        doc = doc[:i] + text + (doc[j:] if j >= 0 else "")
    else:
        j = doc.find("\n## Running")
        doc = doc + text if j < 0 else doc[:j] + text + doc[j:]
    with open(a.into, "w") as f:
        f.write(doc)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)

    p = sub.add_parser("latency")
    p.add_argument("--domain", type=int, required=True)
    p.add_argument("--interface", default=None)
    p.add_argument("--side", choices=["left", "right"], default="left")
    p.add_argument("--count", type=int, default=1000)
    p.add_argument("--rate", type=float, default=100.0)
    p.add_argument("--tag-base", type=int, required=True)
    p.add_argument("--timeout", type=float, default=60.0)
    p.add_argument("--drain", type=float, default=5.0, help="seconds to wait for the last states")
    p.add_argument("--out")
    p.set_defaults(fn=cmd_latency)

    p = sub.add_parser("observe")
    p.add_argument("--domain", type=int, required=True)
    p.add_argument("--interface", default=None)
    p.add_argument("--side", choices=["left", "right"], default="right")
    p.add_argument("--timeout", type=float, default=60.0)
    p.add_argument("--watch-from", type=int, default=None, help="print SHOWN once a state echoes a tag >= this")
    p.add_argument("--watch-move", type=float, default=None, help="print MOVED once index_0 moved this far (rad)")
    p.add_argument("--out", required=True)
    p.set_defaults(fn=cmd_observe)

    p = sub.add_parser("blind")
    p.add_argument("--domain", type=int, required=True)
    p.add_argument("--interface", default=None)
    p.add_argument("--side", choices=["left", "right"], default="left")
    p.add_argument("--rate", type=float, default=100.0)
    p.add_argument("--tag-base", type=int, required=True)
    p.add_argument("--q", type=lambda v: [float(x) for x in v.split(",")], required=True, help="7 joint targets, comma-separated")
    p.add_argument("--index0", type=float, required=True, help="index_0's target")
    p.add_argument("--out", required=True)
    p.set_defaults(fn=cmd_blind)

    p = sub.add_parser("judge")
    p.add_argument("--name", required=True)
    p.add_argument("--what", required=True)
    p.add_argument("--expect", choices=["refused", "moved"], required=True)
    p.add_argument("--observe", required=True)
    p.add_argument("--blind", required=True)
    p.add_argument("--refusals", nargs="*", default=[], help="KIND=COUNT, counted at the robot's zenohd")
    p.add_argument("--counted", default=None, help="refused: the KIND that must have counted this site's attempt")
    p.add_argument("--detail", default="", help="what the robot's zenohd refused meanwhile, ';'-separated")
    p.add_argument("--still-rad", type=float, default=0.02, help="refused: index_0 moved less than this")
    p.add_argument("--moved-rad", type=float, default=0.2, help="moved: index_0 moved at least this")
    p.add_argument("--out", required=True)
    p.set_defaults(fn=cmd_judge)

    p = sub.add_parser("echo-server")
    p.add_argument("--listen", required=True, help="ADDR:PORT")
    p.set_defaults(fn=cmd_echo_server)

    p = sub.add_parser("echo-client")
    p.add_argument("--to", required=True, help="ADDR:PORT")
    p.add_argument("--count", type=int, default=1000)
    p.add_argument("--rate", type=float, default=100.0)
    p.add_argument("--timeout", type=float, default=30.0)
    p.add_argument("--drain", type=float, default=10.0)
    p.add_argument("--out", required=True)
    p.set_defaults(fn=cmd_echo_client)

    p = sub.add_parser("cpu")
    p.add_argument("--out", required=True)
    p.add_argument("procs", nargs="+", help="NAME=PID")
    p.set_defaults(fn=cmd_cpu)

    p = sub.add_parser("metrics")
    p.add_argument("--url", required=True)
    p.add_argument("--out", required=True)
    p.set_defaults(fn=cmd_metrics)

    p = sub.add_parser("summarize")
    p.add_argument("--logs", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--command", required=True)
    p.add_argument("--uptime-before", required=True)
    p.add_argument("--uptime-after", required=True)
    p.add_argument("--shaped", type=int, choices=[0, 1], required=True)
    p.add_argument("--shape", default="")
    p.add_argument("--domain", type=int, required=True)
    p.add_argument("--cut-device", default="dex3_right")
    p.set_defaults(fn=cmd_summarize)

    p = sub.add_parser("report")
    p.add_argument("results")
    p.add_argument("--into")
    p.set_defaults(fn=cmd_report)

    a = ap.parse_args()
    return a.fn(a)


if __name__ == "__main__":
    sys.exit(main())
