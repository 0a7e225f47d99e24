#!/usr/bin/env bash
# The design report's page (`hapticgen report`, docs/design-report.md) in a real browser:
# headless Chromium opens the page of a planar closed chain and of the Delta, which must render
# without a script or console error (the page's `data-status` reads `rendered`: the 3-D view
# drawn and every map image decoded), and a
# screenshot of the 3-D view alone with the sliders at one end differs from one with them at
# the other in more than 200 pixels (the sliders move the rig). Then a `simulate` run of the
# planar rig and a `contact` run of the PHANToM Premium-like arm (a spatial rig whose runs are
# quick in a debug build) replayed in their pages (`report --replay`): each
# renders without error, and the view at the replay's start (`#t=0`) differs from the view
# 2.5 s in (`#t=2.5`) in more than 200 pixels (the replay's time moves the rig). The screenshots stay in the target directory
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
# check_page NAME DIR FIRST SECOND WHAT: the page DIR/index.html renders without error, and its
# 3-D view alone at address FIRST differs from the view at SECOND in more than 200 pixels.
check_page() {
    local name=$1 page="file://$2/index.html" first=$3 second=$4 what=$5
    status=$(chrome --dump-dom "$page" | grep -o 'data-status="[^"]*"' | head -1 || true)
    if [ "$status" != 'data-status="rendered"' ]; then
        echo "report-browser: FAIL: $name's page did not render: ${status:-no status} (see $OUT/chromium.log)" >&2
        exit 1
    fi
    chrome --screenshot="$OUT/$name-first.png" "$page#$first&view" >/dev/null
    chrome --screenshot="$OUT/$name-second.png" "$page#$second&view" >/dev/null
    changed=$(python3 scripts/png-diff.py "$OUT/$name-first.png" "$OUT/$name-second.png")
    if [ "$changed" -le 200 ]; then
        echo "report-browser: FAIL: $name: moving $what changed $changed pixels (the rig did not move)" >&2
        exit 1
    fi
    echo "report-browser: $name: rendered; $what moved the rig ($changed pixels changed); screenshots in $OUT"
}
for model in pantograph_5bar falcon_delta; do
    # Without the stiffest-wall search (simulations, slow in a debug build; the tests check it).
    "$BIN" report "models/$model.yaml" --steps 9 --no-zwidth -o "$OUT/$model" 2>/dev/null >/dev/null
    check_page "$model" "$OUT/$model" "q=0,0,0" "q=15,15,15" "the sliders"
done
# Replays: a simulated run of the five-bar tracing its circle, and the Premium-like arm sliding on a floor.
"$BIN" simulate models/pantograph_5bar.yaml --controller 3 --scenario trace-circle -o "$OUT/run-pantograph_5bar" >/dev/null
"$BIN" contact models/phantom_premium.yaml --only slide -o "$OUT/run-phantom_premium" >/dev/null
for model in pantograph_5bar phantom_premium; do
    run="$OUT/run-$model"
    [ -d "$run/slide" ] && run="$run/slide"
    "$BIN" report "models/$model.yaml" --steps 9 --no-zwidth --replay "$run" -o "$OUT/replay-$model" 2>/dev/null >/dev/null
    check_page "replay-$model" "$OUT/replay-$model" "t=0" "t=2.5" "the replay's time"
done
