//! The closed form of a Delta's loops: a platform that only translates, hung on three legs
//! each of which keeps a point of the platform at a fixed distance from a point its actuated
//! joints move (a shin between two universal joints). Where a spatial chain has this shape
//! ([`ThreeSpheres::recognise`]) the generated code solves its loops in closed form, with no
//! Newton step and no matrix factorisation; any other spatial chain keeps the numerical
//! elimination of [`super::spatial_loops`].
//!
//! **The shape.** One leg carries the platform (its shin, then a universal joint whose centre
//! is the platform's frame origin `O`); each of the two other legs is cut open where its shin
//! meets the platform (a closure). On leg `k` the knee is a universal joint (two passive
//! revolute axes through its centre `K_k`, a function of the actuated coordinates alone); the
//! shin's far point `F_k` is at the fixed distance `b_k` from `K_k`. The platform keeps the
//! orientation `R_P` it has at the assembly (checked at sampled states: Tsai's conditions, which
//! the closures' `perpendicular` axes impose), so `F_k = O + R_P c_k` with `c_k` the platform
//! point, and
//!
//! `|O − C_k| = b_k`, `C_k = K_k − R_P c_k`, `k = 1, 2, 3`:
//!
//! three spheres. With `e₁ = C₂ − C₁`, `e₂ = C₃ − C₁`, `x = O − C₁`: `x·e₁ = h₁`,
//! `x·e₂ = h₂` (`h_i = (b₁² − b_{i+1}² + |e_i|²) / 2`) give `x₀`, the part of `x` in the plane of
//! `e₁`, `e₂`, from their Gram matrix (determinant `G = |e₁ × e₂|²`), and
//! `x = x₀ + σ √((b₁² − |x₀|²) / G) e₁ × e₂`, `σ = ±1` the assembly's side.
//!
//! **The passive angles** follow without inverse trigonometry. A knee turns the shin's reach
//! `d` (from `K_k` to `F_k`, in the shin's frame) onto `u_k = O − C_k`:
//! `R(a₁, α) R(a₂, β) d = w` with `w` the reach in the first axis' frame. The component along
//! `a₁` fixes `β`: `A cos β + B sin β = C` (`A = a₁·d⊥`, `B = a₁·(a₂ × d⊥)`,
//! `C = a₁·w − a₁·d∥`, `d∥`, `d⊥` the parts of `d` along and across `a₂`), so
//! `(cos β, sin β) = (A C − τ B √(R² − C²), B C + τ A √(R² − C²)) / R²`, `R² = A² + B²`,
//! `τ = ±1` the assembly's; then `α` turns `v = R(a₂, β) d` onto `w` about `a₁`:
//! `cos α = (v·w − (a₁·v)(a₁·w)) / (|w|² − (a₁·w)²)`, `sin α = a₁·(v × w) / (…)`. The
//! platform's universal joint (axes `a₃`, then `a₄`) has the known relative rotation
//! `M = R(a₃, γ) R(a₄, δ)`: `γ` turns `a₄` onto `m = M a₄` about `a₃`, and `δ` turns a vector
//! `e ⊥ a₄` onto `M e` after undoing `γ`.
//!
//! **Velocity and acceleration level** by forward differentiation on the expression graph
//! ([`Dag::derivative`]), in the order the angles are computed, each angle's derivative taken
//! from how its sine and cosine are formed, with the platform's and the earlier angles' motion
//! given (so that no derivative passes through a division or square root of the position
//! level): the platform from the spheres' implicit relation, `u_k·(Ȯ − K̇_k) = 0`, so
//! `U Ȯ = [u_k·K̇_k]` with `U` the rows `u_kᵀ` (`U⁻¹` from the cross products of its rows and
//! its determinant), and at `q̈_a = 0` `U Ö = [u_k·K̈_k − |Ȯ − K̇_k|²]`; a knee's second angle
//! from `A cos β + B sin β = C`, `β̇ = Ċ / (B cos β − A sin β)`,
//! `β̈ = (C̈ + C β̇²) / (B cos β − A sin β)`; an angle given as `(N_s, N_c) / r`, `r > 0` (a knee's
//! first angle, the platform joint's second), `φ̇ = (N_c Ṅ_s − N_s Ṅ_c) / Y`, `Y = N_c² + N_s²`,
//! `φ̈ = (N_c N̈_s − N_s N̈_c − φ̇ Ẏ) / Y`. Along one actuated coordinate these are the columns of
//! `A`; along the velocity at `q̈_a = 0`, `q̇_p = A q̇_a` and `Ȧ q̇_a`; `Ȧ` itself (for `C`) by
//! differentiating `A` along the velocity.
//!
//! **Singularity.** The loops are singular where `U` is (the three shins parallel to a plane:
//! the Delta's parallel singularity, `det U = 0`) or where a shin lies along its knee's first
//! axis (the universal joint's own singularity); the margins are `det² U / Π b_k²` and, per
//! knee, `1 − (a₁·w)² / b_k²`, squared sines in `[0, 1]`, 0 exactly there.

use rustc_hash::FxHashMap as HashMap;

use super::kinematics::{body_frames, constant_matrix, mat_mul, mat_vec, vec_add};
use super::recursive::Builder;
use crate::math::matrix::{mat3_vec, transpose3, Numbers};
use crate::math::vector::{cross, dot, scaled, sub};
use crate::model::{JointKind, Model, Motion, SpatialClosure};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, Poly, State};

/// A vector of three nodes.
type Vector = [NodeId; 3];
/// A vector of three polynomials.
type PolyVector = [Poly; 3];

/// A knee: a universal joint turning a shin's reach `d` onto the direction of its platform
/// point, with the polynomials of the module documentation's solution.
#[derive(Clone, Debug)]
struct Knee {
    /// The tree coordinates of its two joints (first axis, second axis).
    joints: [usize; 2],
    /// `a₁`, in the frame of `frame`.
    first_axis: [f64; 3],
    /// The world rotation of the frame `a₁` is fixed in (the thigh's times the cross's fixed
    /// rotation).
    frame: [PolyVector; 3],
    /// `d∥`, `d⊥` and `a₂ × d⊥`, in the cross's frame (the second joint's fixed rotation
    /// applied).
    reach_along: PolyVector,
    reach_across: PolyVector,
    reach_across_turned: PolyVector,
    /// `A = a₁·d⊥`, `B = a₁·(a₂ × d⊥)`, `a₁·d∥` and `R² = A² + B²`.
    cos_coefficient: Poly,
    sin_coefficient: Poly,
    axial_offset: Poly,
    coefficients_squared: Poly,
    /// `τ`: which of the two solutions the assembly has.
    side: f64,
}

/// One leg: its knee and the sphere its platform point lies on.
#[derive(Clone, Debug)]
struct Leg {
    /// The shin's name (names intermediates).
    shin: String,
    knee: Knee,
    /// `K_k`, the knee's centre (a function of the actuated coordinates).
    knee_centre: PolyVector,
    /// `C_k = K_k − R_P c_k`.
    sphere_centre: PolyVector,
    /// `b_k² = |d|²`.
    reach_squared: Poly,
}

/// The platform's universal joint on the carrier's shin: `R(a₃, γ) R(a₄, δ) = M`, with
/// `m = M a₄` and `M e` as polynomials (of the carrier's knee angles).
#[derive(Clone, Debug)]
struct PlatformJoint {
    joints: [usize; 2],
    /// `e ⊥ a₄` (unnormalised), `a₃ × e`, `a₃ (a₃·e)` and `|e|²`.
    normal: [f64; 3],
    normal_turned: [f64; 3],
    normal_axial: [f64; 3],
    normal_squared: f64,
    /// `cos γ = p·m / |p|²` and `sin γ = (a₃ × p)·m / |p|²`, `p` the part of `a₄` across `a₃`.
    first_cos: Poly,
    first_sin: Poly,
    /// `m = M a₄` and `M e`.
    turned_axis: PolyVector,
    turned_normal: PolyVector,
}

/// A Delta's loops in closed form (see the module documentation).
#[derive(Clone, Debug)]
pub struct ThreeSpheres {
    /// The platform body's name.
    platform: String,
    /// The model's points on the platform, each with its offset from the platform's origin in
    /// the world frame (`R_P c`, constant): they move with the origin.
    platform_points: Vec<(usize, PolyVector)>,
    /// The legs, the platform's carrier first.
    legs: [Leg; 3],
    platform_joint: PlatformJoint,
    /// `σ`: which of the spheres' two intersections.
    sphere_side: f64,
}

/// How an angle's sine and cosine are computed, which is how its derivatives are taken.
#[derive(Clone, Copy, Debug)]
enum AngleForm {
    /// The sine and cosine themselves are smooth expressions (polynomials of earlier angles):
    /// `φ' = c s' − s c'`.
    Unit,
    /// `(sin φ, cos φ) = (N_s, N_c) / r` with `r > 0`: `φ' = (N_c N_s' − N_s N_c') / Y`,
    /// `Y = N_c² + N_s² = r²`, and at `q̈_a = 0` `φ'' = (N_c N_s'' − N_s N_c'' − φ' Y') / Y`.
    Ratio { sin_numerator: NodeId, cos_numerator: NodeId, scale: NodeId },
    /// `A cos φ + B sin φ = C` with `A`, `B` constant: `φ' = C' / (B cos φ − A sin φ)` and
    /// `φ'' = (C'' + C φ'²) / (B cos φ − A sin φ)`.
    Implicit { right: NodeId, cos_coefficient: NodeId, sin_coefficient: NodeId },
}

/// A passive angle of the closed form: its joint, its sine and cosine nodes, and their form.
#[derive(Clone, Copy, Debug)]
struct Angle {
    joint: usize,
    sin: NodeId,
    cos: NodeId,
    form: AngleForm,
}

impl Angle {
    /// The angle's derivative along the direction `known` and `input` define.
    fn rate(
        &self,
        dag: &mut Dag,
        known: &mut HashMap<NodeId, NodeId>,
        input: &mut dyn FnMut(&mut Dag, Atom) -> NodeId,
    ) -> NodeId {
        match self.form {
            AngleForm::Unit => {
                let (d_sin, d_cos) =
                    (dag.derivative(self.sin, known, input), dag.derivative(self.cos, known, input));
                product_difference(dag, [self.cos, d_sin], [self.sin, d_cos])
            }
            AngleForm::Ratio { sin_numerator, cos_numerator, scale } => {
                let d_sin = dag.derivative(sin_numerator, known, input);
                let d_cos = dag.derivative(cos_numerator, known, input);
                let numerator = product_difference(dag, [cos_numerator, d_sin], [sin_numerator, d_cos]);
                let scale_squared = dag.mul(scale, scale);
                dag.div(numerator, scale_squared)
            }
            AngleForm::Implicit { right, .. } => {
                let d_right = dag.derivative(right, known, input);
                let slope = self.implicit_slope(dag);
                dag.div(d_right, slope)
            }
        }
    }

    /// The angle's acceleration at `q̈_a = 0` along the velocity (`known` and `input` the
    /// derivative along it, `rate` the angle's rate).
    fn convective_acceleration(
        &self,
        dag: &mut Dag,
        known: &mut HashMap<NodeId, NodeId>,
        input: &mut dyn FnMut(&mut Dag, Atom) -> NodeId,
        rate: NodeId,
    ) -> NodeId {
        let second = |dag: &mut Dag,
                      known: &mut HashMap<NodeId, NodeId>,
                      input: &mut dyn FnMut(&mut Dag, Atom) -> NodeId,
                      x: NodeId| {
            let d = dag.derivative(x, known, input);
            (d, dag.derivative(d, known, input))
        };
        match self.form {
            AngleForm::Unit => {
                let (_, dd_sin) = second(dag, known, input, self.sin);
                let (_, dd_cos) = second(dag, known, input, self.cos);
                product_difference(dag, [self.cos, dd_sin], [self.sin, dd_cos])
            }
            AngleForm::Ratio { sin_numerator, cos_numerator, scale } => {
                let (d_sin, dd_sin) = second(dag, known, input, sin_numerator);
                let (d_cos, dd_cos) = second(dag, known, input, cos_numerator);
                let curvature = product_difference(dag, [cos_numerator, dd_sin], [sin_numerator, dd_cos]);
                // Y' = 2 (N_c N_c' + N_s N_s').
                let cos_part = dag.mul(cos_numerator, d_cos);
                let sin_part = dag.mul(sin_numerator, d_sin);
                let half_scale_rate = dag.add(cos_part, sin_part);
                let two = dag.constant(2.0);
                let scale_rate = dag.mul(two, half_scale_rate);
                let damping = dag.mul(rate, scale_rate);
                let numerator = dag.sub(curvature, damping);
                let scale_squared = dag.mul(scale, scale);
                dag.div(numerator, scale_squared)
            }
            AngleForm::Implicit { right, .. } => {
                let (_, dd_right) = second(dag, known, input, right);
                let rate_squared = dag.mul(rate, rate);
                let centripetal = dag.mul(right, rate_squared);
                let numerator = dag.add(dd_right, centripetal);
                let slope = self.implicit_slope(dag);
                dag.div(numerator, slope)
            }
        }
    }

    /// From now on, along this direction, the sine and cosine move with the angle's `rate`.
    fn given_rate(&self, dag: &mut Dag, known: &mut HashMap<NodeId, NodeId>, rate: NodeId) {
        let d_sin = dag.mul(self.cos, rate);
        let sin_rate = dag.mul(self.sin, rate);
        let d_cos = dag.neg(sin_rate);
        known.entry(self.sin).or_insert(d_sin);
        known.entry(self.cos).or_insert(d_cos);
    }

    /// `B cos φ − A sin φ` of an implicit angle.
    fn implicit_slope(&self, dag: &mut Dag) -> NodeId {
        let AngleForm::Implicit { cos_coefficient, sin_coefficient, .. } = self.form else {
            return dag.constant(f64::NAN);
        };
        product_difference(dag, [sin_coefficient, self.cos], [cos_coefficient, self.sin])
    }
}

/// What [`ThreeSpheres::install`] added to a graph.
#[derive(Clone, Debug, Default)]
pub struct ClosedFormNodes {
    /// Names for the nodes of the elimination.
    pub hints: Vec<(NodeId, String)>,
    /// Every atom substituted, with its node.
    pub atoms: Vec<(Atom, NodeId)>,
    /// The margins: the parallel singularity's, then each knee's (module documentation).
    pub margins: Vec<NodeId>,
    /// The platform's origin and its motion.
    pub platform: PlatformMotion,
}

/// The platform's origin `O`, its Jacobian `∂O/∂q_a` (one column per actuated coordinate) and
/// its acceleration at `q̈_a = 0`, `Ö`: what every point on the platform has, the platform only
/// translating.
#[derive(Clone, Debug, Default)]
pub struct PlatformMotion {
    /// `O`.
    pub origin: Vector,
    /// `∂O/∂q_aj`, by `j`.
    pub jacobian: Vec<Vector>,
    /// `Ö` at `q̈_a = 0`.
    pub convective_acceleration: Vector,
}

/// The atoms the elimination defines, as the caller numbers them.
pub struct ClosedFormAtoms<'a> {
    /// Number of actuated coordinates `N` (the passive ones are the tree's `N …`).
    pub actuated: usize,
    /// `A[r][j]` (`rate`: `Ȧ[r][j]`) for passive coordinate `r`, actuated coordinate `j`.
    pub sensitivity: &'a dyn Fn(usize, usize, bool) -> Atom,
    /// `(Ȧ q̇_a)[r]`.
    pub convective: &'a dyn Fn(usize) -> Atom,
    /// Coordinate names (actuated, then passive), for the hints.
    pub names: &'a [String],
}

/// The serial parts of a body's motion: parent, offset, fixed rotation, joint, and whether
/// it has a fixed transform after the joint.
type SerialParts<'m> = (Option<usize>, &'m PolyVector, [[f64; 3]; 3], Option<usize>, bool);

fn serial(model: &Model, body: usize) -> Option<SerialParts<'_>> {
    match &model.bodies[body].motion {
        Motion::Serial { parent, xyz, rotation, joint, tail } => {
            Some((*parent, xyz, *rotation, *joint, tail.is_some()))
        }
        Motion::Direct { .. } => None,
    }
}

/// `x`, or the value among 0, ±½, ±√2/2, ±√3/2 and ±1 within 10⁻⁹ of it.
fn clean(x: f64) -> f64 {
    let magnitudes = [0.0, 0.5, std::f64::consts::FRAC_1_SQRT_2, 0.75_f64.sqrt(), 1.0];
    magnitudes.iter().map(|m| m.copysign(x)).find(|c| (x - c).abs() < 1e-9).unwrap_or(x)
}

/// `a b − c d`, built in that order.
fn product_difference(dag: &mut Dag, [a, b]: [NodeId; 2], [c, d]: [NodeId; 2]) -> NodeId {
    let first = dag.mul(a, b);
    let second = dag.mul(c, d);
    dag.sub(first, second)
}

/// `a·v` of a constant vector and polynomials.
fn constant_dot(a: [f64; 3], v: &PolyVector) -> Poly {
    Poly::sum(&[v[0].scale(a[0]), v[1].scale(a[1]), v[2].scale(a[2])])
}

/// `a × v` of a constant vector and polynomials.
fn constant_cross(a: [f64; 3], v: &PolyVector) -> PolyVector {
    [
        v[2].scale(a[1]).sub(&v[1].scale(a[2])),
        v[0].scale(a[2]).sub(&v[2].scale(a[0])),
        v[1].scale(a[0]).sub(&v[0].scale(a[1])),
    ]
}

/// `|v|²` of polynomials.
fn norm_squared(v: &PolyVector) -> Poly {
    Poly::sum(&[v[0].mul(&v[0]), v[1].mul(&v[1]), v[2].mul(&v[2])])
}

impl ThreeSpheres {
    /// The closed form of `closures` on `model`'s tree, if the chain has the shape of the
    /// module documentation; else why not (its loops are then solved by Newton's method). The
    /// platform's orientation and the assembly's sides are read at `tree`, the assembly (every
    /// tree coordinate); the caller checks the closed form against the numerical solution
    /// before using it.
    pub fn recognise(
        model: &Model,
        closures: &[SpatialClosure],
        tree: &[f64],
        parameters: &[f64],
    ) -> Result<ThreeSpheres, String> {
        let n = model.joints.len();
        if closures.len() != 2 || model.passive.len() != 8 {
            return Err(format!(
                "not a Delta: {} closure{} and {} passive joint{} where a Delta's three legs have 2 and 8",
                closures.len(),
                if closures.len() == 1 { "" } else { "s" },
                model.passive.len(),
                if model.passive.len() == 1 { "" } else { "s" }
            ));
        }
        if model.passive.iter().any(|p| p.kind != JointKind::Revolute) {
            return Err("a passive joint is prismatic".into());
        }
        let state = State { q: tree, qd: &[], parameters };
        let value = |p: &Poly| p.eval(&state);
        let point_body = |point: usize| model.points[point].body;
        // The platform: the body every closure has a point on.
        let platform = closures[0]
            .points
            .iter()
            .filter_map(|&p| point_body(p))
            .find(|&b| closures.iter().all(|c| c.points.iter().any(|&p| point_body(p) == Some(b))))
            .ok_or("no body has a point of every closure")?;
        // A universal joint ending at `body` (which sits at the centre): its two passive joints,
        // its cross and the body above the cross.
        let universal = |body: usize| -> Result<([usize; 2], usize, usize), String> {
            let name = &model.bodies[body].name;
            let parts = serial(model, body).ok_or(format!("`{name}` is placed directly"))?;
            let (Some(cross), xyz, _, Some(second), false) = parts else {
                return Err(format!("`{name}` does not hang on a passive universal joint"));
            };
            let cross_parts =
                serial(model, cross).ok_or(format!("the cross above `{name}` is placed directly"))?;
            let (Some(above), _, _, Some(first), false) = cross_parts else {
                return Err(format!("`{name}` does not hang on a passive universal joint"));
            };
            if first < n || second < n || !xyz.iter().all(Poly::is_zero) {
                return Err(format!("`{name}` does not hang at the centre of a passive universal joint"));
            }
            Ok(([first, second], cross, above))
        };
        let frames = body_frames(model);
        let moves_passively = |p: &Poly| {
            p.atoms().any(|a| matches!(a, Atom::Sin(j) | Atom::Cos(j) | Atom::Q(j) if usize::from(j) >= n))
        };
        let axis = |coordinate: usize| model.coordinate_axis(coordinate).1;
        // A leg's knee and centre from its shin, and the shin's reach.
        let leg = |shin: usize, reach: PolyVector, offset: &PolyVector| -> Result<Leg, String> {
            let (joints, cross, thigh) = universal(shin)?;
            let frame = &frames[thigh];
            if frame.rotation.iter().flatten().chain(&frame.origin).any(moves_passively) {
                return Err(format!("the knee of `{}` moves with passive joints", model.bodies[shin].name));
            }
            let (_, cross_xyz, cross_rotation, _, _) =
                serial(model, cross).ok_or("a cross is placed directly")?;
            let (_, _, shin_rotation, _, _) = serial(model, shin).ok_or("a shin is placed directly")?;
            let knee_frame = mat_mul(&frame.rotation, &constant_matrix(cross_rotation));
            let knee_centre = vec_add(&frame.origin, &mat_vec(&frame.rotation, cross_xyz));
            let first_axis = axis(joints[0]);
            let second_axis = mat3_vec(&mut Numbers, &shin_rotation, &axis(joints[1]));
            let reach_in_cross = mat_vec(&constant_matrix(shin_rotation), &reach);
            let along = constant_dot(second_axis, &reach_in_cross);
            let reach_along: PolyVector = second_axis.map(|a| along.scale(a));
            let reach_across: PolyVector = std::array::from_fn(|i| reach_in_cross[i].sub(&reach_along[i]));
            let reach_across_turned = constant_cross(second_axis, &reach_across);
            let cos_coefficient = constant_dot(first_axis, &reach_across);
            let sin_coefficient = constant_dot(first_axis, &reach_across_turned);
            let coefficients_squared =
                cos_coefficient.mul(&cos_coefficient).add(&sin_coefficient.mul(&sin_coefficient));
            // τ = sign(A sin β − B cos β) at the assembly (module documentation).
            let beta = tree[joints[1]];
            let side = value(&cos_coefficient) * beta.sin() - value(&sin_coefficient) * beta.cos();
            let sphere_centre = std::array::from_fn(|i| knee_centre[i].sub(&offset[i]));
            Ok(Leg {
                shin: model.bodies[shin].name.clone(),
                knee: Knee {
                    joints,
                    first_axis,
                    frame: knee_frame,
                    axial_offset: constant_dot(first_axis, &reach_along),
                    reach_along,
                    reach_across,
                    reach_across_turned,
                    cos_coefficient,
                    sin_coefficient,
                    coefficients_squared,
                    side: if side >= 0.0 { 1.0 } else { -1.0 },
                },
                knee_centre,
                sphere_centre,
                reach_squared: norm_squared(&reach),
            })
        };
        // The platform's world rotation, constant (checked by the caller at sampled states).
        // The file's numbers, rounded to a dozen digits, leave it off a clean value by about
        // 10⁻¹³, which would enter the code as noise terms: entries that close to 0, ±½, ±√2/2,
        // ±√3/2 or ±1 are taken as those.
        let platform_rotation: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| clean(value(&frames[platform].rotation[i][j]))));
        let offset = |local: &PolyVector| mat_vec(&constant_matrix(platform_rotation), local);
        // The carrier: the platform's universal joint on its shin.
        let (platform_joints, platform_cross, carrier_shin) = universal(platform)?;
        let (_, platform_cross_xyz, platform_cross_rotation, _, _) =
            serial(model, platform_cross).ok_or("a cross is placed directly")?;
        let (_, _, platform_own_rotation, _, _) =
            serial(model, platform).ok_or("the platform is placed directly")?;
        let zero = [Poly::zero(), Poly::zero(), Poly::zero()];
        let mut legs = vec![leg(carrier_shin, platform_cross_xyz.clone(), &zero)?];
        let mut shins = vec![carrier_shin, platform];
        for closure in closures {
            let [first, second] = closure.points;
            let (on_shin, on_platform) =
                if point_body(second) == Some(platform) { (first, second) } else { (second, first) };
            let shin = point_body(on_shin).ok_or("a closure's point is on the base")?;
            if shins.contains(&shin) {
                return Err("two legs end on one body".into());
            }
            shins.push(shin);
            legs.push(leg(
                shin,
                model.points[on_shin].position.clone(),
                &offset(&model.points[on_platform].position),
            )?);
        }
        let mut used: Vec<usize> = legs.iter().flat_map(|l| l.knee.joints).chain(platform_joints).collect();
        used.sort_unstable();
        used.dedup();
        if used.len() != 8 {
            return Err("the legs' universal joints are not the eight passive joints".into());
        }
        // The platform's joint: R(a₃, γ) R(a₄, δ) = M = (R_S O₃)ᵀ R_P O₄ᵀ, with R(a₄, δ) O₄ =
        // O₄ R(O₄ᵀ… ): written with a₄ turned by O₄ (`second`), M = Fᵀ R_P O₄ᵀ.
        let first_axis = axis(platform_joints[0]);
        let second = mat3_vec(&mut Numbers, &platform_own_rotation, &axis(platform_joints[1]));
        let across = sub(second, scaled(dot(first_axis, second), first_axis));
        let across_squared = dot(across, across);
        if across_squared < 1e-12 {
            return Err("the platform's universal joint has parallel axes".into());
        }
        let normal = sub(first_axis, scaled(dot(first_axis, second), second));
        // R_P O₄ᵀ applied to a₄ and to e.
        let platform_unturned: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                (0..3).map(|k| platform_rotation[i][k] * platform_own_rotation[j][k]).sum()
            })
        });
        let frame = mat_mul(&frames[carrier_shin].rotation, &constant_matrix(platform_cross_rotation));
        let turned_axis = mat_vec(
            &transpose3(&frame),
            &mat3_vec(&mut Numbers, &platform_unturned, &second).map(Poly::constant),
        );
        let turned_normal = mat_vec(
            &transpose3(&frame),
            &mat3_vec(&mut Numbers, &platform_unturned, &normal).map(Poly::constant),
        );
        let platform_joint = PlatformJoint {
            joints: platform_joints,
            normal,
            normal_turned: cross(first_axis, normal),
            normal_axial: scaled(dot(first_axis, normal), first_axis),
            normal_squared: dot(normal, normal),
            first_cos: constant_dot(scaled(1.0 / across_squared, across), &turned_axis),
            first_sin: constant_dot(scaled(1.0 / across_squared, cross(first_axis, across)), &turned_axis),
            turned_axis,
            turned_normal,
        };
        let legs: [Leg; 3] = legs.try_into().map_err(|_| "not three legs".to_string())?;
        // σ: the side of the spheres' plane of centres the assembly's platform is on.
        let centres = legs.clone().map(|l| l.sphere_centre.map(|p| value(&p)));
        let origin = frames[platform].origin.clone().map(|p| value(&p));
        let normal_of_centres = cross(sub(centres[1], centres[0]), sub(centres[2], centres[0]));
        let height = dot(sub(origin, centres[0]), normal_of_centres);
        if !height.is_finite() || height == 0.0 {
            return Err("the platform lies in the plane of the spheres' centres at the assembly".into());
        }
        let platform_points = (0..model.points.len())
            .filter(|&i| model.points[i].body == Some(platform))
            .map(|i| (i, mat_vec(&constant_matrix(platform_rotation), &model.points[i].position)))
            .collect();
        Ok(ThreeSpheres {
            platform: model.bodies[platform].name.clone(),
            platform_points,
            legs,
            platform_joint,
            sphere_side: height.signum(),
        })
    }
}

impl ThreeSpheres {
    /// The offset `R_P c` of model point `point` from the platform's origin, if the point is on
    /// the platform (it then moves as the origin does).
    pub fn platform_point(&self, point: usize) -> Option<&[Poly; 3]> {
        self.platform_points.iter().find(|(i, _)| *i == point).map(|(_, offset)| offset)
    }

    /// Adds the closed form to `dag`: from then on the passive joints' sines, cosines and
    /// velocities and the atoms of `A`, `Ȧ` and `Ȧ q̇_a` stand for nodes computed from the
    /// actuated coordinates and velocities.
    pub fn install(&self, dag: &mut Dag, atoms: &ClosedFormAtoms<'_>) -> ClosedFormNodes {
        let mut out = ClosedFormNodes::default();
        let n = atoms.actuated;
        // A node that is two values (the platform's swing undoes the carrier's knee twist:
        // one cosine) keeps its first name.
        let hint = |dag: &Dag, out: &mut ClosedFormNodes, id: NodeId, name: String| {
            if dag.constant_value(id).is_none() && out.hints.iter().all(|(named, _)| *named != id) {
                out.hints.push((id, name));
            }
        };
        let axes = ["x", "y", "z"];
        let mut v = Builder { dag };
        // Position level: the three spheres.
        let centres = self.legs.clone().map(|l| v.poly3(&l.sphere_centre));
        let radii_squared = self.legs.clone().map(|l| v.poly(&l.reach_squared));
        let first_side = v.sub3(&centres[1], &centres[0]);
        let second_side = v.sub3(&centres[2], &centres[0]);
        let g11 = v.dot(&first_side, &first_side);
        let g12 = v.dot(&first_side, &second_side);
        let g22 = v.dot(&second_side, &second_side);
        for (k, g) in [(1, g11), (2, g22)] {
            hint(v.dag, &mut out, g, format!("{}_from_{}_sphere_sq", self.legs[k].shin, self.legs[0].shin));
        }
        for (k, (leg, centre)) in self.legs.iter().zip(&centres).enumerate() {
            for (axis, &id) in axes.iter().zip(centre) {
                hint(v.dag, &mut out, id, format!("{}_sphere_centre_{axis}", leg.shin));
                // The reach `O − C_k` reads the centre negated, which the sign choice may emit
                // in its place.
                let negated = v.dag.neg(id);
                hint(v.dag, &mut out, negated, format!("minus_{}_sphere_centre_{axis}", leg.shin));
            }
            if k > 0 {
                let side = if k == 1 { first_side } else { second_side };
                for (axis, &id) in axes.iter().zip(&side) {
                    hint(
                        v.dag,
                        &mut out,
                        id,
                        format!("{}_from_{}_sphere_{axis}", leg.shin, self.legs[0].shin),
                    );
                }
            }
        }
        hint(v.dag, &mut out, g12, "sphere_sides_dot".into());
        let half = v.dag.constant(0.5);
        let along = |v: &mut Builder, other: NodeId, norm: NodeId| {
            let difference = v.dag.sub(radii_squared[0], other);
            let sum = v.dag.add(difference, norm);
            v.dag.mul(half, sum)
        };
        let h1 = along(&mut v, radii_squared[1], g11);
        let h2 = along(&mut v, radii_squared[2], g22);
        // `h_k = (O − C_1)·(C_k − C_1)`: how far the platform lies along each side.
        for (k, h) in [(1, h1), (2, h2)] {
            hint(v.dag, &mut out, h, format!("{}_along_{}_side", self.platform, self.legs[k].shin));
        }
        let g11g22 = v.dag.mul(g11, g22);
        let g12g12 = v.dag.mul(g12, g12);
        let gram = v.dag.sub(g11g22, g12g12);
        hint(v.dag, &mut out, gram, "sphere_sides_gram".into());
        let solve = |v: &mut Builder, a: NodeId, b: NodeId, c: NodeId, d: NodeId| {
            let numerator = product_difference(v.dag, [a, b], [c, d]);
            v.dag.div(numerator, gram)
        };
        let first_weight = solve(&mut v, h1, g22, h2, g12);
        let second_weight = solve(&mut v, h2, g11, h1, g12);
        let in_plane_first = v.scale3(first_weight, &first_side);
        let in_plane_second = v.scale3(second_weight, &second_side);
        let in_plane = v.add3(&in_plane_first, &in_plane_second);
        let normal = v.cross(&first_side, &second_side);
        hint(v.dag, &mut out, first_weight, format!("{}_sphere_weight", self.legs[1].shin));
        hint(v.dag, &mut out, second_weight, format!("{}_sphere_weight", self.legs[2].shin));
        for (axis, (&along, &across)) in axes.iter().zip(in_plane.iter().zip(&normal)) {
            hint(v.dag, &mut out, along, format!("{}_in_centres_plane_{axis}", self.platform));
            hint(v.dag, &mut out, across, format!("sphere_centres_normal_{axis}"));
        }
        let in_plane_squared = v.dot(&in_plane, &in_plane);
        let height_squared_scaled = v.dag.sub(radii_squared[0], in_plane_squared);
        let height_squared = v.dag.div(height_squared_scaled, gram);
        let height = v.dag.sqrt(height_squared);
        // Named before the sign of the assembly's side: the negation is named after it.
        hint(v.dag, &mut out, height, format!("{}_height", self.platform));
        let height = if self.sphere_side < 0.0 { v.dag.neg(height) } else { height };
        let off_plane = v.scale3(height, &normal);
        let from_first = v.add3(&in_plane, &off_plane);
        let origin = v.add3(&centres[0], &from_first);
        for (axis, &id) in axes.iter().zip(&origin) {
            hint(v.dag, &mut out, id, format!("{}_origin_{axis}", self.platform));
        }
        // The shins' reaches `u_k = O − C_k`, and the knees.
        let reaches = centres.map(|c| v.sub3(&origin, &c));
        let mut angles: Vec<(usize, NodeId, NodeId)> = Vec::new();
        // The angles in the order they are computed (each reads only earlier ones), with how.
        let mut forms: Vec<Angle> = Vec::new();
        for (leg, &reach) in self.legs.iter().zip(&reaches) {
            for (axis, &id) in axes.iter().zip(&reach) {
                hint(v.dag, &mut out, id, format!("{}_reach_{axis}", leg.shin));
            }
            let knee = &leg.knee;
            let frame = knee.frame.clone().map(|row| v.poly3(&row));
            let w = v.mat_t_vec(&frame, &reach);
            let first_axis = v.const3(knee.first_axis);
            let axial = v.dot(&first_axis, &w);
            let swing = &atoms.names[knee.joints[0]];
            for (axis, &id) in axes.iter().zip(&w) {
                hint(v.dag, &mut out, id, format!("{}_reach_at_{swing}_{axis}", leg.shin));
            }
            hint(v.dag, &mut out, axial, format!("{}_reach_along_{swing}", leg.shin));
            let offset = v.poly(&knee.axial_offset);
            let c = v.dag.sub(axial, offset);
            let [a, b, r2] =
                [&knee.cos_coefficient, &knee.sin_coefficient, &knee.coefficients_squared].map(|p| v.poly(p));
            let implicit_form = AngleForm::Implicit { right: c, cos_coefficient: a, sin_coefficient: b };
            let cc = v.dag.mul(c, c);
            let discriminant = v.dag.sub(r2, cc);
            let root = v.dag.sqrt(discriminant);
            hint(v.dag, &mut out, root, format!("{}_knee_root", leg.shin));
            let root = if knee.side < 0.0 { v.dag.neg(root) } else { root };
            // With a constant `R²` (lengths that are not tunable) the coefficients are divided
            // by it here, not in the generated code.
            let (a, b, r2) = match knee.coefficients_squared.as_constant() {
                Some(k) => {
                    let [a, b] =
                        [&knee.cos_coefficient, &knee.sin_coefficient].map(|p| v.poly(&p.scale(1.0 / k)));
                    (a, b, v.dag.constant(1.0))
                }
                None => (a, b, r2),
            };
            let [ac, bc, ar, br] = [(a, c), (b, c), (a, root), (b, root)].map(|(x, y)| v.dag.mul(x, y));
            let cos_numerator = v.dag.sub(ac, br);
            let sin_numerator = v.dag.add(bc, ar);
            let cos_beta = v.dag.div(cos_numerator, r2);
            let sin_beta = v.dag.div(sin_numerator, r2);
            // v = d∥ + cos β d⊥ + sin β (a₂ × d⊥): the reach turned by the second joint.
            let [along, across, turned] =
                [&knee.reach_along, &knee.reach_across, &knee.reach_across_turned].map(|p| v.poly3(p));
            let across = v.scale3(cos_beta, &across);
            let turned = v.scale3(sin_beta, &turned);
            let partial = v.add3(&along, &across);
            let swung = v.add3(&partial, &turned);
            let reach_squared = v.poly(&leg.reach_squared);
            let axial_squared = v.dag.mul(axial, axial);
            let denominator = v.dag.sub(reach_squared, axial_squared);
            hint(v.dag, &mut out, denominator, format!("{}_reach_across_{swing}_sq", leg.shin));
            let swung_w = v.dot(&swung, &w);
            let cos_alpha_numerator = v.dag.sub(swung_w, axial_squared);
            let w_cross_axis = v.cross(&w, &first_axis);
            let sin_alpha_numerator = v.dot(&swung, &w_cross_axis);
            let cos_alpha = v.dag.div(cos_alpha_numerator, denominator);
            let sin_alpha = v.dag.div(sin_alpha_numerator, denominator);
            angles.push((knee.joints[0], sin_alpha, cos_alpha));
            angles.push((knee.joints[1], sin_beta, cos_beta));
            forms.push(Angle { joint: knee.joints[1], sin: sin_beta, cos: cos_beta, form: implicit_form });
            forms.push(Angle {
                joint: knee.joints[0],
                sin: sin_alpha,
                cos: cos_alpha,
                form: AngleForm::Ratio {
                    sin_numerator: sin_alpha_numerator,
                    cos_numerator: cos_alpha_numerator,
                    scale: denominator,
                },
            });
            for (joint, sin, cos) in
                [(knee.joints[1], sin_beta, cos_beta), (knee.joints[0], sin_alpha, cos_alpha)]
            {
                hint(v.dag, &mut out, sin, format!("sin_{}", atoms.names[joint]));
                hint(v.dag, &mut out, cos, format!("cos_{}", atoms.names[joint]));
                v.dag.substitute(Atom::Sin(joint as u16), sin);
                v.dag.substitute(Atom::Cos(joint as u16), cos);
            }
            // The ratios' numerators, after the sines and cosines: where a division by a
            // constant 1 leaves the numerator itself, it keeps the angle's name.
            for (joint, sin_numerator, cos_numerator) in [
                (knee.joints[1], sin_numerator, cos_numerator),
                (knee.joints[0], sin_alpha_numerator, cos_alpha_numerator),
            ] {
                hint(v.dag, &mut out, sin_numerator, format!("sin_{}_numerator", atoms.names[joint]));
                hint(v.dag, &mut out, cos_numerator, format!("cos_{}_numerator", atoms.names[joint]));
            }
            let margin = v.dag.div(denominator, reach_squared);
            hint(v.dag, &mut out, margin, format!("{}_knee_margin", leg.shin));
            out.margins.push(margin);
        }
        // The platform's joint, from the carrier's knee angles (substituted above).
        let joint = &self.platform_joint;
        let cos_gamma = v.poly(&joint.first_cos);
        let sin_gamma = v.poly(&joint.first_sin);
        hint(v.dag, &mut out, sin_gamma, format!("sin_{}", atoms.names[joint.joints[0]]));
        hint(v.dag, &mut out, cos_gamma, format!("cos_{}", atoms.names[joint.joints[0]]));
        let turned_axis = v.poly3(&joint.turned_axis);
        let turned_normal = v.poly3(&joint.turned_normal);
        let second = &atoms.names[joint.joints[1]];
        for (axis, (&a, &e)) in axes.iter().zip(turned_axis.iter().zip(&turned_normal)) {
            hint(v.dag, &mut out, a, format!("{second}_axis_{axis}"));
            hint(v.dag, &mut out, e, format!("{second}_normal_{axis}"));
        }
        let [normal, normal_turned, normal_axial] =
            [joint.normal, joint.normal_turned, joint.normal_axial].map(|c| v.const3(c));
        let one = v.dag.constant(1.0);
        let versine = v.dag.sub(one, cos_gamma);
        let normal_cos = v.scale3(cos_gamma, &normal);
        let normal_sin = v.scale3(sin_gamma, &normal_turned);
        let normal_versine = v.scale3(versine, &normal_axial);
        let partial = v.add3(&normal_cos, &normal_sin);
        let normal_swung = v.add3(&partial, &normal_versine);
        let normal_squared = v.dag.constant(joint.normal_squared);
        let cos_delta_numerator = v.dot(&normal_swung, &turned_normal);
        let cross = v.cross(&normal_swung, &turned_normal);
        let sin_delta_numerator = v.dot(&turned_axis, &cross);
        let cos_delta = v.dag.div(cos_delta_numerator, normal_squared);
        let sin_delta = v.dag.div(sin_delta_numerator, normal_squared);
        angles.push((joint.joints[0], sin_gamma, cos_gamma));
        angles.push((joint.joints[1], sin_delta, cos_delta));
        forms.push(Angle { joint: joint.joints[0], sin: sin_gamma, cos: cos_gamma, form: AngleForm::Unit });
        forms.push(Angle {
            joint: joint.joints[1],
            sin: sin_delta,
            cos: cos_delta,
            form: AngleForm::Ratio {
                sin_numerator: sin_delta_numerator,
                cos_numerator: cos_delta_numerator,
                scale: normal_squared,
            },
        });
        hint(v.dag, &mut out, sin_delta, format!("sin_{}", atoms.names[joint.joints[1]]));
        hint(v.dag, &mut out, cos_delta, format!("cos_{}", atoms.names[joint.joints[1]]));
        for (joint, sin, cos) in
            [(joint.joints[0], sin_gamma, cos_gamma), (joint.joints[1], sin_delta, cos_delta)]
        {
            v.dag.substitute(Atom::Sin(joint as u16), sin);
            v.dag.substitute(Atom::Cos(joint as u16), cos);
        }
        angles.sort_by_key(|a| a.0);
        for &(joint, sin, cos) in &angles {
            out.atoms.push((Atom::Sin(joint as u16), sin));
            out.atoms.push((Atom::Cos(joint as u16), cos));
        }
        // U⁻¹ = [u₂ × u₃, u₃ × u₁, u₁ × u₂] / det U: the platform's motion from the knees'.
        let row_crosses = [
            v.cross(&reaches[1], &reaches[2]),
            v.cross(&reaches[2], &reaches[0]),
            v.cross(&reaches[0], &reaches[1]),
        ];
        let determinant = v.dot(&reaches[0], &row_crosses[0]);
        hint(v.dag, &mut out, determinant, format!("{}_reaches_determinant", self.platform));
        let inverse_determinant = v.dag.div(one, determinant);
        hint(v.dag, &mut out, inverse_determinant, format!("{}_reaches_inverse_determinant", self.platform));
        let inverse_columns = row_crosses.map(|c| v.scale3(inverse_determinant, &c));
        // Margin: det² U / Π b_k².
        let determinant_squared = v.dag.mul(determinant, determinant);
        let r01 = v.dag.mul(radii_squared[0], radii_squared[1]);
        let radii_product = v.dag.mul(r01, radii_squared[2]);
        let parallel_margin = v.dag.div(determinant_squared, radii_product);
        hint(v.dag, &mut out, parallel_margin, format!("{}_parallel_margin", self.platform));
        out.margins.insert(0, parallel_margin);
        let knee_centres = self.legs.clone().map(|l| v.poly3(&l.knee_centre));
        // `U⁻¹ r` for a right-hand side `r`.
        let implicit = |v: &mut Builder, right: [NodeId; 3]| -> Vector {
            let terms = [0, 1, 2].map(|k| v.scale3(right[k], &inverse_columns[k]));
            let partial = v.add3(&terms[0], &terms[1]);
            v.add3(&partial, &terms[2])
        };
        // Velocity level: A column by column, each by differentiating along one actuated
        // coordinate, the platform's motion `U⁻¹ [u_k·∂K_k/∂q_j]` given, and each angle's rate
        // from its form (`Angle::rate`) with the earlier angles' as given: the derivatives
        // never pass through a division or square root of the position level.
        let mut columns: Vec<Vec<NodeId>> = Vec::new();
        let mut platform_columns: Vec<Vector> = Vec::new();
        for j in 0..n {
            let mut known = HashMap::default();
            let mut rule = |dag: &mut Dag, atom: Atom| match atom {
                Atom::Sin(k) if usize::from(k) == j => dag.input(Atom::Cos(k)),
                Atom::Cos(k) if usize::from(k) == j => {
                    let sin = dag.input(Atom::Sin(k));
                    dag.neg(sin)
                }
                Atom::Q(k) if usize::from(k) == j => dag.constant(1.0),
                _ => dag.constant(0.0),
            };
            let right = [0, 1, 2].map(|k| {
                let moved = knee_centres[k].map(|id| v.dag.derivative(id, &mut known, &mut rule));
                v.dot(&reaches[k], &moved)
            });
            let platform_motion = implicit(&mut v, right);
            for (&id, &d) in origin.iter().zip(&platform_motion) {
                known.insert(id, d);
            }
            platform_columns.push(platform_motion);
            let mut column = Vec::new();
            for angle in &forms {
                let rate = angle.rate(v.dag, &mut known, &mut rule);
                angle.given_rate(v.dag, &mut known, rate);
                column.push((angle.joint, rate));
            }
            column.sort_by_key(|&(joint, _)| joint);
            columns.push(column.into_iter().map(|(_, rate)| rate).collect());
        }
        let velocities: Vec<NodeId> = (0..n).map(|j| v.dag.input(Atom::Qd(j as u16))).collect();
        let combine = |v: &mut Builder, entries: &[NodeId]| -> NodeId {
            let mut sum = v.dag.constant(0.0);
            for (&entry, &velocity) in entries.iter().zip(&velocities) {
                let term = v.dag.mul(entry, velocity);
                sum = v.dag.add(sum, term);
            }
            sum
        };
        for (r, &(joint, _, _)) in angles.iter().enumerate() {
            let row: Vec<NodeId> = columns.iter().map(|column| column[r]).collect();
            for (j, &entry) in row.iter().enumerate() {
                hint(v.dag, &mut out, entry, format!("{}_per_{}", atoms.names[joint], atoms.names[j]));
                let atom = (atoms.sensitivity)(joint - n, j, false);
                v.dag.substitute(atom, entry);
                out.atoms.push((atom, entry));
            }
            let rate = combine(&mut v, &row);
            hint(v.dag, &mut out, rate, format!("{}_dot", atoms.names[joint]));
            let atom = Atom::Qd(joint as u16);
            v.dag.substitute(atom, rate);
            out.atoms.push((atom, rate));
        }
        // Acceleration level, along the velocity: Ȯ = Σ_j (∂O/∂q_j) q̇_j, and at q̈_a = 0
        // U Ö = [u_k·K̈_k − |Ȯ − K̇_k|²].
        let mut known = HashMap::default();
        let mut along_velocity = |dag: &mut Dag, atom: Atom| match atom {
            Atom::Sin(k) if usize::from(k) < n => {
                let cos = dag.input(Atom::Cos(k));
                let velocity = dag.input(Atom::Qd(k));
                dag.mul(cos, velocity)
            }
            Atom::Cos(k) if usize::from(k) < n => {
                let sin = dag.input(Atom::Sin(k));
                let velocity = dag.input(Atom::Qd(k));
                let product = dag.mul(sin, velocity);
                dag.neg(product)
            }
            Atom::Q(k) if usize::from(k) < n => dag.input(Atom::Qd(k)),
            _ => dag.constant(0.0),
        };
        let platform_velocity: Vector = std::array::from_fn(|i| {
            combine(&mut v, &platform_columns.iter().map(|c| c[i]).collect::<Vec<_>>())
        });
        for (axis, &id) in axes.iter().zip(&platform_velocity) {
            hint(v.dag, &mut out, id, format!("{}_origin_{axis}_dot", self.platform));
        }
        let right = [0, 1, 2].map(|k| {
            let knee_velocity =
                knee_centres[k].map(|id| v.dag.derivative(id, &mut known, &mut along_velocity));
            let knee_acceleration =
                knee_velocity.map(|id| v.dag.derivative(id, &mut known, &mut along_velocity));
            let relative = v.sub3(&platform_velocity, &knee_velocity);
            let relative_squared = v.dot(&relative, &relative);
            let reach_acceleration = v.dot(&reaches[k], &knee_acceleration);
            v.dag.sub(reach_acceleration, relative_squared)
        });
        let platform_acceleration = implicit(&mut v, right);
        out.platform = PlatformMotion {
            origin,
            jacobian: platform_columns.clone(),
            convective_acceleration: platform_acceleration,
        };
        for ((&id, &d), &dd) in origin.iter().zip(&platform_velocity).zip(&platform_acceleration) {
            known.insert(id, d);
            known.insert(d, dd);
        }
        // Each angle's acceleration at `q̈_a = 0` from its form, the earlier angles' rates and
        // accelerations given.
        let rate_of =
            |joint: usize| out.atoms.iter().find(|(atom, _)| *atom == Atom::Qd(joint as u16)).map(|a| a.1);
        let rates: Vec<NodeId> =
            forms.iter().map(|angle| rate_of(angle.joint).unwrap_or(angle.sin)).collect();
        for (angle, &rate) in forms.iter().zip(&rates) {
            let convective = angle.convective_acceleration(v.dag, &mut known, &mut along_velocity, rate);
            angle.given_rate(v.dag, &mut known, rate);
            known.entry(rate).or_insert(convective);
            let name = &atoms.names[angle.joint];
            hint(v.dag, &mut out, convective, format!("{name}_convective_acceleration"));
            let atom = (atoms.convective)(angle.joint - n);
            v.dag.substitute(atom, convective);
            out.atoms.push((atom, convective));
        }
        for (r, &(joint, _, _)) in angles.iter().enumerate() {
            for (j, column) in columns.iter().enumerate() {
                let rate = v.dag.derivative(column[r], &mut known, &mut along_velocity);
                hint(v.dag, &mut out, rate, format!("{}_per_{}_rate", atoms.names[joint], atoms.names[j]));
                let atom = (atoms.sensitivity)(joint - n, j, true);
                v.dag.substitute(atom, rate);
                out.atoms.push((atom, rate));
            }
        }
        out
    }
}
