//! The identification regressor (`generate --regressor`), compiled for every shipped model and
//! variant, and for the Delta also with its loops solved by Newton's method at run time (the
//! build script's `regressor_rigs`), at random states:
//! - `Y(q, q̇, q̈) · base_parameters()` equals the compiled `inverse_dynamics` plus the model's
//!   viscous friction `B q̇` and Coulomb friction `fc q̇/√(q̇² + δ²)`, to rounding;
//! - with every body's mass, centre of mass and inertia, every rotor inertia and friction
//!   changed, the base parameters of the changed model (its standard parameters combined as
//!   the generator says) times the *nominal* rig's compiled `Y` equal the changed model's
//!   inverse dynamics from the polynomial evaluator (an independent derivation: Lagrangian
//!   polynomials of the changed model, not the regressor's columns).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::dynamics::regressor::Regressor;
use hapticgen_codegen::eval::{evaluate, State};
use hapticgen_codegen::sym::poly::Poly;
use hapticgen_tests::check::{inverse_dynamics_of, load, random_state};
use hapticgen_tests::{regressor_rigs, RegressorRig};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// Random states per rig.
const STATES: usize = 50;

fn times(y: &[Vec<f64>], beta: &[f64]) -> Vec<f64> {
    y.iter().map(|row| row.iter().zip(beta).map(|(a, b)| a * b).sum()).collect()
}

/// `|a − b| ≤ tol · scale`, with the scale the largest of `|b|` and of the terms `|Y_ij β_j|`
/// (what rounding is relative to).
fn assert_close(rig: &RegressorRig, what: &str, y: &[Vec<f64>], beta: &[f64], want: &[f64], tol: f64) {
    let got = times(y, beta);
    for i in 0..want.len() {
        let terms = y[i].iter().zip(beta).map(|(a, b)| (a * b).abs()).fold(0.0, f64::max);
        let scale = want[i].abs().max(terms).max(1e-12);
        assert!(
            (got[i] - want[i]).abs() <= tol * scale,
            "{} ({:?}) {what}, joint {i}: Y·β = {:e}, want {:e} (difference {:e}, scale {scale:e})",
            rig.info.module,
            rig.info.variant,
            got[i],
            want[i],
            (got[i] - want[i]).abs()
        );
    }
}

fn random_qdd(n: usize, rng: &mut SmallRng) -> Vec<f64> {
    (0..n).map(|_| rng.gen_range(-5.0..5.0)).collect()
}

fn smooth_sign(v: f64, band: f64) -> f64 {
    v / (v * v + band * band).sqrt()
}

#[test]
fn regressor_times_nominal_base_parameters_is_the_inverse_dynamics() {
    let rigs = regressor_rigs();
    // Every shipped model and variant (9 files, 3 of them with two variants), and the Delta with
    // its loops solved by Newton's method at run time.
    assert!(rigs.len() >= 13, "only {} regressor rigs", rigs.len());
    for rig in &rigs {
        let (model, _) = load(&rig.info);
        let n = model.joints.len();
        let beta = (rig.base_parameters)();
        assert_eq!(beta.len(), rig.names.len());
        let damping = (rig.damping)();
        let mut rng = SmallRng::seed_from_u64(43);
        let mut checked = 0;
        for _ in 0..STATES {
            let (q, qd) = random_state(&model, &mut rng);
            let qdd = random_qdd(n, &mut rng);
            let y = (rig.regressor)(&q, &qd, &qdd);
            if y.iter().flatten().any(|x| !x.is_finite()) {
                // A closed chain outside the region where its loops close.
                continue;
            }
            let tau = (rig.inverse_dynamics)(&q, &qd, &qdd);
            let want: Vec<f64> = (0..n)
                .map(|j| {
                    tau[j]
                        + damping[j] * qd[j]
                        + model.joints[j].drive.coulomb_friction * smooth_sign(qd[j], rig.coulomb_band)
                })
                .collect();
            assert_close(rig, "nominal", &y, &beta, &want, 1e-9);
            checked += 1;
        }
        assert!(checked >= STATES / 2, "{}: only {checked} states where the loops close", rig.info.module);
    }
}

#[test]
fn perturbed_base_parameters_give_the_changed_models_inverse_dynamics() {
    for rig in &regressor_rigs() {
        let (model, mech) = load(&rig.info);
        let regressor = Regressor::new(&model, mech.closures.as_ref());
        let names: Vec<&str> = regressor.base.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, rig.names, "{}: the generator's base parameters", rig.info.module);

        // Every inertial parameter, rotor inertia and friction changed by 10–40 %, centres of
        // mass moved by up to 2 cm.
        let mut rng = SmallRng::seed_from_u64(1987);
        let mut changed = model.clone();
        let factor = |rng: &mut SmallRng| 1.0 + rng.gen_range(0.1..0.4) * if rng.gen() { 1.0 } else { -1.0 };
        for body in &mut changed.bodies {
            if body.mass.is_zero() {
                continue;
            }
            body.mass = body.mass.scale(factor(&mut rng));
            for c in &mut body.com {
                *c = c.add(&Poly::constant(rng.gen_range(-0.02..0.02)));
            }
            let (a, b) = (factor(&mut rng), factor(&mut rng));
            for r in 0..3 {
                for c in 0..3 {
                    // Scaled diagonal, off-diagonal entries kept: still a valid inertia.
                    if r == c {
                        body.inertia[r][c] = body.inertia[r][c].scale(if r == 0 { a } else { b });
                    }
                }
            }
        }
        for joint in &mut changed.joints {
            joint.drive.motor.rotor_inertia *= factor(&mut rng);
            joint.damping = joint.damping.scale(factor(&mut rng)).add(&Poly::constant(0.001));
            joint.drive.coulomb_friction = joint.drive.coulomb_friction * factor(&mut rng) + 0.01;
        }
        let beta = regressor.base_values(&regressor.standard_values(&changed));
        let nominal = (rig.base_parameters)();
        let moved =
            beta.iter().zip(&nominal).filter(|(a, b)| (*a - *b).abs() > 1e-3 * b.abs().max(1e-9)).count();
        assert!(moved > beta.len() / 2, "{}: only {moved} base parameters changed", rig.info.module);

        let changed_mech = hapticgen_codegen::dynamics::derive(&changed, mech.closures.as_ref());
        let params = changed.nominal_parameters();
        let n = changed.joints.len();
        let mut rng = SmallRng::seed_from_u64(7);
        let mut checked = 0;
        for _ in 0..STATES / 5 {
            let (q, qd) = random_state(&model, &mut rng);
            let qdd = random_qdd(n, &mut rng);
            let y = (rig.regressor)(&q, &qd, &qdd);
            if y.iter().flatten().any(|x| !x.is_finite()) {
                continue;
            }
            let e = evaluate(&changed_mech, &State { q: &q, qd: &qd, parameters: &params }, None);
            let tau = inverse_dynamics_of(&e, &qdd);
            let want: Vec<f64> = (0..n)
                .map(|j| {
                    tau[j]
                        + e.damping[j][j] * qd[j]
                        + changed.joints[j].drive.coulomb_friction * smooth_sign(qd[j], rig.coulomb_band)
                })
                .collect();
            assert_close(rig, "changed model", &y, &beta, &want, 1e-8);
            checked += 1;
        }
        assert!(checked >= STATES / 10, "{}: only {checked} states where the loops close", rig.info.module);
    }
}
