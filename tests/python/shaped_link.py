#!/usr/bin/env python3
"""A shaped IPv4 link between two network namespaces, in user space: netem's delay, jitter, loss,
duplication and reordering for kernels built without sch_netem (this project's machines:
CONFIG_NET_SCH_NETEM is not set, `tc qdisc add ... netem` answers "Specified qdisc kind is
unknown").

It opens a TUN device in each namespace (IFNAME_A in NS_A, IFNAME_B in NS_B; the devices exist
while this process runs) and moves every packet one reads to the other, through the impairments
netem applies on egress, in each direction:

    loss       a packet is dropped with this probability
    duplicate  a packet is sent twice with this probability
    delay      each copy waits delay_ms ± jitter_ms (uniform, as netem's default), so packets
               closer together than the jitter overtake each other
    reorder    with this probability (correlated with the previous decision by reorder_corr, as
               netem's `reorder P C`) a copy goes at once, ahead of the delayed ones

Only the two namespaces' TUN devices carry anything: no packet goes anywhere else. It stops by
itself after --max-seconds, or on SIGTERM/SIGINT, and then prints its counts.

A cut, as a cable pulled: SIGUSR1 cuts the link both ways, SIGUSR2 restores it. While cut,
nothing is delivered: a packet read is dropped, and so is a copy already queued whose time to be
sent comes during the cut (counted `cut`); a copy due after the restore is sent as usual.

    shaped_link.py NS_A IFNAME_A NS_B IFNAME_B [--delay-ms 50] [--jitter-ms 10] [--loss 0.01]
                   [--duplicate 0.01] [--reorder 0.25] [--reorder-corr 0.5] [--seed 1]
                   [--max-seconds 900]

stdout (flushed lines):
    READY                       both devices exist (the caller addresses and raises them)
    CUT <wall> <monotonic>      the link is cut (SIGUSR1), at these times (time.time(),
                                time.monotonic(): seconds)
    RESTORED <wall> <monotonic> the link is back (SIGUSR2)
    STATS <json>                at exit, per direction: packets read, sent, lost, duplicated,
                                sent early by reorder, sent after a later-read packet
                                (overtaken), not taken by the receiving device (unsent), dropped
                                by a cut (cut), and still waiting when it stopped
                                (queued_at_exit): read - lost + duplicated = sent + unsent + cut
                                + queued_at_exit
"""

import argparse
import ctypes
import fcntl
import heapq
import itertools
import json
import os
import random
import select
import signal
import struct
import sys
import time

CLONE_NEWNET = 0x40000000
TUNSETIFF = 0x400454CA
IFF_TUN = 0x0001
IFF_NO_PI = 0x1000


def open_tun_in(netns, ifname):
    """A TUN device named ifname in network namespace netns (/run/netns/NAME), and back."""
    libc = ctypes.CDLL(None, use_errno=True)
    own = os.open("/proc/self/ns/net", os.O_RDONLY)
    target = os.open(f"/run/netns/{netns}", os.O_RDONLY)
    try:
        if libc.setns(target, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), f"setns into {netns}")
        fd = os.open("/dev/net/tun", os.O_RDWR | os.O_NONBLOCK)
        fcntl.ioctl(fd, TUNSETIFF, struct.pack("16sH", ifname.encode(), IFF_TUN | IFF_NO_PI))
        if libc.setns(own, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), "setns back")
        return fd
    finally:
        os.close(own)
        os.close(target)


class Direction:
    """One way of the link: the impairments and the queue of copies waiting to be sent."""

    def __init__(self, name, src, dst, args, rng):
        self.name, self.src, self.dst, self.args, self.rng = name, src, dst, args, rng
        self.last_reorder = 0.0
        self.seq = 0  # order of reading
        self.tiebreak = itertools.count()
        self.last_sent_seq = -1
        self.counts = {
            "read": 0, "sent": 0, "lost": 0, "duplicated": 0, "reorder_early": 0, "overtaken": 0, "unsent": 0,
            "cut": 0, "queued_at_exit": 0,
        }

    def correlated(self, last, corr):
        # netem's get_crandom: the next draw leans towards the previous one by corr.
        return (1.0 - corr) * self.rng.random() + corr * last

    def take(self, packet, now, queue, cut):
        a = self.args
        self.counts["read"] += 1
        seq = self.seq
        self.seq += 1
        if cut:
            self.counts["cut"] += 1
            return
        if self.rng.random() < a.loss:
            self.counts["lost"] += 1
            return
        copies = 1
        if self.rng.random() < a.duplicate:
            copies = 2
            self.counts["duplicated"] += 1
        for _ in range(copies):
            self.last_reorder = self.correlated(self.last_reorder, a.reorder_corr)
            if self.last_reorder < a.reorder:
                due = now
                self.counts["reorder_early"] += 1
            else:
                jitter = self.rng.uniform(-a.jitter_ms, a.jitter_ms)
                due = now + max(0.0, a.delay_ms + jitter) / 1000.0
            heapq.heappush(queue, (due, next(self.tiebreak), self.name, seq, packet, self))

    def send(self, seq, packet, cut):
        if cut:
            self.counts["cut"] += 1
            return
        try:
            os.write(self.dst, packet)
        except OSError:
            # The receiving device is not up yet, or its queue is full: lost, as on a wire.
            self.counts["unsent"] += 1
            return
        self.counts["sent"] += 1
        if seq < self.last_sent_seq:
            self.counts["overtaken"] += 1
        self.last_sent_seq = max(self.last_sent_seq, seq)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ns_a")
    ap.add_argument("if_a")
    ap.add_argument("ns_b")
    ap.add_argument("if_b")
    ap.add_argument("--delay-ms", type=float, default=50.0)
    ap.add_argument("--jitter-ms", type=float, default=10.0)
    ap.add_argument("--loss", type=float, default=0.01)
    ap.add_argument("--duplicate", type=float, default=0.01)
    ap.add_argument("--reorder", type=float, default=0.25)
    ap.add_argument("--reorder-corr", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-seconds", type=float, default=900.0)
    args = ap.parse_args()

    fd_a = open_tun_in(args.ns_a, args.if_a)
    fd_b = open_tun_in(args.ns_b, args.if_b)
    rng = random.Random(args.seed)
    dirs = {
        fd_a: Direction(f"{args.if_a}->{args.if_b}", fd_a, fd_b, args, rng),
        fd_b: Direction(f"{args.if_b}->{args.if_a}", fd_b, fd_a, args, rng),
    }
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    cut = [False]

    def set_cut(on):
        cut[0] = on
        print(f"{'CUT' if on else 'RESTORED'} {time.time():.6f} {time.monotonic():.6f}", flush=True)

    signal.signal(signal.SIGUSR1, lambda *_: set_cut(True))
    signal.signal(signal.SIGUSR2, lambda *_: set_cut(False))
    print("READY", flush=True)

    queue = []
    end = time.monotonic() + args.max_seconds
    while not stop and time.monotonic() < end:
        now = time.monotonic()
        while queue and queue[0][0] <= now:
            _, _, _, seq, packet, d = heapq.heappop(queue)
            d.send(seq, packet, cut[0])
        timeout = max(0.0, queue[0][0] - now) if queue else 0.5
        try:
            ready, _, _ = select.select(list(dirs), [], [], min(timeout, 0.5))
        except InterruptedError:
            continue
        now = time.monotonic()
        for fd in ready:
            d = dirs[fd]
            while True:
                try:
                    packet = os.read(fd, 65536)
                except BlockingIOError:
                    break
                except OSError:
                    break  # the device went down
                d.take(packet, now, queue, cut[0])
    for entry in queue:
        entry[-1].counts["queued_at_exit"] += 1
    print("STATS " + json.dumps({d.name: d.counts for d in dirs.values()}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
