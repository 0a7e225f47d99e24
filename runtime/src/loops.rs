//! Closed loops solved at run time: the passive coordinates of a closed chain whose loops have
//! no closed form (a spatial chain such as a Delta), for generated code to build its
//! reduced dynamics on.
//!
//! The loops are constraints `Φ(q_a, q_p) = 0`, `P` equations in the `P` passive coordinates
//! `q_p` (the actuated `q_a` given). [`solve_passive`] runs Newton's method,
//! `Φ_p Δq_p = −Φ` with `Φ_p = ∂Φ/∂q_p`, from a guess (the previous tick's solution: a warm
//! start, so that one or two steps suffice at a haptic rate), with a fixed bound on the steps;
//! [`passive_sensitivity`] gives `A = −Φ_p⁻¹ Φ_a`, so that `q̇_p = A q̇_a`, from the factors of
//! the last step. At the velocity level the reduced dynamics need `Ȧ q̇_a`, the passive
//! coordinates' acceleration when the actuated ones do not accelerate (the convective term):
//! differentiating `Φ_p q̇_p + Φ_a q̇_a = 0` once more at `q̈_a = 0` gives
//! `Ȧ q̇_a = −Φ_p⁻¹ γ`, `γ = Φ̇_p q̇_p + Φ̇_a q̇_a`, one solve of a vector, where `Ȧ` itself
//! (`−Φ_p⁻¹ (Φ̇_p A + Φ̇_a)`, a solve per actuated coordinate) is computed only when asked
//! for. Both are allocation-free and panic-free, and report failure as a [`LoopError`]
//! instead of returning a plausible-looking number: a loop that does not close (the actuated
//! coordinates out of reach), a singular loop (`Φ_p` losing rank, where the
//! reduced inertia grows without bound) and non-finite inputs.

use core::cell::Cell;
use core::cmp::Ordering;

use crate::linalg::{dot, LuFactors, SolveError};
use crate::Real;

/// Why the loops could not be solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoopError {
    /// An input, a residual or a Jacobian entry was NaN or infinite.
    NonFinite,
    /// `Φ_p`'s smallest pivot was not above the threshold: the loops are (nearly) singular.
    Singular,
    /// The residual did not fall below the tolerance within the allowed steps: the loops do
    /// not close there, or the guess was too far.
    NotConverged,
}

/// Bounds of [`solve_passive`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopSolverSettings<S> {
    /// Newton steps allowed.
    pub max_steps: u32,
    /// Converged when every `|Φ_i|` is at most this (the constraints' own units: m, or the
    /// cosine of a right angle).
    pub tolerance: S,
    /// `Φ_p` is singular when its reciprocal condition estimate (smallest over largest LU
    /// pivot) is at most this.
    pub min_pivot_ratio: S,
    /// [`close_loops`] starts Newton from the last solution when no actuated coordinate moved
    /// more than this since (one control tick's motion); else from the assembly's tangent.
    pub warm_start_radius: S,
}

/// A solution of the loops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopSolution<S, const P: usize> {
    /// The passive coordinates.
    pub passive: [S; P],
    /// The LU factors of `Φ_p` at the last step (for [`passive_sensitivity`]).
    pub factors: LuFactors<S, P>,
    /// How close to singular the loops are: `Φ_p`'s reciprocal condition estimate, in
    /// `[0, 1]` (0 singular).
    pub margin: S,
    /// Newton steps taken (0: the guess already satisfied the tolerance).
    pub steps: u32,
}

/// Newton's method on `Φ(q_a, ·) = 0` from `guess`. `constraints(q_p)` returns `Φ` and `Φ_p` at
/// `q_p` (the actuated coordinates are the caller's). At most `settings.max_steps` steps; the
/// solution's factors are of `Φ_p` at the solution.
pub fn solve_passive<S: Real, const P: usize>(
    mut constraints: impl FnMut(&[S; P]) -> ([S; P], [[S; P]; P]),
    guess: &[S; P],
    settings: &LoopSolverSettings<S>,
) -> Result<LoopSolution<S, P>, LoopError> {
    let mut passive = *guess;
    let mut steps = 0;
    loop {
        if !passive.iter().all(|x| x.is_finite()) {
            return Err(LoopError::NonFinite);
        }
        let (residual, jacobian) = constraints(&passive);
        let factors = LuFactors::new(&jacobian).ok_or(LoopError::NonFinite)?;
        let margin = factors.reciprocal_condition_estimate();
        // Written so that a NaN margin or threshold counts as singular.
        if margin.partial_cmp(&settings.min_pivot_ratio) != Some(Ordering::Greater) {
            return Err(LoopError::Singular);
        }
        let mut worst = S::ZERO;
        for r in &residual {
            if !r.is_finite() {
                return Err(LoopError::NonFinite);
            }
            worst = worst.max(r.abs());
        }
        if worst <= settings.tolerance {
            return Ok(LoopSolution { passive, factors, margin, steps });
        }
        if steps >= settings.max_steps {
            return Err(LoopError::NotConverged);
        }
        let mut negated = residual;
        for r in &mut negated {
            *r = -*r;
        }
        let step = factors.solve(&negated, S::ZERO).map_err(loop_error)?;
        for (q, d) in passive.iter_mut().zip(step.iter()) {
            *q += *d;
        }
        steps += 1;
    }
}

/// `A = −Φ_p⁻¹ Φ_a` (`P × N`), so that `q̇_p = A q̇_a`, from the factors of `Φ_p` of a
/// [`LoopSolution`] and `Φ_a = ∂Φ/∂q_a` at the same state.
pub fn passive_sensitivity<S: Real, const P: usize, const N: usize>(
    factors: &LuFactors<S, P>,
    actuated_jacobian: &[[S; N]; P],
) -> Result<[[S; N]; P], LoopError> {
    negated_solve(factors, actuated_jacobian)
}

/// `−Φ_p⁻¹ B` for a `P × N` matrix `B`, column by column.
fn negated_solve<S: Real, const P: usize, const N: usize>(
    factors: &LuFactors<S, P>,
    right: &[[S; N]; P],
) -> Result<[[S; N]; P], LoopError> {
    let mut solved_columns = [[S::ZERO; N]; P];
    for j in 0..N {
        let mut column = [S::ZERO; P];
        for (slot, row) in column.iter_mut().zip(right.iter()) {
            *slot = -row[j];
        }
        let solved = factors.solve(&column, S::ZERO).map_err(loop_error)?;
        for (row, value) in solved_columns.iter_mut().zip(solved.iter()) {
            row[j] = *value;
        }
    }
    Ok(solved_columns)
}

/// A rig's closed loops, as its generated code describes them to [`close_loops`]: the
/// constraints `Φ(q_a, q_p) = 0` over `N` actuated and `P` passive coordinates, their
/// Jacobians and rates, and the assembly the guess starts from. Each function takes the
/// passive coordinates and their sines and cosines (`passive_sin_cos`, what a revolute
/// joint's terms read; computed once per Newton step by [`close_loops`] and kept with the
/// solution, so that no function at that state computes them again).
pub trait LoopConstraints<S: Real, const N: usize, const P: usize> {
    /// The actuated coordinates of the assembly (the middle of their ranges), `q_a0`.
    const ASSEMBLY_ACTUATED: [S; N];
    /// The passive coordinates of the assembly, `q_p0`: the model file's branch.
    const ASSEMBLY_PASSIVE: [S; P];
    /// `A₀ = −Φ_p⁻¹ Φ_a` at the assembly, so that `q_p0 + A₀ (q_a − q_a0)` is the first guess.
    const ASSEMBLY_SENSITIVITY: [[S; N]; P];
    /// The bounds of Newton's method (the generator checked the step bound over the actuated
    /// ranges).
    const LOOP_SOLVER: LoopSolverSettings<S>;
    /// `Φ` and `Φ_p = ∂Φ/∂q_p` at `(q, passive)`.
    fn loop_constraints(
        &self,
        q: &[S; N],
        passive: &[S; P],
        passive_sin_cos: &[(S, S); P],
    ) -> ([S; P], [[S; P]; P]);
    /// `Φ_a = ∂Φ/∂q_a` at `(q, passive)`.
    fn loop_actuated_jacobian(
        &self,
        q: &[S; N],
        passive: &[S; P],
        passive_sin_cos: &[(S, S); P],
    ) -> [[S; N]; P];
    /// The rig's record of the loops it closed last ([`LoopCache`]).
    fn loop_cache(&self) -> &LoopCache<S, N, P>;
    /// `γ = Φ̇_p q̇_p + Φ̇_a q̇_a` at `(q, passive)` moving with `(qd, passive_rate)`: `Φ̈` at
    /// zero accelerations.
    fn loop_convective(
        &self,
        q: &[S; N],
        qd: &[S; N],
        passive: &[S; P],
        passive_sin_cos: &[(S, S); P],
        passive_rate: &[S; P],
    ) -> [S; P];
    /// `Φ̇_p` and `Φ̇_a` at `(q, passive)` moving with `(qd, passive_rate)`.
    fn loop_jacobian_rates(
        &self,
        q: &[S; N],
        qd: &[S; N],
        passive: &[S; P],
        passive_sin_cos: &[(S, S); P],
        passive_rate: &[S; P],
    ) -> ([[S; P]; P], [[S; N]; P]);
}

/// The loops closed at one state: what the reduced dynamics of a closed chain read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedLoops<S, const N: usize, const P: usize> {
    /// The passive coordinates `q_p`.
    pub passive: [S; P],
    /// Their sines and cosines (meaningless for a prismatic joint, whose terms do not read
    /// them).
    pub passive_sin_cos: [(S, S); P],
    /// Their rates `q̇_p = A q̇_a` (NaN when no velocity was given).
    pub passive_rate: [S; P],
    /// `A = ∂q_p/∂q_a = −Φ_p⁻¹ Φ_a` (NaN when only [`LoopLevel::Position`] was asked for).
    pub sensitivity: [[S; N]; P],
    /// `Ȧ q̇_a = −Φ_p⁻¹ (Φ̇_p q̇_p + Φ̇_a q̇_a)`, the passive coordinates' acceleration at
    /// `q̈_a = 0` (NaN when no velocity was given).
    pub passive_convective_acceleration: [S; P],
    /// `Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a)` (NaN unless [`LoopLevel::SensitivityRate`] was asked for
    /// with a velocity).
    pub sensitivity_rate: [[S; N]; P],
    /// `Φ_p`'s reciprocal condition estimate at the solution ([`LoopSolution::margin`]): 0 where
    /// the loops are singular, NaN where they could not be solved.
    pub margin: S,
    /// Why the loops could not be solved, if they could not.
    pub error: Option<LoopError>,
    /// Newton steps this solution took ([`LoopSolution::steps`]; 0 when it was reused).
    pub steps: u32,
}

impl<S: Real, const N: usize, const P: usize> ClosedLoops<S, N, P> {
    /// Every value NaN: what the reduced dynamics then compute is NaN too, which the safety
    /// monitor latches as a fault (never a plausible-looking number).
    pub fn failed(error: LoopError) -> Self {
        let nan = S::from_f64(f64::NAN);
        ClosedLoops {
            passive: [nan; P],
            passive_sin_cos: [(nan, nan); P],
            passive_rate: [nan; P],
            sensitivity: [[nan; N]; P],
            passive_convective_acceleration: [nan; P],
            sensitivity_rate: [[nan; N]; P],
            margin: nan,
            error: Some(error),
            steps: 0,
        }
    }
}

/// What a caller of [`close_loops`] reads of the solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoopLevel {
    /// The passive coordinates only (positions, the margin).
    Position,
    /// Those and `A = ∂q_p/∂q_a` (with a velocity also `q̇_p` and `Ȧ q̇_a`).
    Sensitivity,
    /// Those and, with a velocity, `Ȧ` (a solve per actuated coordinate: for `C` itself, not
    /// for `C q̇`).
    SensitivityRate,
}

/// The loops a rig closed last, kept in the rig (a field of a generated spatial closed chain):
/// functions called at the same state in one tick reuse them (completing what an earlier call
/// did not need), and the next tick's Newton starts from them. A cache only: it never changes
/// a result beyond rounding (clones and comparisons of rigs ignore it).
pub struct LoopCache<S, const N: usize, const P: usize> {
    last: Cell<Option<CachedLoops<S, N, P>>>,
}

/// One entry of a [`LoopCache`]: the state the loops were closed at, the solution, and which
/// of its levels are filled in.
#[derive(Clone, Copy)]
struct CachedLoops<S, const N: usize, const P: usize> {
    q: [S; N],
    closed: ClosedLoops<S, N, P>,
    /// `Φ_p`'s factors at the solution (none where it failed).
    factors: Option<LuFactors<S, P>>,
    /// `A` is in `closed`.
    has_sensitivity: bool,
    /// The velocity `q̇_p` and `Ȧ q̇_a` in `closed` are for.
    rates_for: Option<[S; N]>,
    /// The velocity `Ȧ` in `closed` is for.
    sensitivity_rate_for: Option<[S; N]>,
}

impl<S: Real, const N: usize, const P: usize> LoopCache<S, N, P> {
    /// An empty cache.
    pub const fn new() -> Self {
        LoopCache { last: Cell::new(None) }
    }
}

impl<S: Real, const N: usize, const P: usize> Default for LoopCache<S, N, P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<S: Real, const N: usize, const P: usize> Clone for LoopCache<S, N, P> {
    fn clone(&self) -> Self {
        LoopCache { last: Cell::new(self.last.get()) }
    }
}

impl<S, const N: usize, const P: usize> PartialEq for LoopCache<S, N, P> {
    /// Always equal: what a rig computes does not depend on its cache.
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}

impl<S, const N: usize, const P: usize> core::fmt::Debug for LoopCache<S, N, P> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("LoopCache")
    }
}

/// Solves `loops` at `q` to `level` (and, with `qd`, at the velocity level: `q̇_p = A q̇_a` and
/// `Ȧ q̇_a`, `A` included; `Ȧ` at [`LoopLevel::SensitivityRate`]), within the generator's
/// checked step bound: Newton's method from the last solution (moved along its `A` and
/// `Ȧ q̇_a` where those were computed, see `warm_start`) when `q` is within
/// [`LoopSolverSettings::warm_start_radius`] of it, else (or if that fails) from the assembly
/// moved along its tangent, `q_p0 + A₀ (q_a − q_a0)`. At the
/// last call's `q` the solution is reused and only what it lacks is computed. Values not asked
/// for are NaN; every value is NaN and `error` says why where the loops cannot be solved.
pub fn close_loops<S: Real, L: LoopConstraints<S, N, P>, const N: usize, const P: usize>(
    loops: &L,
    q: &[S; N],
    level: LoopLevel,
    qd: Option<&[S; N]>,
) -> ClosedLoops<S, N, P> {
    let cache = &loops.loop_cache().last;
    let last = cache.get();
    let mut entry = match last {
        Some(last) if last.q == *q => CachedLoops { closed: ClosedLoops { steps: 0, ..last.closed }, ..last },
        _ => solve_position(loops, q, last),
    };
    if let Some(factors) = entry.factors {
        let complete = |entry: &mut CachedLoops<S, N, P>| -> Result<(), LoopError> {
            if (level != LoopLevel::Position || qd.is_some()) && !entry.has_sensitivity {
                entry.closed.sensitivity = passive_sensitivity(
                    &factors,
                    &loops.loop_actuated_jacobian(q, &entry.closed.passive, &entry.closed.passive_sin_cos),
                )?;
                entry.has_sensitivity = true;
            }
            if let Some(qd) = qd {
                if entry.rates_for.as_ref() != Some(qd) {
                    let (passive_rate, passive_convective_acceleration) =
                        rates(loops, q, qd, &entry.closed, &factors)?;
                    entry.closed.passive_rate = passive_rate;
                    entry.closed.passive_convective_acceleration = passive_convective_acceleration;
                    entry.rates_for = Some(*qd);
                }
                if entry.sensitivity_rate_for.as_ref() != Some(qd) {
                    // Never another velocity's `Ȧ`: NaN where it was not asked for.
                    (entry.closed.sensitivity_rate, entry.sensitivity_rate_for) = match level {
                        LoopLevel::SensitivityRate => {
                            (sensitivity_rate(loops, q, qd, &entry.closed, &factors)?, Some(*qd))
                        }
                        _ => ([[S::from_f64(f64::NAN); N]; P], None),
                    };
                }
            }
            Ok(())
        };
        if let Err(error) = complete(&mut entry) {
            entry = CachedLoops { closed: ClosedLoops::failed(error), factors: None, ..entry };
        }
    }
    cache.set(Some(entry));
    entry.closed
}

/// The passive coordinates at `q` by Newton's method (see [`close_loops`]), as a new cache
/// entry with nothing else filled in.
fn solve_position<S: Real, L: LoopConstraints<S, N, P>, const N: usize, const P: usize>(
    loops: &L,
    q: &[S; N],
    last: Option<CachedLoops<S, N, P>>,
) -> CachedLoops<S, N, P> {
    let settings = &L::LOOP_SOLVER;
    // The sines and cosines of the last point evaluated: the solution's where Newton returns
    // one (it returns the point it evaluated last).
    let nan = S::from_f64(f64::NAN);
    let mut last_sin_cos = [(nan, nan); P];
    let mut constraints = |passive: &[S; P]| {
        for (slot, angle) in last_sin_cos.iter_mut().zip(passive.iter()) {
            *slot = angle.sin_cos();
        }
        loops.loop_constraints(q, passive, &last_sin_cos)
    };
    let near = |last: &CachedLoops<S, N, P>| {
        last.closed.error.is_none()
            && last.q.iter().zip(q.iter()).all(|(a, b)| (*a - *b).abs() <= settings.warm_start_radius)
    };
    let warm = match last {
        Some(last) if near(&last) => solve_passive(&mut constraints, &warm_start(&last, q), settings).ok(),
        _ => None,
    };
    let solved = match warm {
        Some(solution) => Ok(solution),
        None => {
            let mut tangent = L::ASSEMBLY_PASSIVE;
            for (slot, row) in tangent.iter_mut().zip(L::ASSEMBLY_SENSITIVITY.iter()) {
                for ((a, q), q0) in row.iter().zip(q.iter()).zip(L::ASSEMBLY_ACTUATED.iter()) {
                    *slot += *a * (*q - *q0);
                }
            }
            solve_passive(&mut constraints, &tangent, settings)
        }
    };
    let (closed, factors) = match solved {
        Ok(solution) => {
            let closed = ClosedLoops {
                passive: solution.passive,
                passive_sin_cos: last_sin_cos,
                passive_rate: [nan; P],
                sensitivity: [[nan; N]; P],
                passive_convective_acceleration: [nan; P],
                sensitivity_rate: [[nan; N]; P],
                margin: solution.margin,
                error: None,
                steps: solution.steps,
            };
            (closed, Some(solution.factors))
        }
        Err(error) => (ClosedLoops::failed(error), None),
    };
    CachedLoops {
        q: *q,
        closed,
        factors,
        has_sensitivity: false,
        rates_for: None,
        sensitivity_rate_for: None,
    }
}

/// Newton's guess at `q` from the last solution: moved along its tangent where `A` is known
/// (off by `O(|Δq_a|²)`), and along its curvature where `Ȧ q̇_a` is too. The path from the
/// last state at constant velocity `q̇_a`, `q_a(τ) = q_a0 + q̇_a τ`, has
/// `q_p(τ) = q_p0 + A q̇_a τ + ½ (Ȧ q̇_a) τ² + O(τ³)`; `Δq_a = q − q_a0` is taken as that
/// motion for `τ = (Δq_a · q̇_a) / |q̇_a|²`, so that the correction is `½ τ² Ȧ q̇_a`. Where the
/// motion was along the last velocity (a control loop's ticks) the guess is off by
/// `O(|Δq_a|³)`, often within the tolerance at once; in any other direction the correction
/// is itself `O(|Δq_a|²)`, the size of the tangent's error (`|τ| |q̇_a| ≤ |Δq_a|`).
fn warm_start<S: Real, const N: usize, const P: usize>(last: &CachedLoops<S, N, P>, q: &[S; N]) -> [S; P] {
    let mut guess = last.closed.passive;
    if !last.has_sensitivity {
        return guess;
    }
    let mut moved = [S::ZERO; N];
    for ((d, q), q0) in moved.iter_mut().zip(q.iter()).zip(last.q.iter()) {
        *d = *q - *q0;
    }
    for (slot, row) in guess.iter_mut().zip(last.closed.sensitivity.iter()) {
        *slot += dot(row, &moved);
    }
    if let Some(velocity) = &last.rates_for {
        let speed_squared = dot(velocity, velocity);
        // Written so that a zero or NaN speed adds nothing.
        if speed_squared > S::ZERO {
            let time = dot(&moved, velocity) / speed_squared;
            let half_time_squared = S::from_f64(0.5) * time * time;
            for (slot, convective) in guess.iter_mut().zip(last.closed.passive_convective_acceleration.iter())
            {
                *slot += half_time_squared * *convective;
            }
        }
    }
    guess
}

/// `q̇_p = A q̇_a` and `Ȧ q̇_a = −Φ_p⁻¹ (Φ̇_p q̇_p + Φ̇_a q̇_a)` at a solution with its `A`.
fn rates<S: Real, L: LoopConstraints<S, N, P>, const N: usize, const P: usize>(
    loops: &L,
    q: &[S; N],
    qd: &[S; N],
    closed: &ClosedLoops<S, N, P>,
    factors: &LuFactors<S, P>,
) -> Result<([S; P], [S; P]), LoopError> {
    let mut passive_rate = [S::ZERO; P];
    for (rate, row) in passive_rate.iter_mut().zip(closed.sensitivity.iter()) {
        *rate = dot(row, qd);
    }
    let mut negated_convective =
        loops.loop_convective(q, qd, &closed.passive, &closed.passive_sin_cos, &passive_rate);
    for entry in &mut negated_convective {
        *entry = -*entry;
    }
    Ok((passive_rate, factors.solve(&negated_convective, S::ZERO).map_err(loop_error)?))
}

/// `Ȧ = −Φ_p⁻¹ (Φ̇_p A + Φ̇_a)` at a solution with its `A` and `q̇_p`.
fn sensitivity_rate<S: Real, L: LoopConstraints<S, N, P>, const N: usize, const P: usize>(
    loops: &L,
    q: &[S; N],
    qd: &[S; N],
    closed: &ClosedLoops<S, N, P>,
    factors: &LuFactors<S, P>,
) -> Result<[[S; N]; P], LoopError> {
    let sensitivity = &closed.sensitivity;
    let (passive_jacobian_rate, actuated_jacobian_rate) =
        loops.loop_jacobian_rates(q, qd, &closed.passive, &closed.passive_sin_cos, &closed.passive_rate);
    // Φ̇_p A + Φ̇_a.
    let mut right = actuated_jacobian_rate;
    for (row, rate_row) in right.iter_mut().zip(passive_jacobian_rate.iter()) {
        for (j, entry) in row.iter_mut().enumerate() {
            for (k, rate) in rate_row.iter().enumerate() {
                *entry += *rate * sensitivity[k][j];
            }
        }
    }
    negated_solve(factors, &right)
}

fn loop_error(error: SolveError) -> LoopError {
    match error {
        SolveError::NonFinite => LoopError::NonFinite,
        SolveError::NotPositiveDefinite | SolveError::Singular => LoopError::Singular,
    }
}
