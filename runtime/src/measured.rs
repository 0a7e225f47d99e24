//! Measured passive joints: a gimbal's encoders, with no motors. Their counts become the
//! angles a rig's frame functions take (`<frame>_orientation(q, measured)` and
//! `<frame>_angular_jacobian(q, measured)`), by
//!
//! `angle = counts · 2π / counts_per_turn` (a prismatic joint: `counts / counts_per_turn` m),
//!
//! with zero counts at zero angle (the gimbal is at its reference pose when its counters are
//! reset). A reading beyond the joint's limits is refused, not clamped: the encoder slipped,
//! miscounted or is not connected, and a stylus orientation from it would be wrong.

use crate::Real;

/// One measured joint's encoder and range, as the generated `MEASURED_JOINTS` lists them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredJoint<S> {
    /// Encoder counts per turn of the joint (per metre for a prismatic joint), after
    /// quadrature decoding.
    pub counts_per_turn: u32,
    /// `true` for a revolute joint (counts are a fraction of a turn), `false` for a prismatic
    /// one (counts per metre).
    pub revolute: bool,
    /// Lower limit, rad or m: the range a reading is trusted in.
    pub lower: S,
    /// Upper limit, rad or m.
    pub upper: S,
}

impl<S: Real> MeasuredJoint<S> {
    /// The angle (rad) or travel (m) one count stands for: `2π / counts_per_turn` for a
    /// revolute joint, `1 / counts_per_turn` for a prismatic one (`None` without counts).
    pub fn count_size(&self) -> Option<S> {
        if self.counts_per_turn == 0 {
            return None;
        }
        let unit = if self.revolute { S::from_f64(core::f64::consts::TAU) } else { S::ONE };
        Some(unit / S::from_i64(i64::from(self.counts_per_turn)))
    }

    /// The joint's angle (or travel) from its counter, or `None` when it lies beyond the
    /// joint's limits (or the joint has no counts per turn).
    pub fn angle(&self, counts: i32) -> Option<S> {
        if self.counts_per_turn == 0 {
            return None;
        }
        let turns = S::from_i64(i64::from(counts)) / S::from_i64(i64::from(self.counts_per_turn));
        let angle = if self.revolute { turns * S::from_f64(core::f64::consts::TAU) } else { turns };
        if angle >= self.lower && angle <= self.upper {
            Some(angle)
        } else {
            None
        }
    }
}

/// Every measured joint's angle from its counter, in the order of the rig's
/// `MEASURED_JOINTS`; `None` if any reading is beyond its joint's limits.
pub fn measured_angles<S: Real, const K: usize>(
    joints: &[MeasuredJoint<S>; K],
    counts: &[i32; K],
) -> Option<[S; K]> {
    let mut angles = [S::ZERO; K];
    for ((angle, joint), &count) in angles.iter_mut().zip(joints).zip(counts) {
        *angle = joint.angle(count)?;
    }
    Some(angles)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROLL: MeasuredJoint<f64> =
        MeasuredJoint { counts_per_turn: 4096, revolute: true, lower: -2.6, upper: 2.6 };

    #[test]
    fn counts_are_fractions_of_a_turn_and_out_of_range_readings_are_refused() {
        // A quarter turn each way.
        assert_eq!(ROLL.angle(1024), Some(core::f64::consts::FRAC_PI_2));
        assert_eq!(ROLL.angle(-1024), Some(-core::f64::consts::FRAC_PI_2));
        // 2.6 rad is 1694.9 counts: 1694 is in, 1695 is beyond the limit.
        assert!(ROLL.angle(1694).is_some());
        assert_eq!(ROLL.angle(1695), None);
        assert_eq!(ROLL.angle(i32::MIN), None);
        let slide = MeasuredJoint { counts_per_turn: 1000, revolute: false, lower: -0.1, upper: 0.1 };
        assert_eq!(ROLL.count_size(), Some(core::f64::consts::TAU / 4096.0));
        assert_eq!(slide.count_size(), Some(0.001));
        assert_eq!(MeasuredJoint { counts_per_turn: 0, ..ROLL }.count_size(), None);
        assert_eq!(slide.angle(50), Some(0.05));
        assert_eq!(MeasuredJoint { counts_per_turn: 0, ..ROLL }.angle(0), None);
        let joints = [ROLL, slide];
        assert_eq!(measured_angles(&joints, &[0, 50]), Some([0.0, 0.05]));
        assert_eq!(measured_angles(&joints, &[0, 500]), None);
    }
}
