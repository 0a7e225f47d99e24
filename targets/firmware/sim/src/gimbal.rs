//! The simulated gimbal: the operator turns the stylus, each measured joint along its own
//! sine within its limits, `θ_k(t) = a_k sin(2π f_k t)` with `a_k` a share of the joint's
//! smaller limit, and its encoder counts `floor(θ_k · counts_per_turn / 2π)` (quantisation, as
//! the drives' encoders; a prismatic joint's counts are per metre). At the reads listed in
//! `glitches` one counter reads far beyond its joint's range (a slipped or disconnected
//! encoder), which the firmware must refuse.

use hapticgen_fw_control::board::MeasuredEncoders;
use hapticgen_runtime::measured::MeasuredJoint;
use hapticgen_runtime::Real;

/// How far towards its smaller limit each joint turns: 80 % of it.
pub const SHARE_OF_RANGE: f64 = 0.8;
/// Each joint's frequency, Hz: incommensurate, so the stylus visits varied orientations.
pub const FREQUENCIES_HZ: [f64; 3] = [0.7, 1.1, 0.45];
/// What a glitching counter reads: half a million counts, beyond any joint's range here.
pub const GLITCH_COUNTS: i32 = 500_000;

/// A gimbal of `K` measured joints turned by the operator (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct SimGimbal<S, const K: usize> {
    joints: [MeasuredJoint<S>; K],
    amplitudes: [S; K],
    period: S,
    /// The reads (0-based) at which a counter glitches: the `k`-th listed, counter `k % K`.
    glitches: &'static [u32],
    now: u32,
    reads: u32,
}

impl<S: Real, const K: usize> SimGimbal<S, K> {
    /// A gimbal of `joints` (a rig's `MEASURED_JOINTS`), stepped every `period` s, glitching
    /// at the reads `glitches`.
    pub fn new(joints: [MeasuredJoint<S>; K], period: S, glitches: &'static [u32]) -> Self {
        let mut amplitudes = [S::ZERO; K];
        for (amplitude, joint) in amplitudes.iter_mut().zip(joints.iter()) {
            *amplitude = joint.lower.abs().min(joint.upper.abs()) * S::from_f64(SHARE_OF_RANGE);
        }
        Self { joints, amplitudes, period, glitches, now: 0, reads: 0 }
    }

    /// The joints' true angles now, rad.
    pub fn angles(&self) -> [S; K] {
        let t = S::from_f64(f64::from(self.now)) * self.period;
        let mut angles = [S::ZERO; K];
        for (k, (angle, amplitude)) in angles.iter_mut().zip(self.amplitudes.iter()).enumerate() {
            let frequency = S::from_f64(FREQUENCIES_HZ.get(k % FREQUENCIES_HZ.len()).copied().unwrap_or(1.0));
            *angle = *amplitude * (S::from_f64(2.0 * core::f64::consts::PI) * frequency * t).sin();
        }
        angles
    }

    /// The glitches injected so far.
    pub fn glitches(&self) -> u32 {
        self.glitches.iter().filter(|&&at| at < self.reads).count() as u32
    }

    /// One current-loop period on.
    pub fn advance(&mut self) {
        self.now = self.now.wrapping_add(1);
    }
}

impl<S: Real, const K: usize> MeasuredEncoders<K> for SimGimbal<S, K> {
    fn measured_counts(&mut self) -> [i32; K] {
        let angles = self.angles();
        let mut counts = [0i32; K];
        for ((count, angle), joint) in counts.iter_mut().zip(angles.iter()).zip(self.joints.iter()) {
            *count = joint.count_size().map_or(0, |size| libm::floor(angle.to_f64() / size.to_f64()) as i32);
        }
        if let Some(index) = self.glitches.iter().position(|&at| at == self.reads) {
            if let Some(count) = counts.get_mut(index % K.max(1)) {
                *count = GLITCH_COUNTS;
            }
        }
        self.reads = self.reads.wrapping_add(1);
        counts
    }
}
