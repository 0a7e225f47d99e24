//! The generated rigs against independent, hand-written generic implementations on nalgebra,
//! at 100 random states each:
//!
//! - planar rigs against per-body Jacobians and the Lagrangian formulas
//!   (`hapticgen_tests::baseline`): D, C q̇, g, p, J and J̇ q̇ agree to 1e-12;
//! - serial rigs against the recursive Newton–Euler and composite-rigid-body algorithms and
//!   geometric Jacobians evaluated at run time (`hapticgen_tests::baseline_serial`): D, C q̇,
//!   g, p, J, J̇ q̇ (each function and the fused `terms`) and the inverse dynamics agree to
//!   1e-12 of each quantity's largest entry (at least 1), with and without fused
//!   multiply-adds.

use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_tests::baseline::{BaselineTerms, PlanarBaseline};
use hapticgen_tests::baseline_serial::SerialBaseline;
use hapticgen_tests::check::{load, random_state};
use hapticgen_tests::dense;
use hapticgen_tests::{visit_all, RigInfo, RigVisitor};
use nalgebra::{DMatrix, DVector};
use rand::rngs::SmallRng;
use rand::SeedableRng;

#[derive(Default)]
struct AgainstBaseline {
    rigs: usize,
}

fn close(what: &str, info: &RigInfo, got: &[f64], want: &[f64]) {
    for (a, b) in got.iter().zip(want) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            "{} {:?} {what}: {got:?} vs {want:?}",
            info.module,
            info.variant
        );
    }
}

impl RigVisitor for AgainstBaseline {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        let (model, _) = load(info);
        let Some(baseline) = PlanarBaseline::new(&model) else { return };
        let mut rng = SmallRng::seed_from_u64(99);
        for _ in 0..100 {
            let (q, qd) = random_state(&model, &mut rng);
            let qa: [f64; N] = std::array::from_fn(|i| q[i]);
            let qda: [f64; N] = std::array::from_fn(|i| qd[i]);
            let (qv, qdv) = (DVector::from_vec(q), DVector::from_vec(qd));
            let t = rig.terms(&qa, &qda);
            let b = baseline.terms(&qv, &qdv);
            let d: Vec<f64> = t.inertia_matrix.iter().flatten().copied().collect();
            let j: Vec<f64> = t.jacobian.iter().flatten().copied().collect();
            close("D", info, &d, b.inertia_matrix.transpose().as_slice());
            close("C q̇", info, &t.coriolis_times_qdot, b.coriolis_times_qdot.as_slice());
            close("g", info, &t.gravity, b.gravity.as_slice());
            close("p", info, &t.position, b.position.as_slice());
            close("J", info, &j, b.jacobian.transpose().as_slice());
            close("J̇ q̇", info, &t.jacobian_dot_times_qdot, b.jacobian_dot_times_qdot.as_slice());
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
fn generated_rigs_equal_the_nalgebra_baseline() {
    let mut v = AgainstBaseline::default();
    visit_all(&mut v);
    // The joystick and both parallel-link variants are planar with revolute joints.
    assert!(v.rigs >= 3, "only {} planar rigs compared", v.rigs);
}

/// `|a − b| ≤ 1e-12 · max(1, max_k |b_k|)` entry by entry: relative to the quantity's
/// largest entry, absolute below 1.
fn close_scaled(what: &str, info: &RigInfo, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{} {:?} {what}: length", info.module, info.variant);
    let scale = want.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    for (k, (a, b)) in got.iter().zip(want).enumerate() {
        assert!(
            (a - b).abs() <= 1e-12 * scale,
            "{} {:?} {what} entry {k}: got {a:e}, want {b:e} (difference {:e}, scale {scale:e})",
            info.module,
            info.variant,
            (a - b).abs()
        );
    }
}

/// Row-major entries of a generated matrix.
fn rows<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

/// Row-major entries of a nalgebra matrix.
fn rows_of(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

/// The generated serial rigs (f64) against `SerialBaseline`.
#[derive(Default)]
struct AgainstSerialBaseline {
    modules: Vec<&'static str>,
}

impl RigVisitor for AgainstSerialBaseline {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        let (model, _) = load(info);
        let Some(baseline) = SerialBaseline::new(&model) else { return };
        assert_eq!(baseline.joints(), N);
        close_scaled("B", info, &rig.damping(), baseline.damping().as_slice());
        let mut rng = SmallRng::seed_from_u64(0x5e71a1);
        for _ in 0..100 {
            let (q, qd) = random_state(&model, &mut rng);
            let (_, qdd) = random_state(&model, &mut rng);
            let qa: [f64; N] = std::array::from_fn(|i| q[i]);
            let qda: [f64; N] = std::array::from_fn(|i| qd[i]);
            let qdda: [f64; N] = std::array::from_fn(|i| qdd[i]);
            let (qv, qdv, qddv) = (DVector::from_vec(q), DVector::from_vec(qd), DVector::from_vec(qdd));
            let compare = |prefix: &str, t: &hapticgen_runtime::RigTerms<f64, N, M>, b: &BaselineTerms| {
                let name = |what: &str| format!("{prefix}{what}");
                close_scaled(&name("D"), info, &rows(&t.inertia_matrix), &rows_of(&b.inertia_matrix));
                close_scaled(&name("C q̇"), info, &t.coriolis_times_qdot, b.coriolis_times_qdot.as_slice());
                close_scaled(&name("g"), info, &t.gravity, b.gravity.as_slice());
                close_scaled(&name("p"), info, &t.position, b.position.as_slice());
                close_scaled(&name("J"), info, &rows(&t.jacobian), &rows_of(&b.jacobian));
                close_scaled(
                    &name("J̇ q̇"),
                    info,
                    &t.jacobian_dot_times_qdot,
                    b.jacobian_dot_times_qdot.as_slice(),
                );
            };
            // Each generated function against each baseline function, …
            let separate = hapticgen_runtime::RigTerms {
                inertia_matrix: rig.inertia_matrix(&qa),
                coriolis_times_qdot: rig.coriolis_times_qdot(&qa, &qda),
                gravity: rig.gravity(&qa),
                position: rig.position(&qa),
                jacobian: rig.jacobian(&qa),
                jacobian_dot_times_qdot: rig.jacobian_dot_times_qdot(&qa, &qda),
            };
            let baseline_separate = BaselineTerms {
                inertia_matrix: baseline.inertia_matrix(&qv),
                coriolis_times_qdot: baseline.coriolis_times_qdot(&qv, &qdv),
                gravity: baseline.gravity(&qv),
                position: baseline.position(&qv),
                jacobian: baseline.jacobian(&qv),
                jacobian_dot_times_qdot: baseline.jacobian_dot_times_qdot(&qv, &qdv),
            };
            compare("", &separate, &baseline_separate);
            // … the fused `terms` against the baseline's shared-pass `terms`, …
            compare("terms.", &rig.terms(&qa, &qda), &baseline.terms(&qv, &qdv));
            // … and the inverse dynamics against the Newton–Euler algorithm with q̈.
            close_scaled(
                "τ",
                info,
                &rig.inverse_dynamics(&qa, &qda, &qdda),
                baseline.inverse_dynamics(&qv, &qdv, &qddv).as_slice(),
            );
        }
        self.modules.push(info.module);
    }

    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        _: &RigInfo,
        _: &R,
    ) {
    }
}

#[test]
fn generated_serial_rigs_equal_the_newton_euler_baseline() {
    let mut v = AgainstSerialBaseline::default();
    visit_all(&mut v);
    // Each serial model, plain and with fused multiply-adds.
    for model in [
        "joystick_1dof_f64",
        "planar_arm_2dof_horizontal_f64",
        "planar_arm_2dof_vertical_f64",
        "phantom_3dof_f64",
        "puma560_f64",
    ] {
        for module in [model.to_string(), format!("{model}_fma")] {
            assert!(v.modules.contains(&module.as_str()), "{module} not compared; compared: {:?}", v.modules);
        }
    }
}

/// The baseline's own algorithms agree with each other, independently of the generated code:
/// the composite-rigid-body `D` equals the inertia matrix the Newton–Euler algorithm implies
/// (`τ(q, q̇, e_j) − τ(q, q̇, 0)`, column by column), `D` is positive definite, and
/// `C q̇ + g = τ(q, q̇, 0)`; on the planar arm, the serial baseline equals the planar
/// Lagrangian one.
#[test]
fn serial_baseline_is_self_consistent() {
    let mut compared = 0;
    for (file, variant) in [
        ("models/planar_arm_2dof.yaml", Some("vertical")),
        ("models/phantom_3dof.yaml", None),
        ("models/puma560.yaml", None),
    ] {
        let info = RigInfo { file, variant, module: file };
        let (model, _) = load(&info);
        let baseline = SerialBaseline::new(&model).expect("a serial model");
        let planar = PlanarBaseline::new(&model);
        let n = baseline.joints();
        let mut rng = SmallRng::seed_from_u64(7);
        for _ in 0..50 {
            let (q, qd) = random_state(&model, &mut rng);
            let (qv, qdv) = (DVector::from_vec(q), DVector::from_vec(qd));
            let d = baseline.inertia_matrix(&qv);
            let bias = baseline.inverse_dynamics(&qv, &qdv, &DVector::zeros(n));
            let mut from_rnea = DMatrix::zeros(n, n);
            for j in 0..n {
                let column =
                    baseline.inverse_dynamics(&qv, &qdv, &DVector::from_fn(n, |i, _| f64::from(i == j)));
                from_rnea.set_column(j, &(column - &bias));
            }
            close_scaled("D (CRBA vs RNEA)", &info, &rows_of(&d), &rows_of(&from_rnea));
            close_scaled("D symmetric", &info, &rows_of(&d), &rows_of(&d.transpose()));
            let rows_d: Vec<Vec<f64>> = (0..n).map(|i| d.row(i).iter().copied().collect()).collect();
            assert!(dense::is_positive_definite(&rows_d), "{file}: D not positive definite");
            let sum = baseline.coriolis_times_qdot(&qv, &qdv) + baseline.gravity(&qv);
            close_scaled("C q̇ + g", &info, sum.as_slice(), bias.as_slice());
            if let Some(planar) = &planar {
                let (s, p) = (baseline.terms(&qv, &qdv), planar.terms(&qv, &qdv));
                close_scaled("planar D", &info, &rows_of(&s.inertia_matrix), &rows_of(&p.inertia_matrix));
                close_scaled(
                    "planar C q̇",
                    &info,
                    s.coriolis_times_qdot.as_slice(),
                    p.coriolis_times_qdot.as_slice(),
                );
                close_scaled("planar g", &info, s.gravity.as_slice(), p.gravity.as_slice());
                close_scaled("planar p", &info, s.position.as_slice(), p.position.as_slice());
                close_scaled("planar J", &info, &rows_of(&s.jacobian), &rows_of(&p.jacobian));
                close_scaled(
                    "planar J̇ q̇",
                    &info,
                    s.jacobian_dot_times_qdot.as_slice(),
                    p.jacobian_dot_times_qdot.as_slice(),
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 50, "the planar arm compared with the planar baseline at every state");
}
