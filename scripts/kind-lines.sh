#!/bin/sh
# Non-test lines per file of each kind folder in adapters/src: every line before a file's
# first `#[cfg(test)]` (the measure of the kind-kit issue), and of those the lines of code
# (blank and comment-only lines left out); per file and per folder.
# Usage: scripts/kind-lines.sh [DIR...]   (default: every folder of adapters/src)
set -eu
cd "$(dirname "$0")/.."
dirs=${*:-$(ls -d adapters/src/*/)}
printf '%6s %6s  %s\n' lines code file
for d in $dirs; do
  tl=0; tc=0
  for f in $(find "$d" -name '*.rs' | sort); do
    case "$f" in *_tests.rs) continue ;; esac
    set -- $(awk '/^#\[cfg\(test\)\]/{exit} { n++; s=$0; sub(/^[ \t]+/, "", s); if (s != "" && s !~ /^\/\//) c++ } END {print n+0, c+0}' "$f")
    printf '%6d %6d  %s\n' "$1" "$2" "$f"
    tl=$((tl + $1)); tc=$((tc + $2))
  done
  printf '%6d %6d  %s (total)\n\n' "$tl" "$tc" "$d"
done
