//! Closed chains, checked independently of the elimination:
//! - the closed-form passive joints close the loop: `|Φ(q_a, q_p(q_a))| < 1e-12` at random
//!   actuated states over the whole box of joint limits (and `sin² + cos² = 1`);
//! - the reduced `D`, `C q̇`, `g`, `J`, `J̇ q̇` equal the open tree's, projected numerically:
//!   `q_p(q_a)` found by Newton's method on `Φ` (continued from a branch chosen by its
//!   definition), `S = ∂q/∂q_a` and the passive accelerations `γ` by finite differences of it;
//! - energy is conserved by the reduced dynamics (RK4, no damping, no input);
//! - `J` and `J̇` match finite differences of `p` and `J`, `Ḋ − 2C` is skew-symmetric (`Ḋ` by
//!   finite differences) and `D` is symmetric positive definite;
//! - the paper's parallelogram described as a closed chain equals its direct-pose model.
//!
//! The models: `models/pantograph_5bar.yaml` (both variants) and
//! `codegen/tests/good-models/five_bar_2dof.yaml` (passive joints listed first, a clockwise
//! passive joint, a rotated distal frame, the `right` branch, a tunable length).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use std::path::{Path, PathBuf};

use hapticgen_codegen::dynamics::closure::Loop;
use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, Evaluated, Full, State};
use hapticgen_codegen::sym::poly::{Atom, AtomValues, Poly};
use hapticgen_codegen::CheckedModel;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn closed_chains() -> Vec<(String, CheckedModel, Mechanics)> {
    let mut out = Vec::new();
    for (file, variant) in [
        ("models/pantograph_5bar.yaml", Some("horizontal")),
        ("models/pantograph_5bar.yaml", Some("vertical")),
        ("codegen/tests/good-models/five_bar_2dof.yaml", None),
    ] {
        let m = hapticgen_codegen::load_file(&repo_root().join(file), file, variant)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(m.analyses.closures.is_some(), "{file} is a closed chain");
        let mech = hapticgen_codegen::derive(&m);
        out.push((format!("{file} {variant:?}"), m, mech));
    }
    out
}

/// A small deterministic generator (xorshift), uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn actuated(&mut self, model: &CheckedModel) -> Vec<f64> {
        model.joints.iter().map(|j| j.lower + (j.upper - j.lower) * self.next()).collect()
    }
}

/// Values of the open tree's atoms at a full state (all coordinates given).
struct Tree<'a> {
    q: &'a [f64],
    qd: &'a [f64],
    parameters: &'a [f64],
}

impl AtomValues for Tree<'_> {
    fn value(&self, atom: Atom) -> f64 {
        State { q: self.q, qd: self.qd, parameters: self.parameters }.value(atom)
    }
}

fn residual(l: &Loop, q: &[f64], parameters: &[f64]) -> [f64; 2] {
    let zero = vec![0.0; q.len()];
    let values = Tree { q, qd: &zero, parameters };
    [l.residual[0].eval(&values), l.residual[1].eval(&values)]
}

/// The passive angles of loop `l` at `q_a`, by Newton's method on `Φ` from `guess`, with a
/// finite-difference Jacobian (independent of the symbolic elimination).
fn newton(l: &Loop, total: usize, qa: &[f64], guess: [f64; 2], parameters: &[f64]) -> Option<[f64; 2]> {
    let full = |p: [f64; 2]| {
        let mut q = qa.to_vec();
        q.resize(total, 0.0);
        q[l.joints[0]] = p[0];
        q[l.joints[1]] = p[1];
        q
    };
    let mut p = guess;
    for _ in 0..60 {
        let r = residual(l, &full(p), parameters);
        if r[0].hypot(r[1]) < 1e-15 {
            return Some(p);
        }
        let h = 1e-7;
        let mut jac = [[0.0; 2]; 2];
        for k in 0..2 {
            let (mut plus, mut minus) = (p, p);
            plus[k] += h;
            minus[k] -= h;
            let (rp, rm) = (residual(l, &full(plus), parameters), residual(l, &full(minus), parameters));
            for i in 0..2 {
                jac[i][k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
        if det.abs() < 1e-300 {
            return None;
        }
        let dx = (jac[1][1] * r[0] - jac[0][1] * r[1]) / det;
        let dy = (jac[0][0] * r[1] - jac[1][0] * r[0]) / det;
        p = [p[0] - dx, p[1] - dy];
    }
    let r = residual(l, &full(p), parameters);
    (r[0].hypot(r[1]) < 1e-13).then_some(p)
}

/// Which side of the line from the first passive joint's axis to the second's the joined
/// point lies on (the definition of `branch`), at a full state.
fn side(l: &Loop, point: &[Poly], q: &[f64], parameters: &[f64]) -> f64 {
    let zero = vec![0.0; q.len()];
    let values = Tree { q, qd: &zero, parameters };
    let c: Vec<[f64; 2]> = l.centres.iter().map(|c| [c[0].eval(&values), c[1].eval(&values)]).collect();
    let e = [point[0].eval(&values), point[1].eval(&values)];
    let d = [c[1][0] - c[0][0], c[1][1] - c[0][1]];
    let u = [e[0] - c[0][0], e[1] - c[0][1]];
    d[0] * u[1] - d[1] * u[0]
}

/// The passive angles on the model's branch at `qa`, by continuation from the middle of the
/// actuated ranges, where the branch is picked from a grid of starting guesses.
fn passive_by_continuation(model: &CheckedModel, mech: &Mechanics, qa: &[f64]) -> Vec<f64> {
    let closures = model.analyses.closures.as_ref().expect("a closed chain");
    let tree = mech.tree.as_ref().expect("the tree is kept");
    let parameters = model.nominal_parameters();
    let total = model.tree_coordinates();
    let middle: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
    let mut q = qa.to_vec();
    q.resize(total, 0.0);
    for l in &closures.loops {
        // The model file's branch, and the first point of the closure.
        let declared = l.branch_sign;
        let point = &tree.points[l.points[0]];
        let mut start = None;
        let steps = 48;
        'grid: for i in 0..steps {
            for k in 0..steps {
                let guess = [
                    -std::f64::consts::PI + 2.0 * std::f64::consts::PI * i as f64 / steps as f64,
                    -std::f64::consts::PI + 2.0 * std::f64::consts::PI * k as f64 / steps as f64,
                ];
                if let Some(p) = newton(l, total, &middle, guess, &parameters) {
                    let mut full = middle.clone();
                    full.resize(total, 0.0);
                    full[l.joints[0]] = p[0];
                    full[l.joints[1]] = p[1];
                    if side(l, &point.position, &full, &parameters) * declared > 0.0 {
                        start = Some(p);
                        break 'grid;
                    }
                }
            }
        }
        let mut p = start.expect("the loop closes at the middle of the ranges");
        let legs = 16;
        for s in 1..=legs {
            let t = s as f64 / legs as f64;
            let at: Vec<f64> = middle.iter().zip(qa).map(|(m, a)| m + t * (a - m)).collect();
            p = newton(l, total, &at, p, &parameters).expect("continuation converges inside the box");
        }
        q[l.joints[0]] = p[0];
        q[l.joints[1]] = p[1];
    }
    q
}

#[test]
fn eliminated_passive_joints_close_the_loop() {
    for (name, model, mech) in closed_chains() {
        let closures = model.analyses.closures.as_ref().unwrap();
        let parameters = model.nominal_parameters();
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut worst = 0.0f64;
        for _ in 0..500 {
            let qa = rng.actuated(&model);
            let qd = vec![0.0; qa.len()];
            let state = State { q: &qa, qd: &qd, parameters: &parameters };
            let values = Full::new(&mech, &state);
            for l in &closures.loops {
                // With the closed form's sines and cosines …
                let r = [l.residual[0].eval(&values), l.residual[1].eval(&values)];
                worst = worst.max(r[0].hypot(r[1]));
                // … and with the angles they stand for.
                let mut q = qa.clone();
                q.resize(model.tree_coordinates(), 0.0);
                for &j in &l.joints {
                    let (s, c) = (values.value(Atom::Sin(j as u16)), values.value(Atom::Cos(j as u16)));
                    assert!((s * s + c * c - 1.0).abs() < 1e-12, "{name}: sin² + cos² = {}", s * s + c * c);
                    q[j] = s.atan2(c);
                }
                let r = residual(l, &q, &parameters);
                worst = worst.max(r[0].hypot(r[1]));
            }
        }
        eprintln!("{name}: largest constraint residual {worst:e} m");
        assert!(worst < 1e-12, "{name}: constraint residual {worst:e} m");
    }
}

fn mat_t_mat_mat(s: &[Vec<f64>], d: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let (rows, cols) = (s.len(), s[0].len());
    (0..cols)
        .map(|i| {
            (0..cols)
                .map(|j| (0..rows).map(|k| (0..rows).map(|l| s[k][i] * d[k][l] * s[l][j]).sum::<f64>()).sum())
                .collect()
        })
        .collect()
}

fn mat_t_vec(s: &[Vec<f64>], v: &[f64]) -> Vec<f64> {
    (0..s[0].len()).map(|i| (0..s.len()).map(|k| s[k][i] * v[k]).sum()).collect()
}

fn mat_vec(a: &[Vec<f64>], v: &[f64]) -> Vec<f64> {
    a.iter().map(|row| row.iter().zip(v).map(|(x, y)| x * y).sum()).collect()
}

fn largest(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn assert_close(what: &str, got: &[f64], want: &[f64], tol: f64) {
    assert_close_at(what, got, want, tol, largest(want));
}

/// `|got − want| ≤ tol · scale` element-wise.
fn assert_close_at(what: &str, got: &[f64], want: &[f64], tol: f64, scale: f64) {
    let scale = scale.max(1e-300);
    for (a, b) in got.iter().zip(want) {
        assert!((a - b).abs() <= tol * scale, "{what}: {got:?} vs projected {want:?}");
    }
}

#[test]
fn reduced_dynamics_equal_the_tree_projected_numerically() {
    for (name, model, mech) in closed_chains() {
        let tree = mech.tree.as_ref().expect("the tree is kept");
        let parameters = model.nominal_parameters();
        let (n, total) = (model.joints.len(), model.tree_coordinates());
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        for _ in 0..25 {
            let qa = rng.actuated(&model);
            let qda: Vec<f64> = (0..n).map(|_| 4.0 * rng.next() - 2.0).collect();
            let q = passive_by_continuation(&model, &mech, &qa);
            // The closed form agrees with Newton's passive angles.
            let zero = vec![0.0; n];
            let state = State { q: &qa, qd: &zero, parameters: &parameters };
            let values = Full::new(&mech, &state);
            for j in n..total {
                let (s, c) = (values.value(Atom::Sin(j as u16)), values.value(Atom::Cos(j as u16)));
                assert!(
                    (s - q[j].sin()).abs() < 1e-10 && (c - q[j].cos()).abs() < 1e-10,
                    "{name}: passive angle"
                );
            }
            // S = ∂q/∂q_a and γ by finite differences of the passive angles.
            let passive_at = |qa: &[f64], guess: &[f64]| -> Vec<f64> {
                let closures = model.analyses.closures.as_ref().unwrap();
                let mut out = qa.to_vec();
                out.resize(total, 0.0);
                for l in &closures.loops {
                    let p = newton(l, total, qa, [guess[l.joints[0]], guess[l.joints[1]]], &parameters)
                        .expect("Newton converges near a solution");
                    out[l.joints[0]] = p[0];
                    out[l.joints[1]] = p[1];
                }
                out
            };
            let h = 1e-6;
            let mut s = vec![vec![0.0; n]; total];
            for j in 0..n {
                let (mut plus, mut minus) = (qa.clone(), qa.clone());
                plus[j] += h;
                minus[j] -= h;
                let (qp, qm) = (passive_at(&plus, &q), passive_at(&minus, &q));
                for i in 0..total {
                    s[i][j] = if i < n { f64::from(u8::from(i == j)) } else { (qp[i] - qm[i]) / (2.0 * h) };
                }
            }
            let h2 = 3e-4;
            let along = |k: f64| -> Vec<f64> { qa.iter().zip(&qda).map(|(x, v)| x + k * h2 * v).collect() };
            let (qp, qm) = (passive_at(&along(1.0), &q), passive_at(&along(-1.0), &q));
            let gamma: Vec<f64> = (0..total)
                .map(|i| if i < n { 0.0 } else { (qp[i] - 2.0 * q[i] + qm[i]) / (h2 * h2) })
                .collect();
            let qd_full = mat_vec(&s, &qda);
            // The tree at the full state.
            let t: Evaluated = evaluate(tree, &State { q: &q, qd: &qd_full, parameters: &parameters }, None);
            let reduced = evaluate(&mech, &State { q: &qa, qd: &qda, parameters: &parameters }, None);
            let d_a = mat_t_mat_mat(&s, &t.inertia_matrix);
            let d_gamma = mat_vec(&t.inertia_matrix, &gamma);
            let cqd: Vec<f64> = t.coriolis_times_qdot.iter().zip(&d_gamma).map(|(a, b)| a + b).collect();
            let j_gamma = mat_vec(&t.jacobian, &gamma);
            let jdq: Vec<f64> = t.jacobian_dot_times_qdot.iter().zip(&j_gamma).map(|(a, b)| a + b).collect();
            let j_a: Vec<Vec<f64>> = t.jacobian.iter().map(|row| mat_t_vec(&s, row)).collect();
            assert_close(&format!("{name}: D"), &flat(&reduced.inertia_matrix), &flat(&d_a), 1e-7);
            // γ carries the error of a second difference: compare relative to the terms' size.
            let terms =
                largest(&mat_t_vec(&s, &t.coriolis_times_qdot)).max(largest(&mat_t_vec(&s, &d_gamma)));
            assert_close_at(
                &format!("{name}: C q̇"),
                &reduced.coriolis_times_qdot,
                &mat_t_vec(&s, &cqd),
                1e-5,
                terms,
            );
            if t.g.iter().any(|g| *g != 0.0) {
                assert_close(&format!("{name}: g"), &reduced.g, &mat_t_vec(&s, &t.g), 1e-7);
            }
            assert_close(&format!("{name}: p"), &reduced.p, &t.p, 1e-12);
            assert_close(&format!("{name}: J"), &flat(&reduced.jacobian), &flat(&j_a), 1e-7);
            let terms = largest(&t.jacobian_dot_times_qdot).max(largest(&j_gamma));
            assert_close_at(&format!("{name}: J̇ q̇"), &reduced.jacobian_dot_times_qdot, &jdq, 1e-5, terms);
            // C q̇ is the Coriolis matrix times q̇.
            let c_qd = mat_vec(&reduced.coriolis_matrix, &qda);
            assert_close(&format!("{name}: C·q̇"), &c_qd, &reduced.coriolis_times_qdot, 1e-10);
        }
    }
}

#[test]
fn reduced_dynamics_conserve_energy() {
    for (name, model, mech) in closed_chains() {
        let parameters = model.nominal_parameters();
        let n = model.joints.len();
        let eval = |q: &[f64], qd: &[f64]| evaluate(&mech, &State { q, qd, parameters: &parameters }, None);
        let acceleration = |q: &[f64], qd: &[f64]| -> Vec<f64> {
            let e = eval(q, qd);
            let d = &e.inertia_matrix;
            let rhs: Vec<f64> = (0..n).map(|i| -e.coriolis_times_qdot[i] - e.g[i]).collect();
            let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
            vec![(d[1][1] * rhs[0] - d[0][1] * rhs[1]) / det, (d[0][0] * rhs[1] - d[1][0] * rhs[0]) / det]
        };
        let energy = |q: &[f64], qd: &[f64]| -> f64 {
            let e = eval(q, qd);
            let kinetic: f64 = (0..n)
                .map(|i| (0..n).map(|j| 0.5 * qd[i] * e.inertia_matrix[i][j] * qd[j]).sum::<f64>())
                .sum();
            kinetic + e.potential_energy
        };
        let inside = |q: &[f64]| model.joints.iter().zip(q).all(|(j, x)| *x > j.lower && *x < j.upper);
        let mut q: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
        let mut qd = vec![0.8, -0.5];
        let e0 = energy(&q, &qd);
        let scale = e0.abs().max(energy(&q, &[0.0, 0.0]).abs()).max(1e-12);
        let dt = 1e-4;
        let mut worst = 0.0f64;
        let mut steps = 0;
        while steps < 3000 && inside(&q) {
            let add = |a: &[f64], b: &[f64], k: f64| -> Vec<f64> {
                a.iter().zip(b).map(|(x, y)| x + k * y).collect()
            };
            let k1q = qd.clone();
            let k1v = acceleration(&q, &qd);
            let k2q = add(&qd, &k1v, dt / 2.0);
            let k2v = acceleration(&add(&q, &k1q, dt / 2.0), &k2q);
            let k3q = add(&qd, &k2v, dt / 2.0);
            let k3v = acceleration(&add(&q, &k2q, dt / 2.0), &k3q);
            let k4q = add(&qd, &k3v, dt);
            let k4v = acceleration(&add(&q, &k3q, dt), &k4q);
            q = (0..n).map(|i| q[i] + dt / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i])).collect();
            qd = (0..n).map(|i| qd[i] + dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])).collect();
            worst = worst.max((energy(&q, &qd) - e0).abs() / scale);
            steps += 1;
        }
        eprintln!("{name}: {steps} steps, relative energy drift {worst:e}");
        assert!(steps >= 500, "{name}: left the workspace after {steps} steps");
        assert!(worst < 1e-9, "{name}: relative energy drift {worst:e}");
    }
}

#[test]
fn jacobians_and_skew_symmetry_match_finite_differences() {
    for (name, model, mech) in closed_chains() {
        let parameters = model.nominal_parameters();
        let n = model.joints.len();
        let eval = |q: &[f64], qd: &[f64]| evaluate(&mech, &State { q, qd, parameters: &parameters }, None);
        let mut rng = Rng(0x5851_f42d_4c95_7f2d);
        let h = 1e-6;
        for _ in 0..50 {
            let q = rng.actuated(&model);
            let qd: Vec<f64> = (0..n).map(|_| 4.0 * rng.next() - 2.0).collect();
            let e = eval(&q, &qd);
            let shifted = |k: usize, delta: f64| {
                let mut qq = q.clone();
                qq[k] += delta;
                eval(&qq, &qd)
            };
            let along = |delta: f64| {
                let qq: Vec<f64> = q.iter().zip(&qd).map(|(x, v)| x + delta * v).collect();
                eval(&qq, &qd)
            };
            // J = ∂p/∂q_a.
            for k in 0..n {
                let (plus, minus) = (shifted(k, h), shifted(k, -h));
                let column: Vec<f64> = (0..e.p.len()).map(|i| (plus.p[i] - minus.p[i]) / (2.0 * h)).collect();
                let got: Vec<f64> = e.jacobian.iter().map(|row| row[k]).collect();
                assert_close_at(
                    &format!("{name}: J column {k}"),
                    &got,
                    &column,
                    1e-6,
                    largest(&flat(&e.jacobian)),
                );
            }
            // J̇ = dJ/dt along q̇, and D̊ = dD/dt.
            let (plus, minus) = (along(h), along(-h));
            let jdot: Vec<f64> = flat(&plus.jacobian)
                .iter()
                .zip(flat(&minus.jacobian))
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect();
            assert_close_at(
                &format!("{name}: J̇"),
                &flat(&e.jacobian_dot),
                &jdot,
                1e-5,
                largest(&jdot).max(1e-12),
            );
            let ddot: Vec<f64> = flat(&plus.inertia_matrix)
                .iter()
                .zip(flat(&minus.inertia_matrix))
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect();
            let c = flat(&e.coriolis_matrix);
            let scale = largest(&ddot).max(largest(&c));
            for i in 0..n {
                for j in 0..n {
                    let x = ddot[i * n + j] - 2.0 * c[i * n + j];
                    let y = ddot[j * n + i] - 2.0 * c[j * n + i];
                    assert!((x + y).abs() <= 1e-6 * scale, "{name}: Ḋ − 2C not skew-symmetric: {x} vs {y}");
                }
            }
            // D is symmetric positive definite.
            let d = &e.inertia_matrix;
            assert!(
                d[0][1] == d[1][0] && d[0][0] > 0.0 && d[0][0] * d[1][1] - d[0][1] * d[1][0] > 0.0,
                "{name}: D"
            );
        }
    }
}

fn flat(m: &[Vec<f64>]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

#[test]
fn the_paper_parallelogram_as_a_closed_chain_equals_its_direct_poses() {
    // `codegen/tests/closed-chains/parallel_link_closed.yaml` hangs links 3 and 4 on passive
    // joints and closes the loop; `models/parallel_link_2dof.yaml` poses them directly. The
    // elimination must reproduce the direct model (checked against Pinocchio) exactly.
    for variant in ["vertical", "horizontal"] {
        let load = |file: &str| {
            let m = hapticgen_codegen::load_file(&repo_root().join(file), file, Some(variant))
                .unwrap_or_else(|e| panic!("{e}"));
            let mech = hapticgen_codegen::derive(&m);
            (m, mech)
        };
        let (direct, direct_mech) = load("models/parallel_link_2dof.yaml");
        let (closed, closed_mech) = load("codegen/tests/closed-chains/parallel_link_closed.yaml");
        assert!(direct.analyses.closures.is_none() && closed.analyses.closures.is_some());
        let parameters = direct.nominal_parameters();
        let mut rng = Rng(0x1234_5678_9abc_def1);
        let mut compared = 0;
        while compared < 100 {
            let q = rng.actuated(&direct);
            // Away from the collapsed parallelogram (q1 = q2), where the loop is singular.
            if !(0.3..std::f64::consts::PI - 0.3).contains(&(q[0] - q[1])) {
                continue;
            }
            let qd = [4.0 * rng.next() - 2.0, 4.0 * rng.next() - 2.0];
            let state = State { q: &q, qd: &qd, parameters: &parameters };
            let (a, b) = (evaluate(&closed_mech, &state, None), evaluate(&direct_mech, &state, None));
            let close = |what: &str, x: &[f64], y: &[f64]| {
                assert_close_at(&format!("{variant}: {what}"), x, y, 1e-12, largest(y).max(1e-12));
            };
            close("D", &flat(&a.inertia_matrix), &flat(&b.inertia_matrix));
            close("C", &flat(&a.coriolis_matrix), &flat(&b.coriolis_matrix));
            close("C q̇", &a.coriolis_times_qdot, &b.coriolis_times_qdot);
            close("g", &a.g, &b.g);
            close("p", &a.p, &b.p);
            close("J", &flat(&a.jacobian), &flat(&b.jacobian));
            close("J̇", &flat(&a.jacobian_dot), &flat(&b.jacobian_dot));
            close("J̇ q̇", &a.jacobian_dot_times_qdot, &b.jacobian_dot_times_qdot);
            close("V", &[a.potential_energy], &[b.potential_energy]);
            // The passive angles are the parallelogram's: e3 = q1 − q2, e4 = q2 − q1.
            close("passive", &a.passive, &[q[0] - q[1], q[1] - q[0]]);
            compared += 1;
        }
    }
}
