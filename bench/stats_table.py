#!/usr/bin/env python3
"""docs/operation-counts.md's table of `hapticgen stats`: the operation counts of the main emitted
functions for every variant of every model in `models/`, as a Markdown table.

Each cell is `arithmetic + trig`: arithmetic is additions, multiplications, divisions, square
roots and negations (and fused multiply-adds with `--fma`, one each), trig the sine and cosine
evaluations of the function (a `sin_cos` counts two). Not part of the test command; needs
`pip install pyyaml` for the variant names.

    cargo build --release -p hapticgen && python3 bench/stats_table.py [--fma]
"""
import glob
import json
import os
import subprocess
import sys

import yaml

FUNCTIONS = [
    ("D", "inertia_matrix"),
    ("C·q̇", "coriolis_times_qdot"),
    ("g", "gravity"),
    ("p", "position"),
    ("J", "jacobian"),
    ("J̇·q̇", "jacobian_dot_times_qdot"),
    ("inverse dynamics", "inverse_dynamics"),
    ("`terms` (one tick's D, C·q̇, g, p, J, J̇·q̇)", "terms"),
    ("Jacobian-transpose law (Controller 3, fused)", "jacobian_transpose_torque"),
]


def main():
    fma = "--fma" in sys.argv[1:]
    binary = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "hapticgen")
    if not os.path.exists(binary):
        sys.exit(f"{binary} not found: run `cargo build --release -p hapticgen` first")
    print("| model | variant | " + " | ".join(label for label, _ in FUNCTIONS) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in FUNCTIONS) + " |")
    for path in sorted(glob.glob("models/*.yaml")):
        with open(path) as f:
            variants = list((yaml.safe_load(f).get("variants") or {}).keys()) or [None]
        for variant in variants:
            command = [binary, "stats", path, "--json"] + (["--variant", variant] if variant else []) + (["--fma"] if fma else [])
            counts = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
            cells = []
            for _, function in FUNCTIONS:
                c = counts.get(function)
                if c is None:
                    cells.append("—")
                    continue
                arithmetic = sum(c[k] for k in ("additions", "multiplications", "divisions", "square_roots", "negations", "fused"))
                cells.append(f"{arithmetic} + {c['trigonometric']}")
            print(f"| `{os.path.basename(path)}` | {variant or '—'} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
