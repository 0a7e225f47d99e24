//! Every shipped model, generated at build time (all variants, `f32` and `f64`), and a visitor
//! over them so that tests run once per rig.
#![allow(missing_docs)]

pub mod baseline;
pub mod baseline_serial;
pub mod nested_builds;

pub use nested_builds::target_dir;

/// The README's and the runtime guide's examples, compiled and run as doc tests (the build
/// script copies both files with their `rig!` paths made relative to this crate).
#[doc(hidden)]
pub mod docs {
    #[doc = include_str!(concat!(env!("OUT_DIR"), "/readme.md"))]
    pub mod readme {}
    #[doc = include_str!(concat!(env!("OUT_DIR"), "/runtime-guide.md"))]
    pub mod runtime_guide {}
}

use hapticgen_runtime::fused::FusedImpedance;

/// Which model file and variant a generated rig came from.
#[derive(Clone, Copy, Debug)]
pub struct RigInfo {
    /// The model file, relative to the workspace root.
    pub file: &'static str,
    /// The variant, if the model has variants.
    pub variant: Option<&'static str>,
    /// The generated module's name.
    pub module: &'static str,
}

/// Visits generated rigs of either scalar type (generated rigs are `Clone`; all but a spatial
/// closed chain, which keeps a cache of its loops, are `Copy` too).
pub trait RigVisitor {
    /// A double-precision rig.
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64> + Clone, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    );
    /// A single-precision rig.
    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32> + Clone, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    );
}

/// A function of `(q, q̇, q̈)` of a generated rig, over slices.
pub type StateFn<T> = fn(&[f64], &[f64], &[f64]) -> T;

/// A rig generated with the identification regressor (`regressor_rigs`), its functions as
/// plain function pointers over slices (`f64`).
#[derive(Clone, Copy)]
pub struct RegressorRig {
    /// Where it came from.
    pub info: RigInfo,
    /// `BASE_PARAMETERS`.
    pub names: &'static [&'static str],
    /// `COULOMB_BAND`.
    pub coulomb_band: f64,
    /// `regressor(q, q̇, q̈)`, rows of `Y`.
    pub regressor: StateFn<Vec<Vec<f64>>>,
    /// `inverse_dynamics(q, q̇, q̈)`.
    pub inverse_dynamics: StateFn<Vec<f64>>,
    /// `damping()`.
    pub damping: fn() -> Vec<f64>,
    /// `base_parameters()`.
    pub base_parameters: fn() -> Vec<f64>,
}

include!(concat!(env!("OUT_DIR"), "/registry.rs"));

/// The workspace root (for loading model files in tests).
pub fn workspace_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Shared checks of generated rigs against the numeric evaluator.
pub mod check {
    use hapticgen_codegen::dynamics::mechanics::Mechanics;
    use hapticgen_codegen::eval::{evaluate, Evaluated, State};
    use hapticgen_codegen::model::Model;
    use hapticgen_runtime::fused::FusedImpedance;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    use crate::{workspace_root, RigInfo, RigVisitor};

    /// Random states per rig.
    pub const STATES: usize = 100;

    /// Loads the model a generated rig came from.
    pub fn load(info: &RigInfo) -> (Model, Mechanics) {
        let path = workspace_root().join(info.file);
        let model =
            hapticgen_codegen::load_file(&path, info.file, info.variant).unwrap_or_else(|e| panic!("{e}"));
        let mech = hapticgen_codegen::derive(&model);
        (model.model, mech)
    }

    /// A random state within the joint limits, velocities in ±2.
    pub fn random_state(model: &Model, rng: &mut SmallRng) -> (Vec<f64>, Vec<f64>) {
        let q = model.joints.iter().map(|j| rng.gen_range(j.lower..j.upper)).collect();
        let qd = model.joints.iter().map(|_| rng.gen_range(-2.0..2.0)).collect();
        (q, qd)
    }

    /// The evaluator at one state.
    pub fn eval_at(mech: &Mechanics, params: &[f64], q: &[f64], qd: &[f64]) -> Evaluated {
        evaluate(mech, &State { q, qd, parameters: params }, None)
    }

    /// Row-major entries of a matrix.
    pub fn flat<const R: usize, const C: usize, S: Copy + Into<f64>>(m: &[[S; C]; R]) -> Vec<f64> {
        m.iter().flat_map(|row| row.iter().map(|&x| x.into())).collect()
    }

    /// Row-major entries of a nested vector.
    pub fn flat_vec(m: &[Vec<f64>]) -> Vec<f64> {
        m.iter().flatten().copied().collect()
    }

    /// Asserts `|a − b| ≤ tol · max(1, |b|)` element-wise for f64 (`relative_floor` = 1), or
    /// `|a − b| ≤ tol · max(|b|, max|b|)` for f32 outputs (relative to the output's scale).
    /// Element-wise closeness with a description of the first failure.
    pub fn assert_close(
        what: &str,
        info: &RigInfo,
        got: &[f64],
        want: &[f64],
        tol: f64,
        scale_relative: bool,
    ) {
        assert_eq!(got.len(), want.len(), "{what} of {info:?}: length");
        let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (i, (a, b)) in got.iter().zip(want).enumerate() {
            let bound =
                if scale_relative { tol * b.abs().max(scale).max(1e-30) } else { tol * b.abs().max(1.0) };
            assert!(
                (a - b).abs() <= bound,
                "{what} of {} ({:?}) entry {i}: got {a:e}, want {b:e} (difference {:e}, bound {bound:e})",
                info.module,
                info.variant,
                (a - b).abs()
            );
        }
    }

    /// `D q̈ + C q̇ + g` from the evaluator's values.
    pub fn inverse_dynamics_of(e: &Evaluated, qdd: &[f64]) -> Vec<f64> {
        (0..e.g.len())
            .map(|i| {
                e.inertia_matrix[i].iter().zip(qdd).map(|(d, a)| d * a).sum::<f64>()
                    + e.coriolis_times_qdot[i]
                    + e.g[i]
            })
            .collect()
    }

    /// Compares each visited rig's compiled functions with the numeric evaluator at
    /// [`STATES`] random states: f64 to 1e-12, f32 to 1e-5 of each output's scale.
    #[derive(Default)]
    pub struct EvaluatorCheck {
        /// Rigs checked so far.
        pub rigs: usize,
    }

    impl RigVisitor for EvaluatorCheck {
        fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
            &mut self,
            info: &RigInfo,
            rig: &R,
        ) {
            let (model, mech) = load(info);
            let params = model.nominal_parameters();
            let mut rng = SmallRng::seed_from_u64(0x5eed_0001);
            for _ in 0..STATES {
                let (q, qd) = random_state(&model, &mut rng);
                let e = eval_at(&mech, &params, &q, &qd);
                let qa: [f64; N] = std::array::from_fn(|i| q[i]);
                let qda: [f64; N] = std::array::from_fn(|i| qd[i]);
                let tol = 1e-12;
                assert_close(
                    "D",
                    info,
                    &flat(&rig.inertia_matrix(&qa)),
                    &flat_vec(&e.inertia_matrix),
                    tol,
                    false,
                );
                assert_close(
                    "C",
                    info,
                    &flat(&rig.coriolis_matrix(&qa, &qda)),
                    &flat_vec(&e.coriolis_matrix),
                    tol,
                    false,
                );
                assert_close(
                    "C q̇",
                    info,
                    &rig.coriolis_times_qdot(&qa, &qda),
                    &e.coriolis_times_qdot,
                    tol,
                    false,
                );
                assert_close("g", info, &rig.gravity(&qa), &e.g, tol, false);
                // τ = D q̈ + C q̇ + g at a pseudo-random q̈ (the qd of another state).
                let (_, qdd) = random_state(&model, &mut rng);
                let qdda: [f64; N] = std::array::from_fn(|i| qdd[i]);
                let expected = inverse_dynamics_of(&e, &qdd);
                let scale = expected.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let tau = rig.inverse_dynamics(&qa, &qda, &qdda);
                assert_close("τ", info, &tau, &expected, tol * scale.max(1.0), false);
                let b: Vec<f64> = (0..N).map(|i| e.damping[i][i]).collect();
                assert_close("B", info, &rig.damping(), &b, tol, false);
                assert_close("p", info, &rig.position(&qa), &e.p, tol, false);
                assert_close("J", info, &flat(&rig.jacobian(&qa)), &flat_vec(&e.jacobian), tol, false);
                assert_close(
                    "J̇",
                    info,
                    &flat(&rig.jacobian_dot(&qa, &qda)),
                    &flat_vec(&e.jacobian_dot),
                    tol,
                    false,
                );
                assert_close(
                    "J̇ q̇",
                    info,
                    &rig.jacobian_dot_times_qdot(&qa, &qda),
                    &e.jacobian_dot_times_qdot,
                    tol,
                    false,
                );
                let t = rig.terms(&qa, &qda);
                assert_close(
                    "terms.D",
                    info,
                    &flat(&t.inertia_matrix),
                    &flat_vec(&e.inertia_matrix),
                    tol,
                    false,
                );
                assert_close("terms.C q̇", info, &t.coriolis_times_qdot, &e.coriolis_times_qdot, tol, false);
                assert_close("terms.g", info, &t.gravity, &e.g, tol, false);
                assert_close("terms.p", info, &t.position, &e.p, tol, false);
                assert_close("terms.J", info, &flat(&t.jacobian), &flat_vec(&e.jacobian), tol, false);
                assert_close(
                    "terms.J̇ q̇",
                    info,
                    &t.jacobian_dot_times_qdot,
                    &e.jacobian_dot_times_qdot,
                    tol,
                    false,
                );
            }
            self.rigs += 1;
        }

        fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
            &mut self,
            info: &RigInfo,
            rig: &R,
        ) {
            let (model, mech) = load(info);
            let params = model.nominal_parameters();
            let mut rng = SmallRng::seed_from_u64(0x5eed_0002);
            for _ in 0..STATES {
                let (q, qd) = random_state(&model, &mut rng);
                // Evaluate at exactly the f32 state the compiled code sees.
                let q: Vec<f64> = q.iter().map(|&x| f64::from(x as f32)).collect();
                let qd: Vec<f64> = qd.iter().map(|&x| f64::from(x as f32)).collect();
                let e = eval_at(&mech, &params, &q, &qd);
                let qa: [f32; N] = std::array::from_fn(|i| q[i] as f32);
                let qda: [f32; N] = std::array::from_fn(|i| qd[i] as f32);
                let tol = 1e-5;
                // `C q̇` cancels: the parallel link's is `k sin(q1 − q2) (q̇2², −q̇1²)` with
                // sin(q1 − q2) = s1 c2 − s2 c1. Fused (`s1 c2` exact, `s2 c1` rounded) its error
                // measured up to 2.1 × 1e-5 of the output's scale at these states (unfused 0.9 ×,
                // the pantograph's), the same order, so fused rigs (module `…_fma`) get 3e-5 there.
                let coriolis_tol = if info.module.ends_with("_fma") { 3e-5 } else { tol };
                let v = |x: &[f32]| x.iter().map(|&y| f64::from(y)).collect::<Vec<_>>();
                assert_close(
                    "D",
                    info,
                    &flat(&rig.inertia_matrix(&qa)),
                    &flat_vec(&e.inertia_matrix),
                    tol,
                    true,
                );
                assert_close(
                    "C q̇",
                    info,
                    &v(&rig.coriolis_times_qdot(&qa, &qda)),
                    &e.coriolis_times_qdot,
                    coriolis_tol,
                    true,
                );
                assert_close("g", info, &v(&rig.gravity(&qa)), &e.g, tol, true);
                let (_, qdd) = random_state(&model, &mut rng);
                let qdd: Vec<f64> = qdd.iter().map(|&x| f64::from(x as f32)).collect();
                let qdda: [f32; N] = std::array::from_fn(|i| qdd[i] as f32);
                let expected = inverse_dynamics_of(&e, &qdd);
                let scale = expected.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let tau = v(&rig.inverse_dynamics(&qa, &qda, &qdda));
                assert_close("τ", info, &tau, &expected, tol * scale.max(1.0), false);
                assert_close("p", info, &v(&rig.position(&qa)), &e.p, tol, true);
                assert_close("J", info, &flat(&rig.jacobian(&qa)), &flat_vec(&e.jacobian), tol, true);
                assert_close(
                    "J̇ q̇",
                    info,
                    &v(&rig.jacobian_dot_times_qdot(&qa, &qda)),
                    &e.jacobian_dot_times_qdot,
                    tol,
                    true,
                );
                let t = rig.terms(&qa, &qda);
                assert_close(
                    "terms.D",
                    info,
                    &flat(&t.inertia_matrix),
                    &flat_vec(&e.inertia_matrix),
                    tol,
                    true,
                );
                assert_close("terms.J", info, &flat(&t.jacobian), &flat_vec(&e.jacobian), tol, true);
            }
            self.rigs += 1;
        }
    }
}

/// The parallel link's control stack as the tests and benchmarks run it: a virtual circle
/// (a cavity of radius 2 cm, 1500 N/m, 5 N·s/m, as in Fig. 7) and the loop's settings.
pub mod stack {
    use hapticgen_runtime::control::{
        ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters,
    };
    use hapticgen_runtime::estimation::ForceSensorCalibration;
    use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
    use hapticgen_runtime::tick::HapticLoopSettings;

    use crate::parallel_link_2dof_vertical_f64::ParallelLink2dof;

    /// Free space with the 0.3 mm anti-drift grid and a circular cavity in the workspace.
    pub fn circle_scene() -> Scene<f64, 2, 8> {
        let mut scene = Scene::new(0.0, 5.0, 0.3e-3);
        scene.add(VirtualObject {
            shape: Shape::Circle { center: [0.0, 0.13], radius: 0.02 },
            kind: ObjectKind::Cavity,
            stiffness: 1500.0,
            damping: 5.0,
        });
        scene
    }

    /// Settings of the parallel link's loop with the given law: built from the rig
    /// ([`HapticLoopSettings::for_rig`]: 1 kHz filters, the generated current-loop gains), then
    /// the homing pose and the force sensor's calibration of this bench.
    pub fn parallel_link_settings(law: ImpedanceLaw) -> HapticLoopSettings<f64, 2, 2> {
        let controller = ImpedanceController {
            law,
            parameters: ImpedanceParameters { stiffness: [0.0; 2], damping: [5.0; 2], mass: [0.2; 2] },
            options: ControlOptions { min_abs_jacobian_determinant: 1e-4, ..ControlOptions::paper() },
        };
        let mut settings = HapticLoopSettings::for_rig(&ParallelLink2dof::NOMINAL, controller);
        settings.zero_offset = [1.4, 0.1];
        settings.force_calibration = ForceSensorCalibration { scale: [5.0; 2], offset: [2.5; 2] };
        settings
    }

    /// Encoder counts of the parallel link moving on a slow loop through the cavity's wall
    /// (24,000 counts per joint turn through the 12:1 gearhead).
    pub fn encoder_counts(tick: u32) -> [i32; 2] {
        let t = f64::from(tick) * 1e-3;
        [(600.0 * (2.0 * t).sin()) as i32, (900.0 * (1.3 * t).sin()) as i32]
    }
}

/// Dense linear algebra for the tests' independent checks (plain `Vec`s, no library).
// Index loops mirror the textbook elimination.
#[allow(clippy::needless_range_loop)]
pub mod dense {
    /// Solves `a x = b` by Gaussian elimination with partial pivoting.
    pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
        let n = b.len();
        for k in 0..n {
            let p = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs())).unwrap_or(k);
            a.swap(k, p);
            b.swap(k, p);
            for i in k + 1..n {
                let f = a[i][k] / a[k][k];
                for j in k..n {
                    a[i][j] -= f * a[k][j];
                }
                b[i] -= f * b[k];
            }
        }
        let mut x = vec![0.0; n];
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
            x[i] = (b[i] - s) / a[i][i];
        }
        x
    }

    /// `true` when a Cholesky factorisation exists: the matrix is symmetric positive definite.
    pub fn is_positive_definite(a: &[Vec<f64>]) -> bool {
        let n = a.len();
        let mut l = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..=i {
                let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
                if i == j {
                    let d = a[i][i] - s;
                    if d <= 0.0 {
                        return false;
                    }
                    l[i][j] = d.sqrt();
                } else {
                    l[i][j] = (a[i][j] - s) / l[j][j];
                }
            }
        }
        true
    }
}
