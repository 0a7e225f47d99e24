//! An identification excitation as the host sends it (one `SetExcitation` per joint,
//! `hapticgen pil --scenario excite`, `hapticgen connect --excite`), assembled and checked
//! before a device plays it: [`ExcitationParts`] collects the joints, [`ExcitationParts::playable`]
//! gives the [`Excitation`] to play, or `None` (never a partial or doubtful one). The PIL image
//! and device mode ([`crate::device`]) use the same code.

use hapticgen_protocol::{ExcitationJoint, EXCITATION_HARMONICS};
use hapticgen_runtime::excitation::{FourierTrajectory, JointTracking};
use hapticgen_runtime::Real;

/// An identification excitation as the host sent it, joint by joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExcitationParts<const N: usize> {
    trajectory: FourierTrajectory<f32, N, EXCITATION_HARMONICS>,
    tracking_hz: f32,
    /// Which joints have arrived.
    received: [bool; N],
    /// A joint's period, ramp or bandwidth differed from the first's, or a joint was out of
    /// range.
    inconsistent: bool,
}

impl<const N: usize> ExcitationParts<N> {
    /// No joint yet.
    pub const EMPTY: Self = Self {
        trajectory: FourierTrajectory {
            period: 0.0,
            ramp: 0.0,
            offset: [0.0; N],
            sine: [[0.0; EXCITATION_HARMONICS]; N],
            cosine: [[0.0; EXCITATION_HARMONICS]; N],
        },
        tracking_hz: 0.0,
        received: [false; N],
        inconsistent: false,
    };

    /// Takes one joint's part; a joint out of range, or a period, ramp or bandwidth unlike the
    /// first part's, makes the whole excitation unplayable.
    pub fn add(&mut self, part: &ExcitationJoint) {
        let joint = usize::from(part.joint);
        let first = !self.received.iter().any(|&r| r);
        if first {
            self.trajectory.period = part.period;
            self.trajectory.ramp = part.ramp;
            self.tracking_hz = part.tracking_hz;
        } else if (part.period, part.ramp, part.tracking_hz)
            != (self.trajectory.period, self.trajectory.ramp, self.tracking_hz)
        {
            self.inconsistent = true;
        }
        match self.received.get_mut(joint) {
            Some(received) => *received = true,
            None => {
                self.inconsistent = true;
                return;
            }
        }
        if let (Some(offset), Some(sine), Some(cosine)) = (
            self.trajectory.offset.get_mut(joint),
            self.trajectory.sine.get_mut(joint),
            self.trajectory.cosine.get_mut(joint),
        ) {
            *offset = part.offset;
            *sine = part.sine;
            *cosine = part.cosine;
        }
    }

    /// `true` once every joint has arrived, or a part has made the excitation unplayable:
    /// [`Self::playable`] then has its answer.
    pub fn settled(&self) -> bool {
        self.inconsistent || self.received.iter().all(|&r| r)
    }

    /// The excitation to play at `impedance_loop_hz` ticks a second, if every joint arrived,
    /// they agree, every value is finite, the period is a whole number of impedance ticks (so
    /// that the series' time can wrap exactly, [`Excitation::time`]), the ramp not negative and
    /// the bandwidth positive.
    pub fn playable(&self, impedance_loop_hz: u32) -> Option<Excitation<N>> {
        let trajectory = &self.trajectory;
        let rate = impedance_loop_hz as f32;
        let finite = [trajectory.period, trajectory.ramp, self.tracking_hz]
            .iter()
            .chain(&trajectory.offset)
            .chain(trajectory.sine.iter().flatten())
            .chain(trajectory.cosine.iter().flatten())
            .all(|v| v.is_finite());
        let period_ticks = trajectory.period * rate;
        let whole = Real::round(period_ticks);
        let usable = finite
            && !self.inconsistent
            && self.received.iter().all(|&r| r)
            && (1.0..1.0e9).contains(&whole)
            // The `f32` product's rounding (a few 1e-7 of it), not a fraction of a tick.
            && Real::abs(period_ticks - whole) <= 1.0e-5 * whole
            && (0.0..1.0e5).contains(&trajectory.ramp)
            && self.tracking_hz > 0.0;
        usable.then(|| Excitation {
            trajectory: *trajectory,
            tracking: JointTracking::critically_damped(self.tracking_hz),
            period_ticks: whole as u32,
            ramp_ticks: -Real::floor(-trajectory.ramp * rate) as u32,
        })
    }
}

impl<const N: usize> Default for ExcitationParts<N> {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// An excitation a device plays: the series, the tracking law, the period and the blend in
/// whole impedance ticks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Excitation<const N: usize> {
    /// The series and its blend.
    pub trajectory: FourierTrajectory<f32, N, EXCITATION_HARMONICS>,
    /// The joint-space tracking law's gains.
    pub tracking: JointTracking<f32, N>,
    /// The period in impedance ticks.
    pub period_ticks: u32,
    /// The blend, rounded up to whole impedance ticks.
    pub ramp_ticks: u32,
}

impl<const N: usize> Excitation<N> {
    /// The series' time at the excitation's impedance tick `tick` (1 for the first, at time 0)
    /// at `impedance_loop_hz`: after the blend, wrapped to its first period in whole ticks, so
    /// that an `f32` time stays exact to a tick however long the run.
    pub fn time(&self, tick: u32, impedance_loop_hz: u32) -> f32 {
        let elapsed = tick.saturating_sub(1);
        let wrapped = if elapsed >= self.ramp_ticks {
            self.ramp_ticks + (elapsed - self.ramp_ticks) % self.period_ticks.max(1)
        } else {
            elapsed
        };
        wrapped as f32 / impedance_loop_hz as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(joint: u8) -> ExcitationJoint {
        let mut sine = [0.0; EXCITATION_HARMONICS];
        sine[0] = 0.1 * f32::from(joint + 1);
        ExcitationJoint {
            joint,
            period: 2.0,
            ramp: 0.5,
            tracking_hz: 8.0,
            offset: 0.25,
            sine,
            cosine: [0.0; EXCITATION_HARMONICS],
        }
    }

    fn all_of(parts: &[ExcitationJoint]) -> ExcitationParts<2> {
        let mut excitation = ExcitationParts::EMPTY;
        for part in parts {
            excitation.add(part);
        }
        excitation
    }

    #[test]
    fn every_joint_in_any_order_gives_the_excitation() {
        for order in [[0, 1], [1, 0]] {
            let parts = all_of(&order.map(part));
            assert!(parts.settled());
            let play = parts.playable(1000).expect("playable");
            assert_eq!((play.period_ticks, play.ramp_ticks), (2000, 500));
            assert_eq!(play.trajectory.sine[1][0], 0.2);
            assert_eq!(play.trajectory.offset, [0.25; 2]);
            assert_eq!(play.tracking, JointTracking::critically_damped(8.0));
        }
    }

    #[test]
    fn a_missing_joint_is_not_played() {
        let parts = all_of(&[part(1), part(1)]);
        assert!(!parts.settled());
        assert_eq!(parts.playable(1000), None);
    }

    #[test]
    fn joints_that_disagree_or_do_not_exist_are_refused() {
        let mut other = part(1);
        other.period = 3.0;
        assert_eq!(all_of(&[part(0), other]).playable(1000), None);
        let mut other = part(1);
        other.tracking_hz = 4.0;
        assert_eq!(all_of(&[part(0), other]).playable(1000), None);
        let parts = all_of(&[part(0), part(2)]);
        assert!(parts.settled(), "a joint out of range settles it");
        assert_eq!(parts.playable(1000), None);
    }

    #[test]
    fn values_that_cannot_be_played_are_refused() {
        let mut bad = part(1);
        bad.sine[3] = f32::NAN;
        assert_eq!(all_of(&[part(0), bad]).playable(1000), None);
        let not_whole = |period: f32, ramp: f32, tracking_hz: f32| {
            let parts = [part(0), part(1)].map(|p| ExcitationJoint { period, ramp, tracking_hz, ..p });
            all_of(&parts).playable(1000)
        };
        assert_eq!(not_whole(2.0005, 0.5, 8.0), None, "not a whole number of ticks");
        assert_eq!(not_whole(0.0, 0.5, 8.0), None);
        assert_eq!(not_whole(2.0, -0.5, 8.0), None);
        assert_eq!(not_whole(2.0, 0.5, 0.0), None);
        assert!(not_whole(2.0, 0.0, 8.0).is_some(), "no blend is fine");
    }

    #[test]
    fn the_series_time_wraps_in_whole_ticks_after_the_blend() {
        let play = all_of(&[part(0), part(1)]).playable(1000).unwrap();
        assert_eq!(play.time(1, 1000), 0.0);
        assert_eq!(play.time(501, 1000), 0.5);
        assert_eq!(play.time(2500, 1000), 2.499);
        assert_eq!(play.time(2501, 1000), 0.5, "one period after the blend's end");
        assert_eq!(play.time(2501 + 2000 * 1_000_000, 1000), 0.5);
    }
}
