//! Closed kinematic chains, reduced to the actuated coordinates.
//!
//! A closed chain is described as an open tree plus loop-closure constraints: the tree has
//! every joint as a coordinate — the actuated joints `q_a` (`0 … N−1`, the coordinates of the
//! generated code) and the passive joints `q_p` (`N …`) — and each [closure](Loop) says that
//! two points, one turned by each of two passive revolute joints, coincide:
//! `Φ(q) = p₁(q) − p₂(q) = 0`. The mechanics of the tree are derived as usual
//! ([`crate::dynamics::mechanics`]); this module eliminates the passive joints.
//!
//! **Position level, in closed form.** Each point is `p_k = c_k(q_a) + M_k(q_a) [cos q_pk,
//! sin q_pk]ᵀ`: a circle of radius `r_k = √|det M_k|` about the axis `c_k` of its joint. The
//! joined point `E` is the intersection of the two circles on the chosen branch,
//! `E = c₁ + (k d + σ √Δ d⊥) / (2|d|²)` with `d = c₂ − c₁`, `d⊥ = (−d_y, d_x)`,
//! `k = |d|² + r₁² − r₂²`, `Δ = 4|d|² r₁² − k²` and `σ = +1` for `branch: left`
//! (`(c₂ − c₁) × (E − c₁) > 0`), `−1` for `right`. The passive angles enter the tree's
//! polynomials only through their sines and cosines, `[cos q_pk, sin q_pk]ᵀ = M_k⁻¹ (E − c_k)`,
//! so no inverse trigonometric function is needed.
//!
//! **Velocity and acceleration level, by the implicit-function relation.**
//! `q̇_p = A q̇_a` with `A = −Φ_p⁻¹ Φ_a` (`Φ_p = ∂Φ/∂q_p`, 2 × 2 per closure, inverted in
//! closed form), so `q̇ = S q̇_a` with `S = [I; A]`; and `Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a)`, so that
//! `γ = Ȧ q̇_a` is the passive acceleration at `q̈_a = 0`. The entries of `A` and `Ȧ` are
//! [`Atom::Closure`] atoms of the reduced polynomials:
//! `D_a = Sᵀ D S`, `C_a = Sᵀ (C S + D Ṡ)` (so that `Ḋ_a − 2 C_a` is skew-symmetric),
//! `C_a q̇_a = Sᵀ (C q̇ + D Ṡ q̇_a)`, `g_a = Sᵀ g`, `J_a = J S`, `J̇_a = J̇ S + J Ṡ`,
//! `J̇_a q̇_a = J̇ q̇ + J Ṡ q̇_a`, with the tree's quantities evaluated at `q̇ = S q̇_a`.
//! [`install`] defines every such atom as a node of an expression DAG, in front of the
//! outputs, so the generated code computes them once per function, straight-line.
//!
//! **Singular configurations.** Where the loop cannot close (`Δ < 0`: the actuated angles
//! put the two circles apart) the square root is NaN; where the two distal links are
//! aligned (`Δ = 0`, the workspace boundary) `det Φ_p = 0` and the divisions give infinite
//! or NaN values. The generated functions never panic: they return non-finite numbers,
//! which the runtime's checks treat as a fault (safe state). The model's joint limits
//! should keep the actuated angles where the loop closes away from that boundary.

use super::kinematics::point_positions;
use super::spatial_loops::SpatialLoops;
use super::three_spheres::{ClosedFormAtoms, PlatformMotion};
use crate::model::{Branch, LoopClosure, Model};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, AtomValues, Poly, State};

/// A problem with a declared closure, reported at `closures[closure].key`.
#[derive(Clone, Debug)]
pub struct Problem {
    /// Index into the declarations.
    pub closure: usize,
    /// The key of the closure entry the problem is about (`None`: the entry itself).
    pub key: Option<&'static str>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: Option<String>,
}

/// One loop closure, analysed: the polynomials its elimination needs.
#[derive(Clone, Debug)]
pub struct Loop {
    /// The closure's name (names intermediates in the generated code).
    pub name: String,
    /// The two passive joints, as coordinates of the open tree.
    pub joints: [usize; 2],
    /// The two points that coincide (indices into the model's points).
    pub points: [usize; 2],
    /// `σ = +1` (`left`) or `−1` (`right`).
    pub branch_sign: f64,
    /// `c_k`: the axis of each passive joint in the base frame (functions of `q_a`).
    pub centres: [[Poly; 2]; 2],
    /// `M_k`: `p_k = c_k + M_k [cos q_pk, sin q_pk]ᵀ`, row-major.
    pub arms: [[[Poly; 2]; 2]; 2],
    /// `det M_k` (constant, or a function of tunable parameters).
    pub arm_determinants: [Poly; 2],
    /// `r_k² = |det M_k|`.
    pub radii_squared: [Poly; 2],
    /// `Φ = p₁ − p₂`, over all tree coordinates.
    pub residual: [Poly; 2],
    /// `Φ_p = ∂Φ/∂(q_p1, q_p2)`.
    pub passive_jacobian: [[Poly; 2]; 2],
    /// `Φ_a = ∂Φ/∂q_a`, 2 × N.
    pub actuated_jacobian: [Vec<Poly>; 2],
    /// `Φ̇_p = Σ_k ∂Φ_p/∂q_k q̇_k` (passive velocities as the atoms `q̇_p`).
    pub passive_jacobian_dot: [[Poly; 2]; 2],
    /// `Φ̇_a`, 2 × N.
    pub actuated_jacobian_dot: [Vec<Poly>; 2],
}

/// Every closure of a model and the layout of their atoms.
#[derive(Clone, Debug)]
pub struct Closures {
    /// Number of actuated coordinates `N`.
    pub actuated: usize,
    /// Names of all coordinates of the open tree (actuated, then passive).
    pub names: Vec<String>,
    /// The closures of a planar chain.
    pub loops: Vec<Loop>,
    /// The closures of a spatial chain, eliminated together and numerically (their atoms are
    /// numbered after the planar loops').
    pub spatial: Option<SpatialLoops>,
    /// The elimination as a DAG, built on first use ([`Closures::installed`]).
    evaluator: std::sync::OnceLock<(Dag, Installed)>,
}

impl Closures {
    /// The atom of `A[r][j] = ∂q_p/∂q_aj` for passive joint `r` (0 or 1) of loop `c`.
    pub fn sensitivity(&self, c: usize, r: usize, j: usize) -> Atom {
        let n = self.actuated;
        Atom::Closure((c * 4 * n + r * n + j) as u16)
    }

    /// The atom of `Ȧ[r][j]`.
    pub fn sensitivity_rate(&self, c: usize, r: usize, j: usize) -> Atom {
        let n = self.actuated;
        Atom::Closure((c * 4 * n + 2 * n + r * n + j) as u16)
    }

    /// The atom of `∂q_i/∂q_aj` (`rate`: its time derivative) for a passive tree coordinate
    /// `i`; `None` for an actuated one.
    pub(crate) fn sensitivity_atom(&self, i: usize, j: usize, rate: bool) -> Option<Atom> {
        if let Some((c, r)) = self.passive_slot(i) {
            return Some(if rate { self.sensitivity_rate(c, r, j) } else { self.sensitivity(c, r, j) });
        }
        let spatial = self.spatial.as_ref()?;
        let r = i.checked_sub(self.actuated)?;
        (r < spatial.passive).then(|| spatial.sensitivity(self.spatial_first_atom(), r, j, rate))
    }

    /// The atom of `(Ȧ q̇_a)_i`, the acceleration at `q̈_a = 0`, for a passive tree coordinate
    /// `i` of a spatial chain; `None` otherwise (a planar loop's is `Σ_j Ȧ_ij q̇_j`).
    pub(crate) fn convective_atom(&self, i: usize) -> Option<Atom> {
        let spatial = self.spatial.as_ref()?;
        let r = i.checked_sub(self.actuated)?;
        (r < spatial.passive).then(|| spatial.convective(self.spatial_first_atom(), r))
    }

    /// The first atom number of the spatial loops' sensitivities: after the planar loops'.
    fn spatial_first_atom(&self) -> usize {
        self.loops.len() * 4 * self.actuated
    }

    /// A graph holding only the elimination ([`install`] on an empty graph), and what it
    /// installed: built once, then shared (every function's graph starts as a clone of it, see
    /// [`graph_with`]).
    pub fn installed(&self) -> &(Dag, Installed) {
        self.evaluator.get_or_init(|| {
            let mut dag = Dag::new();
            let installed = install(&mut dag, Some(self));
            (dag, installed)
        })
    }

    /// The spatial loops, if the generated code solves them at run time by Newton's method
    /// (`None` for planar loops and for spatial ones in closed form).
    pub fn solved_at_run_time(&self) -> Option<&SpatialLoops> {
        self.spatial.as_ref().filter(|spatial| spatial.closed_form.is_none())
    }

    /// Loop and row of a passive coordinate.
    pub(crate) fn passive_slot(&self, coordinate: usize) -> Option<(usize, usize)> {
        self.loops
            .iter()
            .enumerate()
            .find_map(|(c, l)| l.joints.iter().position(|&j| j == coordinate).map(|r| (c, r)))
    }

    /// Values of every substituted atom, as [`Closures::values`], or why the loops cannot be
    /// closed at that state (on the file's branch): a planar loop whose two circles are apart
    /// (or touch: the workspace boundary), spatial loops where Newton's method fails or a
    /// singular configuration lies between the assembly and the state.
    pub fn checked_values(
        &self,
        q: &[f64],
        qd: &[f64],
        parameters: &[f64],
    ) -> Result<Vec<(Atom, f64)>, String> {
        if let Some(spatial) = &self.spatial {
            return spatial.checked_values(q, qd, parameters, self.spatial_first_atom());
        }
        let values = self.values(q, qd, parameters);
        for (c, closure) in self.loops.iter().enumerate() {
            let mine = |atom: &Atom| {
                (0..2).any(|r| (0..self.actuated).any(|j| *atom == self.sensitivity(c, r, j)))
                    || closure
                        .joints
                        .iter()
                        .any(|&k| matches!(atom, Atom::Sin(i) | Atom::Cos(i) if usize::from(*i) == k))
            };
            if values.iter().any(|(atom, value)| mine(atom) && !value.is_finite()) {
                return Err(format!(
                    "the loop `{}` cannot close at this state (its two links cannot reach each other, or are aligned: the workspace boundary)",
                    closure.name
                ));
            }
        }
        Ok(values)
    }

    /// Values of every substituted atom (passive sines, cosines and velocities, `A`, `Ȧ`)
    /// at a state of the actuated coordinates, in `f64`.
    pub fn values(&self, q: &[f64], qd: &[f64], parameters: &[f64]) -> Vec<(Atom, f64)> {
        if let Some(spatial) = &self.spatial {
            return spatial.values(q, qd, parameters, self.spatial_first_atom());
        }
        let (dag, installed) = self.installed();
        let state = State { q, qd, parameters };
        let values = dag.eval_all(&|a: Atom| state.value(a));
        installed.atoms.iter().map(|&(atom, id)| (atom, values[id])).collect()
    }
}

/// What [`install`] added to a DAG.
#[derive(Clone, Debug, Default)]
pub struct Installed {
    /// Names for the nodes of the elimination (for readable generated code).
    pub hints: Vec<(NodeId, String)>,
    /// Every atom substituted, with its node.
    pub atoms: Vec<(Atom, NodeId)>,
    /// Per closure, its assembly margin `Δ / (4 r₁² r₂²)`: the squared sine of the angle
    /// between the two distal links (`(E − c₁) × (E − c₂) = σ √Δ / 2`). 1 with the links
    /// square to each other, 0 exactly where `det Φ_p = 0` (the links aligned: the workspace
    /// boundary, or the passive joints' axes coincident), negative where the loop cannot
    /// close.
    pub margins: Vec<NodeId>,
    /// A Delta's platform motion (its loops in closed form), for the points on the platform.
    pub platform: Option<PlatformMotion>,
}

fn poly_of_monomial(monomial: &[(Atom, u32)], coefficient: f64) -> Poly {
    monomial.iter().fold(Poly::constant(coefficient), |acc, &(atom, e)| {
        (0..e).fold(acc, |acc, _| acc.mul(&Poly::atom(atom)))
    })
}

/// Analyses declared closures: splits each point into centre and arm, checks that the
/// elimination applies and that the loop closes at the middle of the actuated ranges.
pub fn analyse(model: &Model, declarations: &[LoopClosure]) -> Result<Closures, Vec<Problem>> {
    let n = model.joints.len();
    let total = model.tree_coordinates();
    let positions = point_positions(model);
    let parameters = model.nominal_parameters();
    // The actuated coordinates at the middle of their ranges.
    let middle: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
    let nominal = State { q: &middle, qd: &[], parameters: &parameters };
    let names: Vec<String> = (0..total).map(|j| model.coordinate_name(j).to_string()).collect();
    let mut problems = Vec::new();
    let mut loops = Vec::new();
    'closures: for (c, d) in declarations.iter().enumerate() {
        let problem = |key: Option<&'static str>, message: String, hint: Option<String>| Problem {
            closure: c,
            key,
            message,
            hint,
        };
        let zero = Poly::zero;
        let mut centres = [[zero(), zero()], [zero(), zero()]];
        let mut arms = [[[zero(), zero()], [zero(), zero()]], [[zero(), zero()], [zero(), zero()]]];
        for k in 0..2 {
            let (point, joint) = (&model.points[d.points[k]].name, &names[d.joints[k]]);
            let Some(position) = positions.get(d.points[k]) else { continue 'closures };
            let own = d.joints[k] as u16;
            for (row, p) in position.iter().enumerate().take(2) {
                for (monomial, coefficient) in p.terms() {
                    let (mut cos_e, mut sin_e, mut rest) = (0, 0, Vec::new());
                    for &(atom, e) in monomial {
                        match atom {
                            Atom::Cos(j) if j == own => cos_e = e,
                            Atom::Sin(j) if j == own => sin_e = e,
                            Atom::Sin(j) | Atom::Cos(j) | Atom::Q(j) if usize::from(j) >= n => {
                                problems.push(problem(
                                    Some("points"),
                                    format!(
                                        "point `{point}` moves with passive joint `{}`, but it must hang on the link of `{joint}`",
                                        names[usize::from(j)]
                                    ),
                                    Some(
                                        "pair points and joints in order: `points[k]` hangs on the link that `joints[k]` turns, after actuated joints only"
                                            .into(),
                                    ),
                                ));
                                continue 'closures;
                            }
                            _ => rest.push((atom, e)),
                        }
                    }
                    let term = poly_of_monomial(&rest, coefficient);
                    let slot = match (cos_e, sin_e) {
                        (0, 0) => &mut centres[k][row],
                        (1, 0) => &mut arms[k][row][0],
                        (0, 1) => &mut arms[k][row][1],
                        _ => {
                            problems.push(problem(
                                Some("points"),
                                format!("joint `{joint}` turns point `{point}` more than once"),
                                Some("a closure's point hangs on one link turned by its joint".into()),
                            ));
                            continue 'closures;
                        }
                    };
                    *slot = slot.add(&term);
                }
            }
            if arms[k].iter().flatten().all(Poly::is_zero) {
                problems.push(problem(
                    Some("points"),
                    format!("point `{point}` is not moved by joint `{joint}`"),
                    Some(format!("put `{point}` on the link that `{joint}` turns (closure joints and points pair up in order)")),
                ));
                continue 'closures;
            }
        }
        let determinant = |m: &[[Poly; 2]; 2]| m[0][0].mul(&m[1][1]).sub(&m[0][1].mul(&m[1][0]));
        let arm_determinants = [determinant(&arms[0]), determinant(&arms[1])];
        let mut radii_squared = [zero(), zero()];
        for k in 0..2 {
            let (point, joint) = (&model.points[d.points[k]].name, &names[d.joints[k]]);
            let det = &arm_determinants[k];
            if det.atoms().any(|a| !matches!(a, Atom::Param(_))) {
                problems.push(problem(
                    Some("points"),
                    format!(
                        "the distance of point `{point}` from the axis of joint `{joint}` is not constant"
                    ),
                    None,
                ));
                continue 'closures;
            }
            let value = det.eval(&nominal);
            if value.is_nan() || value.abs() <= 1e-16 {
                problems.push(problem(
                    Some("points"),
                    format!("point `{point}` lies on the axis of joint `{joint}`"),
                    Some("the point must be at the far end of the link the joint turns".into()),
                ));
                continue 'closures;
            }
            radii_squared[k] = det.scale(value.signum());
        }
        // The loop must close at the middle of the actuated ranges.
        let value = |p: &Poly| p.eval(&nominal);
        let (a, b) = (centres[0].clone().map(|p| value(&p)), centres[1].clone().map(|p| value(&p)));
        let (r1, r2) = (value(&radii_squared[0]).sqrt(), value(&radii_squared[1]).sqrt());
        let span = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let k_value = span * span + r1 * r1 - r2 * r2;
        let discriminant = 4.0 * span * span * r1 * r1 - k_value * k_value;
        let scale = 4.0 * span * span * r1 * r1;
        if discriminant.is_nan() || discriminant <= 1e-9 * scale {
            let at: Vec<String> =
                model.joints.iter().zip(&middle).map(|(j, q)| format!("{} = {q:.4}", j.name)).collect();
            let why = if span > r1 + r2 {
                "they are too far apart"
            } else if span < (r1 - r2).abs() {
                "one lies inside the other"
            } else {
                "they touch: the links are aligned, a singular configuration"
            };
            problems.push(problem(
                None,
                format!(
                    "the loop cannot close at the middle of the actuated joints' ranges ({}): the circle of `{}` about `{}` (radius {r1:.6} m) and the circle of `{}` about `{}` (radius {r2:.6} m), {span:.6} m apart, do not intersect: {why}",
                    at.join(", "),
                    model.points[d.points[0]].name,
                    names[d.joints[0]],
                    model.points[d.points[1]].name,
                    names[d.joints[1]],
                ),
                Some("check the link lengths, the joints' origins and the actuated joints' limits".into()),
            ));
            continue;
        }
        let p1 = &positions[d.points[0]];
        let p2 = &positions[d.points[1]];
        let residual = [p1[0].sub(&p2[0]), p1[1].sub(&p2[1])];
        let diff = |p: &Poly, j: usize| p.diff_q(j as u16);
        let rate = |p: &Poly| {
            Poly::sum(
                &(0..total).map(|k| diff(p, k).mul(&Poly::atom(Atom::Qd(k as u16)))).collect::<Vec<_>>(),
            )
        };
        let passive_jacobian = residual.clone().map(|phi| d.joints.map(|j| diff(&phi, j)));
        let actuated_jacobian = residual.clone().map(|phi| (0..n).map(|j| diff(&phi, j)).collect::<Vec<_>>());
        let passive_jacobian_dot = passive_jacobian.clone().map(|row| row.map(|p| rate(&p)));
        let actuated_jacobian_dot = actuated_jacobian.clone().map(|row| row.iter().map(rate).collect());
        loops.push(Loop {
            name: d.name.clone(),
            joints: d.joints,
            points: d.points,
            branch_sign: if d.branch == Branch::Left { 1.0 } else { -1.0 },
            centres,
            arms,
            arm_determinants,
            radii_squared,
            residual,
            passive_jacobian,
            actuated_jacobian,
            passive_jacobian_dot,
            actuated_jacobian_dot,
        });
    }
    if problems.is_empty() {
        Ok(Closures { actuated: n, names, loops, spatial: None, evaluator: std::sync::OnceLock::new() })
    } else {
        Err(problems)
    }
}

/// The closures of a spatial chain, analysed ([`SpatialLoops::analyse`]).
pub fn analyse_spatial(
    model: &Model,
    closures: &[crate::model::SpatialClosure],
) -> Result<Closures, Vec<super::spatial_loops::SpatialProblem>> {
    let spatial = SpatialLoops::analyse(model, closures)?;
    let names = (0..model.tree_coordinates()).map(|j| model.coordinate_name(j).to_string()).collect();
    Ok(Closures {
        actuated: model.joints.len(),
        names,
        loops: Vec::new(),
        spatial: Some(spatial),
        evaluator: std::sync::OnceLock::new(),
    })
}

/// A new graph with the elimination of `closures` in front (an empty one without closures),
/// and what it installed: [`install`] on an empty graph, cloned from the one
/// [`Closures::installed`] keeps (a Delta's closed form and its derivatives are built once).
pub fn graph_with(closures: Option<&Closures>) -> (Dag, Installed) {
    match closures {
        Some(closures) => closures.installed().clone(),
        None => (Dag::new(), Installed::default()),
    }
}

/// Adds the elimination of every closure to `dag`: from then on the passive joints' sines,
/// cosines and velocities and the [`Atom::Closure`] atoms stand for nodes computed from the
/// actuated coordinates. Does nothing without closures.
pub fn install(dag: &mut Dag, closures: Option<&Closures>) -> Installed {
    let mut out = Installed::default();
    let Some(closures) = closures else { return out };
    let n = closures.actuated;
    if let Some(spatial) = &closures.spatial {
        if let Some(closed_form) = &spatial.closed_form {
            let first_atom = closures.spatial_first_atom();
            let sensitivity = |r: usize, j: usize, rate: bool| spatial.sensitivity(first_atom, r, j, rate);
            let convective = |r: usize| spatial.convective(first_atom, r);
            let atoms = ClosedFormAtoms {
                actuated: n,
                sensitivity: &sensitivity,
                convective: &convective,
                names: &closures.names,
            };
            let nodes = closed_form.install(dag, &atoms);
            out.hints = nodes.hints;
            out.atoms = nodes.atoms;
            out.margins = nodes.margins;
            out.platform = Some(nodes.platform);
        }
    }
    for (c, l) in closures.loops.iter().enumerate() {
        let name = |dag: &Dag, id: NodeId, text: String, out: &mut Installed| {
            if dag.constant_value(id).is_none() {
                out.hints.push((id, text));
            }
        };
        let poly = |dag: &mut Dag, p: &Poly| dag.polynomial(p);
        let passive_names = l.joints.map(|j| closures.names[j].clone());
        // Position level: the intersection of the two circles.
        let centre = |dag: &mut Dag, k: usize| [poly(dag, &l.centres[k][0]), poly(dag, &l.centres[k][1])];
        let (a, b) = (centre(dag, 0), centre(dag, 1));
        for (k, centre) in [a, b].iter().enumerate() {
            name(dag, centre[0], format!("{}_axis_x", passive_names[k]), &mut out);
            name(dag, centre[1], format!("{}_axis_y", passive_names[k]), &mut out);
        }
        let r1 = poly(dag, &l.radii_squared[0]);
        let r2 = poly(dag, &l.radii_squared[1]);
        let dx = dag.sub(b[0], a[0]);
        let dy = dag.sub(b[1], a[1]);
        let dx2 = dag.mul(dx, dx);
        let dy2 = dag.mul(dy, dy);
        let span = dag.add(dx2, dy2);
        name(dag, span, format!("{}_span_sq", l.name), &mut out);
        let radii = dag.sub(r1, r2);
        let k = dag.add(span, radii);
        let four = dag.constant(4.0);
        let span_r1 = dag.mul(span, r1);
        let scaled = dag.mul(four, span_r1);
        let k2 = dag.mul(k, k);
        let discriminant = dag.sub(scaled, k2);
        name(dag, discriminant, format!("{}_discriminant", l.name), &mut out);
        // `E − c₁` and `E − c₂` are the two distal links; their cross product is
        // `d × (E − c₁) = σ √Δ / 2`, so `Δ / (4 r₁² r₂²)` is the squared sine of the angle
        // between them: 0 exactly where `det Φ_p` vanishes (links aligned, or the elbows
        // coincident, where `|d|² → 0` would make a ratio to `|d|²` read 1).
        let radii_product = dag.mul(r1, r2);
        let margin_scale = dag.mul(four, radii_product);
        let margin = dag.div(discriminant, margin_scale);
        name(dag, margin, format!("{}_margin", l.name), &mut out);
        out.margins.push(margin);
        let root = dag.sqrt(discriminant);
        let root = if l.branch_sign < 0.0 { dag.neg(root) } else { root };
        name(dag, root, format!("{}_root", l.name), &mut out);
        let two = dag.constant(2.0);
        let denominator = dag.mul(two, span);
        let kdx = dag.mul(k, dx);
        let kdy = dag.mul(k, dy);
        let rdy = dag.mul(root, dy);
        let rdx = dag.mul(root, dx);
        let ox = dag.sub(kdx, rdy);
        let oy = dag.add(kdy, rdx);
        // E − c₁, and E − c₂ = (E − c₁) − d.
        let ox = dag.div(ox, denominator);
        let oy = dag.div(oy, denominator);
        name(dag, ox, format!("{}_from_{}_x", l.name, passive_names[0]), &mut out);
        name(dag, oy, format!("{}_from_{}_y", l.name, passive_names[0]), &mut out);
        let relative = [[ox, oy], [dag.sub(ox, dx), dag.sub(oy, dy)]];
        for (kk, &[ux, uy]) in relative.iter().enumerate() {
            let m = l.arms[kk].clone().map(|row| row.map(|p| dag.polynomial(&p)));
            let det = poly(dag, &l.arm_determinants[kk]);
            // [cos; sin] = adj(M) u / det M.
            let m11u = dag.mul(m[1][1], ux);
            let m01u = dag.mul(m[0][1], uy);
            let cos_num = dag.sub(m11u, m01u);
            let m00u = dag.mul(m[0][0], uy);
            let m10u = dag.mul(m[1][0], ux);
            let sin_num = dag.sub(m00u, m10u);
            let cos = dag.div(cos_num, det);
            let sin = dag.div(sin_num, det);
            let j = l.joints[kk] as u16;
            name(dag, cos, format!("cos_{}", passive_names[kk]), &mut out);
            name(dag, sin, format!("sin_{}", passive_names[kk]), &mut out);
            dag.substitute(Atom::Cos(j), cos);
            dag.substitute(Atom::Sin(j), sin);
            out.atoms.push((Atom::Cos(j), cos));
            out.atoms.push((Atom::Sin(j), sin));
        }
        // Velocity level: A = −Φ_p⁻¹ Φ_a.
        let p = l.passive_jacobian.clone().map(|row| row.map(|x| dag.polynomial(&x)));
        let p00p11 = dag.mul(p[0][0], p[1][1]);
        let p01p10 = dag.mul(p[0][1], p[1][0]);
        let det = dag.sub(p00p11, p01p10);
        name(dag, det, format!("{}_constraint_det", l.name), &mut out);
        // −Φ_p⁻¹ v = (adj(Φ_p) (−v)) / det, adj = [[p11, −p01], [−p10, p00]].
        let solve = |dag: &mut Dag, v: [NodeId; 2]| -> [NodeId; 2] {
            let a0 = dag.mul(p[1][1], v[0]);
            let b0 = dag.mul(p[0][1], v[1]);
            let first = dag.sub(b0, a0);
            let a1 = dag.mul(p[1][0], v[0]);
            let b1 = dag.mul(p[0][0], v[1]);
            let second = dag.sub(a1, b1);
            [dag.div(first, det), dag.div(second, det)]
        };
        let phi_a: Vec<[NodeId; 2]> = (0..n)
            .map(|j| [dag.polynomial(&l.actuated_jacobian[0][j]), dag.polynomial(&l.actuated_jacobian[1][j])])
            .collect();
        let sensitivity: Vec<[NodeId; 2]> = phi_a.iter().map(|&v| solve(dag, v)).collect();
        for (j, column) in sensitivity.iter().enumerate() {
            for r in 0..2 {
                name(dag, column[r], format!("{}_per_{}", passive_names[r], closures.names[j]), &mut out);
                let atom = closures.sensitivity(c, r, j);
                dag.substitute(atom, column[r]);
                out.atoms.push((atom, column[r]));
            }
        }
        for r in 0..2 {
            let mut velocity = dag.constant(0.0);
            for (j, column) in sensitivity.iter().enumerate() {
                let qd = dag.input(Atom::Qd(j as u16));
                let term = dag.mul(column[r], qd);
                velocity = dag.add(velocity, term);
            }
            name(dag, velocity, format!("{}_dot", passive_names[r]), &mut out);
            let atom = Atom::Qd(l.joints[r] as u16);
            dag.substitute(atom, velocity);
            out.atoms.push((atom, velocity));
        }
        // Acceleration level: Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a).
        let pdot = l.passive_jacobian_dot.clone().map(|row| row.map(|x| dag.polynomial(&x)));
        for (j, column) in sensitivity.iter().enumerate() {
            let mut v = [0; 2];
            for (row, slot) in v.iter_mut().enumerate() {
                let mut acc = dag.polynomial(&l.actuated_jacobian_dot[row][j]);
                for (kk, &entry) in column.iter().enumerate() {
                    let t = dag.mul(pdot[row][kk], entry);
                    acc = dag.add(acc, t);
                }
                *slot = acc;
            }
            let rate = solve(dag, v);
            for r in 0..2 {
                name(dag, rate[r], format!("{}_per_{}_rate", passive_names[r], closures.names[j]), &mut out);
                let atom = closures.sensitivity_rate(c, r, j);
                dag.substitute(atom, rate[r]);
                out.atoms.push((atom, rate[r]));
            }
        }
    }
    out
}
