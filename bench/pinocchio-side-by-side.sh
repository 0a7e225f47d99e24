#!/usr/bin/env bash
# Side-by-side timing of hapticgen's generated dynamics against Pinocchio's C++ algorithms on
# the same model and the same states (the PHANToM-like arm's and the Falcon-like Delta's speed targets, docs/performance.md).
# Not part of the test command.
#
#   bench/pinocchio-side-by-side.sh [MODEL [VARIANT]]    # default models/phantom_3dof.yaml
#   bench/pinocchio-side-by-side.sh models/falcon_delta.yaml   # a spatial closed chain
#   ROUNDS=5 bench/pinocchio-side-by-side.sh              # more alternating rounds (default 5)
#
# Everything it builds and writes goes under cargo's target directory (`target/`, or wherever
# CARGO_TARGET_DIR or the cargo configuration puts it; asked of `cargo metadata`).
#
# 1. Builds tests/examples/pinocchio_side_by_side.rs (release, f64; the generated code is what
#    the tests crate's build script generates from MODEL now, without fused multiply-adds).
# 2. Writes the URDF (as `hapticgen export-urdf` does; for a spatial closed chain, which
#    export-urdf refuses, the open tree its loops were cut into) and the states (with gravity,
#    rotor inertias and the task frame; for a closed chain also the tree's actuated joints, the
#    cut closures and the loop solver's bounds) to <target>/pinocchio-bench/run/: 64 random
#    states for a serial model, 1,000 along a smooth closed trajectory of the actuated
#    coordinates for a closed chain (each loop solve starts from the state before's solution).
# 3. Builds bench/pinocchio/side_by_side.cpp twice against the `pin` wheel's headers and shared
#    libraries (installed into <target>/pinocchio-venv, the venv of scripts/pinocchio-check.sh,
#    with the wheels of Eigen and the URDF headers the wheel was built with): "library", with
#    the compile definitions of Pinocchio's CMake package (PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION:
#    the algorithms are the wheel's compiled ones in libpinocchio_default.so), and "headers",
#    without it (the algorithms are instantiated from the headers in the benchmark's own
#    translation unit). g++ -O3 -DNDEBUG, default x86-64 target like the Rust side (no
#    -march=native: it would also change Eigen's alignment from the wheel's). For a closed chain
#    the C++ program closes the loops itself (Newton on the closure constraints with
#    Pinocchio's frame placements and Jacobians) and projects the tree's quantities onto the
#    actuated coordinates (see the top of side_by_side.cpp).
# 4. Checks that Pinocchio and the generated code agree at every state to 1e-9 relative to each
#    quantity's largest entry (D, C·q̇ + g, C·q̇, g, p, J, J̇·q̇; the generated functions and the
#    fused `terms`); stops if not.
# 5. Runs the three programs alternately ROUNDS times; each reports the best of 25 batches of
#    2,000 calls per quantity, and the table shows the best over the rounds (the machine is
#    shared). Ratios are Pinocchio / hapticgen, with the faster of the two Pinocchio builds.
#    A closed chain's every call, on both sides, includes solving the loops at its state.
set -euo pipefail
cd "$(dirname "$0")/.."

model=${1:-models/phantom_3dof.yaml}
variant=${2:--}
rounds=${ROUNDS:-5}
jobs=${JOBS:-2}

command -v g++ >/dev/null || { echo "g++ is required (Debian: apt-get install g++)" >&2; exit 1; }
target=$(cargo metadata --format-version 1 --no-deps |
    python3 -c 'import json, sys; sys.stdout.write(json.load(sys.stdin)["target_directory"])')
[ -n "$target" ] || { echo "cargo metadata gave no target directory" >&2; exit 1; }

# --- Pinocchio: the wheel, plus the headers needed to compile against it --------------------
venv=$target/pinocchio-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import pinocchio, numpy' 2>/dev/null; then
    "$venv/bin/pip" install --quiet pin numpy
fi
site=$("$venv/bin/python" -c 'import sysconfig, sys; sys.stdout.write(sysconfig.get_paths()["purelib"])')
prefix=$site/cmeel.prefix
[ -d "$prefix/include/pinocchio" ] || { echo "no Pinocchio headers under $prefix" >&2; exit 1; }
# The wheel ships Pinocchio's and Boost's headers but not Eigen's nor urdfdom's headers: install
# the cmeel wheels of the versions the wheel was built against (eigenpy's build requirement is
# Eigen 3.4.1; the URDF headers' version is in Pinocchio's CMake package, below).
targets=$prefix/lib/cmake/pinocchio/pinocchioTargets.cmake
urdf_major=$(sed -n 's/.*PINOCCHIO_URDFDOM_HEADERS_MAJOR_VERSION=\([0-9]*\).*/\1/p' "$targets" | head -n1)
urdf_minor=$(sed -n 's/.*PINOCCHIO_URDFDOM_HEADERS_MINOR_VERSION=\([0-9]*\).*/\1/p' "$targets" | head -n1)
urdf_patch=$(sed -n 's/.*PINOCCHIO_URDFDOM_HEADERS_PATCH_VERSION=\([0-9]*\).*/\1/p' "$targets" | head -n1)
if [ ! -f "$prefix/include/eigen3/Eigen/Core" ]; then
    "$venv/bin/pip" install --quiet "cmeel-eigen==3.4.1"
fi
if [ ! -f "$prefix/include/urdfdom_headers/urdf_model/model.h" ]; then
    "$venv/bin/pip" install --quiet "cmeel-urdfdom-headers==$urdf_major.$urdf_minor.$urdf_patch"
fi
pin_version=$("$venv/bin/python" -c 'import pinocchio; print(pinocchio.__version__)')

# Compile definitions of the imported targets pinocchio_headers, _default and _parsers, as a
# CMake user of the package gets them (generator expressions, which name coal's, dropped).
mapfile -t definitions < <(
    sed -n '/set_target_properties(pinocchio::pinocchio_\(headers\|default\|parsers\) PROPERTIES/,/^)/s/.*INTERFACE_COMPILE_DEFINITIONS "\(.*\)"/\1/p' "$targets" \
        | tr ';' '\n' | grep -v '^\\\?\$<' | grep -v '^$' | sort -u
)
[ "${#definitions[@]}" -gt 0 ] || { echo "no compile definitions found in $targets" >&2; exit 1; }

out=$target/pinocchio-bench
run=$out/run
mkdir -p "$run"
# -isystem: the wheel's headers (coal's) are not ours to warn about.
flags=(-std=c++17 -O3 -DNDEBUG -Wall
    -isystem "$prefix/include" -isystem "$prefix/include/eigen3"
    -isystem "$prefix/include/urdfdom_headers" -isystem "$prefix/include/urdfdom")
libs=(-L"$prefix/lib" -lpinocchio_parsers -lpinocchio_default -lurdfdom_model -Wl,-rpath,"$(cd "$prefix/lib" && pwd)")
source=bench/pinocchio/side_by_side.cpp
compile() { # NAME DEFINITIONS...
    local name=$1
    shift
    local binary=$out/side_by_side_$name stamp=$out/side_by_side_$name.flags
    local signature
    signature="$(g++ --version | head -n1) $pin_version ${flags[*]} $* ${libs[*]} $(sha256sum "$source")"
    if [ -x "$binary" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$signature" ]; then
        return
    fi
    echo "building $binary (g++ -O3 -DNDEBUG, Pinocchio $pin_version, $name)" >&2
    g++ "${flags[@]}" "$@" "$source" -o "$binary" "${libs[@]}"
    printf '%s' "$signature" > "$stamp"
}
library_definitions=()
header_definitions=()
for d in "${definitions[@]}"; do
    library_definitions+=("-D$d")
    [ "$d" = PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION ] || header_definitions+=("-D$d")
done
# The two builds in parallel (about 2 minutes each on one core, once).
compile library "${library_definitions[@]}" &
library_build=$!
compile headers "${header_definitions[@]}" &
headers_build=$!
wait "$library_build"
wait "$headers_build"

# --- hapticgen -----------------------------------------------------------------------------
cargo build --quiet --release -j"$jobs" -p hapticgen-tests --example pinocchio_side_by_side
rust=$target/release/examples/pinocchio_side_by_side
variant_flag=()
[ "$variant" = - ] || variant_flag=(--variant "$variant")
"$rust" urdf "$model" "$variant" "$run/model.urdf"
"$rust" states "$model" "$variant" "$run/states.txt"
states=$(sed -n 's/^states \([0-9]*\)$/\1/p' "$run/states.txt")
closed=no
grep -q '^tree ' "$run/states.txt" && closed=yes

# --- agreement -----------------------------------------------------------------------------
for build in library headers; do
    "$out/side_by_side_$build" "$run/model.urdf" "$run/states.txt" "$run/results_$build.txt" > /dev/null
    echo "Pinocchio $pin_version ($build build) against hapticgen:"
    "$rust" check "$model" "$variant" "$run/states.txt" "$run/results_$build.txt"
done

# --- timing, alternately -------------------------------------------------------------------
: > "$run/timings.txt"
for round in $(seq "$rounds"); do
    echo "round $round of $rounds" >&2
    "$out/side_by_side_library" "$run/model.urdf" "$run/states.txt" "$run/scratch.txt" | sed 's/^/library /' >> "$run/timings.txt"
    "$rust" time "$model" "$variant" "$run/states.txt" | sed 's/^/hapticgen /' >> "$run/timings.txt"
    "$out/side_by_side_headers" "$run/model.urdf" "$run/states.txt" "$run/scratch.txt" | sed 's/^/headers /' >> "$run/timings.txt"
done

echo
if [ "$closed" = yes ]; then
    echo "$model${variant_flag[*]:+ ${variant_flag[*]}}: ns per call including the loop solve, best of $rounds alternating rounds × 25 batches × 2,000 calls along $states states of a closed trajectory"
else
    echo "$model${variant_flag[*]:+ ${variant_flag[*]}}: ns per call, best of $rounds alternating rounds × 25 batches × 2,000 calls over $states states"
fi
echo "(f64; g++ $(g++ -dumpfullversion) -O3 -DNDEBUG and rustc release, both default x86-64 target; Pinocchio $pin_version from PyPI \`pin\`)"
echo
awk -v closed="$closed" '
    { key = $1 " " $2; if (!(key in best) || $3 < best[key]) best[key] = $3 }
    function cell(x) { return (x == "") ? "–" : sprintf("%.1f", x) }
    function row(what, calls, pk, hk,    l, h, p, g) {
        l = best["library " pk]; h = best["headers " pk]; g = best["hapticgen " hk]
        p = (l < h) ? l : h
        printf "| %s | %s | %s | %s | %s | %.1f× |\n", what, calls, cell(l), cell(h), cell(g), p / g
    }
    END {
        if (closed == "yes") {
            # Every Pinocchio row starts with the loop solve (Newton: forwardKinematics +
            # updateFramePlacement per step, computeJointJacobians + getFrameJacobian for Φ_p and
            # A), and the velocity rows with forwardKinematics(q, q̇, 0) for the bias Ṡq̇_a.
            print "| quantity | Pinocchio calls after the loop solve (hapticgen function) | Pinocchio ns, wheel library | Pinocchio ns, headers compiled here | hapticgen ns | Pinocchio / hapticgen |"
            print "| --- | --- | --- | --- | --- | --- |"
            row("D", "`crba`, SᵀDS (`inertia_matrix`)", "D", "D")
            row("C·q̇ + g", "`rnea(q, q̇, Ṡq̇_a)`, Sᵀ (`coriolis_times_qdot` + `gravity`)", "nle", "nle")
            row("g", "`computeGeneralizedGravity`, Sᵀ (`gravity`)", "g", "g")
            row("p", "`updateFramePlacement`, no A (`position`)", "p", "p")
            row("J", "`getFrameJacobian`, LOCAL_WORLD_ALIGNED, J S (`jacobian`)", "J", "J")
            row("J̇·q̇", "`getFrameClassicalAcceleration` + J Ṡq̇_a (`jacobian_dot_times_qdot`)", "Jdqd", "Jdqd")
            row("bundle: D, C·q̇, g, p, J, J̇·q̇", "one loop solve, then the calls above (`terms`)", "bundle", "terms")
            row("bundle: D, C·q̇, g, p, J, J̇·q̇", "one loop solve, `computeAllTerms(q, q̇)` for the tree and the bias, then the projections (`terms`)", "allterms", "terms")
            printf "\nPinocchio'"'"'s loop solve alone (Newton, A, q̇ and the bias Ṡq̇_a, as in the bundle): %.1f ns (wheel library), %.1f ns (headers); %.2f Newton steps per solve.\n", best["library loops"], best["headers loops"], best["library newton_steps_per_solve"]
            exit
        }
        print "| quantity | Pinocchio calls (hapticgen function) | Pinocchio ns, wheel library | Pinocchio ns, headers compiled here | hapticgen ns | Pinocchio / hapticgen |"
        print "| --- | --- | --- | --- | --- | --- |"
        row("D", "`crba` (`inertia_matrix`)", "D", "D")
        row("C·q̇ + g", "`nonLinearEffects` (`coriolis_times_qdot` + `gravity`)", "nle", "nle")
        row("g", "`computeGeneralizedGravity` (`gravity`)", "g", "g")
        row("p", "`forwardKinematics(q)` + `updateFramePlacement` (`position`)", "p", "p")
        row("J", "`computeFrameJacobian`, LOCAL_WORLD_ALIGNED (`jacobian`)", "J", "J")
        row("J̇·q̇", "`forwardKinematics(q, v, 0)` + `getFrameClassicalAcceleration` (`jacobian_dot_times_qdot`)", "Jdqd", "Jdqd")
        row("bundle: D, C·q̇, g, p, J, J̇·q̇", "the calls above for D, C·q̇ + g, g, J (gives p), J̇·q̇ (`terms`)", "bundle", "terms")
        row("bundle: D, C·q̇, g, p, J, J̇·q̇", "`computeAllTerms` + `updateFramePlacement` + `getFrameJacobian` + `getFrameClassicalAcceleration` (`terms`)", "allterms", "terms")
    }
' "$run/timings.txt"
if [ "$model" = models/falcon_delta.yaml ]; then
    # The same rig with its loops solved by Newton's method (the solver of every spatial chain
    # without a closed form), timed once after the rounds above.
    echo "hapticgen with the loops solved by Newton's method instead of the closed form (close_loops at the velocity level, as in \`terms\`; $("$rust" loop-steps "$model" "$variant" "$run/states.txt" | sed -n 's/^newton_steps_per_solve //p') Newton steps per solve): \`terms\` $("$rust" time-newton "$model" "$variant" "$run/states.txt" | sed -n 's/^terms //p') ns."
fi
echo
echo "raw timings: $run/timings.txt"
