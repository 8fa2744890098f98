#!/usr/bin/env bash
# Installs what handgate needs on a fresh Debian machine that has only the Rust toolchain.
# Idempotent: every step checks first. Usage: scripts/setup.sh [--no-python]
#   - Debian packages: cyclonedds-dev 0.10.2 (the version on Unitree robots), its tools,
#     libclang-dev (bindgen), libusb-1.0-0-dev (rusb), pkg-config, iproute2 (the two-hosts
#     test's network namespaces), chromium (the dashboard's browser test), valgrind (make
#     valgrind, the DDS paths under memcheck), openssl (`handgate security`'s keystore, its
#     DDS Security test and the doctor's security checks), faketime (the secured lab's client
#     whose clock says its expired certificate is still valid, tests/tests/secure_lab.rs);
#     systemd (only for
#     systemd-analyze, which checks the shipped unit; nothing is started).
#   - tests/browser/node_modules/ (git-ignored): playwright-core from tests/browser's
#     package-lock.json (npm ci), which drives Debian's chromium in the dashboard's test.
#   - .venv/ (git-ignored): cyclonedds==0.10.2 built against that library, and the official
#     unitree-sdk2 (unitree_sdk2py) for the interop tests; mcap readers and websockets for the
#     recording and Foxglove tests; ROS 2 Jazzy's rclpy over Fast DDS from PyPI wheels
#     (scripts/ros2-wheels.txt) for the real-ROS 2 test.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

want_python=1
[ "${1:-}" = "--no-python" ] && want_python=0

sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"

source "$root/scripts/debian-packages.sh"
ensure_debian_packages setup cyclonedds-dev cyclonedds-tools libclang-dev libusb-1.0-0-dev pkg-config \
  iproute2 chromium valgrind openssl faketime
# systemd-analyze checks the shipped unit (tests/tests/least_privilege.rs: offline exposure
# <= 2.0, verify). Debian's systemd package installs cleanly in a container without an init
# (it does not start anything); no recommends (dbus, timesyncd), only the tool is needed.
if ! command -v systemd-analyze >/dev/null 2>&1; then
  echo "setup: installing Debian package: systemd (for systemd-analyze)"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends systemd >/dev/null
fi
ver=$(dpkg-query -W -f='${Version}' cyclonedds-dev)
case "$ver" in
  0.10.2*) ;;
  *) echo "setup: warning: cyclonedds-dev is $ver; Unitree robots and cyclonedds-rs 0.6.5 want 0.10.2" >&2 ;;
esac

# The dashboard's browser test (tests/tests/dashboard.rs) drives Debian's chromium (above) with
# playwright-core, which downloads no browser of its own. npm ci installs exactly the lock's
# versions; skipped when node_modules already holds them.
browser="$root/tests/browser"
if command -v npm >/dev/null 2>&1 && command -v node >/dev/null 2>&1; then
  if ! node -e '
    const fs = require("fs"), path = require("path"), dir = process.argv[1];
    const lock = JSON.parse(fs.readFileSync(path.join(dir, "package-lock.json"), "utf8"));
    for (const [p, meta] of Object.entries(lock.packages || {})) {
      if (!p.startsWith("node_modules/")) continue;
      let have = null;
      try { have = JSON.parse(fs.readFileSync(path.join(dir, p, "package.json"), "utf8")).version; } catch (e) {}
      if (have !== meta.version) process.exit(1);
    }' "$browser"; then
    echo "setup: installing tests/browser's npm packages (playwright-core) with npm ci"
    (cd "$browser" && npm ci --no-audit --no-fund --loglevel=error)
  fi
else
  echo "setup: warning: node and npm not found; the dashboard's browser test (tests/tests/dashboard.rs) needs Node.js >= 20" >&2
fi

[ "$want_python" -eq 1 ] || exit 0

# The Python cyclonedds 0.10.2 package has no wheel for this Python: it builds against the
# installed C library and wants CYCLONEDDS_HOME laid out as lib/ include/ bin/.
multiarch=$(gcc -print-multiarch 2>/dev/null || echo x86_64-linux-gnu)
home="$root/.cyclonedds-home"
mkdir -p "$home"
ln -sfn "/usr/lib/$multiarch" "$home/lib"
ln -sfn /usr/include "$home/include"
ln -sfn /usr/bin "$home/bin"

py=${PYTHON:-python3}
venv="$root/.venv"
if [ ! -x "$venv/bin/python" ]; then
  echo "setup: creating $venv"
  "$py" -m venv "$venv"
fi
vpy="$venv/bin/python"
if [ "$("$vpy" -m pip show cyclonedds 2>/dev/null | sed -n 's/^Version: //p')" != "0.10.2" ]; then
  echo "setup: building cyclonedds==0.10.2 (Python) against the system library"
  "$vpy" -m pip install -q "setuptools<70" wheel
  CYCLONEDDS_HOME="$home" "$vpy" -m pip install -q --no-build-isolation "cyclonedds==0.10.2"
fi
if ! "$vpy" -m pip show -q unitree-sdk2 >/dev/null 2>&1; then
  echo "setup: installing unitree-sdk2==1.0.1 (unitree_sdk2py)"
  "$vpy" -m pip install -q "unitree-sdk2==1.0.1"
fi
# Independent MCAP readers for the recording tests (docs/recording.md).
if [ "$("$vpy" -m pip show mcap-ros2-support 2>/dev/null | sed -n 's/^Version: //p')" != "0.6.0" ] \
  || [ "$("$vpy" -m pip show mcap 2>/dev/null | sed -n 's/^Version: //p')" != "1.6.0" ]; then
  echo "setup: installing mcap==1.6.0 and mcap-ros2-support==0.6.0"
  "$vpy" -m pip install -q "mcap==1.6.0" "mcap-ros2-support==0.6.0"
fi
# The HTTP server's tests: prometheus-client's own text-format parser reads /metrics; the
# websockets package is the dashboard's protocol client (docs/dashboard.md) and the Foxglove
# live server's (tests/python/foxglove_client.py speaks foxglove.websocket.v1 itself,
# docs/foxglove.md).
if [ "$("$vpy" -m pip show prometheus-client 2>/dev/null | sed -n 's/^Version: //p')" != "0.26.0" ] \
  || [ "$("$vpy" -m pip show websockets 2>/dev/null | sed -n 's/^Version: //p')" != "17.4" ]; then
  echo "setup: installing prometheus-client==0.26.0 and websockets==17.4"
  "$vpy" -m pip install -q "prometheus-client==0.26.0" "websockets==17.4"
fi
# A real ROS 2 for tests/tests/ros2_real.rs: Jazzy's rclpy over rmw_fastrtps_cpp (Fast DDS) with
# sensor_msgs and diagnostic_msgs, from PyPI's ros-jazzy-* wheels (no ROS installation, no apt
# repository), every package of the closure pinned in scripts/ros2-wheels.txt. The wheels add
# ros_wheels_bootstrapper.pth, which re-executes the venv's interpreter once with LD_LIBRARY_PATH
# set to their libraries; the tests set the rest (handgate_tests::ros2_env).
ros2_reqs="$root/scripts/ros2-wheels.txt"
# Exit 1 unless every `name==version` line of the file named by argv[1] is installed.
pinned_check='
import sys
from importlib.metadata import version, PackageNotFoundError
missing = []
for line in open(sys.argv[1]):
    line = line.split("#")[0].strip()
    if not line:
        continue
    name, want = line.split("==")
    try:
        have = version(name)
    except PackageNotFoundError:
        have = None
    if have != want:
        missing.append(f"{name} {have} != {want}")
sys.exit(1 if missing else 0)'
if ! "$vpy" -c "$pinned_check" "$ros2_reqs"; then
  echo "setup: installing ROS 2 Jazzy wheels (rclpy, rmw_fastrtps_cpp, sensor_msgs, diagnostic_msgs) from $ros2_reqs"
  "$vpy" -m pip install -q -r "$ros2_reqs"
fi
# The bus hands' own clients (pyrobotiqgripper, dynamixel-sdk, pyrh56, inspire-rh56dftp) and
# their dependency closure, pinned in scripts/peers-requirements.txt; checked the same way.
peers_reqs="$root/scripts/peers-requirements.txt"
if ! "$vpy" -c "$pinned_check" "$peers_reqs"; then
  echo "setup: installing the bus hands' Python clients from $peers_reqs"
  "$vpy" -m pip install -q -r "$peers_reqs"
fi
# unitree-sdk2 1.0.1's __init__ imports a subpackage `b2` that the wheel does not ship
# (docs/sources.md §8). Give it an empty one inside our venv so `import unitree_sdk2py` works.
site=$("$vpy" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
if [ ! -e "$site/unitree_sdk2py/b2/__init__.py" ]; then
  mkdir -p "$site/unitree_sdk2py/b2"
  echo "# handgate setup: empty stand-in for the subpackage unitree-sdk2 1.0.1 imports but does not ship" \
    > "$site/unitree_sdk2py/b2/__init__.py"
fi
"$vpy" -c "import unitree_sdk2py.core.channel, unitree_sdk2py.idl.unitree_hg.msg.dds_" \
  || { echo "setup: unitree_sdk2py does not import" >&2; exit 1; }
"$vpy" -c "import rclpy, sensor_msgs.msg, diagnostic_msgs.msg" \
  || { echo "setup: rclpy (the ROS 2 wheels) does not import" >&2; exit 1; }
"$vpy" -c "import pyrobotiqgripper, dynamixel_sdk, rh56_sdk, inspire_rh56dftp" \
  || { echo "setup: the bus hands' clients do not import" >&2; exit 1; }
echo "setup: ok (cyclonedds-dev $ver, $("$vpy" --version), unitree_sdk2py and rclpy (ROS 2 Jazzy) ready in .venv)"
