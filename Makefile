# handgate: two commands on a fresh Debian machine with the Rust toolchain.
#   make run   - install what is missing, build, start the gateway on its embedded default
#                profile (the simulated fleet on DDS domain 1), with the Foxglove live server
#                on ws://127.0.0.1:8765 (docs/foxglove.md)
#   make test  - install what is missing (incl. the interop venv), reserve the test domains'
#                DDS ports, then the whole suite (with the short reliability suites and a 15 s
#                smoke run of every fuzz target); green on a 2-core machine with a core busy
#   make test-loaded - make test 3 times while a busy loop keeps one core busy; records date,
#                load and duration of each run (scripts/test-loaded.sh, docs/development.md)
#   make reliability - the full reliability suites on the release binary (docs/reliability.md):
#                every state rate held to ±5 % of nominal, 10,000 malformed
#                samples per front, every fault cycle repeated, a 10-minute soak of the sim-all
#                fleet with a client on every front, isolation (one front flooded or driven at
#                10 kHz for 60 s), each fuzz target 10 minutes, mutation testing of the
#                safety core (make mutants) and make valgrind
#   make valgrind - the DDS paths under valgrind memcheck (scripts/valgrind.sh all, ~2 min;
#                setup installs Debian's valgrind): the gateway on the default and sim-all
#                profiles driven by unitree_sdk2py, every wire type through the SDK
#   make mutants - cargo-mutants on the safety core (scripts/mutants.sh; hours for the gateway
#                set); not part of make test
#   make bench - release benchmarks (minutes); rewrites docs/benchmarks.md
#   make fleet - as root: the simulated lab of robots (the lab and export tests, release) and two
#                sites joined by a shaped Zenoh link, measured (latency, the bridges' CPU, dropped
#                commands, a 3 s link cut); rewrites docs/benchmarks.md's "Sites over Zenoh"
#                (scripts/fleet.sh; builds zenohd and its DDS plugin once, 12-19 min on 2 cores)
SHELL := /bin/bash
CARGO ?= cargo
ARGS ?=
# The gateway's features: the Foxglove WebSocket live server (docs/foxglove.md; about 18 s more
# of a clean debug build, no TLS or compression). The tests build the binary with it too.
FEATURES ?= --features handgate/foxglove

.PHONY: run test test-loaded ports setup build lint fmt bench fleet reliability mutants valgrind fixtures clean-venv

setup:
	@scripts/setup.sh

build: setup
	$(CARGO) build --release -p handgate $(FEATURES)

run: build
	$(CARGO) run --release -p handgate $(FEATURES) -- run $(ARGS)

# Keeps the test domains' DDS ports out of the kernel's ephemeral allocation (the script says
# why; root, or sudo without a password; otherwise it warns and the suite runs without).
ports:
	@scripts/reserve-dds-ports.sh

test: setup ports
	$(CARGO) build --workspace --all-targets $(FEATURES)
	$(CARGO) test --workspace --no-fail-fast $(FEATURES)
	scripts/fuzz.sh smoke 15
	$(CARGO) clippy --workspace --all-targets $(FEATURES) -- -D warnings
	$(CARGO) fmt --all -- --check

# make test-loaded: RUNS runs of make test beside a busy loop (scripts/test-loaded.sh).
RUNS ?= 3
test-loaded: setup ports
	scripts/test-loaded.sh $(RUNS)

FUZZ_SECS ?= 600
# The rate suites on the release binary, every rate held both ways (HANDGATE_RELIABILITY_FULL;
# in make test a rate below nominal is reported, not held: docs/development.md "A busy machine").
reliability: setup ports
	$(CARGO) build --release -p handgate $(FEATURES)
	HANDGATE_RELIABILITY_FULL=1 $(CARGO) test --release -p handgate-tests --test reliability --test fronts_service --test dex1_auto -- --nocapture --test-threads=1
	$(CARGO) test --release -p handgate-tests --test motion -- --ignored --nocapture
	scripts/fuzz.sh full $(FUZZ_SECS)
	scripts/mutants.sh all
	scripts/valgrind.sh all

valgrind: setup
	scripts/valgrind.sh all

# MUTANTS_SET: adapters (about 25 min), fronts (minutes), gateway (about 20 min: every mutant
# rebuilds the binary and runs the end-to-end safety tests), kinds (the new kinds' tables) or all.
MUTANTS_SET ?= all
mutants: setup
	scripts/mutants.sh $(MUTANTS_SET)

bench: setup
	@scripts/bench.sh

fleet: setup
	CARGO="$(CARGO)" FEATURES="$(FEATURES)" scripts/fleet.sh

lint:
	$(CARGO) clippy --workspace --all-targets $(FEATURES) -- -D warnings
	$(CARGO) fmt --all -- --check

fmt:
	$(CARGO) fmt --all

fixtures: setup
	.venv/bin/python tests/python/gen_golden.py

clean-venv:
	rm -rf .venv .cyclonedds-home
