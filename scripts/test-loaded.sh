#!/usr/bin/env bash
# make test RUNS times (default 3) while a busy loop keeps one core busy the whole time: the
# check that the suite stays green on a 2-core machine with other work on it (docs/development.md,
# "A busy machine"). Usage: scripts/test-loaded.sh [RUNS]   (make test-loaded RUNS=3)
#
# Each run's whole output goes to $TEST_LOADED_DIR (default target/test-loaded)/run-<date>-<i>.log.
# One markdown table row per run is printed (and appended to summary.md there): start (UTC),
# result, tests passed / failed (summed over cargo's "test result" lines), duration, the 1-minute
# load average sampled every 5 s (median / max), the busy loop's CPU and the whole machine's
# CPU over the run (all CPUs' busy time, /proc/stat; 200 % is both cores of a 2-core machine).
# Exits non-zero when any run failed.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
out=${TEST_LOADED_DIR:-target/test-loaded}
mkdir -p "$out"
make=${MAKE:-make}
hz=$(getconf CLK_TCK)

# Busy CPU ticks of the whole machine: user nice system irq softirq steal.
machine_ticks() { awk '/^cpu /{print $2+$3+$4+$7+$8+$9}' /proc/stat; }
# CPU ticks of process $1 (utime + stime).
proc_ticks() { awk '{print $14+$15}' "/proc/$1/stat"; }

sh -c 'while :; do :; done' &
busy=$!
sampler=""
cleanup() {
  kill "$busy" 2>/dev/null || true
  [ -n "$sampler" ] && kill "$sampler" 2>/dev/null || true
}
trap cleanup EXIT

header="| start (UTC) | result | tests passed / failed | duration | load avg 1 min (median / max) | busy loop CPU | machine CPU |"
echo "$header"
echo "|---|---|---|---|---|---|---|"
[ -f "$out/summary.md" ] || printf '%s\n|---|---|---|---|---|---|---|\n' "$header" > "$out/summary.md"

failed=0
for i in $(seq 1 "$runs"); do
  start=$(date -u +%Y-%m-%dT%H:%M:%SZ)
  log="$out/run-$(date -u +%Y%m%dT%H%M%S)-$i.log"
  loads="$out/load-$i.txt"
  : > "$loads"
  (while :; do cut -d' ' -f1 /proc/loadavg >> "$loads"; sleep 5; done) &
  sampler=$!
  b0=$(proc_ticks "$busy")
  m0=$(machine_ticks)
  t0=$(date +%s.%N)
  if "$make" test > "$log" 2>&1; then result=passed; else result=FAILED; failed=1; fi
  t1=$(date +%s.%N)
  b1=$(proc_ticks "$busy")
  m1=$(machine_ticks)
  kill "$sampler" 2>/dev/null || true
  wait "$sampler" 2>/dev/null || true
  sampler=""
  counts=$(awk '/^test result:/{for(i=1;i<=NF;i++){if($(i+1) ~ /^passed/)p+=$i; if($(i+1) ~ /^failed/)f+=$i}} END{printf "%d / %d", p, f}' "$log")
  row=$(awk -v t0="$t0" -v t1="$t1" -v b0="$b0" -v b1="$b1" -v m0="$m0" -v m1="$m1" -v hz="$hz" \
    -v start="$start" -v result="$result" -v counts="$counts" -v loads="$loads" 'BEGIN {
      n = 0
      while ((getline l < loads) > 0) { v[n++] = l + 0 }
      # median and max of the samples (insertion sort: a few hundred values)
      for (a = 1; a < n; a++) { x = v[a]; for (b = a - 1; b >= 0 && v[b] > x; b--) v[b + 1] = v[b]; v[b + 1] = x }
      med = n ? v[int(n / 2)] : 0; max = n ? v[n - 1] : 0
      d = t1 - t0
      printf "| %s | %s | %s | %dm%02ds | %.2f / %.2f | %.0f %% | %.0f %% |", start, result, counts, int(d / 60), int(d) % 60, med, max, 100 * (b1 - b0) / hz / d, 100 * (m1 - m0) / hz / d
    }')
  echo "$row"
  echo "$row" >> "$out/summary.md"
  if [ "$result" != passed ]; then
    echo "  run $i failed: $log" >&2
    grep -E "^(test .* FAILED|failures:|    [a-z_:]+$)|panicked at" "$log" | head -20 >&2 || true
  fi
done
exit "$failed"
