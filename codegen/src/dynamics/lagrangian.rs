//! The polynomial derivation of the dynamics (paper, eq. (1)): `D(q)` from the kinetic
//! energy `T = ½ Σ_b (m_b v_bᵀ v_b + ω_bᵀ I_b ω_b)` plus the reflected rotor inertias `N² J_m`
//! (`Cᵀ diag(N² J_m) C` through a coupling `a = C q`),
//! and `C(q, q̇)` from the Christoffel symbols `c_kj = Σ_i ½ (∂_i D_kj + ∂_j D_ki − ∂_k D_ij) q̇_i`.

use super::kinematics::{angular_jacobian_columns, mat_mul, mat_vec, vec_add, Frame, Vec3};
use crate::math::matrix::transpose3;
use crate::model::Model;
use crate::sym::poly::{Atom, Poly};

/// The rotor inertias reflected to the actuated joints, `Cᵀ diag(N_k² J_m,k) C` (kg·m², kg
/// for a prismatic joint), from the drives' kinetic energy `½ Σ_k J_m,k (N_k ȧ_k)²` with the
/// drives' outputs `a = C q`; diagonal, `N² J_m` per joint, without a coupling. Rotor axes are
/// taken as fixed to the base (no gyroscopic terms).
pub fn reflected_rotor_inertia(model: &Model) -> Vec<Vec<f64>> {
    let n = model.joints.len();
    let rotor: Vec<f64> = model
        .joints
        .iter()
        .map(|j| j.drive.gear_ratio * j.drive.gear_ratio * j.drive.motor.rotor_inertia)
        .collect();
    match &model.coupling {
        None => (0..n).map(|a| (0..n).map(|b| if a == b { rotor[a] } else { 0.0 }).collect()).collect(),
        Some(coupling) => {
            let c = &coupling.drive_from_joint;
            (0..n)
                .map(|a| (0..n).map(|b| (0..n).map(|k| c[k][a] * rotor[k] * c[k][b]).sum()).collect())
                .collect()
        }
    }
}

/// `D` from the kinetic energy of every body plus the reflected rotor inertias.
pub(crate) fn lagrangian_inertia_matrix(model: &Model, frames: &[Frame]) -> Vec<Vec<Poly>> {
    let n = model.tree_coordinates();
    let rotor = reflected_rotor_inertia(model);
    let dof = |j: usize| j as u16;
    let mut inertia_terms: Vec<Vec<Vec<Poly>>> = vec![vec![Vec::new(); n]; n];
    for (body, frame) in model.bodies.iter().zip(frames) {
        let com_world = vec_add(&frame.origin, &mat_vec(&frame.rotation, &body.com));
        let linear: Vec<Vec3> =
            (0..n).map(|k| std::array::from_fn(|i| com_world[i].diff_q(dof(k)))).collect();
        // Angular-velocity Jacobian columns: vee(∂R/∂q_k · Rᵀ).
        let rotation_t = transpose3(&frame.rotation);
        let angular = angular_jacobian_columns(&frame.rotation, n);
        let inertia_world = mat_mul(&mat_mul(&frame.rotation, &body.inertia), &rotation_t);
        for a in 0..n {
            for b in a..n {
                let dot: Vec<Poly> = (0..3).map(|i| linear[a][i].mul(&linear[b][i])).collect();
                inertia_terms[a][b].push(body.mass.mul(&Poly::sum(&dot)));
                let iw_b = mat_vec(&inertia_world, &angular[b]);
                let rot: Vec<Poly> = (0..3).map(|i| angular[a][i].mul(&iw_b[i])).collect();
                inertia_terms[a][b].push(Poly::sum(&rot));
            }
        }
    }
    let mut inertia_matrix = vec![vec![Poly::zero(); n]; n];
    for a in 0..n {
        for b in a..n {
            let mut entry = Poly::sum(&inertia_terms[a][b]);
            // The diagonal always (as before couplings existed), the rest where a coupling
            // puts an inertia.
            if let Some(&reflected) = rotor.get(a).and_then(|row| row.get(b)) {
                if a == b || reflected != 0.0 {
                    entry = entry.add(&Poly::constant(reflected));
                }
            }
            inertia_matrix[a][b] = entry.clone();
            inertia_matrix[b][a] = entry;
        }
    }
    inertia_matrix
}

/// `C` from the Christoffel symbols of `D`, and `C q̇`.
pub(crate) fn christoffel(inertia_matrix: &[Vec<Poly>]) -> (Vec<Vec<Poly>>, Vec<Poly>) {
    let n = inertia_matrix.len();
    let dof = |j: usize| j as u16;
    let d_inertia: Vec<Vec<Vec<Poly>>> = (0..n)
        .map(|i| inertia_matrix.iter().map(|row| row.iter().map(|p| p.diff_q(dof(i))).collect()).collect())
        .collect();
    let qd = |i: usize| Poly::atom(Atom::Qd(dof(i)));
    let mut coriolis_matrix = vec![vec![Poly::zero(); n]; n];
    for k in 0..n {
        for j in 0..n {
            let terms: Vec<Poly> = (0..n)
                .map(|i| {
                    let christoffel =
                        d_inertia[i][k][j].add(&d_inertia[j][k][i]).sub(&d_inertia[k][i][j]).scale(0.5);
                    christoffel.mul(&qd(i))
                })
                .collect();
            coriolis_matrix[k][j] = Poly::sum(&terms);
        }
    }
    let coriolis_times_qdot: Vec<Poly> = coriolis_matrix
        .iter()
        .map(|row| Poly::sum(&row.iter().enumerate().map(|(j, c)| c.mul(&qd(j))).collect::<Vec<_>>()))
        .collect();
    (coriolis_matrix, coriolis_times_qdot)
}
