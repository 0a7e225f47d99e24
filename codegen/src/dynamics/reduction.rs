//! Reduction of a closed chain's open-tree mechanics to the actuated coordinates, with
//! `q̇ = S q̇_a` from the loop closures ([`super::closure`]): `D_a = Sᵀ D S`,
//! `C_a = Sᵀ (C S + D Ṡ)`, `C_a q̇_a = Sᵀ (C q̇ + D Ṡ q̇_a)`, `g_a = Sᵀ g`, `J_a = J S`,
//! `J̇_a q̇_a = J̇ q̇ + J Ṡ q̇_a`.

use super::closure::Closures;
use super::kinematics::PointKinematics;
use super::mechanics::{Derivation, Mechanics};
use crate::math::matrix::{matrix_add, matrix_mul, matrix_transpose, matrix_vec};
use crate::sym::poly::{Atom, Poly, Polynomials};

type Matrix = Vec<Vec<Poly>>;

fn mat_mul(a: &[Vec<Poly>], b: &[Vec<Poly>]) -> Matrix {
    matrix_mul(&mut Polynomials, a, b)
}

fn mat_vec(a: &[Vec<Poly>], v: &[Poly]) -> Vec<Poly> {
    matrix_vec(&mut Polynomials, a, v)
}

fn mat_add(a: &[Vec<Poly>], b: &[Vec<Poly>]) -> Matrix {
    matrix_add(&mut Polynomials, a, b)
}

/// Reduces the open tree's mechanics to the actuated coordinates (see the module docs).
pub fn reduce(tree: Mechanics, closures: &Closures) -> Mechanics {
    let n = closures.actuated;
    let total = tree.joints;
    // S = ∂q/∂q_a and Ṡ, as polynomials in the `Closure` atoms.
    let entry = |i: usize, j: usize, rate: bool| -> Poly {
        match closures.sensitivity_atom(i, j, rate) {
            Some(atom) => Poly::atom(atom),
            None if !rate && i == j => Poly::constant(1.0),
            None => Poly::zero(),
        }
    };
    let s: Matrix = (0..total).map(|i| (0..n).map(|j| entry(i, j, false)).collect()).collect();
    let s_dot: Matrix = (0..total).map(|i| (0..n).map(|j| entry(i, j, true)).collect()).collect();
    let qd: Vec<Poly> = (0..n).map(|j| Poly::atom(Atom::Qd(j as u16))).collect();
    let s_dot_qd = mat_vec(&s_dot, &qd);
    let st = matrix_transpose(&s);
    let d_s = mat_mul(&tree.inertia_matrix, &s);
    let product = mat_mul(&st, &d_s);
    // Symmetric by construction; mirrored so that rounding cannot make it otherwise.
    let inertia_matrix: Matrix =
        (0..n).map(|i| (0..n).map(|j| product[i.min(j)][i.max(j)].clone()).collect()).collect();
    let coriolis_matrix =
        mat_mul(&st, &mat_add(&mat_mul(&tree.coriolis_matrix, &s), &mat_mul(&tree.inertia_matrix, &s_dot)));
    let tree_cqd: Vec<Poly> = tree
        .coriolis_times_qdot
        .iter()
        .zip(mat_vec(&tree.inertia_matrix, &s_dot_qd))
        .map(|(a, b)| a.add(&b))
        .collect();
    let coriolis_times_qdot = mat_vec(&st, &tree_cqd);
    let gravity = mat_vec(&st, &tree.gravity);
    let reduce_kinematics = |k: &PointKinematics| -> PointKinematics {
        let jacobian = mat_mul(&k.jacobian, &s);
        let jacobian_dot = mat_add(&mat_mul(&k.jacobian_dot, &s), &mat_mul(&k.jacobian, &s_dot));
        let jacobian_dot_times_qdot = k
            .jacobian_dot_times_qdot
            .iter()
            .zip(mat_vec(&k.jacobian, &s_dot_qd))
            .map(|(a, b)| a.add(&b))
            .collect();
        PointKinematics {
            name: k.name.clone(),
            position: k.position.clone(),
            jacobian,
            jacobian_dot,
            jacobian_dot_times_qdot,
        }
    };
    Mechanics {
        // The reduced polynomials contain the closure atoms: emitted as they are.
        derivation: Derivation::Polynomial,
        kinematics: Derivation::Polynomial,
        // A spatial chain's task point is built by projection from the tree's
        // (`super::projection`); a planar chain's task stays the reduced polynomials.
        task_point: if closures.spatial.is_some() { tree.task_point } else { None },
        structured_coriolis: false,
        joints: n,
        task_dim: tree.task_dim,
        inertia_matrix,
        coriolis_matrix,
        coriolis_times_qdot,
        gravity,
        damping: tree.damping[..n].to_vec(),
        potential_energy: tree.potential_energy.clone(),
        task: reduce_kinematics(&tree.task),
        points: tree.points.iter().map(reduce_kinematics).collect(),
        // Frames of closed chains are not reduced yet (none is declared on one).
        frames: Vec::new(),
        closures: Some(closures.clone()),
        tree: Some(Box::new(tree)),
    }
}
