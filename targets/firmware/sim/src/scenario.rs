//! A closed-loop run: the firmware's [`Controller`] driving the [`SimBoard`] for a fixed number
//! of current-loop periods, with an operator force profile, recording a checksum of the
//! trajectory and a decimated trace.
//!
//! Output lines (integers only, see `hapticgen_fw_control::report`):
//!
//! * `S k=<period> q=<µrad,…> x=<task, µm or µrad,…> i=<mA,…>` every `sample_every` periods;
//! * `SUMMARY …` with the final state, the first fault and the checksum;
//! * `STYLUS reads=… refused=… glitches=… max_error=… bound=… lag_min=… lag_max=…` (µrad;
//!   thousandths of a count) for a run with a stylus read from its gimbal ([`StylusRun`]);
//! * `COST …` and `PROFILE …` with counter ticks (zero on the host).
//!
//! The checksum is FNV-1a over the IEEE bits (widened to `f64`) of `q`, `q̇`, `i` and the
//! voltages after every period, and of the stylus's orientation after every read (or a marker
//! for a refused one), so an `f32` run on the host and on the target agree only if every
//! operation rounded identically.

use hapticgen_fw_control::app::{Controller, CostStats, PROFILE_NAMES};
use hapticgen_fw_control::board::CycleCounter;
use hapticgen_fw_control::report::{Line, Sink};
use hapticgen_fw_control::stylus::{OrientationFn, Stylus};
use hapticgen_runtime::tick::ReferenceSource;
use hapticgen_runtime::{Real, RigModel};

use crate::gimbal::SimGimbal;
use crate::plant::SimBoard;

/// The measured joints of a stylus's gimbal: roll, pitch and spin.
pub const GIMBAL_JOINTS: usize = 3;

/// A stylus whose orientation the firmware reads from its gimbal each impedance tick
/// ([`Stylus`]), turned by the operator ([`SimGimbal`]), with the largest angle between the
/// orientation read and the gimbal's true one (both at the firmware's estimate of the actuated
/// joints, so that only the gimbal's reading is measured).
#[derive(Clone, Copy, Debug)]
pub struct StylusRun<S, const N: usize> {
    /// The simulated gimbal.
    pub gimbal: SimGimbal<S, GIMBAL_JOINTS>,
    /// The firmware's reader.
    pub stylus: Stylus<S, N, GIMBAL_JOINTS>,
    /// The stylus frame's orientation (the rig's generated `<frame>_orientation`).
    pub orientation_of: OrientationFn<S, N, GIMBAL_JOINTS>,
    /// The largest angle between a read orientation and the true one, rad.
    pub max_error: S,
    /// The smallest and the largest lag of a joint's read angle behind its true angle, in
    /// thousandths of a count: within `[0, 1000)` for counters that floor the angle (up to
    /// rounding), where a count too many or too few, a wrong scale or sign leaves it.
    pub count_lag: (i64, i64),
}

impl<S: Real, const N: usize> StylusRun<S, N> {
    /// The largest error the encoders' quantisation allows, rad: one count of each joint (the
    /// counters floor the angle), the joints' turns adding up at most (the angle between two
    /// rotations is a metric invariant under composition), and 10 µrad for rounding (`f32`:
    /// about 10⁻⁷ in each entry).
    pub fn error_bound(&self) -> S {
        let mut bound = S::from_f64(10e-6);
        for joint in self.stylus.joints() {
            bound += joint.count_size().unwrap_or(S::ZERO);
        }
        bound
    }
}

/// What a run does besides the control cycle and the plant: nothing (`()`), or read a stylus
/// ([`StylusRun`]). A type of the run, not an `Option` in it, so that an image without a stylus
/// carries none of its code (eight kilobytes of flash on the PHANToM-like image).
pub trait RunExtra<S, const N: usize> {
    /// After an impedance tick, at the firmware's estimate `q` of the actuated joints: `hash`
    /// with what it read folded in.
    fn after_impedance_tick<C: CycleCounter>(&mut self, q: &[S; N], clock: &C, hash: u32) -> u32;
    /// One current-loop period on.
    fn advance(&mut self);
    /// Writes its report lines; its cost, if it has one to report (`COST <label>`).
    fn report<W: Sink>(&self, out: &mut W) -> Option<(&'static str, CostStats)>;
}

impl<S, const N: usize> RunExtra<S, N> for () {
    fn after_impedance_tick<C: CycleCounter>(&mut self, _: &[S; N], _: &C, hash: u32) -> u32 {
        hash
    }

    fn advance(&mut self) {}

    fn report<W: Sink>(&self, _: &mut W) -> Option<(&'static str, CostStats)> {
        None
    }
}

impl<S: Real, const N: usize> RunExtra<S, N> for StylusRun<S, N> {
    /// One read: the error against the gimbal's true orientation, and the orientation (or a
    /// refusal) folded into `hash`.
    fn after_impedance_tick<C: CycleCounter>(&mut self, q: &[S; N], clock: &C, mut hash: u32) -> u32 {
        let true_angles = self.gimbal.angles();
        let truth = (self.orientation_of)(q, &true_angles);
        let read = self.stylus.read(&mut self.gimbal, q, self.orientation_of, clock);
        if let Some(angles) = self.stylus.angles {
            for ((angle, true_angle), joint) in
                angles.iter().zip(true_angles.iter()).zip(self.stylus.joints())
            {
                let count = joint.count_size().map_or(f64::INFINITY, |size| size.to_f64());
                let lag = (true_angle.to_f64() - angle.to_f64()) / count;
                let millicounts = libm::round(lag * 1000.0) as i64;
                self.count_lag = (self.count_lag.0.min(millicounts), self.count_lag.1.max(millicounts));
            }
        }
        match read {
            Some(read) => {
                // The angle between the rotations from the Frobenius norm of their difference,
                // `|R_a − R_b|_F = 2√2 sin(θ/2)`, well conditioned at small angles.
                let mut squared = S::ZERO;
                for (row, true_row) in read.iter().zip(truth.iter()) {
                    for (x, y) in row.iter().zip(true_row.iter()) {
                        hash = fnv(hash, x.to_f64().to_bits());
                        squared += (*x - *y) * (*x - *y);
                    }
                }
                let half_chord = (squared.sqrt() / S::from_f64(2.0 * core::f64::consts::SQRT_2)).min(S::ONE);
                self.max_error = self.max_error.max(S::from_f64(2.0 * libm::asin(half_chord.to_f64())));
            }
            None => hash = fnv(hash, u64::MAX),
        }
        hash
    }

    fn advance(&mut self) {
        self.gimbal.advance();
    }

    fn report<W: Sink>(&self, out: &mut W) -> Option<(&'static str, CostStats)> {
        let mut line = Line::new();
        line.str("STYLUS")
            .kv("reads", i64::from(self.stylus.reads))
            .kv("refused", i64::from(self.stylus.refused))
            .kv("glitches", i64::from(self.gimbal.glitches()))
            .kv("max_error", micro(self.max_error))
            .kv("bound", micro(self.error_bound()))
            .kv("lag_min", self.count_lag.0)
            .kv("lag_max", self.count_lag.1);
        line.emit(out);
        Some(("stylus", self.stylus.cost))
    }
}

/// An operator force, task space, held from period `start` (inclusive) to `end` (exclusive).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Load<S, const M: usize> {
    /// First period.
    pub start: u32,
    /// Period after the last.
    pub end: u32,
    /// The force (N, or N·m for a joint-space task).
    pub force: [S; M],
}

/// A closed-loop run of one rig, with what it does besides (`X`, see [`RunExtra`]).
pub struct Scenario<R, Src, const N: usize, const M: usize, X = ()>
where
    R: RigModel<N, M>,
{
    /// The variant's name (from `targets/firmware/variants.txt`).
    pub name: &'static str,
    /// The firmware's control state.
    pub controller: Controller<R, Src, N, M>,
    /// The simulated board.
    pub board: SimBoard<R, N, M>,
    /// The operator.
    pub load: Load<R::Scalar, M>,
    /// Periods to run.
    pub periods: u32,
    /// Periods between trace lines.
    pub sample_every: u32,
    /// How far an `f32` run's task coordinates may stray from the `f64` reference (m or rad):
    /// see [`trace_tolerance`].
    pub task_tolerance: R::Scalar,
    /// How far an `f32` run's motor currents may stray from the `f64` reference (A): see
    /// [`current_tolerance`].
    pub current_tolerance: R::Scalar,
    /// What the run does besides: a stylus read from its gimbal each impedance tick, for a
    /// rig with one.
    pub extra: X,
    done: u32,
    checksum: u32,
}

/// Encoder counts of disagreement allowed between an `f32` and an `f64` run (see
/// [`trace_tolerance`]).
pub const TOLERANCE_COUNTS: f64 = 4.0;

/// The part of the current tolerance that covers the current loop's transients, mA: 0.5 A,
/// the motor current of 0.18 N·m on the paper's rigs (a quarter of the 3 N·m limit would be
/// 2 A; one encoder count through the paper's 1500 N/m wall is 0.06 N = 0.02 A at the motor).
/// See [`current_tolerance`] for the part that grows with the rendered stiffness.
pub const CURRENT_TOLERANCE_MILLIAMP: i64 = 500;

/// The tolerance of the motor currents of an `f32` run against the `f64` reference, A:
/// [`CURRENT_TOLERANCE_MILLIAMP`] plus the current that the allowed task disagreement
/// `task_tolerance` (see [`trace_tolerance`]) produces through the stiffness `K_d` in
/// effect, `max_j Σ_k |J_kj(q0)| K_d tol / (N_j η_j k_t,j)`. The two runs may rest one
/// grid node or a few encoder counts apart (the position check accepts that); the spring
/// then pulls each to its own point, and on a rig with long levers or low gearing that
/// difference in force is a large current (PHANToM-like arm: 0.3 mm through 1500 N/m at
/// 0.33 m is 0.6 A, a quarter of its current limit).
pub fn current_tolerance<R: RigModel<N, M>, const N: usize, const M: usize>(
    rig: &R,
    q0: &[R::Scalar; N],
    stiffness: R::Scalar,
    task_tolerance: R::Scalar,
) -> R::Scalar {
    let jacobian = rig.jacobian(q0);
    let drives = rig.drives();
    let mut worst = R::Scalar::ZERO;
    for (j, drive) in drives.iter().enumerate() {
        let mut lever = R::Scalar::ZERO;
        for row in jacobian.iter() {
            lever += row[j].abs();
        }
        let amps_per_newton_metre =
            R::Scalar::ONE / (drive.gear_ratio * drive.efficiency * drive.torque_constant);
        worst = worst.max(lever * stiffness.abs() * task_tolerance * amps_per_newton_metre);
    }
    R::Scalar::from_f64(CURRENT_TOLERANCE_MILLIAMP as f64 / 1000.0) + worst
}

/// The tolerance of the task coordinates of an `f32` run against the `f64` reference:
/// [`TOLERANCE_COUNTS`] encoder counts mapped to the task through `|J(q0)|` (largest row sum
/// of `|J_kj| · rad_per_count_j`), plus `extra` (for a rendered scene, two anti-drift grid
/// spacings: after a contact the proxy may settle on a neighbouring grid node).
///
/// Why counts: the two runs round differently in the last bit (about 1e-7 relative in
/// `f32`), so an encoder edge can be crossed one period earlier or later; the estimator then
/// sees a one-count step the other run sees later, and the loop's transient response to a
/// one-count disturbance is of the order of one count. Neutral directions (sliding along a
/// wall, where the renderer applies no spring) integrate such differences, hence the margin.
pub fn trace_tolerance<R: RigModel<N, M>, const N: usize, const M: usize>(
    rig: &R,
    q0: &[R::Scalar; N],
    extra: R::Scalar,
) -> R::Scalar {
    let jacobian = rig.jacobian(q0);
    let drives = rig.drives();
    let mut worst = R::Scalar::ZERO;
    for row in jacobian.iter() {
        let mut sum = R::Scalar::ZERO;
        for (j, entry) in row.iter().enumerate() {
            let per_count = R::Scalar::from_f64(2.0 * core::f64::consts::PI)
                / (R::Scalar::from_f64(f64::from(drives[j].encoder_counts_per_turn)) * drives[j].gear_ratio);
            sum += entry.abs() * per_count;
        }
        worst = worst.max(sum);
    }
    R::Scalar::from_f64(TOLERANCE_COUNTS) * worst + extra
}

const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

fn fnv(mut hash: u32, word: u64) -> u32 {
    for byte in word.to_le_bytes() {
        hash ^= u32::from(byte);
        hash = hash.wrapping_mul(FNV_PRIME);
    }
    hash
}

fn micro<S: Real>(value: S) -> i64 {
    libm::round(value.to_f64() * 1e6) as i64
}

impl<R, Src, const N: usize, const M: usize> Scenario<R, Src, N, M>
where
    R: hapticgen_runtime::fused::FusedImpedance<N, M> + Clone,
    Src: ReferenceSource<R::Scalar, M> + Clone,
{
    /// Assembles a run (with nothing besides; see [`Scenario::with`]).
    pub fn new(
        name: &'static str,
        controller: Controller<R, Src, N, M>,
        board: SimBoard<R, N, M>,
        load: Load<R::Scalar, M>,
        periods: u32,
        sample_every: u32,
    ) -> Self {
        Self {
            name,
            controller,
            board,
            load,
            periods,
            sample_every,
            task_tolerance: R::Scalar::ZERO,
            current_tolerance: R::Scalar::from_f64(CURRENT_TOLERANCE_MILLIAMP as f64 / 1000.0),
            extra: (),
            done: 0,
            checksum: FNV_OFFSET,
        }
    }

    /// The run, doing `extra` besides.
    pub fn with<X: RunExtra<R::Scalar, N>>(self, extra: X) -> Scenario<R, Src, N, M, X> {
        Scenario {
            name: self.name,
            controller: self.controller,
            board: self.board,
            load: self.load,
            periods: self.periods,
            sample_every: self.sample_every,
            task_tolerance: self.task_tolerance,
            current_tolerance: self.current_tolerance,
            extra,
            done: self.done,
            checksum: self.checksum,
        }
    }
}

impl<R, Src, const N: usize, const M: usize, X> Scenario<R, Src, N, M, X>
where
    R: hapticgen_runtime::fused::FusedImpedance<N, M> + Clone,
    Src: ReferenceSource<R::Scalar, M> + Clone,
    X: RunExtra<R::Scalar, N>,
{
    /// `true` once every period has run.
    pub fn finished(&self) -> bool {
        self.done >= self.periods
    }

    /// The trajectory checksum so far.
    pub fn checksum(&self) -> u32 {
        self.checksum
    }

    /// One current-loop period: the interrupt body on the board, then the plant advances by
    /// one period; a trace line every `sample_every` periods. Does nothing once finished.
    pub fn step<C: CycleCounter, W: Sink>(&mut self, clock: &C, out: &mut W) {
        if self.finished() {
            return;
        }
        let outcome = self.controller.on_current_tick(&mut self.board, clock);
        let mut hash = self.checksum;
        if outcome.impedance.is_some() {
            let q = self.controller.haptic.estimator().state().position;
            hash = self.extra.after_impedance_tick(&q, clock, hash);
        }
        let k = self.done;
        let force =
            if k >= self.load.start && k < self.load.end { self.load.force } else { [R::Scalar::ZERO; M] };
        self.board.advance(&force);
        self.extra.advance();
        for j in 0..N {
            hash = fnv(hash, self.board.q[j].to_f64().to_bits());
            hash = fnv(hash, self.board.qd[j].to_f64().to_bits());
            hash = fnv(hash, self.board.current[j].to_f64().to_bits());
            hash = fnv(hash, self.board.volts()[j].to_f64().to_bits());
        }
        self.checksum = hash;
        self.done += 1;
        if self.sample_every > 0 && self.done.is_multiple_of(self.sample_every) {
            self.trace(out);
        }
    }

    /// Runs every remaining period.
    pub fn run<C: CycleCounter, W: Sink>(&mut self, clock: &C, out: &mut W) {
        while !self.finished() {
            self.step(clock, out);
        }
    }

    fn trace<W: Sink>(&self, out: &mut W) {
        let mut line = Line::new();
        line.str("S").kv("k", i64::from(self.done)).str(" q=");
        for j in 0..N {
            if j > 0 {
                line.str(",");
            }
            line.i64(micro(self.board.q[j]));
        }
        let x = self.board.rig().position(&self.board.q);
        line.str(" x=");
        for (k, &value) in x.iter().enumerate() {
            if k > 0 {
                line.str(",");
            }
            line.i64(micro(value));
        }
        line.str(" i=");
        for j in 0..N {
            if j > 0 {
                line.str(",");
            }
            line.i64(micro(self.board.current[j]) / 1000);
        }
        line.emit(out);
    }

    /// The summary, cost and profile lines.
    pub fn report<W: Sink>(&self, scalar: &str, out: &mut W) {
        let c = &self.controller;
        let mut line = Line::new();
        line.str("SUMMARY").str(" variant=").str(self.name).str(" scalar=").str(scalar);
        line.kv("periods", i64::from(self.done)).kv("impedance_ticks", i64::from(c.impedance_ticks()));
        match c.first_fault {
            Some((tick, fault)) => {
                line.kv("fault", i64::from(fault.number())).kv("fault_tick", i64::from(tick))
            }
            None => line.kv("fault", 0),
        };
        line.kv("plant_ok", i64::from(!self.board.broken));
        line.kx("checksum", self.checksum);
        line.emit(out);
        line.str("TOL").kv("x", micro(self.task_tolerance)).kv("i", micro(self.current_tolerance) / 1000);
        line.emit(out);
        let extra_cost = self.extra.report(out);
        let costs = [Some(("current", c.current_cost)), Some(("impedance", c.impedance_cost)), extra_cost];
        for (label, stats) in costs.iter().flatten() {
            line.str("COST ").str(label);
            line.kv("n", i64::from(stats.count))
                .kv("min", i64::from(if stats.count == 0 { 0 } else { stats.min }))
                .kv("max", i64::from(stats.max))
                .kv("mean", i64::from(stats.mean()))
                .kv("argmax", i64::from(stats.argmax));
            line.emit(out);
        }
        if let Some(profile) = &c.profile {
            for (name, stats) in PROFILE_NAMES.iter().zip(profile.steps.iter()) {
                line.str("PROFILE ").str(name);
                line.kv("min", i64::from(if stats.count == 0 { 0 } else { stats.min }))
                    .kv("max", i64::from(stats.max))
                    .kv("mean", i64::from(stats.mean()));
                line.emit(out);
            }
        }
    }
}
