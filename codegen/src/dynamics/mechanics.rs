//! Symbolic rigid-body mechanics of a [`Model`]: the terms of the paper's eq. (1) and (2).
//!
//! Frames are composed exactly as polynomials in `sin q_j`, `cos q_j`, `q_j`:
//! `frame = parent · origin · joint(q) · tail`, where `origin` comes from `xyz`/`rpy` or
//! Denavit–Hartenberg parameters and `tail` is the part of a standard DH link after the joint. From the body
//! frames follow each centre of mass's position `r_b(q)` and angular-velocity Jacobian, hence
//! the inertia matrix from the kinetic energy
//! `T = ½ q̇ᵀ D q̇ = ½ Σ_b (m_b |J_v,b q̇|² + (J_ω,b q̇)ᵀ R_b I_b R_bᵀ (J_ω,b q̇)) + ½ Σ_j N_j² J_m,j q̇_j²`,
//! the Coriolis matrix from the Christoffel symbols of `D`,
//! `C_kj = Σ_i ½ (∂D_kj/∂q_i + ∂D_ki/∂q_j − ∂D_ij/∂q_k) q̇_i`, gravity `g = ∂V/∂q` with
//! `V = −Σ_b m_b gᵀ r_b`, the task position `p(q)`, `J = ∂p/∂q` and `J̇ = Σ_i ∂J/∂q_i q̇_i`.
//! Nothing is derived by hand: every formula above is applied to whatever the model says.

use rustc_hash::FxHashMap as HashMap;

use super::kinematics::{
    body_frames, frame_kinematics, mat_vec, point_world, vec_add, FrameKinematics, PointKinematics,
};
use super::lagrangian::{christoffel, lagrangian_inertia_matrix};
use crate::dynamics::projection::{OpenTree, Projection};
use crate::dynamics::recursive::{self, FrameQuantity, PointQuantity, Quantity};
use crate::model::{Model, TaskSpec};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, Poly};

/// Serial models with at least this many joints always take the recursive path: their
/// expanded polynomials grow exponentially with the chain (docs/operation-counts.md).
pub const RECURSIVE_FROM_JOINTS: usize = 4;

/// The derivations used to build the emitted code of one function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Choice {
    /// For `D`, `C`, `C q̇`, `g` and the inverse dynamics.
    pub dynamics: Derivation,
    /// For points' positions, Jacobians and `J̇ q̇`.
    pub kinematics: Derivation,
    /// `C q̇` in the Christoffel form (polynomial dynamics only).
    pub structured_coriolis: bool,
}

/// How `D`, `C`, `C q̇` and `g` are built into emitted code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Derivation {
    /// From the canonical polynomials of this module (Lagrangian, Christoffel symbols).
    Polynomial,
    /// With the recursive algorithms of [`crate::dynamics::recursive`] on the expression DAG.
    Recursive,
    /// A spatial closed chain's open-tree polynomials projected on the expression DAG with the
    /// loop solution's `S = [I; A]` (`codegen/src/dynamics/projection.rs`), not multiplied out.
    Projected,
}

/// All derived quantities of a model.
#[derive(Clone, Debug)]
pub struct Mechanics {
    /// Which derivation the emitted code of `D`, `C`, `C q̇` and `g` uses.
    pub derivation: Derivation,
    /// Which derivation the emitted code of points' positions, Jacobians and `J̇ q̇` uses.
    pub kinematics: Derivation,
    /// The task's point (index into the model's points), if the task is a point.
    pub task_point: Option<usize>,
    /// On the polynomial path, build `C q̇` as `Σ_{i≤j} Γ_kij q̇_i q̇_j` from shared partial
    /// derivatives of `D` rather than from its expanded polynomial.
    pub structured_coriolis: bool,
    /// Number of joints.
    pub joints: usize,
    /// Task-space dimension.
    pub task_dim: usize,
    /// `D(q)` (empty when derived for emission only on the recursive path).
    pub inertia_matrix: Vec<Vec<Poly>>,
    /// `C(q, q̇)` (empty when derived for emission only on the recursive path).
    pub coriolis_matrix: Vec<Vec<Poly>>,
    /// `C(q, q̇) q̇` (empty when derived for emission only on the recursive path).
    pub coriolis_times_qdot: Vec<Poly>,
    /// `g(q)` (empty when derived for emission only on the recursive path).
    pub gravity: Vec<Poly>,
    /// Diagonal of `B`.
    pub damping: Vec<Poly>,
    /// Potential energy `V(q)` (for energy checks).
    pub potential_energy: Poly,
    /// Task coordinates.
    pub task: PointKinematics,
    /// Every named point of the model (planar: x, y; spatial: x, y, z).
    pub points: Vec<PointKinematics>,
    /// Every named frame of the model (spatial models; none for planar ones).
    pub frames: Vec<FrameKinematics>,
    /// A closed chain's elimination: its polynomials also contain the passive joints' atoms
    /// and [`Atom::Closure`] atoms, which [`crate::dynamics::closure::install`] defines.
    pub closures: Option<crate::dynamics::closure::Closures>,
    /// A closed chain's open-tree mechanics, in all coordinates (actuated, then passive),
    /// before the reduction to the actuated coordinates.
    pub tree: Option<Box<Mechanics>>,
}

/// The mechanics of the open tree, in all coordinates.
pub(crate) fn derive_tree(model: &Model, all_polynomials: bool) -> Mechanics {
    let n = model.tree_coordinates();
    let dof = |j: usize| j as u16;
    let frames = body_frames(model);
    let recursive_only = !all_polynomials && recursive::applies(model) && n >= RECURSIVE_FROM_JOINTS;

    // Potential energy and gravity.
    let mut potential_terms = Vec::new();
    for (body, frame) in model.bodies.iter().zip(&frames) {
        let com_world = vec_add(&frame.origin, &mat_vec(&frame.rotation, &body.com));
        for (g, r) in model.gravity.iter().zip(&com_world) {
            potential_terms.push(body.mass.mul(g).mul(r).scale(-1.0));
        }
    }
    let potential_energy = Poly::sum(&potential_terms);
    let (inertia_matrix, coriolis_matrix, coriolis_times_qdot, gravity) = if recursive_only {
        (Vec::new(), Vec::new(), Vec::new(), Vec::new())
    } else {
        let inertia_matrix = lagrangian_inertia_matrix(model, &frames);
        let gravity: Vec<Poly> = (0..n).map(|k| potential_energy.diff_q(dof(k))).collect();
        let (coriolis_matrix, coriolis_times_qdot) = christoffel(&inertia_matrix);
        (inertia_matrix, coriolis_matrix, coriolis_times_qdot, gravity)
    };
    let damping: Vec<Poly> =
        (0..n).map(|j| model.joints.get(j).map(|j| j.damping.clone()).unwrap_or_default()).collect();

    // Points and task.
    let qd = |i: usize| Poly::atom(Atom::Qd(dof(i)));
    let kinematics = |name: &str, position: Vec<Poly>| -> PointKinematics {
        let jacobian: Vec<Vec<Poly>> =
            position.iter().map(|p| (0..n).map(|k| p.diff_q(dof(k))).collect()).collect();
        let jacobian_dot: Vec<Vec<Poly>> = jacobian
            .iter()
            .map(|row| {
                row.iter()
                    .map(|entry| {
                        Poly::sum(&(0..n).map(|i| entry.diff_q(dof(i)).mul(&qd(i))).collect::<Vec<_>>())
                    })
                    .collect()
            })
            .collect();
        let jacobian_dot_times_qdot = jacobian_dot
            .iter()
            .map(|row| Poly::sum(&row.iter().enumerate().map(|(k, e)| e.mul(&qd(k))).collect::<Vec<_>>()))
            .collect();
        PointKinematics { name: name.to_string(), position, jacobian, jacobian_dot, jacobian_dot_times_qdot }
    };
    let points: Vec<PointKinematics> = (0..model.points.len())
        .map(|i| kinematics(&model.points[i].name, point_world(model, &frames, i)))
        .collect();
    let named_frames: Vec<FrameKinematics> =
        (0..model.frames.len()).map(|i| frame_kinematics(model, &frames, i)).collect();
    let task = match &model.task {
        TaskSpec::Point(i) => {
            let mut k = points[*i].clone();
            k.name = "task".into();
            k
        }
        TaskSpec::Joints(list) => {
            kinematics("task", list.iter().map(|&j| Poly::atom(Atom::Q(dof(j)))).collect())
        }
    };

    let task_point = match &model.task {
        TaskSpec::Point(i) => Some(*i),
        TaskSpec::Joints(_) => None,
    };
    Mechanics {
        derivation: Derivation::Polynomial,
        kinematics: Derivation::Polynomial,
        task_point,
        structured_coriolis: false,
        joints: n,
        task_dim: task.position.len(),
        inertia_matrix,
        coriolis_matrix,
        coriolis_times_qdot,
        gravity,
        damping,
        potential_energy,
        task,
        points,
        frames: named_frames,
        closures: None,
        tree: None,
    }
}

/// For a serial model, the derivations of the dynamics and of the task kinematics whose
/// control-tick quantities (`D`, `C q̇`, `g`, `J`, `J̇ q̇` with shared subexpressions, after
/// merging sums as the emitter does) take the fewest operations. Long chains take the
/// recursive dynamics without comparison: their polynomials are not even expanded.
pub(crate) fn choose_derivations(model: &Model, mechanics: &mut Mechanics) {
    let both = [Derivation::Polynomial, Derivation::Recursive];
    let projected = [Derivation::Polynomial, Derivation::Projected];
    let serial = recursive::applies(model);
    let dynamics: &[Derivation] = if mechanics.projectable() {
        &projected
    } else if !serial {
        &both[..1]
    } else if model.joints.len() >= RECURSIVE_FROM_JOINTS {
        &both[1..]
    } else {
        &both
    };
    let kinematics: &[Derivation] = if mechanics.projectable() {
        &projected
    } else if serial && mechanics.task_point.is_some() {
        &both
    } else {
        &both[..1]
    };
    // The Christoffel form needs `D` in the coordinates of `q̇`, which a closed chain's reduced
    // `D` is not built from.
    let closed = mechanics.closures.is_some();
    let mut best: Option<(usize, Derivation, Derivation, bool)> = None;
    let options: Vec<(Derivation, bool)> = dynamics
        .iter()
        .flat_map(|&d| {
            if d == Derivation::Polynomial && !closed {
                vec![(d, false), (d, true)]
            } else {
                vec![(d, false)]
            }
        })
        .collect();
    for &(d, structured) in &options {
        for &k in kinematics {
            mechanics.derivation = d;
            mechanics.kinematics = k;
            mechanics.structured_coriolis = structured;
            // With a closed chain's elimination in front, as the emitted code has it.
            let (mut dag, _) = super::closure::graph_with(mechanics.closures.as_ref());
            let mut roots = mechanics.build(&mut dag, model, Quantity::InertiaMatrix);
            roots.extend(mechanics.build(&mut dag, model, Quantity::CoriolisTimesQdot));
            roots.extend(mechanics.build(&mut dag, model, Quantity::Gravity));
            roots.extend(mechanics.build_task(&mut dag, model, PointQuantity::Jacobian));
            roots.extend(mechanics.build_task(&mut dag, model, PointQuantity::JacobianDotTimesQdot));
            let counts = dag.optimised_count(&roots);
            let cost = counts.arithmetic() + counts.trigonometric;
            // Strictly cheaper wins; ties keep the polynomial form (listed first).
            if best.is_none_or(|(b, _, _, _)| cost < b) {
                best = Some((cost, d, k, structured));
            }
        }
    }
    if let Some((_, d, k, structured)) = best {
        mechanics.derivation = d;
        mechanics.kinematics = k;
        mechanics.structured_coriolis = structured;
    }
}

impl Mechanics {
    /// Whether this can be built by projection ([`Derivation::Projected`]): a reduced spatial
    /// chain that keeps its open tree.
    pub(crate) fn projectable(&self) -> bool {
        self.projection().is_some()
    }

    /// The projection of this reduced chain's open tree: a spatial closed chain's, else `None`.
    fn projection(&self) -> Option<Projection<'_>> {
        let (tree, closures) = (self.tree.as_deref()?, self.closures.as_ref()?);
        closures.spatial.as_ref()?;
        debug_assert_eq!(tree.derivation, Derivation::Polynomial);
        Some(Projection {
            tree: OpenTree {
                joints: tree.joints,
                inertia_matrix: &tree.inertia_matrix,
                coriolis_matrix: &tree.coriolis_matrix,
                coriolis_times_qdot: &tree.coriolis_times_qdot,
                gravity: &tree.gravity,
                points: &tree.points,
            },
            closures,
        })
    }

    /// `C q̇ = Σ_k Σ_{i≤j} Γ_kij q̇_i q̇_j` with the Christoffel combinations
    /// `Γ_kij = ∂_i D_kj + ∂_j D_ki − ∂_k D_ij` (`i < j`) and `∂_i D_ki − ½ ∂_k D_ii` (`i = j`) built
    /// from the partial derivatives of `D` as shared nodes (the diagonal ones as
    /// `(2 ∂_i D_ki − ∂_k D_ii) · ½ q̇_i²`).
    fn christoffel_form(&self, dag: &mut Dag) -> Vec<NodeId> {
        let n = self.joints;
        let mut partial: HashMap<(usize, usize, usize), NodeId> = HashMap::default();
        let mut d = |dag: &mut Dag, i: usize, r: usize, c: usize| -> NodeId {
            let (r, c) = (r.min(c), r.max(c));
            *partial
                .entry((i, r, c))
                .or_insert_with(|| dag.polynomial(&self.inertia_matrix[r][c].diff_q(i as u16)))
        };
        let half = dag.constant(0.5);
        (0..n)
            .map(|k| {
                let mut acc = dag.constant(0.0);
                for i in 0..n {
                    for j in i..n {
                        let (qi, qj) = (dag.input(Atom::Qd(i as u16)), dag.input(Atom::Qd(j as u16)));
                        let velocities = dag.mul(qi, qj);
                        if i == j {
                            // (2 ∂_i D_ki − ∂_k D_ii) · ½ q̇_i²: the half square is shared by every row.
                            let a = d(dag, i, k, i);
                            let b = d(dag, k, i, i);
                            let two = dag.constant(2.0);
                            let a = dag.mul(two, a);
                            let symbol = dag.sub(a, b);
                            let half_square = dag.mul(half, velocities);
                            let term = dag.mul(symbol, half_square);
                            acc = dag.add(acc, term);
                            continue;
                        }
                        let symbol = {
                            let a = d(dag, i, k, j);
                            let b = d(dag, j, k, i);
                            let c = d(dag, k, i, j);
                            let ab = dag.add(a, b);
                            dag.sub(ab, c)
                        };
                        let term = dag.mul(symbol, velocities);
                        acc = dag.add(acc, term);
                    }
                }
                acc
            })
            .collect()
    }

    /// The task's position, Jacobian (row-major) or `J̇ q̇`, built into `dag`.
    pub fn build_task(&self, dag: &mut Dag, model: &Model, what: PointQuantity) -> Vec<NodeId> {
        match self.task_point {
            Some(i) => self.build(dag, model, Quantity::Point(i, what)),
            None => point_polys(&self.task, what).iter().map(|p| dag.polynomial(p)).collect(),
        }
    }

    /// The derivations this model's emitted code uses by default (the control tick's best).
    pub fn choice(&self) -> Choice {
        Choice {
            dynamics: self.derivation,
            kinematics: self.kinematics,
            structured_coriolis: self.structured_coriolis,
        }
    }

    /// Every combination of derivations this model supports (the emitter takes the cheapest
    /// for each function on its own).
    pub fn choices(&self, model: &Model) -> Vec<Choice> {
        let serial = recursive::applies(model);
        let polynomial_dynamics =
            self.closures.is_some() || !self.inertia_matrix.is_empty() || self.joints == 0;
        let projected = self.projectable();
        let all = [Derivation::Polynomial, Derivation::Recursive, Derivation::Projected];
        let mut out = Vec::new();
        for dynamics in all {
            for kinematics in all {
                for structured_coriolis in [false, true] {
                    let dynamics_ok = match dynamics {
                        Derivation::Polynomial => polynomial_dynamics,
                        Derivation::Recursive => serial && !structured_coriolis,
                        Derivation::Projected => projected && !structured_coriolis,
                    };
                    let kinematics_ok = match kinematics {
                        Derivation::Polynomial => true,
                        Derivation::Recursive => serial,
                        Derivation::Projected => projected,
                    };
                    if dynamics_ok && kinematics_ok && (!structured_coriolis || self.closures.is_none()) {
                        out.push(Choice { dynamics, kinematics, structured_coriolis });
                    }
                }
            }
        }
        out
    }

    /// Builds a quantity into `dag` with this model's derivation; matrices row-major.
    pub fn build(&self, dag: &mut Dag, model: &Model, quantity: Quantity) -> Vec<NodeId> {
        self.build_with(dag, model, quantity, self.choice())
    }

    /// Builds a quantity into `dag` with the given derivations (one of [`Mechanics::choices`]).
    pub fn build_with(
        &self,
        dag: &mut Dag,
        model: &Model,
        quantity: Quantity,
        choice: Choice,
    ) -> Vec<NodeId> {
        let derivation = match quantity {
            Quantity::Point(..) | Quantity::Frame(..) => choice.kinematics,
            _ => choice.dynamics,
        };
        match derivation {
            Derivation::Recursive => return recursive::build(dag, model, quantity),
            Derivation::Projected => {
                return self.projection().map_or_else(Vec::new, |p| p.build(dag, quantity))
            }
            Derivation::Polynomial => {}
        }
        let polys = |dag: &mut Dag, list: &[Poly]| -> Vec<NodeId> {
            list.iter().map(|p| dag.polynomial(p)).collect()
        };
        match quantity {
            Quantity::InertiaMatrix => {
                self.inertia_matrix.iter().flat_map(|row| row.iter()).map(|p| dag.polynomial(p)).collect()
            }
            Quantity::CoriolisMatrix => {
                self.coriolis_matrix.iter().flat_map(|row| row.iter()).map(|p| dag.polynomial(p)).collect()
            }
            Quantity::CoriolisTimesQdot if choice.structured_coriolis => self.christoffel_form(dag),
            Quantity::CoriolisTimesQdot => polys(dag, &self.coriolis_times_qdot),
            Quantity::Gravity => polys(dag, &self.gravity),
            Quantity::Point(i, what) => {
                point_polys(&self.points[i], what).iter().map(|p| dag.polynomial(p)).collect()
            }
            Quantity::Frame(i, what) => {
                let frame = &self.frames[i];
                let matrix = match what {
                    FrameQuantity::Orientation => &frame.rotation,
                    FrameQuantity::AngularJacobian => &frame.angular_jacobian,
                };
                matrix.iter().flatten().map(|p| dag.polynomial(p)).collect()
            }
            Quantity::InverseDynamics => {
                // D q̈ + C q̇ + g, row by row.
                let inertia = self.build_with(dag, model, Quantity::InertiaMatrix, choice);
                let coriolis = self.build_with(dag, model, Quantity::CoriolisTimesQdot, choice);
                let bias: Vec<NodeId> = coriolis
                    .iter()
                    .zip(&self.gravity)
                    .map(|(&c, g)| {
                        let g = dag.polynomial(g);
                        dag.add(c, g)
                    })
                    .collect();
                (0..self.joints)
                    .map(|i| {
                        let mut acc = bias[i];
                        for k in 0..self.joints {
                            let qdd = dag.input(Atom::Qdd(k as u16));
                            let term = dag.mul(inertia[i * self.joints + k], qdd);
                            acc = dag.add(acc, term);
                        }
                        acc
                    })
                    .collect()
            }
        }
    }
}

/// A point's polynomials of one kind, row-major.
fn point_polys(point: &PointKinematics, what: PointQuantity) -> Vec<&Poly> {
    match what {
        PointQuantity::Position => point.position.iter().collect(),
        PointQuantity::Jacobian => point.jacobian.iter().flatten().collect(),
        PointQuantity::JacobianDotTimesQdot => point.jacobian_dot_times_qdot.iter().collect(),
    }
}
