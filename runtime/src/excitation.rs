//! Playing an identification excitation on the device: a periodic joint trajectory and the
//! joint-space law that tracks it.
//!
//! **The trajectory** is a finite Fourier series per joint (Swevers et al. 1997), period `T`,
//! `H` harmonics of `ω = 2π / T`:
//!
//! ```text
//! q_j(t) = q0_j + Σ_{k=1..H} a_jk sin(k ω t) + b_jk cos(k ω t)
//! ```
//!
//! with its velocity and acceleration differentiated term by term. The device starts at rest at
//! `q(0)`, where the series' velocity is in general not zero, so the reference enters the
//! series through a quintic blend over `ramp` seconds,
//! `q_d(t) = q(0) + s(t) (q(t) − q(0))`, `s = 10u³ − 15u⁴ + 6u⁵`, `u = t / ramp`: `q_d` is a
//! convex combination of two poses inside the limits, so it stays inside them, and starts
//! with zero velocity and acceleration.
//!
//! **The law** is computed torque on the model's own dynamics (eq. (1) without the operator):
//!
//! ```text
//! τ = D(q) (q̈_d + K_v (q̇_d − q̇) + K_p (q_d − q)) + C(q, q̇) q̇ + B q̇ + g(q)
//! ```
//!
//! `K_p`, `K_v` are accelerations per radian (per rad/s), so the error dynamics are
//! `ë + K_v ė + K_p e = 0` where the model is exact. Where it is not (that is why one
//! identifies), the feedback keeps the device on the trajectory and the measured torques carry
//! the difference.

// Matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::rig::{RigModel, RigTerms};
use crate::Real;

/// A joint-space reference: position, velocity and acceleration of every joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointReference<S, const N: usize> {
    /// `q_d`, rad (or m).
    pub position: [S; N],
    /// `q̇_d`.
    pub velocity: [S; N],
    /// `q̈_d`.
    pub acceleration: [S; N],
}

/// A periodic excitation trajectory: `H` harmonics per joint (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FourierTrajectory<S, const N: usize, const H: usize> {
    /// Period `T`, s.
    pub period: S,
    /// Duration of the blend from rest into the series, s (0: none).
    pub ramp: S,
    /// `q0_j`, the series' mean.
    pub offset: [S; N],
    /// `a_jk`, the sine coefficients (row `j`, harmonic `k + 1`).
    pub sine: [[S; H]; N],
    /// `b_jk`, the cosine coefficients.
    pub cosine: [[S; H]; N],
}

impl<S: Real, const N: usize, const H: usize> FourierTrajectory<S, N, H> {
    /// The series itself at `t` (no blend). One sine and cosine per call: harmonic `k + 1`'s
    /// come from harmonic `k`'s by the angle-addition formulas (`sin (k+1)x = sin kx cos x +
    /// cos kx sin x`, likewise the cosine), whose rounding grows by about an ulp per harmonic:
    /// a firmware tick computes one `sin_cos` instead of one per harmonic.
    pub fn series(&self, t: S) -> JointReference<S, N> {
        let omega = S::from_f64(core::f64::consts::TAU) / self.period;
        let mut out =
            JointReference { position: self.offset, velocity: [S::ZERO; N], acceleration: [S::ZERO; N] };
        let (sin_first, cos_first) = (omega * t).sin_cos();
        let (mut sin, mut cos) = (sin_first, cos_first);
        for k in 0..H {
            let rate = omega * S::from_i64(k as i64 + 1);
            for j in 0..N {
                let (a, b) = (self.sine[j][k], self.cosine[j][k]);
                out.position[j] += a * sin + b * cos;
                out.velocity[j] += rate * (a * cos - b * sin);
                out.acceleration[j] -= rate * rate * (a * sin + b * cos);
            }
            let next_sin = sin * cos_first + cos * sin_first;
            cos = cos * cos_first - sin * sin_first;
            sin = next_sin;
        }
        out
    }

    /// The reference at `t`: the series entered from rest at `q(0)` over [`Self::ramp`].
    pub fn reference(&self, t: S) -> JointReference<S, N> {
        let series = self.series(t);
        let in_blend = t < self.ramp && self.ramp > S::ZERO;
        if !in_blend {
            return series;
        }
        let start = self.series(S::ZERO).position;
        self.blend(&start, series, t)
    }

    /// The reference at `t` for a device that starts at rest at `start` (wherever it is, not
    /// the series' start): the same quintic blend from `start` into the series over
    /// [`Self::ramp`], then the series. With `start` the series' start it is
    /// [`Self::reference`]. Without a blend (`ramp` 0) the series itself from `t = 0`.
    pub fn reference_from(&self, start: &[S; N], t: S) -> JointReference<S, N> {
        let series = self.series(t);
        let in_blend = t < self.ramp && self.ramp > S::ZERO;
        if !in_blend {
            return series;
        }
        self.blend(start, series, t)
    }

    /// `series` (the series at `t`, inside the blend) entered from rest at `start`.
    #[inline(always)]
    fn blend(&self, start: &[S; N], series: JointReference<S, N>, t: S) -> JointReference<S, N> {
        let u = if t > S::ZERO { t / self.ramp } else { S::ZERO };
        let (u2, u3) = (u * u, u * u * u);
        let c = |x: f64| S::from_f64(x);
        let blend = u3 * (c(10.0) - c(15.0) * u + c(6.0) * u2);
        let blend_rate = c(30.0) * u2 * (S::ONE - u) * (S::ONE - u) / self.ramp;
        let blend_accel = c(60.0) * u * (S::ONE - u) * (S::ONE - c(2.0) * u) / (self.ramp * self.ramp);
        let mut out = series;
        for j in 0..N {
            let travel = series.position[j] - start[j];
            out.position[j] = start[j] + blend * travel;
            out.velocity[j] = blend_rate * travel + blend * series.velocity[j];
            out.acceleration[j] = blend_accel * travel
                + c(2.0) * blend_rate * series.velocity[j]
                + blend * series.acceleration[j];
        }
        out
    }
}

/// Gains of the joint-space tracking law (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointTracking<S, const N: usize> {
    /// `K_p`, 1/s² per joint.
    pub stiffness: [S; N],
    /// `K_v`, 1/s per joint.
    pub damping: [S; N],
}

impl<S: Real, const N: usize> JointTracking<S, N> {
    /// Critically damped error dynamics of natural frequency `hz` on every joint.
    pub fn critically_damped(hz: S) -> Self {
        let omega = S::from_f64(core::f64::consts::TAU) * hz;
        Self { stiffness: [omega * omega; N], damping: [S::from_f64(2.0) * omega; N] }
    }

    /// The computed torque of the module documentation at the measured `position`,
    /// `velocity` (with `terms` evaluated there); `None` if any input or the result is not
    /// finite.
    pub fn torque<R, const M: usize>(
        &self,
        rig: &R,
        terms: &RigTerms<S, N, M>,
        position: &[S; N],
        velocity: &[S; N],
        reference: &JointReference<S, N>,
    ) -> Option<[S; N]>
    where
        R: RigModel<N, M, Scalar = S>,
    {
        let damping = rig.damping();
        let mut acceleration = [S::ZERO; N];
        for j in 0..N {
            acceleration[j] = reference.acceleration[j]
                + self.damping[j] * (reference.velocity[j] - velocity[j])
                + self.stiffness[j] * (reference.position[j] - position[j]);
        }
        let mut torque = [S::ZERO; N];
        for i in 0..N {
            let mut sum = terms.coriolis_times_qdot[i] + terms.gravity[i] + damping[i] * velocity[i];
            for j in 0..N {
                sum += terms.inertia_matrix[i][j] * acceleration[j];
            }
            torque[i] = sum;
        }
        if torque.iter().all(|t| t.is_finite()) {
            Some(torque)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trajectory() -> FourierTrajectory<f64, 2, 3> {
        FourierTrajectory {
            period: 4.0,
            ramp: 1.0,
            offset: [0.1, -0.2],
            sine: [[0.2, -0.1, 0.05], [0.0, 0.3, 0.02]],
            cosine: [[0.1, 0.05, -0.03], [-0.2, 0.0, 0.01]],
        }
    }

    /// `reference`'s velocity and acceleration against central differences of its position
    /// and velocity at each of `times`.
    fn assert_derivatives(reference: impl Fn(f64) -> JointReference<f64, 2>, times: &[f64]) {
        let h = 1e-5;
        for &t in times {
            let (before, now, after) = (reference(t - h), reference(t), reference(t + h));
            for j in 0..2 {
                let velocity = (after.position[j] - before.position[j]) / (2.0 * h);
                let acceleration = (after.velocity[j] - before.velocity[j]) / (2.0 * h);
                assert!(
                    (velocity - now.velocity[j]).abs() < 1e-7,
                    "t = {t}: {velocity} vs {}",
                    now.velocity[j]
                );
                assert!(
                    (acceleration - now.acceleration[j]).abs() < 1e-6,
                    "t = {t}: {acceleration} vs {}",
                    now.acceleration[j]
                );
            }
        }
    }

    #[test]
    fn velocity_and_acceleration_are_the_derivatives_of_the_position() {
        let trajectory = trajectory();
        // Inside the blend and after it.
        assert_derivatives(|t| trajectory.reference(t), &[0.3, 0.77, 1.5, 3.9]);
    }

    /// The recurrence gives each harmonic's sine and cosine as evaluating them directly does,
    /// to rounding, over many periods and twelve harmonics.
    #[test]
    fn the_harmonics_by_recurrence_are_the_harmonics() {
        let mut trajectory = FourierTrajectory::<f64, 1, 12> {
            period: 2.0,
            ramp: 0.0,
            offset: [0.1],
            sine: [[0.0; 12]],
            cosine: [[0.0; 12]],
        };
        for k in 0..12 {
            trajectory.sine[0][k] = 0.3 / (k + 1) as f64;
            trajectory.cosine[0][k] = -0.2 / (k + 1) as f64;
        }
        let omega = core::f64::consts::TAU / trajectory.period;
        for step in 0..600 {
            let t = 0.1 * step as f64 + 0.013;
            let mut direct = [0.1, 0.0, 0.0];
            // The size of the terms each sum adds up: its rounding is relative to that.
            let mut size = [0.1, 0.0, 0.0];
            for k in 0..12 {
                let rate = omega * (k + 1) as f64;
                let (sin, cos) = (rate * t).sin_cos();
                let (a, b) = (trajectory.sine[0][k], trajectory.cosine[0][k]);
                direct[0] += a * sin + b * cos;
                direct[1] += rate * (a * cos - b * sin);
                direct[2] -= rate * rate * (a * sin + b * cos);
                let magnitude = a.abs() + b.abs();
                size[0] += magnitude;
                size[1] += rate * magnitude;
                size[2] += rate * rate * magnitude;
            }
            let series = trajectory.series(t);
            let got = [series.position[0], series.velocity[0], series.acceleration[0]];
            // Both round the phase of the highest harmonic, `12 ω t`, to its ulp.
            let phase_rounding = f64::EPSILON * (1.0 + 12.0 * omega * t);
            for ((g, d), size) in got.iter().zip(direct).zip(size) {
                assert!(
                    (g - d).abs() <= 4.0 * phase_rounding * size,
                    "t = {t}: {g} vs {d} (terms of size {size})"
                );
            }
        }
    }

    #[test]
    fn the_blend_starts_at_rest_at_the_series_start_and_joins_it() {
        let trajectory = trajectory();
        let start = trajectory.reference(0.0);
        assert_eq!(start.position, trajectory.series(0.0).position);
        assert_eq!(start.velocity, [0.0; 2]);
        assert_eq!(start.acceleration, [0.0; 2]);
        let joined = trajectory.reference(1.0);
        let series = trajectory.series(1.0);
        for j in 0..2 {
            assert!((joined.position[j] - series.position[j]).abs() < 1e-15);
            assert!((joined.velocity[j] - series.velocity[j]).abs() < 1e-12);
        }
        // Periodic after the blend.
        let (a, b) = (trajectory.reference(1.3), trajectory.reference(5.3));
        for j in 0..2 {
            assert!((a.position[j] - b.position[j]).abs() < 1e-12);
        }
    }

    /// From the series' own start, the blend from a given pose is the blend of
    /// [`FourierTrajectory::reference`], bit for bit; from another pose it starts there at rest,
    /// its velocity and acceleration are the derivatives of its position, and it joins the
    /// series at the end of the ramp.
    #[test]
    fn the_blend_from_a_given_pose_starts_there_and_joins_the_series() {
        let trajectory = trajectory();
        let own = trajectory.series(0.0).position;
        for t in [0.0, 0.2, 0.5, 0.99, 1.0, 2.5] {
            assert_eq!(trajectory.reference_from(&own, t), trajectory.reference(t), "t = {t}");
        }
        let start = [0.4, 0.3];
        let at_start = trajectory.reference_from(&start, 0.0);
        assert_eq!(at_start.position, start);
        assert_eq!(at_start.velocity, [0.0; 2]);
        assert_eq!(at_start.acceleration, [0.0; 2]);
        assert_derivatives(|t| trajectory.reference_from(&start, t), &[0.1, 0.3, 0.77, 0.95]);
        let (joined, series) = (trajectory.reference_from(&start, 1.0), trajectory.series(1.0));
        assert_eq!(joined, series);
        // Just before the end of the ramp: at the series to within its last steps.
        let almost = trajectory.reference_from(&start, 1.0 - 1e-6);
        for j in 0..2 {
            assert!((almost.position[j] - series.position[j]).abs() < 1e-6);
            assert!((almost.velocity[j] - series.velocity[j]).abs() < 1e-4);
        }
    }
}
