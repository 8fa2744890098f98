#!/usr/bin/env bash
# Reserves the DDS well-known ports of every test domain (0..232) from Linux's ephemeral port
# allocation (net.ipv4.ip_local_reserved_ports). Why: CycloneDDS binds each participant's
# unicast sockets to ephemeral ports (ParticipantIndex none), and domains from about 102 up
# have their discovery ports (7400 + 250 * domain + 0..15) inside the ephemeral range
# (32768-60999), so a parallel test's participant can take another domain's discovery port
# and that gateway fails with "failed to bind to ANY:<port>: address in use" (seen once in
# CI, domain 121). Needs root (or sudo without a password); idempotent; make test calls it
# (docs/development.md, "DDS domain ids for tests").
set -euo pipefail
f=/proc/sys/net/ipv4/ip_local_reserved_ports
ranges=""
for d in $(seq 0 232); do
  b=$((7400 + 250 * d))
  ranges="${ranges:+$ranges,}$b-$((b + 15))"
done
if [ "$(cat "$f")" = "$ranges" ]; then
  exit 0
fi
# One write(2): the sysctl refuses a value split over several (bash builtins write in chunks).
if [ -w "$f" ] && cat > "$f" 2>/dev/null <<< "$ranges"; then
  echo "reserve-dds-ports: DDS ports of domains 0-232 reserved from ephemeral allocation"
elif [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 \
  && sudo -n sh -c "cat > $f" 2>/dev/null <<< "$ranges"; then
  echo "reserve-dds-ports: DDS ports of domains 0-232 reserved from ephemeral allocation (sudo)"
else
  echo "reserve-dds-ports: cannot write $f (not root?): DDS ports stay allocatable (parallel DDS tests may, rarely, collide)" >&2
fi
