#!/usr/bin/env bash
# Identification under QEMU (docs/identification.md, "On the firmware"): the joystick's PIL
# image plays a designed excitation against a simulated "true" joystick (every mass, centre of
# mass and inertia 20-40 % off the model file's, more friction), the host logs what the device
# measured and commanded, and `hapticgen identify --truth` fails unless the identified D, C q̇
# and g are within 2 % of the true device's at 100 random states, each friction parameter
# within 10 %, and the torque of a second, different run (also under QEMU) within 5 % RMS.
#
#   scripts/pil-identify.sh HAPTICGEN IMAGE OUT_DIR
#
# HAPTICGEN: the `hapticgen` binary; IMAGE: the joystick's PIL image
# (scripts/firmware.sh --only pil builds both); OUT_DIR: where the files go.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 HAPTICGEN IMAGE OUT_DIR" >&2; exit 2; }
HAPTICGEN=$1
IMAGE=$2
OUT=$3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
MODEL=$ROOT/models/joystick_1dof.yaml
# Each run: the 1 s blend and two periods of 2 s (the joystick's three rigid-body base
# parameters, friction and offset need far less than a device owner's 60 s, and QEMU runs the
# lock-step link at about a twentieth of real time).
PERIOD=2
DURATION=5
mkdir -p "$OUT"

# The true device: the stick 40 % heavier (its inertia with it: a slender rod), its centre of
# mass 20 % further out, the grip 36 % heavier, 30 % more viscous and Coulomb friction.
sed -e 's/^\(    mass: \)0\.020358$/\10.0285/' \
    -e 's/^\(    com: \)\[0\.0, 0\.075\]$/\1[0.0, 0.09]/' \
    -e 's/^\(    mass: \)0\.05$/\10.068/' \
    -e 's/^\(    damping: \)1\.0e-3$/\11.3e-3/' \
    -e 's/^\(    coulomb_friction: \)0\.01 /\10.013 /' \
    "$MODEL" >"$OUT/true.yaml"
changed=$(diff "$MODEL" "$OUT/true.yaml" | grep -c '^>' || true)
[ "$changed" -eq 5 ] || { echo "pil-identify: the true device changes $changed lines of $MODEL, not 5 (did the model file change?)" >&2; exit 1; }

"$HAPTICGEN" excite "$MODEL" --period "$PERIOD" --evaluations 300 -o "$OUT/traj.yaml"
"$HAPTICGEN" excite "$MODEL" --period "$PERIOD" --evaluations 300 --seed 2 -o "$OUT/other.yaml"
for run in traj other; do
    # Backlash off: a rigid-body model cannot describe a link that lags its encoder
    # (docs/identification.md).
    "$HAPTICGEN" pil "$MODEL" --plant "$OUT/true.yaml" --scenario excite --trajectory "$OUT/$run.yaml" \
        --without backlash --duration "$DURATION" --image "$IMAGE" -o "$OUT/$run"
done
"$HAPTICGEN" identify "$MODEL" --log "$OUT/traj/log.csv" --validate "$OUT/other/log.csv" \
    --truth "$OUT/true.yaml" -o "$OUT/identified.yaml"
