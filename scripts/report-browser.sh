#!/usr/bin/env bash
# The design report's page (`hapticgen report`, docs/design-report.md) in a real browser:
# headless Chromium opens the page of a planar closed chain and of the Delta, which must render
# without a script or console error (the page's `data-status` reads `rendered`: the 3-D view
# drawn and every map image decoded), and a
# screenshot of the 3-D view alone with the sliders at one end differs from one with them at
# the other in more than 200 pixels (the sliders move the rig). The screenshots stay in the target directory
# (`$CARGO_TARGET_DIR/report-browser/`). Installs Debian's chromium if it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v chromium >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
TARGET=${CARGO_TARGET_DIR:-target}
mkdir -p "$TARGET"
TARGET=$(cd "$TARGET" && pwd)
OUT="$TARGET/report-browser"
rm -rf "$OUT"
mkdir -p "$OUT"
cargo build -q -p hapticgen
BIN="$TARGET/debug/hapticgen"
chrome() {
    timeout 120 chromium --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader \
        --virtual-time-budget=8000 --window-size=900,1100 --hide-scrollbars "$@" 2>>"$OUT/chromium.log"
}
for model in pantograph_5bar falcon_delta; do
    # The Delta's stiffest-wall search simulates about sixty 1 s runs: too slow for a debug build.
    extra=()
    [ "$model" = falcon_delta ] && extra=(--no-zwidth)
    "$BIN" report "models/$model.yaml" --steps 9 "${extra[@]}" -o "$OUT/$model" 2>/dev/null >/dev/null
    page="file://$OUT/$model/index.html"
    status=$(chrome --dump-dom "$page" | grep -o 'data-status="[^"]*"' | head -1 || true)
    if [ "$status" != 'data-status="rendered"' ]; then
        echo "report-browser: FAIL: $model's page did not render: ${status:-no status} (see $OUT/chromium.log)" >&2
        exit 1
    fi
    chrome --screenshot="$OUT/$model-first.png" "$page#q=0,0,0&view" >/dev/null
    chrome --screenshot="$OUT/$model-last.png" "$page#q=15,15,15&view" >/dev/null
    changed=$(python3 scripts/png-diff.py "$OUT/$model-first.png" "$OUT/$model-last.png")
    if [ "$changed" -le 200 ]; then
        echo "report-browser: FAIL: $model: moving the sliders changed $changed pixels (the rig did not move)" >&2
        exit 1
    fi
    echo "report-browser: $model: rendered; the sliders moved the rig ($changed pixels changed); screenshots in $OUT"
done
