#!/usr/bin/env bash
# Mutation testing of handgate's safety core with cargo-mutants. See docs/reliability.md.
#
#   scripts/mutants.sh install      cargo-mutants 25.3.1 into .tools/bin (idempotent)
#   scripts/mutants.sh adapters     the mapping, command slot and tables: adapters/src/mapping.rs,
#                                   control.rs, tables.rs, */table.rs; each mutant runs only the
#                                   fast table tests (adapters/tests/mapping.rs, safety.rs)
#   scripts/mutants.sh fronts       the front wire codecs and the front core (its decisions:
#                                   adapters/src/dex3/front.rs, dex1/front.rs, front/*.rs);
#                                   each mutant runs the adapters' unit tests and the front
#                                   codec tests (adapters/tests/front_codecs.rs): seconds per mutant
#   scripts/mutants.sh gateway      the runtime's front tasks (the loop around the front core:
#                                   gateway/src/runtime/fronts.rs); each mutant runs the gateway's
#                                   unit tests and the end-to-end safety tests against the mutated
#                                   binary (slow: about a minute per mutant)
#   scripts/mutants.sh kinds        the tables of the kinds added in issue 13
#                                   (adapters/src/{inspire_dfx,inspire_ftp,brainco}/table.rs);
#                                   each mutant runs those kinds' test files (their tables
#                                   against literal numbers from docs/sources.md) and the
#                                   mapping/safety tests
#   scripts/mutants.sh all          adapters, fronts and gateway
#   scripts/mutants.sh summary DIR  caught / missed / unviable / timeout per file of a finished run
#
# Each run works on a copy of the tree (cargo-mutants' default; the copy includes target/ so
# the dependencies are not rebuilt) and writes target/mutants/<set>/mutants.out/ (outcomes.json,
# caught.txt, missed.txt, unviable.txt, timeout.txt), then prints the per-file summary.
# One job at a time (-j 1): the machine is small and shared. MUTANTS_ARGS adds options, e.g.
# MUTANTS_ARGS="--list" or MUTANTS_ARGS="-F hold_measured".
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
export PATH="$root/.tools/bin:$PATH"
CARGO_MUTANTS_VERSION=25.3.1
read -r -a extra <<<"${MUTANTS_ARGS:-}"

install() {
  if [ -x "$root/.tools/bin/cargo-mutants" ] && "$root/.tools/bin/cargo-mutants" mutants --version | grep -q "$CARGO_MUTANTS_VERSION"; then
    return
  fi
  echo "mutants: installing cargo-mutants $CARGO_MUTANTS_VERSION into .tools/"
  cargo install --locked --quiet --root "$root/.tools" --version "$CARGO_MUTANTS_VERSION" cargo-mutants
}

# summary DIR: per-file counts from cargo-mutants' outcome lists.
summary() {
  local out=$1/mutants.out
  [ -d "$out" ] || { echo "mutants: no $out" >&2; return 2; }
  printf '%-40s %7s %7s %9s %8s %9s\n' file caught missed unviable timeout caught%
  local files
  files=$(cat "$out"/{caught,missed,unviable,timeout}.txt 2>/dev/null | cut -d: -f1 | sort -u)
  local f c m u t
  for f in $files; do
    c=$(grep -c "^$f:" "$out/caught.txt" 2>/dev/null || true)
    m=$(grep -c "^$f:" "$out/missed.txt" 2>/dev/null || true)
    u=$(grep -c "^$f:" "$out/unviable.txt" 2>/dev/null || true)
    t=$(grep -c "^$f:" "$out/timeout.txt" 2>/dev/null || true)
    printf '%-40s %7s %7s %9s %8s %8s%%\n' "$f" "${c:-0}" "${m:-0}" "${u:-0}" "${t:-0}" \
      "$(awk -v c="${c:-0}" -v m="${m:-0}" -v t="${t:-0}" 'BEGIN { v = c + m + t; printf "%.0f", v ? 100 * c / v : 100 }')"
  done
  echo "missed:"
  sed 's/^/  /' "$out/missed.txt" 2>/dev/null || true
}

adapters() {
  install
  local dir=target/mutants/adapters
  mkdir -p "$dir"
  set +e
  cargo mutants -j 1 --copy-target=true --no-shuffle -o "$dir" --timeout 120 --build-timeout 600 \
    -p handgate-adapters \
    -f adapters/src/mapping.rs -f adapters/src/control.rs \
    -f 'adapters/src/*/table.rs' \
    --test-package handgate-adapters \
    "${extra[@]}" -- --test mapping --test safety
  local rc=$?
  set -e
  summary "$dir" || true
  return $rc
}

gateway() {
  install
  local dir=target/mutants/gateway
  mkdir -p "$dir"
  set +e
  # The end-to-end tests are in another package (handgate-tests); cargo-mutants 25.3.1 tests
  # only the mutated package whatever --test-package says, so the package is named to cargo.
  cargo mutants -j 1 --copy-target=true --no-shuffle -o "$dir" --timeout 300 --build-timeout 900 \
    -f gateway/src/runtime/fronts.rs \
    "${extra[@]}" -- --package handgate-tests --lib --test safety_e2e
  local rc=$?
  set -e
  summary "$dir" || true
  return $rc
}

fronts() {
  install
  local dir=target/mutants/fronts
  mkdir -p "$dir"
  set +e
  cargo mutants -j 1 --copy-target=true --no-shuffle -o "$dir" --timeout 120 --build-timeout 600 \
    -p handgate-adapters \
    -f adapters/src/dex3/front.rs -f adapters/src/dex1/front.rs -f 'adapters/src/front/*.rs' \
    --test-package handgate-adapters \
    "${extra[@]}" -- --lib --test front_codecs
  local rc=$?
  set -e
  summary "$dir" || true
  return $rc
}

kinds() {
  install
  local dir=target/mutants/kinds
  mkdir -p "$dir"
  set +e
  cargo mutants -j 1 --copy-target=true --no-shuffle -o "$dir" --timeout 120 --build-timeout 600 \
    -p handgate-adapters \
    -f adapters/src/inspire_dfx/table.rs -f adapters/src/inspire_ftp/table.rs -f adapters/src/brainco/table.rs \
    "${extra[@]}" -- --test inspire_dfx --test inspire_ftp --test brainco --test mapping --test safety
  local rc=$?
  set -e
  summary "$dir" || true
  return $rc
}

case "${1:-}" in
  install) install ;;
  adapters) adapters ;;
  fronts) fronts ;;
  gateway) gateway ;;
  kinds) kinds ;;
  all) rc=0; adapters || rc=$?; fronts || rc=$?; gateway || rc=$?; exit $rc ;;
  summary) [ $# -ge 2 ] || { echo "usage: $0 summary DIR" >&2; exit 2; }; summary "$2" ;;
  *) sed -n '2,28p' "$0"; exit 2 ;;
esac
