# Sourced by the project's scripts (scripts/setup.sh, scripts/zenoh-tools.sh):
#   ensure_debian_packages TAG PKG...
# installs those of the Debian packages PKG... that are not installed (dpkg-query says so), with
# apt-get, as root or through sudo; does nothing when all are. TAG starts its message.
ensure_debian_packages() {
  local tag=$1 sudo_cmd="" p
  shift
  local missing=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ "${#missing[@]}" -gt 0 ] || return 0
  echo "$tag: installing Debian packages: ${missing[*]}"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}" >/dev/null
}
