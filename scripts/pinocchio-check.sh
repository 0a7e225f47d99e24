#!/usr/bin/env bash
# Independent check of hapticgen's dynamics for every serial model: Pinocchio (PyPI `pin`)
# computes D (crba), C·q̇ + g (nonLinearEffects), g (computeGeneralizedGravity) and each named
# point's frame Jacobian (LOCAL_WORLD_ALIGNED, position rows) and each named frame's rotation
# (oMf) and angular rows of its LOCAL_WORLD_ALIGNED frame Jacobian, from the URDF that hapticgen
# exports, at 50 random states per model; every entry must agree with hapticgen's evaluator to
# 1e-10 (relative to the quantity's scale when that exceeds 1).
#
# Rotor inertia: hapticgen adds N²·J_m to D's diagonal; URDF has no place for it, so the check
# compares D − diag(N²·J_m) with crba. Viscous damping is not part of nonLinearEffects and not
# part of hapticgen's C·q̇ + g either. Models with direct poses (closed chains) are skipped.
#
# Usage: scripts/pinocchio-check.sh   (creates target/pinocchio-venv on first use)
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/pinocchio-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import pinocchio, numpy' 2>/dev/null; then
    "$venv/bin/pip" install --quiet pin numpy
fi

reference=target/pinocchio-reference
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
for path in sorted(glob.glob(os.path.join(directory, "*.json"))):
    name = os.path.basename(path)[:-5]
    with open(path) as f:
        ref = json.load(f)
    model = pin.buildModelFromUrdf(os.path.join(directory, name + ".urdf"))
    data = model.createData()
    model.gravity.linear = np.array(ref["gravity"])
    # hapticgen's joint order must be Pinocchio's (one 1-DOF joint each, same names).
    names = [model.names[i] for i in range(1, model.njoints)]
    if names != ref["joints"] or model.nq != len(ref["joints"]):
        failures.append(f"{name}: Pinocchio's joints {names} differ from hapticgen's {ref['joints']}")
        continue
    armature = np.diag(ref["armature"])
    worst = {"D": 0.0, "nle": 0.0, "g": 0.0, "J": 0.0, "p": 0.0, "R": 0.0, "Jw": 0.0}

    def compare(what, got, want, state):
        scale = max(1.0, float(np.max(np.abs(want))) if np.size(want) else 1.0)
        error = float(np.max(np.abs(np.asarray(got) - np.asarray(want)))) / scale
        key = what.split("[")[0]
        worst[key] = max(worst[key], error)
        if error > TOLERANCE:
            failures.append(f"{name} state {state}: {what} differs by {error:.3e} (relative to {scale:.3g})")

    for k, s in enumerate(ref["states"]):
        q, v = np.array(s["q"]), np.array(s["qd"])
        compare("D", np.reshape(pin.crba(model, data, q), (model.nv, model.nv)) + armature, np.array(s["D"]), k)
        compare("nle", pin.nonLinearEffects(model, data, q, v), np.array(s["nle"]), k)
        compare("g", pin.computeGeneralizedGravity(model, data, q), np.array(s["g"]), k)
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        for frame, values in s["points"].items():
            fid = model.getFrameId(frame)
            jacobian = np.reshape(pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED), (6, model.nv))[:3, :]
            compare(f"J[{frame}]", jacobian, np.array(values["J"]), k)
            compare(f"p[{frame}]", data.oMf[fid].translation, np.array(values["p"]), k)
        for frame, values in s.get("frames", {}).items():
            fid = model.getFrameId(frame)
            jacobian = np.reshape(pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED), (6, model.nv))[3:, :]
            compare(f"Jw[{frame}]", jacobian, np.array(values["Jw"]), k)
            compare(f"R[{frame}]", data.oMf[fid].rotation, np.array(values["R"]), k)
    summary.append(
        f"{name:<36} {model.nq} dof, {len(ref['states'])} states: max error "
        + ", ".join(f"{k} {v:.1e}" for k, v in worst.items())
    )

print("\n".join(summary))
if failures:
    print(f"\n{len(failures)} disagreements with Pinocchio {pin.__version__} (first 20):")
    print("\n".join(failures[:20]))
    sys.exit(1)
print(f"\nall {len(summary)} serial models agree with Pinocchio {pin.__version__} to {TOLERANCE:g}")
PY
