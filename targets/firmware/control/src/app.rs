//! The interrupt body of the firmware: one [`Controller::on_current_tick`] per current-loop
//! period (7.5 kHz for the paper's rigs), which also runs the impedance tick (1 kHz) when the
//! runtime's `Scheduler` says it is due.

use hapticgen_runtime::control::TaskSensing;
use hapticgen_runtime::fused::{fused_torque, FusedImpedance};
use hapticgen_runtime::safety::FaultCode;
use hapticgen_runtime::tick::{
    HapticLoop, HapticLoopSettings, ImpedanceInputs, ImpedanceReport, ReferenceSource,
};
use hapticgen_runtime::{Real, RigModel};

use crate::board::{Board, CycleCounter};

/// Minimum, maximum and mean of a cost in counter ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CostStats {
    /// Smallest sample.
    pub min: u32,
    /// Largest sample.
    pub max: u32,
    /// Sum of all samples.
    pub sum: u64,
    /// Number of samples.
    pub count: u32,
    /// Index (0-based) of the first sample equal to `max`.
    pub argmax: u32,
}

impl CostStats {
    /// No samples yet.
    pub const EMPTY: Self = Self { min: u32::MAX, max: 0, sum: 0, count: 0, argmax: 0 };

    /// Adds one sample.
    #[inline]
    pub fn record(&mut self, value: u32) {
        if value < self.min {
            self.min = value;
        }
        if value > self.max {
            self.max = value;
            self.argmax = self.count;
        }
        self.sum += u64::from(value);
        self.count = self.count.wrapping_add(1);
    }

    /// Integer mean (0 without samples).
    pub fn mean(&self) -> u32 {
        if self.count == 0 {
            0
        } else {
            (self.sum / u64::from(self.count)) as u32
        }
    }
}

impl Default for CostStats {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The sub-steps of one impedance tick, timed separately on a copy of the loop's state
/// (so the measurement does not disturb the run).
pub const PROFILE_STEPS: usize = 6;

/// Names of the profiled sub-steps, in the order of [`Profile::steps`].
pub const PROFILE_NAMES: [&str; PROFILE_STEPS] =
    ["estimation", "task_position", "reference", "fused_law", "safety", "sin_cos"];

/// Per-sub-step costs of the impedance tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Profile {
    /// One entry per [`PROFILE_NAMES`] entry.
    pub steps: [CostStats; PROFILE_STEPS],
}

/// What one current-loop period did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TickOutcome<S, const N: usize> {
    /// The voltages sent to the bridges.
    pub volts: [S; N],
    /// The impedance tick's report, when it ran this period.
    pub impedance: Option<ImpedanceReport<S, N>>,
}

/// The firmware's control state: the runtime's [`HapticLoop`] plus tick counting and cost
/// statistics.
pub struct Controller<R, Src, const N: usize, const M: usize>
where
    R: RigModel<N, M>,
{
    /// The runtime's control cycle.
    pub haptic: HapticLoop<R, Src, N, M>,
    rig: R,
    impedance_ticks: u32,
    clock_overhead: u32,
    /// Cost of [`HapticLoop::current_tick`] (all motors), counter ticks.
    pub current_cost: CostStats,
    /// Cost of [`HapticLoop::impedance_tick`], counter ticks.
    pub impedance_cost: CostStats,
    /// Sub-step costs, when profiling is on.
    pub profile: Option<Profile>,
    /// The first fault seen, if any.
    pub first_fault: Option<(u32, FaultCode)>,
}

impl<R, Src, const N: usize, const M: usize> Controller<R, Src, N, M>
where
    R: FusedImpedance<N, M> + Clone,
    Src: ReferenceSource<R::Scalar, M> + Clone,
{
    /// A controller for `rig`; `None` if the rig's rates are unusable. `profile` turns on the
    /// sub-step timing (doubles the impedance work; the timed figures are unaffected).
    pub fn new(
        rig: R,
        source: Src,
        settings: &HapticLoopSettings<R::Scalar, N, M>,
        profile: bool,
    ) -> Option<Self> {
        Some(Self {
            haptic: HapticLoop::new(rig.clone(), source, settings)?,
            rig,
            impedance_ticks: 0,
            clock_overhead: 0,
            current_cost: CostStats::EMPTY,
            impedance_cost: CostStats::EMPTY,
            profile: if profile { Some(Profile::default()) } else { None },
            first_fault: None,
        })
    }

    /// Measures the cost of reading the counter twice back to back (the smallest of 16
    /// tries) and subtracts it from every later measurement. Returns it.
    pub fn calibrate<C: CycleCounter>(&mut self, clock: &C) -> u32 {
        let mut best = u32::MAX;
        for _ in 0..16 {
            let a = clock.now();
            let b = clock.now();
            best = best.min(b.wrapping_sub(a));
        }
        self.clock_overhead = best;
        best
    }

    /// Impedance ticks run so far.
    pub fn impedance_ticks(&self) -> u32 {
        self.impedance_ticks
    }

    #[inline(always)]
    fn elapsed(&self, start: u32, end: u32) -> u32 {
        end.wrapping_sub(start).saturating_sub(self.clock_overhead)
    }

    /// The interrupt body, once per current-loop period: read the currents, run the current
    /// loops, write the voltages; then, if due, read encoders and force sensors and run the
    /// impedance tick (its new setpoints take effect from the next period).
    pub fn on_current_tick<B, C>(&mut self, board: &mut B, clock: &C) -> TickOutcome<R::Scalar, N>
    where
        B: Board<R::Scalar, N, M>,
        C: CycleCounter,
    {
        let (volts, due) = self.current_half(board, clock);
        let mut impedance = None;
        if due {
            let inputs = self.impedance_inputs(board);
            if self.profile.is_some() {
                self.profile_impedance(&inputs, clock);
            }
            let t2 = clock.now();
            let report = self.haptic.impedance_tick_fused(&inputs);
            let t3 = clock.now();
            impedance = Some(self.record_impedance(report, t2, t3));
        }
        TickOutcome { volts, impedance }
    }

    /// [`Self::on_current_tick`] with a joint-space law in place of the impedance law when the
    /// impedance tick is due ([`HapticLoop::joint_tick`]: the same estimation and safety
    /// rules): `law(tick)` receives the impedance tick's number (1 for the first) and returns
    /// the closure the tick calls, e.g. playing an identification excitation at time
    /// `tick / impedance rate`.
    pub fn on_current_tick_joint<B, C, L, F>(
        &mut self,
        board: &mut B,
        clock: &C,
        law: L,
    ) -> TickOutcome<R::Scalar, N>
    where
        B: Board<R::Scalar, N, M>,
        C: CycleCounter,
        L: FnOnce(u32) -> F,
        F: FnOnce(
            &R,
            &hapticgen_runtime::RigTerms<R::Scalar, N, M>,
            &hapticgen_runtime::estimation::JointState<R::Scalar, N>,
        ) -> Option<[R::Scalar; N]>,
    {
        let (volts, due) = self.current_half(board, clock);
        let mut impedance = None;
        if due {
            let inputs = self.impedance_inputs(board);
            let t2 = clock.now();
            let report = self.haptic.joint_tick(&inputs, law(inputs.tick));
            let t3 = clock.now();
            impedance = Some(self.record_impedance(report, t2, t3));
        }
        TickOutcome { volts, impedance }
    }

    /// The current loops of one period: currents read, voltages written; returns the
    /// voltages and whether the impedance tick is due.
    #[inline(always)]
    fn current_half<B, C>(&mut self, board: &mut B, clock: &C) -> ([R::Scalar; N], bool)
    where
        B: Board<R::Scalar, N, M>,
        C: CycleCounter,
    {
        let measured = board.currents();
        let t0 = clock.now();
        let (outputs, due) = self.haptic.current_tick(&measured);
        let t1 = clock.now();
        let mut volts = [R::Scalar::ZERO; N];
        for (v, o) in volts.iter_mut().zip(outputs.iter()) {
            *v = o.voltage;
        }
        board.set_voltages(&volts);
        self.current_cost.record(self.elapsed(t0, t1));
        (volts, due)
    }

    /// The next impedance tick's inputs: its number, the encoders and the force sensors.
    #[inline(always)]
    fn impedance_inputs<B: Board<R::Scalar, N, M>>(
        &mut self,
        board: &mut B,
    ) -> ImpedanceInputs<R::Scalar, N, M> {
        self.impedance_ticks = self.impedance_ticks.wrapping_add(1);
        ImpedanceInputs {
            encoder_counts: board.counts(),
            force_readings: board.force_readings(),
            tick: self.impedance_ticks,
        }
    }

    /// Records an impedance tick's cost (counter ticks `start` to `end`) and its first fault.
    #[inline(always)]
    fn record_impedance(
        &mut self,
        report: ImpedanceReport<R::Scalar, N>,
        start: u32,
        end: u32,
    ) -> ImpedanceReport<R::Scalar, N> {
        self.impedance_cost.record(self.elapsed(start, end));
        if let (None, Some(fault)) = (self.first_fault, report.command.fault) {
            self.first_fault = Some((self.impedance_ticks, fault));
        }
        report
    }

    /// Runs the sub-steps of [`HapticLoop::impedance_tick_fused`] on copies of its state, timing
    /// each. Mirrors `tick.rs` for Controllers 2 (second variant) and 3 (no sensed signals).
    #[inline(never)]
    fn profile_impedance<C: CycleCounter>(&mut self, inputs: &ImpedanceInputs<R::Scalar, N, M>, clock: &C) {
        let mut estimator = *self.haptic.estimator();
        let mut controller = self.haptic.controller;
        let mut source = self.haptic.source.clone();
        let mut safety = *self.haptic.safety();
        let rig = &self.rig;
        let t0 = clock.now();
        let _ = core::hint::black_box(estimator.update(&inputs.encoder_counts));
        let t1 = clock.now();
        let state = *core::hint::black_box(estimator.state());
        let t2 = clock.now();
        let position = core::hint::black_box(rig.position(&state.position));
        let t3 = clock.now();
        let reference = core::hint::black_box(source.update_reference(&position, &mut controller.parameters));
        let t4 = clock.now();
        let output = core::hint::black_box(fused_torque(
            rig,
            &controller,
            &state.position,
            &state.velocity,
            &reference,
            &TaskSensing::default(),
        ));
        let t5 = clock.now();
        safety.check_tick(inputs.tick);
        let command = core::hint::black_box(safety.limit(&output.torque));
        let t6 = clock.now();
        let angle = core::hint::black_box(state.position[0]);
        let t7 = clock.now();
        let _ = core::hint::black_box((angle.sin(), angle.cos()));
        let t8 = clock.now();
        let _ = command;
        let costs = [
            self.elapsed(t0, t1),
            self.elapsed(t2, t3),
            self.elapsed(t3, t4),
            self.elapsed(t4, t5),
            self.elapsed(t5, t6),
            self.elapsed(t7, t8),
        ];
        if let Some(profile) = self.profile.as_mut() {
            for (stats, cost) in profile.steps.iter_mut().zip(costs) {
                stats.record(cost);
            }
        }
    }
}
