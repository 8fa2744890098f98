# gdb extension for scripts/serdata-calls.sh: counts which cyclonedds-rs serdata/sertype
# callbacks CycloneDDS calls in a running handgate, by topic type, thread and caller.
# docs/sources.md §8 ("The DDS binding") has the method and the results.
#
# Input (environment): SERDATA_SYMS, a file of "<hex offset> <callback>" lines (from nm, one per
# monomorphised instance); SERDATA_LIBDDSC, libddsc's path; SERDATA_OUT, where the JSON summary
# goes when the program exits. Breakpoints sit on each callback's first instruction (gdb runs
# the program without address randomisation, so a PIE loads at 0x555555554000), where the
# System V argument registers still hold the C arguments.
import collections
import json
import os
import re

import gdb

PIE_BASE = 0x555555554000
# Argument register holding the serdata (S) or the sertype (T) for each callback.
SERDATA_ARG = {
    "get_size": ("rdi", "S"), "serdata_to_ser": ("rdi", "S"), "serdata_to_ser_ref": ("rdi", "S"),
    "serdata_to_ser_unref": ("rdi", "S"), "serdata_to_sample": ("rdi", "S"),
    "serdata_to_untyped": ("rdi", "S"), "free_serdata": ("rdi", "S"), "eqkey": ("rdi", "S"),
    "get_keyhash": ("rdi", "S"), "print": ("rsi", "S"),
    "serdata_from_fragchain": ("rdi", "T"), "serdata_from_iov": ("rdi", "T"),
    "serdata_from_sample": ("rdi", "T"), "serdata_from_keyhash": ("rdi", "T"),
    "untyped_to_sample": ("rdi", "T"), "free_samples": ("rdi", "T"), "zero_samples": ("rdi", "T"),
    "realloc_samples": ("rsi", "T"), "hash": ("rdi", "T"), "equal": ("rdi", "T"),
    "free_sertype": ("rdi", "T"), "get_sample_size": ("rdi", "S"), "from_iox_buffer": ("rdi", "T"),
}
CDDS_THREADS = re.compile(r"^(recv|recvUC|recvMC|dq\..*|tev|gc|lease|xmit\..*|sendq)$")

counts = collections.Counter()  # (callback, type, thread class, caller) -> n
parts = collections.Counter()  # (callback, type, offset, size) -> n, for to_ser / to_ser_ref
kinds = collections.Counter()  # (type, serdata kind) -> n, for from_sample (1 key, 2 data)
callers = {}  # return address -> caller label
type_names = {}  # sertype address -> name
errors = collections.Counter()


def _reg(frame, name):
    return int(frame.read_register(name)) & 0xFFFFFFFFFFFFFFFF


def _cstr(addr, limit=160):
    raw = bytes(gdb.selected_inferior().read_memory(addr, limit))
    return raw.split(b"\0", 1)[0].decode("utf-8", "replace")


def _ptr(addr):
    return int.from_bytes(bytes(gdb.selected_inferior().read_memory(addr, 8)), "little")


def _type_name(sertype):
    if sertype not in type_names:
        # struct ddsi_sertype: ops, serdata_ops, serdata_basehash, flags, allowed_data_repr,
        # type_name at offset 32 (CycloneDDS 0.10.2, x86-64).
        type_names[sertype] = _cstr(_ptr(sertype + 32)) if sertype else "(null)"
    return type_names[sertype]


def _caller(frame):
    # The return address on entry. libddsc has no debug information here, and its internal
    # functions are not in its dynamic symbol table: `info symbol` names only exported ones
    # (or nothing). CycloneDDS 0.10.2 converts a serdata to another sertype (local delivery to
    # a reader whose sertype differs) in the exported ddsi_serdata_ref_as_type; every other
    # to_ser_ref comes from nn_xmsg_serdata (the network path).
    ret = _ptr(_reg(frame, "rsp"))
    if ret not in callers:
        info = gdb.execute("info symbol 0x%x" % ret, to_string=True).strip()
        callers[ret] = "ref_as_type" if info.startswith("ddsi_serdata_ref_as_type ") else "other"
    return callers[ret]


class Op(gdb.Breakpoint):
    def __init__(self, addr, name):
        super().__init__("*0x%x" % addr, internal=True)
        self.op = name

    def stop(self):
        try:
            frame = gdb.selected_frame()
            reg, kind = SERDATA_ARG[self.op]
            ptr = _reg(frame, reg)
            sertype = _ptr(ptr + 24) if kind == "S" and ptr else ptr  # ddsi_serdata.type at 24
            tname = _type_name(sertype)
            th = gdb.selected_thread().name or "?"
            th = th if CDDS_THREADS.match(th) else "handgate"
            caller = _caller(frame) if self.op in ("serdata_to_ser_ref", "serdata_from_iov", "get_size") else ""
            counts[(self.op, tname, th, caller)] += 1
            if self.op == "serdata_to_ser_ref":  # (serdata, offset, size, iov)
                parts[(self.op, tname, _reg(frame, "rsi"), _reg(frame, "rdx"))] += 1
            elif self.op == "serdata_to_ser":  # (serdata, size, offset, buf)
                parts[(self.op, tname, _reg(frame, "rdx"), _reg(frame, "rsi"))] += 1
            elif self.op == "serdata_from_sample":  # (sertype, kind, sample)
                kinds[(tname, _reg(frame, "rsi") & 0xFFFFFFFF)] += 1
        except Exception as e:  # never stop the program over a bookkeeping failure
            errors[repr(e)[:120]] += 1
        return False


def dump(_event=None):
    out = {
        "counts": [list(k) + [n] for k, n in sorted(counts.items())],
        "parts": [list(k) + [n] for k, n in sorted(parts.items())],
        "from_sample_kinds": [list(k) + [n] for k, n in sorted(kinds.items())],
        "errors": dict(errors),
    }
    with open(os.environ["SERDATA_OUT"], "w") as f:
        json.dump(out, f, indent=1)


def setup():
    n = 0
    with open(os.environ["SERDATA_SYMS"]) as f:
        for line in f:
            off, name = line.split()
            if name in SERDATA_ARG:
                Op(PIE_BASE + int(off, 16), name)
                n += 1
    gdb.write("serdata_calls: %d breakpoints\n" % n)
    gdb.events.exited.connect(dump)


gdb.execute("set pagination off")
gdb.execute("set confirm off")
gdb.execute("handle SIGINT nostop noprint pass")
gdb.execute("handle SIGTERM nostop noprint pass")
gdb.execute("handle SIGPIPE nostop noprint pass")
gdb.execute("handle SIGUSR1 nostop noprint pass")
gdb.execute("set print thread-events off")
gdb.execute("set disable-randomization on")
setup()
