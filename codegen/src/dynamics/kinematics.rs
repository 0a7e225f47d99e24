//! Kinematics of the open tree as polynomials: every body frame by composing the fixed
//! transforms and joint rotations `R = I + sin q [u]× + (1 − cos q) [u]×²` from the base (a
//! direct pose: its plane's frame turned by `Rz(q)`, `q` an absolute angle in that plane; a
//! mimic joint: its leader's angle, `±q + offset`), the
//! world positions of named points, and the rotations and angular-velocity Jacobians
//! `J_ω = vee(∂R/∂q_k · Rᵀ)` of named frames.

use crate::math::matrix::{mat3_mul, mat3_vec, transpose3, vec3_add, IDENTITY};
use crate::math::rotation::exact_sin_cos;
use crate::model::{JointKind, Model, Motion};
use crate::sym::poly::{Atom, Poly, Polynomials};

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

pub(crate) type Vec3 = [Poly; 3];
pub(crate) type Mat3 = [[Poly; 3]; 3];

pub(crate) fn constant_matrix(m: [[f64; 3]; 3]) -> Mat3 {
    m.map(|row| row.map(Poly::constant))
}

pub(crate) fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    mat3_mul(&mut Polynomials, a, b)
}

pub(crate) fn mat_vec(a: &Mat3, v: &Vec3) -> Vec3 {
    mat3_vec(&mut Polynomials, a, v)
}

pub(crate) fn vec_add(a: &Vec3, b: &Vec3) -> Vec3 {
    vec3_add(&mut Polynomials, a, b)
}

/// Rotation by `q_j` about the unit axis `u`: `I + sin q [u]× + (1 − cos q) [u]×²`.
fn axis_rotation(u: [f64; 3], joint: u16) -> Mat3 {
    axis_rotation_by(u, &Poly::atom(Atom::Sin(joint)), &Poly::atom(Atom::Cos(joint)))
}

/// The angle of a joint as the sine and cosine of its coordinate, or for a mimic joint
/// (`θ = ±q_leader + offset`) of its leader's: `sin θ = ±sin q cos o + cos q sin o`,
/// `cos θ = cos q cos o ∓ sin q sin o`.
fn joint_sin_cos(model: &Model, joint: usize) -> (Poly, Poly) {
    let atoms = |j: usize| (Poly::atom(Atom::Sin(j as u16)), Poly::atom(Atom::Cos(j as u16)));
    match model.mimic_joint(joint) {
        None => atoms(joint),
        Some(mimic) => {
            let (sin_q, cos_q) = atoms(mimic.leader);
            let (sin_o, cos_o) = exact_sin_cos(mimic.offset);
            let signed_sin_q = sin_q.scale(mimic.multiplier);
            (
                signed_sin_q.scale(cos_o).add(&cos_q.scale(sin_o)),
                cos_q.scale(cos_o).sub(&signed_sin_q.scale(sin_o)),
            )
        }
    }
}

/// A prismatic joint's travel: its coordinate, or for a mimic joint `m q_leader + offset`.
fn joint_travel(model: &Model, joint: usize) -> Poly {
    match model.mimic_joint(joint) {
        None => Poly::atom(Atom::Q(joint as u16)),
        Some(mimic) => Poly::atom(Atom::Q(mimic.leader as u16))
            .scale(mimic.multiplier)
            .add(&Poly::constant(mimic.offset)),
    }
}

/// Rotation by the angle whose sine and cosine are `s`, `c` about the unit axis `u`.
fn axis_rotation_by(u: [f64; 3], s: &Poly, c: &Poly) -> Mat3 {
    let one_minus_c = Poly::constant(1.0).sub(c);
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

/// A body frame: origin and rotation in the base frame, polynomials over the tree coordinates.
pub(crate) struct Frame {
    pub(crate) origin: Vec3,
    pub(crate) rotation: Mat3,
}

/// Body frames, in dependency order, over all coordinates of the open tree.
pub(crate) fn body_frames(model: &Model) -> Vec<Frame> {
    let dof = |j: usize| j as u16;
    let mut frames: Vec<Frame> = Vec::with_capacity(model.bodies.len());
    let base =
        || Frame { origin: [Poly::zero(), Poly::zero(), Poly::zero()], rotation: constant_matrix(IDENTITY) };
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
                            JointKind::Revolute => {
                                let (sin, cos) = joint_sin_cos(model, *j);
                                mat_mul(&offset_rotation, &axis_rotation_by(axis, &sin, &cos))
                            }
                            JointKind::Prismatic => {
                                let q = joint_travel(model, *j);
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
            Motion::Direct { origin_body, point, angle_joint, plane_body, plane_rotation } => {
                let carrier = match origin_body {
                    Some(b) => &frames[*b],
                    None => &base(),
                };
                let in_plane = axis_rotation([0.0, 0.0, 1.0], dof(*angle_joint));
                // The base plane (every planar model) needs no product: `I · I · Rz(q)`.
                let rotation = match plane_body {
                    None if *plane_rotation == IDENTITY => in_plane,
                    None => mat_mul(&constant_matrix(*plane_rotation), &in_plane),
                    Some(b) => {
                        mat_mul(&mat_mul(&frames[*b].rotation, &constant_matrix(*plane_rotation)), &in_plane)
                    }
                };
                Frame { origin: vec_add(&carrier.origin, &mat_vec(&carrier.rotation, point)), rotation }
            }
        };
        frames.push(frame);
    }
    frames
}

/// Angular-velocity Jacobian columns of a frame with rotation `rotation` over `n`
/// coordinates: `vee(∂R/∂q_k · Rᵀ)` (the skew-symmetric `Ṙ Rᵀ = [ω]×`).
pub(crate) fn angular_jacobian_columns(rotation: &Mat3, n: usize) -> Vec<Vec3> {
    let rotation_t = transpose3(rotation);
    (0..n)
        .map(|k| {
            let d_rotation: Mat3 = rotation.clone().map(|row| row.map(|p| p.diff_q(k as u16)));
            let w = mat_mul(&d_rotation, &rotation_t);
            [w[2][1].clone(), w[0][2].clone(), w[1][0].clone()]
        })
        .collect()
}

/// Rotation and angular-velocity Jacobian of named frame `index`, over all tree coordinates
/// and then the measured joints' (a gimbal's), whose angles turn the frames they carry.
pub(crate) fn frame_kinematics(model: &Model, frames: &[Frame], index: usize) -> FrameKinematics {
    let frame = &model.frames[index];
    let n = model.tree_coordinates() + model.measured.len();
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
pub(crate) fn point_world(model: &Model, frames: &[Frame], index: usize) -> Vec<Poly> {
    let point = &model.points[index];
    let world = match point.body {
        Some(b) => vec_add(&frames[b].origin, &mat_vec(&frames[b].rotation, &point.position)),
        None => point.position.clone(),
    };
    world[..model.dim()].to_vec()
}

/// The world position of every body's frame origin (2 or 3 entries), polynomials over all
/// coordinates of the open tree (a closed chain's passive joints included): the joints of a
/// drawing of the rig.
pub fn body_origins(model: &Model) -> Vec<Vec<Poly>> {
    body_frames(model).iter().map(|f| f.origin[..model.dim()].to_vec()).collect()
}

/// The world positions of every named point, polynomials over all coordinates of the open
/// tree (a closed chain's passive joints included).
pub fn point_positions(model: &Model) -> Vec<Vec<Poly>> {
    let frames = body_frames(model);
    (0..model.points.len()).map(|i| point_world(model, &frames, i)).collect()
}
