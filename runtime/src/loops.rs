//! Closed loops solved at run time: the passive coordinates of a closed chain whose loops have
//! no closed form (a spatial chain such as a Delta, issue 16), for generated code to build its
//! reduced dynamics on.
//!
//! The loops are constraints `Φ(q_a, q_p) = 0`, `P` equations in the `P` passive coordinates
//! `q_p` (the actuated `q_a` given). [`solve_passive`] runs Newton's method,
//! `Φ_p Δq_p = −Φ` with `Φ_p = ∂Φ/∂q_p`, from a guess (the previous tick's solution: a warm
//! start, so that one or two steps suffice at a haptic rate), with a fixed bound on the steps;
//! [`passive_sensitivity`] gives `A = −Φ_p⁻¹ Φ_a`, so that `q̇_p = A q̇_a`, from the factors of
//! the last step. Both are allocation-free and panic-free, and report failure as a
//! [`LoopError`] instead of returning a plausible-looking number: a loop that does not close
//! (the actuated coordinates out of reach), a singular loop (`Φ_p` losing rank, where the
//! reduced inertia grows without bound) and non-finite inputs.

use core::cmp::Ordering;

use crate::linalg::{LuFactors, SolveError};
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
    let mut sensitivity = [[S::ZERO; N]; P];
    for j in 0..N {
        let mut column = [S::ZERO; P];
        for (slot, row) in column.iter_mut().zip(actuated_jacobian.iter()) {
            *slot = -row[j];
        }
        let solved = factors.solve(&column, S::ZERO).map_err(loop_error)?;
        for (row, value) in sensitivity.iter_mut().zip(solved.iter()) {
            row[j] = *value;
        }
    }
    Ok(sensitivity)
}

fn loop_error(error: SolveError) -> LoopError {
    match error {
        SolveError::NonFinite => LoopError::NonFinite,
        SolveError::NotPositiveDefinite | SolveError::Singular => LoopError::Singular,
    }
}
