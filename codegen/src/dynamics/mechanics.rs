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

use crate::dynamics::recursive::{self, FrameQuantity, PointQuantity, Quantity};
use crate::model::{JointKind, Model, Motion, TaskSpec};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, Poly};

/// Serial models with at least this many joints always take the recursive path: their
/// expanded polynomials grow exponentially with the chain (docs/performance.md).
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
}

/// Kinematics of one point: position and its derivatives.
#[derive(Clone, Debug)]
pub struct PointKinematics {
    /// Point name (`task` for the task coordinates).
    pub name: String,
    /// Position, one polynomial per coordinate.
    pub position: Vec<Poly>,
    /// Jacobian, rows × joints.
    pub jacobian: Vec<Vec<Poly>>,
    /// Time derivative of the Jacobian.
    pub jacobian_dot: Vec<Vec<Poly>>,
    /// `J̇ q̇`.
    pub jacobian_dot_times_qdot: Vec<Poly>,
}

/// Orientation of one named frame (spatial models).
#[derive(Clone, Debug)]
pub struct FrameKinematics {
    /// Frame name.
    pub name: String,
    /// Rotation matrix of the frame in the base frame, 3 × 3.
    pub rotation: Vec<Vec<Poly>>,
    /// Angular-velocity Jacobian in base-frame coordinates, 3 × joints: `ω = J_ω q̇`, column
    /// `k` being `vee(∂R/∂q_k · Rᵀ)`.
    pub angular_jacobian: Vec<Vec<Poly>>,
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

type Vec3 = [Poly; 3];
type Mat3 = [[Poly; 3]; 3];

fn constant_matrix(m: [[f64; 3]; 3]) -> Mat3 {
    m.map(|row| row.map(Poly::constant))
}

fn identity() -> Mat3 {
    constant_matrix([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
}

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| Poly::sum(&(0..3).map(|k| a[i][k].mul(&b[k][j])).collect::<Vec<_>>()))
    })
}

fn mat_vec(a: &Mat3, v: &Vec3) -> Vec3 {
    std::array::from_fn(|i| Poly::sum(&(0..3).map(|k| a[i][k].mul(&v[k])).collect::<Vec<_>>()))
}

fn transpose(a: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i].clone()))
}

fn vec_add(a: &Vec3, b: &Vec3) -> Vec3 {
    std::array::from_fn(|i| a[i].add(&b[i]))
}

/// Rotation by `q_j` about the unit axis `u`: `I + sin q [u]× + (1 − cos q) [u]×²`.
fn axis_rotation(u: [f64; 3], joint: u16) -> Mat3 {
    let s = Poly::atom(Atom::Sin(joint));
    let c = Poly::atom(Atom::Cos(joint));
    let one_minus_c = Poly::constant(1.0).sub(&c);
    let k = [[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]];
    let mut k2 = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            k2[i][j] = (0..3).map(|l| k[i][l] * k[l][j]).sum();
        }
    }
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let id = if i == j { 1.0 } else { 0.0 };
            Poly::constant(id).add(&s.scale(k[i][j])).add(&one_minus_c.scale(k2[i][j]))
        })
    })
}

struct Frame {
    origin: Vec3,
    rotation: Mat3,
}

/// Body frames, in dependency order, over all coordinates of the open tree.
fn body_frames(model: &Model) -> Vec<Frame> {
    let dof = |j: usize| j as u16;
    let mut frames: Vec<Frame> = Vec::with_capacity(model.bodies.len());
    let base = || Frame { origin: [Poly::zero(), Poly::zero(), Poly::zero()], rotation: identity() };
    for body in &model.bodies {
        let frame = match &body.motion {
            Motion::Serial { parent, xyz, rotation, joint, tail } => {
                let parent_frame = match parent {
                    Some(p) => &frames[*p],
                    None => &base(),
                };
                let offset_rotation = mat_mul(&parent_frame.rotation, &constant_matrix(*rotation));
                let mut origin = vec_add(&parent_frame.origin, &mat_vec(&parent_frame.rotation, xyz));
                let rotation = match joint {
                    None => offset_rotation,
                    Some(j) => {
                        let (kind, axis) = model.coordinate_axis(*j);
                        match kind {
                            JointKind::Revolute => mat_mul(&offset_rotation, &axis_rotation(axis, dof(*j))),
                            JointKind::Prismatic => {
                                let q = Poly::atom(Atom::Q(dof(*j)));
                                let slide: Vec3 = axis.map(|a| q.scale(a));
                                origin = vec_add(&origin, &mat_vec(&offset_rotation, &slide));
                                offset_rotation
                            }
                        }
                    }
                };
                match tail {
                    None => Frame { origin, rotation },
                    Some(t) => Frame {
                        origin: vec_add(&origin, &mat_vec(&rotation, &t.xyz)),
                        rotation: mat_mul(&rotation, &constant_matrix(t.rotation)),
                    },
                }
            }
            Motion::Direct { origin_body, point, angle_joint } => {
                let carrier = match origin_body {
                    Some(b) => &frames[*b],
                    None => &base(),
                };
                Frame {
                    origin: vec_add(&carrier.origin, &mat_vec(&carrier.rotation, point)),
                    rotation: axis_rotation([0.0, 0.0, 1.0], dof(*angle_joint)),
                }
            }
        };
        frames.push(frame);
    }
    frames
}

/// Angular-velocity Jacobian columns of a frame with rotation `rotation` over `n`
/// coordinates: `vee(∂R/∂q_k · Rᵀ)` (the skew-symmetric `Ṙ Rᵀ = [ω]×`).
fn angular_jacobian_columns(rotation: &Mat3, n: usize) -> Vec<Vec3> {
    let rotation_t = transpose(rotation);
    (0..n)
        .map(|k| {
            let d_rotation: Mat3 = rotation.clone().map(|row| row.map(|p| p.diff_q(k as u16)));
            let w = mat_mul(&d_rotation, &rotation_t);
            [w[2][1].clone(), w[0][2].clone(), w[1][0].clone()]
        })
        .collect()
}

/// Rotation and angular-velocity Jacobian of named frame `index`, over all tree coordinates.
fn frame_kinematics(model: &Model, frames: &[Frame], index: usize) -> FrameKinematics {
    let frame = &model.frames[index];
    let n = model.tree_coordinates();
    let offset = constant_matrix(frame.rotation);
    let rotation = match frame.body {
        Some(b) => mat_mul(&frames[b].rotation, &offset),
        None => offset,
    };
    // The fixed offset does not change ω: ∂(R_b R_o)/∂q (R_b R_o)ᵀ = ∂R_b/∂q R_bᵀ.
    let columns = match frame.body {
        Some(b) => angular_jacobian_columns(&frames[b].rotation, n),
        None => vec![[Poly::zero(), Poly::zero(), Poly::zero()]; n],
    };
    FrameKinematics {
        name: frame.name.clone(),
        rotation: rotation.iter().map(|row| row.to_vec()).collect(),
        angular_jacobian: (0..3).map(|i| columns.iter().map(|c| c[i].clone()).collect()).collect(),
    }
}

/// The world position of named point `index` (2 or 3 entries) over all tree coordinates.
fn point_world(model: &Model, frames: &[Frame], index: usize) -> Vec<Poly> {
    let point = &model.points[index];
    let world = match point.body {
        Some(b) => vec_add(&frames[b].origin, &mat_vec(&frames[b].rotation, &point.position)),
        None => point.position.clone(),
    };
    world[..model.dim()].to_vec()
}

/// The world positions of every named point, polynomials over all coordinates of the open
/// tree (a closed chain's passive joints included).
pub fn point_positions(model: &Model) -> Vec<Vec<Poly>> {
    let frames = body_frames(model);
    (0..model.points.len()).map(|i| point_world(model, &frames, i)).collect()
}

/// Derives every quantity of the model as polynomials (what the evaluator, the simulator and
/// the checks use), and chooses the derivation of the emitted code.
pub fn derive(model: &Model) -> Mechanics {
    derive_with(model, true)
}

/// Derives what emission needs: on the recursive path the polynomials of `D`, `C`, `C q̇` and
/// `g` are not expanded at all (the emitter builds them recursively), which is what keeps
/// generation of long chains fast.
pub fn derive_for_emission(model: &Model) -> Mechanics {
    derive_with(model, false)
}

fn derive_with(model: &Model, all_polynomials: bool) -> Mechanics {
    let mut mechanics = derive_tree(model, all_polynomials);
    if let Some(closures) = &model.closures {
        // A closed chain: reduced to the actuated coordinates as polynomials (see
        // `crate::dynamics::closure`); the emitted code uses those polynomials as they are.
        return crate::dynamics::closure::reduce(mechanics, closures);
    }
    choose_derivations(model, &mut mechanics);
    mechanics
}

/// The mechanics of the open tree, in all coordinates.
fn derive_tree(model: &Model, all_polynomials: bool) -> Mechanics {
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
fn choose_derivations(model: &Model, mechanics: &mut Mechanics) {
    let both = [Derivation::Polynomial, Derivation::Recursive];
    let serial = recursive::applies(model);
    let dynamics: &[Derivation] = if !serial {
        &both[..1]
    } else if model.joints.len() >= RECURSIVE_FROM_JOINTS {
        &both[1..]
    } else {
        &both
    };
    let kinematics: &[Derivation] = if serial && mechanics.task_point.is_some() { &both } else { &both[..1] };
    let mut best: Option<(usize, Derivation, Derivation, bool)> = None;
    let options: Vec<(Derivation, bool)> = dynamics
        .iter()
        .flat_map(
            |&d| if d == Derivation::Polynomial { vec![(d, false), (d, true)] } else { vec![(d, false)] },
        )
        .collect();
    for &(d, structured) in &options {
        for &k in kinematics {
            mechanics.derivation = d;
            mechanics.kinematics = k;
            mechanics.structured_coriolis = structured;
            let mut dag = Dag::new();
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

/// `D` from the kinetic energy of every body plus the reflected rotor inertias.
fn lagrangian_inertia_matrix(model: &Model, frames: &[Frame]) -> Vec<Vec<Poly>> {
    let n = model.tree_coordinates();
    let dof = |j: usize| j as u16;
    let mut inertia_terms: Vec<Vec<Vec<Poly>>> = vec![vec![Vec::new(); n]; n];
    for (body, frame) in model.bodies.iter().zip(frames) {
        let com_world = vec_add(&frame.origin, &mat_vec(&frame.rotation, &body.com));
        let linear: Vec<Vec3> =
            (0..n).map(|k| std::array::from_fn(|i| com_world[i].diff_q(dof(k)))).collect();
        // Angular-velocity Jacobian columns: vee(∂R/∂q_k · Rᵀ).
        let rotation_t = transpose(&frame.rotation);
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
            if let (true, Some(joint)) = (a == b, model.joints.get(a)) {
                let drive = &joint.drive;
                entry = entry
                    .add(&Poly::constant(drive.gear_ratio * drive.gear_ratio * drive.motor.rotor_inertia));
            }
            inertia_matrix[a][b] = entry.clone();
            inertia_matrix[b][a] = entry;
        }
    }
    inertia_matrix
}

/// `C` from the Christoffel symbols of `D`, and `C q̇`.
fn christoffel(inertia_matrix: &[Vec<Poly>]) -> (Vec<Vec<Poly>>, Vec<Poly>) {
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

impl Mechanics {
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
        let mut out = Vec::new();
        for dynamics in [Derivation::Polynomial, Derivation::Recursive] {
            for kinematics in [Derivation::Polynomial, Derivation::Recursive] {
                for structured_coriolis in [false, true] {
                    let ok = match dynamics {
                        Derivation::Polynomial => polynomial_dynamics,
                        Derivation::Recursive => serial && !structured_coriolis,
                    } && (kinematics == Derivation::Polynomial || serial)
                        && (!structured_coriolis || self.closures.is_none());
                    if ok {
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
        let recursive = match quantity {
            Quantity::Point(..) | Quantity::Frame(..) => choice.kinematics == Derivation::Recursive,
            _ => choice.dynamics == Derivation::Recursive,
        };
        if recursive {
            return recursive::build(dag, model, quantity);
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
