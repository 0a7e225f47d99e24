//! `loops`: Newton's method and the passive sensitivity on a planar four-bar whose loop has a
//! closed form worked out here: crank `a` turned by the actuated angle `q` about the origin,
//! coupler `b` at angle `β`, rocker `c` at angle `γ` about the ground pivot `(d, 0)`:
//! `Φ = (a cos q + b cos β − d − c cos γ, a sin q + b sin β − c sin γ) = 0`, passive `(β, γ)`.

use hapticgen_runtime::loops::{
    close_loops, passive_sensitivity, solve_passive, LoopCache, LoopConstraints, LoopError, LoopLevel,
    LoopSolverSettings,
};
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
    LoopSolverSettings {
        max_steps: 8,
        tolerance: S::from_f64(tolerance),
        min_pivot_ratio: S::from_f64(1e-6),
        warm_start_radius: S::from_f64(0.05),
    }
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

/// The four-bar as generated code describes a closed chain to `close_loops`, its assembly at
/// `q = 1` on the closed form's branch, Newton allowed `STEPS` steps.
#[derive(Default)]
struct FourBar<const STEPS: u32> {
    cache: LoopCache<f64, 1, 2>,
    /// How many times the solver evaluated `Φ`.
    evaluations: core::cell::Cell<u32>,
    /// Beyond this crank angle `Φ_a` reads NaN (a fault in the actuated Jacobian only).
    broken_above: core::cell::Cell<Option<f64>>,
}

/// `∂Φ/∂(β, γ)` at `passive`, differentiated once more along `passive_rate`, and `∂Φ_a/∂q · q̇`.
fn jacobian_rates(q: f64, qd: f64, passive: &[f64; 2], rate: &[f64; 2]) -> ([[f64; 2]; 2], [[f64; 1]; 2]) {
    let (b, c) = (COUPLER, ROCKER);
    let (sb, cb) = passive[0].sin_cos();
    let (sg, cg) = passive[1].sin_cos();
    (
        [[-b * cb * rate[0], c * cg * rate[1]], [-b * sb * rate[0], c * sg * rate[1]]],
        [[-CRANK * q.cos() * qd], [-CRANK * q.sin() * qd]],
    )
}

impl<const STEPS: u32> LoopConstraints<f64, 1, 2> for FourBar<STEPS> {
    const ASSEMBLY_ACTUATED: [f64; 1] = [1.0];
    // closed_form(1.0) and its derivative there, to a few digits: a guess, not the answer.
    const ASSEMBLY_PASSIVE: [f64; 2] = [0.40, 1.23];
    const ASSEMBLY_SENSITIVITY: [[f64; 1]; 2] = [[-0.12], [0.38]];
    const LOOP_SOLVER: LoopSolverSettings<f64> = LoopSolverSettings {
        max_steps: STEPS,
        tolerance: 1e-14,
        min_pivot_ratio: 1e-6,
        warm_start_radius: 0.05,
    };
    fn loop_cache(&self) -> &LoopCache<f64, 1, 2> {
        &self.cache
    }
    fn loop_constraints(
        &self,
        q: &[f64; 1],
        passive: &[f64; 2],
        passive_sin_cos: &[(f64, f64); 2],
    ) -> ([f64; 2], [[f64; 2]; 2]) {
        self.evaluations.set(self.evaluations.get() + 1);
        // The solver hands over the sines and cosines of the point it evaluates.
        assert_eq!(*passive_sin_cos, passive.map(Real::sin_cos));
        constraints(q[0], passive)
    }
    fn loop_actuated_jacobian(
        &self,
        q: &[f64; 1],
        passive: &[f64; 2],
        passive_sin_cos: &[(f64, f64); 2],
    ) -> [[f64; 1]; 2] {
        // At a solution: its sines and cosines, kept from the solve.
        assert_eq!(*passive_sin_cos, passive.map(Real::sin_cos));
        match self.broken_above.get() {
            Some(limit) if q[0] > limit => [[f64::NAN], [f64::NAN]],
            _ => actuated_jacobian(q[0]),
        }
    }
    fn loop_convective(
        &self,
        q: &[f64; 1],
        qd: &[f64; 1],
        passive: &[f64; 2],
        _passive_sin_cos: &[(f64, f64); 2],
        passive_rate: &[f64; 2],
    ) -> [f64; 2] {
        // γ = Φ̇_p q̇_p + Φ̇_a q̇_a, from the rates' matrices (the generated code's is its own
        // polynomial).
        let (passive_part, actuated_part) = jacobian_rates(q[0], qd[0], passive, passive_rate);
        core::array::from_fn(|r| {
            passive_part[r][0] * passive_rate[0]
                + passive_part[r][1] * passive_rate[1]
                + actuated_part[r][0] * qd[0]
        })
    }
    fn loop_jacobian_rates(
        &self,
        q: &[f64; 1],
        qd: &[f64; 1],
        passive: &[f64; 2],
        _passive_sin_cos: &[(f64, f64); 2],
        passive_rate: &[f64; 2],
    ) -> ([[f64; 2]; 2], [[f64; 1]; 2]) {
        jacobian_rates(q[0], qd[0], passive, passive_rate)
    }
}

#[test]
fn closed_loops_give_the_closed_form_and_its_first_and_second_derivatives() {
    let h = 1e-5;
    let derivative = |f: &dyn Fn(f64) -> [f64; 2], q: f64| {
        let (plus, minus) = (f(q + h), f(q - h));
        [(plus[0] - minus[0]) / (2.0 * h), (plus[1] - minus[1]) / (2.0 * h)]
    };
    for q in [0.6, 0.9, 1.0, 1.3, 1.6] {
        let qd = 0.7;
        let closed = close_loops(&FourBar::<8>::default(), &[q], LoopLevel::SensitivityRate, Some(&[qd]));
        assert_eq!(closed.error, None);
        let expected = closed_form(q);
        let slope = derivative(&closed_form, q);
        // Ȧ = dA/dq · q̇, with A from the closed form's differences.
        let curvature = derivative(&|x| derivative(&closed_form, x), q);
        for i in 0..2 {
            assert!((closed.passive[i] - expected[i]).abs() < 1e-12, "q = {q}: {:?}", closed.passive);
            assert!((closed.sensitivity[i][0] - slope[i]).abs() < 1e-7, "q = {q}: {:?}", closed.sensitivity);
            assert!((closed.passive_rate[i] - slope[i] * qd).abs() < 1e-7);
            assert!(
                (closed.sensitivity_rate[i][0] - curvature[i] * qd).abs() < 1e-4,
                "q = {q}: {:?} vs {:?}",
                closed.sensitivity_rate,
                curvature
            );
            // `Ȧ q̇_a`, from its own single solve: the second derivative along the path.
            assert!(
                (closed.passive_convective_acceleration[i] - curvature[i] * qd * qd).abs() < 1e-4,
                "q = {q}: {:?} vs {:?}",
                closed.passive_convective_acceleration,
                curvature
            );
            assert!(
                (closed.passive_convective_acceleration[i] - closed.sensitivity_rate[i][0] * qd).abs()
                    < 1e-12
            );
        }
        // At the `Sensitivity` level with a velocity: `q̇_p` and `Ȧ q̇_a`, not `Ȧ`.
        let without_rate = close_loops(&FourBar::<8>::default(), &[q], LoopLevel::Sensitivity, Some(&[qd]));
        assert_eq!(
            (without_rate.passive_rate, without_rate.passive_convective_acceleration),
            (closed.passive_rate, closed.passive_convective_acceleration)
        );
        assert!(without_rate.sensitivity_rate.iter().all(|r| r[0].is_nan()));
        assert!(closed.margin > 1e-3 && closed.margin <= 1.0);
        assert_eq!(closed.passive_sin_cos, closed.passive.map(Real::sin_cos));
        // Without a velocity the rates are not computed (NaN), the rest is the same; at the
        // position level, `A` is not either.
        let without_velocity = close_loops(&FourBar::<8>::default(), &[q], LoopLevel::Sensitivity, None);
        assert_eq!(
            (without_velocity.passive, without_velocity.sensitivity),
            (closed.passive, closed.sensitivity)
        );
        assert!(without_velocity
            .sensitivity_rate
            .iter()
            .chain(&without_velocity.passive_rate.map(|r| [r]))
            .chain(&without_velocity.passive_convective_acceleration.map(|r| [r]))
            .all(|r| r[0].is_nan()));
        let position = close_loops(&FourBar::<8>::default(), &[q], LoopLevel::Position, None);
        assert_eq!(position.passive, closed.passive);
        assert!(position.sensitivity.iter().all(|r| r[0].is_nan()));
    }
}

#[test]
fn closed_loops_that_cannot_be_solved_are_nan_with_the_reason() {
    // A NaN angle; and an angle too far from the assembly for the one step allowed.
    let cases = [
        (
            close_loops(&FourBar::<8>::default(), &[f64::NAN], LoopLevel::SensitivityRate, Some(&[0.5])),
            LoopError::NonFinite,
        ),
        (
            close_loops(&FourBar::<1>::default(), &[1.6], LoopLevel::Sensitivity, Some(&[0.5])),
            LoopError::NotConverged,
        ),
    ];
    for (closed, reason) in cases {
        assert_eq!(closed.error, Some(reason));
        assert!(closed
            .passive
            .iter()
            .chain(closed.passive_rate.iter())
            .chain(closed.passive_convective_acceleration.iter())
            .all(|x| x.is_nan()));
        assert!(closed
            .sensitivity
            .iter()
            .chain(closed.sensitivity_rate.iter())
            .flatten()
            .all(|x| x.is_nan()));
        assert!(closed.margin.is_nan());
    }
}

#[test]
fn closed_loops_are_reused_at_the_same_state_and_warm_started_near_it() {
    let rig = FourBar::<8>::default();
    let first = close_loops(&rig, &[1.3], LoopLevel::Position, None);
    assert!(first.steps >= 2, "from the tangent: {} steps", first.steps);
    // The same state: the same solution, no step, only what is new computed — and the same
    // values as a rig that computed everything at once.
    let full = close_loops(&rig, &[1.3], LoopLevel::SensitivityRate, Some(&[0.7]));
    assert_eq!((full.passive, full.steps), (first.passive, 0));
    let at_once = close_loops(&FourBar::<8>::default(), &[1.3], LoopLevel::SensitivityRate, Some(&[0.7]));
    assert_eq!(
        (full.sensitivity, full.sensitivity_rate, full.passive_convective_acceleration),
        (at_once.sensitivity, at_once.sensitivity_rate, at_once.passive_convective_acceleration)
    );
    // Another velocity at the same state: the rates and `Ȧ` anew, each only when asked for.
    let other_velocity = close_loops(&rig, &[1.3], LoopLevel::Sensitivity, Some(&[-0.2]));
    let expected = close_loops(&FourBar::<8>::default(), &[1.3], LoopLevel::SensitivityRate, Some(&[-0.2]));
    assert_eq!(
        (other_velocity.passive_rate, other_velocity.passive_convective_acceleration),
        (expected.passive_rate, expected.passive_convective_acceleration)
    );
    assert!(other_velocity.sensitivity_rate.iter().all(|r| r[0].is_nan()), "Ȧ of another velocity");
    let other_rate = close_loops(&rig, &[1.3], LoopLevel::SensitivityRate, Some(&[-0.2]));
    assert_eq!(other_rate.sensitivity_rate, expected.sensitivity_rate);
    // A tick's motion away: at most two steps from the last solution, and the closed form.
    let mut q = 1.3;
    for _ in 0..50 {
        q += 0.002;
        let closed = close_loops(&rig, &[q], LoopLevel::Position, None);
        assert!(closed.steps <= 2, "q = {q}: {} steps", closed.steps);
        let expected = closed_form(q);
        assert!(
            (closed.passive[0] - expected[0]).abs() < 1e-12
                && (closed.passive[1] - expected[1]).abs() < 1e-12
        );
    }
    // Where the last call computed `A`, the guess moves along it: fewer steps on the same path.
    let steps_along = |level: LoopLevel| -> u32 {
        let rig = FourBar::<8>::default();
        (0..50).map(|k| close_loops(&rig, &[1.3 + 0.002 * f64::from(k)], level, None).steps).sum()
    };
    let (without, with) = (steps_along(LoopLevel::Position), steps_along(LoopLevel::Sensitivity));
    assert!(with < without, "{with} steps with A against {without} without");
    // And along its curvature where the last call had a velocity (`Ȧ q̇_a`): fewer still.
    // (Steps of 0.01 rad: at 0.002 both need one step per solve, as above.)
    let along = |velocity: Option<&[f64; 1]>| -> u32 {
        let rig = FourBar::<8>::default();
        (0..20)
            .map(|k| close_loops(&rig, &[1.3 + 0.01 * f64::from(k)], LoopLevel::Sensitivity, velocity).steps)
            .sum()
    };
    let (tangent_only, curved) = (along(None), along(Some(&[10.0])));
    assert!(curved < tangent_only, "{curved} steps with Ȧ q̇_a against {tangent_only} with A only");
    // Beyond the warm-start radius: from the tangent again (more steps), still the branch.
    let far = close_loops(&rig, &[0.7], LoopLevel::Position, None);
    assert!(far.steps > 2, "{} steps", far.steps);
    assert!((far.passive[0] - closed_form(0.7)[0]).abs() < 1e-12);
    // A clone carries the cache along, and compares equal to an empty one.
    let cloned = FourBar::<8> { cache: rig.cache.clone(), ..FourBar::default() };
    assert_eq!(close_loops(&cloned, &[0.7], LoopLevel::Position, None).steps, 0);
    assert_eq!(cloned.cache, LoopCache::new());
}

#[test]
fn the_guess_is_the_last_solution_near_it_and_the_assemblys_tangent_elsewhere() {
    // From the tangent: exactly the solver's run from `q_p0 + A₀ (q − q_a0)` (same steps, same
    // bits), for a fresh rig and for one whose last solution is beyond the warm-start radius.
    type Rig = FourBar<8>;
    let tangent = |q: f64| -> [f64; 2] {
        core::array::from_fn(|r| {
            Rig::ASSEMBLY_PASSIVE[r] + Rig::ASSEMBLY_SENSITIVITY[r][0] * (q - Rig::ASSEMBLY_ACTUATED[0])
        })
    };
    let far_from_last = Rig::default();
    close_loops(&far_from_last, &[1.3], LoopLevel::Sensitivity, None);
    for rig in [Rig::default(), far_from_last] {
        let q = 1.6;
        let closed = close_loops(&rig, &[q], LoopLevel::Position, None);
        let expected = solve_passive(|p| constraints(q, p), &tangent(q), &Rig::LOOP_SOLVER).expect("solves");
        assert_eq!((closed.passive, closed.steps), (expected.passive, expected.steps));
    }
    // Near the last solution: exactly the solver's run from
    // `q_p + A Δq_a + ½ τ² Ȧ q̇_a`, `τ = Δq_a · q̇_a / |q̇_a|²`.
    let rig = Rig::default();
    let (q0, velocity, q) = (1.3, -0.8, 1.33);
    let last = close_loops(&rig, &[q0], LoopLevel::Sensitivity, Some(&[velocity]));
    let time = (q - q0) * velocity / (velocity * velocity);
    let guess: [f64; 2] = core::array::from_fn(|r| {
        last.passive[r]
            + last.sensitivity[r][0] * (q - q0)
            + 0.5 * time * time * last.passive_convective_acceleration[r]
    });
    let closed = close_loops(&rig, &[q], LoopLevel::Position, None);
    let expected = solve_passive(|p| constraints(q, p), &guess, &Rig::LOOP_SOLVER).expect("solves");
    assert_eq!((closed.passive, closed.steps), (expected.passive, expected.steps));
    // At rest (`q̇_a = 0`, so no `τ`): the tangent alone, not a 0/0 that would send Newton back
    // to the assembly's tangent.
    let rig = Rig::default();
    let last = close_loops(&rig, &[q0], LoopLevel::Sensitivity, Some(&[0.0]));
    let guess: [f64; 2] = core::array::from_fn(|r| last.passive[r] + last.sensitivity[r][0] * (q - q0));
    let closed = close_loops(&rig, &[q], LoopLevel::Position, None);
    let expected = solve_passive(|p| constraints(q, p), &guess, &Rig::LOOP_SOLVER).expect("solves");
    assert_eq!((closed.passive, closed.steps), (expected.passive, expected.steps));
    // The same state again: no evaluation of Φ at all.
    let rig = Rig::default();
    close_loops(&rig, &[1.3], LoopLevel::Position, None);
    let evaluations = rig.evaluations.get();
    close_loops(&rig, &[1.3], LoopLevel::Sensitivity, Some(&[0.4]));
    assert_eq!(rig.evaluations.get(), evaluations);
    assert_eq!(format!("{:?}", rig.cache), "LoopCache");
}

#[test]
fn a_solution_that_cannot_be_completed_is_nan_and_stays_so_at_that_state() {
    let rig = FourBar::<8>::default();
    rig.broken_above.set(Some(1.2));
    // The passive angles solve; A does not (Φ_a is NaN): everything NaN, with the reason.
    let position = close_loops(&rig, &[1.3], LoopLevel::Position, None);
    assert_eq!(position.error, None);
    let all_nan = |closed: &hapticgen_runtime::loops::ClosedLoops<f64, 1, 2>| {
        closed.passive.iter().chain(&closed.passive_rate).all(|x| x.is_nan())
            && closed.sensitivity.iter().chain(&closed.sensitivity_rate).all(|r| r[0].is_nan())
            && closed.passive_convective_acceleration.iter().all(|x| x.is_nan())
            && closed.margin.is_nan()
    };
    let closed = close_loops(&rig, &[1.3], LoopLevel::Sensitivity, Some(&[0.4]));
    assert_eq!(closed.error, Some(LoopError::NonFinite));
    assert!(all_nan(&closed));
    // The failure is what that state gives until the state changes, even with the fault gone.
    rig.broken_above.set(None);
    for (level, qd) in
        [(LoopLevel::Sensitivity, None), (LoopLevel::Sensitivity, Some(&[0.4])), (LoopLevel::Position, None)]
    {
        let again = close_loops(&rig, &[1.3], level, qd);
        assert_eq!(again.error, Some(LoopError::NonFinite));
        assert!(all_nan(&again), "{level:?}, {qd:?}");
    }
    assert_eq!(close_loops(&rig, &[1.31], LoopLevel::Sensitivity, None).error, None);
}
