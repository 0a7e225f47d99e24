//! The recursive derivation path (Newton–Euler, composite rigid body, Christoffel symbols on
//! the DAG) against the polynomial path, which derives the same quantities independently from
//! the kinetic and potential energy (and named frames against the polynomial rotations): every
//! shipped serial model and the good-model fixtures,
//! at pseudo-random states, including prismatic joints, DH tails, welded bodies and tunable
//! parameters, in each formulation of the recursions (about frame origins, about centres of
//! mass, with regrouped inertial parameters).

use std::path::{Path, PathBuf};

use hapticgen_codegen::dynamics::recursive::{
    self, Formulation, FrameQuantity, JacobianForm, PointQuantity, Quantity,
};
use hapticgen_codegen::eval::{evaluate, evaluate_frame, State};
use hapticgen_codegen::load_file;
use hapticgen_codegen::sym::dag::Dag;
use hapticgen_codegen::sym::poly::Atom;

fn serial_models() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in [root.join("../models"), root.join("tests/good-models")] {
        for entry in std::fs::read_dir(&dir).expect("the directory exists") {
            let path = entry.expect("readable").path();
            if path.extension().is_some_and(|e| e == "yaml") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// A small deterministic generator (the states need not be random, only varied).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

#[test]
fn recursive_algorithms_equal_the_lagrangian_polynomials() {
    let mut checked = 0;
    for path in serial_models() {
        let text = path.display().to_string();
        let base = load_file(&path, &text, None).unwrap_or_else(|d| panic!("{d}"));
        for variant in std::iter::once(None).chain(base.variants.clone().into_iter().map(Some)) {
            let model = load_file(&path, &text, variant.as_deref()).unwrap_or_else(|d| panic!("{d}"));
            if !recursive::applies(&model) {
                continue;
            }
            let n = model.joints.len();
            let mech = hapticgen_codegen::derive(&model);
            let mut dag = Dag::new();
            // Every formulation of the recursions (they differ in the parameters they carry,
            // not in the values), the one `build` picks among them.
            let dynamics: Vec<(Formulation, [Vec<_>; 5])> =
                [Formulation::AboutOrigin, Formulation::AboutCom, Formulation::Regrouped]
                    .into_iter()
                    .map(|formulation| {
                        let quantities = [
                            Quantity::InertiaMatrix,
                            Quantity::CoriolisTimesQdot,
                            Quantity::Gravity,
                            Quantity::CoriolisMatrix,
                            Quantity::InverseDynamics,
                        ]
                        .map(|quantity| recursive::build_with(&mut dag, &model, quantity, formulation));
                        (formulation, quantities)
                    })
                    .collect();
            let points: Vec<[Vec<_>; 3]> = (0..model.points.len())
                .map(|i| {
                    [PointQuantity::Position, PointQuantity::Jacobian, PointQuantity::JacobianDotTimesQdot]
                        .map(|what| recursive::build(&mut dag, &model, Quantity::Point(i, what)))
                })
                .collect();
            // Every form of the point Jacobians, the one `build` picks among them.
            let jacobian_forms: Vec<(usize, JacobianForm, Vec<_>)> = (0..model.points.len())
                .flat_map(|i| {
                    [(false, false), (false, true), (true, false), (true, true)].map(
                        |(in_root_frame, local_columns)| (i, JacobianForm { in_root_frame, local_columns }),
                    )
                })
                .map(|(i, form)| (i, form, recursive::point_jacobian_with(&mut dag, &model, i, form)))
                .collect();
            let frames: Vec<[Vec<_>; 2]> = (0..model.frames.len())
                .map(|i| {
                    [FrameQuantity::Orientation, FrameQuantity::AngularJacobian]
                        .map(|what| recursive::build(&mut dag, &model, Quantity::Frame(i, what)))
                })
                .collect();
            let parameters = model.nominal_parameters();
            let mut rng = Lcg(0x5eed ^ n as u64);
            for _ in 0..20 {
                let q: Vec<f64> = (0..n).map(|_| 2.5 * rng.next()).collect();
                let qd: Vec<f64> = (0..n).map(|_| 3.0 * rng.next()).collect();
                let qdd: Vec<f64> = (0..n).map(|_| 5.0 * rng.next()).collect();
                let want = evaluate(&mech, &State { q: &q, qd: &qd, parameters: &parameters }, None);
                let value = |id| {
                    dag.eval(id, &|atom| match atom {
                        Atom::Sin(j) => q[usize::from(j)].sin(),
                        Atom::Cos(j) => q[usize::from(j)].cos(),
                        Atom::Q(j) => q[usize::from(j)],
                        Atom::Qd(j) => qd[usize::from(j)],
                        Atom::Qdd(j) => qdd[usize::from(j)],
                        Atom::Param(k) => parameters[usize::from(k)],
                        Atom::External(_) | Atom::Closure(_) => f64::NAN,
                    })
                };
                let scale = want.inertia_matrix.iter().flatten().fold(1.0f64, |m, x| m.max(x.abs()))
                    * (1.0 + qd.iter().chain(&qdd).fold(0.0f64, |m, x| m.max(x.abs())).powi(2))
                    + want.g.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let close = |what: &str, got: f64, expected: f64| {
                    assert!(
                        (got - expected).abs() <= 1e-11 * scale,
                        "{text} {variant:?} {what}: recursive {got}, polynomial {expected} at q = {q:?}, q̇ = {qd:?}"
                    );
                };
                for (formulation, [d, cqd, g, c, tau]) in &dynamics {
                    for r in 0..n {
                        for k in 0..n {
                            let at = format!("[{r}][{k}] ({formulation:?})");
                            close(&format!("D{at}"), value(d[r * n + k]), want.inertia_matrix[r][k]);
                            close(&format!("C{at}"), value(c[r * n + k]), want.coriolis_matrix[r][k]);
                        }
                        close(
                            &format!("C q̇[{r}] ({formulation:?})"),
                            value(cqd[r]),
                            want.coriolis_times_qdot[r],
                        );
                        close(&format!("g[{r}] ({formulation:?})"), value(g[r]), want.g[r]);
                        let expected: f64 = (0..n).map(|k| want.inertia_matrix[r][k] * qdd[k]).sum::<f64>()
                            + want.coriolis_times_qdot[r]
                            + want.g[r];
                        close(&format!("τ[{r}] ({formulation:?})"), value(tau[r]), expected);
                    }
                }
                for (i, [rotation, angular]) in frames.iter().enumerate() {
                    let want = evaluate_frame(
                        &mech,
                        &State { q: &q, qd: &qd, parameters: &parameters },
                        &mech.frames[i],
                    );
                    for r in 0..3 {
                        for c in 0..3 {
                            close(
                                &format!("frame {i} R[{r}][{c}]"),
                                value(rotation[r * 3 + c]),
                                want.rotation[r][c],
                            );
                        }
                        for k in 0..n {
                            close(
                                &format!("frame {i} J_ω[{r}][{k}]"),
                                value(angular[r * n + k]),
                                want.angular_jacobian[r][k],
                            );
                        }
                    }
                }
                for (i, [p, jac, jdot]) in points.iter().enumerate() {
                    let want = evaluate(
                        &mech,
                        &State { q: &q, qd: &qd, parameters: &parameters },
                        Some(&mech.points[i]),
                    );
                    for r in 0..p.len() {
                        close(&format!("point {i} p[{r}]"), value(p[r]), want.p[r]);
                        close(
                            &format!("point {i} J̇ q̇[{r}]"),
                            value(jdot[r]),
                            want.jacobian_dot_times_qdot[r],
                        );
                        for k in 0..n {
                            close(
                                &format!("point {i} J[{r}][{k}]"),
                                value(jac[r * n + k]),
                                want.jacobian[r][k],
                            );
                            for (_, form, jacobian) in jacobian_forms.iter().filter(|(point, ..)| *point == i)
                            {
                                close(
                                    &format!("point {i} J[{r}][{k}] ({form:?})"),
                                    value(jacobian[r * n + k]),
                                    want.jacobian[r][k],
                                );
                            }
                        }
                    }
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 6, "only {checked} serial models were compared");
}
