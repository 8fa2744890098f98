#!/usr/bin/env bash
# make bench: runs every benchmark (release builds) and rewrites docs/benchmarks.md.
#   1. codec      cargo bench -p handgate-adapters --bench dex3_usb (criterion), and --bench
#                 ezgripper when adapters/benches/ezgripper.rs exists; 5a. the Robotiq exchange rate
#                 (--bench robotiq)
#   2. loop       the Dex3 USB device loop at 1 kHz on the emulator, 60 s (default, SCHED_FIFO),
#                 beside a reference loop that only sleeps to absolute deadlines
#   2b. busy      the same loop while discovery runs on a domain with 500 remote endpoints
#                 (50 re-created a second), against the same loop with the domain quiet, 30 s each
#   3. hop        end-to-end HandCmd_ -> HandState_ through handgate vs a Rust echo (floor), the echo
#                 plus one emulated Dex3 USB exchange, and a unitree_sdk2py relay, at 200 Hz and 1 kHz
#   3b. shim      a Dex1 client driving a Dex3 served by the G1-service emulator (its own process)
#                 through handgate vs a raw Rust relay (two DDS hops) and a unitree_sdk2py shim
#   3c. secure    the hop on an export domain, plain and with DDS Security ([export.security], the
#                 client an operator identity of a keystore made by handgate security), alternating
#   4. fleet      32 Dex3 + 32 Dex1 emulated in one gateway, 30 s, between two 15 s windows of the
#                 reference (the same emulated hands and DDS traffic without handgate, domain 105):
#                 the verdict is the gateway's CPU over the reference's; again with loop_threads = 0
#   4b. simall    the shipped sim-all profile (every kind emulated at its own rates), 30 s
#   4c. startup   handgate run on sim-all, 5 starts: spawn -> every device fresh, a state on every front
#   4d. timers    64 empty loops at 1 kHz, a thread each vs handgate's shared loop threads, 30 s each
#   5c. rh56      two Inspire RH56 hands on one emulated RS-485 line at 115200 baud, commanded at
#                 50 Hz then 100 Hz, 30 s each: readings per hand against the wire limit
#   6. record     handgate record of every topic of the default fleet beside a gateway, 600 s
#   7. dashboard  the default fleet idle vs watched (3 dashboard tabs in headless Chromium and a
#                 Foxglove client), 30 s per phase, twice (bench/dashboard_cost.py)
#   8. sites      not run here: make fleet measures it (root, Zenoh); the section is re-written
#                 from its last figures, docs/benchmarks/sites.json
# Environment: CARGO_TARGET_DIR (default target/), BENCH_QUICK=1 for short smoke runs,
# BENCH_ONLY="codec loop busy hop shim secure fleet simall startup timers rh56 record dashboard" to run a subset:
# the sections it does not run are carried from docs/benchmarks/raw/ (the last report's raw results),
# marked in the report with the date and load of the run that measured them; raw/ then holds the union.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
cargo=${CARGO:-cargo}
target=${CARGO_TARGET_DIR:-$root/target}
results="$target/bench-results"
only=${BENCH_ONLY:-"codec loop busy hop shim secure fleet simall startup timers rh56 record dashboard"}
quick=${BENCH_QUICK:-0}

loop_secs=60; busy_secs=30; fleet_secs=30; samples=2000; record_secs=600; dash_secs=30
if [ "$quick" = 1 ]; then loop_secs=5; busy_secs=5; fleet_secs=5; samples=300; record_secs=10; dash_secs=5; fi

want() { [[ " $only " == *" $1 "* ]]; }

[ -x .venv/bin/python ] || scripts/setup.sh

echo "bench: building release binaries"
# The gateway as `make run` builds it (with the Foxglove live server: step 7 watches it).
$cargo build --release -p handgate -p handgate-bench --features handgate/foxglove
$cargo build --release -p handgate-adapters --example busy_domain
bin="$target/release"

rm -rf "$results"
mkdir -p "$results"
"$bin/handgate-bench" machine --out "$results/machine.json"
echo "bench: load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"

if want codec; then
  since=$(date +%s)
  echo "bench: 1. codec (criterion)"
  # DEX3_JITTER_SECS=0: the criterion file's own short jitter runs are superseded by step 2.
  DEX3_JITTER_SECS=0 $cargo bench -p handgate-adapters --bench dex3_usb
  "$bin/handgate-bench" criterion --dir "$target/criterion" --since "$since" --out "$results/codec_dex3.json"
  since=$(date +%s)
  $cargo bench -p handgate-adapters --bench dynamixel_codec
  "$bin/handgate-bench" criterion --dir "$target/criterion" --since "$since" --out "$results/codec_ezgripper.json"
  echo "bench: 5. EZGripper measured-state rate over the pty emulator (5 s per case)"
  # The bench prints a markdown table (round periods and rates per gripper); keep it as is.
  $cargo bench -p handgate-adapters --bench ezgripper -- 5 | grep '^|' > "$results/ezgripper.md"
  echo "bench: 5a. Robotiq status+command exchanges at 115200 baud on a simulated line (5 s per case)"
  $cargo bench -p handgate-adapters --bench robotiq -- 5 | grep '^|' > "$results/robotiq.md"
  echo "bench: 5b. LEAP Hand cycle rate at 4 Mbaud against the wire limit (5 s per case)"
  $cargo bench -p handgate-adapters --bench leap -- 5 | grep '^|' > "$results/leap.md"
fi

if want loop; then
  echo "bench: 2. device loop (${loop_secs} s per configuration)"
  configs=default
  # SCHED_FIFO needs root (or CAP_SYS_NICE): the opt-in real-time configuration.
  [ "$(id -u)" -eq 0 ] && configs="default,fifo"
  "$bin/handgate-bench" loop --secs "$loop_secs" --configs "$configs" --out "$results/loop.json"
fi

if want busy; then
  echo "bench: 2b. device loop with a busy domain (${busy_secs} s per phase)"
  busy_configs=default
  [ "$(id -u)" -eq 0 ] && busy_configs="default,fifo"
  "$bin/handgate-bench" busy --secs "$busy_secs" --configs "$busy_configs" --busy-domain "$bin/examples/busy_domain" --out "$results/busy.json"
fi

if want hop; then
  echo "bench: 3. end-to-end hop ($samples samples per rate)"
  # A variant of the default profile: the Dex3 exchanges may come 100 µs apart (the floor of
  # usb.align_min_gap_us) instead of 500 µs (docs/dex3-usb.md, assumption 11).
  sed 's/^timeout_bit = true.*/&\nalign_min_gap_us = 100/' profiles/default.toml > "$results/hop_min_gap_100.toml"
  "$bin/handgate-bench" hop --handgate "$bin/handgate" --python "$root/.venv/bin/python" \
    --relay "$root/bench/python/relay.py" --samples "$samples" \
    --handgate-profile "min_gap 100 µs=$results/hop_min_gap_100.toml" --out "$results/hop.json"
fi

if want shim; then
  echo "bench: 3b. shim hop through a DDS-client device ($samples samples per rate)"
  "$bin/handgate-bench" shim --handgate "$bin/handgate" --python "$root/.venv/bin/python" \
    --script "$root/bench/python/shim.py" --samples "$samples" --out "$results/shim.json"
fi

if want secure; then
  echo "bench: 3c. the export hop, plain and with DDS Security ($samples samples per rate, 2 rounds each)"
  "$bin/handgate-bench" secure-hop --handgate "$bin/handgate" --repo "$root" --samples "$samples" \
    --out "$results/secure_hop.json"
fi

if want fleet; then
  echo "bench: 4. fleet scale (${fleet_secs} s)"
  "$bin/handgate-bench" fleet --handgate "$bin/handgate" --secs "$fleet_secs" --out "$results/fleet.json"
  echo "bench: 4. fleet scale, a thread per DDS-client device loop (loop_threads = 0, ${fleet_secs} s)"
  "$bin/handgate-bench" fleet --handgate "$bin/handgate" --secs "$fleet_secs" --loop-threads 0 --reference-secs 0 --out "$results/fleet_own.json"
fi

if want simall; then
  echo "bench: 4b. sim-all, every kind at its own rates (${fleet_secs} s)"
  "$bin/handgate-bench" profile --handgate "$bin/handgate" --profile sim-all --secs "$fleet_secs" --out "$results/simall.json"
fi

if want startup; then
  echo "bench: 4c. start-up of sim-all (5 starts)"
  "$bin/handgate-bench" startup --handgate "$bin/handgate" --profile sim-all --runs 5 --out "$results/startup.json"
fi

if want timers; then
  echo "bench: 4d. loop threads: 64 loops at 1 kHz, a thread each vs shared (${busy_secs} s each)"
  "$bin/handgate-bench" timers --loops 64 --hz 1000 --secs "$busy_secs" --out "$results/timers.json"
fi

if want rh56; then
  echo "bench: 5c. Inspire RH56: two hands on one line at 115200 baud (${busy_secs} s per schedule)"
  "$bin/handgate-bench" rh56 --secs "$busy_secs" --out "$results/rh56.json"
fi

if want record; then
  echo "bench: 6. recording the default fleet (${record_secs} s)"
  "$bin/handgate-bench" record --handgate "$bin/handgate" --secs "$record_secs" \
    --dir "$target/bench-recording/fleet" --out "$results/record.json"
fi

if want dashboard; then
  echo "bench: 7. the default fleet idle vs watched (${dash_secs} s per phase)"
  .venv/bin/python bench/dashboard_cost.py "$bin/handgate" "$results/dashboard.json" --phase "$dash_secs"
fi

"$bin/handgate-bench" machine --out "$results/machine_end.json"
# The sections this run did not measure: their last results, with the run that measured them.
"$bin/handgate-bench" carry --raw "$root/docs/benchmarks/raw" --results "$results" --measured "$only"
"$bin/handgate-bench" report --results "$results" --repo "$root" --out "$root/docs/benchmarks.md"
if [ -f "$results/dashboard.json" ]; then
  .venv/bin/python bench/dashboard_cost.py --report "$results/dashboard.json" --into "$root/docs/benchmarks.md"
fi
# Section 8 is make fleet's (root, Zenoh): kept as its last run wrote it, from its figures.
if [ -f "$root/docs/benchmarks/sites.json" ]; then
  .venv/bin/python tests/python/sites_measure.py report "$root/docs/benchmarks/sites.json" --into "$root/docs/benchmarks.md"
fi
# Keep the raw results of this run (with those it carried) next to the report, so every figure
# can be re-derived.
raw="$root/docs/benchmarks/raw"
rm -rf "$raw"
mkdir -p "$raw"
cp "$results"/* "$raw"/
echo "bench: load average at end: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "bench: wrote docs/benchmarks.md (raw results in docs/benchmarks/raw/)"
