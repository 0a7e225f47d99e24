#!/usr/bin/env bash
# Instructions per byte of the YAML parsers the crate registry offers, on the fuzzer's seed pool
# (why the loader's fuzz rate is bounded; docs/reliability.md). Builds
# bench/yaml-parsers (its own crate and lockfile, outside the workspace, so that the parsers the
# project does not use are compiled only here) and counts each parser's instructions with
# callgrind (exact): a run of ROUNDS passes over the seeds less a run of none, divided by the
# bytes parsed. Honours CARGO_TARGET_DIR.
#
#   bench/yaml-parsers.sh            # the table of docs/reliability.md
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT/bench/yaml-parsers"
command -v valgrind >/dev/null || { echo "valgrind is required" >&2; exit 1; }
command -v callgrind_annotate >/dev/null || { echo "callgrind_annotate is required" >&2; exit 1; }
cargo build --release --locked -q
TARGET_DIR="${CARGO_TARGET_DIR:-target}"
case "$TARGET_DIR" in /*) ;; *) TARGET_DIR="$PWD/$TARGET_DIR" ;; esac
BIN="$TARGET_DIR/release/hapticgen-bench-yaml-parsers"
ROUNDS=5
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
# Total instructions of one run; its profile is kept as $WORK/$1.$2.
count() {
    valgrind --tool=callgrind --callgrind-out-file="$WORK/$1.$2" "$BIN" "$1" "$2" 2>&1 \
        | sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
BYTES=$("$BIN" read 0 | sed -n 's/.* seeds, \([0-9]*\) bytes.*/\1/p')
FILES=$("$BIN" read 0 | sed -n 's/.*: \([0-9]*\) seeds.*/\1/p')
[ -n "$BYTES" ] && [ "$BYTES" -gt 0 ] || { echo "no seed bytes read" >&2; exit 1; }
echo "the fuzzer's seed pool: $FILES seeds, $BYTES bytes ($(( BYTES / FILES )) bytes a seed), $ROUNDS passes"
echo
echo "| parser | instructions per byte |"
echo "| --- | --- |"
for parser in serde_yaml-value yaml-rust2-events yaml-rust2-value saphyr-events serde-saphyr-json; do
    none=$(count "$parser" 0)
    some=$(count "$parser" "$ROUNDS")
    echo "| $parser | $(( (some - none) / (ROUNDS * BYTES) )) |"
    if [ "$parser" = serde_yaml-value ]; then
        # libyaml's events, inside serde_yaml's parse: the inclusive cost of its parser.
        libyaml=$(callgrind_annotate --inclusive=yes "$WORK/$parser.$ROUNDS" 2>/dev/null \
            | grep 'unsafe_libyaml::parser::yaml_parser_parse ' | head -1 | awk '{ gsub(",", "", $1); print $1 }')
        [ -n "$libyaml" ] || { echo "libyaml's parser not found in the profile" >&2; exit 1; }
        echo "| libyaml's events (inside serde_yaml-value) | $(( libyaml / (ROUNDS * BYTES) )) |"
    fi
done
