#!/usr/bin/env bash
# Headless screenshot of the native Rerun viewer showing a recording with its saved blueprint.
#
#   docs/screenshot.sh RUN.rrd OUT.png [WIDTHxHEIGHT]
#
# Route (TECHNOTES §1.3 route 1): Xvfb + Mesa lavapipe (software Vulkan) + the `rerun` binary of the
# project's venv:  rerun RUN.rrd --window-size WxH --screenshot-to OUT.png
# Missing Debian packages (xvfb, xauth, xdotool, mesa-vulkan-drivers, libgl1-mesa-dri, libegl-mesa0) are
# installed with apt-get (needs root). The PNG is written at 2x the window size by the viewer.
# Environment: RERUN_BIN (default: the venv's rerun, else `rerun` on PATH), SCREENSHOT_TIMEOUT (s, 180).
set -euo pipefail

if [[ $# -lt 2 ]]; then
    echo "usage: $0 RUN.rrd OUT.png [WIDTHxHEIGHT]" >&2
    exit 2
fi
RRD=$1
OUT=$2
SIZE=${3:-1400x900}
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
    echo "installing: ${need[*]}" >&2
    SUDO=""
    [[ $(id -u) -ne 0 ]] && SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}" >&2
fi

# --- capture -------------------------------------------------------------------------------------
"$RERUN_BIN" analytics disable >/dev/null 2>&1 || true
mkdir -p "$(dirname "$OUT")"
TMP_OUT="$(dirname "$OUT")/.$(basename "$OUT").$$.png"
trap 'rm -f "$TMP_OUT"' EXIT
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
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
