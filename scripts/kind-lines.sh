#!/bin/sh
# Non-test lines per file of each kind folder in adapters/src (everything before a file's
# first `#[cfg(test)]`; blank lines and comment-only lines excluded), and per folder.
# Usage: scripts/kind-lines.sh [DIR...]   (default: every folder of adapters/src)
set -eu
cd "$(dirname "$0")/.."
dirs=${*:-$(ls -d adapters/src/*/)}
for d in $dirs; do
  total=0
  for f in $(find "$d" -name '*.rs' | sort); do
    case "$f" in *_tests.rs) continue ;; esac
    n=$(awk '/^#\[cfg\(test\)\]/{exit} { s=$0; sub(/^[ \t]+/, "", s); if (s != "" && s !~ /^\/\//) c++ } END {print c+0}' "$f")
    printf '%6d  %s\n' "$n" "$f"
    total=$((total + n))
  done
  printf '%6d  %s (total)\n\n' "$total" "$d"
done
