#!/usr/bin/env bash
# Builds one Cortex-M4F firmware image per line of targets/firmware/variants.txt, runs each
# under QEMU (MPS2-AN386, -icount shift=10) and checks it against the host reference run of
# the same scenario and against its limits; links each image's control-path probe and fails
# if a panic is reachable from the interrupt body; builds the example board image (stm32f4)
# and its probe the same way (see docs/firmware.md).
#
#   scripts/firmware.sh                  everything, limits enforced
#   scripts/firmware.sh --limits=warn    limit violations reported but not fatal
#   scripts/firmware.sh --plan [...]     print what the run would do (steps, images), do nothing
#   scripts/firmware.sh --only NAME      only that image: its build, checks and run (repeatable; the
#                                        host-side lint and unit tests stay in the full run; `stm32f4` is the board image, `link` the
#                                        host link's cost image: state frames to UART0, checked on the host;
#                                        `pil` the joystick's processor-in-the-loop image, run by `hapticgen pil`
#                                        against the host's plant and compared with `hapticgen simulate`,
#                                        then identification under QEMU and the joystick's image built from
#                                        the identified model file (HAPTICGEN_FW_MODEL) and run;
#                                        `pil-fig7` the parallel link's, tracing the circle of Fig. 7 (its first half: ~5 min);
#                                        `device` the device-mode image, driven by `hapticgen connect`;
#                                        `device-3d` the Delta's device-mode image, a hand pushing it into
#                                        a 3-D scene sent over the link)
#   HAPTICGEN_FW_OPT_LEVEL=s scripts/firmware.sh   another opt-level (the measurement in the docs)
#   HAPTICGEN_FW_FMA=1 scripts/firmware.sh         generated code with fused multiply-adds (vfma.f32)
#   HAPTICGEN_PIL_FIG7_SECONDS=8.8 scripts/firmware.sh --only pil-fig7   the whole Fig. 7 lap under PIL
#
# HAPTICGEN_FW_MODEL (one image from another model file, docs/firmware.md) is refused: every
# image here is built from its line's own model (the identified joystick's, `--only pil`, sets
# it for that one build).
#
# HAPTICGEN_HOST_TARGET_DIR: where the root workspace's `hapticgen` is built for the runs it
# drives (default: CARGO_TARGET_DIR, else <target dir>/host); CI points it at the target
# directory its tests built in, so that the CLI is not built a second time from scratch.
# Works with any CARGO_TARGET_DIR (binaries are found through `cargo metadata`); outputs land
# in <target dir>/images. Honours CARGO_BUILD_JOBS (default: 1, from targets/firmware's
# .cargo/config.toml). Fails, and says why, when a step cannot run, when `--only` names an
# unknown image, or when no image was checked.
#
# Installs what it needs on a fresh machine: the pinned toolchain's thumbv7em-none-eabihf
# target and llvm-tools (rustup) and qemu-system-arm (apt-get).
set -euo pipefail
cd "$(dirname "$0")/.."
# Every image here is its line's own model; HAPTICGEN_FW_MODEL (one image from another model
# file, docs/firmware.md) is for building by hand, and this script sets it for one build only.
if [ -n "${HAPTICGEN_FW_MODEL+set}" ]; then
    echo "FAIL HAPTICGEN_FW_MODEL is set ($HAPTICGEN_FW_MODEL): scripts/firmware.sh builds every image from its line's own model; unset it" >&2
    exit 1
fi
ROOT=$PWD
FW=$ROOT/targets/firmware
TARGET=thumbv7em-none-eabihf
BOARD=stm32f4                 # the board image's name for --only
BOARD_VARIANT=horizontal      # the variants.txt line it is built for (its wiring has two joints)
LINK=link                     # the host link's cost image, for --only (docs/link.md)
PIL=pil                       # the processor-in-the-loop run, for --only (docs/link-pil.md)
PIL_VARIANT=joystick          # the variants.txt line it is built for
PIL_MAX_COUNTS=4              # PIL vs simulate: largest joint difference, encoder counts (docs/link-pil.md)
PIL_FIG7=pil-fig7             # the processor-in-the-loop circle tracing, for --only (docs/link-pil.md)
PIL_FIG7_VARIANT=vertical     # the variants.txt line it is built for (the paper's parallel link)
# Simulated seconds of the Fig. 7 PIL run: the approach and the first half of the 6 s lap
# (about 5 min under QEMU, in the background); 8.8 for the whole figure (about 10 min).
PIL_FIG7_SECONDS=${HAPTICGEN_PIL_FIG7_SECONDS:-4.3}
DEVICE=device                 # the device-mode image driven by `hapticgen connect`, for --only (docs/link-device.md)
DEVICE_VARIANT=horizontal     # the variants.txt line it is built for (a 2-D task: the link's planar scene)
DEVICE3D=device-3d            # the device-mode image of a 3-D task, for --only (docs/link-device.md)
DEVICE3D_VARIANT=falcon       # the variants.txt line it is built for (the Delta: the link's scene in the god object)
QEMU_TIMEOUT=${HAPTICGEN_FW_QEMU_TIMEOUT:-300}
LIMITS=()
ONLY=()
PLAN=0
usage() { echo "usage: $0 [--plan] [--limits=warn] [--only NAME]..." >&2; exit 2; }
while [ $# -gt 0 ]; do
    case "$1" in
        --plan) PLAN=1 ;;
        --limits=warn) LIMITS=(--limits=warn) ;;
        --only) [ $# -ge 2 ] && [ -n "$2" ] || usage; ONLY+=("$2"); shift ;;
        --only=?*) ONLY+=("${1#--only=}") ;;
        *) usage ;;
    esac
    shift
done

START=$SECONDS
step() { printf '\n=== firmware [%ds]: %s ===\n' $((SECONDS - START)) "$*"; }
die() { printf 'FAIL %s\n' "$*" >&2; exit 1; }
# Background runs: `background NAME COMMAND…` starts COMMAND with its output in a log; the
# summary waits for each, prints its log, and counts NAME checked or failed by its exit code.
BACKGROUND_PIDS=()
BACKGROUND_NAMES=()
background() {
    local name=$1
    shift
    "$@" >"$OUT/$name.background.log" 2>&1 &
    BACKGROUND_PIDS+=($!)
    BACKGROUND_NAMES+=("$name")
    echo "started in the background (pid $!, log $OUT/$name.background.log)"
}

# The images: every line of variants.txt, and the board image.
TABLE=$(awk '{ sub(/#.*/, "") } NF { print $1 }' "$FW/variants.txt")
[ -n "$TABLE" ] || die "$FW/variants.txt lists no image"
# The processor-in-the-loop runs first: they wait on QEMU's serial link far more than they
# compute, so they run in the background (`background`) while the other images build and run.
# The device image runs last, in the foreground: its clock is the host's, so its 6 ms heartbeat
# timeout holds only if `hapticgen connect`'s heartbeat thread is not starved by the builds.
KNOWN=$(printf '%s\n%s\n%s\n%s\n%s\n%s\n%s\n' "$PIL" "$PIL_FIG7" "$TABLE" "$BOARD" "$LINK" "$DEVICE3D" "$DEVICE")
SELECTED=()
if [ ${#ONLY[@]} -eq 0 ]; then
    mapfile -t SELECTED <<<"$KNOWN"
else
    for NAME in "${ONLY[@]}"; do
        grep -qxF -- "$NAME" <<<"$KNOWN" || die "--only $NAME: no such image (known: $(tr '\n' ' ' <<<"$KNOWN"))"
        SELECTED+=("$NAME")
    done
fi

# What each selected image's part of the run does, for --plan.
plan_image() {
    case "$1" in
        "$LINK") echo "image $1: build (with the first variants.txt line's rig), run under QEMU, decode its UART stream, check instruction ceilings" ;;
        "$PIL_FIG7") echo "image $1 ($PIL_FIG7_VARIANT): lint, build, build hapticgen, hapticgen pil (Fig. 7 circle) vs simulate, in the background" ;;
        "$DEVICE") echo "image $1 ($DEVICE_VARIANT): lint, build, build hapticgen, scripts/device-run.sh (hapticgen connect under QEMU)" ;;
        "$DEVICE3D") echo "image $1 (the Falcon-like Delta): lint, build, build hapticgen, scripts/device-run-3d.sh (a hand pushed into a half-space and a box, held at F/K)" ;;
        "$PIL") echo "image $1 ($PIL_VARIANT): lint, build (image and probe), panic check, build hapticgen, hapticgen pil (Fig. 4 and fault tests) vs simulate, identification under QEMU (scripts/pil-identify.sh), in the background; then image $PIL_VARIANT built from the identified model file, run under QEMU, its own checks and limits" ;;
        "$BOARD") echo "image $1 ($BOARD_VARIANT): lint, layering (cargo tree), build (image, device image, probes), panic checks" ;;
        *) echo "image $1: lint, build (image and control-path probe), panic check, run under QEMU, compare with the host reference and check limits" ;;
    esac
}
if [ "$PLAN" -eq 1 ]; then
    echo "plan: toolchain and QEMU (installed if missing)"
    if [ ${#ONLY[@]} -eq 0 ]; then
        echo "plan: lint: host-side crates (clippy, warnings are errors)"
        echo "plan: unit tests: renderer, table parser, panic check, reference runs"
    fi
    echo "plan: host reference (hapticgen-fw-reference): build, pre-generated rigs"
    for NAME in "${SELECTED[@]}"; do echo "plan: $(plan_image "$NAME")"; done
    echo "plan: summary: ${#SELECTED[@]} image(s): ${SELECTED[*]}"
    exit 0
fi

step "toolchain and QEMU"
TOOLCHAIN=$(sed -n 's/^channel *= *"\(.*\)"/\1/p' "$FW/rust-toolchain.toml")
[ -n "$TOOLCHAIN" ] || die "no channel in $FW/rust-toolchain.toml"
rustup toolchain install "$TOOLCHAIN" --profile minimal --target "$TARGET" >/dev/null 2>&1 \
    || rustup target add --toolchain "$TOOLCHAIN" "$TARGET"
rustup target list --installed --toolchain "$TOOLCHAIN" | grep -qx "$TARGET" \
    || die "the $TARGET target of toolchain $TOOLCHAIN is not installed"
rustup component add --toolchain "$TOOLCHAIN" clippy >/dev/null 2>&1 || true
# llvm-objdump names the call sites when a probe still has a panic path (the check itself
# does not need it).
rustup component add --toolchain "$TOOLCHAIN" llvm-tools >/dev/null 2>&1 || true
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
SYSROOT=$(rustc --print sysroot)
HOST_TRIPLE=$(rustc -vV | sed -n 's/^host: //p')
OBJDUMP=$SYSROOT/lib/rustlib/$HOST_TRIPLE/bin/llvm-objdump
[ -x "$OBJDUMP" ] || OBJDUMP=$(command -v llvm-objdump || true)

# Where cargo puts this workspace's artifacts: $CARGO_TARGET_DIR, build.target-dir or ./target.
METADATA=$(cargo metadata --locked --format-version 1 --no-deps)
TARGET_DIR=$(printf '%s' "$METADATA" | sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')
[ -n "$TARGET_DIR" ] || die "cargo metadata did not name the target directory"
OUT=$TARGET_DIR/images
mkdir -p "$OUT"
echo "target directory: $TARGET_DIR"

# The host-side lint and unit tests cover every image: the full run's, not one image's (--only).
if [ ${#ONLY[@]} -eq 0 ]; then
    step "lint: host-side crates (clippy, warnings are errors)"
    # hapticgen-fw-build without its generator feature: its own tests need only the table parser;
    # the generator half is linted as the build dependency of hapticgen-fw-reference.
    cargo clippy --locked --all-targets -p hapticgen-fw-control -p hapticgen-fw-sim -p hapticgen-fw-reference \
        -p hapticgen-fw-build --no-default-features -- -D warnings

    step "unit tests: renderer, table parser, panic check, and each scenario's reference run against its closed-form physics"
    cargo test --locked -q -p hapticgen-fw-control -p hapticgen-fw-build -p hapticgen-fw-reference --no-default-features
fi

step "host reference (hapticgen-fw-reference)"
cargo build --locked -p hapticgen-fw-reference
REF=$TARGET_DIR/debug/hapticgen-fw-reference
[ -x "$REF" ] || die "the host reference was built but is not at $REF"
# The images compile the rigs the host reference generated (and its f32 run compiled): the
# image crates are built without their `generate` feature, so the generator is not built a
# second time (in the release profile's build-override) for their build scripts.
HAPTICGEN_FW_GENERATED=$("$REF" generated) || die "$REF generated failed"
[ -d "$HAPTICGEN_FW_GENERATED" ] || die "no pre-generated images at $HAPTICGEN_FW_GENERATED"
export HAPTICGEN_FW_GENERATED
NAMES=$("$REF" list) || die "$REF list failed"
[ -n "$NAMES" ] || die "the host reference lists no image"
[ "$NAMES" = "$TABLE" ] || die "the host reference lists $(tr '\n' ' ' <<<"$NAMES")but variants.txt $(tr '\n' ' ' <<<"$TABLE")"

# The panic check of a linked control-path probe; on failure, where the panics are called.
panic_check() {
    local name=$1 elf=$2
    if "$REF" panics "$elf"; then
        return 0
    fi
    if [ -x "$OBJDUMP" ]; then
        echo "call sites (source line of the call, and of each branch into its block):" >&2
        "$OBJDUMP" -d -l --no-show-raw-insn -C "$elf" 2>/dev/null | awk -v root="$ROOT/" '
            function hex(s,    i, v) {
                v = 0; sub(/^0x/, "", s)
                for (i = 1; i <= length(s); i++) v = v * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1
                return v
            }
            function panicky(name) { return name ~ /panic|unwrap_failed|expect_failed|_fail$|begin_unwind/ }
            /^[0-9a-f]+ <[^$].*>:$/ { fn = $0; sub(/^[0-9a-f]+ </, "", fn); sub(/>:$/, "", fn); next }
            # src: the source line of the next instructions; own: the last one outside the
            # standard library (whose inlined helpers hide the line that called them).
            /^; \/[^:]*:[0-9]+$/ {
                src = substr($0, 3); if (index(src, root) == 1) src = substr(src, length(root) + 1)
                if (src !~ /^\/rustc\//) own = src
                next
            }
            /^ *[0-9a-f]+:[ \t]/ {
                a = $1; sub(/:$/, "", a); a = hex(a); fn_of[a] = fn
                lib = src; sub(/^\/rustc\/[0-9a-f]+\//, "", lib)
                line_of[a] = (src ~ /^\/rustc\// && own != "") ? own " (inlined: " lib ")" : lib
                if (new_block) { block = a; new_block = 0 }
                name = ""
                if (match($0, /0x[0-9a-f]+ <[^>]*>/)) {
                    dest = substr($0, RSTART, RLENGTH)
                    t = hex(substr(dest, 1, index(dest, " ") - 1))
                    name = substr(dest, index(dest, "<") + 1); sub(/>$/, "", name)
                    if (panicky(name) && !panicky(fn)) { calls[++n] = a; callee[n] = name; start[n] = block }
                    else from[t] = from[t] " " a
                }
                # The next instruction starts a block after a jump, a return or a call that
                # does not return.
                if ($2 ~ /^(b|b\.w|b\.n|bx)$/ || ($2 ~ /^pop/ && $0 ~ /pc/) || panicky(name)) new_block = 1
            }
            END {
                for (k = 1; k <= n; k++) {
                    a = calls[k]
                    printf "  %s, called at 0x%x in %s (%s)\n", callee[k], a, fn_of[a], line_of[a]
                    split("", count); split("", order); u = 0
                    for (t = start[k]; t <= a; t += 2) {
                        if (!(t in from)) continue
                        m = split(from[t], sites, " ")
                        for (j = 1; j <= m; j++) {
                            l = line_of[sites[j] + 0]
                            if (!(l in count)) order[++u] = l
                            count[l]++
                        }
                    }
                    for (j = 1; j <= u; j++) printf "    reached from %s (%d branches)\n", order[j], count[order[j]]
                }
            }' >&2
    else
        echo "(no llvm-objdump for the call sites: rustup component add llvm-tools)" >&2
    fi
    FAILED+=("$name: a panic is reachable from the control path (see above)")
}

# Lints (warnings are errors) and builds the QEMU image crate's binaries `BIN…` for the
# variants.txt line `VARIANT`: `lint_and_build_qemu VARIANT BIN…`.
lint_and_build_qemu() {
    local variant=$1 bin
    shift
    local bins=()
    for bin in "$@"; do bins+=(--bin "$bin"); done
    HAPTICGEN_FW_VARIANT=$variant cargo clippy --locked --release --target "$TARGET" \
        -p hapticgen-fw-qemu --no-default-features "${bins[@]}" -- -D warnings
    HAPTICGEN_FW_VARIANT=$variant cargo build --locked --release --target "$TARGET" \
        -p hapticgen-fw-qemu --no-default-features "${bins[@]}"
}

# The `hapticgen` CLI (root workspace) for the runs it drives: `$HAPTICGEN`. Its build goes
# where this script's does, never into <repo>/target.
build_hapticgen() {
    HOST_TARGET_DIR=${HAPTICGEN_HOST_TARGET_DIR:-${CARGO_TARGET_DIR:-$TARGET_DIR/host}}
    (cd "$ROOT" && cargo build --locked -p hapticgen --target-dir "$HOST_TARGET_DIR") || die "building hapticgen failed"
    HAPTICGEN=$HOST_TARGET_DIR/debug/hapticgen
    [ -x "$HAPTICGEN" ] || die "hapticgen was built but is not at $HAPTICGEN"
}

# Runs image ELF under QEMU (exact instruction counts) into OUT_BASE.out and OUT_BASE.err,
# prints its report without the trace lines (`S …`) and returns QEMU's exit status.
run_image() {
    local status=0
    timeout "$QEMU_TIMEOUT" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
        -icount shift=10 -semihosting-config enable=on,target=native -kernel "$1" \
        >"$2.out" 2>"$2.err" || status=$?
    grep -v '^S ' "$2.out" || true
    return "$status"
}

# The line `$PIL_VARIANT`'s image built from the model file identified under QEMU
# (scripts/pil-identify.sh's `identified.yaml`) instead of its line's: its build script
# generates the rig from HAPTICGEN_FW_MODEL (the crate's `generate` feature, the pre-generated
# images unset: they are the lines' own models); run under QEMU; `check-other-model`: the run's
# own checks and the line's limits (the host reference runs the line's own model, so the
# comparisons with it are printed, not bounded). Adds its row to ROWS; fails if a step fails.
identified_image() {
    local name=$PIL_VARIANT model=$OUT/pil-identify/identified.yaml started=$SECONDS
    local elf=$OUT/$name.identified.elf status=0 row
    step "image $name from the identified model file ($model): build (its rig generated from HAPTICGEN_FW_MODEL)"
    [ -f "$model" ] || { echo "no identified model file at $model" >&2; return 1; }
    env -u HAPTICGEN_FW_GENERATED HAPTICGEN_FW_VARIANT="$name" HAPTICGEN_FW_MODEL="$model" \
        cargo build --locked --release --target "$TARGET" -p hapticgen-fw-qemu --bin hapticgen-fw-qemu || return 1
    cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu" "$elf"
    step "image $name from the identified model file: run under QEMU, its own checks, the line's limits"
    run_image "$elf" "$OUT/$name.identified" || status=$?
    if [ "$status" -ne 0 ]; then
        cat "$OUT/$name.identified.err" >&2
        echo "QEMU exit status $status" >&2
        return 1
    fi
    status=0
    row=$("$REF" check-other-model "$name" "$OUT/$name.identified.out" "$elf" "${LIMITS[@]}") || status=$?
    printf '%s\n' "$row"
    ROWS+=("$(sed "1s/^| $name |/| $name (identified model) |/" <<<"$row")")
    echo "image $name from the identified model file: $((SECONDS - started)) s"
    return "$status"
}

ROWS=()
FAILED=()
CHECKED=()
for NAME in "${SELECTED[@]}"; do
    if [ "$NAME" = "$LINK" ]; then
        # The link image holds no rig of its own; it is built with the first table line's.
        FIRST=$(head -n 1 <<<"$TABLE")
        step "link image: build (state frames to UART0, command frames through the device's link)"
        HAPTICGEN_FW_VARIANT=$FIRST cargo build --locked --release --target "$TARGET" \
            -p hapticgen-fw-qemu --no-default-features --bin hapticgen-fw-qemu-link-cost
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-link-cost" "$OUT/$LINK.elf"
        step "link image: run under QEMU, decode its UART stream on the host"
        STATUS=0
        timeout "$QEMU_TIMEOUT" qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
            -icount shift=10 -semihosting-config enable=on,target=native -serial "file:$OUT/$LINK.uart" \
            -kernel "$OUT/$LINK.elf" >"$OUT/$LINK.out" 2>"$OUT/$LINK.err" || STATUS=$?
        grep '^LINK' "$OUT/$LINK.out" || true
        if [ "$STATUS" -ne 0 ] || ! grep -q '^LINK_DONE uart_dropped=0$' "$OUT/$LINK.out"; then
            cat "$OUT/$LINK.err" >&2
            FAILED+=("$LINK: QEMU exit status $STATUS, or bytes dropped at the UART")
            continue
        fi
        "$REF" link-stream "$OUT/$LINK.uart" "$OUT/$LINK.out" || { FAILED+=("$LINK: UART stream"); continue; }
        # Ceilings just above today's cost (docs/link.md, "Cost on the Cortex-M4F"), so that a
        # regression fails: a state frame's per rig (1, 2, 3, 6 joints; moving, at rest and
        # with every value out of range: 386-395, 570-582, 754-766, 1,108-1,122 instructions),
        # a heartbeat's and an impedance command's (200, 1,020); and the goal itself: for the
        # 3-joint rig, the costliest state frame and a heartbeat in <= 1,000 instructions (966).
        LINK_FAIL=$(awk -v goal=1000 '/^LINK / {
                part = ""; max = 0; joints = 0
                for (i = 1; i <= NF; i++) {
                    split($i, kv, "=")
                    if (kv[1] == "part") part = kv[2]
                    if (kv[1] == "max") max = kv[2]
                    if (kv[1] == "joints") joints = kv[2]
                }
                row = (joints == 1) ? 1 : (joints == 2) ? 2 : (joints == 3) ? 3 : (joints == 6) ? 4 : 0
                split("405 590 775 1135", state_ceilings, " ")
                if (part ~ /^state/) limit = (row > 0) ? state_ceilings[row] : 0
                else limit = (part == "heartbeat") ? 210 : (part == "impedance") ? 1035 : 0
                if (limit == 0) print $0 ": no ceiling for this part"
                else if (max + 0 > limit) print $0 " over its ceiling " limit
                if (joints == 3 && part ~ /^state/ && max + 0 > state3) state3 = max + 0
                if (joints == 3 && part == "heartbeat") heartbeat3 = max + 0
            }
            END {
                if (state3 == 0 || heartbeat3 == 0) print "no 3-joint state frame or heartbeat measured"
                else if (state3 + heartbeat3 > goal) print "3 joints: costliest state frame " state3 " + heartbeat " heartbeat3 " = " state3 + heartbeat3 " > " goal
                else print "3 joints: costliest state frame " state3 " + heartbeat " heartbeat3 " = " state3 + heartbeat3 " <= " goal > "/dev/stderr"
            }' "$OUT/$LINK.out")
        if [ -n "$LINK_FAIL" ]; then
            printf '%s\n' "$LINK_FAIL" >&2
            FAILED+=("$LINK: instructions over the ceiling")
            continue
        fi
        CHECKED+=("$LINK")
        continue
    fi
    if [ "$NAME" = "$PIL_FIG7" ]; then
        step "PIL image ($PIL_FIG7_VARIANT): lint and build"
        lint_and_build_qemu "$PIL_FIG7_VARIANT" hapticgen-fw-qemu-pil
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-pil" "$OUT/$PIL_FIG7_VARIANT.pil.elf"
        build_hapticgen
        step "PIL: Fig. 7 (circle tracing) on the parallel link under QEMU vs hapticgen simulate (bound: $PIL_MAX_COUNTS counts through |J|, two grid spacings)"
        background "$PIL_FIG7" "$HAPTICGEN" pil "$ROOT/models/parallel_link_2dof.yaml" --variant "$PIL_FIG7_VARIANT" \
            --controller jacobian-transpose --scenario trace-circle --duration "$PIL_FIG7_SECONDS" \
            --compare --max-counts "$PIL_MAX_COUNTS" \
            --image "$OUT/$PIL_FIG7_VARIANT.pil.elf" -o "$OUT/pil-fig7"
        continue
    fi
    if [ "$NAME" = "$DEVICE" ]; then
        step "device image ($DEVICE_VARIANT): lint and build (its own clock; impedance, scene, enable and heartbeats from UART0)"
        lint_and_build_qemu "$DEVICE_VARIANT" hapticgen-fw-qemu-device
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-device" "$OUT/$DEVICE_VARIANT.device.elf"
        "$REF" size "$OUT/$DEVICE_VARIANT.device.elf"
        build_hapticgen
        step "device: hapticgen connect drives the image under QEMU (its safety checks, a scene that pushes it out of a wall)"
        if "$ROOT/scripts/device-run.sh" "$HAPTICGEN" "$OUT/$DEVICE_VARIANT.device.elf" "$OUT/device"; then
            CHECKED+=("$DEVICE")
        else
            FAILED+=("$DEVICE: hapticgen connect's checks against the device image (above)")
        fi
        continue
    fi
    if [ "$NAME" = "$DEVICE3D" ]; then
        step "device image ($DEVICE3D_VARIANT): lint and build (a 3-D task: the link's scene rendered by the god object)"
        lint_and_build_qemu "$DEVICE3D_VARIANT" hapticgen-fw-qemu-device
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-device" "$OUT/$DEVICE3D_VARIANT.device.elf"
        "$REF" size "$OUT/$DEVICE3D_VARIANT.device.elf"
        build_hapticgen
        step "device-3d: a hand pushes the Delta into a half-space and a box sent by hapticgen connect; held at F/K"
        if "$ROOT/scripts/device-run-3d.sh" "$HAPTICGEN" "$OUT/$DEVICE3D_VARIANT.device.elf" "$OUT/device-3d"; then
            CHECKED+=("$DEVICE3D")
        else
            FAILED+=("$DEVICE3D: the 3-D device image's held depths (above)")
        fi
        continue
    fi
    if [ "$NAME" = "$PIL" ]; then
        step "PIL image ($PIL_VARIANT): lint and build (the control path against sensor frames from UART0, and its probe)"
        lint_and_build_qemu "$PIL_VARIANT" hapticgen-fw-qemu-pil hapticgen-fw-qemu-pil-path
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-pil" "$OUT/$PIL_VARIANT.pil.elf"
        cp "$TARGET_DIR/$TARGET/release/hapticgen-fw-qemu-pil-path" "$OUT/$PIL_VARIANT.pil-path.elf"
        "$REF" size "$OUT/$PIL_VARIANT.pil.elf"
        step "PIL image: no panic reachable from a received byte, the period's control and the answer's framing"
        panic_check "$PIL" "$OUT/$PIL_VARIANT.pil-path.elf"
        step "PIL: the host side (hapticgen, root workspace)"
        build_hapticgen
        step "PIL: Fig. 4 on the joystick under QEMU vs hapticgen simulate (bound: $PIL_MAX_COUNTS encoder counts), then the fault tests (one sensor frame in 100 corrupted and a burst of 96 random bytes before one in 37, every bad frame dropped; the host goes silent at 0.25 s: safe state within 10 ms), then identification under QEMU (scripts/pil-identify.sh: D, C q̇, g within 2 %, friction 10 %, validation torque 5 %)"
        background "$PIL" bash -c '"$1" pil "$2/models/joystick_1dof.yaml" --controller natural-inertia --scenario step \
            --duration 2 --compare --max-counts "$3" --image "$4" -o "$5/pil-fig4" \
            && "$1" pil "$2/models/joystick_1dof.yaml" --controller natural-inertia --scenario step \
            --duration 0.3 --stop-after 0.25 --corrupt-every 100 --garbage-every 37 --image "$4" -o "$5/pil-fault" \
            && "$2/scripts/pil-identify.sh" "$1" "$4" "$5/pil-identify"' \
            pil "$HAPTICGEN" "$ROOT" "$PIL_MAX_COUNTS" "$OUT/$PIL_VARIANT.pil.elf" "$OUT"
        continue
    fi
    if [ "$NAME" = "$BOARD" ]; then
        step "board image $BOARD ($BOARD_VARIANT): lint (board support, runtime and generated code, for the target)"
        HAPTICGEN_FW_VARIANT=$BOARD_VARIANT cargo clippy --locked --release --target "$TARGET" \
            -p hapticgen-fw-stm32f4 --no-default-features --lib --bins -- -D warnings
        step "board image $BOARD: layering (no dependency on the simulator)"
        TREE=$(cargo tree --locked -p hapticgen-fw-stm32f4 --target "$TARGET" -e normal,build --prefix none)
        grep -q '^hapticgen-fw-control ' <<<"$TREE" || die "cargo tree of hapticgen-fw-stm32f4 looks wrong: $TREE"
        if grep -q '^hapticgen-fw-sim ' <<<"$TREE"; then
            FAILED+=("$BOARD: the board crate depends on hapticgen-fw-sim")
        else
            echo "hapticgen-fw-stm32f4 depends on: $(sed 's/ .*//' <<<"$TREE" | grep '^hapticgen' | sort -u | tr '\n' ' ')"
        fi
        step "board image $BOARD: build (image, device-mode image, their control-path probes)"
        HAPTICGEN_FW_VARIANT=$BOARD_VARIANT cargo build --locked --release --target "$TARGET" \
            -p hapticgen-fw-stm32f4 --no-default-features --bins
        BIN=$TARGET_DIR/$TARGET/release
        cp "$BIN/hapticgen-fw-stm32f4" "$OUT/$BOARD.elf"
        cp "$BIN/hapticgen-fw-stm32f4-control-path" "$OUT/$BOARD.control-path.elf"
        cp "$BIN/hapticgen-fw-stm32f4-device" "$OUT/$BOARD.device.elf"
        cp "$BIN/hapticgen-fw-stm32f4-device-path" "$OUT/$BOARD.device-path.elf"
        "$REF" size "$OUT/$BOARD.elf"
        "$REF" size "$OUT/$BOARD.device.elf"
        step "board image $BOARD: no panic reachable from the interrupt body"
        panic_check "$BOARD" "$OUT/$BOARD.control-path.elf"
        step "board image $BOARD, device mode: no panic reachable from the interrupt body or the link's byte handling (USART1)"
        panic_check "$BOARD" "$OUT/$BOARD.device-path.elf"
        CHECKED+=("$BOARD")
        continue
    fi

    step "image $NAME: lint (generated code, runtime and firmware, for the target)"
    HAPTICGEN_FW_VARIANT=$NAME cargo clippy --locked --release --target "$TARGET" \
        -p hapticgen-fw-qemu --no-default-features --bins -- -D warnings
    step "image $NAME: build (image and control-path probe)"
    HAPTICGEN_FW_VARIANT=$NAME cargo build --locked --release --target "$TARGET" \
        -p hapticgen-fw-qemu --no-default-features --bin hapticgen-fw-qemu --bin hapticgen-fw-qemu-control-path
    BIN=$TARGET_DIR/$TARGET/release
    ELF=$OUT/$NAME.elf
    cp "$BIN/hapticgen-fw-qemu" "$ELF"
    cp "$BIN/hapticgen-fw-qemu-control-path" "$OUT/$NAME.control-path.elf"
    "$REF" size "$ELF"

    step "image $NAME: no panic reachable from the control path"
    panic_check "$NAME" "$OUT/$NAME.control-path.elf"

    step "image $NAME: run under QEMU"
    STATUS=0
    run_image "$ELF" "$OUT/$NAME" || STATUS=$?
    if [ "$STATUS" -ne 0 ]; then
        cat "$OUT/$NAME.err" >&2
        if [ "$STATUS" -eq 124 ]; then
            FAILED+=("$NAME: QEMU timed out after ${QEMU_TIMEOUT}s")
        else
            FAILED+=("$NAME: QEMU exit status $STATUS")
        fi
        continue
    fi

    step "image $NAME: compare with the host reference, check limits"
    if ROW=$("$REF" check "$NAME" "$OUT/$NAME.out" "$ELF" "${LIMITS[@]}"); then
        ROWS+=("$ROW")
    else
        ROWS+=("$ROW")
        FAILED+=("$NAME: see FAIL lines above")
    fi
    printf '%s\n' "$ROW"
    CHECKED+=("$NAME")
done

for i in "${!BACKGROUND_PIDS[@]}"; do
    NAME=${BACKGROUND_NAMES[$i]}
    step "background run $NAME: waiting for it (pid ${BACKGROUND_PIDS[$i]})"
    if wait "${BACKGROUND_PIDS[$i]}"; then
        cat "$OUT/$NAME.background.log"
        if [ "$NAME" = "$PIL" ] && ! identified_image; then
            FAILED+=("$NAME: the $PIL_VARIANT image built from the identified model file (above)")
        else
            CHECKED+=("$NAME")
        fi
    else
        cat "$OUT/$NAME.background.log"
        FAILED+=("$NAME: run or comparison (its log is above)")
    fi
done

step "summary (instructions; opt-level ${HAPTICGEN_FW_OPT_LEVEL:-from Cargo.toml})"
echo "| image | impedance min | mean | max | current min | mean | max | flash B | RAM B | checksum | max |Δx| / |Δi| vs f64 |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for ROW in "${ROWS[@]}"; do printf '%s\n' "$ROW" | head -n 1; done
[ ${#CHECKED[@]} -eq ${#SELECTED[@]} ] \
    || FAILED+=("${#SELECTED[@]} images selected, ${#CHECKED[@]} checked")
[ ${#CHECKED[@]} -gt 0 ] || FAILED+=("no image was checked")
if [ ${#FAILED[@]} -gt 0 ]; then
    printf 'FAIL %s\n' "${FAILED[@]}" >&2
    exit 1
fi
echo "firmware: all ${#CHECKED[@]} images passed (${CHECKED[*]}) in $((SECONDS - START)) s"
