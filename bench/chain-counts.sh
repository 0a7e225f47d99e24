#!/usr/bin/env bash
# Generation time and operation counts of the scaling chains (bench/chain.py) against n: one
# table row per chain with the wall time of `hapticgen stats` (load, validate, design the
# current loops, derive, choose, optimise and emit every function; release build) and the
# arithmetic operations (trig excluded) of D, C q̇, g, J, the inverse dynamics and the tick's
# `terms`. Pairs with bench/chain-eval.sh (evaluation times). Not part of the test command.
#
# Usage: bench/chain-counts.sh
set -euo pipefail
cd "$(dirname "$0")/.."
work=target/chain-counts
mkdir -p "$work"
python3 bench/chain.py "$work" > /dev/null
cargo build --quiet --release -p hapticgen
for kind in chain planar_chain; do
    echo "$kind: | n | generation s | D | C·q̇ | g | J | inverse dynamics | tick (terms) |"
    for n in 1 2 3 4 5 6 7; do
        start=$(date +%s.%N)
        stats=$(target/release/hapticgen stats "$work/${kind}_$n.yaml")
        end=$(date +%s.%N)
        awk -v n="$n" -v t="$(echo "$end - $start" | bc)" '
            NR > 1 { ops[$1] = $2 + $3 + $4 + $5 + $7 }
            END {
                printf "| %d | %.3f | %d | %d | %d | %d | %d | %d |\n", n, t, ops["inertia_matrix"],
                    ops["coriolis_times_qdot"], ops["gravity"], ops["jacobian"],
                    ops["inverse_dynamics"], ops["terms"]
            }' <<< "$stats"
    done
done
