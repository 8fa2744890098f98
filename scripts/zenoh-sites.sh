#!/usr/bin/env bash
# Two sites joined only by a Zenoh link over TLS with mutual authentication, on this machine
# (docs/deployment.md, "Sites over Zenoh"): proves that the project's Zenoh recipe carries a
# robot's Dex3 hands and handgate's status to an operator site, and the operator's commands
# back, and that the robot's zenohd refuses every other site: one without a client certificate,
# one with a certificate of another CA, and one with a valid lab certificate whose name its
# access_control does not allow.
#
#   scripts/zenoh-sites.sh [--no-netem] [--domain N] [--logs DIR] [--measure FILE]
#
# Two network namespaces (names from $ZENOH_SITES_NS, default hg-zenoh: hg-zenoh-rb, hg-zenoh-op),
# made here and deleted on exit, whatever happens:
#
#   robot site (…-rb)                                     operator site (…-op)
#   handgate run (default profile: emulated Dex3 pair,    xr_dex3_client.py (unitree_sdk2py,
#     Dex1 pair; fronts rt/dex3/*, status)                  as xr_teleoperate's Dex3 controller)
#   zenohd + dds plugin (robot.json5)                     handgate status --once
#        |  DDS on zl-rb 10.77.1.1/24                     zenohd + dds plugin (operator.json5)
#        |                                                     |  DDS on zl-op 10.77.2.1/24
#   zw-rb 10.77.0.2/24  ====== the link, Zenoh TLS 7447 ======  zw-op 10.77.0.1/24
#
# Each site's DDS runs on an interface of its own (a veth pair inside the namespace, multicast
# on): the two DDS networks have no route between them, so whatever crosses, crosses through
# Zenoh. The plugin's CycloneDDS 11 and the 0.10 of handgate and unitree_sdk2py do not discover
# each other over a loopback without multicast, hence the veth. The link between the sites is
# shaped both ways as `netem delay 50ms 10ms loss 1% duplicate 1% reorder 25% 50%` would shape
# it, by tests/python/shaped_link.py between two TUN devices (this kernel has no sch_netem);
# --no-netem: a plain veth pair. No packet leaves the two namespaces.
#
# Identities: a lab keystore made for the run in LOGS/keystore by `handgate security` (below,
# lab_keystore: one lab CA; the robot site's zenohd "/robot", role gateway, its certificate
# naming 10.77.0.2; the operator site's "/operator", role operator; a third lab identity
# "/student", role observer), and a second CA's keystore in LOGS/keystore-other that issues
# another "/operator". The robot's zenohd logs its TLS
# handshakes (zenoh_link_tls=debug) and its access-control decisions
# (zenoh::net::routing::interceptor::access_control=trace), from which the refusals are counted.
#
# After the proof (and after the measurements, with --measure), the operator's zenohd stops and
# the negative tests run, each a separate zenohd at the operator site dialling the robot's, with
# an SDK client streaming commands to the left hand through it (tests/python/sites_measure.py
# blind) and a subscriber at the robot site watching the hand's state:
#   a. no client certificate (mTLS off on that side): the robot's listener ends the handshake;
#   b. a certificate of another CA, named "/operator": the handshake is refused, the name is
#      never looked at;
#   c. a valid lab certificate named "/student": the link comes up, every command is refused on
#      arrival by the robot's access_control;
#   d. the control: the same rig with the lab's "/operator": the hand moves, nothing refused.
# Each of a-c passes when the hand's state showed none of that site's commands, index_0 moved
# less than 0.02 rad, and the robot's zenohd counted the refusal (a, b: refused TLS handshakes;
# c: refused puts on rt/dex3/left/cmd); d when its commands were applied and none refused.
#
# Needs root (namespaces), tools/zenoh (scripts/zenoh-tools.sh), the handgate binary
# ($HANDGATE_BIN, default ${CARGO_TARGET_DIR:-target}/debug/handgate: cargo build -p handgate;
# its `handgate security` makes the certificates, with openssl), and .venv with unitree_sdk2py
# (scripts/setup.sh). Exit 0 when the state crossed to the operator, the operator's command
# reached the robot's hands, handgate's status crossed and the four identity tests passed.
#
# --measure FILE (make fleet, scripts/fleet.sh; docs/benchmarks.md "Sites over Zenoh"): handgate
# runs profiles/zenoh/sites-robot.toml instead (two emulated Dex3 hands; the right one's front
# with silence = "watchdog"), and the run measures, with tests/python/sites_measure.py, then
# writes its figures to FILE (JSON):
#   1. before the bridges start, the baseline: the latency client (tagged Dex3 commands at
#      100 Hz, each timed until the state echoes it) in the robot site, on handgate's network;
#   2. the proof above;
#   3. the link's own TCP round trip, operator -> robot;
#   4. the same latency client at the operator site, across Zenoh, and meanwhile the CPU of
#      both zenohd, handgate and the shaped link;
#   5. a 3 s cut of the link (shaped: tests/python/shaped_link.py's SIGUSR1/SIGUSR2; plain: the
#      operator's end down) while the client streams to the right hand: the watchdog trips, the
#      gateway's log times the hold and the resumption, a subscriber at the robot site sees
#      which commands reach the hand after the restore;
#   6. the gateway's counters (/metrics), handgate status --once at the operator site;
#   7. the identity tests above.
# $SITES_COMMAND names the command that ran it in FILE (default this script's command line).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

command="scripts/zenoh-sites.sh $*"
netem=1 domain=29 logs="" measure=""
while [ $# -gt 0 ]; do
  case "$1" in
    --no-netem) netem=0; shift ;;
    --domain) domain=${2:?--domain takes a DDS domain id}; shift 2 ;;
    --logs) logs=${2:?--logs takes a directory}; shift 2 ;;
    --measure) measure=${2:?--measure takes the file to write the figures to}; shift 2 ;;
    *) echo "usage: scripts/zenoh-sites.sh [--no-netem] [--domain N] [--logs DIR] [--measure FILE]" >&2; exit 2 ;;
  esac
done
command=${SITES_COMMAND:-$command}

[ "$(id -u)" -eq 0 ] || { echo "zenoh-sites: needs root (network namespaces)" >&2; exit 2; }
handgate=${HANDGATE_BIN:-${CARGO_TARGET_DIR:-$root/target}/debug/handgate}
py="$root/.venv/bin/python"
[ -x "$handgate" ] || { echo "zenoh-sites: no handgate binary at $handgate (cargo build -p handgate, or set HANDGATE_BIN)" >&2; exit 2; }
[ -x "$py" ] || { echo "zenoh-sites: no .venv (scripts/setup.sh)" >&2; exit 2; }
[ -x "$root/tools/zenoh/bin/zenohd" ] || { echo "zenoh-sites: tools/zenoh is not built (scripts/zenoh-tools.sh)" >&2; exit 2; }
command -v openssl >/dev/null || { echo "zenoh-sites: needs openssl (handgate security makes the run's certificates with it)" >&2; exit 2; }
"$handgate" security --help > /dev/null 2>&1 \
  || { echo "zenoh-sites: $handgate has no 'security' command (the lab keystore): rebuild it" >&2; exit 2; }

ns=${ZENOH_SITES_NS:-hg-zenoh}
rb="$ns-rb" op="$ns-op"
[ -n "$logs" ] || logs=$(mktemp -d /tmp/zenoh-sites.XXXXXX)
mkdir -p "$logs"
logs=$(cd "$logs" && pwd) # absolute: the wrapper and the keystore take paths under it
# handgate's own settings come from this script's flags, not from the caller's environment.
for v in $(env | sed -n 's/^\(HANDGATE_[A-Z0-9_]*\)=.*/\1/p'); do unset "$v"; done

pids=()
cleanup() {
  local rc=$?
  set +e
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  done
  # Anything still inside the namespaces (nothing, when every start above was a direct child).
  for n in "$rb" "$op"; do
    left=$(ip netns pids "$n" 2>/dev/null | paste -sd' ' -)
    [ -z "$left" ] || { echo "zenoh-sites: killing what is left in $n: $left" >&2; kill -KILL $left 2>/dev/null; }
  done
  ip netns del "$rb" 2>/dev/null
  ip netns del "$op" 2>/dev/null
  grep -h "^STATS " "$logs/link.log" 2>/dev/null | sed 's/^STATS /zenoh-sites: shaped link, packets per direction: /'
  # Say so if anything survived: a process of this run, or a namespace.
  survived=""
  for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && survived+=" pid $pid"; done
  for n in "$rb" "$op"; do ip netns list | grep -qx "$n\( .*\)\?" && survived+=" netns $n"; done
  if [ -n "$survived" ]; then
    echo "zenoh-sites: FAILED to clean up:$survived" >&2
    [ "$rc" -ne 0 ] || rc=1
  else
    echo "zenoh-sites: namespaces $rb and $op removed, no process of this run left; logs in $logs"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# In the foreground only: a function run with & is a subshell, whose $! is not the program's pid
# (the background starts below call ip netns exec directly, which execs the program).
in_rb() { ip netns exec "$rb" "$@"; }
in_op() { ip netns exec "$op" "$@"; }
# Runs a command to its end in the background and waits for it: bash runs a trap only between
# foreground commands, but interrupts `wait`, so a signal to this script cleans up at once. Give
# it a program (ip netns exec ...), not a function, so that its pid is the program's.
run() {
  "$@" &
  local pid=$!
  pids+=("$pid")
  wait "$pid"
}

# Waits up to SECONDS for a line of FILE matching PATTERN (a deadline, not a sleep for
# readiness); fails with the file's tail.
wait_log() {
  local file=$1 pattern=$2 secs=$3 what=$4
  local end=$((SECONDS + secs))
  until grep -q -- "$pattern" "$file" 2>/dev/null; do
    if [ "$SECONDS" -ge "$end" ]; then
      echo "zenoh-sites: FAILED: $what not seen within ${secs}s ($file):" >&2
      tail -n 30 "$file" >&2
      return 1
    fi
    sleep 0.2
  done
}

# The run's certificates, from the lab keystore (`handgate security`, SROS2 layout):
#   lab_keystore DIR CA_NAME                  DIR/public/ca.cert.pem, DIR/private/ca.key.pem, ...
#   lab_keystore DIR CA_NAME NAME ROLE [SAN]  + DIR/enclaves/NAME/{cert.pem,key.pem,...}: ECDSA
#                                               P-256, subject CN "/NAME", valid for a day; a
#                                               gateway or operator for this run's domain
lab_keystore() {
  local dir=$1 ca_name=$2 name=${3:-} role=${4:-} san=${5:-}
  [ -f "$dir/public/ca.cert.pem" ] || "$handgate" security init --keystore "$dir" --name "$ca_name" > /dev/null
  [ -n "$name" ] || return 0
  local opts=(--role "$role" --days 1)
  [ "$role" = observer ] || opts+=(--robot "$domain")
  [ -z "$san" ] || opts+=(--san "$san")
  "$handgate" security issue --keystore "$dir" "$name" "${opts[@]}" > /dev/null
}

echo "zenoh-sites: namespaces $rb (robot) and $op (operator), DDS domain $domain, logs in $logs"
for n in "$rb" "$op"; do
  ip netns del "$n" 2>/dev/null || true # a leftover of a killed run
  ip netns add "$n"
  ip netns exec "$n" ip link set lo up
done
# The Zenoh link: the only connection between the sites. Shaped: a user-space netem
# (tests/python/shaped_link.py: this kernel has no sch_netem) moving packets between a TUN device
# in each namespace; plain: a veth pair.
if [ "$netem" -eq 1 ]; then
  shape=(--delay-ms 50 --jitter-ms 10 --loss 0.01 --duplicate 0.01 --reorder 0.25 --reorder-corr 0.5)
  python3 "$root/tests/python/shaped_link.py" "$rb" zw-rb "$op" zw-op "${shape[@]}" \
    --max-seconds 900 > "$logs/link.log" 2>&1 &
  link=$!
  pids+=("$link")
  wait_log "$logs/link.log" "^READY" 10 "the shaped link's TUN devices"
  echo "zenoh-sites: Zenoh link shaped both ways as netem delay 50ms 10ms loss 1% duplicate 1% reorder 25% 50%"
else
  ip link add zw-rb netns "$rb" type veth peer name zw-op netns "$op"
fi
in_rb ip addr add 10.77.0.2/24 dev zw-rb
in_op ip addr add 10.77.0.1/24 dev zw-op
in_rb ip link set zw-rb up
in_op ip link set zw-op up
# Each site's DDS network: a veth pair inside the namespace, one end addressed, multicast on.
in_rb ip link add zl-rb type veth peer name zl-rbp
in_rb ip addr add 10.77.1.1/24 dev zl-rb
in_op ip link add zl-op type veth peer name zl-opp
in_op ip addr add 10.77.2.1/24 dev zl-op
for l in zl-rb zl-rbp; do in_rb ip link set "$l" multicast on up; done
for l in zl-op zl-opp; do in_op ip link set "$l" multicast on up; done

# Nothing but the link joins the sites: each one's routes are its own two networks.
for n in "$rb" "$op"; do
  echo "zenoh-sites: routes in $n: $(ip netns exec "$n" ip -4 route | awk '{print $1" dev "$3}' | paste -sd, -)"
done

# The identities: the lab's keystore and another CA's (above, lab_keystore).
keystore="$logs/keystore" other="$logs/keystore-other"
rm -rf "$keystore" "$other"
lab_keystore "$keystore" "handgate lab CA" robot gateway "IP:10.77.0.2"
lab_keystore "$keystore" "handgate lab CA" operator operator
lab_keystore "$keystore" "handgate lab CA" student observer
lab_keystore "$other" "another CA" operator operator
lab_ca="$keystore/public/ca.cert.pem"
for n in robot operator student; do
  echo "zenoh-sites: identity $n: $(openssl x509 -in "$keystore/enclaves/$n/cert.pem" -noout -subject -issuer -ext subjectAltName 2>/dev/null | paste -sd' ' - | tr -s ' ')"
done
echo "zenoh-sites: identity other-CA operator: $(openssl x509 -in "$other/enclaves/operator/cert.pem" -noout -subject -issuer | paste -sd' ' -)"
# The bridge of each site: its identity from the keystore.
identity() { # KEYSTORE NAME: the wrapper's certificate options, in the array ident
  ident=(--ca "$lab_ca" --cert "$1/enclaves/$2/cert.pem" --key "$1/enclaves/$2/key.pem")
}

# Robot site: handgate serving its default profile's fronts on zl-rb (--measure: the measured
# run's profile, its dashboard and /metrics on a port of the namespace's own), then the robot's
# zenohd.
profile=() http_port=0
if [ -n "$measure" ]; then
  profile=(--profile "$root/profiles/zenoh/sites-robot.toml")
  http_port=8780
  metrics_url="http://127.0.0.1:$http_port/"
  uptime_before=$(uptime)
fi
ip netns exec "$rb" "$handgate" run "${profile[@]}" --domain "$domain" --interface zl-rb \
  --http-port "$http_port" > "$logs/handgate.log" 2>&1 &
gateway=$!
pids+=("$gateway")
wait_log "$logs/handgate.log" "handgate serving" 60 "handgate serving"

measure_py=("$py" "$root/tests/python/sites_measure.py")
rate=100 samples=1000
if [ -n "$measure" ]; then
  # 1. The baseline: the same client and gateway with no Zenoh (the client on handgate's own
  # network, in the robot site), before any bridge exists.
  echo "zenoh-sites: measure: baseline latency, the client in the robot site on zl-rb (no Zenoh), $samples commands at $rate Hz"
  run ip netns exec "$rb" "${measure_py[@]}" latency --domain "$domain" --interface zl-rb --side left \
    --count "$samples" --rate "$rate" --tag-base 1000000 --out "$logs/latency-direct.json" \
    > "$logs/latency-direct.log" 2>&1
  sed -n 's/^RESULT /zenoh-sites: measure: direct: /p' "$logs/latency-direct.log"
fi

# The robot's zenohd logs each TLS handshake it accepts (with the client's name) or refuses, and
# each access-control decision: the refusals below are counted from these lines.
identity "$keystore" robot
ip netns exec "$rb" env RUST_LOG="info,zenoh_link_tls=debug,zenoh::net::routing::interceptor::access_control=trace" \
  "$root/scripts/zenoh-bridge.sh" robot --dds-interface zl-rb --domain "$domain" \
  --listen tls/10.77.0.2:7447 "${ident[@]}" > "$logs/zenohd-robot.log" 2>&1 &
zenohd_robot=$!
pids+=("$zenohd_robot")
identity "$keystore" operator
ip netns exec "$op" "$root/scripts/zenoh-bridge.sh" operator --dds-interface zl-op --domain "$domain" \
  --robot 10.77.0.2 "${ident[@]}" > "$logs/zenohd-operator.log" 2>&1 &
zenohd_operator=$!
pids+=("$zenohd_operator")

# Operator site: xr_teleoperate's Dex3 start-up (wait for both hands' state, nonzero), then its
# command stream closing index_0 until the state reads it back.
echo "zenoh-sites: operator: xr_dex3_client.py on zl-op, domain $domain"
ip netns exec "$op" "$py" "$root/tests/python/xr_dex3_client.py" --domain "$domain" --interface zl-op \
  --timeout 60 > "$logs/client.log" 2>&1 &
client=$!
pids+=("$client")
wait_log "$logs/client.log" "^WAITED " 90 "the client's wait for the robot's state"
waited=$(grep "^WAITED " "$logs/client.log")
echo "zenoh-sites: robot -> operator, rt/dex3/{left,right}/state: $waited"
grep -q '"nonzero": true' <<<"$waited" \
  || { echo "zenoh-sites: FAILED: the robot's Dex3 state never reached the operator site" >&2; exit 1; }
wait_log "$logs/client.log" "^RESULT " 90 "the client's command result"
result=$(grep "^RESULT " "$logs/client.log")
echo "zenoh-sites: operator -> robot, rt/dex3/{left,right}/cmd, read back in the state: $result"
grep -q '"converged": true' <<<"$result" \
  || { echo "zenoh-sites: FAILED: the operator's command did not reach the robot's hands" >&2; exit 1; }
wait "$client" || true

# handgate's status heartbeat, read at the operator site.
status_once() {
  echo "zenoh-sites: operator: handgate status --once (rt/handgate/status across the link)"
  run ip netns exec "$op" "$handgate" status --domain "$domain" --interface zl-op --once --timeout 30 \
    > "$logs/status.txt"
  sed 's/^/  /' "$logs/status.txt"
}
status_once

# The allow-list at work: the routes each side's plugin made, and the topics it refused.
for side in robot operator; do
  f="$logs/zenohd-$side.log"
  routes=$(sed -n 's/.*Route \(DDS->Zenoh\|Zenoh->DDS\) (\([^ ]*\) -> .*created.*/\1 \2/p' "$f" | sort -u | paste -sd, -)
  refused=$(sed -n 's/.*resource \([^ ]*\) as it is not allowed.*/\1/p' "$f" | sort -u | paste -sd' ' -)
  echo "zenoh-sites: $side plugin routes: ${routes:-none}"
  echo "zenoh-sites: $side plugin refused (allow-list): ${refused:-none}"
done
# The listeners: the robot's zenohd on the TLS port only, the operator's on none.
for side in robot operator; do
  n=$rb pid=$zenohd_robot
  [ "$side" = robot ] || { n=$op; pid=$zenohd_operator; }
  socks=$(ip netns exec "$n" ss -Hltnp 2>/dev/null | { grep "pid=$pid," || true; } | awk '{print $4}' | sort -u | paste -sd' ' -)
  echo "zenoh-sites: $side zenohd listens on: ${socks:-nothing}"
  case "$side:$socks" in
    robot:10.77.0.2:7447 | operator:) ;;
    *) echo "zenoh-sites: FAILED: the $side zenohd listens on ${socks:-nothing}, not on the TLS port alone" >&2; exit 1 ;;
  esac
done

# 7. (or the end of the proof without --measure) The identity tests (see the top of this file).
# What the robot's zenohd counted, from its log: TLS handshakes it refused, and commands its
# access_control refused on arrival (the ACL's trace line for each message, below).
# A refused handshake is the TLS listener's accept error (zenoh-link-tls 1.10.2 logs it at warn,
# with a hint about open files whatever the error was), e.g. "peer sent no certificates" or
# "invalid peer certificate: UnknownIssuer".
tls_refused_re='zenoh_link_tls::unicast.*Hint: increase the system open file limit'
count_tls_refused() { grep -cE "$tls_refused_re" "$logs/zenohd-robot.log" || true; }
# An ACL refusal of a put, one line per message: "Using cached result: ZID is unauthorized to Put
# (ingress) on KEY", the decision for a message whose key the router knows (every command of a
# declared publisher). Not the lines "ZID on SUBJECT is unauthorized to ...": those are written
# per subject while a key's decisions are cached, for every kind of message, whether one comes
# or not (a permitted operator has them too, for the subject it matches and is not allowed by).
count_acl_put_refused() { grep -c "Using cached result: [0-9a-f]* is unauthorized to Put (ingress) on rt/dex3/left/cmd" "$logs/zenohd-robot.log" || true; }
# What the robot's zenohd refused from line N+1 of its log on: the handshake errors and the ACL's
# per-message refusals, each with its count.
refused_since() {
  tail -n +$(($1 + 1)) "$logs/zenohd-robot.log" | sed 's/\x1b\[[0-9;]*m//g' \
    | sed -n -e "s/.*zenoh_link_tls::unicast: \(.*\)\. Hint: increase the system open file limit\./TLS handshake refused: \1/p" \
      -e 's/.*Using cached result: [0-9a-f]* is unauthorized to \(.*\)/ACL refused \1/p' \
    | sort | uniq -c | awk '{n=$1; $1=""; print substr($0,2)" x"n}' | paste -sd';' -
}
# Waits up to SECONDS for a count (a function) to reach a value; fails with what it reached, or
# at once when the robot-side observer's log (WATCH) says the hand took this site's commands.
wait_count() {
  local fn=$1 want=$2 secs=$3 what=$4 watch=$5
  local end=$((SECONDS + secs))
  until [ "$($fn)" -ge "$want" ]; do
    if grep -q "^SHOWN " "$watch"; then
      echo "zenoh-sites: FAILED: the robot's hand applied a command of this site ($(grep "^SHOWN " "$watch")) while waiting for: $what ($($fn) of $want)" >&2
      return 1
    fi
    [ "$SECONDS" -lt "$end" ] || { echo "zenoh-sites: FAILED: $what: $($fn) of $want within ${secs}s" >&2; return 1; }
    sleep 0.2
  done
}
# identity_test NAME WHAT EXPECT(refused|moved) COUNTED(tls_handshakes|acl_puts|-) KEYSTORE ENCLAVE [-- ZENOHD_ARGS]
identity_test() {
  local name=$1 what=$2 expect=$3 counted=$4 ks=$5 enclave=$6
  shift 6
  local base=$((4000000 + 100000 * $(printf '%d' "'$name")))
  local f="$logs/identity-$name"
  echo "zenoh-sites: identity $name: $what"
  # The robot's left hand, watched at the robot site; where it is now picks the test's target.
  ip netns exec "$rb" "${measure_py[@]}" observe --domain "$domain" --interface zl-rb --side left \
    --watch-from $((base + 1)) --watch-move 0.2 --out "$f-observe.json" > "$f-observe.log" 2>&1 &
  local observer=$!
  pids+=("$observer")
  wait_log "$f-observe.log" "^READY" 30 "the robot-side observer" || return 1
  local q target
  q=$(sed -n 's/^READY //p' "$f-observe.log" | "$py" -c 'import json,sys; print(",".join(f"{x:.4f}" for x in json.load(sys.stdin)["q"]))')
  # index_0 0.4 rad away from where it is, towards the middle of its range.
  target=$("$py" -c 'import sys; q=float(sys.argv[1].split(",")[5]); print(f"{q + 0.4 if q < 0 else q - 0.4:.4f}")' "$q")
  local tls0 acl0 line0
  tls0=$(count_tls_refused) acl0=$(count_acl_put_refused) line0=$(wc -l < "$logs/zenohd-robot.log")
  identity "$ks" "$enclave"
  ip netns exec "$op" "$root/scripts/zenoh-bridge.sh" operator --dds-interface zl-op --domain "$domain" \
    --robot 10.77.0.2 "${ident[@]}" "$@" > "$f-zenohd.log" 2>&1 &
  local zpid=$!
  pids+=("$zpid")
  ip netns exec "$op" "${measure_py[@]}" blind --domain "$domain" --interface zl-op --side left \
    --tag-base "$base" --q="$q" --index0="$target" --out "$f-blind.json" > "$f-blind.log" 2>&1 &
  local client=$!
  pids+=("$client")
  wait_log "$f-blind.log" "^STREAMING" 30 "the test client's stream" || return 1
  # The test site's bridge took the client's commands into Zenoh: from here on, a link would
  # carry them to the robot.
  wait_log "$f-zenohd.log" 'Route DDS->Zenoh (rt/dex3/left/cmd ' 60 "the test site's bridge routing the client's commands" || return 1
  case "$expect:$counted" in
    refused:tls_handshakes)
      # Two more attempts of this site refused, after its bridge had the commands.
      local t1
      t1=$(count_tls_refused)
      wait_count count_tls_refused $((t1 + 2)) 60 "handshakes refused by the robot's zenohd" "$f-observe.log" || return 1 ;;
    refused:acl_puts)
      # A second's worth of the stream refused on arrival.
      wait_count count_acl_put_refused $((acl0 + 100)) 60 "commands refused by the robot's access_control" "$f-observe.log" || return 1 ;;
    moved:-)
      wait_log "$f-observe.log" "^MOVED" 60 "the hand moving to the control's commands" || return 1 ;;
  esac
  kill -TERM "$client"
  wait "$client" || true
  kill -TERM "$zpid"
  wait "$zpid" || true
  kill -TERM "$observer"
  wait "$observer" || true
  local tls acl
  tls=$(($(count_tls_refused) - tls0)) acl=$(($(count_acl_put_refused) - acl0))
  local judged
  judged=$("${measure_py[@]}" judge --name "$name" --what "$what" --expect "$expect" --counted "$counted" \
    --observe "$f-observe.json" --blind "$f-blind.json" --refusals "tls_handshakes=$tls" "acl_puts=$acl" \
    --detail "$(refused_since "$line0")" --out "$f.json") || { echo "zenoh-sites: FAILED: identity $name: $judged" >&2; return 1; }
  echo "zenoh-sites: identity $name: $judged"
}
identity_tests() {
  echo "zenoh-sites: identity tests: the operator's zenohd stops; each test site is a zenohd of its own at the operator site"
  kill -TERM "$zenohd_operator"
  wait "$zenohd_operator" || true
  identity_test a "no client certificate (mTLS off at that site)" refused tls_handshakes "$keystore" operator \
    -- --cfg transport/link/tls/enable_mtls:false || return 1
  identity_test b "a certificate of another CA, named /operator" refused tls_handshakes "$other" operator || return 1
  identity_test c "a valid lab certificate named /student, which the ACL does not allow" refused acl_puts \
    "$keystore" student || return 1
  identity_test d "the control: the lab's /operator through the same rig" moved - "$keystore" operator || return 1
  # Who the robot's zenohd let in over the whole run, by certificate name.
  echo "zenoh-sites: the robot's zenohd accepted TLS links from: $(sed -n 's/.*Accepted TLS connection.*Common Name: \(.*\)\.$/\1/p' "$logs/zenohd-robot.log" | sort | uniq -c | awk '{print $2" x"$1}' | paste -sd' ' -)"
  echo "zenoh-sites: the robot's zenohd refused TLS handshakes: $(grep -E "$tls_refused_re" "$logs/zenohd-robot.log" | sed 's/\x1b\[[0-9;]*m//g; s/.*zenoh_link_tls::unicast: //; s/\. Hint: .*//' | sort | uniq -c | awk '{n=$1; $1=""; print substr($0,2)" x"n}' | paste -sd, -)"
}

if [ -z "$measure" ]; then
  identity_tests || { echo "zenoh-sites: FAILED: the identity tests" >&2; exit 1; }
  echo "zenoh-sites: OK"
  exit 0
fi

# The measured run (--measure), after the proof above.
procs=(handgate="$gateway" zenohd_robot="$zenohd_robot" zenohd_operator="$zenohd_operator")
[ "$netem" -eq 0 ] || procs+=(shaped_link="$link")
metrics() { ip netns exec "$rb" "${measure_py[@]}" metrics --url "$metrics_url" --out "$logs/metrics-$1.json"; }

# 3. The link alone: TCP round trips operator -> robot, at the commands' rate.
echo "zenoh-sites: measure: the link's own TCP round trip, $samples messages at $rate Hz"
ip netns exec "$rb" "${measure_py[@]}" echo-server --listen 10.77.0.2:7448 > "$logs/echo-server.log" 2>&1 &
pids+=($!)
wait_log "$logs/echo-server.log" "^READY" 10 "the echo server"
run ip netns exec "$op" "${measure_py[@]}" echo-client --to 10.77.0.2:7448 --count "$samples" --rate "$rate" \
  --out "$logs/echo.json" > "$logs/echo-client.log" 2>&1
sed -n 's/^RESULT /zenoh-sites: measure: link: /p' "$logs/echo-client.log"

# 4. The latency across Zenoh, and the CPU meanwhile.
echo "zenoh-sites: measure: latency across Zenoh, the client at the operator site on zl-op, $samples commands at $rate Hz"
"${measure_py[@]}" cpu --out "$logs/cpu-latency-start.json" "${procs[@]}"
run ip netns exec "$op" "${measure_py[@]}" latency --domain "$domain" --interface zl-op --side left \
  --count "$samples" --rate "$rate" --tag-base 2000000 --out "$logs/latency-zenoh.json" \
  > "$logs/latency-zenoh.log" 2>&1
"${measure_py[@]}" cpu --out "$logs/cpu-latency-end.json" "${procs[@]}"
sed -n 's/^RESULT /zenoh-sites: measure: across Zenoh: /p' "$logs/latency-zenoh.log"

# 5. A 3 s cut while the client streams to the right hand (silence = "watchdog").
cut_link() { # on | off
  if [ "$netem" -eq 1 ]; then
    local want=CUT signal=USR1
    [ "$1" = on ] || { want=RESTORED; signal=USR2; }
    local before
    before=$(grep -c "^$want " "$logs/link.log" || true)
    kill -"$signal" "$link"
    local end=$((SECONDS + 5))
    until [ "$(grep -c "^$want " "$logs/link.log" || true)" -gt "$before" ]; do
      [ "$SECONDS" -lt "$end" ] || { echo "zenoh-sites: FAILED: the shaped link did not say $want" >&2; return 1; }
      sleep 0.01
    done
  else
    local state=down word=CUT
    [ "$1" = on ] || { state=up; word=RESTORED; }
    ip -n "$op" link set zw-op "$state"
    "$py" -c "import time; print('$word', f'{time.time():.6f}', f'{time.monotonic():.6f}')" >> "$logs/link.log"
  fi
}
echo "zenoh-sites: measure: a 3 s cut of the link while the client streams to the right hand"
ip netns exec "$rb" "${measure_py[@]}" observe --domain "$domain" --interface zl-rb --side right \
  --out "$logs/observe-cut.json" > "$logs/observe-cut.log" 2>&1 &
observer=$!
pids+=("$observer")
wait_log "$logs/observe-cut.log" "^READY" 30 "the robot-side observer"
ip netns exec "$op" "${measure_py[@]}" latency --domain "$domain" --interface zl-op --side right \
  --count 6000 --rate "$rate" --tag-base 3000000 --out "$logs/stream-cut.json" > "$logs/stream-cut.log" 2>&1 &
streamer=$!
pids+=("$streamer")
wait_log "$logs/stream-cut.log" "^ECHOED" 60 "the streaming client's first command echoed"
metrics stream
sleep 3 # the stream before the cut: part of the experiment, not a wait for readiness
metrics before-cut
resumed='commands resumed after the silence action.*"dex3_right"'
resumed_before=$(grep -c "$resumed" "$logs/handgate.log" || true)
cut_link on
sleep 3 # the cut
cut_link off
end=$((SECONDS + 30))
until [ "$(grep -c "$resumed" "$logs/handgate.log" || true)" -gt "$resumed_before" ]; do
  [ "$SECONDS" -lt "$end" ] || { echo "zenoh-sites: FAILED: the right hand's commands did not resume within 30 s of the restore" >&2; exit 1; }
  sleep 0.2
done
sleep 1 # the stream after the restore
metrics after-cut
kill -TERM "$streamer" "$observer"
wait "$streamer" || { echo "zenoh-sites: FAILED: the streaming client" >&2; tail -n 20 "$logs/stream-cut.log" >&2; exit 1; }
wait "$observer" || { echo "zenoh-sites: FAILED: the observer" >&2; tail -n 20 "$logs/observe-cut.log" >&2; exit 1; }

# 6. The end: counters, status across the link, the whole run's CPU, the link's counts.
metrics final
status_once
"${measure_py[@]}" cpu --out "$logs/cpu-end.json" "${procs[@]}"
identity_tests || { echo "zenoh-sites: FAILED: the identity tests" >&2; exit 1; }
if [ "$netem" -eq 1 ]; then
  kill -TERM "$link"
  wait "$link" || true
  shape_text="netem delay 50ms 10ms loss 1% duplicate 1% reorder 25% 50%"
else
  shape_text=""
fi
"${measure_py[@]}" summarize --logs "$logs" --out "$measure" --command "$command" \
  --uptime-before "$uptime_before" --uptime-after "$(uptime)" --shaped "$netem" --shape "$shape_text" \
  --domain "$domain"
echo "zenoh-sites: measure: figures in $measure"
echo "zenoh-sites: OK"
