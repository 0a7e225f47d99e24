//! Property tests (proptest) over random valid serial models: planar and spatial chains of
//! 1–4 revolute or prismatic joints with random masses, lengths, centres of mass, inertias,
//! axes, joint-frame rotations, rotor inertias and gravity, written as model files and loaded
//! by the real loader. For each model, at a random state:
//!
//! 1. `D(q)` is symmetric positive definite (Cholesky);
//! 2. `Ḋ − 2C` is skew-symmetric, `Ḋ` by a central finite difference along `q̇`;
//! 3. total energy `½ q̇ᵀ D q̇ + V(q)` is conserved over 0.1 s of undamped, unforced motion
//!    (RK4, 0.2 ms steps, evaluated through the emitted expression DAG);
//! 4. the expression DAG the emitter prints (`Dag::polynomial`, shared across all outputs
//!    as in emission, evaluated node by node) equals the term-by-term polynomial evaluator
//!    for every entry of `p`, `J`, `J̇`, `J̇q̇`, `D`, `C`, `Cq̇`, `g` and `V`.
//!
//! Cases: 48 per property by default (a few seconds in a debug build); set `PROPTEST_CASES`
//! for a longer run (`PROPTEST_CASES=1000 cargo test -p hapticgen-tests --test workspace properties::`).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::State;
use hapticgen_codegen::model::Model;
use hapticgen_codegen::sym::dag::{Dag, Node, NodeId};
use hapticgen_codegen::sym::poly::{Atom, AtomValues, Poly};
use hapticgen_codegen::Source;
use hapticgen_tests::dense::{is_positive_definite, solve};
use proptest::prelude::*;

use crate::random_chain::{chain, check_ddot_minus_two_c_skew, model_text, Chain};

fn load(c: &Chain) -> Result<(Model, Mechanics), TestCaseError> {
    let text = model_text(c);
    let m = hapticgen_codegen::load(&Source { name: "random_chain.yaml", text: &text }, None)
        .map_err(|d| TestCaseError::fail(format!("a valid random model was rejected: {d}\n{text}")))?;
    let mech = hapticgen_codegen::derive(&m);
    Ok((m.model, mech))
}

fn eval(p: &Poly, q: &[f64], qd: &[f64]) -> f64 {
    p.eval(&State { q, qd, parameters: &[] })
}

fn matrix(m: &[Vec<Poly>], q: &[f64], qd: &[f64]) -> Vec<Vec<f64>> {
    m.iter().map(|row| row.iter().map(|p| eval(p, q, qd)).collect()).collect()
}

/// Every node of a DAG at one state (children precede parents).
fn eval_nodes(dag: &Dag, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let state = State { q, qd, parameters: &[] };
    let mut values: Vec<f64> = Vec::with_capacity(dag.nodes().len());
    for node in dag.nodes() {
        let v = match *node {
            Node::Const(bits) => f64::from_bits(bits),
            Node::Input(atom) => state.value(atom),
            Node::Add(a, b) => values[a] + values[b],
            Node::Sub(a, b) => values[a] - values[b],
            Node::Mul(a, b) => values[a] * values[b],
            Node::Neg(a) => -values[a],
            Node::Div(a, b) => values[a] / values[b],
            Node::Sqrt(a) => values[a].sqrt(),
        };
        values.push(v);
    }
    values
}

/// `D`, `C q̇`, `g` and `V` as one DAG, for the simulation.
struct Dynamics {
    dag: Dag,
    inertia: Vec<Vec<NodeId>>,
    coriolis: Vec<NodeId>,
    gravity: Vec<NodeId>,
    potential: NodeId,
}

impl Dynamics {
    fn new(mech: &Mechanics) -> Dynamics {
        let mut dag = Dag::new();
        let inertia =
            mech.inertia_matrix.iter().map(|r| r.iter().map(|p| dag.polynomial(p)).collect()).collect();
        let coriolis = mech.coriolis_times_qdot.iter().map(|p| dag.polynomial(p)).collect();
        let gravity = mech.gravity.iter().map(|p| dag.polynomial(p)).collect();
        let potential = dag.polynomial(&mech.potential_energy);
        Dynamics { dag, inertia, coriolis, gravity, potential }
    }

    /// `q̈ = D⁻¹ (−C q̇ − g)` and the total energy.
    fn accel_energy(&self, q: &[f64], qd: &[f64]) -> (Vec<f64>, f64) {
        let v = eval_nodes(&self.dag, q, qd);
        let n = q.len();
        let d: Vec<Vec<f64>> = self.inertia.iter().map(|r| r.iter().map(|&i| v[i]).collect()).collect();
        let rhs: Vec<f64> = (0..n).map(|k| -v[self.coriolis[k]] - v[self.gravity[k]]).collect();
        let kinetic: f64 = (0..n).map(|i| (0..n).map(|j| 0.5 * qd[i] * d[i][j] * qd[j]).sum::<f64>()).sum();
        (solve(d, rhs), kinetic + v[self.potential])
    }
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: 48, ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn inertia_matrix_is_symmetric_positive_definite(c in chain(1..=4, 0.5)) {
        let (_, mech) = load(&c)?;
        let d = matrix(&mech.inertia_matrix, &c.q, &c.qd);
        let n = d.len();
        for i in 0..n {
            for j in 0..n {
                prop_assert_eq!(d[i][j], d[j][i], "D not symmetric at {:?}", c.q);
            }
        }
        prop_assert!(is_positive_definite(&d), "D not positive definite at {:?}: {:?}", c.q, d);
    }

    #[test]
    fn ddot_minus_two_c_is_skew_symmetric(c in chain(1..=4, 0.5)) {
        let (_, mech) = load(&c)?;
        let along = |t: f64| {
            let q: Vec<f64> = c.q.iter().zip(&c.qd).map(|(a, b)| a + t * b).collect();
            matrix(&mech.inertia_matrix, &q, &c.qd)
        };
        check_ddot_minus_two_c_skew(&c, along, &matrix(&mech.coriolis_matrix, &c.q, &c.qd))?;
    }

    #[test]
    fn energy_is_conserved_without_damping(c in chain(1..=4, 0.5)) {
        let (_, mech) = load(&c)?;
        let dynamics = Dynamics::new(&mech);
        let (mut q, mut qd) = (c.q.clone(), c.qd.clone());
        let n = q.len();
        let (_, e0) = dynamics.accel_energy(&q, &qd);
        let dt = 2e-4;
        let mut scale = e0.abs();
        for _ in 0..500 {
            let step = |q: &[f64], qd: &[f64], dq: &[f64], dqd: &[f64], h: f64| {
                let q2: Vec<f64> = (0..n).map(|i| q[i] + h * dq[i]).collect();
                let qd2: Vec<f64> = (0..n).map(|i| qd[i] + h * dqd[i]).collect();
                let (a, _) = dynamics.accel_energy(&q2, &qd2);
                (qd2, a)
            };
            let (k1v, k1a) = (qd.clone(), dynamics.accel_energy(&q, &qd).0);
            let (k2v, k2a) = step(&q, &qd, &k1v, &k1a, dt / 2.0);
            let (k3v, k3a) = step(&q, &qd, &k2v, &k2a, dt / 2.0);
            let (k4v, k4a) = step(&q, &qd, &k3v, &k3a, dt);
            for i in 0..n {
                q[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
                qd[i] += dt / 6.0 * (k1a[i] + 2.0 * k2a[i] + 2.0 * k3a[i] + k4a[i]);
            }
            let (_, e) = dynamics.accel_energy(&q, &qd);
            scale = scale.max(e.abs());
        }
        let (_, e1) = dynamics.accel_energy(&q, &qd);
        // Kinetic and potential energy exchange, so scale by the largest magnitude seen
        // and by the kinetic energy's size at the start.
        let kinetic0: f64 = {
            let d = matrix(&mech.inertia_matrix, &c.q, &c.qd);
            (0..n).map(|i| (0..n).map(|j| 0.5 * c.qd[i] * d[i][j] * c.qd[j]).sum::<f64>()).sum()
        };
        let tolerance = 1e-7 * scale.max(kinetic0).max(1e-6);
        prop_assert!(q.iter().chain(&qd).all(|v| v.is_finite()), "the simulation diverged");
        prop_assert!((e1 - e0).abs() < tolerance, "energy drifted from {} to {} (tolerance {})", e0, e1, tolerance);
    }

    #[test]
    fn emitted_dag_equals_the_polynomial_evaluator(c in chain(1..=4, 0.5)) {
        let (m, mech) = load(&c)?;
        prop_assert_eq!(m.joints.len(), c.links.len());
        let mut polys: Vec<&Poly> = Vec::new();
        let task = &mech.task;
        polys.extend(&task.position);
        polys.extend(task.jacobian.iter().flatten());
        polys.extend(task.jacobian_dot.iter().flatten());
        polys.extend(&task.jacobian_dot_times_qdot);
        polys.extend(mech.inertia_matrix.iter().flatten());
        polys.extend(mech.coriolis_matrix.iter().flatten());
        polys.extend(&mech.coriolis_times_qdot);
        polys.extend(&mech.gravity);
        polys.push(&mech.potential_energy);
        let mut dag = Dag::new();
        let roots: Vec<NodeId> = polys.iter().map(|p| dag.polynomial(p)).collect();
        let values = eval_nodes(&dag, &c.q, &c.qd);
        for (k, (p, &root)) in polys.iter().zip(&roots).enumerate() {
            let expected = eval(p, &c.q, &c.qd);
            let got = values[root];
            // Also through the DAG's own evaluator.
            let direct = dag.eval(root, &|a: Atom| State { q: &c.q, qd: &c.qd, parameters: &[] }.value(a));
            prop_assert_eq!(got.to_bits(), direct.to_bits());
            let magnitude: f64 = p.terms().map(|(mono, coeff)| {
                mono.iter().fold(coeff.abs(), |acc, (a, e)| acc * State { q: &c.q, qd: &c.qd, parameters: &[] }.value(*a).abs().powi(*e as i32))
            }).sum();
            prop_assert!((got - expected).abs() <= 1e-12 * magnitude.max(1e-300) + 1e-300,
                "output {}: DAG {} vs polynomial {} (term magnitude {})", k, got, expected, magnitude);
        }
    }
}
