#!/usr/bin/env bash
# handgate's DDS paths under valgrind memcheck (docs/reliability.md §7).
#
#   scripts/valgrind.sh gateway [PROFILE [SECONDS]]
#       the release gateway on PROFILE (default sim-all; `default` is the embedded profile),
#       every front driven by unitree_sdk2py (tests/python/drive_fronts.py: commands written,
#       states read) for SECONDS (default 20) once every state topic delivers
#   scripts/valgrind.sh wire
#       the binding's round trip of every wire type through unitree_sdk2py
#       (tests/tests/dds_binding.rs every_wire_type_round_trips_through_the_sdk, debug build)
#   scripts/valgrind.sh all
#       both
#
# Prints each run's ERROR SUMMARY and LEAK SUMMARY lines and its invalid reads / writes; exits
# non-zero unless every run has no memcheck error (suppressions: scripts/valgrind.supp), no
# byte definitely or indirectly lost, and (gateway) every front delivered states. `all` runs
# the default profile for 15 s, sim-all for 20 s, then the wire types (about 3 minutes here).
# Logs: target/valgrind-<run>.log, the program's output next to it (.out). DDS domains 219
# (gateway) and 218 (wire): run it inside a network namespace when others use them
# (`ip netns exec <ns> scripts/valgrind.sh all`). Needs valgrind (apt-get install valgrind)
# and the venv (scripts/setup.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}
domain=219 # the gateway's runs (the wire run's test uses 218; docs/development.md)
command -v valgrind >/dev/null || { echo "valgrind is missing: apt-get install valgrind" >&2; exit 2; }
[ -x .venv/bin/python ] || { echo ".venv is missing: run scripts/setup.sh" >&2; exit 2; }
vg=(valgrind --tool=memcheck --leak-check=full --show-leak-kinds=definite,indirect
    --errors-for-leak-kinds=definite,indirect --track-origins=yes --num-callers=40
    --suppressions=scripts/valgrind.supp)
failed=0

summary() { # $1 log, $2 run name
    local log=$1
    echo "== $2 ($log)"
    grep -E "ERROR SUMMARY|definitely lost:|indirectly lost:|no leaks are possible" "$log" | sed 's/^==[0-9]*== *//'
    local invalid
    invalid=$(grep -cE "Invalid (read|write)" "$log" || true)
    echo "invalid reads/writes: $invalid"
    local errors definite indirect
    errors=$(sed -n 's/.*ERROR SUMMARY: \([0-9,]*\) errors.*/\1/p' "$log" | tr -d ,)
    definite=$(sed -n 's/.*definitely lost: \([0-9,]*\) bytes.*/\1/p' "$log" | tr -d ,)
    indirect=$(sed -n 's/.*indirectly lost: \([0-9,]*\) bytes.*/\1/p' "$log" | tr -d ,)
    if [ "${errors:-1}" != 0 ] || [ "${definite:-0}" != 0 ] || [ "${indirect:-0}" != 0 ] || [ "$invalid" != 0 ]; then
        echo "FAIL: memcheck found errors or leaks"
        failed=1
    fi
}

run_gateway() {
    local profile=${1:-sim-all} secs=${2:-20}
    local set=$profile log="$target/valgrind-gateway-$profile.log" out="$target/valgrind-gateway-$profile.out"
    [ "$profile" = default ] && set=default
    cargo build --release -p handgate --features handgate/foxglove
    local args=(run --domain "$domain")
    [ "$profile" != default ] && args+=(--profile "$profile")
    "${vg[@]}" --log-file="$log" "$target/release/handgate" "${args[@]}" >"$out" 2>&1 &
    local pid=$!
    for _ in $(seq 600); do grep -q "handgate serving" "$out" && break; sleep 1; done
    grep -q "handgate serving" "$out" || { echo "the gateway did not start; see $out" >&2; kill "$pid"; exit 1; }
    local done_line
    .venv/bin/python tests/python/drive_fronts.py --set "$set" --domain "$domain" --seconds "$secs" >"$out.client"
    done_line=$(grep "^DONE " "$out.client" || true)
    kill -INT "$pid"
    wait "$pid" || { echo "FAIL: the gateway exited $? (see $out)"; failed=1; }
    summary "$log" "gateway, profile $profile, $secs s"
    echo "client: ${done_line:0:160}..."
    if ! grep -q '"silent": \[\]' <<<"$done_line"; then
        echo "FAIL: fronts without states: $(sed 's/.*"silent"/"silent"/' <<<"$done_line")"
        failed=1
    fi
}

run_wire() {
    local log="$target/valgrind-wire.log" bin
    bin=$(cargo test -p handgate-tests --test dds_binding --no-run 2>&1 | sed -n 's/.*Executable .*(\(.*\))$/\1/p')
    if ! "${vg[@]}" --log-file="$log" "$bin" every_wire_type_round_trips_through_the_sdk --exact --nocapture \
        >"$target/valgrind-wire.out" 2>&1; then
        echo "FAIL: the round trip failed (see $target/valgrind-wire.out)"
        failed=1
    fi
    summary "$log" "wire types through unitree_sdk2py"
    grep -E "B on the wire|test result" "$target/valgrind-wire.out" || true
}

case "${1:-}" in
gateway) shift; run_gateway "$@" ;;
wire) run_wire ;;
all) run_gateway default 15; run_gateway sim-all 20; run_wire ;;
*) sed -n '2,21p' "$0" >&2; exit 2 ;;
esac
exit $failed
