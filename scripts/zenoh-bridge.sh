#!/usr/bin/env bash
# Starts zenohd with the DDS plugin as one site of a Zenoh link between sites
# (docs/deployment.md, "Sites over Zenoh"), with the project's config for that side:
#
#   scripts/zenoh-bridge.sh robot    --dds-interface IFACE --ca CA --cert CERT --key KEY [--domain N] [--listen ENDPOINT] [-- ZENOHD_ARGS...]
#   scripts/zenoh-bridge.sh operator --dds-interface IFACE --ca CA --cert CERT --key KEY --robot ADDR[:PORT] [--domain N] [-- ZENOHD_ARGS...]
#
#   robot | operator   profiles/zenoh/robot.json5 or profiles/zenoh/operator.json5
#   --dds-interface    the network interface of this site's DDS traffic, where handgate's fronts
#                      (robot) or the DDS clients (operator) are. The plugin's CycloneDDS (11)
#                      binds to it through CYCLONEDDS_URI. It must be a real interface with
#                      multicast, not lo: CycloneDDS 11 and the 0.10 of handgate and
#                      unitree_sdk2py do not discover each other over a loopback without
#                      multicast.
#   --ca               the lab CA's certificate (PEM; KEYSTORE/public/ca.cert.pem of `handgate
#                      security init`): the only issuer this side trusts for the other's.
#   --cert, --key      this site's certificate and private key (PEM; KEYSTORE/enclaves/NAME/
#                      cert.pem and key.pem of `handgate security issue`). The robot's must
#                      name its address as a subjectAltName (--san IP:ADDR); the operator's
#                      name ("/operator") is what the robot's access_control allows.
#   --domain           the DDS domain to bridge (the config's default: 0, a G1's).
#   --listen           robot: the endpoint to listen on instead of tls/0.0.0.0:7447 (tls/ only).
#   --robot            operator: the robot site's address; port 7447 unless given. The link is
#                      TLS (tls/ADDR:PORT).
#   after --            passed to zenohd as they are (e.g. --cfg KEY:VALUE).
#
# zenohd and libzenoh_plugin_dds.so come from tools/zenoh (scripts/zenoh-tools.sh builds them).
# zenohd replaces this script (exec): stop it with a signal. RUST_LOG sets its log level
# (default info).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

usage() {
  sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

side=${1:-}
case "$side" in
  robot | operator) shift ;;
  *) usage ;;
esac

iface="" domain="" listen="" robot="" ca="" cert="" key=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --dds-interface) iface=${2:?--dds-interface takes an interface name}; shift 2 ;;
    --domain) domain=${2:?--domain takes a DDS domain id}; shift 2 ;;
    --listen) listen=${2:?--listen takes an endpoint, e.g. tls/10.0.0.2:7447}; shift 2 ;;
    --robot) robot=${2:?--robot takes the address of the robot site}; shift 2 ;;
    --ca) ca=${2:?--ca takes the lab CA certificate file}; shift 2 ;;
    --cert) cert=${2:?--cert takes the site certificate file}; shift 2 ;;
    --key) key=${2:?--key takes the site private key file}; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    -h | --help) usage ;;
    *) echo "zenoh-bridge: unknown argument $1" >&2; usage ;;
  esac
done

[ -n "$iface" ] || { echo "zenoh-bridge: --dds-interface is required (the interface of this site's DDS traffic)" >&2; exit 2; }
[ "$iface" != "lo" ] || { echo "zenoh-bridge: --dds-interface lo: CycloneDDS 11 (the plugin) and 0.10 (handgate, unitree_sdk2py) do not discover each other over a loopback without multicast; use a real interface" >&2; exit 2; }
[ -e "/sys/class/net/$iface" ] || { echo "zenoh-bridge: interface $iface does not exist on this host" >&2; exit 2; }

# The certificate files: all three, readable, and paths zenohd's --cfg takes as a JSON5 string.
for opt in ca cert key; do
  f=${!opt}
  [ -n "$f" ] || { echo "zenoh-bridge: --$opt is required (the link is TLS with mutual authentication; see --help)" >&2; exit 2; }
  [ -r "$f" ] || { echo "zenoh-bridge: --$opt $f: not a readable file" >&2; exit 2; }
  case "$f" in *\"* | *\\*) echo "zenoh-bridge: --$opt $f: a path with a quote or a backslash" >&2; exit 2 ;; esac
done
abs() { (cd "$(dirname "$1")" && printf '%s/%s' "$PWD" "$(basename "$1")"); }
ca=$(abs "$ca") cert=$(abs "$cert") key=$(abs "$key")

zenohd="$root/tools/zenoh/bin/zenohd"
plugin_dir="$root/tools/zenoh/lib"
[ -x "$zenohd" ] && [ -f "$plugin_dir/libzenoh_plugin_dds.so" ] \
  || { echo "zenoh-bridge: tools/zenoh is not built; run scripts/zenoh-tools.sh" >&2; exit 2; }

tls=transport/link/tls
args=(-c "$root/profiles/zenoh/$side.json5" --plugin-search-dir "$plugin_dir"
  --cfg "$tls/root_ca_certificate:\"$ca\"")
case "$side" in
  robot)
    [ -z "$robot" ] || { echo "zenoh-bridge: --robot is for the operator side" >&2; exit 2; }
    if [ -n "$listen" ]; then
      case "$listen" in
        tls/*) args+=(-l "$listen") ;;
        *) echo "zenoh-bridge: --listen $listen: the robot listens on TLS only (tls/ADDR:PORT)" >&2; exit 2 ;;
      esac
    fi
    args+=(--cfg "$tls/listen_certificate:\"$cert\"" --cfg "$tls/listen_private_key:\"$key\"")
    ;;
  operator)
    [ -n "$robot" ] || { echo "zenoh-bridge: operator: --robot ADDR[:PORT] is required (the robot site's address)" >&2; exit 2; }
    [ -z "$listen" ] || { echo "zenoh-bridge: --listen is for the robot side" >&2; exit 2; }
    case "$robot" in
      *:*) args+=(-e "tls/$robot") ;;
      *) args+=(-e "tls/$robot:7447") ;;
    esac
    args+=(--cfg "$tls/connect_certificate:\"$cert\"" --cfg "$tls/connect_private_key:\"$key\"")
    ;;
esac
[ -z "$domain" ] || args+=(--cfg "plugins/dds/domain:$domain")

# The plugin's CycloneDDS on this site's DDS interface only, with multicast on it whatever
# CycloneDDS makes of the interface (discovery with handgate and the SDK clients is by
# multicast). A CYCLONEDDS_URI already set (peers where multicast is blocked, say) still
# applies after it: CycloneDDS reads a comma-separated list of configurations in order.
own="<CycloneDDS><Domain><General><Interfaces><NetworkInterface name=\"$iface\" multicast=\"true\"/></Interfaces></General></Domain></CycloneDDS>"
export CYCLONEDDS_URI="$own${CYCLONEDDS_URI:+,$CYCLONEDDS_URI}"
export RUST_LOG=${RUST_LOG:-info}
exec "$zenohd" "${args[@]}" "${extra[@]}"
