//! The baseline a user would write instead of generated code for a serial chain: a generic
//! implementation of a spatial rigid-body tree's dynamics and point kinematics on nalgebra,
//! evaluated at run time with the textbook algorithms.
//!
//! - **Inverse dynamics** by the recursive Newton–Euler algorithm (Luh, Walker and Paul; the
//!   form of Craig's or Siciliano's textbooks, with every vector in base coordinates): a
//!   forward pass propagates each body's angular velocity `ω`, angular acceleration `ω̇` and
//!   the linear acceleration of its frame's origin from the base outwards, with gravity
//!   entered as an upward acceleration `−g⃗` of the base; a backward pass sums, from the tips
//!   inwards, the force `m a_c` and the moment `I ω̇ + ω × I ω` about each centre of mass into
//!   the force and moment each joint transmits, and projects them on the joint's axis. With
//!   `q̈ = 0` and no gravity it gives `C(q, q̇) q̇`; with `q̇ = q̈ = 0` it gives `g(q)`.
//! - **Inertia matrix** by the composite-rigid-body algorithm: the mass, first moment and
//!   inertia about the base origin of every subtree, accumulated from the tips inwards; column
//!   `j` of `D` is the momentum the subtree behind joint `j` takes for a unit `q̇_j`, projected
//!   on the motion subspaces of joint `j` and of every joint between it and the base.
//! - **Task point** `p` by composing the body frames; its geometric Jacobian's columns
//!   `z_k × (p − o_k)` (revolute) or `z_k` (prismatic) for the joints between it and the base;
//!   `J̇ q̇` as the point's acceleration from the Newton–Euler forward pass at `q̈ = 0` without
//!   gravity.
//!
//! The reflected rotor inertia `N² J_m` of each drive is added to `D`'s diagonal and, as
//! `N² J_m q̈`, to the inverse dynamics, as the generated code does; viscous damping is not
//! part of any of these quantities.
//!
//! A body frame is `parent · Trans(xyz) · rotation · joint(q) · tail` (the model's resolved
//! [`Motion::Serial`]); the joint turns about, or slides along, its axis given in the frame
//! before it. The model is read once, its constant parameters evaluated at their nominal
//! values; every quantity is then computed numerically, with no code generation involved,
//! so that this is an independent check of the generated code (`tests/tests/baseline.rs`) and
//! the side-by-side reference of the benchmarks (`tests/benches/dynamics.rs`).
#![warn(missing_docs)]

use hapticgen_codegen::model::{JointKind, Model, Motion, TaskSpec};
use hapticgen_codegen::sym::poly::{Atom, AtomValues, Poly};
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Unit, Vector3};

use crate::baseline::BaselineTerms;

/// The model's tunable parameters at their nominal values; any other atom (a joint
/// coordinate) in what should be a constant gives NaN, which the comparisons then catch.
struct Nominal<'a>(&'a [f64]);

impl AtomValues for Nominal<'_> {
    fn value(&self, atom: Atom) -> f64 {
        match atom {
            Atom::Param(k) => self.0.get(usize::from(k)).copied().unwrap_or(f64::NAN),
            _ => f64::NAN,
        }
    }
}

/// A joint of the chain: its coordinate, kind and unit axis in the frame before it.
#[derive(Clone, Copy, Debug)]
struct Joint {
    index: usize,
    kind: JointKind,
    axis: Unit<Vector3<f64>>,
}

/// One rigid body with the transform from its parent's frame.
#[derive(Clone, Debug)]
struct Link {
    parent: Option<usize>,
    /// Translation from the parent frame's origin to the joint, in the parent frame.
    offset: Vector3<f64>,
    /// Fixed rotation from the parent frame to the frame before the joint.
    rotation: Matrix3<f64>,
    joint: Option<Joint>,
    /// Fixed translation and rotation after the joint (standard Denavit–Hartenberg links).
    tail_offset: Vector3<f64>,
    tail_rotation: Matrix3<f64>,
    mass: f64,
    /// Centre of mass in the body frame.
    com: Vector3<f64>,
    /// Inertia tensor about the centre of mass, body axes.
    inertia: Matrix3<f64>,
}

/// Where one body is at a configuration, in base coordinates.
#[derive(Clone, Copy, Debug)]
struct Pose {
    /// Orientation of the body frame.
    rotation: Matrix3<f64>,
    /// Origin of the body frame.
    origin: Vector3<f64>,
    /// The joint's point: the origin of the frame just before the joint, on its axis.
    pivot: Vector3<f64>,
    /// The joint's axis (unit), zero for a welded body.
    axis: Vector3<f64>,
}

/// Velocities and accelerations of one body from the Newton–Euler forward pass.
#[derive(Clone, Copy, Debug)]
struct BodyMotion {
    omega: Vector3<f64>,
    omega_dot: Vector3<f64>,
    /// Linear acceleration of the body frame's origin.
    accel: Vector3<f64>,
}

/// The task coordinates.
#[derive(Clone, Debug)]
enum Task {
    /// A point fixed in a body (`None`: the base), position in that body's frame.
    Point { body: Option<usize>, position: Vector3<f64> },
    /// Joint coordinates.
    Joints(Vec<usize>),
}

/// A serial (open-tree) rig on nalgebra: recursive Newton–Euler, composite rigid bodies and
/// geometric Jacobians, evaluated at run time.
#[derive(Clone, Debug)]
pub struct SerialBaseline {
    n: usize,
    /// Rows of the task point's position and Jacobian (2 for planar models, 3 for spatial).
    dim: usize,
    links: Vec<Link>,
    task: Task,
    gravity: Vector3<f64>,
    damping: DVector<f64>,
    rotor: DMatrix<f64>,
}

fn vector(p: &[Poly; 3], at: &Nominal<'_>) -> Vector3<f64> {
    Vector3::new(p[0].eval(at), p[1].eval(at), p[2].eval(at))
}

fn matrix(m: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| m[i][j])
}

/// Bodies from `body` to the base, `body` first.
fn path_to_base(links: &[Link], body: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    std::iter::successors(body, |&b| links[b].parent)
}

impl SerialBaseline {
    /// Builds the baseline of a model whose bodies all move serially (every body hangs off
    /// its parent through at most one joint); `None` for direct poses and closed chains.
    pub fn new(model: &Model) -> Option<Self> {
        if !model.passive.is_empty() || !model.closures.is_empty() {
            return None;
        }
        let parameters = model.nominal_parameters();
        let at = Nominal(&parameters);
        let mut links = Vec::with_capacity(model.bodies.len());
        for body in &model.bodies {
            let Motion::Serial { parent, xyz, rotation, joint, tail } = &body.motion else {
                return None;
            };
            let joint = joint.map(|j| {
                let spec = &model.joints[j];
                Joint {
                    index: j,
                    kind: spec.kind,
                    axis: Unit::new_normalize(Vector3::new(spec.axis[0], spec.axis[1], spec.axis[2])),
                }
            });
            let (tail_offset, tail_rotation) = match tail {
                Some(t) => (vector(&t.xyz, &at), matrix(&t.rotation)),
                None => (Vector3::zeros(), Matrix3::identity()),
            };
            links.push(Link {
                parent: *parent,
                offset: vector(xyz, &at),
                rotation: matrix(rotation),
                joint,
                tail_offset,
                tail_rotation,
                mass: body.mass.eval(&at),
                com: vector(&body.com, &at),
                inertia: Matrix3::from_fn(|i, j| body.inertia[i][j].eval(&at)),
            });
        }
        let task = match &model.task {
            TaskSpec::Point(i) => {
                let point = &model.points[*i];
                Task::Point { body: point.body, position: vector(&point.position, &at) }
            }
            TaskSpec::Joints(joints) => Task::Joints(joints.clone()),
        };
        let n = model.joints.len();
        Some(SerialBaseline {
            n,
            dim: model.dim(),
            links,
            task,
            gravity: vector(&model.gravity, &at),
            damping: DVector::from_iterator(n, model.joints.iter().map(|j| j.damping.eval(&at))),
            rotor: crate::baseline::rotor_inertias(model),
        })
    }

    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.n
    }

    /// Diagonal of `B`.
    pub fn damping(&self) -> &DVector<f64> {
        &self.damping
    }

    /// Every body's frame and joint axis in base coordinates (forward kinematics).
    fn poses(&self, q: &DVector<f64>) -> Vec<Pose> {
        let mut poses: Vec<Pose> = Vec::with_capacity(self.links.len());
        for link in &self.links {
            let (parent_rotation, parent_origin) = match link.parent {
                Some(p) => (poses[p].rotation, poses[p].origin),
                None => (Matrix3::identity(), Vector3::zeros()),
            };
            let pivot = parent_origin + parent_rotation * link.offset;
            let before = parent_rotation * link.rotation;
            let (after, slide, axis) = match link.joint {
                None => (before, Vector3::zeros(), Vector3::zeros()),
                Some(j) => {
                    let axis = before * j.axis.into_inner();
                    match j.kind {
                        JointKind::Revolute => (
                            before * Rotation3::from_axis_angle(&j.axis, q[j.index]).into_inner(),
                            Vector3::zeros(),
                            axis,
                        ),
                        JointKind::Prismatic => (before, axis * q[j.index], axis),
                    }
                }
            };
            poses.push(Pose {
                rotation: after * link.tail_rotation,
                origin: pivot + slide + after * link.tail_offset,
                pivot,
                axis,
            });
        }
        poses
    }

    /// The Newton–Euler forward pass: `ω`, `ω̇` and the origin's acceleration of every body
    /// for joint rates `qd` and accelerations `qdd` (`None`: zero), the base accelerating at
    /// `base_accel`.
    fn forward(
        &self,
        poses: &[Pose],
        qd: &DVector<f64>,
        qdd: Option<&DVector<f64>>,
        base_accel: Vector3<f64>,
    ) -> Vec<BodyMotion> {
        let mut motions: Vec<BodyMotion> = Vec::with_capacity(self.links.len());
        for (i, link) in self.links.iter().enumerate() {
            let pose = &poses[i];
            let (parent, parent_origin) = match link.parent {
                Some(p) => (motions[p], poses[p].origin),
                None => (
                    BodyMotion { omega: Vector3::zeros(), omega_dot: Vector3::zeros(), accel: base_accel },
                    Vector3::zeros(),
                ),
            };
            // A point fixed in the parent body: a = a_p + ω̇_p × r + ω_p × (ω_p × r).
            let carried = |point: Vector3<f64>| {
                let r = point - parent_origin;
                parent.accel + parent.omega_dot.cross(&r) + parent.omega.cross(&parent.omega.cross(&r))
            };
            let motion = match link.joint {
                None => BodyMotion { accel: carried(pose.origin), ..parent },
                Some(j) => {
                    let rate = qd[j.index];
                    let accel = qdd.map_or(0.0, |a| a[j.index]);
                    let z = pose.axis;
                    match j.kind {
                        JointKind::Revolute => {
                            let omega = parent.omega + z * rate;
                            let omega_dot = parent.omega_dot + z * accel + parent.omega.cross(&(z * rate));
                            let r = pose.origin - pose.pivot;
                            BodyMotion {
                                omega,
                                omega_dot,
                                accel: carried(pose.pivot)
                                    + omega_dot.cross(&r)
                                    + omega.cross(&omega.cross(&r)),
                            }
                        }
                        JointKind::Prismatic => BodyMotion {
                            accel: carried(pose.origin) + parent.omega.cross(&z) * (2.0 * rate) + z * accel,
                            ..parent
                        },
                    }
                }
            };
            motions.push(motion);
        }
        motions
    }

    /// The Newton–Euler backward pass: joint forces from the bodies' motions (the rotor
    /// inertias' `N² J_m q̈` added when `qdd` is given).
    fn backward(&self, poses: &[Pose], motions: &[BodyMotion], qdd: Option<&DVector<f64>>) -> DVector<f64> {
        let bodies = self.links.len();
        // Force and moment (about the body's pivot) that each body's joint transmits to it.
        let mut force = vec![Vector3::zeros(); bodies];
        let mut moment = vec![Vector3::zeros(); bodies];
        let mut tau = DVector::zeros(self.n);
        for i in (0..bodies).rev() {
            let (link, pose, m) = (&self.links[i], &poses[i], &motions[i]);
            let r = pose.rotation * link.com;
            let com_accel = m.accel + m.omega_dot.cross(&r) + m.omega.cross(&m.omega.cross(&r));
            let inertia = pose.rotation * link.inertia * pose.rotation.transpose();
            let f = com_accel * link.mass;
            let n = inertia * m.omega_dot + m.omega.cross(&(inertia * m.omega));
            force[i] += f;
            moment[i] += n + (pose.origin + r - pose.pivot).cross(&f);
            if let Some(j) = link.joint {
                tau[j.index] = match j.kind {
                    JointKind::Revolute => pose.axis.dot(&moment[i]),
                    JointKind::Prismatic => pose.axis.dot(&force[i]),
                } + qdd.map_or(0.0, |a| self.rotor.row(j.index).dot(&a.transpose()));
            }
            if let Some(p) = link.parent {
                let (fi, ni) = (force[i], moment[i]);
                force[p] += fi;
                moment[p] += ni + (pose.pivot - poses[p].pivot).cross(&fi);
            }
        }
        tau
    }

    /// `τ = D(q) q̈ + C(q, q̇) q̇ + g(q)` by the recursive Newton–Euler algorithm.
    pub fn inverse_dynamics(&self, q: &DVector<f64>, qd: &DVector<f64>, qdd: &DVector<f64>) -> DVector<f64> {
        let poses = self.poses(q);
        let motions = self.forward(&poses, qd, Some(qdd), -self.gravity);
        self.backward(&poses, &motions, Some(qdd))
    }

    /// `D(q)` by the composite-rigid-body algorithm, with the rotor inertias on the diagonal.
    pub fn inertia_matrix(&self, q: &DVector<f64>) -> DMatrix<f64> {
        self.crba(&self.poses(q))
    }

    fn crba(&self, poses: &[Pose]) -> DMatrix<f64> {
        let bodies = self.links.len();
        // Each subtree's mass, first moment Σ m c and inertia about the base origin.
        let mut mass = vec![0.0; bodies];
        let mut first = vec![Vector3::zeros(); bodies];
        let mut inertia = vec![Matrix3::zeros(); bodies];
        for i in (0..bodies).rev() {
            let (link, pose) = (&self.links[i], &poses[i]);
            let c = pose.origin + pose.rotation * link.com;
            mass[i] += link.mass;
            first[i] += c * link.mass;
            inertia[i] += pose.rotation * link.inertia * pose.rotation.transpose()
                + (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * link.mass;
            if let Some(p) = link.parent {
                let (m, h, i_o) = (mass[i], first[i], inertia[i]);
                mass[p] += m;
                first[p] += h;
                inertia[p] += i_o;
            }
        }
        let mut d = self.rotor.clone();
        for (b, link) in self.links.iter().enumerate() {
            let Some(joint) = link.joint else { continue };
            let pose = &poses[b];
            // The subtree's momentum (linear L, angular H about the base origin) for q̇_j = 1.
            let (omega, v_origin) = match joint.kind {
                JointKind::Revolute => (pose.axis, pose.pivot.cross(&pose.axis)),
                JointKind::Prismatic => (Vector3::zeros(), pose.axis),
            };
            let linear = v_origin * mass[b] + omega.cross(&first[b]);
            let angular = first[b].cross(&v_origin) + inertia[b] * omega;
            for k in path_to_base(&self.links, Some(b)) {
                let Some(other) = self.links[k].joint else { continue };
                let ancestor = &poses[k];
                let entry = match other.kind {
                    JointKind::Revolute => ancestor.axis.dot(&(angular - ancestor.pivot.cross(&linear))),
                    JointKind::Prismatic => ancestor.axis.dot(&linear),
                };
                d[(other.index, joint.index)] += entry;
                if other.index != joint.index {
                    d[(joint.index, other.index)] += entry;
                }
            }
        }
        d
    }

    /// `C(q, q̇) q̇`: the recursive Newton–Euler algorithm at `q̈ = 0` without gravity.
    pub fn coriolis_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        let poses = self.poses(q);
        let motions = self.forward(&poses, qd, None, Vector3::zeros());
        self.backward(&poses, &motions, None)
    }

    /// `g(q)`: the recursive Newton–Euler algorithm at `q̇ = q̈ = 0`.
    pub fn gravity(&self, q: &DVector<f64>) -> DVector<f64> {
        let poses = self.poses(q);
        self.gravity_at(&poses)
    }

    fn gravity_at(&self, poses: &[Pose]) -> DVector<f64> {
        let motions = self.forward(poses, &DVector::zeros(self.n), None, -self.gravity);
        self.backward(poses, &motions, None)
    }

    /// The task point in base coordinates (3 entries), or `None` for joint-space tasks.
    fn point(&self, poses: &[Pose]) -> Option<(Option<usize>, Vector3<f64>)> {
        match &self.task {
            Task::Point { body: Some(b), position } => {
                Some((Some(*b), poses[*b].origin + poses[*b].rotation * position))
            }
            Task::Point { body: None, position } => Some((None, *position)),
            Task::Joints(_) => None,
        }
    }

    fn position_at(&self, q: &DVector<f64>, poses: &[Pose]) -> DVector<f64> {
        match (&self.task, self.point(poses)) {
            (Task::Joints(joints), _) => DVector::from_iterator(joints.len(), joints.iter().map(|&j| q[j])),
            (_, Some((_, p))) => DVector::from_column_slice(&p.as_slice()[..self.dim]),
            (_, None) => unreachable!("a point task has a point"),
        }
    }

    fn jacobian_at(&self, poses: &[Pose]) -> DMatrix<f64> {
        match (&self.task, self.point(poses)) {
            (Task::Joints(joints), _) => {
                DMatrix::from_fn(joints.len(), self.n, |r, c| if joints[r] == c { 1.0 } else { 0.0 })
            }
            (_, Some((body, p))) => {
                let mut jacobian = DMatrix::zeros(self.dim, self.n);
                for b in path_to_base(&self.links, body) {
                    let Some(joint) = self.links[b].joint else { continue };
                    let pose = &poses[b];
                    let column = match joint.kind {
                        JointKind::Revolute => pose.axis.cross(&(p - pose.pivot)),
                        JointKind::Prismatic => pose.axis,
                    };
                    for r in 0..self.dim {
                        jacobian[(r, joint.index)] = column[r];
                    }
                }
                jacobian
            }
            (_, None) => unreachable!("a point task has a point"),
        }
    }

    /// `J̇ q̇` from the forward pass at `q̈ = 0` without gravity (`motions`).
    fn jacobian_dot_times_qdot_at(&self, poses: &[Pose], motions: &[BodyMotion]) -> DVector<f64> {
        match (&self.task, self.point(poses)) {
            (Task::Joints(joints), _) => DVector::zeros(joints.len()),
            (_, Some((None, _))) => DVector::zeros(self.dim),
            (_, Some((Some(b), p))) => {
                let m = &motions[b];
                let r = p - poses[b].origin;
                let a = m.accel + m.omega_dot.cross(&r) + m.omega.cross(&m.omega.cross(&r));
                DVector::from_column_slice(&a.as_slice()[..self.dim])
            }
            (_, None) => unreachable!("a point task has a point"),
        }
    }

    /// The potential energy `V(q) = −Σ m_i g⃗ · c_i(q)` of gravity, with `c_i` each body's
    /// centre of mass in base coordinates.
    pub fn potential_energy(&self, q: &DVector<f64>) -> f64 {
        let poses = self.poses(q);
        self.links
            .iter()
            .zip(&poses)
            .map(|(link, pose)| -link.mass * self.gravity.dot(&(pose.origin + pose.rotation * link.com)))
            .sum()
    }

    /// `p(q)`.
    pub fn position(&self, q: &DVector<f64>) -> DVector<f64> {
        self.position_at(q, &self.poses(q))
    }

    /// `J(q)`: the task point's geometric (positional) Jacobian.
    pub fn jacobian(&self, q: &DVector<f64>) -> DMatrix<f64> {
        self.jacobian_at(&self.poses(q))
    }

    /// `J̇(q, q̇) q̇`.
    pub fn jacobian_dot_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        let poses = self.poses(q);
        let motions = self.forward(&poses, qd, None, Vector3::zeros());
        self.jacobian_dot_times_qdot_at(&poses, &motions)
    }

    /// Everything one tick needs, sharing the forward kinematics and the velocity pass:
    /// one pose pass, CRBA, one Newton–Euler pass without gravity (`C q̇`, `J̇ q̇`) and one
    /// with only gravity (`g`).
    pub fn terms(&self, q: &DVector<f64>, qd: &DVector<f64>) -> BaselineTerms {
        let poses = self.poses(q);
        let motions = self.forward(&poses, qd, None, Vector3::zeros());
        BaselineTerms {
            inertia_matrix: self.crba(&poses),
            coriolis_times_qdot: self.backward(&poses, &motions, None),
            gravity: self.gravity_at(&poses),
            position: self.position_at(q, &poses),
            jacobian: self.jacobian_at(&poses),
            jacobian_dot_times_qdot: self.jacobian_dot_times_qdot_at(&poses, &motions),
        }
    }

    /// Controller 3 on nalgebra: `u = C q̇ + B q̇ + g − Jᵀ(B_d ẋ̃ + K_d x̃)` (eq. (12) in
    /// eq. (3)), for a reference at rest.
    pub fn jacobian_transpose(
        &self,
        terms: &BaselineTerms,
        qd: &DVector<f64>,
        reference: &DVector<f64>,
        stiffness: &DVector<f64>,
        damping: &DVector<f64>,
    ) -> DVector<f64> {
        crate::baseline::jacobian_transpose(terms, &self.damping, qd, reference, stiffness, damping)
    }
}
