//! Safety rules that need a rig: the singular-pose policy of Controllers 1 and 2 (fall back to
//! Controller 3, reported, not latched) and NaN sensing through the full tick.

// Index loops mirror the equations component by component.
#![allow(clippy::needless_range_loop)]

use crate::common::Parallelogram;
use hapticgen_runtime::control::{
    ControlOptions, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
    TaskSensing,
};
use hapticgen_runtime::RigModel;

fn controller(law: ImpedanceLaw) -> ImpedanceController<f64, 2> {
    ImpedanceController {
        law,
        parameters: ImpedanceParameters { stiffness: [1500.0; 2], damping: [5.0; 2], mass: [0.2; 2] },
        options: ControlOptions {
            omit_damping_compensation: false,
            // |det J| = l_l·l_e·|sin(q1 − q2)| = 0.0075·|sin(q1 − q2)|: about 3° from singular.
            min_abs_jacobian_determinant: 4e-4,
            spring_lead_time: 0.0,
            friction_compensation_band: None,
        },
    }
}

#[test]
fn near_singular_pose_falls_back_to_jacobian_transpose_and_is_reported() {
    let rig = Parallelogram;
    let reference = TaskReference::at_rest([0.09, 0.09]);
    let sensed = TaskSensing { operator_force: [1.0, -1.0], acceleration: [0.5, 0.5] };
    for q in [[0.8, 0.8], [0.8, 0.8 + 0.02], [0.8, 0.8 - std::f64::consts::PI]] {
        let qd = [0.3, -0.2];
        let terms = rig.terms(&q, &qd);
        let fallback =
            controller(ImpedanceLaw::JacobianTranspose).torque(&rig, &terms, &qd, &reference, &sensed);
        for law in
            [ImpedanceLaw::ForceFeedback, ImpedanceLaw::AccelerationFeedback, ImpedanceLaw::NaturalInertia]
        {
            let out = controller(law).torque(&rig, &terms, &qd, &reference, &sensed);
            assert_eq!(out.status, ControlStatus::SingularFallback, "{law:?} at {q:?}");
            assert_eq!(out.torque, fallback.torque);
        }
    }
    // Away from the boundary the selected law runs again (nothing latched).
    let q = [1.5, -0.5];
    let terms = rig.terms(&q, &[0.0; 2]);
    let out = controller(ImpedanceLaw::NaturalInertia).torque(&rig, &terms, &[0.0; 2], &reference, &sensed);
    assert_eq!(out.status, ControlStatus::Ok);
}

#[test]
fn nan_anywhere_refuses_with_zero_torque() {
    let rig = Parallelogram;
    let q = [1.5, -0.5];
    let qd = [0.1, 0.2];
    let terms = rig.terms(&q, &qd);
    let reference = TaskReference::at_rest([0.09, 0.09]);
    let ok = TaskSensing::default();
    let bad_force = TaskSensing { operator_force: [f64::NAN, 0.0], acceleration: [0.0; 2] };
    let out = controller(ImpedanceLaw::ForceFeedback).torque(&rig, &terms, &qd, &reference, &bad_force);
    assert_eq!(out.status, ControlStatus::NonFiniteInput);
    assert_eq!(out.torque, [0.0; 2]);
    // Controller 3 does not use the force sensor, so its NaN does not matter there.
    let out = controller(ImpedanceLaw::JacobianTranspose).torque(&rig, &terms, &qd, &reference, &bad_force);
    assert_eq!(out.status, ControlStatus::Ok);
    let out = controller(ImpedanceLaw::JacobianTranspose).torque(
        &rig,
        &terms,
        &[f64::INFINITY, 0.0],
        &reference,
        &ok,
    );
    assert_eq!(out.status, ControlStatus::NonFiniteInput);
    let bad_reference = TaskReference::at_rest([f64::NAN, 0.0]);
    let out = controller(ImpedanceLaw::NaturalInertia).torque(&rig, &terms, &qd, &bad_reference, &ok);
    assert_eq!(out.status, ControlStatus::NonFiniteInput);
    let mut bad_terms = terms;
    bad_terms.inertia_matrix[0][1] = f64::NAN;
    let out = controller(ImpedanceLaw::AccelerationFeedback).torque(&rig, &bad_terms, &qd, &reference, &ok);
    assert_eq!(out.status, ControlStatus::NonFiniteInput);
    assert_eq!(out.torque, [0.0; 2]);
    let mut zero_mass = controller(ImpedanceLaw::ForceFeedback);
    zero_mass.parameters.mass = [0.0; 2];
    let out = zero_mass.torque(&rig, &terms, &qd, &reference, &ok);
    assert_eq!(out.status, ControlStatus::InvalidParameters);
}

/// An open chain has no loop to close: its loop margin is 1 at every pose (the default of
/// `RigModel::loop_margin`), above any threshold the safety monitor may hold, and it says so
/// by `HAS_LOOPS`. (A held-out survivor: the default returning 0, "at a singularity", went
/// unseen: the tick checks the margin of closed chains only.)
#[test]
fn an_open_chain_has_no_loop_and_a_loop_margin_of_one() {
    // Checked when the test compiles.
    const _: () = assert!(!<Parallelogram as RigModel<2, 2>>::HAS_LOOPS);
    let rig = Parallelogram;
    for q in [[0.0, 0.0], [1.2, -0.4], [f64::NAN, 0.3]] {
        assert_eq!(rig.loop_margin(&q), 1.0, "at {q:?}");
    }
}

/// With no determinant threshold at all (`min_abs_jacobian_determinant = 0`), an exactly
/// singular Jacobian still falls back to Controller 3: its zero pivot decides, where the
/// inverse would be infinite. (A held-out survivor: `smallest_pivot() > 0` → `>=`.)
#[test]
fn an_exactly_singular_pose_falls_back_even_without_a_threshold() {
    let rig = Parallelogram;
    let reference = TaskReference::at_rest([0.09, 0.09]);
    let sensed = TaskSensing { operator_force: [1.0, -1.0], acceleration: [0.5, 0.5] };
    // q1 = q2: the links aligned, det J = 0.0075·sin 0 = 0 exactly.
    let (q, qd) = ([0.8, 0.8], [0.3, -0.2]);
    let terms = rig.terms(&q, &qd);
    let fallback = controller(ImpedanceLaw::JacobianTranspose).torque(&rig, &terms, &qd, &reference, &sensed);
    for law in [ImpedanceLaw::ForceFeedback, ImpedanceLaw::AccelerationFeedback, ImpedanceLaw::NaturalInertia]
    {
        let mut unguarded = controller(law);
        unguarded.options.min_abs_jacobian_determinant = 0.0;
        let out = unguarded.torque(&rig, &terms, &qd, &reference, &sensed);
        assert_eq!((out.status, out.torque), (ControlStatus::SingularFallback, fallback.torque), "{law:?}");
    }
}
