//! The stylus's orientation from its gimbal's encoders (measured passive joints: encoders, no
//! motors; the PHANToM Premium-like arm's roll, pitch and spin), read once per impedance tick.
//! The counters become angles by `angle = counts · 2π / counts_per_turn`
//! (`hapticgen_runtime::measured`, which refuses a reading beyond its joint's limits: a slipped
//! or disconnected encoder), and the generated `<frame>_orientation(q, measured)` turns them,
//! with the actuated joints' angles `q`, into the frame's rotation matrix `R(q, measured)`.
//! Force feedback stays 3-DOF: the orientation is an output for the host (a tool's pose), not
//! an input of the force.

use hapticgen_runtime::measured::{measured_angles, MeasuredJoint};

use crate::app::CostStats;
use crate::board::{CycleCounter, MeasuredEncoders};

/// The rotation matrix of a frame from the actuated joints' angles (`N`) and the measured
/// joints' (`K`): a rig's generated `<frame>_orientation`.
pub type OrientationFn<S, const N: usize, const K: usize> = fn(&[S; N], &[S; K]) -> [[S; 3]; 3];

/// Reads a gimbal's encoders into the stylus's orientation.
#[derive(Clone, Copy, Debug)]
pub struct Stylus<S, const N: usize, const K: usize> {
    joints: [MeasuredJoint<S>; K],
    /// The orientation of the last read; `None` before the first and after a refused one (a
    /// stale orientation is not passed on as a new one).
    pub orientation: Option<[[S; 3]; 3]>,
    /// The measured joints' angles of the last read (rad, or m), `None` as `orientation`.
    pub angles: Option<[S; K]>,
    /// Reads so far.
    pub reads: u32,
    /// Reads refused: some joint's reading beyond its limits.
    pub refused: u32,
    /// Cost of a read, counter ticks.
    pub cost: CostStats,
}

impl<S: hapticgen_runtime::Real, const N: usize, const K: usize> Stylus<S, N, K> {
    /// A reader for the measured `joints` (a rig's generated `MEASURED_JOINTS`).
    pub fn new(joints: [MeasuredJoint<S>; K]) -> Self {
        Self { joints, orientation: None, angles: None, reads: 0, refused: 0, cost: CostStats::EMPTY }
    }

    /// The measured joints' encoders and ranges.
    pub fn joints(&self) -> &[MeasuredJoint<S>; K] {
        &self.joints
    }

    /// Reads the gimbal's counters on `encoders` and, with the actuated joints' angles `q`,
    /// sets [`Stylus::orientation`] through the frame function `orientation_of` (a rig's
    /// `<frame>_orientation`; `None` when a reading is refused); timed with `clock`.
    pub fn read<E, F, C>(
        &mut self,
        encoders: &mut E,
        q: &[S; N],
        orientation_of: F,
        clock: &C,
    ) -> Option<[[S; 3]; 3]>
    where
        E: MeasuredEncoders<K>,
        F: Fn(&[S; N], &[S; K]) -> [[S; 3]; 3],
        C: CycleCounter,
    {
        let start = clock.now();
        let counts = encoders.measured_counts();
        let angles = measured_angles(&self.joints, &counts);
        let orientation = angles.map(|angles| orientation_of(q, &angles));
        let end = clock.now();
        self.cost.record(end.wrapping_sub(start));
        self.reads = self.reads.wrapping_add(1);
        if orientation.is_none() {
            self.refused = self.refused.wrapping_add(1);
        }
        self.orientation = orientation;
        self.angles = angles;
        orientation
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::NoClock;

    struct Counters([i32; 2]);

    impl MeasuredEncoders<2> for Counters {
        fn measured_counts(&mut self) -> [i32; 2] {
            self.0
        }
    }

    /// A frame turned about z by the first measured angle and about x by the second, the actuated
    /// joint's angle added to the first.
    fn turned(q: &[f64; 1], m: &[f64; 2]) -> [[f64; 3]; 3] {
        let (a, b) = (q[0] + m[0], m[1]);
        [[a.cos(), -a.sin(), 0.0], [a.sin(), a.cos(), 0.0], [0.0, 0.0, b]]
    }

    const JOINT: MeasuredJoint<f64> =
        MeasuredJoint { counts_per_turn: 4096, revolute: true, lower: -1.0, upper: 1.0 };

    #[test]
    fn counts_turn_into_the_frame_s_orientation_and_a_reading_out_of_range_is_refused() {
        let mut stylus = Stylus::new([JOINT, JOINT]);
        // 512 counts of 4096 are an eighth of a turn; 0.1 rad of actuated angle is added.
        let read = stylus.read(&mut Counters([512, -256]), &[0.1], turned, &NoClock);
        let expected = turned(&[0.1], &[core::f64::consts::FRAC_PI_4, -core::f64::consts::FRAC_PI_8]);
        assert_eq!(read, Some(expected));
        assert_eq!(stylus.orientation, Some(expected));
        // 1.0 rad is 651.9 counts: 652 is beyond the limit, and the last orientation is dropped.
        assert_eq!(stylus.read(&mut Counters([652, 0]), &[0.1], turned, &NoClock), None);
        assert_eq!(stylus.orientation, None);
        assert_eq!((stylus.reads, stylus.refused), (2, 1));
        assert!(stylus.read(&mut Counters([651, 0]), &[0.1], turned, &NoClock).is_some());
        assert_eq!((stylus.reads, stylus.refused, stylus.cost.count), (3, 1, 3));
    }
}
