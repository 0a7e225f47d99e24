#!/usr/bin/env bash
# The device image under QEMU, driven by `hapticgen connect` as an application drives a device
# (docs/link-device.md). QEMU runs without -icount, so that the image's clock is the host's
# (the heartbeat timeout is real time); its UART0 is a Unix socket in OUTDIR.
#
#   scripts/device-run.sh HAPTICGEN IMAGE OUTDIR
#
# 1. `hapticgen connect --check-safety`: garbage and corrupted frames beside the heartbeats
#    (no tick missing, bridges on), heartbeat loss (safe state within 10 ms), Enable refused
#    until ResetFault; fails if one does not hold.
# 2. The scene of scenes/device-wall.yaml, loaded before: a box whose face is 3 mm to the left
#    of the start point, so that the renderer pushes the device out; checked on the CSV log of
#    the state stream: the device point ends at or left of the face (within 0.5 mm), and the
#    stream has no missing tick.
# 3. The 3-D scene of scenes/device-ceiling.yaml (a half-space): this 2-D device answers that it
#    does not render it, and `hapticgen connect` fails with the error at the object's line and
#    column (never "loaded" when nothing is rendered).
# 4. Identification on the device (`hapticgen connect --excite`, docs/identification.md): two
#    trajectories designed for the model (`hapticgen excite`, period 2 s = 2,000 impedance
#    ticks, seeds 1 and 2), each played by the device from its start pose for the blend and four
#    periods of the device's own ticks (a loaded machine slows QEMU's clock, not the log's
#    time), each on a fresh QEMU with a 50 ms heartbeat timeout (the link's safety rules are
#    step 1's; a late heartbeat on a loaded 2-core machine must not end an identification run).
#    `connect` fails by itself if the device does not play the trajectory or stops. Checked: at
#    most 0.1 % of the ticks missing from either log and none two in a row (a frame lost on a
#    loaded machine; the fit interpolates one), tracking error after the blend under 0.02 rad, and
#    `identify --validate --truth MODEL` (the image's plant is the model's own mechanics): D(q)
#    and C(q, q̇) q̇ within their 2 % bounds, the validation torque within 5 %. Friction is printed,
#    not checked: the image's plant has no Coulomb friction (`SimBoard`), so the model file's is
#    not the device's, and the viscous term is off by 20–40 % (see docs/identification.md).
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 HAPTICGEN IMAGE OUTDIR" >&2; exit 2; }
HAPTICGEN=$1
IMAGE=$2
OUT=$3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WALL_FACE=-0.053   # m: the box's face in scenes/device-wall.yaml
[ -x "$HAPTICGEN" ] || { echo "FAIL no hapticgen at $HAPTICGEN" >&2; exit 1; }
[ -f "$IMAGE" ] || { echo "FAIL no device image at $IMAGE" >&2; exit 1; }
mkdir -p "$OUT"
SOCKET=$OUT/uart0.sock
rm -f "$SOCKET" "$OUT/state.csv"
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
    -semihosting-config enable=on,target=native -serial "unix:$SOCKET,server=on,wait=off" \
    -kernel "$IMAGE" >"$OUT/qemu.out" 2>"$OUT/qemu.err" &
QEMU=$!
trap 'kill "$QEMU" 2>/dev/null || true' EXIT
"$HAPTICGEN" connect --port "unix:$SOCKET" --check-safety --impedance 1500,5 \
    --scene "$ROOT/scenes/device-wall.yaml" --duration 1 --log "$OUT/state.csv" --quiet | tee "$OUT/connect.out"
grep -q '^PASS heartbeat loss' "$OUT/connect.out" || { echo "FAIL the safety checks did not run" >&2; exit 1; }
awk -F, -v face="$WALL_FACE" '
    NR == 1 { for (i = 1; i <= NF; i++) column[$i] = i; next }
    {
        rows++
        if (rows > 1 && ($(column["tick"]) - last + 65536) % 65536 != 1) missing++
        last = $(column["tick"]); x = $(column["x0"]); enabled = $(column["enabled"])
    }
    END {
        # The device runs on the host clock when QEMU has the CPU, slower when it has not.
        if (rows < 100) { printf "FAIL device: %d state frames in 1 s (fewer than 100)\n", rows; exit 1 }
        if (missing) { printf "FAIL device: %d gaps in the tick sequence\n", missing; exit 1 }
        if (!enabled) { printf "FAIL device: disabled at the end\n"; exit 1 }
        if (x > face + 0.0005) { printf "FAIL device: x = %.2f mm at the end, inside the wall (face at %.1f mm)\n", x * 1e3, face * 1e3; exit 1 }
        printf "device: %d state frames, no gap; x = %.2f mm at the end, out of the wall (face at %.1f mm, start -50 mm inside it)\n", rows, x * 1e3, face * 1e3
    }' "$OUT/state.csv"
# On a fresh QEMU: after the flood the first one's UART may still be taking its backlog (a
# reconnection to it once waited 10 s for the answer to Hello on a busy machine).
kill "$QEMU" 2>/dev/null || true
wait "$QEMU" 2>/dev/null || true
SOCKET=$OUT/uart0-refusal.sock
rm -f "$SOCKET"
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
    -semihosting-config enable=on,target=native -serial "unix:$SOCKET,server=on,wait=off" \
    -kernel "$IMAGE" >"$OUT/qemu-refusal.out" 2>"$OUT/qemu-refusal.err" &
QEMU=$!
STATUS=0
"$HAPTICGEN" connect --port "unix:$SOCKET" --scene "$ROOT/scenes/device-ceiling.yaml" --duration 0 --quiet \
    >"$OUT/refused.out" 2>&1 || STATUS=$?
if [ "$STATUS" -eq 0 ] || ! grep -q 'device-ceiling.yaml:[0-9]*:[0-9]*: .*the device refused this half-space' "$OUT/refused.out"; then
    cat "$OUT/refused.out" >&2
    echo "FAIL device: a half-space sent to this 2-D device was not refused at its line (exit status $STATUS)" >&2
    exit 1
fi
echo "device: a half-space refused at its line: $(grep -o 'device-ceiling.yaml:[0-9]*:[0-9]*: [^:]*: the device refused this half-space' "$OUT/refused.out" | head -n 1)"
kill "$QEMU" 2>/dev/null || true
wait "$QEMU" 2>/dev/null || true

MODEL=$ROOT/models/parallel_link_2dof.yaml
for SEED in 1 2; do
    "$HAPTICGEN" excite "$MODEL" --variant horizontal --period 2 --evaluations 300 --seed "$SEED" \
        -o "$OUT/excite-$SEED.yaml" >"$OUT/excite-$SEED.out" 2>&1 \
        || { cat "$OUT/excite-$SEED.out" >&2; echo "FAIL device: hapticgen excite (seed $SEED)" >&2; exit 1; }
    SOCKET=$OUT/uart0-excite-$SEED.sock
    rm -f "$SOCKET" "$OUT/excite-$SEED.csv"
    qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
        -semihosting-config enable=on,target=native,arg=timeout_ms=50 -serial "unix:$SOCKET,server=on,wait=off" \
        -kernel "$IMAGE" >"$OUT/qemu-excite-$SEED.out" 2>"$OUT/qemu-excite-$SEED.err" &
    QEMU=$!
    STATUS=0
    "$HAPTICGEN" connect --port "unix:$SOCKET" --excite "$OUT/excite-$SEED.yaml" --model "$MODEL" \
        --variant horizontal --log "$OUT/excite-$SEED.csv" >"$OUT/connect-excite-$SEED.out" 2>&1 || STATUS=$?
    kill "$QEMU" 2>/dev/null || true
    wait "$QEMU" 2>/dev/null || true
    cat "$OUT/connect-excite-$SEED.out"
    [ "$STATUS" -eq 0 ] || { echo "FAIL device: connect --excite (seed $SEED) exited with $STATUS" >&2; exit 1; }
    awk -F, -v seed="$SEED" '
        NR == 1 { next }
        {
            rows++
            if (rows > 1) { step = $1 - last; if (step > 0.0015) missing += step / 0.001 - 1; if (step > 0.0025) long++ }
            last = $1
        }
        END {
            if (rows < 8000) { printf "FAIL device: excitation %s: %d rows (fewer than 8000)\n", seed, rows; exit 1 }
            if (long || missing > rows / 1000) {
                printf "FAIL device: excitation %s: %d ticks missing, %d gaps longer than one tick\n", seed, missing, long; exit 1
            }
            printf "device: excitation %s: %d rows, %d ticks missing (at most 0.1 %%, none two in a row)\n", seed, rows, missing
        }' "$OUT/excite-$SEED.csv"
    awk -v seed="$SEED" '
        /largest tracking error after the blend/ { n++; if ($NF + 0 > 0.02 || $NF + 0 != $NF + 0) bad = bad " " $2 $NF }
        END {
            if (n == 0) { print "FAIL device: no tracking error printed"; exit 1 }
            if (bad != "") { printf "FAIL device: excitation %s: tracking error over 0.02 rad:%s\n", seed, bad; exit 1 }
        }' "$OUT/connect-excite-$SEED.out"
done
STATUS=0
"$HAPTICGEN" identify "$MODEL" --variant horizontal --log "$OUT/excite-1.csv" --validate "$OUT/excite-2.csv" \
    --truth "$MODEL" >"$OUT/identify.out" 2>&1 || STATUS=$?
awk '/^\| figure/ { table = 1 } table && /^\|/' "$OUT/identify.out"
awk '
    function percent(field) { gsub(/[ %]/, "", field); return field + 0 }
    /^\| D\(q\) \|/ { d = percent($3); seen++ }
    /^\| C\(q, q̇\) q̇ \|/ { c = percent($3); seen++ }
    /^\| validation torque \|/ { v = percent($3); seen++ }
    END {
        if (seen != 3) { print "FAIL device: identify printed no D, C q̇ or validation figure"; exit 1 }
        if (d > 2 || c > 2 || v > 5) { printf "FAIL device: identified D %.2f %%, C q̇ %.2f %% (bound 2 %%), validation %.2f %% (bound 5 %%)\n", d, c, v; exit 1 }
        printf "device: identified on the device: D(q) %.2f %%, C(q, q̇) q̇ %.2f %% off the model (bound 2 %%), validation torque %.2f %% RMS (bound 5 %%)\n", d, c, v
    }' FS='|' "$OUT/identify.out"
