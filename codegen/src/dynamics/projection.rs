//! The reduction of a closed chain to its actuated coordinates built on the expression graph:
//! the open tree's quantities as nodes, projected with `S = ∂q_tree/∂q_a = [I; A]`,
//! `D_a = Sᵀ (D S)`, `C_a q̇_a = Sᵀ (C q̇ + D (Ṡ q̇_a))`, `C_a = Sᵀ (C S + D Ṡ)`, `g_a = Sᵀ g`,
//! `J_a = J S`, `J̇_a q̇_a = J̇ q̇ + J (Ṡ q̇_a)`, the formulas of `super::reduction`.
//!
//! `super::reduction` multiplies the polynomials out, which is exact and what the evaluator
//! and the checks use; for a spatial chain, whose `A` has a column per actuated coordinate for
//! every passive joint, the expanded products are many times larger than the products
//! themselves (the Falcon-like Delta's `D` takes 2,065 operations expanded). Here the products
//! are kept: each entry of the tree's `D`, `C q̇`, `g`, `J` and `J̇ q̇` is built once, and `S`
//! multiplies them as the run-time code of a projection would, with the tree's zeros (legs
//! that do not move each other) dropped by the graph's constant folding. The tree's
//! quantities read the passive joints' velocities directly (`q̇_p = A q̇_a` comes from the loop
//! solution), and `Ṡ q̇_a` is one vector, shared by `C q̇` and `J̇ q̇`, which the runtime solves
//! for directly (`Ȧ q̇_a = −Φ_p⁻¹ γ`), so that only `C` itself reads `Ȧ`.

use super::closure::Closures;
use super::kinematics::PointKinematics;
use super::recursive::{PointQuantity, Quantity};
use crate::math::matrix::{matrix_mul, matrix_transpose, matrix_vec, Arithmetic};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, Poly};

/// The open tree's polynomials, in all its coordinates (actuated, then passive): what is
/// projected.
pub(crate) struct OpenTree<'a> {
    /// Number of tree coordinates.
    pub joints: usize,
    /// The tree's `D`.
    pub inertia_matrix: &'a [Vec<Poly>],
    /// The tree's `C`.
    pub coriolis_matrix: &'a [Vec<Poly>],
    /// The tree's `C q̇`.
    pub coriolis_times_qdot: &'a [Poly],
    /// The tree's `g`.
    pub gravity: &'a [Poly],
    /// The tree's named points.
    pub points: &'a [PointKinematics],
}

/// The open tree and the loop closures of a reduced chain, the two halves of a projection.
pub(crate) struct Projection<'a> {
    /// What is projected.
    pub tree: OpenTree<'a>,
    /// The loop solution whose `A` atoms make `S`.
    pub closures: &'a Closures,
}

impl Projection<'_> {
    /// `S = ∂q_tree/∂q_a`: the identity on the actuated rows, the loop solution's `A` atoms on
    /// the passive ones (`rate`: `Ṡ`, zero on the actuated rows).
    fn sensitivity(&self, dag: &mut Dag, rate: bool) -> Vec<Vec<NodeId>> {
        let actuated = self.closures.actuated;
        (0..self.tree.joints)
            .map(|i| {
                (0..actuated)
                    .map(|j| match self.closures.sensitivity_atom(i, j, rate) {
                        Some(atom) => dag.input(atom),
                        None => dag.constant(if !rate && i == j { 1.0 } else { 0.0 }),
                    })
                    .collect()
            })
            .collect()
    }

    /// `Ṡ q̇_a`, the tree coordinates' acceleration at `q̈_a = 0`: zero on the actuated rows,
    /// the loop solution's `Ȧ q̇_a` (one solve at run time) on the passive ones.
    fn sensitivity_rate_times_qdot(&self, dag: &mut Dag) -> Vec<NodeId> {
        let s_dot = self.sensitivity(dag, true);
        let qd: Vec<NodeId> = (0..self.closures.actuated).map(|j| dag.input(Atom::Qd(j as u16))).collect();
        let products = matrix_vec(dag, &s_dot, &qd);
        products
            .into_iter()
            .enumerate()
            .map(|(i, product)| match self.closures.convective_atom(i) {
                Some(atom) => dag.input(atom),
                None => product,
            })
            .collect()
    }

    fn nodes(dag: &mut Dag, polys: &[Poly]) -> Vec<NodeId> {
        polys.iter().map(|p| dag.polynomial(p)).collect()
    }

    fn matrix(dag: &mut Dag, polys: &[Vec<Poly>]) -> Vec<Vec<NodeId>> {
        polys.iter().map(|row| Self::nodes(dag, row)).collect()
    }

    /// `Sᵀ v` for a vector over the tree coordinates.
    fn project(&self, dag: &mut Dag, v: &[NodeId]) -> Vec<NodeId> {
        let s = self.sensitivity(dag, false);
        matrix_vec(dag, &matrix_transpose(&s), v)
    }

    /// `a + b`, entry by entry.
    fn add(dag: &mut Dag, a: &[NodeId], b: &[NodeId]) -> Vec<NodeId> {
        a.iter().zip(b).map(|(&x, &y)| dag.add(x, y)).collect()
    }

    /// For a point on a Delta's platform (its loops in closed form), `what` from the platform's
    /// motion: the platform only translates, so the point is its origin plus a constant,
    /// `J = ∂O/∂q_a` and `J̇ q̇ = Ö`, none of which needs the passive joints or `S`.
    fn platform_point(&self, dag: &mut Dag, point: usize, what: PointQuantity) -> Option<Vec<NodeId>> {
        let closed_form = self.closures.spatial.as_ref()?.closed_form.as_ref()?;
        let offset = closed_form.platform_point(point)?;
        // A graph that starts as the shared one with the elimination (`closure::graph_with`,
        // as every emitted function's does) has its nodes; any other gets them installed (the
        // same nodes if they are there already).
        let (shared, installed) = self.closures.installed();
        let motion = if dag.nodes().starts_with(shared.nodes()) {
            installed.platform.clone()?
        } else {
            super::closure::install(dag, Some(self.closures)).platform?
        };
        Some(match what {
            PointQuantity::Position => (0..3)
                .map(|r| {
                    let offset = dag.polynomial(&offset[r]);
                    dag.add(motion.origin[r], offset)
                })
                .collect(),
            PointQuantity::Jacobian => {
                (0..3).flat_map(|r| motion.jacobian.iter().map(move |column| column[r])).collect()
            }
            PointQuantity::JacobianDotTimesQdot => motion.convective_acceleration.to_vec(),
        })
    }

    /// Builds `quantity` of the reduced chain as the projection of the open tree's (see the
    /// module docs); matrices row-major.
    pub(crate) fn build(&self, dag: &mut Dag, quantity: Quantity) -> Vec<NodeId> {
        let tree = &self.tree;
        match quantity {
            Quantity::InertiaMatrix => {
                let s = self.sensitivity(dag, false);
                let tree_inertia = Self::matrix(dag, tree.inertia_matrix);
                let inertia_times_s = matrix_mul(dag, &tree_inertia, &s);
                // `(Sᵀ D S)_ij = Σ_k S_ki (D S)_kj`, built for `i ≤ j` only; the lower triangle
                // mirrors it, so that rounding cannot make the matrix unsymmetric.
                let upper = |dag: &mut Dag, i: usize, j: usize| {
                    Arithmetic::dot(
                        dag,
                        s.iter().map(|row| &row[i]).zip(inertia_times_s.iter().map(|row| &row[j])),
                    )
                };
                let actuated = self.closures.actuated;
                let mut built = std::collections::BTreeMap::new();
                (0..actuated)
                    .flat_map(|i| (0..actuated).map(move |j| (i.min(j), i.max(j))))
                    .map(|(i, j)| *built.entry((i, j)).or_insert_with(|| upper(dag, i, j)))
                    .collect()
            }
            Quantity::CoriolisMatrix => {
                let s = self.sensitivity(dag, false);
                let s_dot = self.sensitivity(dag, true);
                let tree_coriolis = Self::matrix(dag, tree.coriolis_matrix);
                let tree_inertia = Self::matrix(dag, tree.inertia_matrix);
                let coriolis_s = matrix_mul(dag, &tree_coriolis, &s);
                let inertia_s_dot = matrix_mul(dag, &tree_inertia, &s_dot);
                let sum: Vec<Vec<NodeId>> =
                    coriolis_s.iter().zip(&inertia_s_dot).map(|(a, b)| Self::add(dag, a, b)).collect();
                matrix_mul(dag, &matrix_transpose(&s), &sum).into_iter().flatten().collect()
            }
            Quantity::CoriolisTimesQdot => {
                let tree_cqd = Self::nodes(dag, tree.coriolis_times_qdot);
                let tree_inertia = Self::matrix(dag, tree.inertia_matrix);
                let bias = self.sensitivity_rate_times_qdot(dag);
                let inertia_bias = matrix_vec(dag, &tree_inertia, &bias);
                let sum = Self::add(dag, &tree_cqd, &inertia_bias);
                self.project(dag, &sum)
            }
            Quantity::Gravity => {
                let tree_gravity = Self::nodes(dag, tree.gravity);
                self.project(dag, &tree_gravity)
            }
            Quantity::InverseDynamics => {
                let actuated = self.closures.actuated;
                let inertia = self.build(dag, Quantity::InertiaMatrix);
                let coriolis = self.build(dag, Quantity::CoriolisTimesQdot);
                let gravity = self.build(dag, Quantity::Gravity);
                (0..actuated)
                    .map(|i| {
                        let mut acc = dag.add(coriolis[i], gravity[i]);
                        for k in 0..actuated {
                            let qdd = dag.input(Atom::Qdd(k as u16));
                            let term = dag.mul(inertia[i * actuated + k], qdd);
                            acc = dag.add(acc, term);
                        }
                        acc
                    })
                    .collect()
            }
            Quantity::Point(i, what) => {
                if let Some(nodes) = self.platform_point(dag, i, what) {
                    return nodes;
                }
                let point = &tree.points[i];
                match what {
                    PointQuantity::Position => Self::nodes(dag, &point.position),
                    PointQuantity::Jacobian => {
                        let s = self.sensitivity(dag, false);
                        let tree_jacobian = Self::matrix(dag, &point.jacobian);
                        matrix_mul(dag, &tree_jacobian, &s).into_iter().flatten().collect()
                    }
                    PointQuantity::JacobianDotTimesQdot => {
                        let tree_jdqd = Self::nodes(dag, &point.jacobian_dot_times_qdot);
                        let tree_jacobian = Self::matrix(dag, &point.jacobian);
                        let bias = self.sensitivity_rate_times_qdot(dag);
                        let jacobian_bias = matrix_vec(dag, &tree_jacobian, &bias);
                        Self::add(dag, &tree_jdqd, &jacobian_bias)
                    }
                }
            }
            // Frames of closed chains are not reduced (none is declared on one; see
            // `super::reduction`).
            Quantity::Frame(..) => Vec::new(),
        }
    }
}
