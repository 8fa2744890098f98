"""What watching the fleet costs the gateway (docs/benchmarks.md, "Dashboard and Foxglove").

Starts the release gateway on the default fleet, then alternates phases of PHASE seconds:
  idle     no client (the baseline)
  watched  3 dashboard tabs in headless Chromium (tests/browser/node_modules/playwright-core)
           plus one Foxglove WebSocket client subscribed to every channel (when the binary has
           the `foxglove` feature)
  fed      the same 3 page connections and Foxglove client from clients that draw nothing
           (Python), to tell the gateway's serving from the browsers' own CPU on this machine
in the order idle, fed, watched, idle, fed, watched (so drift shows). Per phase: the gateway's CPU (%
of one core, from /proc/<pid>/stat), the Dex3 loops' period p50/p99 and the share of periods
beyond 1.1 ms (from the deltas of /metrics' loop-period histogram), missed cycles, the load
average; the browsers' and the Foxglove client's own CPU are reported apart (they are not
the gateway's).

  .venv/bin/python bench/dashboard_cost.py BIN OUT.json [--phase 30] [--domain 104]
  .venv/bin/python bench/dashboard_cost.py --report OUT.json [--into docs/benchmarks.md]
                                           (the markdown section; --into: before "## Running")
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        parts = f.read().rsplit(")", 1)[1].split()
    # utime, stime, cutime, cstime are fields 14-17 (1-based) of stat; after the comm split,
    # index 11..14.
    return sum(int(x) for x in parts[11:15]) / TICK


def tree_cpu(pid):
    """CPU seconds of a process and its descendants (a browser's renderer processes)."""
    total = 0.0
    todo = [pid]
    while todo:
        p = todo.pop()
        try:
            total += cpu_seconds(p)
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except (FileNotFoundError, ProcessLookupError):
            pass
    return total


def metrics(url):
    text = urllib.request.urlopen(url + "metrics", timeout=10).read().decode()
    hist = {}
    missed = {}
    for line in text.splitlines():
        m = re.match(r'handgate_device_loop_period_seconds_bucket\{device="([^"]+)",kind="dex3".*le="([^"]+)"\} (\S+)', line)
        if m:
            hist.setdefault(m.group(1), []).append((float(m.group(2)), float(m.group(3))))
        m = re.match(r'handgate_device_missed_cycles_total\{device="([^"]+)",kind="dex3".*\} (\S+)', line)
        if m:
            missed[m.group(1)] = float(m.group(2))
    return hist, missed


def quantile(buckets, q):
    """Upper bound of the bucket holding quantile q of cumulative (le, count) buckets."""
    n = buckets[-1][1]
    if n <= 0:
        return None
    for le, c in buckets:
        if c >= q * n:
            return le
    return None


def delta(a, b):
    return [(le, cb - ca) for (le, ca), (_, cb) in zip(a, b)]


def report(path):
    r = json.load(open(path))
    ph = r["phases"]
    out = ["", "## 7. Watching the fleet: dashboard and Foxglove", ""]
    fox = any(p["foxglove_client"] for p in ph)
    out.append(
        f"The default fleet (release build) with nobody watching (`idle`), then with 3 dashboard "
        f"tabs in headless Chromium{' and one Foxglove WebSocket client subscribed to every channel' if fox else ' (this binary had no `foxglove` feature: no Foxglove client)'} "
        f"(`watched`), and the same connections from Python clients that draw nothing (`fed`: the gateway's serving without "
        f"the browsers' rendering on the same 2 cores), {r['phase_seconds']:.0f} s per phase, in the order idle, fed, watched, idle, fed, watched. "
        "The gateway's CPU from /proc; the Dex3 loops' periods from the deltas of `/metrics`' "
        "loop-period histogram (buckets 5–10 µs wide around 1 ms, so p50/p99 are bucket upper "
        "bounds); the clients' own CPU (browsers, Python) apart. `bench/dashboard_cost.py`, DDS domain 104.")
    out.append("")
    out.append("| phase | gateway CPU % of a core | clients' CPU % | dex3 p50 ms | dex3 p99 ms | periods > 1.1 ms % | missed | load 1 min |")
    out.append("|---|---|---|---|---|---|---|---|")
    for p in ph:
        lo = p["loops"].values()
        fmt = lambda k, f: " / ".join(f.format(l[k]) for l in lo)
        out.append(
            f"| {p['phase']} | {p['gateway_cpu_pct']:.1f} | {p['clients_cpu_pct']:.1f} | {fmt('p50_ms', '{:.3f}')} | "
            f"{fmt('p99_ms', '{:.3f}')} | {fmt('beyond_1_1ms_pct', '{:.2f}')} | {fmt('missed', '{:.0f}')} | {p['load1']:.2f} |")
    mean = lambda name: (lambda v: sum(v) / len(v))([p["gateway_cpu_pct"] for p in ph if p["phase"] == name])
    extra = mean("watched") - mean("idle")
    extra_fed = mean("fed") - mean("idle")
    out.append("")
    out.append(
        f"Extra gateway CPU while watched: {extra:+.1f} % of one core (mean of the watched phases "
        f"minus the mean of the idle ones; {extra_fed:+.1f} % with the clients that draw nothing; target under 5 %: "
        f"{'met' if max(extra, extra_fed) < 5 else 'MISSED'}). Each cell of the loop columns lists dex3_left / dex3_right.")
    return "\n".join(out) + "\n"


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "--report":
        text = report(sys.argv[2])
        if len(sys.argv) == 5 and sys.argv[3] == "--into":
            # Before the report's closing "## Running" section.
            doc = open(sys.argv[4]).read()
            i = doc.find("\n## Running")
            doc = doc + text if i < 0 else doc[:i] + text + doc[i:]
            open(sys.argv[4], "w").write(doc)
        else:
            sys.stdout.write(text)
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("bin")
    ap.add_argument("out")
    ap.add_argument("--phase", type=float, default=30)
    ap.add_argument("--domain", type=int, default=104)
    ap.add_argument("--phases", default="idle,fed,watched,idle,fed,watched")
    ap.add_argument("--no-foxglove", action="store_true", help="no Foxglove client (the pages alone)")
    ap.add_argument("--no-pages", action="store_true", help="no page (the Foxglove client alone)")
    a = ap.parse_args()
    gw = subprocess.Popen(
        [a.bin, "run", "--domain", str(a.domain), "--http-port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
    )
    url, fox = None, None
    for line in gw.stdout:
        m = re.search(r"http: listening url=(http://\S+)", line)
        if m:
            url = m.group(1)
        m = re.search(r"foxglove: listening url=(ws://\S+)", line)
        if m:
            fox = m.group(1)
        if "handgate serving" in line:
            break
    if url is None:
        sys.exit("the gateway never said where its dashboard listens")
    # Keep draining the gateway's output so it never blocks on a full pipe.
    import threading
    threading.Thread(target=lambda: [None for _ in gw.stdout], daemon=True).start()
    time.sleep(3)  # warm-up: discovery settles, the loops reach their rate
    phases = []
    if a.no_foxglove:
        fox = None
    for name in a.phases.split(","):
        clients = []
        if name == "watched":
            node = ["node", os.path.join(ROOT, "bench", "dashboard_tabs.mjs"), url, "3", str(a.phase + 10)]
            clients.append(subprocess.Popen(node, cwd=ROOT, stdout=subprocess.PIPE, text=True))
        if name == "fed":
            # The same three page connections, from a client that draws nothing.
            for _ in range(0 if a.no_pages else 3):
                probe = [sys.executable, os.path.join(ROOT, "tests", "python", "http_probe.py"), "ws", url, "--quiet"]
                clients.append(subprocess.Popen(probe, cwd=ROOT, stdout=subprocess.PIPE, text=True))
        if name != "idle":
            if fox:
                py = [sys.executable, os.path.join(ROOT, "tests", "python", "foxglove_client.py"), fox, "*",
                      "--quiet", "--seconds", str(a.phase + 10)]
                clients.append(subprocess.Popen(py, cwd=ROOT, stdout=subprocess.PIPE, text=True))
            # Each client says READY once it receives data.
            for c in clients:
                for line in c.stdout:
                    if line.startswith("READY"):
                        break
        h0, m0 = metrics(url)
        g0, c0, t0 = cpu_seconds(gw.pid), sum(tree_cpu(c.pid) for c in clients), time.monotonic()
        time.sleep(a.phase)
        h1, m1 = metrics(url)
        g1, c1, t1 = cpu_seconds(gw.pid), sum(tree_cpu(c.pid) for c in clients), time.monotonic()
        load = os.getloadavg()[0]
        dt = t1 - t0
        loops = {}
        for dev in h1:
            d = delta(h0[dev], h1[dev])
            n = d[-1][1]
            beyond = n - next(c for le, c in d if le >= 0.0011)
            loops[dev] = {
                "p50_ms": quantile(d, 0.5) * 1e3,
                "p99_ms": quantile(d, 0.99) * 1e3,
                "beyond_1_1ms_pct": 100.0 * beyond / n if n else None,
                "cycles": n,
                "missed": m1[dev] - m0[dev],
            }
        phases.append({
            "phase": name,
            "gateway_cpu_pct": 100.0 * (g1 - g0) / dt,
            "clients_cpu_pct": 100.0 * (c1 - c0) / dt if clients else 0.0,
            "foxglove_client": bool(fox) and name != "idle",
            "tabs": 3 if name == "watched" else 0,
            "pages_without_browser": 3 if name == "fed" and not a.no_pages else 0,
            "load1": load,
            "seconds": dt,
            "loops": loops,
        })
        for c in clients:
            c.terminate()
            try:
                c.wait(10)
            except subprocess.TimeoutExpired:
                c.kill()
        print(json.dumps(phases[-1]), flush=True)
    gw.send_signal(2)
    gw.wait(10)
    with open(a.out, "w") as f:
        json.dump({"phase_seconds": a.phase, "nproc": os.cpu_count(), "no_foxglove": a.no_foxglove,
                   "no_pages": a.no_pages, "phases": phases}, f, indent=1)


if __name__ == "__main__":
    main()
