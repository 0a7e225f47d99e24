#!/usr/bin/env python3
"""The other tools of docs/operation-counts.md's operation counts, measured on the same models.

A textbook Lagrangian derivation (per-body Jacobians, D = Σ m Jᵥᵀ Jᵥ + J_ωᵀ I J_ω + diag(N² J_m),
C from the Christoffel symbols, g = ∂V/∂q, J = ∂p/∂q, J̇·q̇ = Σᵢ ∂(J q̇)/∂qᵢ q̇ᵢ), written once
over a scalar type and run with two symbolic back ends:

* **SymPy**: the outputs D, C·q̇, g, J and J̇·q̇, optionally `trigsimp` + `simplify`, then
  `cse` over all of them and C code printing (`ccode`, written to OUT_DIR); the operations are
  counted on the CSE'd expressions.
* **CasADi** SX: the same outputs as one `casadi.Function` with common-subexpression
  elimination (`cse: True`), C code generation (`Function.generate`, written to OUT_DIR); the
  operations are counted on the function's SX algorithm, instruction by instruction.

Counted like `hapticgen stats` counts: additions, subtractions, multiplications, divisions,
negations and square roots are arithmetic (a square, SymPy's `x**2` or CasADi's `sq`, is one
multiplication; CasADi's `twice` one addition); sine and cosine evaluations are
trig. A CasADi `sin` and `cos` of the same angle are two, as are SymPy's.

Models: `parallel_link` (the paper's parallelogram, `models/parallel_link_2dof.yaml`'s vertical
variant, transcribed here because URDF cannot describe its direct poses), or any URDF that
`hapticgen export-urdf` wrote (gravity and the rotor inertias N²·J_m are read from its header;
the point is the first `point_*` link unless `--point` names another; `--check` compares with
hapticgen's values for the same point).

Not part of the test command; needs `pip install sympy casadi`:

    python3 bench/other_tools.py parallel_link --check models/parallel_link_2dof.yaml
    cargo run --release -p hapticgen -- export-urdf models/phantom_3dof.yaml -o target/phantom.urdf
    python3 bench/other_tools.py target/phantom.urdf --check models/phantom_3dof.yaml
    cargo run --release -p hapticgen -- export-urdf models/puma560.yaml -o target/puma560.urdf
    python3 bench/other_tools.py target/puma560.urdf --point tool --check models/puma560.yaml --tools casadi,sympy-cse
"""
import argparse
import json
import math
import os
import random
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ElementTree

# ---------------------------------------------------------------------------------------------
# Models: numeric data and a function that builds the kinematics over a back end's scalars.
# ---------------------------------------------------------------------------------------------


def snap(x):
    """Rounds the float noise of right angles (cos(π/2) = 6e-17) to the exact 0 or ±1."""
    for exact in (0.0, 1.0, -1.0):
        if abs(x - exact) < 1e-12:
            return exact
    return x


def mat_mul(a, b):
    return [[sum_terms([a[i][k] * b[k][j] for k in range(len(b))]) for j in range(len(b[0]))] for i in range(len(a))]


def mat_vec(a, v):
    return [sum_terms([a[i][k] * v[k] for k in range(len(v))]) for i in range(len(a))]


def transpose(a):
    return [list(row) for row in zip(*a)]


def is_zero(x):
    return isinstance(x, (int, float)) and x == 0


def sum_terms(terms):
    """Σ terms, skipping exact numeric zeros so that the back ends see no `0·x`."""
    total = 0
    for term in terms:
        if is_zero(term):
            continue
        total = term if is_zero(total) else total + term
    return total


def times(c, x):
    """c·x for a numeric c, with 0 and ±1 exact."""
    if c == 0 or is_zero(x):
        return 0
    if c == 1:
        return x
    if c == -1:
        return -x
    return c * x


def rpy_matrix(roll, pitch, yaw):
    cr, sr, cp, sp_, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw))
    r = [
        [cy * cp, cy * sp_ * sr - sy * cr, cy * sp_ * cr + sy * sr],
        [sy * cp, sy * sp_ * sr + cy * cr, sy * sp_ * cr - cy * sr],
        [-sp_, cp * sr, cp * cr],
    ]
    return [[snap(x) for x in row] for row in r]


class Body:
    """One rigid body: mass, centre of mass p(q) (3-vector, base frame), angular-velocity
    Jacobian J_ω(q) (3 × n, base frame) and inertia about the centre of mass in base axes."""

    def __init__(self, mass, com, angular_jacobian, inertia):
        self.mass, self.com, self.angular_jacobian, self.inertia = mass, com, angular_jacobian, inertia


class ParallelLink:
    """The paper's parallelogram (`models/parallel_link_2dof.yaml`, vertical variant)."""

    name = "parallel_link"
    point_name = "end_effector"

    def __init__(self):
        self.joints = ["q1", "q2"]
        self.gravity = [0.0, -9.81, 0.0]
        self.armature = [12.0**2 * 1.42e-5] * 2

    def build(self, be, q):
        c1, s1, c2, s2 = be.cos(q[0]), be.sin(q[0]), be.cos(q[1]), be.sin(q[1])
        u = {0: (c1, s1), 1: (c2, s2)}

        def along(terms):
            return [sum_terms([times(length, u[a][0]) for length, a in terms]), sum_terms([times(length, u[a][1]) for length, a in terms]), 0]

        def spin(angle, izz):
            jw = [[0, 0], [0, 0], [1 if angle == 0 else 0, 1 if angle == 1 else 0]]
            return jw, [[0, 0, 0], [0, 0, 0], [0, 0, izz]]

        rod = lambda m, length: m * length**2 / 12
        l_l, l_e = 0.15, 0.05
        masses = [0.020358, 0.06075, 0.020358, 0.081]
        bodies = []
        # (mass, com as lengths along the links' directions, inertia, angle)
        for m, com, length, angle in [
            (masses[0], [(0.075, 0)], 0.15, 0),
            (masses[1], [(0.075, 1)], 0.15, 1),
            (masses[2], [(l_l, 1), (0.075, 0)], 0.15, 0),
            (masses[3], [(l_l, 0), (0.05, 1)], 0.2, 1),
        ]:
            jw, inertia = spin(angle, rod(m, length))
            bodies.append(Body(m, along(com), jw, inertia))
        point = along([(l_l, 0), (-l_e, 1)])[:2]
        return bodies, point


class Urdf:
    """A serial chain as `hapticgen export-urdf` writes it."""

    def __init__(self, path, point):
        text = open(path).read()
        root = ElementTree.fromstring(text)
        self.name = root.get("name")
        gravity = re.search(r"gravity \(m/s², base frame\): \[([^\]]*)\]", text)
        self.gravity = [float(x) for x in gravity.group(1).split(",")] if gravity else [0.0, 0.0, -9.81]
        armature = {m.group(1): float(m.group(2)) for m in re.finditer(r"joint (\S+): .*adds N²·J_m = (\S+) to D", text)}
        self.links = {}
        for link in root.findall("link"):
            inertial = link.find("inertial")
            if inertial is None:
                self.links[link.get("name")] = None
                continue
            origin = inertial.find("origin")
            xyz = [float(x) for x in origin.get("xyz", "0 0 0").split()] if origin is not None else [0.0] * 3
            rpy = [float(x) for x in origin.get("rpy", "0 0 0").split()] if origin is not None else [0.0] * 3
            i = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
            tensor = [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
            rotation = rpy_matrix(*rpy)
            tensor = mat_mul(mat_mul(rotation, tensor), transpose(rotation))
            self.links[link.get("name")] = (float(inertial.find("mass").get("value")), xyz, tensor)
        self.parent_joint = {}
        self.joints = []
        for joint in root.findall("joint"):
            origin = joint.find("origin")
            xyz = [float(x) for x in origin.get("xyz", "0 0 0").split()] if origin is not None else [0.0] * 3
            rpy = [float(x) for x in origin.get("rpy", "0 0 0").split()] if origin is not None else [0.0] * 3
            axis = joint.find("axis")
            kind = joint.get("type")
            if kind not in ("revolute", "continuous", "prismatic", "fixed"):
                sys.exit(f"{path}: joint {joint.get('name')}: type {kind} not supported")
            entry = {
                "name": joint.get("name"),
                "kind": kind,
                "parent": joint.find("parent").get("link"),
                "xyz": xyz,
                "rotation": rpy_matrix(*rpy),
                "axis": [float(x) for x in axis.get("xyz").split()] if axis is not None else [1.0, 0.0, 0.0],
            }
            self.parent_joint[joint.find("child").get("link")] = entry
            if kind != "fixed":
                self.joints.append(entry["name"])
        self.armature = [armature.get(j, 0.0) for j in self.joints]
        points = [name for name in self.links if name.startswith("point_")]
        self.point = f"point_{point}" if point else (points[0] if points else None)
        self.point_name = self.point[len("point_"):] if self.point else None
        if self.point not in self.links:
            sys.exit(f"{path}: no point link {self.point!r} (the named points are {points})")

    def build(self, be, q):
        index = {name: k for k, name in enumerate(self.joints)}
        n = len(self.joints)
        frames = {}

        def frame(link):
            """(R, p, angular Jacobian columns) of a link in the base frame."""
            if link in frames:
                return frames[link]
            joint = self.parent_joint.get(link)
            if joint is None:
                result = ([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [0, 0, 0], [[0] * n for _ in range(3)])
            else:
                r_parent, p_parent, jw_parent = frame(joint["parent"])
                r_origin = mat_mul(r_parent, joint["rotation"])
                p = [sum_terms([p_parent[i], sum_terms([times(joint["xyz"][k], r_parent[i][k]) for k in range(3)])]) for i in range(3)]
                jw = [list(row) for row in jw_parent]
                r = r_origin
                if joint["kind"] != "fixed":
                    k = index[joint["name"]]
                    axis = joint["axis"]
                    world_axis = [sum_terms([times(axis[j], r_origin[i][j]) for j in range(3)]) for i in range(3)]
                    if joint["kind"] == "prismatic":
                        p = [sum_terms([p[i], world_axis[i] * q[k]]) for i in range(3)]
                    else:
                        r = mat_mul(r_origin, axis_rotation(be, axis, q[k]))
                        for i in range(3):
                            jw[i][k] = world_axis[i]
                result = (r, p, jw)
            frames[link] = result
            return result

        bodies = []
        for name, inertial in self.links.items():
            if inertial is None:
                continue
            mass, com, tensor = inertial
            r, p, jw = frame(name)
            com_world = [sum_terms([p[i], sum_terms([times(com[k], r[i][k]) for k in range(3)])]) for i in range(3)]
            inertia_world = mat_mul(mat_mul(r, tensor), transpose(r))
            bodies.append(Body(mass, com_world, jw, inertia_world))
        return bodies, frame(self.point)[1]


def axis_rotation(be, axis, angle):
    """Rodrigues' rotation about a unit axis (numeric) by a symbolic angle."""
    c, s = be.cos(angle), be.sin(angle)
    x, y, z = axis
    k = [[0, -z, y], [z, 0, -x], [-y, x, 0]]
    kk = [[snap(sum(k[i][m] * k[m][j] for m in range(3))) for j in range(3)] for i in range(3)]
    one_minus_c = 1 - c
    return [
        [sum_terms([1 if i == j else 0, times(k[i][j], s), times(kk[i][j], one_minus_c)]) for j in range(3)]
        for i in range(3)
    ]


# ---------------------------------------------------------------------------------------------
# The Lagrangian, over any back end with sin, cos and diff.
# ---------------------------------------------------------------------------------------------


def lagrangian_outputs(model, be):
    n = len(model.joints)
    q = [be.symbol(f"q{k + 1}") for k in range(n)]
    qd = [be.symbol(f"qd{k + 1}") for k in range(n)]
    bodies, point = model.build(be, q)
    d = [[0] * n for _ in range(n)]
    potential = 0
    for body in bodies:
        jv = [[be.diff(body.com[i], q[k]) for k in range(n)] for i in range(3)]
        translational = mat_mul(transpose(jv), jv)
        rotational = mat_mul(mat_mul(transpose(body.angular_jacobian), body.inertia), body.angular_jacobian)
        for a in range(n):
            for b in range(n):
                d[a][b] = sum_terms([d[a][b], times(body.mass, translational[a][b]), rotational[a][b]])
        potential = sum_terms([potential] + [times(-body.mass * model.gravity[i], body.com[i]) for i in range(3)])
    for k in range(n):
        d[k][k] = sum_terms([d[k][k], model.armature[k]])
    partial = [[[be.diff(d[a][b], q[c]) for c in range(n)] for b in range(n)] for a in range(n)]
    coriolis_times_qdot = []
    for k in range(n):
        terms = []
        for i in range(n):
            for j in range(n):
                christoffel = sum_terms([partial[k][j][i], partial[k][i][j], times(-1, partial[i][j][k])])
                if not is_zero(christoffel):
                    terms.append(0.5 * christoffel * qd[i] * qd[j])
        coriolis_times_qdot.append(sum_terms(terms))
    gravity = [be.diff(potential, qk) for qk in q]
    jacobian = [[be.diff(p, qk) for qk in q] for p in point]
    jacobian_qdot = mat_vec(jacobian, qd)
    jacobian_dot_qdot = [sum_terms([be.diff(v, q[i]) * qd[i] for i in range(n)]) for v in jacobian_qdot]
    outputs = [x for row in d for x in row] + coriolis_times_qdot + gravity + [x for row in jacobian for x in row] + jacobian_dot_qdot
    return q, qd, outputs


# ---------------------------------------------------------------------------------------------
# Back ends.
# ---------------------------------------------------------------------------------------------


class SymPy:
    def __init__(self, simplify):
        import sympy

        self.sp, self.simplify = sympy, simplify
        self.label = f"SymPy, {'simplify + ' if simplify else ''}cse"

    def symbol(self, name):
        return self.sp.Symbol(name, real=True)

    def sin(self, x):
        return self.sp.sin(x)

    def cos(self, x):
        return self.sp.cos(x)

    def diff(self, e, x):
        return self.sp.diff(e, x) if not isinstance(e, (int, float)) else 0

    def run(self, model, out_dir):
        sp = self.sp
        start = time.time()
        _, _, outputs = lagrangian_outputs(model, self)
        outputs = [sp.sympify(e) for e in outputs]
        if self.simplify:
            outputs = [sp.simplify(sp.trigsimp(e)) for e in outputs]
        replacements, reduced = sp.cse(outputs)
        lines = [f"const double {symbol} = {sp.ccode(e)};" for symbol, e in replacements]
        lines += [f"out[{k}] = {sp.ccode(e)};" for k, e in enumerate(reduced)]
        seconds = time.time() - start
        write(out_dir, f"{model.name}_sympy{'_simplify' if self.simplify else ''}.c", "\n".join(lines) + "\n")
        ops = sp.count_ops([e for _, e in replacements] + list(reduced), visual=True)
        counts = {str(k): int(v) for k, v in ops.as_coefficients_dict().items()}
        trig = counts.get("SIN", 0) + counts.get("COS", 0)
        arithmetic = sum(counts.get(k, 0) for k in ("ADD", "SUB", "MUL", "DIV", "NEG", "SQRT", "POW"))
        # count_ops counts each power once: right for squares; x**k with an integer k > 2 costs
        # the multiplications of binary powering, and what is not such a power is reported.
        odd_powers = set()
        for e in [e for _, e in replacements] + list(reduced):
            for node in sp.preorder_traversal(e):
                if isinstance(node, sp.Pow) and node.exp != 2:
                    k = node.exp
                    if k.is_Integer and k > 2:
                        arithmetic += int(k).bit_length() + bin(int(k)).count("1") - 3
                    else:
                        odd_powers.add(str(node))
        if odd_powers:
            counts["powers other than integer ones"] = sorted(odd_powers)
        unknown = {k: v for k, v in counts.items() if k not in ("ADD", "SUB", "MUL", "DIV", "NEG", "SQRT", "POW", "SIN", "COS")}

        def evaluate(q_values, qd_values):
            # The CSE'd code itself, so that a wrong simplification would show.
            values = {self.symbol(f"q{k + 1}"): v for k, v in enumerate(q_values)}
            values.update({self.symbol(f"qd{k + 1}"): v for k, v in enumerate(qd_values)})
            for symbol, e in replacements:
                values[symbol] = e.evalf(subs=values)
            return [float(e.evalf(subs=values)) for e in reduced]

        return arithmetic, trig, seconds, unknown, evaluate


class CasADi:
    label = "CasADi SX, cse"

    def __init__(self):
        import casadi

        self.ca = casadi

    def symbol(self, name):
        return self.ca.SX.sym(name)

    def sin(self, x):
        return self.ca.sin(x)

    def cos(self, x):
        return self.ca.cos(x)

    def diff(self, e, x):
        if isinstance(e, (int, float)):
            return 0
        return self.ca.jacobian(e, x)

    def run(self, model, out_dir):
        ca = self.ca
        start = time.time()
        q, qd, outputs = lagrangian_outputs(model, self)
        outputs = [ca.SX(e) if isinstance(e, (int, float)) else e for e in outputs]
        function = ca.Function("terms", [ca.vertcat(*q), ca.vertcat(*qd)], [ca.vertcat(*outputs)], {"cse": True})
        seconds = time.time() - start
        if out_dir:
            os.makedirs(out_dir, exist_ok=True)
            function.generate(f"{model.name}_casadi.c", {"with_header": False})
            os.replace(f"{model.name}_casadi.c", os.path.join(out_dir, f"{model.name}_casadi.c"))
        names = {getattr(ca, k): k[3:].lower() for k in dir(ca) if k.startswith("OP_")}
        arithmetic_ops = {"add": 1, "sub": 1, "mul": 1, "div": 1, "neg": 1, "sq": 1, "twice": 1, "sqrt": 1, "inv": 1, "fmin": 1, "fmax": 1}
        free = {"const", "input", "output", "parameter", "assign"}
        arithmetic = trig = 0
        unknown = {}
        for k in range(function.n_instructions()):
            op = names.get(function.instruction_id(k), str(function.instruction_id(k)))
            if op in arithmetic_ops:
                arithmetic += arithmetic_ops[op]
            elif op in ("sin", "cos"):
                trig += 1
            elif op not in free:
                unknown[op] = unknown.get(op, 0) + 1

        def evaluate(q_values, qd_values):
            return [float(x) for x in ca.DM(function(q_values, qd_values)).full().ravel()]

        return arithmetic, trig, seconds, unknown, evaluate


def write(out_dir, name, text):
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        with open(os.path.join(out_dir, name), "w") as f:
            f.write(text)


def hapticgen_values(model_file, variant, point, q_values, qd_values):
    """D, C·q̇, g, J and J̇·q̇ from `hapticgen eval` (the generator's own evaluator), in the
    order of `lagrangian_outputs`."""
    binary = "target/release/hapticgen"
    command = [binary] if os.path.exists(binary) else ["cargo", "run", "--release", "-q", "-p", "hapticgen", "--"]
    # Random states may lie beyond the joints' limits: the formulas are compared, not the device.
    command += ["eval", model_file, "--q", ",".join(map(repr, q_values)), "--qd", ",".join(map(repr, qd_values)), "--beyond-limits"]
    if variant:
        command += ["--variant", variant]
    if point:
        command += ["--point", point]
    values = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
    return [x for row in values["D"] for x in row] + values["C_qd"] + values["g"] + [x for row in values["J"] for x in row] + values["Jdot_qd"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model", help="`parallel_link` or a URDF written by `hapticgen export-urdf`")
    parser.add_argument("--point", help="the named point whose J and J̇·q̇ are outputs (default: the first)")
    parser.add_argument("--tools", default="sympy-simplify,sympy-cse,casadi", help="comma-separated: sympy-simplify, sympy-cse, casadi")
    parser.add_argument("--check", metavar="MODEL.yaml", help="first compare every tool's outputs with `hapticgen eval` of this model at three random states")
    parser.add_argument("--variant", help="the variant of --check's model")
    parser.add_argument("--out", default="target/other-tools", help="where the generated C files go")
    args = parser.parse_args()
    model = ParallelLink() if args.model == "parallel_link" else Urdf(args.model, args.point)
    print(f"{model.name}: D, C·q̇, g, J, J̇·q̇ together ({len(model.joints)} joints)")
    for tool in args.tools.split(","):
        backend = {"sympy-simplify": lambda: SymPy(True), "sympy-cse": lambda: SymPy(False), "casadi": CasADi}[tool]()
        arithmetic, trig, seconds, unknown, evaluate = backend.run(model, args.out)
        extra = f" (also counted nowhere: {unknown})" if unknown else ""
        if args.check:
            generator = random.Random(7)
            worst = 0.0
            for _ in range(3):
                q_values = [generator.uniform(-1.0, 1.0) for _ in model.joints]
                qd_values = [generator.uniform(-2.0, 2.0) for _ in model.joints]
                want = hapticgen_values(args.check, args.variant, model.point_name, q_values, qd_values)
                got = evaluate(q_values, qd_values)
                worst = max([worst] + [abs(a - b) / max(1.0, abs(b)) for a, b in zip(got, want)])
            if worst > 1e-9:
                sys.exit(f"{backend.label}: outputs differ from `hapticgen eval {args.check}` by {worst:.2e}")
            extra += f" (agrees with hapticgen eval to {worst:.0e})"
        print(f"  {backend.label:<24} {arithmetic:>6} arithmetic + {trig:>3} trig = {arithmetic + trig:>6}   {seconds:7.1f} s{extra}")


if __name__ == "__main__":
    main()
