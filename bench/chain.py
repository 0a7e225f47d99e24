#!/usr/bin/env python3
"""Writes model files of serial chains with n = 1..7 revolute joints for the scaling
measurements of docs/operation-counts.md: spatial chains `chain_N.yaml` (alternating axes, centres
of mass off the axes, full inertia tensors) and planar chains `planar_chain_N.yaml` (vertical
plane, centres of mass off the link axes): `python3 bench/chain.py OUTDIR`."""
import sys
from pathlib import Path

out = Path(sys.argv[1] if len(sys.argv) > 1 else "target/chains")
out.mkdir(parents=True, exist_ok=True)
for n in range(1, 8):
    lines = [
        f"# A {n}-joint spatial serial chain for the scaling benchmark (bench/chain.py).",
        f"name: chain_{n}", "space: spatial", "gravity: [0.0, 0.0, -9.81]", "drives:", "  d:",
        "    motor: {rotor_inertia: 1.0e-5, resistance: 0.3, inductance: 1.0e-4, torque_constant: 0.03}",
        "    gear_ratio: 10.0", "    torque_limit: 2.0", "    current_limit: 7.0", "    supply_voltage: 24.0",
        "    encoder: {counts_per_turn: 2000}", "joints:",
    ]
    for i in range(n):
        lines += [f"  - name: q{i + 1}", "    type: revolute", "    limits: {lower: -3.0, upper: 3.0}", "    drive: d"]
    lines += ["bodies:"]
    for i in range(n):
        rpy = "[1.5707963267948966, 0.0, 0.0]" if i % 2 == 1 else "[0.0, 0.0, 0.0]"
        lines += [
            f"  - name: l{i + 1}", f"    mass: {1.0 + 0.1 * i:g}", "    com: [0.1, 0.01, 0.02]",
            "    inertia: {ixx: 0.01, iyy: 0.02, izz: 0.025, ixy: 0.001, ixz: 0.0005, iyz: 0.0002}",
            f"    parent: {'base' if i == 0 else f'l{i}'}",
            f"    origin: {{xyz: [{'0.0' if i == 0 else '0.3'}, 0.0, 0.05], rpy: {rpy}}}", f"    joint: q{i + 1}",
        ]
    lines += [
        "points:", "  - name: tip", f"    body: l{n}", "    position: [0.2, 0.0, 0.0]", "task:", "  point: tip",
        "rates: {current_loop_hz: 7500, impedance_loop_hz: 1000}",
        "current_loop: {bandwidth_hz: 700.0, damping_ratio: 1.05, anti_alias_cutoff_hz: 2500.0}",
    ]
    (out / f"chain_{n}.yaml").write_text("\n".join(lines) + "\n")

for n in range(1, 8):
    lines = [
        f"# A {n}-joint planar serial chain for the scaling benchmark (bench/chain.py).",
        f"name: planar_chain_{n}", "space: planar", "gravity: [0.0, -9.81]", "drives:", "  d:",
        "    motor: {rotor_inertia: 1.0e-5, resistance: 0.3, inductance: 1.0e-4, torque_constant: 0.03}",
        "    gear_ratio: 10.0", "    torque_limit: 2.0", "    current_limit: 7.0", "    supply_voltage: 24.0",
        "    encoder: {counts_per_turn: 2000}", "joints:",
    ]
    for i in range(n):
        lines += [f"  - name: q{i + 1}", "    type: revolute", "    limits: {lower: -3.0, upper: 3.0}", "    drive: d"]
    lines += ["bodies:"]
    for i in range(n):
        lines += [
            f"  - name: l{i + 1}", f"    mass: {1.0 + 0.1 * i:g}", "    com: [0.15, 0.01]", "    inertia: 0.01",
            f"    parent: {'base' if i == 0 else f'l{i}'}",
            f"    origin: {{xyz: [{'0.0' if i == 0 else '0.3'}, 0.0]}}", f"    joint: q{i + 1}",
        ]
    lines += [
        "points:", "  - name: tip", f"    body: l{n}", "    position: [0.3, 0.0]", "task:", "  point: tip",
        "rates: {current_loop_hz: 7500, impedance_loop_hz: 1000}",
        "current_loop: {bandwidth_hz: 700.0, damping_ratio: 1.05, anti_alias_cutoff_hz: 2500.0}",
    ]
    (out / f"planar_chain_{n}.yaml").write_text("\n".join(lines) + "\n")
