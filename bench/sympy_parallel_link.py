#!/usr/bin/env python3
"""The baseline of docs/performance.md's operation counts: the parallel link's D, C·q̇, g, J and
J̇·q̇ derived with a SymPy Lagrangian from the same physical data, then common-subexpression
elimination, with and without `simplify`. Counts additions/subtractions, multiplications,
divisions, powers (as multiplications) and trigonometric calls of the CSE'd code, the way
`hapticgen stats` counts. Not part of the test command: `pip install sympy` first.

    python3 bench/sympy_parallel_link.py
"""
import time

import sympy as sp

q1, q2, qd1, qd2 = sp.symbols("q1 q2 qd1 qd2")
q = [q1, q2]
qd = [qd1, qd2]
g0 = sp.Float(9.81)
ll, le = sp.Float(0.15), sp.Float(0.05)
rod = lambda m, length: m * length**2 / 12
rotor = sp.Float(12) ** 2 * sp.Float(1.42e-5)
# (mass, com position as a function of q, inertia about the com, angle)
m1, m2, m3, m4 = sp.Float(0.020358), sp.Float(0.06075), sp.Float(0.020358), sp.Float(0.081)
u = lambda a: sp.Matrix([sp.cos(a), sp.sin(a)])
bodies = [
    (m1, 0.075 * u(q1), rod(m1, 0.15), q1),
    (m2, 0.075 * u(q2), rod(m2, 0.15), q2),
    (m3, ll * u(q2) + 0.075 * u(q1), rod(m3, 0.15), q1),
    (m4, ll * u(q1) + 0.05 * u(q2), rod(m4, 0.2), q2),
]
p = ll * u(q1) - le * u(q2)


def derive(simplify):
    start = time.time()
    D = sp.zeros(2, 2)
    V = 0
    for m, r, inertia, angle in bodies:
        Jv = r.jacobian(q)
        Jw = sp.Matrix([[sp.diff(angle, qi) for qi in q]])
        D += m * Jv.T * Jv + inertia * Jw.T * Jw
        V += m * g0 * r[1]
    D += rotor * sp.eye(2)
    C = sp.zeros(2, 2)
    for k in range(2):
        for j in range(2):
            C[k, j] = sum(
                sp.Rational(1, 2) * (sp.diff(D[k, j], q[i]) + sp.diff(D[k, i], q[j]) - sp.diff(D[i, j], q[k])) * qd[i]
                for i in range(2)
            )
    Cqd = C * sp.Matrix(qd)
    gv = sp.Matrix([sp.diff(V, qi) for qi in q])
    J = p.jacobian(q)
    Jdot = sp.zeros(2, 2)
    for r in range(2):
        for c in range(2):
            Jdot[r, c] = sum(sp.diff(J[r, c], q[i]) * qd[i] for i in range(2))
    Jdqd = Jdot * sp.Matrix(qd)
    outputs = list(D) + list(Cqd) + list(gv) + list(J) + list(Jdqd)
    if simplify:
        outputs = [sp.simplify(sp.trigsimp(e)) for e in outputs]
    replacements, reduced = sp.cse(outputs)
    return replacements, reduced, time.time() - start


def count(replacements, reduced):
    exprs = [e for _, e in replacements] + list(reduced)
    ops = sp.count_ops(exprs, visual=True)
    counts = {str(k): v for k, v in ops.as_coefficients_dict().items()}
    trig = sum(v for k, v in counts.items() if k in ("SIN", "COS"))
    # POW with an integer exponent counts as multiplications (x**2 = x·x), NEG as a negation.
    arithmetic = sum(v for k, v in counts.items() if k in ("ADD", "SUB", "MUL", "DIV", "NEG", "POW"))
    return arithmetic, trig, counts


for simplify in (True, False):
    replacements, reduced, seconds = derive(simplify)
    arithmetic, trig, counts = count(replacements, reduced)
    print(f"SymPy {'with' if simplify else 'without'} simplify + cse: {arithmetic} arithmetic + {trig} trig "
          f"({seconds:.1f} s) {counts}")
