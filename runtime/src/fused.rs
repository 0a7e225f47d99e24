//! Fused, rig-specialised impedance laws (eq. (3), (4), (7)–(13)) emitted by codegen, and the
//! rig-independent checks around them.
//!
//! For each rig, codegen emits one straight-line function per law with `J⁻¹`, `D⁻¹` and
//! `W⁻¹ = J⁻ᵀ D J⁻¹` in closed form (adjugate over determinant), sharing every subexpression
//! with the rig terms. [`fused_torque`] wraps them with exactly the checks and the singularity
//! policy of [`ImpedanceController::torque`](crate::control::ImpedanceController::torque),
//! so the two give the same torques and statuses; only the arithmetic is specialised.
//!
//! The emitted functions return the torque of eq. (3) *without* the viscous term `B q̇`,
//! which [`fused_torque`] adds unless `omit_damping_compensation` is set (section 4), nor the
//! friction feed-forward, which it adds when `friction_compensation_band` is set
//! ([`crate::friction`]).

use crate::control::ImpedanceParameters;
use crate::control::{
    ControlOutput, ControlStatus, ImpedanceController, ImpedanceLaw, TaskReference, TaskSensing,
};
use crate::{friction, linalg, Real, RigModel};

/// A fused law's result: eq. (3) without `B q̇`, and `det J` for the singularity guard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusedTorque<S, const N: usize> {
    /// `D a_q + C q̇ + g + Jᵀ a_f`.
    pub torque: [S; N],
    /// `det J` at this state.
    pub jacobian_determinant: S,
}

/// The impedance laws of section 3, specialised for one rig by codegen.
///
/// The methods taking `J⁻¹` return `None` when the task is not square (`N != M`) or has no
/// closed form: that is their default, so a rig implements only the laws it has.
pub trait FusedImpedance<const N: usize, const M: usize>: RigModel<N, M> {
    /// Jacobian-transpose impedance (the paper's Controller 3): `C q̇ + g − Jᵀ(B_d ẋ̃ + K_d x̃)`, eq. (12) in eq. (3) with `a_q = 0`.
    fn jacobian_transpose_torque(
        &self,
        q: &[Self::Scalar; N],
        qd: &[Self::Scalar; N],
        reference: &TaskReference<Self::Scalar, M>,
        parameters: &ImpedanceParameters<Self::Scalar, M>,
    ) -> [Self::Scalar; N];

    /// Force feedback (the paper's Controller 1): `a_x` from eq. (7), `a_f = f_l`, `a_q` from eq. (4).
    fn force_feedback_torque(
        &self,
        q: &[Self::Scalar; N],
        qd: &[Self::Scalar; N],
        reference: &TaskReference<Self::Scalar, M>,
        parameters: &ImpedanceParameters<Self::Scalar, M>,
        operator_force: &[Self::Scalar; M],
    ) -> Option<FusedTorque<Self::Scalar, N>> {
        let _ = (q, qd, reference, parameters, operator_force);
        None
    }

    /// Acceleration feedback (the paper's Controller 2, first variant): `a_x` from eq. (8), `a_f` from the corrected eq. (10).
    fn acceleration_feedback_torque(
        &self,
        q: &[Self::Scalar; N],
        qd: &[Self::Scalar; N],
        reference: &TaskReference<Self::Scalar, M>,
        parameters: &ImpedanceParameters<Self::Scalar, M>,
        task_acceleration: &[Self::Scalar; M],
    ) -> Option<FusedTorque<Self::Scalar, N>> {
        let _ = (q, qd, reference, parameters, task_acceleration);
        None
    }

    /// Natural-inertia impedance (the paper's Controller 2, second variant): `a_x = ẍ_d − W (B_d ẋ̃ + K_d x̃)`, `a_f = 0`, eq. (11).
    fn natural_inertia_torque(
        &self,
        q: &[Self::Scalar; N],
        qd: &[Self::Scalar; N],
        reference: &TaskReference<Self::Scalar, M>,
        parameters: &ImpedanceParameters<Self::Scalar, M>,
    ) -> Option<FusedTorque<Self::Scalar, N>> {
        let _ = (q, qd, reference, parameters);
        None
    }
}

/// Joint torques of the selected law through the rig's fused functions, with the same
/// checks, singularity fallback and statuses as `ImpedanceController::torque`.
pub fn fused_torque<R, const N: usize, const M: usize>(
    rig: &R,
    controller: &ImpedanceController<R::Scalar, M>,
    q: &[R::Scalar; N],
    qd: &[R::Scalar; N],
    reference: &TaskReference<R::Scalar, M>,
    sensed: &TaskSensing<R::Scalar, M>,
) -> ControlOutput<R::Scalar, N>
where
    R: FusedImpedance<N, M>,
{
    // The spring lead enters as extra damping `K_d τ` (see `ControlOptions::spring_lead_time`),
    // exactly as in the generic law.
    let mut parameters = controller.parameters;
    for (b, &k) in parameters.damping.iter_mut().zip(controller.parameters.stiffness.iter()) {
        *b += k * controller.options.spring_lead_time;
    }
    let p = &parameters;
    let sensed_is_finite = match controller.law {
        ImpedanceLaw::ForceFeedback => linalg::all_finite(&sensed.operator_force),
        ImpedanceLaw::AccelerationFeedback => linalg::all_finite(&sensed.acceleration),
        ImpedanceLaw::NaturalInertia | ImpedanceLaw::JacobianTranspose => true,
    };
    let finite = sensed_is_finite
        && linalg::all_finite(q)
        && linalg::all_finite(qd)
        && linalg::all_finite(&reference.position)
        && linalg::all_finite(&reference.velocity)
        && linalg::all_finite(&reference.acceleration)
        && linalg::all_finite(&p.stiffness)
        && linalg::all_finite(&p.damping)
        && linalg::all_finite(&p.mass)
        && controller.options.are_finite();
    if !finite {
        return ControlOutput::refused(ControlStatus::NonFiniteInput);
    }
    let jacobian_transpose = |status: ControlStatus| ControlOutput {
        torque: rig.jacobian_transpose_torque(q, qd, reference, p),
        status,
    };
    let output = match controller.law {
        ImpedanceLaw::JacobianTranspose => jacobian_transpose(ControlStatus::Ok),
        law => {
            let fused = match law {
                ImpedanceLaw::ForceFeedback => {
                    rig.force_feedback_torque(q, qd, reference, p, &sensed.operator_force)
                }
                ImpedanceLaw::AccelerationFeedback => {
                    rig.acceleration_feedback_torque(q, qd, reference, p, &sensed.acceleration)
                }
                _ => rig.natural_inertia_torque(q, qd, reference, p),
            };
            match fused {
                None => return ControlOutput::refused(ControlStatus::NonSquareTask),
                Some(f) => {
                    let det = f.jacobian_determinant;
                    // Written so that a NaN threshold or determinant counts as singular.
                    let regular = det.abs() >= controller.options.min_abs_jacobian_determinant
                        && det.abs() > R::Scalar::ZERO;
                    if !regular {
                        jacobian_transpose(ControlStatus::SingularFallback)
                    } else if law != ImpedanceLaw::NaturalInertia
                        && !p.mass.iter().all(|&m| m > R::Scalar::ZERO)
                    {
                        return ControlOutput::refused(ControlStatus::InvalidParameters);
                    } else {
                        ControlOutput { torque: f.torque, status: ControlStatus::Ok }
                    }
                }
            }
        }
    };
    let mut torque = output.torque;
    if !controller.options.omit_damping_compensation {
        let damping = rig.damping();
        for i in 0..N {
            torque[i] += damping[i] * qd[i];
        }
    }
    if let Some(band) = controller.options.friction_compensation_band {
        let friction = friction::friction_compensation(rig, qd, band);
        for (t, f) in torque.iter_mut().zip(friction.iter()) {
            *t += *f;
        }
    }
    if linalg::all_finite(&torque) {
        ControlOutput { torque, status: output.status }
    } else {
        ControlOutput::refused(ControlStatus::NonFiniteResult)
    }
}
