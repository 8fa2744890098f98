# handgate: two commands on a fresh Debian machine with the Rust toolchain.
#   make run   - install what is missing, build, start the gateway on its embedded default
#                profile (the simulated fleet on DDS domain 1)
#   make test  - install what is missing (incl. the interop venv), then the whole suite
#   make bench - release benchmarks (minutes); rewrites docs/benchmarks.md
SHELL := /bin/bash
CARGO ?= cargo
ARGS ?=

.PHONY: run test setup build lint fmt bench reliability fixtures clean-venv

setup:
	@scripts/setup.sh

build: setup
	$(CARGO) build --release -p handgate

run: build
	$(CARGO) run --release -p handgate -- run $(ARGS)

test: setup
	$(CARGO) build --workspace --all-targets
	$(CARGO) test --workspace --no-fail-fast
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	$(CARGO) fmt --all -- --check

bench: setup
	@scripts/bench.sh

lint:
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	$(CARGO) fmt --all -- --check

fmt:
	$(CARGO) fmt --all

fixtures: setup
	.venv/bin/python tests/python/gen_golden.py

clean-venv:
	rm -rf .venv .cyclonedds-home
