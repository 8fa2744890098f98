#!/usr/bin/env bash
# Builds the Zenoh tools that join sites (docs/deployment.md, "Sites over Zenoh") from their
# crates.io sources, never from a prebuilt binary: the router zenohd and the DDS plugin
# zenoh-plugin-dds (its cdylib libzenoh_plugin_dds.so, which zenohd loads at run time).
#
#   tools/zenoh/bin/zenohd
#   tools/zenoh/lib/libzenoh_plugin_dds.so
#   tools/zenoh/BUILD            what was built, with which rustc, and how long it took
#
# tools/ is git-ignored. Idempotent: when BUILD names this version and the current rustc and both
# files are there, it does nothing. Usage: scripts/zenoh-tools.sh [--force]
#
# One pinned version for both crates. zenohd loads a plugin only if it was built from the same
# zenoh version, with the same zenoh feature set and by the same rustc (zenoh-plugin-trait's
# compatibility check; Rust has no stable ABI), so the two are always rebuilt together, and a
# rustc change rebuilds both. Each is built with `--locked` against the Cargo.lock its crate
# publishes; the two locks pin the same zenoh and the same run-time crates. The plugin's source
# gets one fix before it is built (below: two calls that abort zenohd).
#
# The plugin builds CycloneDDS 11 (crate cyclors) with cmake and generates its bindings with
# bindgen (libclang): the Debian packages cmake and libclang-dev are installed when missing.
# Lean build: release, default features only (zenohd's zenoh/default, the plugin's
# dynamic_plugin); no DDS security, no shared memory, no stats, no other plugin. zenoh 1.10.2's
# default features include transport_tls (rustls), and its access control is not behind a
# feature: the sites' TLS link with mutual authentication and ACL needs nothing more. zenohd needs
# zenoh's default features anyway: the plugin's zenoh has them, and zenohd refuses a plugin whose
# zenoh features differ.
#
# The build goes to $CARGO_TARGET_DIR/zenoh-tools (default target/zenoh-tools), a directory this
# script owns: it is deleted once the two files are copied out, so the disk is returned (the
# crates.io downloads stay in cargo's own cache).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

version=1.10.2
out="$root/tools/zenoh"
stamp="$out/BUILD"

force=0
[ "${1:-}" = "--force" ] && force=1

rustc_v=$(rustc -V)
want="zenoh $version; $rustc_v; plugin fix spawn_runtime"
if [ "$force" -eq 0 ] && [ -x "$out/bin/zenohd" ] && [ -f "$out/lib/libzenoh_plugin_dds.so" ] \
  && [ -f "$stamp" ] && [ "$(head -n1 "$stamp")" = "$want" ]; then
  echo "zenoh-tools: up to date ($want) in tools/zenoh"
  exit 0
fi

source "$root/scripts/debian-packages.sh"
ensure_debian_packages zenoh-tools cmake libclang-dev g++ make

build="${CARGO_TARGET_DIR:-$root/target}/zenoh-tools"
rm -rf "$build"
mkdir -p "$build/fetch/src" "$build/src"
start=$(date +%s)

# The plugin's source as crates.io publishes it (checksummed by cargo): a throwaway manifest
# that depends on exactly this version, resolved by `cargo metadata`, which downloads it and says
# where it is. The empty [workspace] keeps cargo from adopting a workspace above the build dir.
cat > "$build/fetch/Cargo.toml" <<EOF
[package]
name = "handgate-zenoh-fetch"
version = "0.0.0"
edition = "2021"
publish = false

[lib]
path = "src/lib.rs"

[dependencies]
zenoh-plugin-dds = "=$version"

[workspace]
EOF
: > "$build/fetch/src/lib.rs"
plugin_manifest=$(cargo metadata --format-version 1 --manifest-path "$build/fetch/Cargo.toml" \
  | python3 -c '
import json, sys
m = json.load(sys.stdin)
print(next(p["manifest_path"] for p in m["packages"]
           if p["name"] == "zenoh-plugin-dds" and p["version"] == sys.argv[1]))' "$version")
plugin_src="$build/src/zenoh-plugin-dds-$version"
cp -r "$(dirname "$plugin_manifest")" "$plugin_src"
printf '\n[workspace]\n' >> "$plugin_src/Cargo.toml"

# One fix to the plugin's source, the same call in two places. Two of its tasks are started with
# tokio::task::spawn, which needs the caller to be inside a Tokio runtime of the plugin's own
# copy of tokio. In a plugin that zenohd loads at run time that is never the case on zenohd's
# threads: the plugin brings spawn_runtime (src/lib.rs) for exactly this, and uses it everywhere
# else. Unpatched, a sample that reaches a Zenoh->DDS route before the route's DDS writer exists
# (the subscriber callback's fallback, src/route_zenoh_dds.rs) panics there, the panic cannot
# unwind out of the plugin, and the whole zenohd aborts: seen on a link with sub-millisecond
# round trips (scripts/zenoh-sites.sh --no-netem), in most runs. The second call
# (src/dds_mgt.rs, readers with a max_frequencies period) is fixed alike. spawn_runtime runs
# the task on the current runtime when there is one, as before, and on the plugin's own
# otherwise.
fix_files=("$plugin_src/src/route_zenoh_dds.rs" "$plugin_src/src/dds_mgt.rs")
[ "$(cat "${fix_files[@]}" | grep -c 'tokio::task::spawn(')" -eq 2 ] \
  || { echo "zenoh-tools: zenoh-plugin-dds $version does not have the two calls this script fixes; review the fix" >&2; exit 1; }
sed -i 's/tokio::task::spawn(/crate::spawn_runtime(/' "${fix_files[@]}"

echo "zenoh-tools: building zenohd $version (cargo install --locked)"
cargo install zenohd --version "=$version" --locked --root "$build/install" --target-dir "$build"

echo "zenoh-tools: building zenoh-plugin-dds $version (cdylib, --locked)"
CARGO_TARGET_DIR="$build" cargo build --release --locked --lib --manifest-path "$plugin_src/Cargo.toml"

secs=$(($(date +%s) - start))
disk=$(du -sh "$build" | cut -f1)
mkdir -p "$out/bin" "$out/lib"
install -m 0755 "$build/install/bin/zenohd" "$out/bin/zenohd"
install -m 0644 "$build/release/libzenoh_plugin_dds.so" "$out/lib/libzenoh_plugin_dds.so"
{
  echo "$want"
  echo "built $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(nproc) cores in ${secs}s; build dir at the end $disk"
  echo "tools/zenoh: $(du -sh "$out/bin/zenohd" | cut -f1) zenohd, $(du -sh "$out/lib/libzenoh_plugin_dds.so" | cut -f1) libzenoh_plugin_dds.so"
} > "$stamp"
rm -rf "$build"
cat "$stamp"
