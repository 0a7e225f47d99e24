//! Numerical verification of every shipped model (all variants) against independent
//! computations, at 100 random states each:
//! - `J` and `J̇` against central finite differences of `p` and `J`;
//! - `D` symmetric positive definite; `Ḋ − 2C` skew-symmetric (`Ḋ` by finite differences);
//! - total energy conserved over 1 s of undamped, unforced motion (RK4 on the compiled code);
//! - the compiled, emitted code equal to the numeric evaluator (f64 to 1e-12, f32 to 1e-5).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::build;
use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{Full, State};
use hapticgen_codegen::model::Model;
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_tests::check::{eval_at, load, random_state, EvaluatorCheck, STATES};
use hapticgen_tests::dense::{is_positive_definite, solve};
use hapticgen_tests::{visit_all, workspace_root, RigInfo, RigVisitor};
use rand::rngs::SmallRng;
use rand::SeedableRng;

#[test]
fn compiled_code_equals_the_evaluator() {
    let mut v = EvaluatorCheck::default();
    visit_all(&mut v);
    // joystick (f32, f64) + parallel link (2 variants × 2 scalars).
    assert!(v.rigs >= 6, "only {} rigs visited", v.rigs);
}

/// Each shipped model and variant, loaded for the evaluator-only checks.
fn shipped() -> Vec<(String, Option<String>, Model, Mechanics)> {
    let mut out = Vec::new();
    for entry in build::models_in(&workspace_root().join("models"), "models").unwrap() {
        for v in entry.variants {
            let m = hapticgen_codegen::load_file(&entry.path, &entry.display, v.as_deref()).unwrap();
            let mech = hapticgen_codegen::derive(&m);
            out.push((entry.display.clone(), v, m.model, mech));
        }
    }
    assert!(out.len() >= 3);
    out
}

#[test]
fn jacobians_match_finite_differences() {
    let h = 1e-6;
    for (file, variant, model, mech) in shipped() {
        let params = model.nominal_parameters();
        let mut rng = SmallRng::seed_from_u64(7);
        let n = model.joints.len();
        for _ in 0..STATES {
            let (q, qd) = random_state(&model, &mut rng);
            let e = eval_at(&mech, &params, &q, &qd);
            let shifted = |k: usize, delta: f64| {
                let mut qq = q.clone();
                qq[k] += delta;
                eval_at(&mech, &params, &qq, &qd)
            };
            for k in 0..n {
                let (plus, minus) = (shifted(k, h), shifted(k, -h));
                for r in 0..e.p.len() {
                    let fd = (plus.p[r] - minus.p[r]) / (2.0 * h);
                    let j = e.jacobian[r][k];
                    assert!(
                        (fd - j).abs() < 1e-8,
                        "{file} {variant:?}: J[{r}][{k}] = {j}, finite difference {fd}"
                    );
                }
            }
            // J̇ = d/dt J along q̇: central difference of J(q + t q̇).
            let along = |t: f64| {
                let qq: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + t * b).collect();
                eval_at(&mech, &params, &qq, &qd)
            };
            let (plus, minus) = (along(h), along(-h));
            for r in 0..e.p.len() {
                for k in 0..n {
                    let fd = (plus.jacobian[r][k] - minus.jacobian[r][k]) / (2.0 * h);
                    let jd = e.jacobian_dot[r][k];
                    assert!(
                        (fd - jd).abs() < 1e-7,
                        "{file} {variant:?}: J̇[{r}][{k}] = {jd}, finite difference {fd}"
                    );
                }
                let jdqd: f64 = (0..n).map(|k| e.jacobian_dot[r][k] * qd[k]).sum();
                assert!((jdqd - e.jacobian_dot_times_qdot[r]).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn inertia_is_spd_and_ddot_minus_two_c_is_skew() {
    let h = 1e-6;
    for (file, variant, model, mech) in shipped() {
        let params = model.nominal_parameters();
        let mut rng = SmallRng::seed_from_u64(11);
        let n = model.joints.len();
        for _ in 0..STATES {
            let (q, qd) = random_state(&model, &mut rng);
            let e = eval_at(&mech, &params, &q, &qd);
            let d = &e.inertia_matrix;
            for i in 0..n {
                for j in 0..n {
                    assert_eq!(d[i][j], d[j][i], "{file} {variant:?}: D not symmetric");
                }
            }
            assert!(is_positive_definite(d), "{file} {variant:?}: D not positive definite at {q:?}");
            let along = |t: f64| {
                let qq: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + t * b).collect();
                eval_at(&mech, &params, &qq, &qd).inertia_matrix
            };
            let (plus, minus) = (along(h), along(-h));
            let n_matrix: Vec<Vec<f64>> = (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| (plus[i][j] - minus[i][j]) / (2.0 * h) - 2.0 * e.coriolis_matrix[i][j])
                        .collect()
                })
                .collect();
            // The central difference of D carries a round-off of about ε·|D|/h ≈ 2e-10·|D|.
            let bound = 1e-9 * d.iter().flatten().fold(1.0f64, |m, x| m.max(x.abs()));
            for i in 0..n {
                for j in 0..n {
                    let s = n_matrix[i][j] + n_matrix[j][i];
                    assert!(
                        s.abs() < bound,
                        "{file} {variant:?}: (Ḋ − 2C) + (Ḋ − 2C)ᵀ = {s} at [{i}][{j}] (bound {bound:e})"
                    );
                }
            }
            // C q̇ is the product of the two.
            for i in 0..n {
                let cqd: f64 = (0..n).map(|j| e.coriolis_matrix[i][j] * qd[j]).sum();
                assert!((cqd - e.coriolis_times_qdot[i]).abs() < 1e-12);
            }
        }
    }
}

struct EnergyConservation {
    rigs: usize,
}

impl RigVisitor for EnergyConservation {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        let (model, mech) = load(info);
        let params = model.nominal_parameters();
        // Undamped, unforced: D q̈ = −C q̇ − g.
        let acceleration = |q: &[f64; N], qd: &[f64; N]| -> [f64; N] {
            let d = rig.inertia_matrix(q);
            let c = rig.coriolis_times_qdot(q, qd);
            let g = rig.gravity(q);
            let x = solve(d.iter().map(|r| r.to_vec()).collect(), (0..N).map(|i| -c[i] - g[i]).collect());
            std::array::from_fn(|i| x[i])
        };
        let energy = |q: &[f64; N], qd: &[f64; N]| -> f64 {
            let d = rig.inertia_matrix(q);
            let kinetic: f64 =
                (0..N).map(|i| (0..N).map(|j| 0.5 * qd[i] * d[i][j] * qd[j]).sum::<f64>()).sum();
            let state = State { q, qd, parameters: &params };
            let v = mech.potential_energy.eval(&Full::new(&mech, &state));
            kinetic + v
        };
        let mut rng = SmallRng::seed_from_u64(3);
        for _ in 0..3 {
            let (q0, qd0) = random_state(&model, &mut rng);
            let mut q: [f64; N] = std::array::from_fn(|i| q0[i]);
            let mut qd: [f64; N] = std::array::from_fn(|i| qd0[i]);
            let e0 = energy(&q, &qd);
            let dt = 1e-4;
            let mut worst = 0.0f64;
            let scale = e0.abs().max((0..N).map(|i| qd[i].abs()).fold(0.0, f64::max).powi(2) * 1e-3);
            // A closed chain's reduced dynamics hold where the loop closes: its run ends when
            // it leaves the box of joint limits (chosen inside the workspace).
            let closed = !model.passive.is_empty();
            let inside =
                |q: &[f64; N]| model.joints.iter().zip(q).all(|(j, x)| *x >= j.lower && *x <= j.upper);
            let mut steps = 0;
            for _ in 0..10_000 {
                if closed && !inside(&q) {
                    break;
                }
                steps += 1;
                // Classical fourth-order Runge–Kutta.
                let add = |a: &[f64; N], b: &[f64; N], k: f64| -> [f64; N] {
                    std::array::from_fn(|i| a[i] + k * b[i])
                };
                let k1q = qd;
                let k1v = acceleration(&q, &qd);
                let k2q = add(&qd, &k1v, dt / 2.0);
                let k2v = acceleration(&add(&q, &k1q, dt / 2.0), &k2q);
                let k3q = add(&qd, &k2v, dt / 2.0);
                let k3v = acceleration(&add(&q, &k2q, dt / 2.0), &k3q);
                let k4q = add(&qd, &k3v, dt);
                let k4v = acceleration(&add(&q, &k3q, dt), &k4q);
                q = std::array::from_fn(|i| {
                    q[i] + dt / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i])
                });
                qd = std::array::from_fn(|i| {
                    qd[i] + dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
                });
                worst = worst.max((energy(&q, &qd) - e0).abs() / scale);
            }
            eprintln!("{} energy drift {worst:e} over {steps} steps", info.module);
            assert!(steps >= 200, "{}: left the joint limits after {steps} steps", info.module);
            assert!(
                worst < 1e-9,
                "{} {:?}: relative energy drift {worst:e} over 1 s",
                info.module,
                info.variant
            );
        }
        self.rigs += 1;
    }

    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        _: &RigInfo,
        _: &R,
    ) {
    }
}

#[test]
fn energy_is_conserved_without_damping_or_forces() {
    let mut v = EnergyConservation { rigs: 0 };
    visit_all(&mut v);
    assert!(v.rigs >= 3);
}
