#!/usr/bin/env bash
# Checks that the runtime and the generated code build with Rust 1.63 (the oldest toolchain
# the firmware fallback path uses: Debian bookworm's rustc). Installs Debian's rustc 1.63 and
# its libm if missing, then compiles, with that rustc and no cargo:
#   1. libm (Debian's librust-libm-dev source),
#   2. runtime/ as a library (also with `-C target-feature=+fma`: `Real::mul_add`'s x86 path),
#   3. a crate that includes the generated code of every shipped model, variant and scalar,
#      unfused and with fused multiply-adds.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
RUSTC=/usr/bin/rustc
if ! [ -x "$RUSTC" ] || ! [ -d /usr/share/cargo/registry ] || ! ls -d /usr/share/cargo/registry/libm-* >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO=sudo
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get install -y --no-install-recommends rustc librust-libm-dev >/dev/null 2>&1 || {
        $SUDO apt-get update >/dev/null
        $SUDO apt-get install -y --no-install-recommends rustc librust-libm-dev >/dev/null
    }
fi
"$RUSTC" --version
case "$("$RUSTC" --version)" in
    "rustc 1.63."*) ;;
    *) echo "msrv: expected rustc 1.63 at $RUSTC" >&2; exit 1 ;;
esac
# Cargo's target directory: target/, or wherever CARGO_TARGET_DIR puts it.
TARGET_DIR=$(cargo metadata --format-version 1 --no-deps \
    | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
[ -n "$TARGET_DIR" ] || { echo "msrv: cargo metadata named no target directory" >&2; exit 1; }
OUT=$TARGET_DIR/msrv
rm -rf "$OUT"
mkdir -p "$OUT/generated"
LIBM_SRC=$(ls -d /usr/share/cargo/registry/libm-* | sort -V | tail -n 1)
echo "msrv: libm from $LIBM_SRC"
"$RUSTC" --edition 2018 --crate-type lib --crate-name libm -O --cap-lints allow \
    "$LIBM_SRC/src/lib.rs" --out-dir "$OUT"
echo "msrv: runtime"
"$RUSTC" --edition 2021 --crate-type lib --crate-name hapticgen_runtime -D warnings \
    "$ROOT/runtime/src/lib.rs" --extern libm="$OUT/liblibm.rlib" -L "$OUT" --out-dir "$OUT"
echo "msrv: runtime with the x86 FMA instructions"
mkdir -p "$OUT/fma"
"$RUSTC" --edition 2021 --crate-type lib --crate-name hapticgen_runtime -D warnings -C target-feature=+fma \
    "$ROOT/runtime/src/lib.rs" --extern libm="$OUT/liblibm.rlib" -L "$OUT" --out-dir "$OUT/fma"
echo "msrv: generated code"
# The tests crate's build script generates every shipped model, variant and scalar.
# Its output directory is the one cargo reports for this build (the target directory holds
# others, from builds with other settings, possibly older: never guess it from their dates).
GENERATED=$(cargo build -q -p hapticgen-tests --message-format=json | python3 -c '
import json, sys
for line in sys.stdin:
    message = json.loads(line)
    if message.get("reason") == "build-script-executed" and "#hapticgen-tests@" in message.get("package_id", ""):
        print(message["out_dir"])
' | tail -n 1)
[ -n "$GENERATED" ] && [ -f "$GENERATED/registry.rs" ] \
    || { echo "msrv: cargo reported no generated rigs for hapticgen-tests (got '$GENERATED')" >&2; exit 1; }
LIB=$OUT/generated/lib.rs
{
    echo "//! Every shipped model's generated code, compiled with Rust 1.63."
    echo "#![no_std]"
} > "$LIB"
n=0
for file in "$GENERATED"/*.rs; do
    name=$(basename "$file" .rs)
    [ "$name" = registry ] && continue
    cp "$file" "$OUT/generated/$name.rs"
    printf 'pub mod %s {\n    include!("%s.rs");\n}\n' "$name" "$name" >> "$LIB"
    n=$((n + 1))
done
[ "$n" -gt 0 ] || { echo "msrv: no generated rig in $GENERATED: nothing to compile" >&2; exit 1; }
"$RUSTC" --edition 2021 --crate-type lib --crate-name generated_rigs -D warnings "$LIB" \
    --extern hapticgen_runtime="$OUT/libhapticgen_runtime.rlib" -L "$OUT" --out-dir "$OUT"
echo "msrv: ok: runtime and $n generated rigs build with $("$RUSTC" --version)"
