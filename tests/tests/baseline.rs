//! The generated rigs against an independent, hand-written generic implementation on
//! nalgebra (per-body Jacobians and the Lagrangian formulas, `hapticgen_tests::baseline`), at
//! 100 random states: D, C q̇, g, p, J and J̇ q̇ agree to 1e-12.

use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_tests::baseline::PlanarBaseline;
use hapticgen_tests::check::{load, random_state};
use hapticgen_tests::{visit_all, RigInfo, RigVisitor};
use nalgebra::DVector;
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
