//! The inverse-dynamics law, eq. (3) `u = D a_q + C q̇ + B q̇ + g + Jᵀ a_f`, with
//! `a_q = J⁻¹(a_x − J̇ q̇)` from eq. (4), and the outer impedance laws of section 3 that choose
//! `a_x`, `a_f` (and `a_q`):
//!
//! | [`ImpedanceLaw`] | the paper's name | `a_x` | `a_f` | closed loop |
//! | --- | --- | --- | --- | --- |
//! | `ForceFeedback` | Controller 1 | eq. (7) | `f_l` (sensed) | eq. (6) |
//! | `AccelerationFeedback` | Controller 2, first variant | eq. (8) | eq. (10), corrected (below) | eq. (6) |
//! | `NaturalInertia` | Controller 2, second variant | eq. (8) with `M_d = W⁻¹` | `0` | eq. (11) |
//! | `JacobianTranspose` | Controller 3 | — (`a_q = 0`) | eq. (12) | eq. (13) |
//!
//! `W = J D⁻¹ Jᵀ` is the mobility tensor of eq. (5); `x̃ = x − x_d`.
//!
//! **Eq. (10) as printed has a typo**: its last term multiplies `ẍ`; the derivation from (5)
//! and (9) gives `x̃`. Writing `r = B_d ẋ̃ + K_d x̃`, eq. (9) reads
//! `W⁻¹(ẍ̃ + M_d⁻¹ r) − a_f = −f_l`, and requiring (6), `M_d ẍ̃ + r = −f_l`, gives
//! `a_f = (W⁻¹ − M_d) ẍ̃ + (W⁻¹ M_d⁻¹ − I)(B_d ẋ̃ + K_d x̃)`, i.e. the `K_d` term acts on `x̃`.
//! It is evaluated as `a_f = W⁻¹(ẍ − a_x) − M_d ẍ̃ − r` (one application of
//! `W⁻¹ = J⁻ᵀ D J⁻¹`), where `ẍ` is the caller's acceleration estimate.
//!
//! **Singularity policy.** Controllers 1 and 2 need `J⁻¹`. When `|det J|` is below
//! [`ControlOptions::min_abs_jacobian_determinant`] (or `J` is exactly singular) they fall
//! back, for that tick only, to Controller 3 (`a_q = 0`, `a_f` from eq. (12)), which the paper
//! (section 3.3, 6.1) shows stays stable at the workspace boundary; the output is flagged
//! [`ControlStatus::SingularFallback`] so the caller sees it. Nothing is latched: moving back
//! into the workspace restores the selected law. With `N != M`, Controllers 1 and 2 refuse
//! ([`ControlStatus::NonSquareTask`], zero torque); Controller 3 works for any `N`, `M`.
//!
//! **Omitting damping compensation** (section 4): with
//! [`ControlOptions::omit_damping_compensation`] the `B q̇` term of eq. (3) is dropped, so the
//! device's natural damping adds to `B_d` in free space.
//!
//! **Friction compensation** (not in the paper): with
//! [`ControlOptions::friction_compensation_band`] set, the rig's Coulomb friction
//! ([`RigModel::coulomb_friction`]) is fed forward, `u += Cᵀ F_c sat(C q̇ / δ)`
//! ([`crate::friction`]); off in [`ControlOptions::paper`].

use crate::friction;
use crate::linalg::{self, LuFactors, SolveError};
use crate::{Real, RigModel, RigTerms};

/// The outer impedance law, selectable at run time (section 3 of the paper).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImpedanceLaw {
    /// Force feedback (the paper's Controller 1, section 3.1): sensed operator force,
    /// `a_f = f_l`, `a_x` from eq. (7). Target eq. (6).
    ForceFeedback,
    /// Acceleration feedback (the paper's Controller 2, first variant, section 3.2): `a_x` from
    /// eq. (8), `a_f` from (corrected) eq. (10) using an estimate of the task acceleration `ẍ`.
    /// Target eq. (6).
    AccelerationFeedback,
    /// Natural-inertia impedance (the paper's Controller 2, second variant, section 3.2): the
    /// displayed mass is the device's own, `M_d = W⁻¹`, `a_f = 0`. Target eq. (11). `M_d` is
    /// ignored.
    NaturalInertia,
    /// Jacobian-transpose impedance (the paper's Controller 3, section 3.3): `a_q = 0`, `a_f`
    /// from eq. (12) applied through `Jᵀ`; no `J⁻¹`, no `J̇`. Target eq. (13). `M_d` is ignored.
    JacobianTranspose,
}

/// The desired impedance of eq. (6): diagonal `K_d`, `B_d`, `M_d`, one entry per task axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceParameters<S, const M: usize> {
    /// Diagonal of the desired stiffness `K_d`, N/m or N·m/rad.
    pub stiffness: [S; M],
    /// Diagonal of the desired damping `B_d`, N·s/m or N·m·s/rad.
    pub damping: [S; M],
    /// Diagonal of the desired mass `M_d`, kg or kg·m²; must be positive for Controller 1
    /// and the first variant of Controller 2.
    pub mass: [S; M],
}

/// The reference trajectory `x_d`, `ẋ_d`, `ẍ_d` in task space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskReference<S, const M: usize> {
    /// `x_d`.
    pub position: [S; M],
    /// `ẋ_d`.
    pub velocity: [S; M],
    /// `ẍ_d` (the paper takes it as zero; kept for generality).
    pub acceleration: [S; M],
}

impl<S: Real, const M: usize> TaskReference<S, M> {
    /// A reference at rest at `position`.
    pub fn at_rest(position: [S; M]) -> Self {
        Self { position, velocity: [S::ZERO; M], acceleration: [S::ZERO; M] }
    }
}

/// Task-space signals only some laws use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskSensing<S, const M: usize> {
    /// Operator force `f_l` from the force sensors (Controller 1 only), with the sign
    /// convention of eq. (1).
    pub operator_force: [S; M],
    /// Estimate of the task acceleration `ẍ` (first variant of Controller 2 only).
    pub acceleration: [S; M],
}

impl<S: Real, const M: usize> Default for TaskSensing<S, M> {
    fn default() -> Self {
        Self { operator_force: [S::ZERO; M], acceleration: [S::ZERO; M] }
    }
}

/// Options of the inverse-dynamics law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlOptions<S> {
    /// Drop `B q̇` from eq. (3) (paper, section 4).
    pub omit_damping_compensation: bool,
    /// Below this `|det J|`, Controllers 1 and 2 fall back to Controller 3 (see module docs).
    pub min_abs_jacobian_determinant: S,
    /// Lead time `τ` of the spring term, s: the law uses `x̃ + τ ẋ̃` in `K_d x̃`, i.e. a damping
    /// `B_d + K_d τ`. `0` is the paper's law. A sampled implementation delays the spring force
    /// by about half an impedance period (zero-order hold) plus the current loop's delay, which
    /// acts as a negative damping `−K_d τ` (Colgate & Schenkel); setting `τ` to that delay
    /// restores the displayed damping `B_d` of eq. (6), (11), (13).
    pub spring_lead_time: S,
    /// Coulomb-friction feed-forward ([`crate::friction`]): `None` (the paper's law) leaves it
    /// off; `Some(δ)` adds `F_c sat(ȧ/δ)` per drive, the rig's
    /// [`RigModel::coulomb_friction`] with a ramp of half-width `δ` (rad/s, m/s at the drives'
    /// outputs) through zero velocity, so that it does not chatter at rest. A NaN or infinite
    /// `δ` is refused like any non-finite input ([`ControlStatus::NonFiniteInput`]); a negative
    /// one gives no compensation.
    pub friction_compensation_band: Option<S>,
}

impl<S: Real> ControlOptions<S> {
    /// The paper's law: damping compensation on, no spring lead, singular below `|det J| = 0`,
    /// no friction compensation.
    pub fn paper() -> Self {
        Self {
            omit_damping_compensation: false,
            min_abs_jacobian_determinant: S::ZERO,
            spring_lead_time: S::ZERO,
            friction_compensation_band: None,
        }
    }

    /// `false` when a set option cannot be used: a non-finite spring lead or friction band
    /// (the laws then refuse with [`ControlStatus::NonFiniteInput`]).
    pub(crate) fn are_finite(&self) -> bool {
        let band_is_finite = match self.friction_compensation_band {
            Some(band) => band.is_finite(),
            None => true,
        };
        self.spring_lead_time.is_finite() && band_is_finite
    }
}

/// What happened in one evaluation of the law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControlStatus {
    /// The selected law was applied.
    Ok,
    /// `J` was (nearly) singular: Controller 3 was applied instead of Controller 1 or 2.
    SingularFallback,
    /// Controllers 1 and 2 need a square Jacobian (`N == M`). Torque is zero.
    NonSquareTask,
    /// A rig term, velocity, reference, sensed signal or parameter was NaN or infinite.
    /// Torque is zero.
    NonFiniteInput,
    /// `D` is not positive definite (Controller 2 needs `D⁻¹` or `W⁻¹`). Torque is zero.
    InertiaNotPositiveDefinite,
    /// A desired mass is not strictly positive where `M_d⁻¹` is needed. Torque is zero.
    InvalidParameters,
    /// The result overflowed. Torque is zero.
    NonFiniteResult,
}

impl ControlStatus {
    /// `true` when the torque is meaningful (the law or its documented fallback ran).
    pub fn is_usable(self) -> bool {
        matches!(self, ControlStatus::Ok | ControlStatus::SingularFallback)
    }
}

/// Joint torques `u` of eq. (3) and how they were obtained.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlOutput<S, const N: usize> {
    /// Joint torques (zero unless [`ControlStatus::is_usable`]).
    pub torque: [S; N],
    /// Status of this evaluation.
    pub status: ControlStatus,
}

impl<S: Real, const N: usize> ControlOutput<S, N> {
    pub(crate) fn refused(status: ControlStatus) -> Self {
        Self { torque: [S::ZERO; N], status }
    }
}

/// The configured impedance controller: law, desired impedance and options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceController<S, const M: usize> {
    /// Which law of section 3 to run.
    pub law: ImpedanceLaw,
    /// `K_d`, `B_d`, `M_d`.
    pub parameters: ImpedanceParameters<S, M>,
    /// Options of eq. (3).
    pub options: ControlOptions<S>,
}

impl<S: Real, const M: usize> ImpedanceController<S, M> {
    /// `law` rendering the desired impedance of eq. (6): diagonal stiffness `K_d`, damping
    /// `B_d` and mass `M_d`, one entry per task axis, with the paper's options
    /// ([`ControlOptions::paper`]).
    pub fn new(law: ImpedanceLaw, stiffness: [S; M], damping: [S; M], mass: [S; M]) -> Self {
        Self {
            law,
            parameters: ImpedanceParameters { stiffness, damping, mass },
            options: ControlOptions::paper(),
        }
    }
}

impl<S: Real, const M: usize> ImpedanceController<S, M> {
    /// Joint torques for one tick. `terms` must come from `rig.terms(q, joint_velocity)`;
    /// `rig` supplies the damping `B`. Never panics; see [`ControlStatus`] for refusals.
    pub fn torque<R, const N: usize>(
        &self,
        rig: &R,
        terms: &RigTerms<S, N, M>,
        joint_velocity: &[S; N],
        reference: &TaskReference<S, M>,
        sensed: &TaskSensing<S, M>,
    ) -> ControlOutput<S, N>
    where
        R: RigModel<N, M, Scalar = S>,
    {
        let damping = rig.damping();
        let sensed_is_finite = match self.law {
            ImpedanceLaw::ForceFeedback => linalg::all_finite(&sensed.operator_force),
            ImpedanceLaw::AccelerationFeedback => linalg::all_finite(&sensed.acceleration),
            ImpedanceLaw::NaturalInertia | ImpedanceLaw::JacobianTranspose => true,
        };
        if !sensed_is_finite
            || !inputs_are_finite(terms, joint_velocity, &damping, reference)
            || !parameters_are_finite(&self.parameters)
            || !self.options.are_finite()
        {
            return ControlOutput::refused(ControlStatus::NonFiniteInput);
        }
        // Eq. (3) without D a_q and Jᵀ a_f: C q̇ + B q̇ + g (+ the friction feed-forward).
        let friction = match self.options.friction_compensation_band {
            Some(band) => friction::friction_compensation(rig, joint_velocity, band),
            None => [S::ZERO; N],
        };
        let mut bias = [S::ZERO; N];
        for i in 0..N {
            bias[i] = terms.coriolis_times_qdot[i] + terms.gravity[i] + friction[i];
            if !self.options.omit_damping_compensation {
                bias[i] += damping[i] * joint_velocity[i];
            }
        }
        let task_velocity = linalg::mat_vec(&terms.jacobian, joint_velocity);
        let mut position_error = [S::ZERO; M];
        let mut velocity_error = [S::ZERO; M];
        // r = B_d ẋ̃ + K_d x̃, the impedance's restoring force.
        let mut restoring = [S::ZERO; M];
        for k in 0..M {
            position_error[k] = terms.position[k] - reference.position[k];
            velocity_error[k] = task_velocity[k] - reference.velocity[k];
            let damping =
                self.parameters.damping[k] + self.parameters.stiffness[k] * self.options.spring_lead_time;
            restoring[k] = damping * velocity_error[k] + self.parameters.stiffness[k] * position_error[k];
        }

        let output = match self.law {
            ImpedanceLaw::JacobianTranspose => jacobian_transpose(terms, bias, &restoring),
            ImpedanceLaw::ForceFeedback
            | ImpedanceLaw::AccelerationFeedback
            | ImpedanceLaw::NaturalInertia => {
                if N != M {
                    return ControlOutput::refused(ControlStatus::NonSquareTask);
                }
                let jacobian: [[S; N]; N] = square(&terms.jacobian);
                let factors = match LuFactors::new(&jacobian) {
                    Some(factors) => factors,
                    None => return ControlOutput::refused(ControlStatus::NonFiniteInput),
                };
                // Written so that a NaN threshold or determinant counts as singular.
                let regular = factors.determinant().abs() >= self.options.min_abs_jacobian_determinant
                    && factors.smallest_pivot() > S::ZERO;
                if !regular {
                    let mut fallback = jacobian_transpose(terms, bias, &restoring);
                    if fallback.status == ControlStatus::Ok {
                        fallback.status = ControlStatus::SingularFallback;
                    }
                    return fallback;
                }
                self.inverse_dynamics(terms, bias, &factors, reference, sensed, &restoring)
            }
        };
        if linalg::all_finite(&output.torque) {
            output
        } else {
            ControlOutput::refused(ControlStatus::NonFiniteResult)
        }
    }

    /// Controllers 1 and 2: `a_x`, `a_f`, then eq. (4) and (3). `N == M` here.
    fn inverse_dynamics<const N: usize>(
        &self,
        terms: &RigTerms<S, N, M>,
        bias: [S; N],
        jacobian: &LuFactors<S, N>,
        reference: &TaskReference<S, M>,
        sensed: &TaskSensing<S, M>,
        restoring: &[S; M],
    ) -> ControlOutput<S, N> {
        let needs_mass = !matches!(self.law, ImpedanceLaw::NaturalInertia);
        if needs_mass && !self.parameters.mass.iter().all(|&m| m > S::ZERO) {
            return ControlOutput::refused(ControlStatus::InvalidParameters);
        }
        let mut task_accel_command = [S::ZERO; M]; // a_x
        let mut task_force_command = [S::ZERO; M]; // a_f
        match self.law {
            ImpedanceLaw::ForceFeedback => {
                // Eq. (7): a_x = ẍ_d − M_d⁻¹(B_d ẋ̃ + K_d x̃ + f_l); a_f = f_l.
                for k in 0..M {
                    task_accel_command[k] = reference.acceleration[k]
                        - (restoring[k] + sensed.operator_force[k]) / self.parameters.mass[k];
                    task_force_command[k] = sensed.operator_force[k];
                }
            }
            ImpedanceLaw::AccelerationFeedback => {
                // Eq. (8), then the corrected eq. (10): a_f = W⁻¹(ẍ − a_x) − M_d ẍ̃ − r.
                let mut accel_excess = [S::ZERO; N];
                for k in 0..M {
                    task_accel_command[k] =
                        reference.acceleration[k] - restoring[k] / self.parameters.mass[k];
                }
                for (k, excess) in accel_excess.iter_mut().enumerate().take(M) {
                    *excess = sensed.acceleration[k] - task_accel_command[k];
                }
                let mobility_inverse_excess =
                    match inverse_mobility_times(jacobian, &terms.inertia_matrix, &accel_excess) {
                        Ok(value) => value,
                        Err(status) => return ControlOutput::refused(status),
                    };
                for (k, &value) in mobility_inverse_excess.iter().enumerate().take(M) {
                    let accel_error = sensed.acceleration[k] - reference.acceleration[k];
                    task_force_command[k] = value - self.parameters.mass[k] * accel_error - restoring[k];
                }
            }
            ImpedanceLaw::NaturalInertia => {
                // Eq. (8) with M_d⁻¹ = W = J D⁻¹ Jᵀ; a_f = 0.
                let jt_restoring: [S; N] = linalg::transpose_mul_vec(&terms.jacobian, restoring);
                let inertia_inverse = match linalg::cholesky_solve(&terms.inertia_matrix, &jt_restoring) {
                    Ok(value) => value,
                    Err(error) => return ControlOutput::refused(inertia_status(error)),
                };
                let mobility_restoring = linalg::mat_vec(&terms.jacobian, &inertia_inverse);
                for k in 0..M {
                    task_accel_command[k] = reference.acceleration[k] - mobility_restoring[k];
                }
            }
            ImpedanceLaw::JacobianTranspose => {}
        }
        // Eq. (4): a_q = J⁻¹(a_x − J̇ q̇).
        let mut rhs = [S::ZERO; N];
        for (k, value) in rhs.iter_mut().enumerate().take(M) {
            *value = task_accel_command[k] - terms.jacobian_dot_times_qdot[k];
        }
        let joint_accel_command = match jacobian.solve(&rhs, S::ZERO) {
            Ok(value) => value,
            Err(SolveError::NonFinite) => return ControlOutput::refused(ControlStatus::NonFiniteResult),
            Err(_) => return ControlOutput::refused(ControlStatus::NonFiniteInput),
        };
        // Eq. (3).
        let inertia_term = linalg::mat_vec(&terms.inertia_matrix, &joint_accel_command);
        let force_term = linalg::transpose_mul_vec(&terms.jacobian, &task_force_command);
        let mut torque = bias;
        for i in 0..N {
            torque[i] += inertia_term[i] + force_term[i];
        }
        ControlOutput { torque, status: ControlStatus::Ok }
    }
}

/// Controller 3, eq. (12) in eq. (3) with `a_q = 0`: `u = C q̇ + B q̇ + g − Jᵀ(B_d ẋ̃ + K_d x̃)`.
fn jacobian_transpose<S: Real, const N: usize, const M: usize>(
    terms: &RigTerms<S, N, M>,
    bias: [S; N],
    restoring: &[S; M],
) -> ControlOutput<S, N> {
    let force_term = linalg::transpose_mul_vec(&terms.jacobian, restoring);
    let mut torque = bias;
    for i in 0..N {
        torque[i] -= force_term[i];
    }
    ControlOutput { torque, status: ControlStatus::Ok }
}

/// `W⁻¹ v = J⁻ᵀ D J⁻¹ v`.
fn inverse_mobility_times<S: Real, const N: usize>(
    jacobian: &LuFactors<S, N>,
    inertia: &[[S; N]; N],
    v: &[S; N],
) -> Result<[S; N], ControlStatus> {
    let joint = jacobian.solve(v, S::ZERO).map_err(|_| ControlStatus::NonFiniteResult)?;
    let torque = linalg::mat_vec(inertia, &joint);
    jacobian.solve_transposed(&torque, S::ZERO).map_err(|_| ControlStatus::NonFiniteResult)
}

fn inertia_status(error: SolveError) -> ControlStatus {
    match error {
        SolveError::NonFinite => ControlStatus::NonFiniteResult,
        SolveError::NotPositiveDefinite | SolveError::Singular => ControlStatus::InertiaNotPositiveDefinite,
    }
}

/// Copies an `M × N` matrix into `N × N` (callers check `N == M`; never panics otherwise).
fn square<S: Real, const N: usize, const M: usize>(a: &[[S; N]; M]) -> [[S; N]; N] {
    let mut out = [[S::ZERO; N]; N];
    for (dst, src) in out.iter_mut().zip(a.iter()) {
        *dst = *src;
    }
    out
}

fn inputs_are_finite<S: Real, const N: usize, const M: usize>(
    terms: &RigTerms<S, N, M>,
    joint_velocity: &[S; N],
    damping: &[S; N],
    reference: &TaskReference<S, M>,
) -> bool {
    linalg::all_finite_matrix(&terms.inertia_matrix)
        && linalg::all_finite(&terms.coriolis_times_qdot)
        && linalg::all_finite(&terms.gravity)
        && linalg::all_finite(&terms.position)
        && linalg::all_finite_matrix(&terms.jacobian)
        && linalg::all_finite(&terms.jacobian_dot_times_qdot)
        && linalg::all_finite(joint_velocity)
        && linalg::all_finite(damping)
        && linalg::all_finite(&reference.position)
        && linalg::all_finite(&reference.velocity)
        && linalg::all_finite(&reference.acceleration)
}

fn parameters_are_finite<S: Real, const M: usize>(parameters: &ImpedanceParameters<S, M>) -> bool {
    linalg::all_finite(&parameters.stiffness)
        && linalg::all_finite(&parameters.damping)
        && linalg::all_finite(&parameters.mass)
}
