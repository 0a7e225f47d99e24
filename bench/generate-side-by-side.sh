#!/usr/bin/env bash
# Generation time of every shipped model, side by side with another commit (default: the
# parent of HEAD): builds the `hapticgen` CLI in release at both commits, then times
# `hapticgen generate` of every model and variant, alternating the two binaries round by round
# (so that the shared machine's load falls on both alike), and prints the median time of each
# and their ratio. The generated text of both must be identical, or the script fails.
#
#   bench/generate-side-by-side.sh [REV] [ROUNDS]
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
REV=${1:-HEAD~1}
ROUNDS=${2:-30}
WORK=$(mktemp -d)
trap 'git -C "$ROOT" worktree remove --force "$WORK/before" >/dev/null 2>&1 || true; rm -rf "$WORK"' EXIT
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}

git worktree add --detach "$WORK/before" "$REV" >/dev/null
echo "building the CLI at $REV and at the working tree (release)"
(cd "$WORK/before" && CARGO_TARGET_DIR="$TARGET/side-by-side-before" cargo build -q --release -p hapticgen --bin hapticgen)
cargo build -q --release -p hapticgen --bin hapticgen
BEFORE="$TARGET/side-by-side-before/release/hapticgen"
AFTER="$TARGET/release/hapticgen"

python3 - "$BEFORE" "$AFTER" "$ROUNDS" <<'PY'
import statistics, subprocess, sys, time, glob, re
before, after, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
cases = []
for path in sorted(glob.glob("models/*.yaml")):
    text = open(path).read()
    m = re.search(r"^variants:\n((?:  .*\n|\n)*)", text, re.M)
    variants = re.findall(r"^  ([a-z_0-9]+):", m.group(1), re.M) if m else []
    cases += [(path, v) for v in variants] or [(path, None)]
if not cases:
    sys.exit("no shipped models found")
def run(binary, path, variant):
    args = [binary, "generate", path] + (["--variant", variant] if variant else [])
    start = time.perf_counter()
    out = subprocess.run(args, check=True, capture_output=True).stdout
    return time.perf_counter() - start, out
times = {c: ([], []) for c in cases}
for c in cases:
    a, b = run(before, *c)[1], run(after, *c)[1]
    if a != b:
        sys.exit(f"{c}: the two commits generate different code")
for r in range(rounds):
    for c in cases:
        order = (0, 1) if r % 2 == 0 else (1, 0)
        for k in order:
            times[c][k].append(run((before, after)[k], *c)[0])
print(f"{'model':48} {'before ms':>10} {'after ms':>10} {'after/before':>13}")
ratios = []
for c, (tb, ta) in times.items():
    mb, ma = statistics.median(tb) * 1e3, statistics.median(ta) * 1e3
    ratios.append(ma / mb)
    name = c[0] + (f" ({c[1]})" if c[1] else "")
    print(f"{name:48} {mb:10.2f} {ma:10.2f} {ma / mb:13.3f}")
print(f"geometric mean of after/before over {len(cases)} models: {statistics.geometric_mean(ratios):.3f}")
PY
