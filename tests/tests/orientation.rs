//! Orientation outputs (`frames:`) of the shipped spatial models, at random states (a model's
//! measured joints, such as the PHANToM Premium-like arm's gimbal, at random angles and rates
//! within their limits too: their angles turn the frames, and `J_ω` has a column for each):
//! - `R` orthonormal with determinant +1;
//! - `Ṙ Rᵀ = [J_ω q̇]×`, with `Ṙ` the central finite difference of `R(q + t q̇)`;
//! - the compiled `<frame>_orientation` and `<frame>_angular_jacobian` equal to the evaluator
//!   (f64 to 1e-12, f32 to 1e-5).
//!
//! Pinocchio checks the same quantities independently (`scripts/pinocchio-check.sh`).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::build;
use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate_frame, EvaluatedFrame, State};
use hapticgen_codegen::model::Model;
use hapticgen_tests::check::{random_state, STATES};
use hapticgen_tests::workspace_root;
use rand::rngs::SmallRng;
use rand::SeedableRng;

/// Each shipped model and variant that declares frames.
fn with_frames() -> Vec<(String, Option<String>, Model, Mechanics)> {
    let mut out = Vec::new();
    for entry in build::models_in(&workspace_root().join("models"), "models").unwrap() {
        for v in entry.variants {
            let m = hapticgen_codegen::load_file(&entry.path, &entry.display, v.as_deref()).unwrap();
            if m.frames.is_empty() {
                continue;
            }
            let mech = hapticgen_codegen::derive(&m);
            assert_eq!(mech.frames.len(), m.frames.len());
            out.push((entry.display.clone(), v, m.model, mech));
        }
    }
    out
}

fn frame_at(mech: &Mechanics, params: &[f64], index: usize, q: &[f64], qd: &[f64]) -> EvaluatedFrame {
    evaluate_frame(mech, &State { q, qd, parameters: params }, &mech.frames[index])
}

/// A random state of the actuated joints followed by the measured ones (angles within their
/// limits): the coordinates a frame is a function of.
fn random_frame_state(model: &Model, rng: &mut SmallRng) -> (Vec<f64>, Vec<f64>) {
    use rand::Rng;
    let (mut q, mut qd) = random_state(model, rng);
    for joint in &model.measured {
        q.push(rng.gen_range(joint.lower..joint.upper));
        qd.push(rng.gen_range(-2.0..2.0));
    }
    (q, qd)
}

#[test]
fn the_premium_s_stylus_turns_with_its_measured_gimbal() {
    let frames = with_frames();
    let (_, _, model, _) =
        frames.iter().find(|(file, ..)| file == "models/phantom_premium.yaml").expect("the Premium");
    let names: Vec<&str> = model.measured.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["gimbal_roll", "gimbal_pitch", "stylus_spin"]);
    assert!(model.frames.iter().any(|f| f.name == "stylus"));
}

#[test]
fn the_phantom_and_the_puma_declare_frames() {
    let names: Vec<String> =
        with_frames().iter().flat_map(|(_, _, m, _)| m.frames.iter().map(|f| f.name.clone())).collect();
    assert!(names.contains(&"gimbal_mount".to_string()), "{names:?}");
    assert!(names.contains(&"flange".to_string()), "{names:?}");
}

#[test]
fn rotations_are_orthonormal_and_proper() {
    for (file, variant, model, mech) in with_frames() {
        let params = model.nominal_parameters();
        let mut rng = SmallRng::seed_from_u64(19);
        for _ in 0..STATES {
            let (q, qd) = random_frame_state(&model, &mut rng);
            for (f, frame) in model.frames.iter().enumerate() {
                let r = frame_at(&mech, &params, f, &q, &qd).rotation;
                for i in 0..3 {
                    for j in 0..3 {
                        let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                        let want = if i == j { 1.0 } else { 0.0 };
                        assert!(
                            (dot - want).abs() < 1e-12,
                            "{file} {variant:?} {}: (RᵀR)[{i}][{j}] = {dot} at {q:?}",
                            frame.name
                        );
                    }
                }
                let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
                    - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
                    + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
                assert!((det - 1.0).abs() < 1e-12, "{file} {variant:?} {}: det R = {det}", frame.name);
            }
        }
    }
}

#[test]
fn angular_jacobian_matches_finite_differences_of_the_rotation() {
    let h = 1e-6;
    for (file, variant, model, mech) in with_frames() {
        let params = model.nominal_parameters();
        let n = model.joints.len() + model.measured.len();
        let mut rng = SmallRng::seed_from_u64(23);
        for _ in 0..STATES {
            let (q, qd) = random_frame_state(&model, &mut rng);
            let along = |f: usize, t: f64| {
                let qq: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + t * b).collect();
                frame_at(&mech, &params, f, &qq, &qd).rotation
            };
            for (f, frame) in model.frames.iter().enumerate() {
                let e = frame_at(&mech, &params, f, &q, &qd);
                let (plus, minus) = (along(f, h), along(f, -h));
                // W = Ṙ Rᵀ, which must be [ω]× with ω = J_ω q̇.
                let w: Vec<Vec<f64>> = (0..3)
                    .map(|i| {
                        (0..3)
                            .map(|j| {
                                (0..3)
                                    .map(|k| (plus[i][k] - minus[i][k]) / (2.0 * h) * e.rotation[j][k])
                                    .sum()
                            })
                            .collect()
                    })
                    .collect();
                let omega: Vec<f64> =
                    (0..3).map(|i| (0..n).map(|k| e.angular_jacobian[i][k] * qd[k]).sum()).collect();
                let skew =
                    [[0.0, -omega[2], omega[1]], [omega[2], 0.0, -omega[0]], [-omega[1], omega[0], 0.0]];
                for i in 0..3 {
                    for j in 0..3 {
                        assert!(
                            (w[i][j] - skew[i][j]).abs() < 1e-7,
                            "{file} {variant:?} {}: (Ṙ Rᵀ)[{i}][{j}] = {}, [J_ω q̇]× = {} at {q:?}",
                            frame.name,
                            w[i][j],
                            skew[i][j]
                        );
                    }
                }
            }
        }
    }
}

/// Compares a compiled frame's outputs with the evaluator at random states: `N` actuated
/// joints, `K` measured ones, `C = N + K` columns of `J_ω`.
fn compare<const N: usize, const K: usize, const C: usize, S: Copy + Into<f64>>(
    file: &str,
    frame: &str,
    tolerance: f64,
    from: fn(f64) -> S,
    orientation: impl Fn(&[S; N], &[S; K]) -> [[S; 3]; 3],
    angular_jacobian: impl Fn(&[S; N], &[S; K]) -> [[S; C]; 3],
) {
    assert_eq!(C, N + K);
    let path = workspace_root().join(file);
    let m = hapticgen_codegen::load_file(&path, file, None).unwrap();
    let mech = hapticgen_codegen::derive(&m);
    let index = m.frames.iter().position(|f| f.name == frame).expect("the frame is declared");
    let params = m.nominal_parameters();
    let mut rng = SmallRng::seed_from_u64(29);
    for _ in 0..STATES {
        let (q, qd) = random_frame_state(&m, &mut rng);
        assert_eq!(q.len(), C, "{file}: the model has {} coordinates for the frame", q.len());
        // Both sides at the same (rounded) state.
        let qs: [S; N] = std::array::from_fn(|i| from(q[i]));
        let measured: [S; K] = std::array::from_fn(|k| from(q[N + k]));
        let q: Vec<f64> = qs.iter().chain(&measured).map(|&x| x.into()).collect();
        let e = frame_at(&mech, &params, index, &q, &qd);
        let r = orientation(&qs, &measured);
        let jw = angular_jacobian(&qs, &measured);
        for i in 0..3 {
            for j in 0..3 {
                let got: f64 = r[i][j].into();
                assert!(
                    (got - e.rotation[i][j]).abs() < tolerance,
                    "{file} {frame}: R[{i}][{j}] = {got}, evaluator {}",
                    e.rotation[i][j]
                );
            }
            for k in 0..C {
                let got: f64 = jw[i][k].into();
                assert!(
                    (got - e.angular_jacobian[i][k]).abs() < tolerance,
                    "{file} {frame}: J_ω[{i}][{k}] = {got}, evaluator {}",
                    e.angular_jacobian[i][k]
                );
            }
        }
    }
}

#[test]
fn compiled_orientation_equals_the_evaluator() {
    use hapticgen_tests::{
        phantom_3dof_f32, phantom_3dof_f64, phantom_premium_f32, phantom_premium_f64, puma560_f32,
        puma560_f64,
    };
    let phantom = "models/phantom_3dof.yaml";
    let rig = phantom_3dof_f64::Phantom3dof::NOMINAL;
    compare::<3, 0, 3, _>(
        phantom,
        "gimbal_mount",
        1e-12,
        |x| x,
        |q, _| rig.gimbal_mount_orientation(q),
        |q, _| rig.gimbal_mount_angular_jacobian(q),
    );
    let rig = phantom_3dof_f32::Phantom3dof::NOMINAL;
    compare::<3, 0, 3, _>(
        phantom,
        "gimbal_mount",
        1e-5,
        |x| x as f32,
        |q, _| rig.gimbal_mount_orientation(q),
        |q, _| rig.gimbal_mount_angular_jacobian(q),
    );
    let puma = "models/puma560.yaml";
    let rig = puma560_f64::Puma560::NOMINAL;
    compare::<6, 0, 6, _>(
        puma,
        "flange",
        1e-12,
        |x| x,
        |q, _| rig.flange_orientation(q),
        |q, _| rig.flange_angular_jacobian(q),
    );
    let rig = puma560_f32::Puma560::NOMINAL;
    compare::<6, 0, 6, _>(
        puma,
        "flange",
        1e-5,
        |x| x as f32,
        |q, _| rig.flange_orientation(q),
        |q, _| rig.flange_angular_jacobian(q),
    );
    // The Premium's stylus turns with its three measured gimbal joints.
    let premium = "models/phantom_premium.yaml";
    let rig = phantom_premium_f64::PhantomPremium::NOMINAL;
    compare::<3, 3, 6, _>(
        premium,
        "stylus",
        1e-12,
        |x| x,
        |q, measured| rig.stylus_orientation(q, measured),
        |q, measured| rig.stylus_angular_jacobian(q, measured),
    );
    let rig = phantom_premium_f32::PhantomPremium::NOMINAL;
    compare::<3, 3, 6, _>(
        premium,
        "stylus",
        1e-5,
        |x| x as f32,
        |q, measured| rig.stylus_orientation(q, measured),
        |q, measured| rig.stylus_angular_jacobian(q, measured),
    );
}
