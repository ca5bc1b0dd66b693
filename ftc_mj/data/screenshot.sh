#!/usr/bin/env bash
# Headless screenshot of the native Rerun viewer showing a recording with its saved blueprint.
#
#   docs/screenshot.sh [--install] RUN.rrd|RUN_DIR OUT.png [WIDTHxHEIGHT]
#
# Shipped in the package as ftc_mj/data/screenshot.sh (docs/screenshot.sh links to it), so an installed
# ftc-mj can name it: `ftc-mj view` without a display prints the command with its installed path.
#
# Route: Xvfb (a virtual X display) + Mesa lavapipe (software Vulkan, no GPU needed) + the `rerun`
# binary of the project's venv:  rerun RUN.rrd --window-size WxH --screenshot-to OUT.png
# The PNG is written at 2x the window size by the viewer; it shows the blueprint saved in the file
# (for ftc-mj compare recordings: the overlaid runs).
#
# What it needs from the system (Debian/Ubuntu packages): xvfb, xauth, xdotool, mesa-vulkan-drivers,
# libgl1-mesa-dri, libegl-mesa0. If some are missing it stops and prints the apt-get command; with
# --install it runs that command itself (system-wide, with sudo unless root) and says so first.
# Nothing else outside this run changes: the viewer runs with HOME-independent temporary config,
# data, cache and runtime folders (its usage-analytics opt-out is written there, not in your
# ~/.config), which are removed at the end; OUT.png appears only when the capture succeeded.
# Environment: RERUN_BIN (default: the venv's rerun, else `rerun` on PATH), SCREENSHOT_TIMEOUT (s, 180).
set -euo pipefail

INSTALL=0
if [[ ${1:-} == "--install" ]]; then
    INSTALL=1
    shift
fi
if [[ $# -lt 2 || ${1:-} == "-h" || ${1:-} == "--help" ]]; then
    echo "usage: $0 [--install] RUN.rrd|RUN_DIR OUT.png [WIDTHxHEIGHT]" >&2
    exit 2
fi
RRD=$1
OUT=$2
SIZE=${3:-1400x900}
[[ -d "$RRD" ]] && RRD="$RRD/run.rrd"
if [[ ! -f "$RRD" ]]; then
    echo "error: recording not found: $RRD" >&2
    exit 2
fi
if [[ ! "$SIZE" =~ ^[0-9]+x[0-9]+$ ]]; then
    echo "error: size must be WIDTHxHEIGHT, got: $SIZE" >&2
    exit 2
fi

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(dirname "$HERE")
if [[ -z "${RERUN_BIN:-}" ]]; then
    if [[ -x "$REPO/.venv/bin/rerun" ]]; then
        RERUN_BIN="$REPO/.venv/bin/rerun"
    else
        RERUN_BIN=$(command -v rerun || true)
    fi
fi
if [[ -z "$RERUN_BIN" || ! -x "$RERUN_BIN" ]]; then
    echo "error: rerun executable not found (set RERUN_BIN or install rerun-sdk in .venv)" >&2
    exit 1
fi

# --- system packages -----------------------------------------------------------------------------
need=()
command -v xvfb-run >/dev/null 2>&1 || need+=(xvfb)
command -v xauth >/dev/null 2>&1 || need+=(xauth)
command -v xdotool >/dev/null 2>&1 || need+=(xdotool)
for pkg in mesa-vulkan-drivers libgl1-mesa-dri libegl-mesa0; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || need+=("$pkg")
done
if [[ ${#need[@]} -gt 0 ]]; then
    SUDO=""
    [[ $(id -u) -ne 0 ]] && SUDO="sudo "
    cmd="${SUDO}apt-get install -y --no-install-recommends ${need[*]}"
    if [[ $INSTALL -eq 0 ]]; then
        echo "error: missing system packages: ${need[*]}; install them with: ${SUDO}apt-get update && $cmd" >&2
        echo "       (or re-run with --install to let this script run that command)" >&2
        exit 2
    fi
    echo "installing system-wide with apt-get: ${need[*]}" >&2
    ${SUDO}apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $cmd -qq >&2
fi

# --- capture -------------------------------------------------------------------------------------
WORK=$(mktemp -d "${TMPDIR:-/tmp}/ftc-mj-screenshot.XXXXXX")
mkdir -p "$(dirname "$OUT")"
TMP_OUT="$(dirname "$OUT")/.$(basename "$OUT").$$.png"
trap 'rm -rf "$WORK"; rm -f "$TMP_OUT"' EXIT
mkdir -p "$WORK/config" "$WORK/data" "$WORK/cache" "$WORK/run"
chmod 700 "$WORK/run"
export XDG_CONFIG_HOME="$WORK/config" XDG_DATA_HOME="$WORK/data" XDG_CACHE_HOME="$WORK/cache" XDG_RUNTIME_DIR="$WORK/run"
"$RERUN_BIN" analytics disable >/dev/null 2>&1 || true   # into the temporary config above
export WGPU_BACKEND=${WGPU_BACKEND:-vulkan}
W=${SIZE%x*}
H=${SIZE#*x}
# Xvfb puts the mouse pointer mid-screen, where it would leave a hover tooltip in the picture; if
# xdotool is available it is parked on the empty top bar while the viewer starts.
export RERUN_BIN RRD SIZE TMP_OUT W H
timeout "${SCREENSHOT_TIMEOUT:-180}" xvfb-run -a -s "-screen 0 ${W}x${H}x24" bash -c '
    "$RERUN_BIN" "$RRD" --new --bind 127.0.0.1 --window-size "$SIZE" --screenshot-to "$TMP_OUT" &
    pid=$!
    if command -v xdotool >/dev/null 2>&1; then
        while kill -0 "$pid" 2>/dev/null; do
            xdotool mousemove $((W * 3 / 4)) 8 >/dev/null 2>&1 || true
            sleep 0.5
        done
    fi
    wait "$pid"
' >&2
if [[ ! -s "$TMP_OUT" ]]; then
    echo "error: the viewer produced no screenshot" >&2
    exit 1
fi
mv -f "$TMP_OUT" "$OUT"
echo "$OUT"
