#!/usr/bin/env bash
# Which cyclonedds-rs serdata / sertype callbacks CycloneDDS calls on handgate's DDS paths, by
# measurement (docs/sources.md §8 "The DDS binding"): the program runs under gdb with a
# breakpoint on the first instruction of every callback (every monomorphised instance, from
# nm), each hit counted by callback, topic type, thread and caller, with the (offset, size) of
# every to_ser / to_ser_ref (scripts/serdata_calls.py). Breakpoints slow the program a lot:
# the counts say which callbacks run and with what, not how often per second.
#
#   scripts/serdata-calls.sh gateway [SECONDS]   release gateway, profile sim-all, every front
#                                                driven by unitree_sdk2py (drive_fronts.py) for
#                                                SECONDS (default 10) once all states flow
#   scripts/serdata-calls.sh wire                the binding's SDK round trip of every wire
#                                                type (tests/tests/dds_binding.rs, debug build)
#
# Output: a table on stdout, the raw counts in target/serdata-calls-<mode>.json. DDS domain 219
# (gateway) or 218 (wire): run it inside a network namespace when others use them
# (`ip netns exec <ns> scripts/serdata-calls.sh gateway`). Needs gdb and the venv
# (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-}
secs=${2:-10}
target=${CARGO_TARGET_DIR:-target}
command -v gdb >/dev/null || { echo "gdb is missing: apt-get install gdb" >&2; exit 2; }
[ -x .venv/bin/python ] || { echo ".venv is missing: run scripts/setup.sh" >&2; exit 2; }
out="$target/serdata-calls-$mode.json"
log="$target/serdata-calls-$mode.log"
syms=$(mktemp)
trap 'rm -f "$syms"' EXIT

symbols() { # "<offset> <callback>" for every instance of a cyclonedds_rs::serdes callback
    nm -C "$1" | awk '$2 ~ /^[tT]$/ && NF == 3 && $3 ~ /^cyclonedds_rs::serdes::[a-z_]+$/ {
        sub("cyclonedds_rs::serdes::", "", $3); print $1, $3 }' > "$syms"
}

case "$mode" in
gateway)
    cargo build --release -p handgate --features handgate/foxglove
    bin="$target/release/handgate"
    symbols "$bin"
    SERDATA_SYMS=$syms SERDATA_OUT=$out gdb -q -batch -x scripts/serdata_calls.py -ex run \
        --args "$bin" run --profile sim-all --domain 219 >"$log" 2>&1 &
    gdb_pid=$!
    for _ in $(seq 600); do grep -q "handgate serving" "$log" && break; sleep 1; done
    grep -q "handgate serving" "$log" || { echo "the gateway did not start; see $log" >&2; kill "$gdb_pid"; exit 1; }
    .venv/bin/python tests/python/drive_fronts.py --set sim-all --domain 219 --seconds "$secs" | grep -E "^(STREAMING|DONE)" | cut -c1-200
    # The gateway is gdb's child: SIGINT to it by its pid, then gdb writes the counts on exit.
    gw_pid=$(pgrep -P "$gdb_pid" | head -1)
    kill -INT "$gw_pid"
    wait "$gdb_pid"
    ;;
wire)
    bin=$(cargo test -p handgate-tests --test dds_binding --no-run 2>&1 | sed -n 's/.*Executable .*(\(.*\))$/\1/p')
    symbols "$bin"
    SERDATA_SYMS=$syms SERDATA_OUT=$out gdb -q -batch -x scripts/serdata_calls.py -ex run \
        --args "$bin" every_wire_type_round_trips_through_the_sdk --exact --nocapture >"$log" 2>&1
    grep -E "test result" "$log"
    ;;
*)
    sed -n '2,20p' "$0" >&2
    exit 2
    ;;
esac
.venv/bin/python - "$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print("callback | type | thread | caller | calls")
print("---|---|---|---|---")
for op, ty, th, caller, n in d["counts"]:
    print(f"{op} | {ty} | {th} | {caller or '-'} | {n}")
print()
print("to_ser / to_ser_ref requests: callback | type | offset | size | calls")
for op, ty, off, size, n in d["parts"]:
    print(f"{op} | {ty} | {off} | {size} | {n}")
print()
print("from_sample kinds (1 key, 2 data):", d["from_sample_kinds"])
if d["errors"]:
    print("bookkeeping errors:", d["errors"])
PY
