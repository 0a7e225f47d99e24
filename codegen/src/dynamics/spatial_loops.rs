//! The loops of a spatial closed chain (a Delta's legs), eliminated numerically.
//!
//! As for planar loops ([`super::closure`]) the chain is an open tree, every joint a
//! coordinate: the actuated `q_a` (`0 … N−1`) and the passive `q_p` (`N … N+P−1`). Each
//! spatial closure cuts the loop at a joint and asks that two points coincide,
//! `p₁(q) − p₂(q) = 0` (3 equations), and optionally that two body axes stay perpendicular,
//! `(R_A a)·(R_B b) = 0` (1 equation: the universal joint that was cut). All closures
//! together give `Φ(q) = 0`, `P` equations in the `P` passive coordinates (the resolver checks
//! the count).
//!
//! **Position level**: Newton's method on `Φ(q_a, q_p) = 0` over `q_p`,
//! `Φ_p Δq_p = −Φ`, from the assembly the file chooses (each passive joint's `assembly` angle
//! at the middle of the actuated ranges, refined here), continued along the straight line to
//! the requested `q_a` in steps, so the solution stays on the file's branch. The evaluator
//! ([`SpatialLoops::continued`]) steps at most [`CONTINUATION_STEP`] in each actuated
//! coordinate and requires the sign of `det Φ_p` to stay the assembly's. A state where Newton
//! does not converge, or which lies beyond a singular configuration, gives NaN values and the
//! reason (an error value, never the plausible-looking numbers of another branch).
//!
//! **Velocity and acceleration level**, as in the planar case: `q̇_p = A q̇_a`,
//! `A = −Φ_p⁻¹ Φ_a`, `Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a)`, solved numerically (pivoted LU); the
//! entries of `A` and `Ȧ` are the [`Atom::Closure`] atoms the reduction of the open tree
//! (`dynamics::reduction`) builds `S = [I; A]` from.
//!
//! **Singularity.** The loops are singular where `Φ_p` loses rank; [`SpatialLoops::analyse`]
//! refuses an assembly where it does, naming the passive joints the constraints leave free
//! and the equations that are redundant.

use std::sync::OnceLock;

use super::kinematics::{body_frames, mat_vec, point_positions};
use super::three_spheres::{ClosedFormAtoms, ThreeSpheres};
use crate::math::dense::{determinant, independent_columns, solve};
use crate::model::{Model, SpatialClosure};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, AtomValues, Poly, State};

/// Newton iterations allowed per continuation step.
const NEWTON_ITERATIONS: usize = 30;
/// Convergence: the largest constraint residual, m (and rad for perpendicularity).
const RESIDUAL_TOLERANCE: f64 = 1e-13;
/// Continuation steps from the assembly to a requested state.
const CONTINUATION_STEPS: usize = 8;
/// The largest step (rad, or m) of any actuated coordinate between two solutions of the
/// evaluator's continuation from the assembly ([`SpatialLoops::continued`]).
pub const CONTINUATION_STEP: f64 = 0.05;
/// The most steps [`SpatialLoops::continued`] takes (1,000 rad at [`CONTINUATION_STEP`]).
const MAX_CONTINUATION_STEPS: usize = 20_000;
/// How far (rad, or m) the actuated coordinates may have moved since the last solution for the
/// generated code's Newton to start from it (`hapticgen_runtime::loops::close_loops`): 50 rad/s
/// at a 1 kHz tick. [`SpatialLoops::analyse`] checks that it reaches the file's branch from
/// there over the actuated ranges.
pub const WARM_START_RADIUS: f64 = 0.05;
/// Newton steps the generated code may take beyond the most seen over the actuated ranges
/// ([`SpatialLoops::newton_step_bound`]): states between the samples, and `f32` rounding.
const EXTRA_NEWTON_STEPS: usize = 2;

/// A problem with the spatial closures, reported at `closures` (or one entry of it).
#[derive(Clone, Debug)]
pub struct SpatialProblem {
    /// The closure at fault, if one is.
    pub closure: Option<usize>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: String,
}

/// The constraints of a spatial closed chain and what their elimination needs.
#[derive(Clone, Debug)]
pub struct SpatialLoops {
    /// Number of actuated coordinates `N`.
    pub actuated: usize,
    /// Number of passive coordinates `P` (the tree coordinates `N … N+P−1`).
    pub passive: usize,
    /// A name per equation (`leg2.x`, `leg2.perpendicular`), for messages.
    pub equation_names: Vec<String>,
    /// `Φ`, `P` polynomials over every tree coordinate.
    pub residual: Vec<Poly>,
    /// `Φ_p = ∂Φ/∂q_p`, `P × P`.
    pub passive_jacobian: Vec<Vec<Poly>>,
    /// `Φ_a = ∂Φ/∂q_a`, `P × N`.
    pub actuated_jacobian: Vec<Vec<Poly>>,
    /// `Φ̇_p`, with every tree velocity as its `Qd` atom.
    pub passive_jacobian_dot: Vec<Vec<Poly>>,
    /// `Φ̇_a`.
    pub actuated_jacobian_dot: Vec<Vec<Poly>>,
    /// The actuated coordinates where the assembly was found (middle of their ranges).
    pub nominal_actuated: Vec<f64>,
    /// The passive coordinates of the assembly there (the file's `assembly` angles, refined).
    pub assembly: Vec<f64>,
    /// `A = −Φ_p⁻¹ Φ_a` at the assembly, `P × N`: the generated code's first guess at `q_a` is
    /// the assembly moved along it, `q_p ≈ q_p0 + A₀ (q_a − q_a0)` ([`SpatialLoops::predicted`]).
    pub assembly_sensitivity: Vec<Vec<f64>>,
    /// The most Newton steps the guess (the assembly's tangent, or the last solution within
    /// [`WARM_START_RADIUS`]) needed at any of the states sampled over the actuated ranges
    /// ([`SpatialLoops::analyse`] checks that it always reaches the file's branch).
    pub newton_steps: usize,
    /// The loops in closed form, where they are a Delta's ([`ThreeSpheres::recognise`]) and the
    /// closed form agrees with Newton's solutions at states sampled over the actuated ranges:
    /// the generated code then solves them so, without Newton's method.
    pub closed_form: Option<ThreeSpheres>,
    /// Why the loops have no closed form (when [`SpatialLoops::closed_form`] is `None`).
    pub newton_reason: Option<String>,
    /// The polynomials as expression DAGs (shared subterms evaluated once), built on first
    /// use: `[Φ, Φ_p, Φ_a]` for Newton's steps, `[Φ̇_p, Φ̇_a]` once per state.
    compiled: OnceLock<[Compiled; 2]>,
}

/// Polynomials compiled into one DAG, with the node of each, row-major.
#[derive(Clone, Debug)]
struct Compiled {
    dag: Dag,
    roots: Vec<NodeId>,
}

impl Compiled {
    fn new<'a>(polys: impl Iterator<Item = &'a Poly>) -> Compiled {
        let mut dag = Dag::new();
        let roots = polys.map(|p| dag.polynomial(p)).collect();
        Compiled { dag, roots }
    }

    /// The values of the roots at `state`.
    fn eval(&self, state: &State<'_>) -> Vec<f64> {
        let values = self.dag.eval_all(&|atom| state.value(atom));
        self.roots.iter().map(|&r| values[r]).collect()
    }
}

fn largest(values: &[f64]) -> f64 {
    values.iter().fold(0.0_f64, |m, x| if x.is_nan() { f64::NAN } else { m.max(x.abs()) })
}

impl SpatialLoops {
    /// The constraints of `closures` on `model`'s tree, and the assembly at the middle of the
    /// actuated ranges; problems if the loops do not close there or are singular.
    pub fn analyse(model: &Model, closures: &[SpatialClosure]) -> Result<SpatialLoops, Vec<SpatialProblem>> {
        let n = model.joints.len();
        let total = model.tree_coordinates();
        let p = total - n;
        let positions = point_positions(model);
        let frames = body_frames(model);
        let mut residual = Vec::new();
        let mut equation_names = Vec::new();
        for closure in closures {
            let [first, second] = closure.points.map(|k| &positions[k]);
            for (axis, (a, b)) in ["x", "y", "z"].iter().zip(first.iter().zip(second)) {
                residual.push(a.sub(b));
                equation_names.push(format!("{}.{axis}", closure.name));
            }
            if let Some(axes) = &closure.perpendicular {
                let [u, v] = axes.map(|(body, axis)| {
                    let constant = axis.map(Poly::constant);
                    match body {
                        Some(b) => mat_vec(&frames[b].rotation, &constant),
                        None => constant,
                    }
                });
                residual.push(Poly::sum(&[u[0].mul(&v[0]), u[1].mul(&v[1]), u[2].mul(&v[2])]));
                equation_names.push(format!("{}.perpendicular", closure.name));
            }
        }
        let diff = |poly: &Poly, k: usize| poly.diff_q(k as u16);
        let rate = |poly: &Poly| {
            Poly::sum(
                &(0..total).map(|k| diff(poly, k).mul(&Poly::atom(Atom::Qd(k as u16)))).collect::<Vec<_>>(),
            )
        };
        let passive_jacobian: Vec<Vec<Poly>> =
            residual.iter().map(|phi| (n..total).map(|k| diff(phi, k)).collect()).collect();
        let actuated_jacobian: Vec<Vec<Poly>> =
            residual.iter().map(|phi| (0..n).map(|k| diff(phi, k)).collect()).collect();
        let passive_jacobian_dot =
            passive_jacobian.iter().map(|row| row.iter().map(rate).collect()).collect();
        let actuated_jacobian_dot =
            actuated_jacobian.iter().map(|row| row.iter().map(rate).collect()).collect();
        let nominal_actuated: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
        let mut loops = SpatialLoops {
            actuated: n,
            passive: p,
            equation_names,
            residual,
            passive_jacobian,
            actuated_jacobian,
            passive_jacobian_dot,
            actuated_jacobian_dot,
            nominal_actuated,
            assembly: model.passive.iter().map(|j| j.assembly).collect(),
            assembly_sensitivity: Vec::new(),
            newton_steps: 0,
            closed_form: None,
            newton_reason: None,
            compiled: OnceLock::new(),
        };
        let parameters = model.nominal_parameters();
        let names = |indices: &[usize], of: &dyn Fn(usize) -> String| -> String {
            indices.iter().map(|&i| of(i)).collect::<Vec<_>>().join(", ")
        };
        let passive_name = |k: usize| format!("`{}`", model.coordinate_name(n + k));
        // Φ_p must have full rank; else name what is free and what is redundant.
        let singular = |passive: &[f64]| -> Option<SpatialProblem> {
            let state = loops.tree_state(&loops.nominal_actuated, passive);
            let (_, jacobian, _) =
                loops.position_level(&State { q: &state, qd: &[], parameters: &parameters });
            let (_, free) = independent_columns(&jacobian, 1e-9);
            if free.is_empty() {
                return None;
            }
            let transposed: Vec<Vec<f64>> =
                (0..p).map(|j| jacobian.iter().map(|row| row[j]).collect()).collect();
            let (_, redundant) = independent_columns(&transposed, 1e-9);
            Some(SpatialProblem {
                closure: None,
                message: format!(
                    "the loops are singular at their assembly: the constraints do not determine passive joint{} {} (redundant equation{}: {})",
                    if free.len() > 1 { "s" } else { "" },
                    names(&free, &passive_name),
                    if redundant.len() > 1 { "s" } else { "" },
                    names(&redundant, &|k| format!("`{}`", loops.equation_names[k])),
                ),
                hint: "a redundant equation repeats what other closures already impose: drop that closure's `perpendicular` (or cut the loop at another joint) and add a passive joint where the mechanism has one".into(),
            })
        };
        let (guess, q_a) = (loops.assembly.clone(), loops.nominal_actuated.clone());
        let Some(assembly) = loops.newton(&q_a, &guess, &parameters) else {
            // A structural singularity shows at the guess already; else the loops do not close.
            if let Some(problem) = singular(&guess) {
                return Err(vec![problem]);
            }
            let state = loops.tree_state(&q_a, &guess);
            let (values, _, _) = loops.position_level(&State { q: &state, qd: &[], parameters: &parameters });
            let worst = (0..values.len()).max_by(|&i, &j| values[i].abs().total_cmp(&values[j].abs()));
            return Err(vec![SpatialProblem {
                closure: None,
                message: format!(
                    "the loops do not close near the passive joints' `assembly` angles at the middle of the actuated ranges{}",
                    worst.map(|w| format!(" (there `{}` is off by {:.3e})", loops.equation_names[w], values[w]))
                        .unwrap_or_default()
                ),
                hint: "give each passive joint an `assembly` angle near the assembly you mean (within a few tenths of a radian), or check the loops' points and axes".into(),
            }]);
        };
        if let Some(problem) = singular(&assembly) {
            return Err(vec![problem]);
        }
        // Φ_p has full rank at the assembly (checked just above), so `A₀` exists.
        let sensitivity = loops.sensitivity_at(&q_a, &assembly, &parameters).unwrap_or_default();
        loops.assembly = assembly;
        loops.assembly_sensitivity = sensitivity;
        loops.newton_steps = loops
            .sampled_newton_steps(model, &parameters, WARM_START_RADIUS)
            .map_err(|problem| vec![problem])?;
        let tree = loops.tree_state(&loops.nominal_actuated, &loops.assembly);
        match ThreeSpheres::recognise(model, closures, &tree, &parameters)
            .and_then(|closed_form| loops.check_closed_form(model, &parameters, closed_form))
        {
            Ok(closed_form) => loops.closed_form = Some(closed_form),
            Err(reason) => loops.newton_reason = Some(reason),
        }
        Ok(loops)
    }

    /// `closed_form` if it agrees with Newton's solutions (the passive sines, cosines and
    /// rates, `A`, `Ȧ` and `Ȧ q̇_a`) at states spread over the actuated ranges, moving.
    fn check_closed_form(
        &self,
        model: &Model,
        parameters: &[f64],
        closed_form: ThreeSpheres,
    ) -> Result<ThreeSpheres, String> {
        let n = self.actuated;
        let names: Vec<String> =
            (0..model.tree_coordinates()).map(|j| model.coordinate_name(j).to_string()).collect();
        let sensitivity = |r: usize, j: usize, rate: bool| self.sensitivity(0, r, j, rate);
        let convective = |r: usize| self.convective(0, r);
        let mut dag = Dag::new();
        let installed = closed_form.install(
            &mut dag,
            &ClosedFormAtoms {
                actuated: n,
                sensitivity: &sensitivity,
                convective: &convective,
                names: &names,
            },
        );
        let per_axis: usize = 3;
        for index in 0..per_axis.pow(n as u32) {
            let fraction = |j: usize| {
                0.1 + 0.8 * ((index / per_axis.pow(j as u32)) % per_axis) as f64 / (per_axis - 1) as f64
            };
            let q: Vec<f64> = model
                .joints
                .iter()
                .enumerate()
                .map(|(j, joint)| joint.lower + (joint.upper - joint.lower) * fraction(j))
                .collect();
            let qd: Vec<f64> = (0..n).map(|j| 0.7 - 0.45 * j as f64).collect();
            let expected = self.values(&q, &qd, parameters, 0);
            let state = State { q: &q, qd: &qd, parameters };
            let values = dag.eval_all(&|atom| state.value(atom));
            for (atom, value) in &expected {
                if matches!(atom, Atom::Q(_)) {
                    continue;
                }
                let Some(&(_, node)) = installed.atoms.iter().find(|(a, _)| a == atom) else {
                    return Err(format!("the closed form does not define {atom:?}"));
                };
                let found = values[node];
                // A NaN on either side disagrees.
                let agrees = (found - value).abs() <= 1e-7 * (1.0 + value.abs());
                if !agrees {
                    return Err(format!(
                        "the closed form gives {found} for {atom:?} where Newton's method gives {value}"
                    ));
                }
            }
        }
        Ok(closed_form)
    }

    /// The bound on Newton's steps in the generated code: the most seen over the actuated
    /// ranges from the assembly's tangent, plus a margin.
    pub fn newton_step_bound(&self) -> usize {
        self.newton_steps + EXTRA_NEWTON_STEPS
    }

    /// The largest length in the loops' point equations (their largest coefficient): the scale
    /// of their residuals (the generated code's Newton tolerance is 32 ε times it).
    pub fn length_scale(&self) -> f64 {
        self.residual
            .iter()
            .zip(&self.equation_names)
            .filter(|(_, name)| !name.ends_with(".perpendicular"))
            .flat_map(|(poly, _)| poly.terms().map(|(_, c)| c.abs()).collect::<Vec<_>>())
            .fold(0.0, f64::max)
    }

    /// `A = −Φ_p⁻¹ Φ_a` at `(q_a, q_p)`; `None` where `Φ_p` is singular.
    fn sensitivity_at(&self, actuated: &[f64], passive: &[f64], parameters: &[f64]) -> Option<Vec<Vec<f64>>> {
        let state = self.tree_state(actuated, passive);
        let (_, phi_p, phi_a) = self.position_level(&State { q: &state, qd: &[], parameters });
        solve(phi_p, phi_a.iter().map(|row| row.iter().map(|x| -x).collect()).collect())
    }

    /// The guess the generated code starts Newton from at `actuated`: the assembly moved along
    /// its tangent, `q_p0 + A₀ (q_a − q_a0)`.
    pub fn predicted(&self, actuated: &[f64]) -> Vec<f64> {
        self.assembly
            .iter()
            .zip(&self.assembly_sensitivity)
            .map(|(q0, row)| {
                q0 + row
                    .iter()
                    .zip(actuated.iter().zip(&self.nominal_actuated))
                    .map(|(a, (q, m))| a * (q - m))
                    .sum::<f64>()
            })
            .collect()
    }

    /// Newton from [`SpatialLoops::predicted`] at states spread over the actuated ranges (a
    /// grid of at most about 250, corners included): the most steps it took, or the first
    /// state where it failed or reached another branch than the continuation from the
    /// assembly (the generated code has no continuation: one guess, a bounded number of steps).
    fn sampled_newton_steps(
        &self,
        model: &Model,
        parameters: &[f64],
        warm_start_radius: f64,
    ) -> Result<usize, SpatialProblem> {
        let n = self.actuated;
        let per_axis = (1..=6).rev().find(|g: &usize| g.pow(n as u32) <= 250).unwrap_or(1).max(2);
        let mut most = 0;
        for index in 0..per_axis.pow(n as u32) {
            let actuated: Vec<f64> = model
                .joints
                .iter()
                .enumerate()
                .map(|(j, joint)| {
                    let step = (index / per_axis.pow(j as u32)) % per_axis;
                    joint.lower + (joint.upper - joint.lower) * step as f64 / (per_axis - 1) as f64
                })
                .collect();
            let at = || {
                model
                    .joints
                    .iter()
                    .zip(&actuated)
                    .map(|(j, q)| format!("{} = {q:.4}", j.name))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let problem = |message: String| {
                SpatialProblem {
                closure: None,
                message,
                hint: "narrow the actuated joints' limits to where the mechanism moves smoothly from its assembly, or choose `assembly` angles nearer the middle of that motion".into(),
            }
            };
            let Some(reference) = self.passive_coordinates(&actuated, parameters) else {
                return Err(problem(format!(
                    "the loops cannot be solved within the actuated joints' limits (at {}): they do not close there, or pass a singular configuration on the way from the assembly",
                    at()
                )));
            };
            let same = |passive: &[f64], reference: &[f64]| {
                largest(&passive.iter().zip(reference).map(|(a, b)| a - b).collect::<Vec<_>>()) <= 1e-9
            };
            let reached = self.newton_counted(&actuated, &self.predicted(&actuated), parameters);
            match reached {
                Some((passive, steps)) if same(&passive, &reference) => most = most.max(steps),
                _ => {
                    return Err(problem(format!(
                        "Newton's method from the assembly's tangent does not reach the assembly's branch at {} (the generated code solves the loops from that guess)",
                        at()
                    )))
                }
            }
            // The warm start: from this solution to a state `WARM_START_RADIUS` away in every
            // actuated coordinate (towards the middle of each range), as the next tick may be.
            let neighbour: Vec<f64> = model
                .joints
                .iter()
                .zip(&actuated)
                .map(|(joint, &q)| q + warm_start_radius.copysign(0.5 * (joint.lower + joint.upper) - q))
                .collect();
            let warm = self.newton_counted(&neighbour, &reference, parameters);
            let expected = self.passive_coordinates(&neighbour, parameters);
            match (warm, expected) {
                (Some((passive, steps)), Some(expected)) if same(&passive, &expected) => most = most.max(steps),
                _ => {
                    return Err(problem(format!(
                        "Newton's method warm-started from the solution at {} does not reach the assembly's branch {warm_start_radius} away (the generated code starts from the last solution within that distance)",
                        at()
                    )))
                }
            }
        }
        Ok(most)
    }

    fn compiled(&self) -> &[Compiled; 2] {
        self.compiled.get_or_init(|| {
            let flat = |m: &[Vec<Poly>]| m.iter().flatten().cloned().collect::<Vec<_>>();
            let position: Vec<Poly> = self
                .residual
                .iter()
                .cloned()
                .chain(flat(&self.passive_jacobian))
                .chain(flat(&self.actuated_jacobian))
                .collect();
            let rates: Vec<Poly> = flat(&self.passive_jacobian_dot)
                .into_iter()
                .chain(flat(&self.actuated_jacobian_dot))
                .collect();
            [Compiled::new(position.iter()), Compiled::new(rates.iter())]
        })
    }

    /// `Φ`, `Φ_p` and `Φ_a` at `state`.
    fn position_level(&self, state: &State<'_>) -> (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let (n, p) = (self.actuated, self.passive);
        let values = self.compiled()[0].eval(state);
        let (residual, rest) = values.split_at(p);
        let (passive, actuated) = rest.split_at(p * p);
        let rows = |m: &[f64], width: usize| m.chunks(width).map(<[f64]>::to_vec).collect();
        (residual.to_vec(), rows(passive, p), rows(actuated, n))
    }

    /// The tree coordinates `(q_a, q_p)`.
    fn tree_state(&self, actuated: &[f64], passive: &[f64]) -> Vec<f64> {
        actuated.iter().chain(passive).copied().collect()
    }

    /// Newton's method on `Φ(q_a, ·) = 0` from `guess`; `None` if it does not converge.
    fn newton(&self, actuated: &[f64], guess: &[f64], parameters: &[f64]) -> Option<Vec<f64>> {
        self.newton_counted(actuated, guess, parameters).map(|(passive, _)| passive)
    }

    /// [`SpatialLoops::newton`], with the number of steps it took.
    fn newton_counted(
        &self,
        actuated: &[f64],
        guess: &[f64],
        parameters: &[f64],
    ) -> Option<(Vec<f64>, usize)> {
        let mut passive = guess.to_vec();
        for steps in 0..NEWTON_ITERATIONS {
            let state = self.tree_state(actuated, &passive);
            let (residual, jacobian, _) = self.position_level(&State { q: &state, qd: &[], parameters });
            let converged = largest(&residual) <= RESIDUAL_TOLERANCE;
            let step = solve(jacobian, residual.iter().map(|r| vec![-r]).collect())?;
            for (q, d) in passive.iter_mut().zip(&step) {
                *q += d[0];
            }
            if !passive.iter().all(|q| q.is_finite()) {
                return None;
            }
            // Converged: with the step above as a polish (quadratic convergence puts the
            // residual at rounding level), so that the solution does not depend on the guess.
            if converged {
                return Some((passive, steps));
            }
        }
        None
    }

    /// The passive coordinates at `actuated`, continued from the assembly along the straight
    /// line in the actuated coordinates (the file's branch); `None` if Newton fails on the way.
    pub fn passive_coordinates(&self, actuated: &[f64], parameters: &[f64]) -> Option<Vec<f64>> {
        let mut passive = self.assembly.clone();
        for step in 1..=CONTINUATION_STEPS {
            let t = step as f64 / CONTINUATION_STEPS as f64;
            let along: Vec<f64> =
                self.nominal_actuated.iter().zip(actuated).map(|(from, to)| from + t * (to - from)).collect();
            passive = self.newton(&along, &passive, parameters)?;
        }
        Some(passive)
    }

    /// The atom of `A[r][j]` (`rate`: of `Ȧ[r][j]`), for passive coordinate `r` (counted from
    /// the first passive one) and actuated coordinate `j`, numbered from `first_atom`.
    pub fn sensitivity(&self, first_atom: usize, r: usize, j: usize, rate: bool) -> Atom {
        let (n, p) = (self.actuated, self.passive);
        Atom::Closure((first_atom + usize::from(rate) * p * n + r * n + j) as u16)
    }

    /// The atom of `(Ȧ q̇_a)[r]`, passive coordinate `r`'s acceleration at `q̈_a = 0`, numbered
    /// from `first_atom` after `A` and `Ȧ`.
    pub fn convective(&self, first_atom: usize, r: usize) -> Atom {
        let (n, p) = (self.actuated, self.passive);
        Atom::Closure((first_atom + 2 * p * n + r) as u16)
    }

    /// The atoms [`SpatialLoops::values_from`] gives values of, in its order: per passive
    /// coordinate its sine, cosine, angle and rate; then `A` and `Ȧ` row-major
    /// ([`SpatialLoops::sensitivity`], numbered from `first_atom`); then `Ȧ q̇_a`
    /// ([`SpatialLoops::convective`]).
    pub fn atoms(&self, first_atom: usize) -> Vec<Atom> {
        let (n, p) = (self.actuated, self.passive);
        let mut atoms: Vec<Atom> = (0..p)
            .flat_map(|r| {
                let k = (n + r) as u16;
                [Atom::Sin(k), Atom::Cos(k), Atom::Q(k), Atom::Qd(k)]
            })
            .collect();
        for rate in [false, true] {
            atoms.extend(
                (0..p)
                    .flat_map(|r| (0..n).map(move |j| (r, j)))
                    .map(|(r, j)| self.sensitivity(first_atom, r, j, rate)),
            );
        }
        atoms.extend((0..p).map(|r| self.convective(first_atom, r)));
        atoms
    }

    /// Atom values at `(q_a, q̇_a)`, paired with their atoms ([`SpatialLoops::checked_values`],
    /// with every value NaN where the loops cannot be solved on the file's branch).
    pub fn values(&self, q: &[f64], qd: &[f64], parameters: &[f64], first_atom: usize) -> Vec<(Atom, f64)> {
        self.checked_values(q, qd, parameters, first_atom)
            .unwrap_or_else(|_| self.atoms(first_atom).into_iter().map(|atom| (atom, f64::NAN)).collect())
    }

    /// Atom values at `(q_a, q̇_a)`, paired with their atoms, the loops solved by
    /// [`SpatialLoops::continued`] from the assembly; or why they cannot be solved there on the
    /// file's branch.
    pub fn checked_values(
        &self,
        q: &[f64],
        qd: &[f64],
        parameters: &[f64],
        first_atom: usize,
    ) -> Result<Vec<(Atom, f64)>, String> {
        let actuated = &q[..self.actuated.min(q.len())];
        let passive = self.continued(actuated, parameters)?;
        let (values, _) = self.values_at(actuated, qd, parameters, passive)?;
        Ok(self.atoms(first_atom).into_iter().zip(values).collect())
    }

    /// The values of [`SpatialLoops::atoms`] at `(q_a, q̇_a)`, and the passive coordinates
    /// found. Newton's method starts from `guess` (a previous solution: a warm start) if
    /// given and converges from it, else continues from the assembly
    /// ([`SpatialLoops::continued`], the file's branch). Every value NaN, and no coordinates,
    /// where the loops cannot be solved.
    pub fn values_from(
        &self,
        q: &[f64],
        qd: &[f64],
        parameters: &[f64],
        guess: Option<&[f64]>,
    ) -> (Vec<f64>, Option<Vec<f64>>) {
        let (n, p) = (self.actuated, self.passive);
        let actuated = &q[..n.min(q.len())];
        let warm = guess.filter(|g| g.len() == p).and_then(|g| self.newton(actuated, g, parameters));
        let passive = match warm {
            Some(passive) => Ok(passive),
            None => self.continued(actuated, parameters),
        };
        match passive.and_then(|passive| self.values_at(actuated, qd, parameters, passive)) {
            Ok((values, passive)) => (values, Some(passive)),
            Err(_) => (vec![f64::NAN; 5 * p + 2 * p * n], None),
        }
    }

    /// The passive coordinates at `actuated`, continued from the assembly along the straight
    /// line in the actuated coordinates in steps of at most [`CONTINUATION_STEP`] in each (and
    /// never fewer than the analysis' continuation takes), with
    /// Newton's method at every step; the sign of `det Φ_p` must stay the assembly's all the
    /// way (a sign change is a singular configuration passed, beyond which Newton's method
    /// would land on another assembly branch). The reason where it fails to converge or the
    /// sign changes.
    pub fn continued(&self, actuated: &[f64], parameters: &[f64]) -> Result<Vec<f64>, String> {
        let distance = largest(
            &self.nominal_actuated.iter().zip(actuated).map(|(from, to)| to - from).collect::<Vec<_>>(),
        );
        if !distance.is_finite() {
            return Err("the actuated coordinates are not finite".into());
        }
        // Never fewer steps than the analysis' continuation ([`SpatialLoops::passive_coordinates`]).
        let steps = (distance / CONTINUATION_STEP).ceil().max(CONTINUATION_STEPS as f64);
        if steps > MAX_CONTINUATION_STEPS as f64 {
            return Err(format!(
                "the state is {distance:.4} rad from the assembly (at the middle of the joint ranges): too far to follow the assembly's branch"
            ));
        }
        let steps = steps as usize;
        let determinant_at = |along: &[f64], passive: &[f64]| {
            let state = self.tree_state(along, passive);
            let (_, phi_p, _) = self.position_level(&State { q: &state, qd: &[], parameters });
            determinant(phi_p)
        };
        let start = determinant_at(&self.nominal_actuated, &self.assembly);
        let mut passive = self.assembly.clone();
        let at = |along: &[f64]| along.iter().map(|q| format!("{q:.4}")).collect::<Vec<_>>().join(", ");
        for step in 1..=steps {
            let t = step as f64 / steps as f64;
            let along: Vec<f64> =
                self.nominal_actuated.iter().zip(actuated).map(|(from, to)| from + t * (to - from)).collect();
            let Some(next) = self.newton(&along, &passive, parameters) else {
                return Err(format!(
                    "the loops do not close at this state: following the assembly's branch from the middle of the joint ranges, Newton's method fails at q = [{}] rad ({:.0}% of the way)",
                    at(&along),
                    100.0 * t
                ));
            };
            // NaN (a non-finite Jacobian) fails too.
            let same_sign = determinant_at(&along, &next) * start > 0.0;
            if !same_sign {
                return Err(format!(
                    "the loops pass a singular configuration on the way from the assembly: the constraint Jacobian's determinant changes sign at q = [{}] rad ({:.0}% of the way); beyond it lies another assembly branch",
                    at(&along),
                    100.0 * t
                ));
            }
            passive = next;
        }
        Ok(passive)
    }

    /// The atom values ([`SpatialLoops::atoms`]' order) at `(q_a, q̇_a)` with the passive
    /// coordinates found, and those coordinates; why not where `Φ_p` is singular.
    fn values_at(
        &self,
        actuated: &[f64],
        qd: &[f64],
        parameters: &[f64],
        passive: Vec<f64>,
    ) -> Result<(Vec<f64>, Vec<f64>), String> {
        let (n, p) = (self.actuated, self.passive);
        let singular =
            || "the loops are singular at this state (the constraint Jacobian has lost rank)".to_string();
        let a = self.sensitivity_at(actuated, &passive, parameters).ok_or_else(singular)?;
        let state = self.tree_state(actuated, &passive);
        let (_, phi_p, _) = self.position_level(&State { q: &state, qd: &[], parameters });
        let passive_velocity: Vec<f64> =
            a.iter().map(|row| row.iter().zip(qd).map(|(x, v)| x * v).sum()).collect();
        let velocities = self.tree_state(&qd[..n.min(qd.len())], &passive_velocity);
        let rates = self.compiled()[1].eval(&State { q: &state, qd: &velocities, parameters });
        let (phi_p_dot, phi_a_dot) = rates.split_at(p * p);
        let phi_p_dot: Vec<&[f64]> = phi_p_dot.chunks(p).collect();
        let phi_a_dot: Vec<&[f64]> = phi_a_dot.chunks(n).collect();
        // Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a).
        let right: Vec<Vec<f64>> = (0..p)
            .map(|row| {
                (0..n)
                    .map(|j| -(phi_a_dot[row][j] + (0..p).map(|k| phi_p_dot[row][k] * a[k][j]).sum::<f64>()))
                    .collect()
            })
            .collect();
        let a_dot = solve(phi_p, right).ok_or_else(singular)?;
        let mut values = Vec::with_capacity(5 * p + 2 * p * n);
        for (&angle, &velocity) in passive.iter().zip(&passive_velocity) {
            values.extend([angle.sin(), angle.cos(), angle, velocity]);
        }
        values.extend(a.iter().chain(&a_dot).flatten());
        values.extend(a_dot.iter().map(|row| row.iter().zip(qd).map(|(x, v)| x * v).sum::<f64>()));
        Ok((values, passive))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Falcon-like Delta and its loops, analysed.
    fn falcon() -> (Model, SpatialLoops) {
        let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/falcon_delta.yaml"));
        let model =
            crate::model::load_file(path, "models/falcon_delta.yaml", None).unwrap_or_else(|e| panic!("{e}"));
        let loops = SpatialLoops::analyse(&model, &model.spatial_closures)
            .unwrap_or_else(|problems| panic!("{}", problems[0].message));
        (model, loops)
    }

    #[test]
    fn a_warm_start_from_too_far_is_refused() {
        let (model, loops) = falcon();
        let parameters = model.nominal_parameters();
        // The shipped radius passes; a whole radian (the thighs' range) does not.
        assert!(loops.sampled_newton_steps(&model, &parameters, WARM_START_RADIUS).is_ok());
        let problem = loops.sampled_newton_steps(&model, &parameters, 1.0).expect_err("refused");
        assert!(problem.message.contains("warm-started"), "{}", problem.message);
    }
}
