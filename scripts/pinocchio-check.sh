#!/usr/bin/env bash
# Independent check of hapticgen's dynamics for every serial model: Pinocchio (PyPI `pin`)
# computes D (crba), C·q̇ + g (nonLinearEffects), g (computeGeneralizedGravity) and each named
# point's frame Jacobian (LOCAL_WORLD_ALIGNED, position rows) and each named frame's rotation
# (oMf) and angular rows of its LOCAL_WORLD_ALIGNED frame Jacobian, from the URDF that hapticgen
# exports, at 50 random states per model; every entry must agree with hapticgen's evaluator to
# 1e-10 (relative to the quantity's scale when that exceeds 1). The same for the hand-written
# URDFs of tests/urdf/ (written by no exporter): hapticgen imports each (`import-urdf`'s code)
# and Pinocchio reads the original file (with its <mimic> joints, `mimic=True`: a hand-written
# arm has two, which hapticgen imports as mimic joints).
#
# Rotor inertia: hapticgen adds N²·J_m to D's diagonal; URDF has no place for it, so the check
# compares D − diag(N²·J_m) with crba. Viscous damping is not part of nonLinearEffects and not
# part of hapticgen's C·q̇ + g either. Other models with direct poses (closed chains) are skipped.
#
# The check fails, rather than passing on nothing, when no model was exported, when the set of
# exported models differs from the set checked, or when a model has no states to compare.
#
# A closed chain whose loop makes its open tree's angles linear in its coordinates (the PHANToM
# Premium-like arm's parallelogram) is checked through a hand-written open tree,
# tests/urdf-trees/NAME.urdf, and the loop's map NAME.map.json (q_tree = S q): Pinocchio's tree
# dynamics reduced by S (D = Sᵀ D_tree S, C·q̇ + g = Sᵀ nle_tree(S q, S q̇), J = J_tree S).
#
# Usage: scripts/pinocchio-check.sh   (creates <target dir>/pinocchio-venv on first use; the
# target directory is cargo's: `target/` or wherever CARGO_TARGET_DIR puts it)
set -euo pipefail
cd "$(dirname "$0")/.."

target_dir=$(cargo metadata --format-version 1 --no-deps \
    | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')
[ -n "$target_dir" ] || { echo "pinocchio-check: cargo metadata named no target directory" >&2; exit 1; }

venv=$target_dir/pinocchio-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import pinocchio, numpy' 2>/dev/null; then
    "$venv/bin/pip" install --quiet pin numpy
    "$venv/bin/python" -c 'import pinocchio, numpy' \
        || { echo "pinocchio-check: pinocchio and numpy do not import after installing them" >&2; exit 1; }
fi

reference=$target_dir/pinocchio-reference
rm -rf "$reference"
cargo run --quiet -p hapticgen-tests --example pinocchio_reference -- "$reference"

"$venv/bin/python" - "$reference" <<'PY'
import glob, json, os, sys

import numpy as np
import pinocchio as pin

TOLERANCE = 1e-10
directory = sys.argv[1]
failures = []
summary = []
comparisons = 0
# The exporter lists every model it wrote; each must be here and checked, and nothing else.
with open(os.path.join(directory, "models.txt")) as f:
    exported = sorted(line.strip() for line in f if line.strip())
found = sorted(os.path.basename(p)[:-5] for p in glob.glob(os.path.join(directory, "*.json")))
if not exported:
    sys.exit("pinocchio-check: FAIL: the exporter wrote no serial model, so nothing was checked")
if found != exported:
    sys.exit(f"pinocchio-check: FAIL: reference files {found} differ from the exported models {exported}")
for path in sorted(glob.glob(os.path.join(directory, "*.json"))):
    name = os.path.basename(path)[:-5]
    with open(path) as f:
        ref = json.load(f)
    # mimic=True: a URDF's <mimic> joints follow their leaders in Pinocchio's model (no
    # velocity of their own), as hapticgen's mimic joints do.
    model = pin.buildModelFromUrdf(os.path.join(directory, name + ".urdf"), mimic=True)
    data = model.createData()
    model.gravity.linear = np.array(ref["gravity"])
    # Every quantity goes through S, the tree's velocities from hapticgen's (q_tree = S q):
    # for a serial model, a permutation (Pinocchio numbers a branching tree depth first, the
    # URDF importer in document order); for a closed chain written as a hand-written open tree,
    # the loop's map (tests/urdf-trees/NAME.map.json). Then D = S^T D_tree S, C qd + g = S^T nle_tree(S q, S qd)
    # (S is constant, so the tree's accelerations are S qdd exactly), J = J_tree S.
    names = [model.names[i] for i in range(1, model.njoints) if model.joints[i].shortname() != "JointModelMimic"]
    mimics = model.njoints - 1 - len(names)
    map_path = os.path.join(directory, name + ".map")
    if os.path.exists(map_path):
        with open(map_path) as f:
            tree_from_model = json.load(f)["tree_from_model"]
        unknown = {c for row in tree_from_model.values() for c in row} - set(ref["joints"])
        if sorted(names) != sorted(tree_from_model) or model.nv != len(names):
            failures.append(f"{name}: the tree's joints {names} differ from the map's {sorted(tree_from_model)}")
            continue
        if unknown:
            failures.append(f"{name}: the map names {sorted(unknown)}, not coordinates of the model")
            continue
    elif sorted(names) != sorted(ref["joints"]) or model.nv != len(ref["joints"]):
        failures.append(f"{name}: Pinocchio's joints {names} differ from hapticgen's {ref['joints']}")
        continue
    else:
        tree_from_model = {j: {j: 1.0} for j in ref["joints"]}
    tree_joints = [model.joints[model.getJointId(j)] for j in names]
    if any(j.nv != 1 for j in tree_joints):
        failures.append(f"{name}: a joint with other than one velocity")
        continue
    S = np.zeros((model.nv, len(ref["joints"])))
    for joint_name, row in tree_from_model.items():
        for column, value in row.items():
            S[model.joints[model.getJointId(joint_name)].idx_v, ref["joints"].index(column)] = value

    def configuration(q_hapticgen):
        angles = S @ np.asarray(q_hapticgen)
        q = np.zeros(model.nq)
        for joint in tree_joints:
            value = angles[joint.idx_v]
            if joint.nq == 2:  # a continuous joint: (cos q, sin q)
                q[joint.idx_q:joint.idx_q + 2] = [np.cos(value), np.sin(value)]
            else:
                q[joint.idx_q] = value
        return q

    def velocity(v_hapticgen):
        return S @ np.asarray(v_hapticgen)

    def in_hapticgen_order(x):
        """A joint-space force vector or the joint-space matrix D, reduced to hapticgen's coordinates."""
        x = np.asarray(x)
        return S.T @ x if x.ndim == 1 else S.T @ x @ S

    def columns_in_hapticgen_order(jacobian):
        return np.asarray(jacobian) @ S

    armature = np.array(ref["armature"])  # N x N: C^T diag(N^2 J_m) C
    worst = {"D": 0.0, "nle": 0.0, "g": 0.0, "J": 0.0, "p": 0.0, "R": 0.0, "Jw": 0.0}

    def compare(what, got, want, state):
        global comparisons
        comparisons += 1
        scale = max(1.0, float(np.max(np.abs(want))) if np.size(want) else 1.0)
        error = float(np.max(np.abs(np.asarray(got) - np.asarray(want)))) / scale
        key = what.split("[")[0]
        worst[key] = max(worst[key], error)
        if error > TOLERANCE:
            failures.append(f"{name} state {state}: {what} differs by {error:.3e} (relative to {scale:.3g})")

    if not ref["states"]:
        failures.append(f"{name}: no states to compare")
    for k, s in enumerate(ref["states"]):
        q, v = configuration(s["q"]), velocity(s["qd"])
        crba = np.reshape(pin.crba(model, data, q), (model.nv, model.nv))
        crba = np.triu(crba) + np.triu(crba, 1).T  # crba fills the upper triangle
        compare("D", in_hapticgen_order(crba) + armature, np.array(s["D"]), k)
        compare("nle", in_hapticgen_order(pin.nonLinearEffects(model, data, q, v)), np.array(s["nle"]), k)
        compare("g", in_hapticgen_order(pin.computeGeneralizedGravity(model, data, q)), np.array(s["g"]), k)
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        for frame, values in s["points"].items():
            fid = model.getFrameId(frame)
            jacobian = np.reshape(pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED), (6, model.nv))[:3, :]
            compare(f"J[{frame}]", columns_in_hapticgen_order(jacobian), np.array(values["J"]), k)
            compare(f"p[{frame}]", data.oMf[fid].translation, np.array(values["p"]), k)
        for frame, values in s.get("frames", {}).items():
            fid = model.getFrameId(frame)
            jacobian = np.reshape(pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED), (6, model.nv))[3:, :]
            compare(f"Jw[{frame}]", columns_in_hapticgen_order(jacobian), np.array(values["Jw"]), k)
            compare(f"R[{frame}]", data.oMf[fid].rotation, np.array(values["R"]), k)
    summary.append(
        f"{name:<36} {model.nv} dof{f' (+{mimics} mimic)' if mimics else ''}, {len(ref['states'])} states: max error "
        + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
    )

print("\n".join(summary))
if failures:
    print(f"\n{len(failures)} disagreements with Pinocchio {pin.__version__} (first 20):")
    print("\n".join(failures[:20]))
    sys.exit(1)
if len(summary) != len(exported):
    sys.exit(f"pinocchio-check: FAIL: {len(summary)} models checked of {len(exported)} exported")
print(
    f"\nall {len(summary)} serial models agree with Pinocchio {pin.__version__} to {TOLERANCE:g} "
    f"({comparisons} comparisons)"
)
PY
