#!/usr/bin/env bash
# Starts zenohd with the DDS plugin as one site of a Zenoh link between sites
# (docs/deployment.md, "Sites over Zenoh"), with the project's config for that side:
#
#   scripts/zenoh-bridge.sh robot    --dds-interface IFACE [--domain N] [--listen ENDPOINT] [-- ZENOHD_ARGS...]
#   scripts/zenoh-bridge.sh operator --dds-interface IFACE --robot ADDR[:PORT] [--domain N] [-- ZENOHD_ARGS...]
#
#   robot | operator   profiles/zenoh/robot.json5 or profiles/zenoh/operator.json5
#   --dds-interface    the network interface of this site's DDS traffic, where handgate's fronts
#                      (robot) or the DDS clients (operator) are. The plugin's CycloneDDS (11)
#                      binds to it through CYCLONEDDS_URI. It must be a real interface with
#                      multicast, not lo: CycloneDDS 11 and the 0.10 of handgate and
#                      unitree_sdk2py do not discover each other over a loopback without
#                      multicast.
#   --domain           the DDS domain to bridge (the config's default: 0, a G1's).
#   --listen           robot: the endpoint to listen on instead of tcp/0.0.0.0:7447.
#   --robot            operator: the robot site's address; port 7447 unless given.
#   after --            passed to zenohd as they are (e.g. --cfg KEY:VALUE).
#
# zenohd and libzenoh_plugin_dds.so come from tools/zenoh (scripts/zenoh-tools.sh builds them).
# zenohd replaces this script (exec): stop it with a signal. RUST_LOG sets its log level
# (default info).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

usage() {
  sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

side=${1:-}
case "$side" in
  robot | operator) shift ;;
  *) usage ;;
esac

iface="" domain="" listen="" robot=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --dds-interface) iface=${2:?--dds-interface takes an interface name}; shift 2 ;;
    --domain) domain=${2:?--domain takes a DDS domain id}; shift 2 ;;
    --listen) listen=${2:?--listen takes an endpoint, e.g. tcp/10.0.0.2:7447}; shift 2 ;;
    --robot) robot=${2:?--robot takes the address of the robot site}; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "zenoh-bridge: unknown argument $1" >&2; usage ;;
  esac
done

[ -n "$iface" ] || { echo "zenoh-bridge: --dds-interface is required (the interface of this site's DDS traffic)" >&2; exit 2; }
[ "$iface" != "lo" ] || { echo "zenoh-bridge: --dds-interface lo: CycloneDDS 11 (the plugin) and 0.10 (handgate, unitree_sdk2py) do not discover each other over a loopback without multicast; use a real interface" >&2; exit 2; }
[ -e "/sys/class/net/$iface" ] || { echo "zenoh-bridge: interface $iface does not exist on this host" >&2; exit 2; }

zenohd="$root/tools/zenoh/bin/zenohd"
plugin_dir="$root/tools/zenoh/lib"
[ -x "$zenohd" ] && [ -f "$plugin_dir/libzenoh_plugin_dds.so" ] \
  || { echo "zenoh-bridge: tools/zenoh is not built; run scripts/zenoh-tools.sh" >&2; exit 2; }

args=(-c "$root/profiles/zenoh/$side.json5" --plugin-search-dir "$plugin_dir")
case "$side" in
  robot)
    [ -z "$robot" ] || { echo "zenoh-bridge: --robot is for the operator side" >&2; exit 2; }
    [ -z "$listen" ] || args+=(-l "$listen")
    ;;
  operator)
    [ -n "$robot" ] || { echo "zenoh-bridge: operator: --robot ADDR[:PORT] is required (the robot site's address)" >&2; exit 2; }
    [ -z "$listen" ] || { echo "zenoh-bridge: --listen is for the robot side" >&2; exit 2; }
    case "$robot" in
      *:*) args+=(-e "tcp/$robot") ;;
      *) args+=(-e "tcp/$robot:7447") ;;
    esac
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
