#!/usr/bin/env bash
# Evaluation time of the generated code of the scaling chains (bench/chain.py) against n:
# generates every chain into one throw-away crate under target/chain-eval, builds it in
# release and times `terms` (D, C q̇, g, p, J, J̇ q̇) and `inverse_dynamics` per call (best of
# 25 batches of 20,000 calls over 64 states). Not part of the test command.
#
# Usage: bench/chain-eval.sh
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
work=target/chain-eval
rm -rf "$work"
mkdir -p "$work/src" "$work/models"
python3 bench/chain.py "$work/models" > /dev/null
cargo build --quiet --release -p hapticgen
mods=""
calls=""
for kind in chain planar_chain; do
    for n in 1 2 3 4 5 6 7; do
        name="${kind}_${n}"
        target/release/hapticgen generate "$work/models/$name.yaml" --scalar f64 -o "$work/src/$name.rs"
        mods+="#[allow(clippy::all)] mod $name { include!(\"$name.rs\"); }"$'\n'
        type=$(python3 -c "print(''.join(p.capitalize() for p in '$name'.split('_')))")
        calls+="    time!(\"$kind\", $n, $name::$type::NOMINAL);"$'\n'
    done
done
cat > "$work/Cargo.toml" <<TOML
[package]
name = "chain-eval"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
hapticgen-runtime = { path = "$root/runtime" }

[workspace]
TOML
cat > "$work/src/main.rs" <<RUST
#![allow(dead_code)]
use std::hint::black_box;
use std::time::Instant;
$mods
fn best_ns(mut f: impl FnMut(usize)) -> f64 {
    (0..25)
        .map(|_| {
            let t = Instant::now();
            for i in 0..20_000 {
                f(i);
            }
            t.elapsed().as_nanos() as f64 / 20_000.0
        })
        .fold(f64::INFINITY, f64::min)
}
macro_rules! time {
    (\$kind:expr, \$n:expr, \$rig:expr) => {{
        let rig = \$rig;
        let states: Vec<([f64; \$n], [f64; \$n])> = (0..64usize)
            .map(|k| {
                let q = std::array::from_fn(|i| ((k * 7 + i * 3) % 13) as f64 * 0.2 - 1.2);
                let qd = std::array::from_fn(|i| ((k * 5 + i) % 11) as f64 * 0.3 - 1.5);
                (q, qd)
            })
            .collect();
        let terms = best_ns(|i| {
            let (q, qd) = &states[i % 64];
            black_box(rig.terms(black_box(q), black_box(qd)));
        });
        let inverse = best_ns(|i| {
            let (q, qd) = &states[i % 64];
            black_box(rig.inverse_dynamics(black_box(q), black_box(qd), black_box(qd)));
        });
        println!("| {} | {} | {:.1} | {:.1} |", \$kind, \$n, terms, inverse);
    }};
}
fn main() {
    println!("| chain | n | terms ns | inverse_dynamics ns |");
    println!("| --- | --- | --- | --- |");
$calls}
RUST
CARGO_TARGET_DIR="$root/target/chain-eval/target" cargo run --quiet --release --manifest-path "$work/Cargo.toml"
