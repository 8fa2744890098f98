#!/usr/bin/env bash
# make fleet: the lab of robots and the sites over Zenoh, run and measured (issue #28;
# docs/deployment.md "A lab of robots" and "Sites over Zenoh", docs/benchmarks.md "8. Sites over
# Zenoh"). Needs root (network namespaces) and the network once (crates.io, for the Zenoh tools).
#
#   1. builds what it needs: scripts/zenoh-tools.sh (zenohd and the DDS plugin from crates.io
#      into tools/zenoh; nothing when they are there: 12 to 19 minutes on a 2-core machine
#      otherwise), the release handgate with $FEATURES (the tests build it with the foxglove
#      feature, so with the default FEATURES they reuse it)
#   2. the simulated lab: cargo test --release -p handgate-tests --test lab --test export
#      (tests/tests/lab.rs, tests/tests/export.rs); a test that skips (not root) fails the target
#   3. the two sites over the shaped Zenoh link (TLS with mutual authentication, the robot's
#      access control), measured, then the identity tests (no client certificate, another CA,
#      a lab certificate the ACL does not allow, and the permitted operator as the control):
#      scripts/zenoh-sites.sh --measure
#   4. docs/benchmarks.md's section "8. Sites over Zenoh" from the figures, which are kept in
#      docs/benchmarks/sites.json (make bench re-inserts the section from it)
#
# Steps 2 and 3 each run in a sandbox of their own: new mount and PID namespaces with a private
# /run/netns (unshare --kill-child). Their scripts and tests clean up after themselves; the
# sandbox makes sure of it: when a step ends, however it ends (a failure, Ctrl-C, a kill), every
# process it started is killed with its PID namespace and every network namespace it made goes
# with its mount namespace. Nothing outside can see those namespaces, so two runs never collide.
#
# Environment: CARGO_TARGET_DIR (default target/), CARGO, FEATURES (default
# --features handgate/foxglove), FLEET_ONLY ("lab sites", the default, or one of them),
# FLEET_LOGS (the logs' directory; default a new one under /tmp).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
cargo=${CARGO:-cargo}
features=${FEATURES:---features handgate/foxglove}
target=${CARGO_TARGET_DIR:-$root/target}
only=${FLEET_ONLY:-"lab sites"}
want() { [[ " $only " == *" $1 "* ]]; }

[ "$(id -u)" -eq 0 ] || { echo "fleet: needs root: the lab and the sites are network namespaces (sudo make fleet)" >&2; exit 2; }
command -v unshare >/dev/null || { echo "fleet: needs unshare (util-linux)" >&2; exit 2; }
logs=${FLEET_LOGS:-$(mktemp -d /tmp/fleet.XXXXXX)}
mkdir -p "$logs"
start=$SECONDS
echo "fleet: logs in $logs"

# A step in its own mount and PID namespaces with a private /run/netns (see above).
sandbox() {
  mkdir -p /run/netns
  # shellcheck disable=SC2016 # expanded by the sandbox's shell
  unshare --mount --pid --fork --kill-child --mount-proc \
    bash -c 'mount -t tmpfs -o size=1m fleet-netns /run/netns && exec "$@"' fleet "$@"
}

[ -x .venv/bin/python ] || scripts/setup.sh
echo "fleet: 1. build: the Zenoh tools (scripts/zenoh-tools.sh), the release handgate"
scripts/zenoh-tools.sh
# shellcheck disable=SC2086 # FEATURES is a list of arguments
$cargo build --release -p handgate $features

if want lab; then
  echo "fleet: 2. the simulated lab: cargo test --release -p handgate-tests --test lab --test export"
  # The tests build (or reuse) the release handgate with the foxglove feature, as above.
  if ! sandbox $cargo test --release -p handgate-tests --test lab --test export -- --nocapture 2>&1 \
    | tee "$logs/lab.log"; then
    echo "fleet: FAILED: the simulated lab (log: $logs/lab.log)" >&2
    exit 1
  fi
  if grep -q "^SKIPPED" "$logs/lab.log"; then
    echo "fleet: FAILED: a lab test skipped: $(grep '^SKIPPED' "$logs/lab.log" | head -n1)" >&2
    exit 1
  fi
fi

if want sites; then
  echo "fleet: 3. the two sites over the shaped Zenoh link, TLS, measured, and the identity tests (scripts/zenoh-sites.sh --measure)"
  results="$logs/sites.json"
  sandbox env HANDGATE_BIN="$target/release/handgate" \
    SITES_COMMAND="make fleet (scripts/zenoh-sites.sh --measure FILE --logs DIR)" \
    scripts/zenoh-sites.sh --measure "$results" --logs "$logs/sites"
  echo "fleet: 4. docs/benchmarks.md, section \"8. Sites over Zenoh\" (figures in docs/benchmarks/sites.json)"
  mkdir -p docs/benchmarks
  cp "$results" docs/benchmarks/sites.json
  .venv/bin/python tests/python/sites_measure.py report docs/benchmarks/sites.json --into docs/benchmarks.md
fi
echo "fleet: OK in $((SECONDS - start)) s"
