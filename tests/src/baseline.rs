//! The baseline a user would write instead of generated code: a generic implementation of a
//! planar rig's dynamics on nalgebra, with per-body Jacobians and the Lagrangian formulas
//!
//! `D = Σ_b (m_b J_v,bᵀ J_v,b + I_b a_b a_bᵀ) + diag(N² J_m)`, `C q̇ = Σ_b m_b J_v,bᵀ (J̇_v,b q̇)`,
//! `g = −Σ_b m_b J_v,bᵀ g⃗`,
//!
//! where each point is a chain of segments `Σ_s R(θ_s) v_s` with angles `θ_s = φ_s + a_sᵀ q`
//! linear in the coordinates (serial chains and the parallelogram's direct poses alike), so
//! `J_v = Σ_s R(θ_s + π/2) v_s a_sᵀ` and `J̇_v q̇ = −Σ_s R(θ_s) v_s (a_sᵀ q̇)²`. It is built once
//! from a loaded model and evaluated numerically on `DMatrix`/`DVector`: the generic, reusable
//! code a controls engineer writes, used by the benchmarks as the side-by-side reference and
//! by a test as one more independent check of the generated code.

use hapticgen_codegen::model::{JointKind, Model, Motion, TaskSpec};
use hapticgen_codegen::sym::poly::Poly;
use nalgebra::{DMatrix, DVector, Vector2};

/// One term `R(φ + aᵀq) v` of a point's position.
#[derive(Clone, Debug)]
struct Segment {
    phase: f64,
    angle: DVector<f64>,
    offset: Vector2<f64>,
}

/// A point as a chain of segments.
#[derive(Clone, Debug, Default)]
struct Chain {
    segments: Vec<Segment>,
}

#[derive(Clone, Debug)]
struct Body {
    mass: f64,
    inertia: f64,
    /// Angle coefficients of the body frame (its angular-velocity Jacobian).
    angle: DVector<f64>,
    com: Chain,
}

/// A planar rig on nalgebra (revolute joints).
#[derive(Clone, Debug)]
pub struct PlanarBaseline {
    n: usize,
    bodies: Vec<Body>,
    task: Result<Chain, usize>,
    gravity: Vector2<f64>,
    damping: DVector<f64>,
    rotor: DMatrix<f64>,
}

/// The terms of one tick, as nalgebra values.
#[derive(Clone, Debug)]
pub struct BaselineTerms {
    /// `D`.
    pub inertia_matrix: DMatrix<f64>,
    /// `C q̇`.
    pub coriolis_times_qdot: DVector<f64>,
    /// `g`.
    pub gravity: DVector<f64>,
    /// `p`.
    pub position: DVector<f64>,
    /// `J`.
    pub jacobian: DMatrix<f64>,
    /// `J̇ q̇`.
    pub jacobian_dot_times_qdot: DVector<f64>,
}

/// The rotors' inertia reflected to the joints, which both baselines add to `D`: `N² J_m` on
/// the diagonal, or `Cᵀ diag(N² J_m) C` through a transmission `a = C q`.
pub fn rotor_inertias(model: &Model) -> DMatrix<f64> {
    let n = model.joints.len();
    let rotor = DMatrix::from_diagonal(&DVector::from_iterator(
        n,
        model.joints.iter().map(|j| j.drive.gear_ratio.powi(2) * j.drive.motor.rotor_inertia),
    ));
    match &model.coupling {
        Some(coupling) => {
            let c = DMatrix::from_fn(n, n, |k, j| coupling.drive_from_joint[k][j]);
            c.transpose() * rotor * c
        }
        None => rotor,
    }
}

fn constant(p: &Poly) -> Option<f64> {
    p.as_constant()
}

fn rotate(theta: f64, v: &Vector2<f64>) -> Vector2<f64> {
    let (s, c) = theta.sin_cos();
    Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

impl Chain {
    fn extended(&self, phase: f64, angle: &DVector<f64>, offset: Vector2<f64>) -> Chain {
        let mut c = self.clone();
        if offset != Vector2::zeros() {
            c.segments.push(Segment { phase, angle: angle.clone(), offset });
        }
        c
    }

    fn position(&self, q: &DVector<f64>) -> Vector2<f64> {
        self.segments.iter().map(|s| rotate(s.phase + s.angle.dot(q), &s.offset)).sum()
    }

    fn jacobian(&self, q: &DVector<f64>, n: usize) -> DMatrix<f64> {
        let mut j = DMatrix::zeros(2, n);
        for s in &self.segments {
            let d = rotate(s.phase + s.angle.dot(q) + std::f64::consts::FRAC_PI_2, &s.offset);
            j += DMatrix::from_column_slice(2, 1, d.as_slice()) * s.angle.transpose();
        }
        j
    }

    fn jacobian_dot_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> Vector2<f64> {
        self.segments
            .iter()
            .map(|s| -rotate(s.phase + s.angle.dot(q), &s.offset) * s.angle.dot(qd).powi(2))
            .sum()
    }
}

impl PlanarBaseline {
    /// Builds the baseline of a planar open-chain model with revolute joints and constant
    /// parameters; `None` for other models (closed chains with passive joints included).
    pub fn new(model: &Model) -> Option<Self> {
        if !model.planar
            || !model.passive.is_empty()
            || !model.tunable.is_empty()
            || model.joints.iter().any(|j| j.kind != JointKind::Revolute)
        {
            return None;
        }
        let n = model.joints.len();
        let unit = |j: usize, sign: f64| {
            let mut a = DVector::zeros(n);
            a[j] = sign;
            a
        };
        let xy = |p: &[Poly; 3]| Some(Vector2::new(constant(&p[0])?, constant(&p[1])?));
        // Frames: (origin chain, phase, angle coefficients).
        let mut frames: Vec<(Chain, f64, DVector<f64>)> = Vec::new();
        let base = (Chain::default(), 0.0, DVector::zeros(n));
        let mut bodies = Vec::new();
        for body in &model.bodies {
            let frame = match &body.motion {
                // A fixed transform after the joint (standard DH links, spatial only).
                Motion::Serial { tail: Some(_), .. } => return None,
                Motion::Serial { parent, xyz, rotation, joint, tail: None } => {
                    let (chain, phase, angle) = parent.map_or(base.clone(), |p| frames[p].clone());
                    let chain = chain.extended(phase, &angle, xy(xyz)?);
                    let fixed = rotation[1][0].atan2(rotation[0][0]);
                    let angle = match joint {
                        Some(j) => &angle + unit(*j, model.joints[*j].axis[2].signum()),
                        None => angle,
                    };
                    (chain, phase + fixed, angle)
                }
                // A planar model's direct pose turns in the base plane (`plane_body` is None).
                Motion::Direct { origin_body, point, angle_joint, .. } => {
                    let (chain, phase, angle) = origin_body.map_or(base.clone(), |p| frames[p].clone());
                    (chain.extended(phase, &angle, xy(point)?), 0.0, unit(*angle_joint, 1.0))
                }
            };
            let (chain, phase, angle) = frame.clone();
            bodies.push(Body {
                mass: constant(&body.mass)?,
                inertia: constant(&body.inertia[2][2])?,
                angle: angle.clone(),
                com: chain.extended(phase, &angle, xy(&body.com)?),
            });
            frames.push(frame);
        }
        let task = match &model.task {
            TaskSpec::Point(i) => {
                let point = &model.points[*i];
                let (chain, phase, angle) = point.body.map_or(base.clone(), |b| frames[b].clone());
                Ok(chain.extended(phase, &angle, xy(&point.position)?))
            }
            TaskSpec::Joints(joints) if joints.len() == 1 => Err(joints[0]),
            TaskSpec::Joints(_) => return None,
        };
        Some(PlanarBaseline {
            n,
            bodies,
            task,
            gravity: Vector2::new(constant(&model.gravity[0])?, constant(&model.gravity[1])?),
            damping: DVector::from_iterator(
                n,
                model.joints.iter().map(|j| constant(&j.damping).unwrap_or(0.0)),
            ),
            rotor: rotor_inertias(model),
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

    /// `D(q)`.
    pub fn inertia_matrix(&self, q: &DVector<f64>) -> DMatrix<f64> {
        let mut d = self.rotor.clone();
        for b in &self.bodies {
            let jv = b.com.jacobian(q, self.n);
            d += b.mass * jv.transpose() * &jv + b.inertia * &b.angle * b.angle.transpose();
        }
        d
    }

    /// `C(q, q̇) q̇`.
    pub fn coriolis_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        let mut c = DVector::zeros(self.n);
        for b in &self.bodies {
            let jv = b.com.jacobian(q, self.n);
            let a = b.com.jacobian_dot_times_qdot(q, qd);
            c += b.mass * jv.transpose() * DVector::from_column_slice(a.as_slice());
        }
        c
    }

    /// `g(q)`.
    pub fn gravity(&self, q: &DVector<f64>) -> DVector<f64> {
        let mut g = DVector::zeros(self.n);
        let gravity = DVector::from_column_slice(self.gravity.as_slice());
        for b in &self.bodies {
            g -= b.mass * b.com.jacobian(q, self.n).transpose() * &gravity;
        }
        g
    }

    /// `p(q)`.
    pub fn position(&self, q: &DVector<f64>) -> DVector<f64> {
        match &self.task {
            Ok(chain) => DVector::from_column_slice(chain.position(q).as_slice()),
            Err(j) => DVector::from_element(1, q[*j]),
        }
    }

    /// `J(q)`.
    pub fn jacobian(&self, q: &DVector<f64>) -> DMatrix<f64> {
        match &self.task {
            Ok(chain) => chain.jacobian(q, self.n),
            Err(j) => {
                let mut m = DMatrix::zeros(1, self.n);
                m[(0, *j)] = 1.0;
                m
            }
        }
    }

    /// `J̇ q̇`.
    pub fn jacobian_dot_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
        match &self.task {
            Ok(chain) => DVector::from_column_slice(chain.jacobian_dot_times_qdot(q, qd).as_slice()),
            Err(_) => DVector::zeros(1),
        }
    }

    /// Everything one tick needs.
    pub fn terms(&self, q: &DVector<f64>, qd: &DVector<f64>) -> BaselineTerms {
        BaselineTerms {
            inertia_matrix: self.inertia_matrix(q),
            coriolis_times_qdot: self.coriolis_times_qdot(q, qd),
            gravity: self.gravity(q),
            position: self.position(q),
            jacobian: self.jacobian(q),
            jacobian_dot_times_qdot: self.jacobian_dot_times_qdot(q, qd),
        }
    }

    /// Controller 3 on nalgebra: `u = C q̇ + B q̇ + g − Jᵀ(B_d ẋ̃ + K_d x̃)` (eq. (12) in eq. (3)).
    pub fn jacobian_transpose(
        &self,
        terms: &BaselineTerms,
        qd: &DVector<f64>,
        reference: &DVector<f64>,
        stiffness: &DVector<f64>,
        damping: &DVector<f64>,
    ) -> DVector<f64> {
        jacobian_transpose(terms, &self.damping, qd, reference, stiffness, damping)
    }
}

/// Controller 3 on nalgebra from one tick's terms and the joints' viscous damping `B`:
/// `u = C q̇ + B q̇ + g − Jᵀ(B_d ẋ̃ + K_d x̃)` (eq. (12) in eq. (3)), for a reference at rest.
/// Both baselines' laws are this one.
pub fn jacobian_transpose(
    terms: &BaselineTerms,
    joint_damping: &DVector<f64>,
    qd: &DVector<f64>,
    reference: &DVector<f64>,
    stiffness: &DVector<f64>,
    damping: &DVector<f64>,
) -> DVector<f64> {
    let velocity = &terms.jacobian * qd;
    let restoring =
        damping.component_mul(&velocity) + stiffness.component_mul(&(&terms.position - reference));
    &terms.coriolis_times_qdot + joint_damping.component_mul(qd) + &terms.gravity
        - terms.jacobian.transpose() * restoring
}
