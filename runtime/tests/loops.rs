//! `loops`: Newton's method and the passive sensitivity on a planar four-bar whose loop has a
//! closed form worked out here: crank `a` turned by the actuated angle `q` about the origin,
//! coupler `b` at angle `β`, rocker `c` at angle `γ` about the ground pivot `(d, 0)`:
//! `Φ = (a cos q + b cos β − d − c cos γ, a sin q + b sin β − c sin γ) = 0`, passive `(β, γ)`.

use hapticgen_runtime::loops::{passive_sensitivity, solve_passive, LoopError, LoopSolverSettings};
use hapticgen_runtime::Real;

const CRANK: f64 = 0.03;
const COUPLER: f64 = 0.08;
const ROCKER: f64 = 0.06;
const GROUND: f64 = 0.07;

/// `Φ` and `Φ_p` at `(q, [β, γ])`.
fn constraints<S: Real>(q: S, passive: &[S; 2]) -> ([S; 2], [[S; 2]; 2]) {
    let (a, b, c, d) = (S::from_f64(CRANK), S::from_f64(COUPLER), S::from_f64(ROCKER), S::from_f64(GROUND));
    let (sq, cq) = q.sin_cos();
    let (sb, cb) = passive[0].sin_cos();
    let (sg, cg) = passive[1].sin_cos();
    ([a * cq + b * cb - d - c * cg, a * sq + b * sb - c * sg], [[-b * sb, c * sg], [b * cb, -c * cg]])
}

/// `Φ_a = ∂Φ/∂q`.
fn actuated_jacobian(q: f64) -> [[f64; 1]; 2] {
    [[-CRANK * q.sin()], [CRANK * q.cos()]]
}

/// The closed form: the coupler's far end `E` is where the circle of radius `b` about the
/// crank's end meets the circle of radius `c` about the ground pivot, on the upper branch.
fn closed_form(q: f64) -> [f64; 2] {
    let crank_end = [CRANK * q.cos(), CRANK * q.sin()];
    let to_pivot = [GROUND - crank_end[0], -crank_end[1]];
    let distance = to_pivot[0].hypot(to_pivot[1]);
    let along = (distance * distance + COUPLER * COUPLER - ROCKER * ROCKER) / (2.0 * distance);
    let across = (COUPLER * COUPLER - along * along).sqrt();
    let unit = [to_pivot[0] / distance, to_pivot[1] / distance];
    let end = [
        crank_end[0] + along * unit[0] - across * unit[1],
        crank_end[1] + along * unit[1] + across * unit[0],
    ];
    [(end[1] - crank_end[1]).atan2(end[0] - crank_end[0]), end[1].atan2(end[0] - GROUND)]
}

fn settings<S: Real>(tolerance: f64) -> LoopSolverSettings<S> {
    LoopSolverSettings { max_steps: 8, tolerance: S::from_f64(tolerance), min_pivot_ratio: S::from_f64(1e-6) }
}

#[test]
fn newton_finds_the_closed_form_from_a_warm_start_in_a_few_steps() {
    // Along a crank turn, each tick warm-started from the previous solution, as a rig would.
    let mut previous = closed_form(0.0);
    for k in 1..=200 {
        let q = f64::from(k) * 0.03;
        let solution = solve_passive(|p| constraints(q, p), &previous, &settings(1e-14)).expect("solves");
        let expected = closed_form(q);
        for i in 0..2 {
            assert!(
                (solution.passive[i] - expected[i]).abs() < 1e-12,
                "q = {q}: {:?} vs {expected:?}",
                solution.passive
            );
        }
        assert!(solution.steps <= 4, "q = {q}: {} steps", solution.steps);
        assert!(solution.margin > 0.0 && solution.margin <= 1.0);
        previous = solution.passive;
    }
    // In f32, to its precision.
    let q = 1.0_f32;
    let expected = closed_form(1.0);
    let guess = [expected[0] as f32 + 0.05, expected[1] as f32 - 0.05];
    let solution = solve_passive(|p| constraints(q, p), &guess, &settings(1e-6)).expect("solves in f32");
    for i in 0..2 {
        assert!(
            (f64::from(solution.passive[i]) - expected[i]).abs() < 1e-4,
            "{:?} vs {expected:?}",
            solution.passive
        );
    }
}

#[test]
fn the_sensitivity_is_the_derivative_of_the_closed_form() {
    for q in [0.3, 1.1, 2.4, 4.0, 5.5] {
        let solution =
            solve_passive(|p| constraints(q, p), &closed_form(q), &settings(1e-14)).expect("solves");
        let sensitivity = passive_sensitivity(&solution.factors, &actuated_jacobian(q)).expect("regular");
        let h = 1e-6;
        let (plus, minus) = (closed_form(q + h), closed_form(q - h));
        for i in 0..2 {
            let difference = (plus[i] - minus[i]) / (2.0 * h);
            assert!(
                (sensitivity[i][0] - difference).abs() < 1e-7,
                "q = {q}, row {i}: {} vs {difference}",
                sensitivity[i][0]
            );
        }
    }
}

#[test]
fn failures_are_reported_never_returned_as_numbers() {
    // Out of reach: with the crank stretched to 0.5 m the coupler and rocker cannot close the
    // loop; Newton stops at its bound.
    let far = |p: &[f64; 2]| {
        let (r, j) = constraints(0.0, p);
        ([r[0] + 0.5, r[1]], j)
    };
    assert_eq!(solve_passive(far, &[0.5, 1.0], &settings(1e-12)).err(), Some(LoopError::NotConverged));
    // A NaN guess, and a NaN actuated angle.
    assert_eq!(
        solve_passive(|p| constraints(0.3, p), &[f64::NAN, 1.0], &settings(1e-12)).err(),
        Some(LoopError::NonFinite)
    );
    assert_eq!(
        solve_passive(|p| constraints(f64::NAN, p), &closed_form(0.3), &settings(1e-12)).err(),
        Some(LoopError::NonFinite)
    );
    // Coupler and rocker aligned (β = γ): Φ_p's columns are parallel, the loop is singular.
    assert_eq!(
        solve_passive(|p| constraints(0.3, p), &[0.7, 0.7], &settings(1e-12)).err(),
        Some(LoopError::Singular)
    );
    // A NaN threshold fails safe.
    let mut nan_threshold = settings::<f64>(1e-12);
    nan_threshold.min_pivot_ratio = f64::NAN;
    assert_eq!(
        solve_passive(|p| constraints(0.3, p), &closed_form(0.3), &nan_threshold).err(),
        Some(LoopError::Singular)
    );
    // The sensitivity refuses a non-finite Φ_a.
    let solution =
        solve_passive(|p| constraints(0.3, p), &closed_form(0.3), &settings(1e-14)).expect("solves");
    assert_eq!(
        passive_sensitivity(&solution.factors, &[[f64::NAN], [0.0]]).err(),
        Some(LoopError::NonFinite)
    );
}
