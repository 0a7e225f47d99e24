#!/usr/bin/env bash
# The god-object renderer side by side with parry3d on the same meshes: builds
# bench/parry (its own crate and lockfile, outside the workspace, so parry3d is compiled only
# here), checks that both find the same closest distances, then prints the timing table of
# docs/rendering.md. Honours CARGO_TARGET_DIR.
#
#   bench/render-vs-parry.sh                 # wall-clock table (best of 5, shared machine)
#   bench/render-vs-parry.sh --instructions  # exact instruction counts (valgrind's callgrind)
set -euo pipefail
cd "$(dirname "$0")/parry"
if [ "${1:-}" != "--instructions" ]; then
    cargo run --release --locked -q
    exit 0
fi
command -v valgrind >/dev/null || { echo "valgrind is required for --instructions" >&2; exit 1; }
cargo build --release --locked -q
BIN="${CARGO_TARGET_DIR:-target}/release/hapticgen-bench-parry"
OPERATIONS=2000
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$BIN" count "$@" 2>&1 \
        | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
per_operation() {
    local zero many
    zero=$(count "$1" "$2" 0)
    many=$(count "$1" "$2" "$OPERATIONS")
    echo $(( (many - zero) / OPERATIONS ))
}
echo "| triangles | proxy update | closest point, hapticgen | point projection, parry3d | update / projection |"
echo "| --- | --- | --- | --- | --- |"
for size in 0 1 2; do
    update=$(per_operation update "$size")
    closest=$(per_operation closest "$size")
    project=$(per_operation project "$size")
    triangles=$(echo "960 9800 99224" | cut -d' ' -f$((size + 1)))
    ratio=$(awk -v u="$update" -v p="$project" 'BEGIN { printf "%.2f", u / p }')
    echo "| $triangles | $update | $closest | $project | $ratio |"
done
