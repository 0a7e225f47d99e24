//! The fused, generated control laws equal the runtime's generic laws (eq. (3), (4), (7)–(13))
//! on every shipped rig: same status, torques within 1e-12 (f64), at 200 random states per law,
//! including states near the singular boundary (fallback to Controller 3), with and without the
//! `B q̇` term, with and without the friction compensation, and with non-finite inputs.

use hapticgen_runtime::control::{
    ControlOptions, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
    TaskSensing,
};
use hapticgen_runtime::fused::{fused_torque, FusedImpedance};
use hapticgen_tests::{visit_all, RigInfo, RigVisitor};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

const LAWS: [ImpedanceLaw; 4] = [
    ImpedanceLaw::ForceFeedback,
    ImpedanceLaw::AccelerationFeedback,
    ImpedanceLaw::NaturalInertia,
    ImpedanceLaw::JacobianTranspose,
];

/// Determinant of a small square matrix by Laplace expansion (N ≤ 3 here).
fn generic_det<const N: usize, const M: usize>(j: &[[f64; N]; M]) -> f64 {
    let rows: Vec<Vec<f64>> = j.iter().map(|r| r.to_vec()).collect();
    fn det(m: &[Vec<f64>]) -> f64 {
        if m.len() == 1 {
            return m[0][0];
        }
        (0..m.len())
            .map(|c| {
                let minor: Vec<Vec<f64>> = m[1..]
                    .iter()
                    .map(|r| r.iter().enumerate().filter(|(k, _)| *k != c).map(|(_, x)| *x).collect())
                    .collect();
                let sign = if c % 2 == 0 { 1.0 } else { -1.0 };
                sign * m[0][c] * det(&minor)
            })
            .sum()
    }
    det(&rows)
}

struct FusedEqualsGeneric {
    comparisons: usize,
    fallbacks: usize,
    /// Rigs whose model has Coulomb friction (their compensation is compared too).
    with_friction: usize,
}

impl RigVisitor for FusedEqualsGeneric {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        let drives = rig.drives();
        // The rig carries its model's Coulomb friction, which the compensation feeds forward.
        let path = hapticgen_tests::workspace_root().join(info.file);
        let model =
            hapticgen_codegen::load_file(&path, info.file, info.variant).unwrap_or_else(|e| panic!("{e}"));
        let coulomb: Vec<f64> = model.model.joints.iter().map(|j| j.drive.coulomb_friction).collect();
        assert_eq!(rig.coulomb_friction().to_vec(), coulomb, "{}", info.module);
        if coulomb.iter().any(|&fc| fc > 0.0) {
            self.with_friction += 1;
        }
        let mut rng = SmallRng::seed_from_u64(0xf05ed);
        for law in LAWS {
            for case in 0..200 {
                let q: [f64; N] = std::array::from_fn(|i| {
                    rng.gen_range(drives[i].position_lower..drives[i].position_upper)
                });
                let qd: [f64; N] = std::array::from_fn(|_| rng.gen_range(-2.0..2.0));
                let x = rig.position(&q);
                let reference = TaskReference {
                    position: std::array::from_fn(|k| x[k] + rng.gen_range(-0.02..0.02)),
                    velocity: std::array::from_fn(|_| rng.gen_range(-0.1..0.1)),
                    acceleration: std::array::from_fn(|_| rng.gen_range(-1.0..1.0)),
                };
                let parameters = ImpedanceParameters {
                    stiffness: std::array::from_fn(|_| rng.gen_range(0.0..2000.0)),
                    damping: std::array::from_fn(|_| rng.gen_range(0.0..10.0)),
                    mass: std::array::from_fn(|_| rng.gen_range(0.01..2.0)),
                };
                let mut sensed = TaskSensing {
                    operator_force: std::array::from_fn(|_| rng.gen_range(-5.0..5.0)),
                    acceleration: std::array::from_fn(|_| rng.gen_range(-5.0..5.0)),
                };
                // Every 50th case carries a NaN where the law reads it.
                if case % 50 == 49 {
                    sensed.operator_force[0] = f64::NAN;
                    sensed.acceleration[0] = f64::NAN;
                }
                let controller = ImpedanceController {
                    law,
                    parameters,
                    options: ControlOptions {
                        omit_damping_compensation: case % 2 == 0,
                        min_abs_jacobian_determinant: 5e-4,
                        spring_lead_time: 0.0,
                        // Every third case with the friction feed-forward (a band well inside
                        // the sampled velocities, so both sides of it are compared).
                        friction_compensation_band: (case % 3 == 0).then_some(0.5),
                    },
                };
                let generic = controller.torque(rig, &rig.terms(&q, &qd), &qd, &reference, &sensed);
                let fused = fused_torque(rig, &controller, &q, &qd, &reference, &sensed);
                assert_eq!(generic.status, fused.status, "{} {law:?} at q = {q:?}", info.module);
                if generic.status == ControlStatus::SingularFallback {
                    self.fallbacks += 1;
                }
                // J⁻¹ amplifies rounding by J's condition number; the two implementations
                // (LU vs adjugate) round differently, so the bound scales with it.
                let j = rig.jacobian(&q);
                let norm: f64 = j.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
                let det = if N == M { generic_det(&j) } else { 1.0 };
                let conditioning = if law == ImpedanceLaw::JacobianTranspose || N != M {
                    1.0
                } else {
                    (norm.powi(N as i32) / det.abs()).max(1.0)
                };
                for i in 0..N {
                    let (a, b) = (generic.torque[i], fused.torque[i]);
                    assert!(
                        (a - b).abs() <= 1e-12 * conditioning * a.abs().max(1.0),
                        "{} {law:?}: joint {i} generic {a:e} fused {b:e} at q = {q:?}",
                        info.module
                    );
                }
                self.comparisons += 1;
            }
        }
    }

    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        _: &RigInfo,
        _: &R,
    ) {
    }
}

#[test]
fn fused_generated_laws_equal_the_generic_runtime_laws() {
    let mut v = FusedEqualsGeneric { comparisons: 0, fallbacks: 0, with_friction: 0 };
    visit_all(&mut v);
    assert!(v.comparisons >= 3 * 4 * 200);
    // The parallel link's random states include some near q1 = q2.
    assert!(v.fallbacks > 0, "no state exercised the singular fallback");
    // The joystick, the parallel link, the pantograph, the PHANToM-like arm and the PUMA 560.
    assert!(v.with_friction >= 5, "{} rigs with Coulomb friction", v.with_friction);
}
