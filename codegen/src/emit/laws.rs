//! Fused, rig-specialised impedance laws: eq. (3) with `a_q` from eq. (4) and the outer laws
//! of section 3 (Controllers 1, 2 in both variants, 3), built as one expression DAG per law on
//! top of the rig's own terms, so that `J⁻¹`, `D⁻¹` and `W⁻¹ = J⁻ᵀ D J⁻¹` appear in closed form
//! (adjugate over determinant) and share every subexpression with `D`, `J`, `C q̇`, `g`.
//!
//! The emitted functions implement `hapticgen_runtime::fused::FusedImpedance`; the runtime
//! adds the rig-independent checks (finite inputs, singularity fallback, `B q̇`).

use crate::dynamics::mechanics::Mechanics;
use crate::dynamics::recursive::{PointQuantity, Quantity};
use crate::math::matrix::{matrix_transpose, matrix_vec};
use crate::model::Model;
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::Atom;

/// Which law to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Law {
    /// Force feedback (the paper's Controller 1), eq. (7) with `a_f = f_l`.
    ForceFeedback,
    /// Acceleration feedback (Controller 2, first variant), eq. (8) and the corrected eq. (10).
    AccelerationFeedback,
    /// Natural-inertia impedance (Controller 2, second variant), eq. (8) with `M_d = W⁻¹`,
    /// `a_f = 0`.
    NaturalInertia,
    /// Jacobian-transpose impedance (Controller 3), eq. (12) with `a_q = 0`.
    JacobianTranspose,
}

/// Index layout of the external inputs (`Atom::External`) for a task dimension `m`.
#[derive(Clone, Copy, Debug)]
pub enum External {
    /// `x_d[k]`.
    ReferencePosition,
    /// `ẋ_d[k]`.
    ReferenceVelocity,
    /// `ẍ_d[k]`.
    ReferenceAcceleration,
    /// `K_d[k]`.
    Stiffness,
    /// `B_d[k]`.
    Damping,
    /// `M_d[k]`.
    Mass,
    /// The sensed signal: `f_l[k]` (Controller 1) or the acceleration estimate (Controller 2a).
    Sensed,
}

impl External {
    /// All kinds, in index order.
    pub const ALL: [External; 7] = [
        External::ReferencePosition,
        External::ReferenceVelocity,
        External::ReferenceAcceleration,
        External::Stiffness,
        External::Damping,
        External::Mass,
        External::Sensed,
    ];

    /// The atom of component `k`.
    pub fn atom(self, k: usize, m: usize) -> Atom {
        Atom::External((self as usize * m + k) as u16)
    }
}

/// The DAG nodes of one law: the torque without `B q̇`, and `det J` where `J⁻¹` is used.
pub struct LawNodes {
    /// Torque per joint.
    pub torque: Vec<NodeId>,
    /// `det J`, for Controllers 1 and 2.
    pub jacobian_determinant: Option<NodeId>,
    /// Names of intermediate nodes with a role in the law (for readable emitted code).
    pub names: Vec<(NodeId, String)>,
}

/// Determinant and adjugate of a square matrix of nodes (n ≤ 3), `None` beyond.
fn determinant_and_adjugate(dag: &mut Dag, a: &[Vec<NodeId>]) -> Option<(NodeId, Vec<Vec<NodeId>>)> {
    let n = a.len();
    match n {
        1 => {
            let one = dag.constant(1.0);
            Some((a[0][0], vec![vec![one]]))
        }
        2 => {
            let ad = dag.mul(a[0][0], a[1][1]);
            let bc = dag.mul(a[0][1], a[1][0]);
            let det = dag.sub(ad, bc);
            let minus_b = dag.neg(a[0][1]);
            let minus_c = dag.neg(a[1][0]);
            Some((det, vec![vec![a[1][1], minus_b], vec![minus_c, a[0][0]]]))
        }
        3 => {
            // Cofactor C_ij = (−1)^(i+j) M_ij; adjugate = Cᵀ.
            let mut cofactor = vec![vec![0; 3]; 3];
            for (i, row) in cofactor.iter_mut().enumerate() {
                for (j, entry) in row.iter_mut().enumerate() {
                    let rows: Vec<usize> = (0..3).filter(|&r| r != i).collect();
                    let cols: Vec<usize> = (0..3).filter(|&c| c != j).collect();
                    let p = dag.mul(a[rows[0]][cols[0]], a[rows[1]][cols[1]]);
                    let q = dag.mul(a[rows[0]][cols[1]], a[rows[1]][cols[0]]);
                    *entry = if (i + j) % 2 == 0 { dag.sub(p, q) } else { dag.sub(q, p) };
                }
            }
            let mut det = dag.constant(0.0);
            for (j, &c) in cofactor[0].iter().enumerate() {
                let t = dag.mul(a[0][j], c);
                det = dag.add(det, t);
            }
            let adjugate = (0..3).map(|i| (0..3).map(|j| cofactor[j][i]).collect()).collect();
            Some((det, adjugate))
        }
        _ => None,
    }
}

fn mat_vec(dag: &mut Dag, a: &[Vec<NodeId>], v: &[NodeId]) -> Vec<NodeId> {
    matrix_vec(dag, a, v)
}

/// `A⁻¹ v = adj(A) v / det A`.
fn solve(dag: &mut Dag, adjugate: &[Vec<NodeId>], det: NodeId, v: &[NodeId]) -> Vec<NodeId> {
    let adj_v = mat_vec(dag, adjugate, v);
    adj_v.into_iter().map(|x| dag.div(x, det)).collect()
}

/// Builds one law into `dag`; `None` if it needs `J⁻¹` and the task is not square (or
/// larger than 3 × 3, where no closed form is emitted).
pub fn build(dag: &mut Dag, model: &Model, mech: &Mechanics, law: Law) -> Option<LawNodes> {
    let n = mech.joints;
    let m = mech.task_dim;
    let jacobian: Vec<Vec<NodeId>> = mech
        .build_task(dag, model, PointQuantity::Jacobian)
        .chunks(n.max(1))
        .map(<[NodeId]>::to_vec)
        .collect();
    let position = mech.build_task(dag, model, PointQuantity::Position);
    let qd: Vec<NodeId> = (0..n).map(|i| dag.input(Atom::Qd(i as u16))).collect();
    let ext = |dag: &mut Dag, kind: External, k: usize| dag.input(kind.atom(k, m));

    // ẋ = J q̇, x̃ = x − x_d, ẋ̃ = ẋ − ẋ_d, r = B_d ẋ̃ + K_d x̃ (the impedance's restoring force).
    let task_velocity = mat_vec(dag, &jacobian, &qd);
    let mut restoring = Vec::with_capacity(m);
    for k in 0..m {
        let x_d = ext(dag, External::ReferencePosition, k);
        let xdot_d = ext(dag, External::ReferenceVelocity, k);
        let stiffness = ext(dag, External::Stiffness, k);
        let damping = ext(dag, External::Damping, k);
        let position_error = dag.sub(position[k], x_d);
        let velocity_error = dag.sub(task_velocity[k], xdot_d);
        let damping_force = dag.mul(damping, velocity_error);
        let spring_force = dag.mul(stiffness, position_error);
        restoring.push(dag.add(damping_force, spring_force));
    }
    let mut names: Vec<(NodeId, String)> = Vec::new();
    for (k, &r) in restoring.iter().enumerate() {
        names.push((r, format!("restoring_force_{k}")));
    }
    let coriolis = mech.build(dag, model, Quantity::CoriolisTimesQdot);
    let gravity = mech.build(dag, model, Quantity::Gravity);
    let bias: Vec<NodeId> = coriolis.iter().zip(&gravity).map(|(&c, &g)| dag.add(c, g)).collect();
    let jacobian_t = matrix_transpose(&jacobian);

    if law == Law::JacobianTranspose {
        let force = mat_vec(dag, &jacobian_t, &restoring);
        let torque = bias.iter().zip(&force).map(|(&b, &f)| dag.sub(b, f)).collect();
        return Some(LawNodes { torque, jacobian_determinant: None, names });
    }
    if n != m {
        return None;
    }
    let (det_j, adj_j) = determinant_and_adjugate(dag, &jacobian)?;
    names.push((det_j, "jacobian_determinant".into()));
    let inertia: Vec<Vec<NodeId>> =
        mech.build(dag, model, Quantity::InertiaMatrix).chunks(n).map(<[NodeId]>::to_vec).collect();
    for (i, row) in inertia.iter().enumerate() {
        for (j, &d) in row.iter().enumerate().skip(i) {
            names.push((d, format!("inertia_{i}{j}")));
        }
    }
    let jdot_qd = mech.build_task(dag, model, PointQuantity::JacobianDotTimesQdot);
    let mut accel_command = Vec::with_capacity(m); // a_x
    let mut force_command: Option<Vec<NodeId>> = None; // a_f
    match law {
        Law::ForceFeedback => {
            // Eq. (7): a_x = ẍ_d − M_d⁻¹(r + f_l); a_f = f_l.
            let mut forces = Vec::with_capacity(m);
            for (k, &r) in restoring.iter().enumerate() {
                let xddot_d = ext(dag, External::ReferenceAcceleration, k);
                let mass = ext(dag, External::Mass, k);
                let f = ext(dag, External::Sensed, k);
                let total = dag.add(r, f);
                let per_mass = dag.div(total, mass);
                accel_command.push(dag.sub(xddot_d, per_mass));
                forces.push(f);
            }
            force_command = Some(forces);
        }
        Law::AccelerationFeedback => {
            // Eq. (8), then the corrected eq. (10): a_f = W⁻¹(ẍ − a_x) − M_d ẍ̃ − r.
            let mut excess = Vec::with_capacity(m);
            for (k, &r) in restoring.iter().enumerate() {
                let xddot_d = ext(dag, External::ReferenceAcceleration, k);
                let mass = ext(dag, External::Mass, k);
                let per_mass = dag.div(r, mass);
                let a_x = dag.sub(xddot_d, per_mass);
                accel_command.push(a_x);
                let xddot = ext(dag, External::Sensed, k);
                excess.push(dag.sub(xddot, a_x));
            }
            let joint = solve(dag, &adj_j, det_j, &excess);
            let torque = mat_vec(dag, &inertia, &joint);
            let adj_jt = matrix_transpose(&adj_j);
            let mobility_inverse_excess = solve(dag, &adj_jt, det_j, &torque);
            let mut forces = Vec::with_capacity(m);
            for (k, &r) in restoring.iter().enumerate() {
                let xddot_d = ext(dag, External::ReferenceAcceleration, k);
                let mass = ext(dag, External::Mass, k);
                let xddot = ext(dag, External::Sensed, k);
                let accel_error = dag.sub(xddot, xddot_d);
                let inertial = dag.mul(mass, accel_error);
                let t = dag.sub(mobility_inverse_excess[k], inertial);
                forces.push(dag.sub(t, r));
            }
            force_command = Some(forces);
        }
        Law::NaturalInertia => {
            // Eq. (8) with M_d⁻¹ = W = J D⁻¹ Jᵀ: a_x = ẍ_d − J D⁻¹ Jᵀ r.
            let (det_d, adj_d) = determinant_and_adjugate(dag, &inertia)?;
            let jt_r = mat_vec(dag, &jacobian_t, &restoring);
            let d_inv_jt_r = solve(dag, &adj_d, det_d, &jt_r);
            let mobility_restoring = mat_vec(dag, &jacobian, &d_inv_jt_r);
            for (k, &w) in mobility_restoring.iter().enumerate() {
                let xddot_d = ext(dag, External::ReferenceAcceleration, k);
                accel_command.push(dag.sub(xddot_d, w));
            }
        }
        Law::JacobianTranspose => unreachable!("handled above"),
    }
    // Eq. (4): a_q = J⁻¹(a_x − J̇ q̇); eq. (3): u = D a_q + C q̇ + g + Jᵀ a_f.
    let rhs: Vec<NodeId> = accel_command.iter().zip(&jdot_qd).map(|(&a, &j)| dag.sub(a, j)).collect();
    let joint_accel = solve(dag, &adj_j, det_j, &rhs);
    for (k, &a) in accel_command.iter().enumerate() {
        names.push((a, format!("task_accel_command_{k}")));
    }
    for (k, &r) in rhs.iter().enumerate() {
        names.push((r, format!("task_accel_minus_jdot_qd_{k}")));
    }
    for (k, &a) in joint_accel.iter().enumerate() {
        names.push((a, format!("joint_accel_command_{k}")));
    }
    let inertial = mat_vec(dag, &inertia, &joint_accel);
    let mut torque: Vec<NodeId> = bias.iter().zip(&inertial).map(|(&b, &d)| dag.add(b, d)).collect();
    if let Some(forces) = force_command {
        let force = mat_vec(dag, &jacobian_t, &forces);
        torque = torque.iter().zip(&force).map(|(&t, &f)| dag.add(t, f)).collect();
    }
    Some(LawNodes { torque, jacobian_determinant: Some(det_j), names })
}
