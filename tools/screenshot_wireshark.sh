#!/bin/sh
# Remakes docs/wireshark.png: the Wireshark GUI (Qt) under Xvfb with the pndiss plugin in a fresh
# personal plugin folder, a fault capture opened once (no -2, no filter) and the frame with the
# violation selected, its "pndiss violations" subtree expanded.
# Needs: wireshark (wireshark-qt), xvfb, imagemagick (import), xdotool.
#   sh tools/screenshot_wireshark.sh [CAPTURE] [FRAME] [OUT.png]
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CAP=${1:-$ROOT/captures/fault-preset-ack-missing.pcapng}
FRAME=${2:-347}
OUT=${3:-$ROOT/docs/wireshark.png}
for t in wireshark Xvfb import xdotool; do
    command -v $t >/dev/null || { echo "screenshot_wireshark: $t is missing" >&2; exit 2; }
done
TMP=$(mktemp -d)
DISP=:$((90 + $$ % 100))
cleanup() { kill "$WS" "$XV" 2>/dev/null || true; rm -rf "$TMP"; }
WS= XV=
trap cleanup EXIT
Xvfb "$DISP" -screen 0 1400x900x24 -nolisten tcp >/dev/null 2>&1 &
XV=$!
export DISPLAY=$DISP HOME=$TMP XDG_RUNTIME_DIR=$TMP
mkdir -p "$TMP/.config/wireshark" "$TMP/.local/lib/wireshark/plugins"
cp "$ROOT"/lua/pndiss.lua "$ROOT"/lua/pndiss_checker.lua "$ROOT"/lua/pndiss_tables.lua "$TMP/.local/lib/wireshark/plugins/"
# default columns without Destination/Length (room for the Info column)
cat > "$TMP/.config/wireshark/preferences" <<'EOF'
gui.update.enabled: FALSE
gui.column.format:
	"No.", "%m",
	"Time", "%t",
	"Source", "%uhs",
	"Protocol", "%p",
	"Info", "%i"
EOF
sleep 1
wireshark -r "$CAP" -g "$FRAME" >"$TMP/ws.log" 2>&1 &
WS=$!
W=
for _ in $(seq 60); do
    W=$(xdotool search --name "$(basename "$CAP")" 2>/dev/null | head -1) && [ -n "$W" ] && break
    sleep 1
done
[ -n "$W" ] || { echo "screenshot_wireshark: no Wireshark window" >&2; cat "$TMP/ws.log" >&2; exit 1; }
sleep 3
xdotool windowsize "$W" 1400 900 windowmove "$W" 0 0
sleep 2
# the last item of the details pane is the pndiss violations subtree: click it, expand all below it
Y=614   # its row (8th of the details pane) at 1400x900
xdotool mousemove 90 "$Y" click 1
sleep 0.5
xdotool key shift+Right
sleep 1
import -window root "$OUT"
# 64 colours: the same picture at a fifth of the size
python3 -c "import sys; from PIL import Image; Image.open(sys.argv[1]).convert('RGB').quantize(64).save(sys.argv[1], optimize=True)" "$OUT" 2>/dev/null || true
echo "wrote $OUT"
