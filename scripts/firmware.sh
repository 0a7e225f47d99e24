#!/usr/bin/env bash
# Builds one Cortex-M4F firmware image per line of targets/firmware/variants.txt, runs each
# under QEMU (MPS2-AN386, -icount shift=10) and checks it against the host reference run of
# the same scenario, and against the limits (see docs/firmware.md).
#
#   scripts/firmware.sh                  everything, limits enforced
#   scripts/firmware.sh --limits=warn    limit violations reported but not fatal
#   scripts/firmware.sh --only NAME      one image
#   HAPTICGEN_FW_OPT_LEVEL=s scripts/firmware.sh   another opt-level (the measurement in the docs)
#   HAPTICGEN_FW_FMA=1 scripts/firmware.sh         generated code with fused multiply-adds (vfma.f32)
#
# Installs what it needs on a fresh machine: the pinned toolchain's thumbv7em-none-eabihf
# target (rustup) and qemu-system-arm (apt-get).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
FW=$ROOT/targets/firmware
TARGET=thumbv7em-none-eabihf
QEMU_TIMEOUT=${HAPTICGEN_FW_QEMU_TIMEOUT:-300}
LIMITS=()
ONLY=""
while [ $# -gt 0 ]; do
    case "$1" in
        --limits=warn) LIMITS=(--limits=warn) ;;
        --only) ONLY=$2; shift ;;
        *) echo "usage: $0 [--limits=warn] [--only NAME]" >&2; exit 2 ;;
    esac
    shift
done

step() { printf '\n=== firmware: %s ===\n' "$*"; }
die() { printf 'FAIL %s\n' "$*" >&2; exit 1; }

step "toolchain and QEMU"
TOOLCHAIN=$(sed -n 's/^channel *= *"\(.*\)"/\1/p' "$FW/rust-toolchain.toml")
rustup toolchain install "$TOOLCHAIN" --profile minimal --target "$TARGET" >/dev/null 2>&1 \
    || rustup target add --toolchain "$TOOLCHAIN" "$TARGET"
rustup target list --installed --toolchain "$TOOLCHAIN" | grep -qx "$TARGET" \
    || die "the $TARGET target of toolchain $TOOLCHAIN is not installed"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO=sudo
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get install -y --no-install-recommends qemu-system-arm >/dev/null 2>&1 || {
        $SUDO apt-get update >/dev/null
        $SUDO apt-get install -y --no-install-recommends qemu-system-arm >/dev/null
    }
fi
command -v qemu-system-arm >/dev/null || die "qemu-system-arm is missing and could not be installed"
qemu-system-arm --version | head -n 1

cd "$FW"
export CARGO_TERM_COLOR=never
if [ -n "${HAPTICGEN_FW_OPT_LEVEL:-}" ]; then
    export CARGO_PROFILE_RELEASE_OPT_LEVEL=$HAPTICGEN_FW_OPT_LEVEL
fi

step "lint: host-side crates (clippy, warnings are errors)"
rustup component add --toolchain "$TOOLCHAIN" clippy >/dev/null 2>&1 || true
cargo clippy --locked -j1 --all-targets -p hapticgen-fw-control -p hapticgen-fw-sim -p hapticgen-fw-host \
    -p hapticgen-fw-build -- -D warnings

step "unit tests: renderer, table parser, and each scenario's reference run against its closed-form physics"
cargo test --locked -j1 -q -p hapticgen-fw-control -p hapticgen-fw-build -p hapticgen-fw-host

step "host reference (hapticgen-fw-host)"
cargo build --locked -j1 -p hapticgen-fw-host
HOST=$FW/target/debug/hapticgen-fw-host

OUT=$FW/target/images
mkdir -p "$OUT"
ROWS=()
FAILED=()
for NAME in $("$HOST" list); do
    [ -z "$ONLY" ] || [ "$ONLY" = "$NAME" ] || continue
    step "image $NAME: lint (generated code, runtime and firmware, for the target)"
    HAPTICGEN_FW_VARIANT=$NAME cargo clippy --locked -j1 --release --target "$TARGET" -p hapticgen-fw-qemu -- -D warnings
    step "image $NAME: build"
    HAPTICGEN_FW_VARIANT=$NAME cargo build --locked -j1 --release --target "$TARGET" -p hapticgen-fw-qemu
    ELF=$OUT/$NAME.elf
    cp "$FW/target/$TARGET/release/hapticgen-fw-qemu" "$ELF"
    "$HOST" size "$ELF"

    step "image $NAME: run under QEMU"
    STATUS=0
    timeout "$QEMU_TIMEOUT" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
        -icount shift=10 -semihosting-config enable=on,target=native -kernel "$ELF" \
        >"$OUT/$NAME.out" 2>"$OUT/$NAME.err" || STATUS=$?
    grep -v '^S ' "$OUT/$NAME.out" || true
    if [ "$STATUS" -ne 0 ]; then
        cat "$OUT/$NAME.err" >&2
        [ "$STATUS" -eq 124 ] && FAILED+=("$NAME: QEMU timed out after ${QEMU_TIMEOUT}s") \
            || FAILED+=("$NAME: QEMU exit status $STATUS")
        continue
    fi

    step "image $NAME: compare with the host reference, check limits"
    if ROW=$("$HOST" check "$NAME" "$OUT/$NAME.out" "$ELF" "${LIMITS[@]}"); then
        ROWS+=("$ROW")
    else
        ROWS+=("$ROW")
        FAILED+=("$NAME: see FAIL lines above")
    fi
    printf '%s\n' "$ROW"
done

step "summary (instructions; opt-level ${HAPTICGEN_FW_OPT_LEVEL:-from Cargo.toml})"
echo "| image | impedance min | mean | max | current min | mean | max | flash B | RAM B | checksum | max |Δx| / |Δi| vs f64 |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for ROW in "${ROWS[@]}"; do printf '%s\n' "$ROW" | head -n 1; done
if [ ${#FAILED[@]} -gt 0 ]; then
    printf 'FAIL %s\n' "${FAILED[@]}" >&2
    exit 1
fi
echo "firmware: all images passed"
