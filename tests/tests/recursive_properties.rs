//! Property tests (proptest) of the recursive derivation path — Newton–Euler, composite rigid
//! bodies and Christoffel symbols on the expression DAG, which generates every serial chain of
//! four joints or more — over random valid chains of 4–7 revolute or prismatic joints with
//! arbitrary axes, joint-frame rotations, inertias and gravity, written as model files and
//! loaded by the real loader (`random_chain`). For each chain, at a random state and in each
//! formulation of the recursions (about frame origins, about centres of mass, regrouped
//! inertial parameters):
//!
//! 1. `D`, `C q̇`, `g`, the inverse dynamics at a random `q̈`, and the tip's `p`, `J`, `J̇ q̇`
//!    equal the nalgebra baseline (`hapticgen_tests::baseline_serial`: run-time RNEA, CRBA and
//!    geometric Jacobians, no code shared with the generator's dynamics);
//! 2. `D(q)` is symmetric positive definite;
//! 3. `Ḋ − 2C` is skew-symmetric, with `C` from the Christoffel symbols on the DAG and `Ḋ` a
//!    central finite difference of the recursive `D` along `q̇`;
//! 4. total energy `½ q̇ᵀ D q̇ + V(q)` is conserved over 0.05 s of undamped, unforced motion
//!    (RK4 on the recursive `D`, `C q̇`, `g`; `V = −Σ m g⃗·c` from the baseline's forward
//!    kinematics, so `g` is also checked against the gradient of an independent potential).
//!
//! Cases: 32 per property by default; set `PROPTEST_CASES` for a longer run
//! (`PROPTEST_CASES=500 cargo test -p hapticgen-tests --test workspace recursive_properties::`).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::dynamics::recursive::{self, Formulation, PointQuantity, Quantity};
use hapticgen_codegen::eval::State;
use hapticgen_codegen::model::Model;
use hapticgen_codegen::sym::dag::{Dag, NodeId};
use hapticgen_codegen::sym::poly::{Atom, AtomValues};
use hapticgen_codegen::Source;
use hapticgen_tests::baseline_serial::SerialBaseline;
use hapticgen_tests::dense::{is_positive_definite, solve};
use nalgebra::DVector;
use proptest::prelude::*;

use crate::random_chain::{chain, check_ddot_minus_two_c_skew, model_text, Chain};

const FORMULATIONS: [Formulation; 3] =
    [Formulation::AboutOrigin, Formulation::AboutCom, Formulation::Regrouped];

/// The chain's resolved model.
fn load(c: &Chain) -> Result<Model, TestCaseError> {
    let text = model_text(c);
    let checked = hapticgen_codegen::load(&Source { name: "random_chain.yaml", text: &text }, None)
        .map_err(|d| TestCaseError::fail(format!("a valid random model was rejected: {d}\n{text}")))?;
    prop_assert!(recursive::applies(&checked.model), "a serial chain must take the recursive path");
    Ok(checked.model)
}

/// Every node of a DAG at a state, with `q̈` for the inverse dynamics' inputs.
fn values(dag: &Dag, q: &[f64], qd: &[f64], qdd: &[f64]) -> Vec<f64> {
    let state = State { q, qd, parameters: &[] };
    dag.eval_all(&|atom: Atom| match atom {
        Atom::Qdd(j) => qdd[usize::from(j)],
        other => state.value(other),
    })
}

fn pick(values: &[f64], roots: &[NodeId]) -> Vec<f64> {
    roots.iter().map(|&r| values[r]).collect()
}

fn square(entries: Vec<f64>, n: usize) -> Vec<Vec<f64>> {
    entries.chunks(n).map(<[f64]>::to_vec).collect()
}

/// Asserts `got ≈ expected` entry by entry, relative to the largest entry of `expected` and
/// to `scale`.
fn assert_close(what: &str, got: &[f64], expected: &[f64], scale: f64) -> Result<(), TestCaseError> {
    prop_assert_eq!(got.len(), expected.len(), "{}: lengths differ", what);
    let size = expected.iter().fold(scale, |m, v| m.max(v.abs()));
    for (k, (g, e)) in got.iter().zip(expected).enumerate() {
        prop_assert!(
            (g - e).abs() <= 1e-9 * size,
            "{}[{}]: recursive {} vs baseline {} (scale {})",
            what,
            k,
            g,
            e,
            size
        );
    }
    Ok(())
}

/// `D`, `C q̇` and `g` of the recursive path in one DAG, for the simulation.
struct RecursiveDynamics {
    dag: Dag,
    inertia: Vec<NodeId>,
    coriolis: Vec<NodeId>,
    gravity: Vec<NodeId>,
}

impl RecursiveDynamics {
    fn new(model: &Model) -> Self {
        let mut dag = Dag::new();
        let inertia = recursive::build(&mut dag, model, Quantity::InertiaMatrix);
        let coriolis = recursive::build(&mut dag, model, Quantity::CoriolisTimesQdot);
        let gravity = recursive::build(&mut dag, model, Quantity::Gravity);
        RecursiveDynamics { dag, inertia, coriolis, gravity }
    }

    /// `q̈ = D⁻¹ (−C q̇ − g)` and the kinetic energy.
    fn accel_kinetic(&self, q: &[f64], qd: &[f64]) -> (Vec<f64>, f64) {
        let v = values(&self.dag, q, qd, &[]);
        let n = q.len();
        let d = square(pick(&v, &self.inertia), n);
        let rhs: Vec<f64> = (0..n).map(|k| -v[self.coriolis[k]] - v[self.gravity[k]]).collect();
        let kinetic: f64 = (0..n).map(|i| (0..n).map(|j| 0.5 * qd[i] * d[i][j] * qd[j]).sum::<f64>()).sum();
        (solve(d, rhs), kinetic)
    }
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: 32, ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn recursive_path_equals_the_nalgebra_baseline(c in chain(4..=7, 0.2), qdd in prop::collection::vec(-5.0f64..5.0, 7)) {
        let model = load(&c)?;
        let n = model.joints.len();
        let baseline = SerialBaseline::new(&model).expect("a serial chain");
        let (q, qd, qdd) = (DVector::from_column_slice(&c.q), DVector::from_column_slice(&c.qd), DVector::from_column_slice(&qdd[..n]));
        let expected_d: Vec<f64> = baseline.inertia_matrix(&q).transpose().iter().copied().collect();
        let expected_cqd: Vec<f64> = baseline.coriolis_times_qdot(&q, &qd).iter().copied().collect();
        let expected_g: Vec<f64> = baseline.gravity(&q).iter().copied().collect();
        let expected_tau: Vec<f64> = baseline.inverse_dynamics(&q, &qd, &qdd).iter().copied().collect();
        let torque_scale = expected_tau.iter().chain(&expected_g).fold(1e-9f64, |m, v| m.max(v.abs()));
        for formulation in FORMULATIONS {
            let mut dag = Dag::new();
            let roots = [Quantity::InertiaMatrix, Quantity::CoriolisTimesQdot, Quantity::Gravity, Quantity::InverseDynamics]
                .map(|quantity| recursive::build_with(&mut dag, &model, quantity, formulation));
            let v = values(&dag, &c.q, &c.qd, qdd.as_slice());
            let name = |what: &str| format!("{what} ({formulation:?})");
            assert_close(&name("D"), &pick(&v, &roots[0]), &expected_d, 1e-9)?;
            assert_close(&name("C q̇"), &pick(&v, &roots[1]), &expected_cqd, torque_scale)?;
            assert_close(&name("g"), &pick(&v, &roots[2]), &expected_g, torque_scale)?;
            assert_close(&name("inverse dynamics"), &pick(&v, &roots[3]), &expected_tau, torque_scale)?;
        }
        if c.tip_task {
            let mut dag = Dag::new();
            let roots = [PointQuantity::Position, PointQuantity::Jacobian, PointQuantity::JacobianDotTimesQdot]
                .map(|what| recursive::build(&mut dag, &model, Quantity::Point(0, what)));
            let v = values(&dag, &c.q, &c.qd, &[]);
            let expected_j: Vec<f64> = baseline.jacobian(&q).transpose().iter().copied().collect();
            assert_close("p", &pick(&v, &roots[0]), baseline.position(&q).as_slice(), 1e-9)?;
            assert_close("J", &pick(&v, &roots[1]), &expected_j, 1e-9)?;
            assert_close("J̇ q̇", &pick(&v, &roots[2]), baseline.jacobian_dot_times_qdot(&q, &qd).as_slice(), 1e-9)?;
        }
    }

    #[test]
    fn recursive_inertia_matrix_is_symmetric_positive_definite(c in chain(4..=7, 0.2)) {
        let model = load(&c)?;
        let n = model.joints.len();
        for formulation in FORMULATIONS {
            let mut dag = Dag::new();
            let roots = recursive::build_with(&mut dag, &model, Quantity::InertiaMatrix, formulation);
            let d = square(pick(&values(&dag, &c.q, &c.qd, &[]), &roots), n);
            let size = d.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                for j in 0..i {
                    prop_assert!((d[i][j] - d[j][i]).abs() <= 1e-14 * size, "D not symmetric ({:?}) at {:?}", formulation, c.q);
                }
            }
            prop_assert!(is_positive_definite(&d), "D not positive definite ({:?}) at {:?}: {:?}", formulation, c.q, d);
        }
    }

    #[test]
    fn recursive_ddot_minus_two_c_is_skew_symmetric(c in chain(4..=7, 0.2)) {
        let model = load(&c)?;
        let n = model.joints.len();
        let mut dag = Dag::new();
        let inertia = recursive::build(&mut dag, &model, Quantity::InertiaMatrix);
        let coriolis = recursive::build(&mut dag, &model, Quantity::CoriolisMatrix);
        let coriolis_times_qdot = recursive::build(&mut dag, &model, Quantity::CoriolisTimesQdot);
        let inertia_along = |t: f64| {
            let q: Vec<f64> = c.q.iter().zip(&c.qd).map(|(a, b)| a + t * b).collect();
            square(pick(&values(&dag, &q, &c.qd, &[]), &inertia), n)
        };
        let cm = square(pick(&values(&dag, &c.q, &c.qd, &[]), &coriolis), n);
        check_ddot_minus_two_c_skew(&c, inertia_along, &cm)?;
        let scale = cm.iter().flatten().fold(1e-3f64, |m, v| m.max(v.abs())) * c.qd.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        // `C q̇` built by Newton–Euler equals the Christoffel `C` times `q̇`.
        let cqd = pick(&values(&dag, &c.q, &c.qd, &[]), &coriolis_times_qdot);
        let product: Vec<f64> = (0..n).map(|i| (0..n).map(|j| cm[i][j] * c.qd[j]).sum()).collect();
        assert_close("C q̇ vs C·q̇", &cqd, &product, 1e-9 * scale)?;
    }

    #[test]
    fn recursive_dynamics_conserve_energy(c in chain(4..=7, 0.2)) {
        let model = load(&c)?;
        let baseline = SerialBaseline::new(&model).expect("a serial chain");
        let dynamics = RecursiveDynamics::new(&model);
        let energy = |q: &[f64], qd: &[f64]| {
            dynamics.accel_kinetic(q, qd).1 + baseline.potential_energy(&DVector::from_column_slice(q))
        };
        let (mut q, mut qd) = (c.q.clone(), c.qd.clone());
        let n = q.len();
        let e0 = energy(&q, &qd);
        let (dt, steps) = (2e-4, 250);
        let mut scale = e0.abs().max(dynamics.accel_kinetic(&q, &qd).1);
        for _ in 0..steps {
            let derivative = |dq: &[f64], dqd: &[f64], h: f64| {
                let q2: Vec<f64> = (0..n).map(|i| q[i] + h * dq[i]).collect();
                let qd2: Vec<f64> = (0..n).map(|i| qd[i] + h * dqd[i]).collect();
                let (a, _) = dynamics.accel_kinetic(&q2, &qd2);
                (qd2, a)
            };
            let (k1v, k1a) = (qd.clone(), dynamics.accel_kinetic(&q, &qd).0);
            let (k2v, k2a) = derivative(&k1v, &k1a, dt / 2.0);
            let (k3v, k3a) = derivative(&k2v, &k2a, dt / 2.0);
            let (k4v, k4a) = derivative(&k3v, &k3a, dt);
            for i in 0..n {
                q[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
                qd[i] += dt / 6.0 * (k1a[i] + 2.0 * k2a[i] + 2.0 * k3a[i] + k4a[i]);
            }
            scale = scale.max(energy(&q, &qd).abs());
        }
        prop_assert!(q.iter().chain(&qd).all(|v| v.is_finite()), "the simulation diverged");
        let e1 = energy(&q, &qd);
        prop_assert!((e1 - e0).abs() < 1e-7 * scale.max(1e-6), "energy drifted from {} to {} (scale {})", e0, e1, scale);
    }
}
