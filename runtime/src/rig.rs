//! The interface between a generated rig and the runtime.
//!
//! A rig with `N` joints and an `M`-dimensional task space (the operational point the
//! impedance controllers act on) implements [`RigModel<N, M>`]. The terms are those of the
//! paper's eq. (1) and (2): inertia matrix `D(q)`, Coriolis/centrifugal matrix `C(q, q̇)`,
//! viscous damping `B` (diagonal), gravity `g(q)`, task position `p(q)`, Jacobian `J(q)` and
//! `J̇(q, q̇)`. Matrices are row-major `[[S; cols]; rows]`.

use crate::current_loop::CurrentLoopGains;
use crate::Real;

/// Everything the control laws need at one state, computed in one pass so that common
/// subexpressions (sines, cosines, products) are shared across the terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigTerms<S, const N: usize, const M: usize> {
    /// Inertia matrix `D(q)` (symmetric positive definite), kg·m² or kg.
    pub inertia_matrix: [[S; N]; N],
    /// Coriolis and centrifugal torques `C(q, q̇) q̇`, N·m or N.
    pub coriolis_times_qdot: [S; N],
    /// Gravity torques `g(q) = ∂V/∂q`, N·m or N.
    pub gravity: [S; N],
    /// Task-space position `p(q)` of the operational point.
    pub position: [S; M],
    /// Task Jacobian `J(q) = ∂p/∂q`, `M` rows by `N` columns.
    pub jacobian: [[S; N]; M],
    /// `J̇(q, q̇) q̇`, the velocity-product term of eq. (2).
    pub jacobian_dot_times_qdot: [S; M],
}

/// A constant coupling between the joint coordinates `q` and the drives' output angles
/// `a = C q`: a cable or bevel differential, or a motor on the base that turns an absolute
/// angle through a parallelogram. Drive `k` turns its output by `a_k` (its motor by
/// `N_k a_k`, [`DriveTrain::gear_ratio`]), and by virtual work the joint torques are
/// `τ = Cᵀ τ_a`; the generator reflects the rotor inertias into `D` as `Cᵀ diag(N² J_m) C`.
/// A rig without one has `C = I` (each joint's drive turns that joint alone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coupling<S, const N: usize> {
    /// `C`: row `k` is drive `k`'s output angle per joint coordinate.
    pub drive_from_joint: [[S; N]; N],
    /// `C⁻¹` (inverted by the generator in `f64`): the joint coordinates per drive output.
    pub joint_from_drive: [[S; N]; N],
}

/// One joint's drive train: motor, gearhead, sensors and limits, all in SI units.
///
/// Torques on the joint side are `gear_ratio * efficiency * torque_constant * current`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveTrain<S> {
    /// Motor turns per joint turn (N).
    pub gear_ratio: S,
    /// Gearhead efficiency in (0, 1].
    pub efficiency: S,
    /// Motor torque constant k_t, N·m/A.
    pub torque_constant: S,
    /// Armature resistance R, Ω.
    pub resistance: S,
    /// Armature inductance L, H.
    pub inductance: S,
    /// Rotor inertia J_m, kg·m² (the reflected N²·J_m is already part of `D`).
    pub rotor_inertia: S,
    /// Largest joint-side torque the controller may command, N·m (or N for prismatic joints).
    pub torque_limit: S,
    /// Largest motor current the controller may command, A.
    pub current_limit: S,
    /// Supply voltage that bounds the current loop's output, V.
    pub supply_voltage: S,
    /// Encoder counts per motor turn (after quadrature decoding).
    pub encoder_counts_per_turn: u32,
    /// Lower joint limit, rad or m.
    pub position_lower: S,
    /// Upper joint limit, rad or m.
    pub position_upper: S,
}

impl<S: Real> DriveTrain<S> {
    /// The joint-side angle one encoder count stands for, rad: `2π / (counts_per_turn · N)`.
    pub fn count_size(&self) -> S {
        let counts_per_joint_turn = S::from_i64(i64::from(self.encoder_counts_per_turn)) * self.gear_ratio;
        S::from_f64(core::f64::consts::TAU) / counts_per_joint_turn
    }
}

/// A rig: the model-specific terms of the paper's eq. (1)–(2), implemented by generated code.
///
/// `N` is the number of joints (generalised coordinates), `M` the task-space dimension.
/// Every method is allocation-free straight-line arithmetic; none of them panics.
pub trait RigModel<const N: usize, const M: usize> {
    /// The scalar type the rig was generated for (`f32` or `f64`).
    type Scalar: Real;

    /// The model's name.
    const NAME: &'static str;
    /// Current-loop sample rate, Hz.
    const CURRENT_LOOP_HZ: u32;
    /// Impedance (outer) loop sample rate, Hz.
    const IMPEDANCE_LOOP_HZ: u32;

    /// Inertia matrix `D(q)`.
    fn inertia_matrix(&self, q: &[Self::Scalar; N]) -> [[Self::Scalar; N]; N];
    /// Coriolis/centrifugal matrix `C(q, q̇)` from the Christoffel symbols of `D`.
    fn coriolis_matrix(&self, q: &[Self::Scalar; N], qd: &[Self::Scalar; N]) -> [[Self::Scalar; N]; N];
    /// `C(q, q̇) q̇`.
    fn coriolis_times_qdot(&self, q: &[Self::Scalar; N], qd: &[Self::Scalar; N]) -> [Self::Scalar; N];
    /// Gravity vector `g(q)`.
    fn gravity(&self, q: &[Self::Scalar; N]) -> [Self::Scalar; N];
    /// Diagonal of the viscous damping matrix `B`.
    fn damping(&self) -> [Self::Scalar; N];
    /// Task-space position `p(q)`.
    fn position(&self, q: &[Self::Scalar; N]) -> [Self::Scalar; M];
    /// Task Jacobian `J(q)`.
    fn jacobian(&self, q: &[Self::Scalar; N]) -> [[Self::Scalar; N]; M];
    /// Time derivative of the Jacobian `J̇(q, q̇)`.
    fn jacobian_dot(&self, q: &[Self::Scalar; N], qd: &[Self::Scalar; N]) -> [[Self::Scalar; N]; M];
    /// `J̇(q, q̇) q̇`.
    fn jacobian_dot_times_qdot(&self, q: &[Self::Scalar; N], qd: &[Self::Scalar; N]) -> [Self::Scalar; M];
    /// All terms one control tick needs, sharing common subexpressions.
    fn terms(&self, q: &[Self::Scalar; N], qd: &[Self::Scalar; N]) -> RigTerms<Self::Scalar, N, M>;
    /// `true` for a closed chain: the impedance tick then checks [`RigModel::loop_margin`]
    /// (an open chain's check would always pass, so it is not paid for).
    const HAS_LOOPS: bool = false;

    /// How far `q` is from a singularity of the rig's own closed loops, where the constraint
    /// Jacobian of the passive joints loses rank and `D` grows without bound: the least over
    /// the loops of a closed chain's `closure_margin` (the squared sine of the angle between
    /// each loop's two distal links; 0 singular, negative or NaN where a loop cannot close).
    /// Open chains have no loop: `1`. The safety monitor latches a fault below its
    /// threshold ([`crate::safety::SafetyMonitor::check_loop_margin`]).
    fn loop_margin(&self, q: &[Self::Scalar; N]) -> Self::Scalar {
        let _ = q;
        Self::Scalar::ONE
    }
    /// The drive train of each joint (with a [`RigModel::coupling`], drive `k` is the one in
    /// joint `k`'s slot: its encoder, current loop and limits are drive `k`'s, its position
    /// limits joint `k`'s).
    fn drives(&self) -> [DriveTrain<Self::Scalar>; N];
    /// The coupling between joint coordinates and drive outputs; `None` (the default) when
    /// each joint's drive turns that joint alone.
    fn coupling(&self) -> Option<Coupling<Self::Scalar, N>> {
        None
    }
    /// Each drive's Coulomb friction `F_c`, N·m (N for a prismatic joint), acting on its output
    /// (drive `k` in joint `k`'s slot, as [`RigModel::drives`]): the model file's
    /// `coulomb_friction`, which a generated rig carries as `COULOMB_FRICTION` when any drive
    /// has some. The default, for a rig without friction, is zero. Read only by the friction
    /// compensation ([`crate::friction`]), which is off unless
    /// [`ControlOptions::friction_compensation_band`](crate::control::ControlOptions::friction_compensation_band)
    /// is set.
    fn coulomb_friction(&self) -> [Self::Scalar; N] {
        [Self::Scalar::ZERO; N]
    }
    /// Each motor's current-loop gains, in the order of `q`: for a generated rig its
    /// `CURRENT_LOOP_GAINS`, designed per joint from the model's motor, rates and filter.
    fn current_loop_gains(&self) -> [CurrentLoopGains<Self::Scalar>; N];
    /// Inverse dynamics of eq. (1) without damping and friction:
    /// `τ = D(q) q̈ + C(q, q̇) q̇ + g(q)`. The default evaluates the three terms; generated rigs
    /// override it with one straight-line function (the recursive Newton–Euler algorithm for
    /// long serial chains), which is cheaper than `D` alone.
    fn inverse_dynamics(
        &self,
        q: &[Self::Scalar; N],
        qd: &[Self::Scalar; N],
        qdd: &[Self::Scalar; N],
    ) -> [Self::Scalar; N] {
        let inertia = self.inertia_matrix(q);
        let mut torque = self.coriolis_times_qdot(q, qd);
        let gravity = self.gravity(q);
        for (i, t) in torque.iter_mut().enumerate() {
            *t += gravity[i];
            for (k, a) in qdd.iter().enumerate() {
                *t += inertia[i][k] * *a;
            }
        }
        torque
    }
}

/// Implements [`RigModel`] for a generated rig by calling the rig's inherent methods of the
/// same names (generated code emits the arithmetic once, as inherent methods, and this glue
/// once per rig instead of repeating it in every generated file).
///
/// ```text
/// ::hapticgen_runtime::impl_rig_model!(MyRig, f64, 2, 2, "my_rig", 7500, 1000);
/// ::hapticgen_runtime::impl_rig_model!(MyRig, f64, 2, 2, "my_rig", 7500, 1000; friction COULOMB_FRICTION);
/// ```
#[macro_export]
macro_rules! impl_rig_model {
    // `closure_margin`, for a closed chain: the inherent method whose least entry is the
    // rig's `loop_margin`.
    // `coupling CONST`, for a rig with a transmission: the inherent constant that is its
    // `RigModel::coupling`.
    // `friction CONST`, for a rig whose drives have Coulomb friction: the inherent constant
    // that is its `RigModel::coulomb_friction`.
    ($rig:ty, $s:ty, $n:literal, $m:literal, $name:literal, $current_hz:literal, $impedance_hz:literal $(, $closure_margin:ident)? $(; coupling $coupling:ident)? $(; friction $friction:ident)?) => {
        impl $crate::RigModel<$n, $m> for $rig {
            type Scalar = $s;
            const NAME: &'static str = $name;
            const CURRENT_LOOP_HZ: u32 = $current_hz;
            const IMPEDANCE_LOOP_HZ: u32 = $impedance_hz;

            fn inertia_matrix(&self, q: &[$s; $n]) -> [[$s; $n]; $n] {
                Self::inertia_matrix(self, q)
            }
            fn coriolis_matrix(&self, q: &[$s; $n], qd: &[$s; $n]) -> [[$s; $n]; $n] {
                Self::coriolis_matrix(self, q, qd)
            }
            fn coriolis_times_qdot(&self, q: &[$s; $n], qd: &[$s; $n]) -> [$s; $n] {
                Self::coriolis_times_qdot(self, q, qd)
            }
            fn gravity(&self, q: &[$s; $n]) -> [$s; $n] {
                Self::gravity(self, q)
            }
            fn damping(&self) -> [$s; $n] {
                Self::damping(self)
            }
            fn position(&self, q: &[$s; $n]) -> [$s; $m] {
                Self::position(self, q)
            }
            fn jacobian(&self, q: &[$s; $n]) -> [[$s; $n]; $m] {
                Self::jacobian(self, q)
            }
            fn jacobian_dot(&self, q: &[$s; $n], qd: &[$s; $n]) -> [[$s; $n]; $m] {
                Self::jacobian_dot(self, q, qd)
            }
            fn jacobian_dot_times_qdot(&self, q: &[$s; $n], qd: &[$s; $n]) -> [$s; $m] {
                Self::jacobian_dot_times_qdot(self, q, qd)
            }
            fn terms(&self, q: &[$s; $n], qd: &[$s; $n]) -> $crate::RigTerms<$s, $n, $m> {
                Self::terms(self, q, qd)
            }
            fn drives(&self) -> [$crate::DriveTrain<$s>; $n] {
                Self::DRIVES
            }
            $(
                fn coupling(&self) -> Option<$crate::rig::Coupling<$s, $n>> {
                    Some(Self::$coupling)
                }
            )?
            $(
                fn coulomb_friction(&self) -> [$s; $n] {
                    Self::$friction
                }
            )?
            fn current_loop_gains(&self) -> [$crate::current_loop::CurrentLoopGains<$s>; $n] {
                Self::CURRENT_LOOP_GAINS
            }
            fn inverse_dynamics(&self, q: &[$s; $n], qd: &[$s; $n], qdd: &[$s; $n]) -> [$s; $n] {
                Self::inverse_dynamics(self, q, qd, qdd)
            }
            $(
                const HAS_LOOPS: bool = true;
                fn loop_margin(&self, q: &[$s; $n]) -> $s {
                    $crate::rig::least_loop_margin(&Self::$closure_margin(self, q))
                }
            )?
        }
    };
}

/// The least of a closed chain's loop margins (`1` with none), for
/// [`RigModel::loop_margin`]; `−1` (a loop that cannot close)
/// as soon as one is not finite, so that NaN never reads as safe.
pub fn least_loop_margin<S: Real>(margins: &[S]) -> S {
    let mut least = S::ONE;
    for &margin in margins {
        if !margin.is_finite() {
            return S::ZERO - S::ONE;
        }
        if margin < least {
            least = margin;
        }
    }
    least
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_loop_margin_is_the_minimum_and_never_reads_a_non_finite_margin_as_safe() {
        assert_eq!(least_loop_margin::<f64>(&[]), 1.0);
        assert_eq!(least_loop_margin(&[0.7, 0.2, 0.9]), 0.2);
        assert_eq!(least_loop_margin(&[0.7, -0.3]), -0.3);
        assert_eq!(least_loop_margin(&[0.7, f64::NAN, 0.9]), -1.0);
        assert_eq!(least_loop_margin(&[f64::INFINITY]), -1.0);
        assert_eq!(least_loop_margin(&[0.5_f32, f32::NAN]), -1.0);
    }
}
