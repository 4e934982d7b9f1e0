#!/bin/sh
# Remakes docs/report.png: `pndiss report` of a fault capture rendered by headless Chromium
# (the top 2200 px: verdict, stations and ARs, the axis plot, the first violation).
#   sh tools/screenshot_report.sh [CAPTURE] [OUT.png]
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CAP=${1:-$ROOT/captures/fault-cmd-executed-without-control.pcapng}
OUT=${2:-$ROOT/docs/report.png}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
PYTHONPATH=$ROOT python3 -m pndiss report "$CAP" -o "$TMP/report.html"
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking \
    --disable-component-update --disable-sync --user-data-dir="$TMP/ud" --window-size=1280,2200 \
    --screenshot="$OUT" "file://$TMP/report.html" 2>/dev/null
python3 -c "import sys; from PIL import Image; Image.open(sys.argv[1]).convert('RGB').quantize(256).save(sys.argv[1], optimize=True)" "$OUT"
echo "wrote $OUT"
