"""Independent clients of handgate's HTTP server (tests/tests/http.rs), one per subcommand.

  metrics URL [TOKEN]     parse URL/metrics with prometheus_client's own text parser; print
                          one JSON line {"families": {name: type}, "samples": {"name{labels}": v}};
                          with TOKEN, sent as `Authorization: Bearer TOKEN` (as Prometheus does)
  ws URL [--send F ...] [--every-ms N --for-ms M] [--origin O] [--cookie C]
                          open URL/ws (websockets); print each frame received as "<type> <json>";
                          send the frames F (re-sent every N ms for M ms, like the page's
                          slider), then print "sent_done"; "closed" when the server closes.
                          --origin: send Origin O, as a browser page does (none by default).
                          --cookie: send `Cookie: C` (the page's token cookie, [http] token_file).
"""

import asyncio
import json
import sys
import urllib.request


def metrics(url, token=None):
    from prometheus_client.parser import text_string_to_metric_families

    req = urllib.request.Request(url + "metrics")
    if token:
        req.add_header("Authorization", f"Bearer {token}")
    text = urllib.request.urlopen(req, timeout=10).read().decode()
    families = {}
    samples = {}
    for fam in text_string_to_metric_families(text):
        families[fam.name] = fam.type
        for s in fam.samples:
            labels = ",".join(f'{k}="{v}"' for k, v in sorted(s.labels.items()))
            # JSON has no NaN (a never-measured age): null.
            samples[f"{s.name}{{{labels}}}"] = None if s.value != s.value else s.value
    print(json.dumps({"families": families, "samples": samples}), flush=True)


async def ws(url, args):
    import argparse

    import websockets

    ap = argparse.ArgumentParser(prog="http_probe.py ws")
    ap.add_argument("--send", action="append", default=[], help="a frame (JSON text) to send")
    ap.add_argument("--every-ms", type=float, default=0, help="re-send the frames this often")
    ap.add_argument("--for-ms", type=float, default=0, help="keep re-sending this long")
    ap.add_argument("--quiet", action="store_true", help="READY at hello, then only count frames (a benchmark's viewer)")
    ap.add_argument("--origin", help="the Origin header a browser page would send")
    ap.add_argument("--cookie", help="the Cookie header a browser page would send")
    a = ap.parse_args(args)
    uri = url.replace("http://", "ws://") + "ws"
    headers = {"Cookie": a.cookie} if a.cookie else None
    async with websockets.connect(uri, max_size=2**24, origin=a.origin, additional_headers=headers) as sock:

        async def pump():
            n = 0
            async for m in sock:
                n += 1
                if not a.quiet:
                    print(f"{json.loads(m).get('type')} {m}", flush=True)
                elif n == 1:
                    print("READY", flush=True)

        async def sender():
            loop = asyncio.get_running_loop()
            end = loop.time() + a.for_ms / 1000
            while True:
                for f in a.send:
                    await sock.send(f)
                if a.every_ms <= 0 or loop.time() >= end:
                    break
                await asyncio.sleep(a.every_ms / 1000)
            print("sent_done", flush=True)

        s = asyncio.ensure_future(sender())
        await pump()
        s.cancel()
    print("closed", flush=True)


if __name__ == "__main__":
    cmd, url = sys.argv[1], sys.argv[2]
    if not url.endswith("/"):
        url += "/"
    if cmd == "metrics":
        metrics(url, sys.argv[3] if len(sys.argv) > 3 else None)
    elif cmd == "ws":
        asyncio.run(ws(url, sys.argv[3:]))
    else:
        sys.exit(f"unknown subcommand {cmd}")
