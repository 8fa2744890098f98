#!/usr/bin/env bash
# libFuzzer (cargo fuzz) for handgate on a STABLE toolchain. See docs/reliability.md.
#
#   scripts/fuzz.sh install            cargo-fuzz 0.13.2 into .tools/bin (idempotent)
#   scripts/fuzz.sh build              build every target (release, debug assertions, no sanitizer)
#   scripts/fuzz.sh seeds              (re)write fuzz/corpus/<target>/seed_* from the fixtures
#   scripts/fuzz.sh run TARGET SECS    build, seed, fuzz one target for SECS seconds (corpus kept in fuzz/corpus)
#   scripts/fuzz.sh exec TARGET SECS   fuzz an already built target (no build, no seeding)
#   scripts/fuzz.sh smoke [SECS]       every target for SECS (default 15) seconds: what `make test` runs
#   scripts/fuzz.sh full [SECS]        every target for SECS (default 600) seconds, one at a time
#   scripts/fuzz.sh list               the targets
#
# Stable rustc refuses the -Z flags cargo fuzz passes; RUSTC_BOOTSTRAP=1 lets this one build
# use them (nothing else is built with it). Sanitizer: none (handgate is safe Rust apart from the
# DDS bindings, which the targets do not call; ASan would halve the exec rate on a shared machine).
# Debug assertions are on, so integer overflow panics count as findings.
# Final libFuzzer stats (execs, cov, ft, corpus) of every run go to fuzz/logs/<target>.log.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
export PATH="$root/.tools/bin:$PATH"
export RUSTC_BOOTSTRAP=1
fuzz_target_dir=${FUZZ_TARGET_DIR:-${CARGO_TARGET_DIR:+$CARGO_TARGET_DIR/fuzz}}
fuzz_target_dir=${fuzz_target_dir:-$root/fuzz/target}
CARGO_FUZZ_VERSION=0.13.2

TARGETS=(dex3_state_frame dex3_emulator_frame cdr_decode front_decode dynamixel_packet dynamixel_fast_sync_reply modbus_rtu_frame modbus_mbap rh56_proto robotiq_front)
BUILD_FLAGS=(-O -a -s none --target-dir "$fuzz_target_dir")
triple=$(rustc -vV | sed -n 's/^host: //p')
bindir="$fuzz_target_dir/$triple/release"

install() {
  if [ -x "$root/.tools/bin/cargo-fuzz" ] && "$root/.tools/bin/cargo-fuzz" --version | grep -q "$CARGO_FUZZ_VERSION"; then
    return
  fi
  echo "fuzz: installing cargo-fuzz $CARGO_FUZZ_VERSION into .tools/"
  cargo install --locked --quiet --root "$root/.tools" --version "$CARGO_FUZZ_VERSION" cargo-fuzz
}

build() {
  install
  cargo fuzz build "${BUILD_FLAGS[@]}"
}

seeds() {
  mkdir -p fuzz/corpus
  "$bindir/gen_seeds" "$root/tests/fixtures/golden" "$root/fuzz/corpus"
}

# run TARGET SECS [extra libFuzzer args]
run() {
  local t=$1 secs=$2
  shift 2
  mkdir -p "fuzz/corpus/$t" fuzz/artifacts/"$t" fuzz/logs
  local log="fuzz/logs/$t.log"
  echo "fuzz: $t for ${secs}s"
  set +e
  "$bindir/$t" "fuzz/corpus/$t" -max_total_time="$secs" -print_final_stats=1 \
    -artifact_prefix="fuzz/artifacts/$t/" -rss_limit_mb=2048 -max_len=4096 "$@" >"$log" 2>&1
  local rc=$?
  set -e
  # The last progress line (cov/ft/corp/exec/s) and the final stats.
  grep -E '^#[0-9]+' "$log" | tail -n 1 || true
  grep -E '^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)' "$log" || true
  if [ $rc -ne 0 ]; then
    echo "fuzz: $t FAILED (exit $rc); crash input in fuzz/artifacts/$t/, log $log" >&2
    grep -E 'panicked|ERROR|SUMMARY' "$log" | head -n 5 >&2 || true
    return $rc
  fi
}

all() {
  local secs=$1
  build
  seeds
  local failed=0
  for t in "${TARGETS[@]}"; do
    run "$t" "$secs" || failed=1
  done
  return $failed
}

case "${1:-}" in
  install) install ;;
  build) build ;;
  seeds) seeds ;;
  run) [ $# -ge 3 ] || { echo "usage: $0 run TARGET SECS" >&2; exit 2; }; build; seeds; run "$2" "$3" ;;
  exec) [ $# -ge 3 ] || { echo "usage: $0 exec TARGET SECS" >&2; exit 2; }; run "$2" "$3" ;;
  smoke) all "${2:-15}" ;;
  full) all "${2:-600}" ;;
  list) printf '%s\n' "${TARGETS[@]}" ;;
  *) sed -n '2,18p' "$0"; exit 2 ;;
esac
