//! Spatial direct poses: the PHANToM Premium-like arm (`models/phantom_premium.yaml`), whose
//! parallelogram's links are absolute angles in the turning turret's plane, against the closed
//! form a published model of the Premium 1.5 gives (the data `models/phantom_premium.yaml` cites):
//! `x = cos θ1 (l1 cos θ2 + l2 sin θ3)`, `y = sin θ1 (…)`, `z = l1 sin θ2 − l2 cos θ3`, and the
//! parallelogram's fourth corner `l3` behind the elbow along the forearm; and its stylus's
//! orientation, turned by the three measured gimbal joints, against the forearm's direction
//! and the shoulder axis composed with the gimbal's rotations by hand. Its dynamics are
//! checked against Pinocchio (`scripts/pinocchio-check.sh`, on a hand-written open tree) and by
//! `tests/tests/numerical.rs` (finite differences of `J`, energy), as for every shipped model.

use std::path::Path;

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, evaluate_frame, State};

const L1: f64 = 0.20955;
const L2: f64 = 0.169545;
const L3: f64 = 0.03175;

/// The shipped model's mechanics.
fn premium() -> Mechanics {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/phantom_premium.yaml");
    let model = hapticgen_codegen::load_file(&path, "models/phantom_premium.yaml", None)
        .unwrap_or_else(|d| panic!("{d}"));
    hapticgen_codegen::derive(&model)
}

#[test]
fn the_premium_follows_the_published_closed_form() {
    let mechanics = premium();
    let point = |name: &str| mechanics.points.iter().find(|p| p.name == name).expect("the point exists");
    let (tip, rear_hinge) = (point("gimbal_centre"), point("rear_hinge"));
    // A grid over the joint limits (θ1 ∈ [−1, 1], θ2, θ3 ∈ [−0.35, 0.6]), 125 states.
    let steps = |lower: f64, upper: f64| (0..5).map(move |k| lower + (upper - lower) * f64::from(k) / 4.0);
    let mut states = 0;
    for t1 in steps(-1.0, 1.0) {
        for t2 in steps(-0.35, 0.6) {
            for t3 in steps(-0.35, 0.6) {
                let q = [t1, t2, t3];
                let state = State { q: &q, qd: &[0.0; 3], parameters: &[] };
                let reach = L1 * t2.cos() + L2 * t3.sin();
                let expected_tip = [t1.cos() * reach, t1.sin() * reach, L1 * t2.sin() - L2 * t3.cos()];
                let behind = L1 * t2.cos() - L3 * t3.sin();
                let expected_rear = [t1.cos() * behind, t1.sin() * behind, L1 * t2.sin() + L3 * t3.cos()];
                for (point, expected) in [(tip, expected_tip), (rear_hinge, expected_rear)] {
                    let got = evaluate(&mechanics, &state, Some(point)).p;
                    for axis in 0..3 {
                        assert!(
                            (got[axis] - expected[axis]).abs() < 1e-14,
                            "{} at q = {q:?}: axis {axis} is {}, the closed form gives {}",
                            point.name,
                            got[axis],
                            expected[axis]
                        );
                    }
                }
                states += 1;
            }
        }
    }
    assert_eq!(states, 125);
}

fn rotation_x(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

fn rotation_z(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

fn product(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

#[test]
fn the_premium_s_stylus_turns_on_the_forearm_by_its_gimbal() {
    let mechanics = premium();
    let stylus = mechanics.frames.iter().find(|f| f.name == "stylus").expect("the stylus frame");
    let mut states = 0;
    for (t1, t2, t3) in [(0.0_f64, 0.0_f64, 0.0_f64), (0.3, 0.2, 0.4), (-0.9, -0.3, 0.55), (0.7, 0.5, -0.2)] {
        for (roll, pitch, spin) in
            [(0.0_f64, 0.0_f64, 0.0_f64), (0.1, 0.2, 0.3), (-2.0, 1.1, -2.9), (1.5, -0.7, 0.4)]
        {
            // With the gimbal at zero the stylus's x axis points along the forearm, towards its
            // tip, and its z axis along the shoulder axis, the turret's −y.
            let along_forearm = [t1.cos() * t3.sin(), t1.sin() * t3.sin(), -t3.cos()];
            let shoulder_axis = [t1.sin(), -t1.cos(), 0.0];
            let third = [
                shoulder_axis[1] * along_forearm[2] - shoulder_axis[2] * along_forearm[1],
                shoulder_axis[2] * along_forearm[0] - shoulder_axis[0] * along_forearm[2],
                shoulder_axis[0] * along_forearm[1] - shoulder_axis[1] * along_forearm[0],
            ];
            let mount: [[f64; 3]; 3] =
                std::array::from_fn(|i| [along_forearm[i], third[i], shoulder_axis[i]]);
            // Roll about x, pitch about the turned z, spin about the turned x.
            let expected =
                product(product(product(mount, rotation_x(roll)), rotation_z(pitch)), rotation_x(spin));
            let q = [t1, t2, t3, roll, pitch, spin];
            let got =
                evaluate_frame(&mechanics, &State { q: &q, qd: &[0.0; 6], parameters: &[] }, stylus).rotation;
            for i in 0..3 {
                for j in 0..3 {
                    assert!(
                        (got[i][j] - expected[i][j]).abs() < 1e-14,
                        "R[{i}][{j}] at q = {q:?}: {}, by hand {}",
                        got[i][j],
                        expected[i][j]
                    );
                }
            }
            states += 1;
        }
    }
    assert_eq!(states, 16);
}
