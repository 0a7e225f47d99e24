//! Hand-derived test rigs of the paper (`models/joystick_1dof.yaml`, `models/parallel_link_2dof.yaml`), written independently of the generator:
//! the 1-DOF joystick (inverted pendulum, x = q) and the vertical 2-DOF parallelogram.
#![allow(dead_code, clippy::needless_range_loop)]

use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::{DriveTrain, RigModel, RigTerms};

pub const GRAVITY: f64 = 9.81;
pub const GEAR: f64 = 12.0;
pub const ROTOR_INERTIA: f64 = 1.42e-5;
pub const JOINT_DAMPING: f64 = 1e-3;
/// The joystick's Coulomb friction, N·m (the model's estimate).
pub const JOINT_COULOMB_FRICTION: f64 = 0.01;
pub const TUBE_MASS: f64 = 0.020358;
pub const TUBE_LENGTH: f64 = 0.15;

pub fn re40_drive() -> DriveTrain<f64> {
    DriveTrain {
        gear_ratio: GEAR,
        efficiency: 1.0,
        torque_constant: 30.2e-3,
        resistance: 0.299,
        inductance: 0.082e-3,
        rotor_inertia: ROTOR_INERTIA,
        torque_limit: 3.0,
        current_limit: 10.0,
        supply_voltage: 24.0,
        encoder_counts_per_turn: 2000,
        position_lower: -3.2,
        position_upper: 3.2,
    }
}

/// The RE 40's PI current loop designed by hand for these rigs, independently of the
/// generator: the controller's zero cancels the armature's pole (`ki/kp = R/L`) and the
/// closed loop is first order at a tenth of the 7.5 kHz sample rate (`kp = ω_c L`).
pub fn re40_current_gains() -> CurrentLoopGains<f64> {
    let drive = re40_drive();
    let crossover = 2.0 * std::f64::consts::PI * 750.0;
    CurrentLoopGains {
        kp: crossover * drive.inductance,
        ki: crossover * drive.resistance,
        sample_period: 1.0 / 7500.0,
        proportional_setpoint_weight: 0.0,
    }
}

/// Rig 1: stick pivoted at its bottom end (rod: m L²/3 about the pivot), grip 0.05 kg at
/// 0.12 m, reflected rotor N² J_m; inverted pendulum: V = (m L/2 + m_g r) g cos q.
pub struct Joystick;

impl Joystick {
    const GRIP_MASS: f64 = 0.05;
    const GRIP_RADIUS: f64 = 0.12;
    pub fn inertia() -> f64 {
        TUBE_MASS * TUBE_LENGTH * TUBE_LENGTH / 3.0
            + Self::GRIP_MASS * Self::GRIP_RADIUS * Self::GRIP_RADIUS
            + GEAR * GEAR * ROTOR_INERTIA
    }
    fn gravity_moment() -> f64 {
        (TUBE_MASS * TUBE_LENGTH / 2.0 + Self::GRIP_MASS * Self::GRIP_RADIUS) * GRAVITY
    }
}

impl RigModel<1, 1> for Joystick {
    type Scalar = f64;
    const NAME: &'static str = "joystick";
    const CURRENT_LOOP_HZ: u32 = 7500;
    const IMPEDANCE_LOOP_HZ: u32 = 1000;
    fn inertia_matrix(&self, _q: &[f64; 1]) -> [[f64; 1]; 1] {
        [[Self::inertia()]]
    }
    fn coriolis_matrix(&self, _q: &[f64; 1], _qd: &[f64; 1]) -> [[f64; 1]; 1] {
        [[0.0]]
    }
    fn coriolis_times_qdot(&self, _q: &[f64; 1], _qd: &[f64; 1]) -> [f64; 1] {
        [0.0]
    }
    fn gravity(&self, q: &[f64; 1]) -> [f64; 1] {
        // ∂/∂q of (m L/2 + m_g r) g cos q.
        [-Self::gravity_moment() * q[0].sin()]
    }
    fn damping(&self) -> [f64; 1] {
        [JOINT_DAMPING]
    }
    fn position(&self, q: &[f64; 1]) -> [f64; 1] {
        *q
    }
    fn jacobian(&self, _q: &[f64; 1]) -> [[f64; 1]; 1] {
        [[1.0]]
    }
    fn jacobian_dot(&self, _q: &[f64; 1], _qd: &[f64; 1]) -> [[f64; 1]; 1] {
        [[0.0]]
    }
    fn jacobian_dot_times_qdot(&self, _q: &[f64; 1], _qd: &[f64; 1]) -> [f64; 1] {
        [0.0]
    }
    fn terms(&self, q: &[f64; 1], qd: &[f64; 1]) -> RigTerms<f64, 1, 1> {
        generic_terms(self, q, qd)
    }
    fn drives(&self) -> [DriveTrain<f64>; 1] {
        [re40_drive()]
    }
    fn coulomb_friction(&self) -> [f64; 1] {
        [JOINT_COULOMB_FRICTION]
    }
    fn current_loop_gains(&self) -> [CurrentLoopGains<f64>; 1] {
        [re40_current_gains()]
    }
}

/// Rig 2, vertical: links 1 and 3 at absolute angle q1, links 2 and 4 at q2, all from the
/// base joint; link 4's centre of mass 5 cm from its hinge towards link 3.
pub struct Parallelogram;

impl Parallelogram {
    pub const LINK_LENGTH: f64 = 0.15; // l_l = l1 = l2 = l3
    pub const EXTENSION: f64 = 0.05; // l_e
    const BOTTOM_MASS: f64 = 0.06075; // link 2
    const TOP_MASS: f64 = 0.081; // link 4, 20 cm
    const TOP_LENGTH: f64 = 0.20;
    const TOP_COM: f64 = 0.05;

    fn d11() -> f64 {
        let (m1, m3, m4) = (TUBE_MASS, TUBE_MASS, Self::TOP_MASS);
        let l = Self::LINK_LENGTH;
        m1 * (l / 2.0).powi(2)
            + m3 * (l / 2.0).powi(2)
            + m4 * l * l
            + 2.0 * TUBE_MASS * l * l / 12.0
            + GEAR * GEAR * ROTOR_INERTIA
    }
    fn d22() -> f64 {
        let (m2, m3, m4) = (Self::BOTTOM_MASS, TUBE_MASS, Self::TOP_MASS);
        let l = Self::LINK_LENGTH;
        m2 * (l / 2.0).powi(2)
            + m3 * l * l
            + m4 * Self::TOP_COM.powi(2)
            + m2 * l * l / 12.0
            + m4 * Self::TOP_LENGTH.powi(2) / 12.0
            + GEAR * GEAR * ROTOR_INERTIA
    }
    /// D12 = coupling · cos(q1 − q2).
    pub fn coupling() -> f64 {
        let l = Self::LINK_LENGTH;
        TUBE_MASS * l * (l / 2.0) + Self::TOP_MASS * l * Self::TOP_COM
    }
}

impl RigModel<2, 2> for Parallelogram {
    type Scalar = f64;
    const NAME: &'static str = "parallelogram";
    const CURRENT_LOOP_HZ: u32 = 7500;
    const IMPEDANCE_LOOP_HZ: u32 = 1000;
    fn inertia_matrix(&self, q: &[f64; 2]) -> [[f64; 2]; 2] {
        let d12 = Self::coupling() * (q[0] - q[1]).cos();
        [[Self::d11(), d12], [d12, Self::d22()]]
    }
    fn coriolis_matrix(&self, q: &[f64; 2], qd: &[f64; 2]) -> [[f64; 2]; 2] {
        let s = Self::coupling() * (q[0] - q[1]).sin();
        [[0.0, s * qd[1]], [-s * qd[0], 0.0]]
    }
    fn coriolis_times_qdot(&self, q: &[f64; 2], qd: &[f64; 2]) -> [f64; 2] {
        let s = Self::coupling() * (q[0] - q[1]).sin();
        [s * qd[1] * qd[1], -s * qd[0] * qd[0]]
    }
    fn gravity(&self, q: &[f64; 2]) -> [f64; 2] {
        let l = Self::LINK_LENGTH;
        let first = TUBE_MASS * l / 2.0 + TUBE_MASS * l / 2.0 + Self::TOP_MASS * l;
        let second = Self::BOTTOM_MASS * l / 2.0 + TUBE_MASS * l + Self::TOP_MASS * Self::TOP_COM;
        [GRAVITY * first * q[0].cos(), GRAVITY * second * q[1].cos()]
    }
    fn damping(&self) -> [f64; 2] {
        [JOINT_DAMPING; 2]
    }
    fn position(&self, q: &[f64; 2]) -> [f64; 2] {
        let (l, e) = (Self::LINK_LENGTH, Self::EXTENSION);
        [l * q[0].cos() - e * q[1].cos(), l * q[0].sin() - e * q[1].sin()]
    }
    fn jacobian(&self, q: &[f64; 2]) -> [[f64; 2]; 2] {
        let (l, e) = (Self::LINK_LENGTH, Self::EXTENSION);
        [[-l * q[0].sin(), e * q[1].sin()], [l * q[0].cos(), -e * q[1].cos()]]
    }
    fn jacobian_dot(&self, q: &[f64; 2], qd: &[f64; 2]) -> [[f64; 2]; 2] {
        let (l, e) = (Self::LINK_LENGTH, Self::EXTENSION);
        [[-l * q[0].cos() * qd[0], e * q[1].cos() * qd[1]], [-l * q[0].sin() * qd[0], e * q[1].sin() * qd[1]]]
    }
    fn jacobian_dot_times_qdot(&self, q: &[f64; 2], qd: &[f64; 2]) -> [f64; 2] {
        let (l, e) = (Self::LINK_LENGTH, Self::EXTENSION);
        [
            -l * q[0].cos() * qd[0] * qd[0] + e * q[1].cos() * qd[1] * qd[1],
            -l * q[0].sin() * qd[0] * qd[0] + e * q[1].sin() * qd[1] * qd[1],
        ]
    }
    fn terms(&self, q: &[f64; 2], qd: &[f64; 2]) -> RigTerms<f64, 2, 2> {
        generic_terms(self, q, qd)
    }
    fn drives(&self) -> [DriveTrain<f64>; 2] {
        [re40_drive(); 2]
    }
    fn current_loop_gains(&self) -> [CurrentLoopGains<f64>; 2] {
        [re40_current_gains(); 2]
    }
}

fn generic_terms<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(
    rig: &R,
    q: &[f64; N],
    qd: &[f64; N],
) -> RigTerms<f64, N, M> {
    RigTerms {
        inertia_matrix: rig.inertia_matrix(q),
        coriolis_times_qdot: rig.coriolis_times_qdot(q, qd),
        gravity: rig.gravity(q),
        position: rig.position(q),
        jacobian: rig.jacobian(q),
        jacobian_dot_times_qdot: rig.jacobian_dot_times_qdot(q, qd),
    }
}

/// q̈ from eq. (1): D q̈ = u − C q̇ − B q̇ − g − Jᵀ f_l (Gaussian elimination, test-side).
pub fn forward_dynamics<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(
    rig: &R,
    q: &[f64; N],
    qd: &[f64; N],
    torque: &[f64; N],
    operator_force: &[f64; M],
) -> [f64; N] {
    let terms = rig.terms(q, qd);
    let damping = rig.damping();
    let mut rhs = [0.0; N];
    for i in 0..N {
        rhs[i] = torque[i] - terms.coriolis_times_qdot[i] - damping[i] * qd[i] - terms.gravity[i];
        for k in 0..M {
            rhs[i] -= terms.jacobian[k][i] * operator_force[k];
        }
    }
    solve(terms.inertia_matrix, rhs)
}

/// Plain Gaussian elimination with partial pivoting (independent of the runtime's linalg).
pub fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> [f64; N] {
    for col in 0..N {
        let pivot = (col..N).max_by(|&i, &j| a[i][col].abs().partial_cmp(&a[j][col].abs()).unwrap()).unwrap();
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..N {
            let f = a[row][col] / a[col][col];
            for k in col..N {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; N];
    for i in (0..N).rev() {
        let mut s = b[i];
        for k in i + 1..N {
            s -= a[i][k] * x[k];
        }
        x[i] = s / a[i][i];
    }
    x
}
