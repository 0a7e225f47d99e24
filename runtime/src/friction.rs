//! Friction compensation: a feed-forward of the drives' Coulomb friction, the model's
//! `coulomb_friction` ([`RigModel::coulomb_friction`]), added to the torque of eq. (3).
//!
//! The paper leaves friction out of its model-based law and attributes the inaccuracy of the
//! step response "at low angular displacements from steady-state" to it (section 6.1). With
//! [`ControlOptions::friction_compensation_band`](crate::control::ControlOptions::friction_compensation_band)
//! set to `Some(δ)`, each drive `k` is given
//!
//! ```text
//! τ_f,k = F_c,k · sat(ȧ_k / δ),      sat(s) = max(−1, min(1, s))
//! ```
//!
//! on its output velocity `ȧ = C q̇` (`ȧ = q̇` without a [`RigModel::coupling`]), and the joints
//! get `Cᵀ τ_f` — where the simulated plant's friction acts too. Outside the band `|ȧ| ≥ δ`
//! this is `±F_c`, the friction the drive will feel; inside it a ramp through zero, so that
//! an estimated velocity that dithers about zero at rest (a quantised encoder, noise) gives a
//! torque proportional to the dither rather than `±F_c` switching every tick. The band is the
//! price: within it the compensation is partial. The identification regressor models the
//! same friction with the smoothed sign `q̇/√(q̇² + δ²)` (`COULOMB_BAND`,
//! `docs/regressor.md`); the ramp here reaches `±F_c` at `|ȧ| = δ` instead of
//! approaching it.
//!
//! Only Coulomb friction is fed forward. Static friction (`static_friction`) holds a joint at
//! rest until the other torques exceed it; a feed-forward cannot know which way a resting
//! joint is about to move, so that band remains (the stick band `τ_s / K_d` of a step
//! response). The viscous `B q̇` of eq. (3) is the law's own (the model's `damping`), not part
//! of this compensation.
//!
//! Off unless set ([`ControlOptions::paper`](crate::control::ControlOptions::paper) leaves it
//! `None`); nothing allocates and nothing panics. A NaN or infinite velocity gives no
//! compensation (zero torque for that drive), never a NaN torque; so does a band that is NaN
//! or negative. A band of `0` is the discontinuous `F_c sign ȧ` (zero at `ȧ = 0`).

use crate::{linalg, Real, RigModel};

/// The Coulomb feed-forward of one drive: `F_c · sat(velocity / band)` (module docs).
///
/// Zero when `velocity` or `coulomb` is not finite, or `band` is NaN or negative; with
/// `band = 0`, `±coulomb` for any non-zero velocity and zero at zero velocity.
pub fn coulomb_feedforward<S: Real>(coulomb: S, velocity: S, band: S) -> S {
    let usable_band = band >= S::ZERO; // false for a NaN band
    if !velocity.is_finite() || !coulomb.is_finite() || !usable_band {
        return S::ZERO;
    }
    let ratio = if band > S::ZERO {
        (velocity / band).clamp_to(-S::ONE, S::ONE)
    } else if velocity > S::ZERO {
        S::ONE
    } else if velocity < S::ZERO {
        -S::ONE
    } else {
        S::ZERO
    };
    coulomb * ratio
}

/// The joint torques that compensate `rig`'s Coulomb friction at `joint_velocity`, with the
/// ramp's half-width `band` (rad/s or m/s at the drives' outputs): `Cᵀ τ_f` with
/// `τ_f,k = F_c,k · sat((C q̇)_k / band)` (module docs). All zero for a rig without friction.
pub fn friction_compensation<R, const N: usize, const M: usize>(
    rig: &R,
    joint_velocity: &[R::Scalar; N],
    band: R::Scalar,
) -> [R::Scalar; N]
where
    R: RigModel<N, M>,
{
    let coulomb = rig.coulomb_friction();
    match rig.coupling() {
        Some(coupling) => {
            let drive_velocity = linalg::mat_vec(&coupling.drive_from_joint, joint_velocity);
            let mut drive_torque = [R::Scalar::ZERO; N];
            for ((torque, &fc), &velocity) in
                drive_torque.iter_mut().zip(coulomb.iter()).zip(drive_velocity.iter())
            {
                *torque = coulomb_feedforward(fc, velocity, band);
            }
            linalg::transpose_mul_vec(&coupling.drive_from_joint, &drive_torque)
        }
        None => {
            let mut torque = [R::Scalar::ZERO; N];
            for ((out, &fc), &velocity) in torque.iter_mut().zip(coulomb.iter()).zip(joint_velocity.iter()) {
                *out = coulomb_feedforward(fc, velocity, band);
            }
            torque
        }
    }
}

#[cfg(test)]
mod tests {
    use super::coulomb_feedforward;

    const FC: f64 = 0.01;
    const BAND: f64 = 0.05;

    #[test]
    fn outside_the_band_it_is_the_full_coulomb_friction_with_the_velocitys_sign() {
        for v in [BAND, 1.5 * BAND, 2.0, 1e6] {
            assert_eq!(coulomb_feedforward(FC, v, BAND), FC, "v = {v}");
            assert_eq!(coulomb_feedforward(FC, -v, BAND), -FC, "v = {}", -v);
        }
    }

    #[test]
    fn inside_the_band_it_is_a_ramp_through_zero() {
        assert_eq!(coulomb_feedforward(FC, 0.0, BAND), 0.0);
        for fraction in [0.1, 0.25, 0.5, 0.9] {
            let v = fraction * BAND;
            let expected = fraction * FC;
            assert!((coulomb_feedforward(FC, v, BAND) - expected).abs() < 1e-15, "v = {v}");
            assert!((coulomb_feedforward(FC, -v, BAND) + expected).abs() < 1e-15, "v = {}", -v);
        }
        // Monotone across the band.
        let mut samples = [0.0; 41];
        for (k, sample) in samples.iter_mut().enumerate() {
            *sample = coulomb_feedforward(FC, (k as f64 - 20.0) * 0.1 * BAND, BAND);
        }
        assert!(samples.windows(2).all(|w| w[0] <= w[1]), "{samples:?}");
    }

    #[test]
    fn a_zero_band_is_the_sign() {
        assert_eq!(coulomb_feedforward(FC, 1e-12, 0.0), FC);
        assert_eq!(coulomb_feedforward(FC, -1e-12, 0.0), -FC);
        assert_eq!(coulomb_feedforward(FC, 0.0, 0.0), 0.0);
    }

    #[test]
    fn non_finite_velocity_or_a_bad_band_gives_no_compensation() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(coulomb_feedforward(FC, v, BAND), 0.0, "v = {v}");
            assert_eq!(coulomb_feedforward(FC, v, 0.0), 0.0, "v = {v}, zero band");
        }
        for band in [f64::NAN, -BAND, f64::NEG_INFINITY] {
            assert_eq!(coulomb_feedforward(FC, 1.0, band), 0.0, "band = {band}");
        }
        assert_eq!(coulomb_feedforward(f64::NAN, 1.0, BAND), 0.0);
        // An infinite band never leaves the ramp's centre.
        assert_eq!(coulomb_feedforward(FC, 1.0, f64::INFINITY), 0.0);
    }

    #[test]
    fn single_precision_too() {
        assert_eq!(coulomb_feedforward(0.01f32, 0.2, 0.05), 0.01);
        assert_eq!(coulomb_feedforward(0.01f32, f32::NAN, 0.05), 0.0);
    }
}
