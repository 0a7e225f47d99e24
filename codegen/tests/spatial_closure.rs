//! Spatial closed chains: two Deltas, the Falcon-like one
//! (`models/falcon_delta.yaml`) and an omega-like one written as a file
//! only (`omega_delta.yaml`), each open tree reduced to the three thigh angles by the
//! generator's numerical elimination, checked against a separate formulation written here that
//! shares no code with the generator:
//!
//! - **Kinematics**: the platform centre by the closed-form intersection of three spheres
//!   (radius `b` about each knee moved inwards by the platform radius `s`), its Jacobian from
//!   the differentiated sphere equations `(P + s_k − K_k)·(Ṗ − K̇_k) = 0`;
//! - **Dynamics** from the kinetic and potential energies of the bodies: each thigh turns about
//!   its fixed axis (`m a²/3`, plus the reflected rotor `N² J_m`), each shin is a uniform slender
//!   rod with ends `A`, `B` (`T = m/6 (v_A² + v_A·v_B + v_B²)`), the platform a point mass; so
//!   `D = Σ` of exact Jacobian products, `g = ∂V/∂q` from the centres' heights, and `C q̇`,
//!   `J̇ q̇` by central differences of that `D` and `J`.
//!
//! and against the structure the mechanism must have: the loops' residual ≤ 1e-12 m, the
//! platform's orientation constant (Tsai's conditions) to 1e-12, `D` symmetric positive
//! definite, `J` equal to finite differences of `p`, at 60 random states over the box of the
//! thigh angles.

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use std::path::{Path, PathBuf};

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, Evaluated, Full, State};
use hapticgen_codegen::sym::dag::{Dag, NodeId};
use hapticgen_codegen::sym::poly::{Atom, AtomValues};
use hapticgen_codegen::CheckedModel;

mod support;
use support::TreePositions;

/// A Delta's data, copied from its model file's sources (not read from it).
struct Device {
    file: &'static str,
    base_radius: f64,
    thigh: f64,
    shin: f64,
    platform_radius: f64,
    thigh_mass: f64,
    shin_mass: f64,
    platform_mass: f64,
    /// `N² J_m`.
    reflected_rotor: f64,
}

/// The published Falcon-class dimensions `models/falcon_delta.yaml` cites.
const FALCON: Device = Device {
    file: "models/falcon_delta.yaml",
    base_radius: 0.037233758,
    thigh: 0.060,
    shin: 0.1025,
    platform_radius: 0.027330909,
    thigh_mass: 0.020,
    shin_mass: 0.010,
    platform_mass: 0.060,
    reflected_rotor: 7.72 * 7.72 * 1.7e-7,
};

/// The dimensions `omega_delta.yaml`'s header chooses.
const OMEGA: Device = Device {
    file: "codegen/tests/closed-chains/omega_delta.yaml",
    base_radius: 0.060,
    thigh: 0.100,
    shin: 0.160,
    platform_radius: 0.030,
    thigh_mass: 0.050,
    shin_mass: 0.030,
    platform_mass: 0.150,
    reflected_rotor: 10.0 * 10.0 * 1.0e-6,
};

const DEVICES: [&Device; 2] = [&FALCON, &OMEGA];
const GRAVITY: f64 = 9.81;
const STATES: usize = 60;

type Vec3 = [f64; 3];
type Mat3 = [[f64; 3]; 3];

fn load(device: &Device) -> (CheckedModel, Mechanics) {
    let model = hapticgen_codegen::load_file(&repo_file(device.file), device.file, None)
        .unwrap_or_else(|e| panic!("{e}"));
    let mechanics = hapticgen_codegen::derive(&model);
    (model, mechanics)
}

fn repo_file(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// A small deterministic generator (xorshift), uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn states(model: &CheckedModel) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = Rng(0x5eed_de17a);
    (0..STATES)
        .map(|_| {
            let q = std::array::from_fn(|k| {
                let j = &model.joints[k];
                j.lower + (j.upper - j.lower) * rng.next()
            });
            let qd = std::array::from_fn(|_| 4.0 * rng.next() - 2.0);
            (q, qd)
        })
        .collect()
}

fn eval(mech: &Mechanics, q: &[f64; 3], qd: &[f64; 3]) -> Evaluated {
    evaluate(mech, &State { q, qd, parameters: &[] }, None)
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn scale(a: Vec3, k: f64) -> Vec3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Leg `k`'s radial and tangent directions.
fn leg_axes(k: usize) -> (Vec3, Vec3) {
    let angle = (k as f64) * 2.0 * std::f64::consts::PI / 3.0;
    ([angle.cos(), angle.sin(), 0.0], [-angle.sin(), angle.cos(), 0.0])
}

/// Knee `k` and its derivative with respect to its thigh angle.
fn knee(device: &Device, k: usize, theta: f64) -> (Vec3, Vec3) {
    let (radial, _) = leg_axes(k);
    let (thigh, base_radius) = (device.thigh, device.base_radius);
    let position = add(scale(radial, base_radius + thigh * theta.cos()), [0.0, 0.0, -thigh * theta.sin()]);
    let derivative = add(scale(radial, -thigh * theta.sin()), [0.0, 0.0, -thigh * theta.cos()]);
    (position, derivative)
}

/// The Delta's kinematics, independently: the platform centre `P` (three spheres of radius
/// `b` about `K_k − s e_k`, the solution below the base), its Jacobian and the knees' rates.
struct Delta {
    platform: Vec3,
    /// `∂P/∂θ`, column `k` for thigh `k`.
    platform_jacobian: Mat3,
    /// `∂K_k/∂θ_k`.
    knee_rates: [Vec3; 3],
}

fn solve3(m: Mat3, v: Vec3) -> Vec3 {
    let det = dot(m[0], cross(m[1], m[2]));
    // Cramer's rule with the rows of m: x = (v0 (r1×r2) + v1 (r2×r0) + v2 (r0×r1)) / det.
    let x = add(
        add(scale(cross(m[1], m[2]), v[0]), scale(cross(m[2], m[0]), v[1])),
        scale(cross(m[0], m[1]), v[2]),
    );
    scale(x, 1.0 / det)
}

fn delta(device: &Device, theta: &[f64; 3]) -> Delta {
    let knees_and_rates: [(Vec3, Vec3); 3] = std::array::from_fn(|k| knee(device, k, theta[k]));
    let centres: [Vec3; 3] =
        std::array::from_fn(|k| sub(knees_and_rates[k].0, scale(leg_axes(k).0, device.platform_radius)));
    // Three spheres |P − c_k| = b: subtracting pairs gives two planes; P = base + t n on their
    // line, and the first sphere gives t (the lower root: the platform below the base).
    let [c0, c1, c2] = centres;
    let plane = |a: Vec3, b: Vec3| (scale(sub(b, a), 2.0), dot(b, b) - dot(a, a));
    let (n1, d1) = plane(c0, c1);
    let (n2, d2) = plane(c0, c2);
    let direction = cross(n1, n2);
    // A point on both planes: with direction d = n1 × n2, x0 = (d1 (n2 × d) + d2 (d × n1)) / |d|².
    let on_line = scale(
        add(scale(cross(n2, direction), d1), scale(cross(direction, n1), d2)),
        1.0 / dot(direction, direction),
    );
    let unit = scale(direction, 1.0 / dot(direction, direction).sqrt());
    let from = sub(on_line, c0);
    let (half_b, c) = (dot(from, unit), dot(from, from) - device.shin * device.shin);
    let root = (half_b * half_b - c).sqrt();
    let candidates = [add(on_line, scale(unit, -half_b + root)), add(on_line, scale(unit, -half_b - root))];
    let platform = if candidates[0][2] < candidates[1][2] { candidates[0] } else { candidates[1] };
    // (P − c_k)·(Ṗ − K̇_k) = 0 for each leg: U Ṗ = diag(u_k · K̇_k).
    let rows: Mat3 = std::array::from_fn(|k| sub(platform, centres[k]));
    let mut platform_jacobian = [[0.0; 3]; 3];
    for k in 0..3 {
        let mut right = [0.0; 3];
        right[k] = dot(rows[k], knees_and_rates[k].1);
        let column = solve3(rows, right);
        for i in 0..3 {
            platform_jacobian[i][k] = column[i];
        }
    }
    Delta { platform, platform_jacobian, knee_rates: std::array::from_fn(|k| knees_and_rates[k].1) }
}

/// `D`, `g` of the independent formulation (see the module docs).
fn independent_dynamics(device: &Device, theta: &[f64; 3]) -> (Mat3, Vec3) {
    let d = delta(device, theta);
    let (thigh, thigh_mass, shin_mass) = (device.thigh, device.thigh_mass, device.shin_mass);
    let mut inertia = [[0.0; 3]; 3];
    let mut gravity = [0.0; 3];
    // Jacobians (3 × 3, column per thigh) of the knee and of the platform joint of leg k.
    let knee_jacobian = |k: usize| -> Mat3 {
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            m[i][k] = d.knee_rates[k][i];
        }
        m
    };
    let add_product = |inertia: &mut Mat3, a: &Mat3, b: &Mat3, weight: f64| {
        for i in 0..3 {
            for j in 0..3 {
                inertia[i][j] += weight * (0..3).map(|r| a[r][i] * b[r][j]).sum::<f64>();
            }
        }
    };
    for k in 0..3 {
        // Thigh about its fixed axis, and the rotor.
        inertia[k][k] += thigh_mass * thigh * thigh / 3.0 + device.reflected_rotor;
        gravity[k] += thigh_mass * GRAVITY * (-0.5 * thigh * theta[k].cos());
        // Shin: a slender rod from the knee to the platform joint (which moves with P).
        let (a, b) = (knee_jacobian(k), d.platform_jacobian);
        add_product(&mut inertia, &a, &a, shin_mass / 3.0);
        add_product(&mut inertia, &b, &b, shin_mass / 3.0);
        add_product(&mut inertia, &a, &b, shin_mass / 6.0);
        add_product(&mut inertia, &b, &a, shin_mass / 6.0);
        // V = m g (z_A + z_B)/2.
        for j in 0..3 {
            gravity[j] += shin_mass * GRAVITY * 0.5 * (a[2][j] + b[2][j]);
        }
    }
    let p = d.platform_jacobian;
    add_product(&mut inertia, &p, &p, device.platform_mass);
    for j in 0..3 {
        gravity[j] += device.platform_mass * GRAVITY * p[2][j];
    }
    (inertia, gravity)
}

fn assert_close(what: &str, got: f64, expected: f64, tolerance: f64) {
    assert!(
        (got - expected).abs() <= tolerance,
        "{what}: {got:.15e} vs {expected:.15e} (difference {:.3e} > {tolerance:.1e})",
        (got - expected).abs()
    );
}

#[test]
fn the_platform_is_where_three_spheres_meet_and_j_is_their_derivative() {
    DEVICES
        .iter()
        .for_each(|device| the_platform_is_where_three_spheres_meet_and_j_is_their_derivative_of(device));
}

fn the_platform_is_where_three_spheres_meet_and_j_is_their_derivative_of(device: &Device) {
    let (model, mech) = load(device);
    for (q, qd) in states(&model) {
        let e = eval(&mech, &q, &qd);
        let d = delta(device, &q);
        for i in 0..3 {
            assert_close(&format!("p[{i}] at {q:?}"), e.p[i], d.platform[i], 1e-12);
            for j in 0..3 {
                assert_close(
                    &format!("J[{i}][{j}] at {q:?}"),
                    e.jacobian[i][j],
                    d.platform_jacobian[i][j],
                    1e-11,
                );
            }
        }
    }
}

#[test]
fn the_reduced_dynamics_equal_the_energies_of_the_bodies() {
    DEVICES.iter().for_each(|device| the_reduced_dynamics_equal_the_energies_of_the_bodies_of(device));
}

fn the_reduced_dynamics_equal_the_energies_of_the_bodies_of(device: &Device) {
    let (model, mech) = load(device);
    let h = 1e-5;
    for (q, qd) in states(&model) {
        let e = eval(&mech, &q, &qd);
        let (inertia, gravity) = independent_dynamics(device, &q);
        let scale = inertia.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
        for i in 0..3 {
            for j in 0..3 {
                assert_close(
                    &format!("D[{i}][{j}] at {q:?}"),
                    e.inertia_matrix[i][j],
                    inertia[i][j],
                    1e-9 * scale,
                );
            }
            assert_close(
                &format!("g[{i}] at {q:?}"),
                e.g[i],
                gravity[i],
                1e-9 * gravity.iter().map(|g| g.abs()).fold(0.0, f64::max),
            );
        }
        // C q̇ = Ḋ q̇ − ½ ∂(q̇ᵀ D q̇)/∂q, and J̇ q̇, by central differences of the exact D and J.
        let along = |k: Option<usize>, step: f64| -> [f64; 3] {
            std::array::from_fn(|i| q[i] + step * k.map_or(qd[i], |k| if k == i { 1.0 } else { 0.0 }))
        };
        let d_dot: Mat3 = {
            let (plus, minus) = (
                independent_dynamics(device, &along(None, h)).0,
                independent_dynamics(device, &along(None, -h)).0,
            );
            std::array::from_fn(|i| std::array::from_fn(|j| (plus[i][j] - minus[i][j]) / (2.0 * h)))
        };
        let quadratic =
            |m: &Mat3| (0..3).map(|i| (0..3).map(|j| qd[i] * m[i][j] * qd[j]).sum::<f64>()).sum::<f64>();
        let coriolis: Vec3 = std::array::from_fn(|k| {
            let (plus, minus) = (
                independent_dynamics(device, &along(Some(k), h)).0,
                independent_dynamics(device, &along(Some(k), -h)).0,
            );
            (0..3).map(|j| d_dot[k][j] * qd[j]).sum::<f64>()
                - 0.5 * (quadratic(&plus) - quadratic(&minus)) / (2.0 * h)
        });
        let (plus, minus) = (
            delta(device, &along(None, h)).platform_jacobian,
            delta(device, &along(None, -h)).platform_jacobian,
        );
        let bias: Vec3 =
            std::array::from_fn(|i| (0..3).map(|j| (plus[i][j] - minus[i][j]) / (2.0 * h) * qd[j]).sum());
        let speed = qd.iter().map(|v| v * v).sum::<f64>();
        for i in 0..3 {
            assert_close(
                &format!("(C q̇)[{i}] at {q:?}"),
                e.coriolis_times_qdot[i],
                coriolis[i],
                1e-9 * scale * speed,
            );
            assert_close(
                &format!("(J̇ q̇)[{i}] at {q:?}"),
                e.jacobian_dot_times_qdot[i],
                bias[i],
                1e-8 * speed,
            );
        }
    }
}

/// The generator's own structure: residual, orientation, `D` SPD, `J` against `p`.
#[test]
fn the_loops_close_the_platform_translates_and_d_is_positive_definite() {
    DEVICES
        .iter()
        .for_each(|device| the_loops_close_the_platform_translates_and_d_is_positive_definite_of(device));
}

fn the_loops_close_the_platform_translates_and_d_is_positive_definite_of(device: &Device) {
    let (model, mech) = load(device);
    let closures = mech.closures.as_ref().expect("a closed chain");
    let spatial = closures.spatial.as_ref().expect("spatial loops");
    for (q, qd) in states(&model) {
        let values = closures.values(&q, &qd, &[]);
        let angle = |k: usize| {
            values
                .iter()
                .find(|(a, _)| *a == Atom::Q((3 + k) as u16))
                .map(|&(_, v)| v)
                .expect("passive angle")
        };
        let passive: Vec<f64> = (0..spatial.passive).map(angle).collect();
        // The residual of every loop equation at the solution.
        let tree: Vec<f64> = q.iter().chain(&passive).copied().collect();
        for (name, r) in spatial.equation_names.iter().zip(&spatial.residual) {
            let value = r.eval(&TreePositions(&tree));
            assert!(value.abs() <= 1e-12, "{name} at {q:?}: {value:e}");
        }
        // The platform's orientation, composed here from the joint angles along leg 1:
        // thigh (about y), knee swing (y), knee twist (z), platform swing (z), platform twist (y).
        let about = |axis: usize, angle: f64| -> Mat3 {
            let (s, c) = angle.sin_cos();
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut m = [[0.0; 3]; 3];
            m[axis][axis] = 1.0;
            m[i][i] = c;
            m[j][j] = c;
            m[i][j] = -s;
            m[j][i] = s;
            m
        };
        let mul = |a: Mat3, b: Mat3| -> Mat3 {
            std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
        };
        let names = ["knee1_swing", "knee1_twist", "platform_swing", "platform_twist"];
        let index = |name: &str| {
            (0..spatial.passive).find(|&k| model.coordinate_name(3 + k) == name).expect("joint of the model")
        };
        let [swing, twist, platform_swing, platform_twist] = names.map(|n| passive[index(n)]);
        let rotation = [
            about(1, q[0]),
            about(1, swing),
            about(2, twist),
            about(2, platform_swing),
            about(1, platform_twist),
        ]
        .into_iter()
        .fold([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], mul);
        for i in 0..3 {
            for j in 0..3 {
                let identity = if i == j { 1.0 } else { 0.0 };
                assert_close(&format!("platform R[{i}][{j}] at {q:?}"), rotation[i][j], identity, 1e-12);
            }
        }
        // D symmetric positive definite (Sylvester's criterion), J against central differences of p.
        let e = eval(&mech, &q, &qd);
        let d = &e.inertia_matrix;
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(d[i][j], d[j][i], "D symmetric at {q:?}");
            }
        }
        let minor2 = d[0][0] * d[1][1] - d[0][1] * d[1][0];
        let det = d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
            - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0])
            + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
        assert!(d[0][0] > 0.0 && minor2 > 0.0 && det > 0.0, "D not positive definite at {q:?}: {d:?}");
        let h = 1e-6;
        for j in 0..3 {
            let mut plus = q;
            let mut minus = q;
            plus[j] += h;
            minus[j] -= h;
            let (pp, pm) = (eval(&mech, &plus, &qd).p, eval(&mech, &minus, &qd).p);
            for i in 0..3 {
                assert_close(
                    &format!("J[{i}][{j}] vs differences at {q:?}"),
                    e.jacobian[i][j],
                    (pp[i] - pm[i]) / (2.0 * h),
                    1e-8,
                );
            }
        }
    }
}

/// The closed form's loop margins (what the emitted `closure_margin` returns, and the safety
/// monitor's `loop_margin` the least of) are the mechanism's squared sines, from the separate
/// kinematics: `det²[u₁ u₂ u₃] / b⁶` with `u_k` the shins from knee to platform joint (0 where
/// the shins are parallel to one plane, the Delta's parallel singularity) and, per knee,
/// `1 − (t_k·u_k)² / b²` (the shin against the knee's swing axis, the thigh's tangent); and
/// over the workspace they stay far above the safety monitor's 10⁻³. (To 10⁻⁹: the model files
/// give the legs' 120° placements to twelve digits, the separate kinematics exactly.)
#[test]
fn the_closed_forms_margins_are_the_mechanisms_squared_sines() {
    for device in &DEVICES {
        let (model, _) = load(device);
        let closures = model.analyses.closures.as_ref().expect("closures");
        let mut dag = Dag::new();
        let margins = hapticgen_codegen::dynamics::closure::install(&mut dag, Some(closures)).margins;
        assert_eq!(margins.len(), 4, "{}", device.file);
        let shin_squared = device.shin * device.shin;
        let mut least = f64::INFINITY;
        for (q, _) in states(&model) {
            let values = dag.eval_all(&|atom| State { q: &q, qd: &[], parameters: &[] }.value(atom));
            let platform = delta(device, &q).platform;
            let shins: [Vec3; 3] = std::array::from_fn(|k| {
                let joint = add(platform, scale(leg_axes(k).0, device.platform_radius));
                sub(joint, knee(device, k, q[k]).0)
            });
            let parallel = dot(shins[0], cross(shins[1], shins[2])).powi(2) / shin_squared.powi(3);
            assert_close(
                &format!("{} parallel margin at {q:?}", device.file),
                values[margins[0]],
                parallel,
                1e-9,
            );
            least = least.min(parallel);
            for (k, shin) in shins.iter().enumerate() {
                let knee_margin = 1.0 - dot(leg_axes(k).1, *shin).powi(2) / shin_squared;
                let what = format!("{} knee {} margin at {q:?}", device.file, k + 1);
                assert_close(&what, values[margins[1 + k]], knee_margin, 1e-9);
                least = least.min(knee_margin);
            }
        }
        assert!(least > 1e-3, "{}: least margin {least}", device.file);
    }
}

#[test]
fn a_delta_solves_its_loops_in_closed_form_and_on_request_by_newton_at_run_time() {
    for device in &DEVICES {
        let (model, _) = load(device);
        let spatial =
            model.analyses.closures.as_ref().and_then(|c| c.spatial.as_ref()).expect("spatial loops");
        assert!(spatial.closed_form.is_some(), "{}: {:?}", device.file, spatial.newton_reason);
        let steps = spatial.newton_steps;
        let closed_form =
            hapticgen_codegen::generate_model(model.clone(), hapticgen_codegen::Scalar::F64).file_text();
        assert!(!closed_form.contains("close_loops"), "{}", device.file);
        assert!(!closed_form.contains("LoopConstraints"), "{}", device.file);
        assert!(closed_form.contains("::hapticgen_runtime::Real::sqrt("), "{}", device.file);
        let model = model.with_loops_solved_numerically();
        let text = hapticgen_codegen::generate_model(model, hapticgen_codegen::Scalar::F64).file_text();
        assert!(
            text.contains("impl ::hapticgen_runtime::loops::LoopConstraints<f64, 3, 8> for"),
            "{}",
            device.file
        );
        assert!(text.contains("let loops = ::hapticgen_runtime::loops::close_loops("), "{}", device.file);
        // The solver's bound: the most steps seen over the actuated ranges, plus two.
        assert!((1..=8).contains(&steps), "{}: {steps} steps", device.file);
        assert!(text.contains(&format!("max_steps: {},", steps + 2)), "{}", device.file);
    }
}

/// The reduced dynamics conserve energy: RK4 over 1 s with gravity held by a joint-space
/// spring `K (q − q₀)` about the middle of the thigh ranges (no damping, no input), relative
/// drift of `½ q̇ᵀ D q̇ + V + ½ K |q − q₀|²` ≤ 1e-8.
#[test]
fn the_reduced_dynamics_conserve_energy_with_gravity_held_by_a_spring() {
    DEVICES
        .iter()
        .for_each(|device| the_reduced_dynamics_conserve_energy_with_gravity_held_by_a_spring_of(device));
}

fn the_reduced_dynamics_conserve_energy_with_gravity_held_by_a_spring_of(device: &Device) {
    let (model, mech) = load(device);
    let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (model.joints[k].lower + model.joints[k].upper));
    // Ten times gravity's torque per radian: gravity moves the rest pose by about 0.1 rad, and
    // the thighs swing at about 5 Hz (D of a few 1e-4 kg·m² on the Falcon-like device).
    let gravity = independent_dynamics(device, &centre).1;
    let stiffness = 10.0 * gravity.iter().fold(0.0_f64, |m, g| m.max(g.abs()));
    let spring = |q: &[f64; 3]| -> f64 { (0..3).map(|k| 0.5 * stiffness * (q[k] - centre[k]).powi(2)).sum() };
    // Only D, C q̇ and g, from one expression DAG of their polynomials (shared subterms
    // evaluated once: term by term, 4,000 steps take half a minute in a debug build).
    let mut dag = Dag::new();
    let roots: Vec<NodeId> = mech
        .inertia_matrix
        .iter()
        .flatten()
        .chain(&mech.coriolis_times_qdot)
        .chain(&mech.gravity)
        .map(|p| dag.polynomial(p))
        .collect();
    let acceleration = |q: &[f64; 3], qd: &[f64; 3]| -> [f64; 3] {
        let state = State { q, qd, parameters: &[] };
        let at = Full::new(&mech, &state);
        let values = dag.eval_all(&|atom| at.value(atom));
        let value = |k: usize| values[roots[k]];
        let rhs: Vec3 =
            std::array::from_fn(|i| -value(9 + i) - value(12 + i) - stiffness * (q[i] - centre[i]));
        let d: Mat3 = std::array::from_fn(|i| std::array::from_fn(|j| value(3 * i + j)));
        solve3(d, rhs)
    };
    let energy = |q: &[f64; 3], qd: &[f64; 3]| -> f64 {
        let e = eval(&mech, q, qd);
        let kinetic: f64 =
            (0..3).map(|i| (0..3).map(|j| 0.5 * qd[i] * e.inertia_matrix[i][j] * qd[j]).sum::<f64>()).sum();
        kinetic + e.potential_energy + spring(q)
    };
    let (mut q, mut qd) = (centre, [1.0, -0.5, 0.3]);
    let e0 = energy(&q, &qd);
    let kinetic0 = e0 - energy(&q, &[0.0; 3]);
    let dt = 2.5e-4;
    let mut worst = 0.0_f64;
    let step = |x: &[f64; 3], v: &[f64; 3], k: f64| -> [f64; 3] { std::array::from_fn(|i| x[i] + k * v[i]) };
    for n in 1..=4000 {
        let k1q = qd;
        let k1v = acceleration(&q, &qd);
        let k2q = step(&qd, &k1v, dt / 2.0);
        let k2v = acceleration(&step(&q, &k1q, dt / 2.0), &k2q);
        let k3q = step(&qd, &k2v, dt / 2.0);
        let k3v = acceleration(&step(&q, &k2q, dt / 2.0), &k3q);
        let k4q = step(&qd, &k3v, dt);
        let k4v = acceleration(&step(&q, &k3q, dt), &k4q);
        q = std::array::from_fn(|i| q[i] + dt / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i]));
        qd = std::array::from_fn(|i| qd[i] + dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]));
        if n % 40 == 0 {
            // Relative to the motion's energy (the potential's zero is arbitrary).
            worst = worst.max((energy(&q, &qd) - e0).abs() / kinetic0);
        }
        for (k, joint) in model.joints.iter().enumerate() {
            assert!(q[k] > joint.lower && q[k] < joint.upper, "left the workspace at step {n}: {q:?}");
        }
    }
    eprintln!("{}: 1 s, relative energy drift {worst:e}", device.file);
    assert!(worst <= 1e-8, "relative energy drift {worst:e}");
}
