#!/usr/bin/env bash
# Exact instruction counts of one full 1 kHz tick (impedance tick + one current-loop step) of
# each shipped rig on the host (x86-64, release), with valgrind's callgrind: the difference
# between 10,000 ticks and 0 ticks, divided by 10,000. Not part of the test command.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "valgrind is required" >&2; exit 1; }
cargo build -q --release -p hapticgen-tests --example tick_instructions
BIN=target/release/examples/tick_instructions
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$BIN" "$@" 2>&1 \
        | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
TICKS=10000
echo "| rig | law | instructions per tick |"
echo "| --- | --- | --- |"
for rig in joystick parallel_link planar_arm phantom puma560 pantograph; do
    for mode in fused generic; do
        zero=$(count "$rig" "$mode" 0)
        many=$(count "$rig" "$mode" "$TICKS")
        echo "| $rig | $mode | $(( (many - zero) / TICKS )) |"
    done
done
