//! Recursive rigid-body algorithms run symbolically on the expression DAG: the second
//! derivation path of eq. (1), for models whose bodies form a tree of joints.
//!
//! The polynomial path ([`crate::dynamics::mechanics`]) expands every quantity into a canonical polynomial
//! in the sines and cosines of the joint angles. That gives the smallest code for short chains
//! (the sin² + cos² = 1 and angle-sum simplifications are complete), but for long spatial chains
//! the expanded `D` and, above all, the Christoffel form of `C q̇` grow exponentially. The
//! algorithms here keep the intermediate quantities factored instead, building one DAG node per
//! arithmetic operation with constants folded and common subexpressions shared:
//!
//! * the recursive Newton–Euler algorithm (Luh, Walker and Paul 1980; Featherstone,
//!   *Rigid Body Dynamics Algorithms*, ch. 5) for the inverse dynamics
//!   `τ = D(q) q̈ + C(q, q̇) q̇ + g(q)` of eq. (1), for `C q̇` (q̈ = 0, no gravity) and for `g`
//!   (q̇ = q̈ = 0): O(n) operations;
//! * the composite-rigid-body algorithm (Walker and Orin 1982; Featherstone ch. 6) for `D`:
//!   O(n²) operations;
//! * `C(q, q̇)` from the Christoffel symbols of that `D`, differentiated on the DAG.
//!
//! Every body's quantities are expressed in its *joint frame* (the frame after the fixed origin
//! transform and the joint, before a Denavit–Hartenberg tail), so masses, first moments
//! `h = m c` and inertias about the frame origin are constants; a body's tail is folded into
//! its children's fixed offsets at generation time. The rotor inertia `N² J_m` of each drive
//! enters `D`'s diagonal and the inverse dynamics as in the polynomial path (a coupling's
//! `Cᵀ diag(N² J_m) C` also off the diagonal).

use rustc_hash::FxHashMap as HashMap;

use super::lagrangian::reflected_rotor_inertia;
use crate::math::matrix::{mat3_mul, mat3_vec, Numbers, IDENTITY};
use crate::math::rotation::snap_entry;
use crate::model::{JointKind, Model, Motion};
use crate::sym::dag::{Dag, Node, NodeId};
use crate::sym::poly::{Atom, Poly};

/// A quantity the recursive path can build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// `D(q)`, row-major.
    InertiaMatrix,
    /// `C(q, q̇)`, row-major.
    CoriolisMatrix,
    /// `C(q, q̇) q̇`.
    CoriolisTimesQdot,
    /// `g(q)`.
    Gravity,
    /// `D(q) q̈ + C(q, q̇) q̇ + g(q)`, with `q̈` the inputs [`Atom::Qdd`].
    InverseDynamics,
    /// Kinematics of the named point with this index.
    Point(usize, PointQuantity),
    /// Orientation or angular-velocity Jacobian of the named frame with this index.
    Frame(usize, FrameQuantity),
}

/// Orientation or angular-velocity Jacobian of a named frame (`Model::frames`), in the base
/// frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameQuantity {
    /// `R(q)`, from the frame to the base frame, row-major.
    Orientation,
    /// `J_ω(q)` with `ω = J_ω q̇`, row-major: the joint axes `z_k` of the revolute joints
    /// between the frame and the base, zero columns for prismatic joints.
    AngularJacobian,
}

/// Position, Jacobian or `J̇ q̇` of the named point with this index (`Model::points`), in the
/// base frame, by composing the joint frames (`J`'s columns `z_k × (p − o_k)` for revolute and
/// `z_k` for prismatic joints; `J̇ q̇` the point's acceleration from the forward pass at
/// `q̈ = 0` without gravity).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PointQuantity {
    /// `p(q)`.
    Position,
    /// `J(q)`, row-major.
    Jacobian,
    /// `J̇(q, q̇) q̇`.
    JacobianDotTimesQdot,
}

/// Whether the recursive algorithms apply: every body hangs from its parent (or the base) by
/// one joint or a weld, and no loop closes. Direct poses (closed chains written as absolute
/// angles) and closures (reduced as polynomials, see `crate::dynamics::closure`) do not, nor
/// do measured joints (their frames take the measured angles: the polynomial kinematics) or
/// mimic joints (one coordinate turning two joints).
pub fn applies(model: &Model) -> bool {
    model.passive.is_empty()
        && model.measured.is_empty()
        && model.mimic.is_empty()
        && model.bodies.iter().all(|b| matches!(b.motion, Motion::Serial { .. }))
}

type V3 = [NodeId; 3];
type M3 = [[NodeId; 3]; 3];

/// Constant data of one body in its joint frame.
struct Link {
    /// The body's name in the model, for the names of its values in the emitted code.
    name: String,
    parent: Option<usize>,
    /// Rotation from the parent's joint frame to this joint frame, before the joint.
    offset_rotation: [[f64; 3]; 3],
    /// Origin of this joint frame in the parent's joint frame, before a prismatic slide.
    offset: [Poly; 3],
    /// Joint index, kind and unit axis (in this joint frame).
    joint: Option<(usize, JointKind, [f64; 3])>,
    mass: Poly,
    /// First moment `m c` about the joint-frame origin.
    first_moment: [Poly; 3],
    /// Inertia about the joint-frame origin, joint-frame axes.
    inertia: [[Poly; 3]; 3],
    /// Centre of mass in the joint frame.
    com: [Poly; 3],
    /// Inertia about the centre of mass, joint-frame axes.
    central_inertia: [[Poly; 3]; 3],
    /// The body frame in the joint frame (a Denavit–Hartenberg tail; identity otherwise).
    tail: ([[f64; 3]; 3], [Poly; 3]),
}

/// How a point's Jacobian is built: in the base frame or in its chain's root joint frame (then
/// turned once per column), with the columns `z_k × (p − o_k)` from the frames' origins or
/// each in its own joint frame (`Recursion::local_jacobian_columns`). The cheapest is chosen
/// per point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JacobianForm {
    /// Build in the root body's joint frame, then turn into the base frame.
    pub in_root_frame: bool,
    /// Build each column in its own joint frame.
    pub local_columns: bool,
}

/// How the Newton–Euler equations and the composite inertias are written; the cheapest is
/// chosen per model (see [`formulation`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Formulation {
    /// About each joint-frame origin with the first moment `h = m c`.
    AboutOrigin,
    /// About each centre of mass.
    AboutCom,
    /// About each joint-frame origin, with the inertial parameters regrouped first
    /// (`regroup`, Khalil and Kleinfinger's base inertial parameters).
    Regrouped,
}

/// Moves to each body's parent the part of its inertial parameters that joint motion cannot
/// reveal (the regrouping of Khalil and Kleinfinger's base inertial parameters, 1987, done
/// numerically in the joint frames), so that the recursions carry fewer non-zero parameters.
///
/// Every body is taken from the tip to the base, in the linear parametrisation (mass `m`, first
/// moment `h`, inertia `J` about the joint-frame origin) in which kinetic energy
/// `½ m v² + v · (ω × h) + ½ ωᵀ J ω` and potential energy are linear:
/// * behind a revolute joint with unit axis `a` (the frame origin lies on it), the mass, the
///   first moment along the axis `(h·a) a` and, for a coordinate axis `a = e_k`, the inertia
///   `λ (1 − a aᵀ)` with `λ = J_ii` of the axis `i` after `k` in the cycle z → x → y (Khalil's
///   `YY`) contribute the same energy whether carried by the body or by its parent, because
///   the origin's velocity and `ω × a` and `|ω × a|²` are the same for both;
/// * behind a prismatic joint the body turns with its parent, so the whole `J` moves;
/// * a welded body moves whole.
///
/// What a body hands to the fixed base contributes no energy that changes and is dropped.
/// The equations of motion are unchanged; only the parameters that enter them are fewer.
fn regroup(links: &mut [Link]) {
    let zero3 = || [Poly::zero(), Poly::zero(), Poly::zero()];
    for i in (0..links.len()).rev() {
        let link = &mut links[i];
        let (mass, first_moment, inertia) = match link.joint {
            None => (
                std::mem::replace(&mut link.mass, Poly::zero()),
                std::mem::replace(&mut link.first_moment, zero3()),
                std::mem::replace(&mut link.inertia, std::array::from_fn(|_| zero3())),
            ),
            Some((_, JointKind::Prismatic, _)) => (
                Poly::zero(),
                zero3(),
                std::mem::replace(&mut link.inertia, std::array::from_fn(|_| zero3())),
            ),
            Some((_, JointKind::Revolute, axis)) => {
                let along =
                    Poly::sum(&(0..3).map(|k| link.first_moment[k].scale(axis[k])).collect::<Vec<_>>());
                let moved_moment: [Poly; 3] = std::array::from_fn(|k| along.scale(axis[k]));
                for (h, moved) in link.first_moment.iter_mut().zip(&moved_moment) {
                    *h = h.sub(moved);
                }
                let lambda = match (0..3).find(|&k| axis[k].abs() == 1.0) {
                    Some(k) => {
                        let i = (k + 2) % 3;
                        link.inertia[i][i].clone()
                    }
                    None => Poly::zero(),
                };
                let moved_inertia: [[Poly; 3]; 3] = std::array::from_fn(|r| {
                    std::array::from_fn(|c| {
                        let delta = if r == c { 1.0 } else { 0.0 };
                        lambda.scale(delta - axis[r] * axis[c])
                    })
                });
                for (row, moved_row) in link.inertia.iter_mut().zip(&moved_inertia) {
                    for (entry, moved) in row.iter_mut().zip(moved_row) {
                        *entry = entry.sub(moved);
                    }
                }
                (std::mem::replace(&mut link.mass, Poly::zero()), moved_moment, moved_inertia)
            }
        };
        let Some(parent) = links[i].parent else { continue };
        let rotation = links[i].offset_rotation;
        let offset = links[i].offset.clone();
        // The moved part in the parent's joint frame, about its origin: h' = E h + m p and
        // J' = E J Eᵀ + (2 h·p + m|p|²) 1 − h pᵀ − p hᵀ − m p pᵀ with h = E h (see
        // `Recursion::inertia_matrix`).
        let h = const_mat_poly_vec(&rotation, &first_moment);
        let h_dot_p = Poly::sum(&(0..3).map(|k| h[k].mul(&offset[k])).collect::<Vec<_>>());
        let p_sq = Poly::sum(&(0..3).map(|k| offset[k].mul(&offset[k])).collect::<Vec<_>>());
        let diagonal = h_dot_p.scale(2.0).add(&mass.mul(&p_sq));
        let target = &mut links[parent];
        target.mass = target.mass.add(&mass);
        for k in 0..3 {
            target.first_moment[k] = target.first_moment[k].add(&h[k]).add(&mass.mul(&offset[k]));
        }
        for r in 0..3 {
            for c in 0..3 {
                let mut rotated = Vec::new();
                for k in 0..3 {
                    for l in 0..3 {
                        let w = rotation[r][k] * rotation[c][l];
                        if w != 0.0 {
                            rotated.push(inertia[k][l].scale(w));
                        }
                    }
                }
                let mut value = Poly::sum(&rotated)
                    .sub(&h[r].mul(&offset[c]))
                    .sub(&offset[r].mul(&h[c]))
                    .sub(&mass.mul(&offset[r].mul(&offset[c])));
                if r == c {
                    value = value.add(&diagonal);
                }
                target.inertia[r][c] = target.inertia[r][c].add(&value);
            }
        }
    }
}

fn const_mat_poly_vec(a: &[[f64; 3]; 3], v: &[Poly; 3]) -> [Poly; 3] {
    std::array::from_fn(|i| Poly::sum(&(0..3).map(|k| v[k].scale(a[i][k])).collect::<Vec<_>>()))
}

fn links(model: &Model) -> Vec<Link> {
    let zero = || [Poly::zero(), Poly::zero(), Poly::zero()];
    // Each body's tail (the fixed transform after its joint), to be folded into its children.
    let tails: Vec<([[f64; 3]; 3], [Poly; 3])> = model
        .bodies
        .iter()
        .map(|b| match &b.motion {
            Motion::Serial { tail: Some(t), .. } => (t.rotation, t.xyz.clone()),
            _ => (IDENTITY, zero()),
        })
        .collect();
    model
        .bodies
        .iter()
        .enumerate()
        .map(|(index, body)| {
            let Motion::Serial { parent, xyz, rotation, joint, .. } = &body.motion else {
                unreachable!("recursive::applies was checked")
            };
            // Parent tail, then this body's origin transform.
            let (parent_rotation, parent_offset) = match parent {
                Some(p) => tails[*p].clone(),
                None => (IDENTITY, zero()),
            };
            let offset_rotation = mat3_mul(&mut Numbers, &parent_rotation, rotation);
            let rotated = const_mat_poly_vec(&parent_rotation, xyz);
            let offset = std::array::from_fn(|i| parent_offset[i].add(&rotated[i]));
            let joint = joint.map(|j| (j, model.joints[j].kind, model.joints[j].axis));
            // Centre of mass and inertia, from the body frame to the joint frame.
            let (tail_rotation, tail_offset) = &tails[index];
            let com_rotated = const_mat_poly_vec(tail_rotation, &body.com);
            let com: [Poly; 3] = std::array::from_fn(|i| tail_offset[i].add(&com_rotated[i]));
            let mass = body.mass.clone();
            let first_moment = com.clone().map(|c| mass.mul(&c));
            // R I Rᵀ + m (|c|² 1 − c cᵀ): the parallel-axis theorem about the frame origin.
            let rotated_inertia: [[Poly; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let mut terms = Vec::new();
                    for k in 0..3 {
                        for l in 0..3 {
                            let w = tail_rotation[i][k] * tail_rotation[j][l];
                            if w != 0.0 {
                                terms.push(body.inertia[k][l].scale(w));
                            }
                        }
                    }
                    Poly::sum(&terms)
                })
            });
            let com_sq = Poly::sum(&com.iter().map(|c| c.mul(c)).collect::<Vec<_>>());
            let inertia = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let shift = if i == j {
                        com_sq.sub(&com[i].mul(&com[j]))
                    } else {
                        com[i].mul(&com[j]).scale(-1.0)
                    };
                    rotated_inertia[i][j].add(&mass.mul(&shift))
                })
            });
            Link {
                name: body.name.clone(),
                parent: *parent,
                offset_rotation,
                offset,
                joint,
                mass,
                first_moment,
                inertia,
                com,
                central_inertia: rotated_inertia,
                tail: tails[index].clone(),
            }
        })
        .collect()
}

/// Vector algebra on DAG nodes (also for the Delta's closed form, `super::three_spheres`).
pub(super) struct Builder<'d> {
    pub(super) dag: &'d mut Dag,
}

/// The part of a value's name that says which recursive pass built it: none for the full one
/// (velocities, accelerations and gravity), `_coriolis` for velocities alone (`C q̇`, `J̇ q̇`),
/// `_gravity` for gravity alone (`g`), `_inertial` for accelerations alone.
fn pass_label(velocity: bool, acceleration: bool, gravity: bool) -> String {
    match (velocity, acceleration, gravity) {
        (true, true, true) => String::new(),
        (true, false, false) => "_coriolis".into(),
        (false, false, true) => "_gravity".into(),
        (false, true, false) => "_inertial".into(),
        (v, a, g) => {
            format!("{}{}{}", if v { "_v" } else { "" }, if a { "_a" } else { "" }, if g { "_g" } else { "" })
        }
    }
}

/// The coordinate names of a 3-vector's entries.
const AXES: [&str; 3] = ["x", "y", "z"];

impl Builder<'_> {
    /// Names each entry of `v` as `{link}_{quantity}_{x|y|z}` for the emitted code.
    fn name3(&mut self, v: &V3, link: &str, quantity: &str) {
        for (&id, axis) in v.iter().zip(AXES) {
            self.dag.hint(id, || format!("{link}_{quantity}_{axis}"));
        }
    }

    /// Names each entry of `m` as `{link}_{quantity}_{row}{column}` for the emitted code.
    fn name33(&mut self, m: &M3, link: &str, quantity: &str) {
        for (r, row) in m.iter().enumerate() {
            for (c, &id) in row.iter().enumerate() {
                self.dag.hint(id, || format!("{link}_{quantity}_{r}{c}"));
            }
        }
    }

    fn zero(&mut self) -> NodeId {
        self.dag.constant(0.0)
    }

    fn zero3(&mut self) -> V3 {
        let z = self.zero();
        [z, z, z]
    }

    pub(super) fn poly(&mut self, p: &Poly) -> NodeId {
        self.dag.polynomial(p)
    }

    pub(super) fn poly3(&mut self, v: &[Poly; 3]) -> V3 {
        std::array::from_fn(|i| self.poly(&v[i]))
    }

    fn sum(&mut self, terms: &[NodeId]) -> NodeId {
        let mut acc = self.zero();
        for &t in terms {
            acc = self.dag.add(acc, t);
        }
        acc
    }

    pub(super) fn add3(&mut self, a: &V3, b: &V3) -> V3 {
        std::array::from_fn(|i| self.dag.add(a[i], b[i]))
    }

    pub(super) fn sub3(&mut self, a: &V3, b: &V3) -> V3 {
        std::array::from_fn(|i| self.dag.sub(a[i], b[i]))
    }

    pub(super) fn scale3(&mut self, k: NodeId, v: &V3) -> V3 {
        std::array::from_fn(|i| self.dag.mul(k, v[i]))
    }

    pub(super) fn dot(&mut self, a: &V3, b: &V3) -> NodeId {
        let products: Vec<NodeId> = (0..3).map(|i| self.dag.mul(a[i], b[i])).collect();
        self.sum(&products)
    }

    pub(super) fn cross(&mut self, a: &V3, b: &V3) -> V3 {
        std::array::from_fn(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let x = self.dag.mul(a[j], b[k]);
            let y = self.dag.mul(a[k], b[j]);
            self.dag.sub(x, y)
        })
    }

    fn mat_vec(&mut self, m: &M3, v: &V3) -> V3 {
        std::array::from_fn(|i| self.dot(&m[i], v))
    }

    pub(super) fn mat_t_vec(&mut self, m: &M3, v: &V3) -> V3 {
        std::array::from_fn(|i| {
            let column = [m[0][i], m[1][i], m[2][i]];
            self.dot(&column, v)
        })
    }

    pub(super) fn const3(&mut self, v: [f64; 3]) -> V3 {
        v.map(|x| self.dag.constant(x))
    }

    /// `ω × (I ω)` for a symmetric `I`, written in the products `ω_r ω_c` that the `U` matrix
    /// computes anyway: component `i` (with `j, k` the next indices cyclically) is
    /// `I_ki ω_i ω_j − I_ji ω_i ω_k + I_jk (ω_j² − ω_k²) + (I_kk − I_jj) ω_j ω_k`, which for a
    /// principal-axis inertia is the one product of Euler's equations.
    fn gyroscopic(&mut self, inertia: &M3, w: &V3) -> V3 {
        std::array::from_fn(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let w_ij = self.dag.mul(w[i], w[j]);
            let w_ik = self.dag.mul(w[i], w[k]);
            let w_jk = self.dag.mul(w[j], w[k]);
            let w_jj = self.dag.mul(w[j], w[j]);
            let w_kk = self.dag.mul(w[k], w[k]);
            let t1 = self.dag.mul(inertia[k][i], w_ij);
            let t2 = self.dag.mul(inertia[j][i], w_ik);
            let squares = if self.dag.constant_value(inertia[j][k]) == Some(0.0) {
                self.zero()
            } else {
                self.dag.sub(w_jj, w_kk)
            };
            let t3 = self.dag.mul(inertia[j][k], squares);
            let difference = self.dag.sub(inertia[k][k], inertia[j][j]);
            let t4 = self.dag.mul(difference, w_jk);
            let a = self.dag.sub(t1, t2);
            let b = self.dag.add(t3, t4);
            self.dag.add(a, b)
        })
    }

    /// `U = [ω̇]× + [ω]×[ω]×`, so that `U v = ω̇ × v + ω × (ω × v)` for every `v` a body
    /// carries (its first moment and its children's origins).
    fn u_matrix(&mut self, w: &V3, wd: &V3) -> M3 {
        let square = |b: &mut Self, i: usize| b.dag.mul(w[i], w[i]);
        let squares = [square(self, 0), square(self, 1), square(self, 2)];
        std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                if r == c {
                    // −(|ω|² − ω_r²): the two other squares.
                    let (j, k) = ((r + 1) % 3, (r + 2) % 3);
                    let sum = self.dag.add(squares[j], squares[k]);
                    self.dag.neg(sum)
                } else {
                    // ω_r ω_c ∓ ω̇_k, with k the third index.
                    let k = 3 - r - c;
                    let product = self.dag.mul(w[r], w[c]);
                    // [ω̇]× has +ω̇_k at (r, c) when (r, c, k) is a cyclic permutation.
                    if (r + 1) % 3 == c {
                        self.dag.sub(product, wd[k])
                    } else {
                        self.dag.add(product, wd[k])
                    }
                }
            })
        })
    }

    /// `R₀ · Rot(axis, q_j)` with Rodrigues' formula written per entry as
    /// `(δ + K²) + K sin q − K² cos q`, so that a coordinate axis gives the familiar
    /// `cos`/`sin` entries with no arithmetic.
    fn joint_rotation(&mut self, offset: &[[f64; 3]; 3], axis: [f64; 3], joint: usize) -> M3 {
        let j = joint as u16;
        let (s, c) = (self.dag.input(Atom::Sin(j)), self.dag.input(Atom::Cos(j)));
        let k = [[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]];
        let k2: [[f64; 3]; 3] = mat3_mul(&mut Numbers, &k, &k);
        // Entry (i, j) of R₀ · Rot = Σ_l R₀[i][l] (δ_lj + K²_lj + K_lj s − K²_lj c).
        std::array::from_fn(|i| {
            std::array::from_fn(|col| {
                let (mut constant, mut sine, mut cosine) = (0.0, 0.0, 0.0);
                for l in 0..3 {
                    let r = offset[i][l];
                    let delta = if l == col { 1.0 } else { 0.0 };
                    constant += r * (delta + k2[l][col]);
                    sine += r * k[l][col];
                    cosine -= r * k2[l][col];
                }
                let (constant, sine, cosine) = (snap_entry(constant), snap_entry(sine), snap_entry(cosine));
                let constant = self.dag.constant(constant);
                let sine_k = self.dag.constant(sine);
                let cosine_k = self.dag.constant(cosine);
                let sine_term = self.dag.mul(sine_k, s);
                let cosine_term = self.dag.mul(cosine_k, c);
                let partial = self.dag.add(constant, sine_term);
                self.dag.add(partial, cosine_term)
            })
        })
    }
}

/// Per-body kinematic state of the forward pass, in the body's joint frame.
struct Motion3 {
    angular_velocity: V3,
    angular_acceleration: V3,
    /// Classical acceleration of the frame origin (gravity included as a base acceleration).
    linear_acceleration: V3,
}

/// The recursive algorithms over one DAG.
struct Recursion<'d> {
    b: Builder<'d>,
    links: Vec<Link>,
    /// Rotation from the parent's joint frame to each joint frame (`E_i`).
    rotations: Vec<M3>,
    /// Origin of each joint frame in the parent's joint frame (`p_i`).
    offsets: Vec<V3>,
    rotor: Vec<Poly>,
    /// The reflected rotor inertia off the diagonal, `(row, column, kg·m²)`, where a coupling
    /// between joints and drives puts one (`Cᵀ diag(N² J_m) C`).
    rotor_coupling: Vec<(usize, usize, f64)>,
    gravity: [Poly; 3],
    /// Newton–Euler equations about each centre of mass (`a_c = a + U c`, `f = m a_c`,
    /// `n = I_c ω̇ + ω × I_c ω + c × f`) instead of about the frame origin with the first
    /// moment `h` (`f = m a + U h`, `n = I_o ω̇ + ω × I_o ω + h × a`). Which is cheaper depends on
    /// the model: principal-axis inertias favour the former, full tensors the latter.
    about_com: bool,
    /// While frames are built relative to a chain's root body (`in_root_frame`), that body:
    /// their values are named `…_in_{root}_…`.
    frames_in: Option<usize>,
}

impl<'d> Recursion<'d> {
    fn new(dag: &'d mut Dag, model: &Model, formulation: Formulation) -> Self {
        let mut links = links(model);
        if formulation == Formulation::Regrouped {
            regroup(&mut links);
        }
        let about_com = formulation == Formulation::AboutCom;
        let mut b = Builder { dag };
        let mut rotations = Vec::with_capacity(links.len());
        let mut offsets = Vec::with_capacity(links.len());
        for link in &links {
            let mut offset = b.poly3(&link.offset);
            let rotation = match link.joint {
                Some((j, JointKind::Revolute, axis)) => b.joint_rotation(&link.offset_rotation, axis, j),
                Some((j, JointKind::Prismatic, axis)) => {
                    let q = b.dag.input(Atom::Q(j as u16));
                    let direction = b.const3(mat3_vec(&mut Numbers, &link.offset_rotation, &axis));
                    let slide = b.scale3(q, &direction);
                    offset = b.add3(&offset, &slide);
                    link.offset_rotation.map(|row| row.map(|x| b.dag.constant(x)))
                }
                None => link.offset_rotation.map(|row| row.map(|x| b.dag.constant(x))),
            };
            rotations.push(rotation);
            offsets.push(offset);
        }
        let reflected = reflected_rotor_inertia(model);
        let rotor = (0..reflected.len()).map(|j| Poly::constant(reflected[j][j])).collect();
        let rotor_coupling = (0..reflected.len())
            .flat_map(|j| (0..reflected.len()).map(move |k| (j, k)))
            .filter(|&(j, k)| j != k && reflected[j][k] != 0.0)
            .map(|(j, k)| (j, k, reflected[j][k]))
            .collect();
        Self {
            b,
            links,
            rotations,
            offsets,
            rotor,
            rotor_coupling,
            gravity: model.gravity.clone(),
            about_com,
            frames_in: None,
        }
    }

    /// The forward pass: each body's angular velocity and acceleration and its origin's
    /// acceleration (with gravity as an upward base acceleration if asked), and its `U` matrix.
    fn forward(&mut self, velocity: bool, acceleration: bool, gravity: bool) -> (Vec<Motion3>, Vec<M3>) {
        let mut states: Vec<Motion3> = Vec::with_capacity(self.links.len());
        let mut u_matrices: Vec<M3> = Vec::with_capacity(self.links.len());
        for i in 0..self.links.len() {
            let (parent_w, parent_wd, parent_a) = match self.links[i].parent {
                Some(p) => {
                    let s = &states[p];
                    (s.angular_velocity, s.angular_acceleration, s.linear_acceleration)
                }
                None => {
                    let z = self.b.zero3();
                    let base_acceleration = if gravity {
                        // The base accelerates upwards at −g⃗: gravity acts on every body.
                        let g = self.gravity.clone().map(|p| p.scale(-1.0));
                        self.b.poly3(&g)
                    } else {
                        z
                    };
                    (z, z, base_acceleration)
                }
            };
            let rotation = self.rotations[i];
            let offset = self.offsets[i];
            // Origin acceleration in the parent frame: a_p + U_p p, with
            // U_p p = ω̇_p × p + ω_p × (ω_p × p) (Khalil and Kleinfinger's U matrix).
            let u_p = match self.links[i].parent {
                Some(p) => u_matrices[p],
                None => [[self.b.zero(); 3]; 3],
            };
            let u_offset = self.b.mat_vec(&u_p, &offset);
            let a_parent = self.b.add3(&parent_a, &u_offset);
            let mut linear = self.b.mat_t_vec(&rotation, &a_parent);
            let mut angular_velocity = self.b.mat_t_vec(&rotation, &parent_w);
            let mut angular_acceleration = self.b.mat_t_vec(&rotation, &parent_wd);
            if let Some((j, kind, axis)) = self.links[i].joint {
                let axis = self.b.const3(axis);
                let qd = if velocity { self.b.dag.input(Atom::Qd(j as u16)) } else { self.b.zero() };
                let qdd = if acceleration { self.b.dag.input(Atom::Qdd(j as u16)) } else { self.b.zero() };
                let axis_qd = self.b.scale3(qd, &axis);
                let axis_qdd = self.b.scale3(qdd, &axis);
                match kind {
                    JointKind::Revolute => {
                        // ω̇ = Eᵀω̇_p + a q̈ + (Eᵀω_p) × a q̇
                        let coupling = self.b.cross(&angular_velocity, &axis_qd);
                        angular_acceleration = self.b.add3(&angular_acceleration, &axis_qdd);
                        angular_acceleration = self.b.add3(&angular_acceleration, &coupling);
                        angular_velocity = self.b.add3(&angular_velocity, &axis_qd);
                    }
                    JointKind::Prismatic => {
                        // a = Eᵀ(…) + 2 ω × a q̇ + a q̈
                        let coriolis = self.b.cross(&angular_velocity, &axis_qd);
                        let two = self.b.dag.constant(2.0);
                        let coriolis = self.b.scale3(two, &coriolis);
                        linear = self.b.add3(&linear, &coriolis);
                        linear = self.b.add3(&linear, &axis_qdd);
                    }
                }
            }
            // Names say which pass a value belongs to when it is not the full one (velocities,
            // accelerations and gravity): the passes of `C q̇` and `g` share one function.
            let pass = pass_label(velocity, acceleration, gravity);
            let link = &self.links[i].name;
            self.b.name3(&angular_velocity, link, "angular_velocity");
            self.b.name3(&angular_acceleration, link, &format!("angular_acceleration{pass}"));
            self.b.name3(&linear, link, &format!("acceleration{pass}"));
            u_matrices.push(self.b.u_matrix(&angular_velocity, &angular_acceleration));
            states.push(Motion3 { angular_velocity, angular_acceleration, linear_acceleration: linear });
        }
        (states, u_matrices)
    }

    /// The recursive Newton–Euler algorithm: joint torques for the given velocities and
    /// accelerations (`None` = zero) and optionally gravity.
    fn newton_euler(&mut self, velocity: bool, acceleration: bool, gravity: bool) -> Vec<NodeId> {
        let n_joints = self.rotor.len();
        let (states, u_matrices) = self.forward(velocity, acceleration, gravity);

        // Body forces about each joint-frame origin, then the backward pass.
        let mut forces: Vec<V3> = Vec::with_capacity(self.links.len());

        let mut moments: Vec<V3> = Vec::with_capacity(self.links.len());
        for (i, (state, u)) in states.iter().zip(&u_matrices).enumerate() {
            let link = &self.links[i];
            let mass = self.b.poly(&link.mass);
            let h = self.b.poly3(&link.first_moment);
            let inertia: M3 =
                std::array::from_fn(|r| std::array::from_fn(|c| self.b.poly(&link.inertia[r][c])));
            let (w, wd, a) = (state.angular_velocity, state.angular_acceleration, state.linear_acceleration);
            let (f, n) = if self.about_com {
                // a_c = a + U c, f = m a_c, n = I_c ω̇ + ω × (I_c ω) + c × f
                let com = self.b.poly3(&link.com);
                let central: M3 = std::array::from_fn(|r| {
                    std::array::from_fn(|c| self.b.poly(&link.central_inertia[r][c]))
                });
                let u_c = self.b.mat_vec(u, &com);
                let a_c = self.b.add3(&a, &u_c);
                let f = self.b.scale3(mass, &a_c);
                let i_wd = self.b.mat_vec(&central, &wd);
                let w_i_w = self.b.gyroscopic(&central, &w);
                let c_f = self.b.cross(&com, &f);
                let n = self.b.add3(&i_wd, &w_i_w);
                (f, self.b.add3(&n, &c_f))
            } else {
                // f = m a + ω̇ × h + ω × (ω × h) = m a + U h
                let ma = self.b.scale3(mass, &a);
                let u_h = self.b.mat_vec(u, &h);
                let f = self.b.add3(&ma, &u_h);
                // n = I ω̇ + ω × (I ω) + h × a
                let i_wd = self.b.mat_vec(&inertia, &wd);
                let w_i_w = self.b.gyroscopic(&inertia, &w);
                let h_a = self.b.cross(&h, &a);
                let n = self.b.add3(&i_wd, &w_i_w);
                (f, self.b.add3(&n, &h_a))
            };
            forces.push(f);
            moments.push(n);
        }
        let mut torques = vec![self.b.zero(); n_joints];
        for i in (0..self.links.len()).rev() {
            // Every child has added its share: the force and moment the joint transmits.
            let pass = pass_label(velocity, acceleration, gravity);
            let link = &self.links[i].name;
            self.b.name3(&forces[i], link, &format!("force{pass}"));
            self.b.name3(&moments[i], link, &format!("moment{pass}"));
            if let Some((j, kind, axis)) = self.links[i].joint {
                let axis = self.b.const3(axis);
                let along = match kind {
                    JointKind::Revolute => moments[i],
                    JointKind::Prismatic => forces[i],
                };
                let mut tau = self.b.dot(&axis, &along);
                if acceleration {
                    let rotor = self.b.poly(&self.rotor[j]);
                    let qdd = self.b.dag.input(Atom::Qdd(j as u16));
                    let reflected = self.b.dag.mul(rotor, qdd);
                    tau = self.b.dag.add(tau, reflected);
                }
                torques[j] = tau;
            }
            if let Some(p) = self.links[i].parent {
                let (f, n) = self.moved_to_parent(i, forces[i], moments[i]);
                forces[p] = self.b.add3(&forces[p], &f);
                moments[p] = self.b.add3(&moments[p], &n);
            }
        }
        if acceleration {
            for &(j, k, inertia) in &self.rotor_coupling {
                let inertia = self.b.dag.constant(inertia);
                let qdd = self.b.dag.input(Atom::Qdd(k as u16));
                let reflected = self.b.dag.mul(inertia, qdd);
                torques[j] = self.b.dag.add(torques[j], reflected);
            }
        }
        torques
    }

    /// A force and moment about body `i`'s origin, expressed about its parent's origin in the
    /// parent's frame: `f' = E f`, `n' = E n + p × f'`.
    fn moved_to_parent(&mut self, i: usize, f: V3, n: V3) -> (V3, V3) {
        let rotation = self.rotations[i];
        let offset = self.offsets[i];
        let f_parent = self.b.mat_vec(&rotation, &f);
        let n_rotated = self.b.mat_vec(&rotation, &n);
        let moment_arm = self.b.cross(&offset, &f_parent);
        (f_parent, self.b.add3(&n_rotated, &moment_arm))
    }

    /// Each joint frame's rotation and origin in the base frame.
    fn world_frames(&mut self) -> Vec<(M3, V3)> {
        let mut frames: Vec<(M3, V3)> = Vec::with_capacity(self.links.len());
        for i in 0..self.links.len() {
            let (rotation, offset) = (self.rotations[i], self.offsets[i]);
            let frame = match self.links[i].parent {
                None => (rotation, offset),
                Some(p) => {
                    let (parent_rotation, parent_origin) = frames[p];
                    let columns: [V3; 3] = std::array::from_fn(|c| {
                        let column = [rotation[0][c], rotation[1][c], rotation[2][c]];
                        self.b.mat_vec(&parent_rotation, &column)
                    });
                    let world_rotation = std::array::from_fn(|r| std::array::from_fn(|c| columns[c][r]));
                    let shift = self.b.mat_vec(&parent_rotation, &offset);
                    (world_rotation, self.b.add3(&parent_origin, &shift))
                }
            };
            let relative = self.frames_in.map(|r| format!("_in_{}", self.links[r].name)).unwrap_or_default();
            let link = &self.links[i].name;
            self.b.name33(&frame.0, link, &format!("orientation{relative}"));
            self.b.name3(&frame.1, link, &format!("origin{relative}"));
            frames.push(frame);
        }
        frames
    }

    /// Position, Jacobian (row-major) or `J̇ q̇` of a point, first `dim` coordinates.
    /// `in_root_frame`: build the Jacobian in the joint frame of the chain's root body, then
    /// turn it into the base frame (see [`jacobian_in_root_frame`]).
    fn point(&mut self, model: &Model, index: usize, what: PointQuantity, form: JacobianForm) -> Vec<NodeId> {
        let JacobianForm { in_root_frame, local_columns } = form;
        let n_joints = self.rotor.len();
        let dim = model.dim();
        let point = &model.points[index];
        let Some(body) = point.body else {
            // A point of the base: constant position, zero Jacobian and J̇ q̇.
            return match what {
                PointQuantity::Position => (0..dim).map(|i| self.b.poly(&point.position[i])).collect(),
                PointQuantity::Jacobian => vec![self.b.zero(); dim * n_joints],
                PointQuantity::JacobianDotTimesQdot => vec![self.b.zero(); dim],
            };
        };
        // The point in its body's joint frame.
        let (tail_rotation, tail_offset) = self.links[body].tail.clone();
        let rotated = const_mat_poly_vec(&tail_rotation, &point.position);
        let local: [Poly; 3] = std::array::from_fn(|i| tail_offset[i].add(&rotated[i]));
        let local = self.b.poly3(&local);
        if what == PointQuantity::JacobianDotTimesQdot {
            let frames = self.world_frames();
            let (states, u_matrices) = self.forward(true, false, false);
            let u_r = self.b.mat_vec(&u_matrices[body], &local);
            let a = self.b.add3(&states[body].linear_acceleration, &u_r);
            let world = self.b.mat_vec(&frames[body].0, &a);
            return world[..dim].to_vec();
        }
        if what == PointQuantity::Position {
            let frames = self.world_frames();
            let (rotation, origin) = frames[body];
            let arm = self.b.mat_vec(&rotation, &local);
            let position = self.b.add3(&origin, &arm);
            return position[..dim].to_vec();
        }
        let root = self.root_of(body);
        let root_frame = (self.rotations[root], self.offsets[root]);
        if in_root_frame {
            // Frames relative to the root body's joint frame: the columns come out in that
            // frame, free of the root joint's sine and cosine, and are turned once at the end.
            let identity = self.b.const3([1.0, 0.0, 0.0]);
            let identity = [identity, self.b.const3([0.0, 1.0, 0.0]), self.b.const3([0.0, 0.0, 1.0])];
            self.rotations[root] = identity;
            self.offsets[root] = self.b.zero3();
            self.frames_in = Some(root);
        }
        let columns = if local_columns {
            self.local_jacobian_columns(body, &local)
        } else {
            self.jacobian_columns(body, &local)
        };
        self.frames_in = None;
        (self.rotations[root], self.offsets[root]) = root_frame;
        let mut jacobian = vec![self.b.zero(); dim * n_joints];
        for (j, column) in columns {
            let column = if in_root_frame { self.b.mat_vec(&root_frame.0, &column) } else { column };
            for (r, &value) in column.iter().take(dim).enumerate() {
                jacobian[r * n_joints + j] = value;
            }
        }
        jacobian
    }

    /// As [`Self::jacobian_columns`], with each column built in its own joint frame, where the
    /// axis is a constant (`a × r_k`, with the lever `r_k = p − o_k` carried from the tip
    /// inwards, `r_parent = p_k + E_k r_k`), then turned by that frame's rotation.
    fn local_jacobian_columns(&mut self, body: usize, local: &V3) -> Vec<(usize, V3)> {
        let frames = self.world_frames();
        let mut lever = *local;
        let mut columns = Vec::new();
        let mut link = body;
        loop {
            if let Some((j, kind, axis)) = self.links[link].joint {
                let axis = self.b.const3(axis);
                let column = match kind {
                    JointKind::Revolute => self.b.cross(&axis, &lever),
                    JointKind::Prismatic => axis,
                };
                columns.push((j, self.b.mat_vec(&frames[link].0, &column)));
            }
            let Some(parent) = self.links[link].parent else { break };
            let turned = self.b.mat_vec(&self.rotations[link], &lever);
            lever = self.b.add3(&self.offsets[link], &turned);
            link = parent;
        }
        columns
    }

    /// Orientation or angular Jacobian (row-major) of named frame `index`; `in_root_frame` as
    /// for points: built relative to the chain's root joint frame, turned into the base frame
    /// at the end.
    pub(crate) fn frame(
        &mut self,
        model: &Model,
        index: usize,
        what: FrameQuantity,
        in_root_frame: bool,
    ) -> Vec<NodeId> {
        let n_joints = self.rotor.len();
        let frame = &model.frames[index];
        let Some(body) = frame.body else {
            return match what {
                FrameQuantity::Orientation => {
                    frame.rotation.iter().flatten().map(|&x| self.b.dag.constant(x)).collect()
                }
                FrameQuantity::AngularJacobian => vec![self.b.zero(); 3 * n_joints],
            };
        };
        let root = self.root_of(body);
        let root_frame = (self.rotations[root], self.offsets[root]);
        if in_root_frame {
            self.rotations[root] =
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|row| self.b.const3(row));
            self.offsets[root] = self.b.zero3();
            self.frames_in = Some(root);
        }
        let frames = self.world_frames();
        self.frames_in = None;
        (self.rotations[root], self.offsets[root]) = root_frame;
        let to_base =
            |b: &mut Builder<'_>, v: V3| if in_root_frame { b.mat_vec(&root_frame.0, &v) } else { v };
        match what {
            FrameQuantity::Orientation => {
                // Joint frame · DH tail · the frame's fixed rotation, column by column.
                let fixed = mat3_mul(&mut Numbers, &self.links[body].tail.0, &frame.rotation);
                let columns: [V3; 3] = std::array::from_fn(|c| {
                    let column = self.b.const3([fixed[0][c], fixed[1][c], fixed[2][c]]);
                    let column = self.b.mat_vec(&frames[body].0, &column);
                    to_base(&mut self.b, column)
                });
                (0..9).map(|k| columns[k % 3][k / 3]).collect()
            }
            FrameQuantity::AngularJacobian => {
                let mut jacobian = vec![self.b.zero(); 3 * n_joints];
                let mut k = Some(body);
                while let Some(link) = k {
                    if let Some((j, JointKind::Revolute, axis)) = self.links[link].joint {
                        let axis = self.b.const3(axis);
                        let z = self.b.mat_vec(&frames[link].0, &axis);
                        let z = to_base(&mut self.b, z);
                        for (r, &value) in z.iter().enumerate() {
                            jacobian[r * n_joints + j] = value;
                        }
                    }
                    k = self.links[link].parent;
                }
                jacobian
            }
        }
    }

    /// The body at the top of `body`'s chain (hanging from the base).
    fn root_of(&self, body: usize) -> usize {
        let mut root = body;
        while let Some(parent) = self.links[root].parent {
            root = parent;
        }
        root
    }

    /// The Jacobian columns (joint index, column) of the point `local` of `body`, in the frame
    /// of [`Self::world_frames`]: `z_k × (p − o_k)` for revolute and `z_k` for prismatic joints.
    fn jacobian_columns(&mut self, body: usize, local: &V3) -> Vec<(usize, V3)> {
        let frames = self.world_frames();
        let (rotation, origin) = frames[body];
        let arm = self.b.mat_vec(&rotation, local);
        let position = self.b.add3(&origin, &arm);
        let mut columns = Vec::new();
        let mut k = Some(body);
        while let Some(link) = k {
            if let Some((j, kind, axis)) = self.links[link].joint {
                let (rotation, origin) = frames[link];
                let axis = self.b.const3(axis);
                let z = self.b.mat_vec(&rotation, &axis);
                let column = match kind {
                    JointKind::Revolute => {
                        let lever = std::array::from_fn(|i| self.b.dag.sub(position[i], origin[i]));
                        self.b.cross(&z, &lever)
                    }
                    JointKind::Prismatic => z,
                };
                columns.push((j, column));
            }
            k = self.links[link].parent;
        }
        columns
    }

    /// The composite-rigid-body algorithm: `D(q)`, row-major.
    fn inertia_matrix(&mut self) -> Vec<NodeId> {
        let n_joints = self.rotor.len();
        let count = self.links.len();
        // Composite mass, first moment and inertia of each subtree, in its joint frame.
        let mut mass: Vec<NodeId> = Vec::with_capacity(count);
        let mut moment: Vec<V3> = Vec::with_capacity(count);
        let mut inertia: Vec<M3> = Vec::with_capacity(count);
        for link in &self.links {
            mass.push(self.b.poly(&link.mass));
            moment.push(self.b.poly3(&link.first_moment));
            let i: M3 = std::array::from_fn(|r| std::array::from_fn(|c| self.b.poly(&link.inertia[r][c])));
            inertia.push(i);
        }
        for i in (0..count).rev() {
            let Some(p) = self.links[i].parent else { continue };
            let (m, h, inertia_i) = (mass[i], moment[i], inertia[i]);
            let rotation = self.rotations[i];
            let offset = self.offsets[i];
            let h_rotated = self.b.mat_vec(&rotation, &h);
            // E I Eᵀ, symmetric: six distinct entries.
            let columns: M3 = std::array::from_fn(|c| {
                let column = [inertia_i[0][c], inertia_i[1][c], inertia_i[2][c]];
                self.b.mat_vec(&rotation, &column)
            });
            // columns[c] = E · I[:, c]; (E I Eᵀ)[r][s] = Σ_c (E I)[r][c] E[s][c].
            let mut rotated = [[self.b.zero(); 3]; 3];
            for r in 0..3 {
                for s in r..3 {
                    let row = [columns[0][r], columns[1][r], columns[2][r]];
                    let value = self.b.dot(&row, &rotation[s]);
                    rotated[r][s] = value;
                    rotated[s][r] = value;
                }
            }
            // Shift to the parent's origin: + (2 h·p + m|p|²) 1 − h pᵀ − p hᵀ − m p pᵀ.
            let m_p = self.b.scale3(m, &offset);
            let h_total = self.b.add3(&h_rotated, &m_p);
            let two = self.b.dag.constant(2.0);
            let h_dot_p = self.b.dot(&h_rotated, &offset);
            let twice = self.b.dag.mul(two, h_dot_p);
            let m_p_p = self.b.dot(&m_p, &offset);
            let diagonal = self.b.dag.add(twice, m_p_p);
            // h pᵀ + p hᵀ + m p pᵀ = h_total pᵀ + p h_rotatedᵀ, symmetric.
            for r in 0..3 {
                for s in r..3 {
                    let x = self.b.dag.mul(h_total[r], offset[s]);
                    let y = self.b.dag.mul(offset[r], h_rotated[s]);
                    let outer = self.b.dag.add(x, y);
                    let mut value = self.b.dag.sub(rotated[r][s], outer);
                    if r == s {
                        value = self.b.dag.add(value, diagonal);
                    }
                    let total = self.b.dag.add(inertia[p][r][s], value);
                    inertia[p][r][s] = total;
                    inertia[p][s][r] = total;
                }
            }
            mass[p] = self.b.dag.add(mass[p], m);
            moment[p] = self.b.add3(&moment[p], &h_total);
        }
        for i in 0..count {
            let link = &self.links[i].name;
            self.b.dag.hint(mass[i], || format!("{link}_composite_mass"));
            self.b.name3(&moment[i], link, "composite_first_moment");
            self.b.name33(&inertia[i], link, "composite_inertia");
        }
        let mut d = vec![self.b.zero(); n_joints * n_joints];
        for i in 0..count {
            let Some((ji, kind, axis)) = self.links[i].joint else { continue };
            let axis_nodes = self.b.const3(axis);
            // Force and moment that accelerate the composite body `i` at unit q̈_i.
            let (mut f, mut n) = match kind {
                JointKind::Revolute => {
                    let f = self.b.cross(&axis_nodes, &moment[i]);
                    let n = self.b.mat_vec(&inertia[i], &axis_nodes);
                    (f, n)
                }
                JointKind::Prismatic => {
                    let f = self.b.scale3(mass[i], &axis_nodes);
                    let n = self.b.cross(&moment[i], &axis_nodes);
                    (f, n)
                }
            };
            let along = |kind: JointKind, f: &V3, n: &V3| if kind == JointKind::Revolute { *n } else { *f };
            let diagonal = self.b.dot(&axis_nodes, &along(kind, &f, &n));
            let rotor = self.b.poly(&self.rotor[ji]);
            d[ji * n_joints + ji] = self.b.dag.add(diagonal, rotor);
            self.b.dag.hint(d[ji * n_joints + ji], || format!("inertia_{ji}{ji}"));
            let mut body = i;
            while let Some(p) = self.links[body].parent {
                let moved = self.moved_to_parent(body, f, n);
                f = moved.0;
                n = moved.1;
                body = p;
                if let Some((jp, kind_p, axis_p)) = self.links[p].joint {
                    let axis_p = self.b.const3(axis_p);
                    let value = self.b.dot(&axis_p, &along(kind_p, &f, &n));
                    d[ji * n_joints + jp] = value;
                    d[jp * n_joints + ji] = value;
                    let (r, c) = (jp.min(ji), jp.max(ji));
                    self.b.dag.hint(value, || format!("inertia_{r}{c}"));
                }
            }
        }
        for &(j, k, inertia) in &self.rotor_coupling {
            let inertia = self.b.dag.constant(inertia);
            d[j * n_joints + k] = self.b.dag.add(d[j * n_joints + k], inertia);
        }
        d
    }
}

/// The partial derivative of each of `roots` with respect to `q_joint`, built in the DAG.
///
/// The derivative of a named node is named after it: `d_{name}_d_{joint_name}`.
pub fn derivative(dag: &mut Dag, roots: &[NodeId], joint: u16, joint_name: &str) -> Vec<NodeId> {
    let order = dag.reachable(roots);
    let mut d: HashMap<NodeId, NodeId> = HashMap::with_capacity_and_hasher(order.len(), Default::default());
    let zero = dag.constant(0.0);
    for id in order {
        let value = match dag.nodes()[id] {
            Node::Const(_) => zero,
            Node::Input(Atom::Sin(j)) if j == joint => dag.input(Atom::Cos(j)),
            Node::Input(Atom::Cos(j)) if j == joint => {
                let s = dag.input(Atom::Sin(j));
                dag.neg(s)
            }
            Node::Input(Atom::Q(j)) if j == joint => dag.constant(1.0),
            Node::Input(_) => zero,
            Node::Add(a, b) => dag.add(d[&a], d[&b]),
            Node::Sub(a, b) => dag.sub(d[&a], d[&b]),
            Node::Neg(a) => dag.neg(d[&a]),
            Node::Mul(a, b) => {
                let x = dag.mul(d[&a], b);
                let y = dag.mul(a, d[&b]);
                dag.add(x, y)
            }
            Node::Sqrt(a) => {
                // (√a)' = a' / (2 √a)
                let two = dag.constant(2.0);
                let twice = dag.mul(two, id);
                dag.div(d[&a], twice)
            }
            Node::Div(a, b) => {
                // (a/b)' = (a' − (a/b) b') / b
                let quotient = dag.div(a, b);
                let t = dag.mul(quotient, d[&b]);
                let numerator = dag.sub(d[&a], t);
                dag.div(numerator, b)
            }
        };
        if let Some(name) = dag.hints().get(&id).cloned() {
            dag.hint(value, || format!("d_{name}_d_{joint_name}"));
        }
        d.insert(id, value);
    }
    roots.iter().map(|r| d[r]).collect()
}

/// Builds a quantity of the model with the recursive algorithms; its nodes join `dag`.
pub fn build(dag: &mut Dag, model: &Model, quantity: Quantity) -> Vec<NodeId> {
    build_with(dag, model, quantity, formulation(model))
}

/// Builds a quantity with the given formulation (all give the same values; [`build`] picks the
/// cheapest).
pub fn build_with(dag: &mut Dag, model: &Model, quantity: Quantity, formulation: Formulation) -> Vec<NodeId> {
    let mut recursion = Recursion::new(dag, model, formulation);
    match quantity {
        Quantity::InertiaMatrix => recursion.inertia_matrix(),
        Quantity::CoriolisTimesQdot => recursion.newton_euler(true, false, false),
        Quantity::Gravity => recursion.newton_euler(false, false, true),
        Quantity::InverseDynamics => recursion.newton_euler(true, true, true),
        Quantity::Point(index, PointQuantity::Jacobian) => {
            drop(recursion);
            let form = jacobian_form(model, index);
            point_jacobian_with(dag, model, index, form)
        }
        Quantity::Point(index, what) => recursion.point(model, index, what, JacobianForm::default()),
        Quantity::Frame(index, what) => {
            drop(recursion);
            let cost = |in_root_frame: bool| {
                let mut scratch = Dag::new();
                let roots = Recursion::new(&mut scratch, model, Formulation::AboutOrigin).frame(
                    model,
                    index,
                    what,
                    in_root_frame,
                );
                let counts = scratch.optimised_count(&roots);
                counts.arithmetic() + counts.trigonometric
            };
            let in_root_frame = cost(true) < cost(false);
            Recursion::new(dag, model, Formulation::AboutOrigin).frame(model, index, what, in_root_frame)
        }
        Quantity::CoriolisMatrix => {
            let d = recursion.inertia_matrix();
            drop(recursion);
            let names: Vec<String> = model.joints.iter().map(|j| j.name.clone()).collect();
            christoffel(dag, &d, &names)
        }
    }
}

/// Builds point `index`'s Jacobian (row-major) in the given form (all give the same values;
/// [`build`] picks the cheapest).
pub fn point_jacobian_with(dag: &mut Dag, model: &Model, index: usize, form: JacobianForm) -> Vec<NodeId> {
    // The kinematics do not depend on how the inertial parameters are written.
    Recursion::new(dag, model, Formulation::AboutOrigin).point(model, index, PointQuantity::Jacobian, form)
}

/// The form of point `index`'s Jacobian that is smallest after optimisation (each is built and
/// counted; a tie keeps the earlier, the base frame with global columns first).
fn jacobian_form(model: &Model, index: usize) -> JacobianForm {
    let cost = |form: JacobianForm| {
        let mut dag = Dag::new();
        let roots = point_jacobian_with(&mut dag, model, index, form);
        let counts = dag.optimised_count(&roots);
        counts.arithmetic() + counts.trigonometric
    };
    let mut best = (JacobianForm { in_root_frame: false, local_columns: false }, usize::MAX);
    for in_root_frame in [false, true] {
        for local_columns in [false, true] {
            let form = JacobianForm { in_root_frame, local_columns };
            let c = cost(form);
            if c < best.1 {
                best = (form, c);
            }
        }
    }
    best.0
}

/// The formulation that gives this model the smallest inverse dynamics (each is built and
/// counted; a tie keeps the earlier of frame origins, centres of mass, regrouped parameters).
pub fn formulation(model: &Model) -> Formulation {
    let cost = |formulation: Formulation| {
        let mut dag = Dag::new();
        let roots = build_with(&mut dag, model, Quantity::InverseDynamics, formulation);
        let counts = dag.count(&roots);
        counts.arithmetic() + counts.trigonometric
    };
    let mut best = (Formulation::AboutOrigin, cost(Formulation::AboutOrigin));
    for candidate in [Formulation::AboutCom, Formulation::Regrouped] {
        let c = cost(candidate);
        if c < best.1 {
            best = (candidate, c);
        }
    }
    best.0
}

/// `C_kj = Σ_i ½ (∂D_kj/∂q_i + ∂D_ki/∂q_j − ∂D_ij/∂q_k) q̇_i`, row-major.
/// `joint_names` name the derivatives in the emitted code.
pub fn christoffel(dag: &mut Dag, inertia: &[NodeId], joint_names: &[String]) -> Vec<NodeId> {
    let n = joint_names.len();
    let partials: Vec<Vec<NodeId>> =
        joint_names.iter().enumerate().map(|(i, name)| derivative(dag, inertia, i as u16, name)).collect();
    let half = dag.constant(0.5);
    let mut c = Vec::with_capacity(n * n);
    for k in 0..n {
        for j in 0..n {
            let mut acc = dag.constant(0.0);
            for i in 0..n {
                let x = dag.add(partials[i][k * n + j], partials[j][k * n + i]);
                let symbol = dag.sub(x, partials[k][i * n + j]);
                let symbol = dag.mul(half, symbol);
                let qd = dag.input(Atom::Qd(i as u16));
                let term = dag.mul(symbol, qd);
                acc = dag.add(acc, term);
            }
            c.push(acc);
        }
    }
    c
}

/// The standard inertial parameters of each body in its joint frame, in the order of the
/// regressor's columns (`crate::dynamics::regressor`): mass `m`, first moment `h = m c`
/// (x, y, z) and the inertia about the joint-frame origin (xx, xy, xz, yy, yz, zz).
pub(crate) fn joint_frame_parameters(model: &Model) -> Vec<(String, [Poly; 10])> {
    links(model)
        .into_iter()
        .map(|l| {
            let [hx, hy, hz] = l.first_moment;
            let i = l.inertia;
            let values = [
                l.mass,
                hx,
                hy,
                hz,
                i[0][0].clone(),
                i[0][1].clone(),
                i[0][2].clone(),
                i[1][1].clone(),
                i[1][2].clone(),
                i[2][2].clone(),
            ];
            (l.name, values)
        })
        .collect()
}

/// The inverse dynamics' columns for each standard parameter of [`joint_frame_parameters`]
/// (body-major, ten per body): the Newton–Euler algorithm run with that parameter 1 and every
/// other one, rotor inertias included, 0. The inverse dynamics is linear in these parameters,
/// so the columns are its regressor; the kinematics of the forward pass are shared by all.
pub(crate) fn standard_columns(dag: &mut Dag, model: &Model) -> Vec<Vec<NodeId>> {
    let mut recursion = Recursion::new(dag, model, Formulation::AboutOrigin);
    let n = recursion.rotor.len();
    recursion.rotor = vec![Poly::zero(); n];
    recursion.rotor_coupling.clear();
    let zero3 = || [Poly::zero(), Poly::zero(), Poly::zero()];
    let mut columns = Vec::new();
    for body in 0..recursion.links.len() {
        for k in 0..10 {
            for link in &mut recursion.links {
                link.mass = Poly::zero();
                link.first_moment = zero3();
                link.inertia = std::array::from_fn(|_| zero3());
            }
            let one = Poly::constant(1.0);
            let link = &mut recursion.links[body];
            match k {
                0 => link.mass = one,
                1..=3 => link.first_moment[k - 1] = one,
                _ => {
                    let (r, c) = INERTIA_ENTRIES[k - 4];
                    link.inertia[r][c] = one.clone();
                    link.inertia[c][r] = one;
                }
            }
            columns.push(recursion.newton_euler(true, true, true));
        }
    }
    columns
}

/// The six distinct entries of a symmetric inertia, in the regressor's order.
pub(crate) const INERTIA_ENTRIES: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
