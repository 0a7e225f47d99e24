//! Eq. (6), (11) and (13) hold exactly with an exact plant and exact sensing: for random
//! states, the torque of each law is applied to eq. (1) with a random operator force, q̈ and
//! ẍ = J q̈ + J̇ q̇ (eq. (2)) are computed, and the target impedance is checked to 1e-9.
//!
//! Each law is given only the sensor it has: Controller 1 the operator force, the first variant
//! of Controller 2 a task acceleration (and no force: a zero reading), the others nothing. The
//! acceleration Controller 2 senses is the simulated plant's own: its torque depends on the
//! acceleration it senses, and the plant's acceleration on that torque, so the test probes the
//! plant (the law and eq. (1)) at N + 1 sensed accelerations, solves for the one the plant
//! then actually has, and checks eq. (6) there; and, at a random sensed acceleration `a`, that
//! the impedance error is exactly what eq. (9) leaves for a sensing error,
//! `M_d ẍ̃ + B_d ẋ̃ + K_d x̃ + f_l = (M_d − W⁻¹)(ẍ − a)`.

// Index loops mirror the equations component by component.
#![allow(clippy::needless_range_loop)]

use crate::common::{forward_dynamics, solve, Joystick, Parallelogram};
use hapticgen_runtime::control::{
    ControlOptions, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
    TaskSensing,
};
use hapticgen_runtime::RigModel;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

const STATES: usize = 200;
const TOLERANCE: f64 = 1e-9;

const LAWS: [ImpedanceLaw; 4] = [
    ImpedanceLaw::ForceFeedback,
    ImpedanceLaw::AccelerationFeedback,
    ImpedanceLaw::NaturalInertia,
    ImpedanceLaw::JacobianTranspose,
];

fn random_array<const K: usize>(rng: &mut SmallRng, low: f64, high: f64) -> [f64; K] {
    let mut out = [0.0; K];
    for value in out.iter_mut() {
        *value = rng.gen_range(low..high);
    }
    out
}

/// Runs every law at one state and returns the largest residual of its target equation.
fn residuals<R: RigModel<N, N, Scalar = f64>, const N: usize>(
    rig: &R,
    rng: &mut SmallRng,
    q: [f64; N],
) -> [f64; 4] {
    let qd = random_array::<N>(rng, -3.0, 3.0);
    let operator_force = random_array::<N>(rng, -5.0, 5.0);
    let parameters = ImpedanceParameters {
        stiffness: random_array::<N>(rng, 1.0, 2000.0),
        damping: random_array::<N>(rng, 0.01, 10.0),
        mass: random_array::<N>(rng, 0.01, 2.0),
    };
    let terms = rig.terms(&q, &qd);
    let mut reference = TaskReference {
        position: terms.position,
        velocity: random_array::<N>(rng, -0.5, 0.5),
        acceleration: random_array::<N>(rng, -2.0, 2.0),
    };
    for (target, offset) in reference.position.iter_mut().zip(random_array::<N>(rng, -0.02, 0.02)) {
        *target += offset;
    }
    let mut velocity = [0.0; N];
    for k in 0..N {
        for i in 0..N {
            velocity[k] += terms.jacobian[k][i] * qd[i];
        }
    }
    let mut position_error = [0.0; N];
    let mut velocity_error = [0.0; N];
    let mut restoring_plus_force = [0.0; N]; // B_d ẋ̃ + K_d x̃ + f_l
    for k in 0..N {
        position_error[k] = terms.position[k] - reference.position[k];
        velocity_error[k] = velocity[k] - reference.velocity[k];
        restoring_plus_force[k] = parameters.damping[k] * velocity_error[k]
            + parameters.stiffness[k] * position_error[k]
            + operator_force[k];
    }
    // The acceleration eq. (6) prescribes: ẍ* = ẍ_d − M_d⁻¹(B_d ẋ̃ + K_d x̃ + f_l).
    let mut target_accel = [0.0; N];
    for k in 0..N {
        target_accel[k] = reference.acceleration[k] - restoring_plus_force[k] / parameters.mass[k];
    }

    let mut worst = [0.0f64; 4];
    let mut sensing_error_worst = 0.0f64;
    for (slot, law) in worst.iter_mut().zip(LAWS) {
        let controller = ImpedanceController {
            law,
            parameters,
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: 1e-9,
                spring_lead_time: 0.0,
                friction_compensation_band: None,
            },
        };
        // The law's torque for what it senses, applied to the plant: q̈ from eq. (1) and the
        // task acceleration ẍ = J q̈ + J̇ q̇ of eq. (2).
        let plant = |sensed: &TaskSensing<f64, N>| -> ([f64; N], [f64; N]) {
            let output = controller.torque(rig, &terms, &qd, &reference, sensed);
            assert_eq!(output.status, ControlStatus::Ok, "{law:?}");
            let qdd = forward_dynamics(rig, &q, &qd, &output.torque, &operator_force);
            let mut accel = terms.jacobian_dot_times_qdot;
            for k in 0..N {
                for i in 0..N {
                    accel[k] += terms.jacobian[k][i] * qdd[i];
                }
            }
            (qdd, accel)
        };
        let (qdd, accel) = match law {
            // Exact force sensing, no accelerometer.
            ImpedanceLaw::ForceFeedback => plant(&TaskSensing { operator_force, acceleration: [0.0; N] }),
            // An accelerometer, no force sensor: the plant's own acceleration, the fixed point
            // of a ↦ ẍ(a), found from the plant alone (ẍ(a) is affine in the sensed a).
            ImpedanceLaw::AccelerationFeedback => {
                let sensing = |acceleration: [f64; N]| TaskSensing { operator_force: [0.0; N], acceleration };
                let (_, at_zero) = plant(&sensing([0.0; N]));
                let mut system = [[0.0; N]; N]; // I − ∂ẍ/∂a
                for j in 0..N {
                    let mut probe = [0.0; N];
                    probe[j] = 1.0;
                    let (_, response) = plant(&sensing(probe));
                    for i in 0..N {
                        system[i][j] = f64::from(u8::from(i == j)) - (response[i] - at_zero[i]);
                    }
                }
                let sensed = solve(system, at_zero);
                let (qdd, accel) = plant(&sensing(sensed));
                for k in 0..N {
                    let mismatch = (accel[k] - sensed[k]).abs();
                    assert!(mismatch < 1e-9 * sensed[k].abs().max(1.0), "sensed {sensed:?}, plant {accel:?}");
                }
                // A sensing error: at a random sensed acceleration a, eq. (6)'s residual is
                // (M_d − W⁻¹)(ẍ − a), with W⁻¹ v = J⁻ᵀ D J⁻¹ v.
                let wrong = random_array::<N>(rng, -5.0, 5.0);
                let (_, off) = plant(&sensing(wrong));
                let error: [f64; N] = core::array::from_fn(|k| off[k] - wrong[k]);
                let jacobian_transpose: [[f64; N]; N] =
                    core::array::from_fn(|i| core::array::from_fn(|k| terms.jacobian[k][i]));
                let d_j_inv_error: [f64; N] = {
                    let j_inv_error = solve(terms.jacobian, error);
                    core::array::from_fn(|i| {
                        (0..N).map(|j| terms.inertia_matrix[i][j] * j_inv_error[j]).sum()
                    })
                };
                let w_inv_error = solve(jacobian_transpose, d_j_inv_error);
                for k in 0..N {
                    let impedance_error =
                        parameters.mass[k] * (off[k] - reference.acceleration[k]) + restoring_plus_force[k];
                    let predicted = parameters.mass[k] * error[k] - w_inv_error[k];
                    let scale = predicted.abs().max(1.0);
                    sensing_error_worst =
                        sensing_error_worst.max((impedance_error - predicted).abs() / scale);
                }
                (qdd, accel)
            }
            // Neither sensor.
            ImpedanceLaw::NaturalInertia | ImpedanceLaw::JacobianTranspose => plant(&TaskSensing::default()),
        };
        let residual: [f64; N] = match law {
            // Eq. (6): M_d ẍ̃ + B_d ẋ̃ + K_d x̃ + f_l = 0.
            ImpedanceLaw::ForceFeedback | ImpedanceLaw::AccelerationFeedback => core::array::from_fn(|k| {
                parameters.mass[k] * (accel[k] - reference.acceleration[k]) + restoring_plus_force[k]
            }),
            // Eq. (11): W⁻¹ ẍ̃ + B_d ẋ̃ + K_d x̃ + f_l = 0, checked as ẍ̃ + W(…) = 0.
            ImpedanceLaw::NaturalInertia => {
                let jt: [f64; N] = core::array::from_fn(|i| {
                    (0..N).map(|k| terms.jacobian[k][i] * restoring_plus_force[k]).sum()
                });
                let d_inv_jt = solve(terms.inertia_matrix, jt);
                core::array::from_fn(|k| {
                    let w_term: f64 = (0..N).map(|i| terms.jacobian[k][i] * d_inv_jt[i]).sum();
                    accel[k] - reference.acceleration[k] + w_term
                })
            }
            // Eq. (13) times Jᵀ: D q̈ + Jᵀ(B_d ẋ̃ + K_d x̃ + f_l) = 0.
            ImpedanceLaw::JacobianTranspose => core::array::from_fn(|i| {
                (0..N).map(|j| terms.inertia_matrix[i][j] * qdd[j]).sum::<f64>()
                    + (0..N).map(|k| terms.jacobian[k][i] * restoring_plus_force[k]).sum::<f64>()
            }),
        };
        *slot = residual.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        if law == ImpedanceLaw::AccelerationFeedback {
            // The acceleration the plant settles at is the target ẍ*, and a sensing error
            // leaves exactly the predicted impedance error.
            for k in 0..N {
                *slot = slot.max((accel[k] - target_accel[k]).abs() * parameters.mass[k]);
            }
            *slot = slot.max(sensing_error_worst);
        }
    }
    worst
}

fn report(rig: &str, worst: [f64; 4]) {
    for (law, residual) in LAWS.iter().zip(worst) {
        println!("{rig}: {law:?} worst residual {residual:.3e} over {STATES} states");
        assert!(residual < TOLERANCE, "{rig} {law:?}: residual {residual}");
    }
}

#[test]
fn joystick_closed_loops_match_their_target_impedance() {
    let mut rng = SmallRng::seed_from_u64(1);
    let mut worst = [0.0f64; 4];
    for _ in 0..STATES {
        let q = [rng.gen_range(-1.2..1.2)];
        for (w, r) in worst.iter_mut().zip(residuals(&Joystick, &mut rng, q)) {
            *w = w.max(r);
        }
    }
    report("joystick", worst);
}

#[test]
fn parallelogram_closed_loops_match_their_target_impedance() {
    let mut rng = SmallRng::seed_from_u64(2);
    let mut worst = [0.0f64; 4];
    let mut states = 0;
    while states < STATES {
        let q: [f64; 2] = [rng.gen_range(0.0..3.1), rng.gen_range(-3.1..0.5)];
        if (q[0] - q[1]).sin().abs() < 0.2 {
            continue; // keep away from the singular boundary for the J⁻¹ laws
        }
        states += 1;
        for (w, r) in worst.iter_mut().zip(residuals(&Parallelogram, &mut rng, q)) {
            *w = w.max(r);
        }
    }
    report("parallelogram", worst);
}

#[test]
fn omitting_damping_compensation_removes_exactly_b_qdot() {
    let rig = Parallelogram;
    let (q, qd) = ([1.0, -0.5], [0.7, -1.3]);
    let terms = rig.terms(&q, &qd);
    let mut controller = ImpedanceController {
        law: ImpedanceLaw::JacobianTranspose,
        parameters: ImpedanceParameters { stiffness: [1500.0; 2], damping: [5.0; 2], mass: [0.1; 2] },
        options: ControlOptions {
            omit_damping_compensation: false,
            min_abs_jacobian_determinant: 1e-6,
            spring_lead_time: 0.0,
            friction_compensation_band: None,
        },
    };
    let reference = TaskReference::at_rest([0.1, 0.1]);
    let with = controller.torque(&rig, &terms, &qd, &reference, &TaskSensing::default());
    controller.options.omit_damping_compensation = true;
    let without = controller.torque(&rig, &terms, &qd, &reference, &TaskSensing::default());
    for i in 0..2 {
        assert!((with.torque[i] - without.torque[i] - rig.damping()[i] * qd[i]).abs() < 1e-12);
    }
}

/// RobCoGen-style consistency of the hand-derived rig: J and J̇q̇ against finite
/// differences of p(q), C q̇ against the Coriolis matrix, D symmetric.
#[test]
fn parallelogram_terms_are_mutually_consistent() {
    let rig = Parallelogram;
    let mut rng = SmallRng::seed_from_u64(3);
    for _ in 0..50 {
        let q = random_array::<2>(&mut rng, -3.0, 3.0);
        let qd = random_array::<2>(&mut rng, -2.0, 2.0);
        let h = 1e-6;
        let j = rig.jacobian(&q);
        for i in 0..2 {
            let mut plus = q;
            let mut minus = q;
            plus[i] += h;
            minus[i] -= h;
            let (pp, pm) = (rig.position(&plus), rig.position(&minus));
            for k in 0..2 {
                assert!(((pp[k] - pm[k]) / (2.0 * h) - j[k][i]).abs() < 1e-8);
            }
        }
        // d/dt (J q̇) along q̇ at constant q̇ = J̇ q̇.
        let plus = [q[0] + h * qd[0], q[1] + h * qd[1]];
        let minus = [q[0] - h * qd[0], q[1] - h * qd[1]];
        let (jp, jm) = (rig.jacobian(&plus), rig.jacobian(&minus));
        let jdqd = rig.jacobian_dot_times_qdot(&q, &qd);
        let jdot = rig.jacobian_dot(&q, &qd);
        for k in 0..2 {
            let fd: f64 = (0..2).map(|i| (jp[k][i] - jm[k][i]) / (2.0 * h) * qd[i]).sum();
            assert!((fd - jdqd[k]).abs() < 1e-7);
            let direct: f64 = (0..2).map(|i| jdot[k][i] * qd[i]).sum();
            assert!((direct - jdqd[k]).abs() < 1e-14);
        }
        let c = rig.coriolis_matrix(&q, &qd);
        let cqd = rig.coriolis_times_qdot(&q, &qd);
        for i in 0..2 {
            assert!((c[i][0] * qd[0] + c[i][1] * qd[1] - cqd[i]).abs() < 1e-14);
        }
        let d = rig.inertia_matrix(&q);
        assert_eq!(d[0][1], d[1][0]);
        assert!(d[0][0] > 0.0 && d[0][0] * d[1][1] - d[0][1] * d[1][0] > 0.0);
        // Ḋ − 2C is skew-symmetric (passivity), a check on the Christoffel symbols.
        let (dp, dm) = (rig.inertia_matrix(&plus), rig.inertia_matrix(&minus));
        let n = |a: usize, b: usize| (dp[a][b] - dm[a][b]) / (2.0 * h) - 2.0 * c[a][b];
        assert!((n(0, 1) + n(1, 0)).abs() < 1e-8);
        assert!(n(0, 0).abs() < 1e-8 && n(1, 1).abs() < 1e-8);
    }
}
