#!/usr/bin/env bash
# Identification's speed on the Falcon-like Delta (the costliest shipped model: 43 base
# parameters plus friction, a closed chain): `hapticgen excite` with its default settings,
# then `hapticgen identify` on a 60 s simulated excitation log, each timed side by side with
# `hapticgen check` of the same model (loading and analysing it, which both commands do first)
# as the baseline, alternating round by round so that the shared machine's load falls on all
# alike. Prints the median of each, the ratio to the baseline, and the targets (excite ≤ 10 s,
# identify ≤ 2 s on a 2-core machine; docs/identification-figures.md).
#
#   bench/identify.sh [ROUNDS]     (default 5; builds the CLI in release first)
set -euo pipefail
cd "$(dirname "$0")/.."
ROUNDS=${1:-5}
MODEL=models/falcon_delta.yaml
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

echo "building the CLI (release)"
cargo build -q --release -p hapticgen --bin hapticgen
TARGET_DIR=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
HAPTICGEN=$TARGET_DIR/release/hapticgen
[ -x "$HAPTICGEN" ] || { echo "identify bench: no CLI at $HAPTICGEN" >&2; exit 1; }

echo "the 60 s log: excitation designed, then played on the simulated device"
"$HAPTICGEN" excite "$MODEL" -o "$WORK/trajectory.yaml" >/dev/null
"$HAPTICGEN" simulate "$MODEL" --scenario excite --trajectory "$WORK/trajectory.yaml" --duration 60 \
    -o "$WORK/run" >/dev/null
[ -s "$WORK/run/log.csv" ] || { echo "identify bench: the run wrote no log" >&2; exit 1; }

python3 - "$HAPTICGEN" "$MODEL" "$WORK" "$ROUNDS" <<'PY'
import statistics, subprocess, sys, time
hapticgen, model, work, rounds = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
commands = {
    "check (baseline)": [hapticgen, "check", model],
    "excite": [hapticgen, "excite", model, "-o", f"{work}/again.yaml"],
    "identify (60 s log)": [hapticgen, "identify", model, "--log", f"{work}/run/log.csv"],
}
targets = {"excite": 10.0, "identify (60 s log)": 2.0}
times = {name: [] for name in commands}
for r in range(rounds):
    names = list(commands) if r % 2 == 0 else list(reversed(commands))
    for name in names:
        start = time.perf_counter()
        subprocess.run(commands[name], check=True, capture_output=True)
        times[name].append(time.perf_counter() - start)
baseline = statistics.median(times["check (baseline)"])
print(f"{'command':22} {'median s':>9} {'/ check':>8} {'target s':>9}")
for name, samples in times.items():
    median = statistics.median(samples)
    target = f"{targets[name]:9.1f}" if name in targets else f"{'':9}"
    print(f"{name:22} {median:9.2f} {median / baseline:8.2f} {target}")
PY
