//! One full control cycle of Fig. 1, as the firmware runs it, generic over the rig:
//!
//! * the **impedance tick** (`IMPEDANCE_LOOP_HZ`, 1 kHz): encoders → `q`, `q̇`, `q̈`
//!   (`estimation`) → rig terms of eq. (1)–(2) → reference `x_d` and `K_d`, `B_d` from a
//!   [`ReferenceSource`] (the haptic renderer of section 4, or a fixed reference) → the
//!   impedance law of eq. (3)–(13) (`control`) → limits and faults (`safety`) → motor current
//!   setpoints;
//! * the **current tick** (`CURRENT_LOOP_HZ`, 7.5 kHz): the PI current loops of section 2
//!   (`current_loop`) track those setpoints; the [`Scheduler`] says when the impedance tick is
//!   due.
//!
//! All state lives in [`HapticLoop`]; nothing allocates.
//!
//! # Example
//!
//! A control loop on the paper's parallel link, generated from its model with `rig!`: the
//! settings built from the rig in one call, a fixed reference at the start point, and one
//! second of the current-loop interrupt with the impedance tick run whenever it is due. On a
//! board the currents come from the ADC, the counts from the encoders and the voltages go to
//! the PWM stage; `docs/runtime-guide.md` walks through a longer example.
//!
//! ```
//! hapticgen_macros::rig!(mod rig = "../models/parallel_link_2dof.yaml", variant = "horizontal");
//! use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw, TaskReference};
//! use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
//! use hapticgen_runtime::RigModel;
//! use rig::ParallelLink2dof;
//!
//! let rig = ParallelLink2dof::NOMINAL;
//! let law = ImpedanceController::new(ImpedanceLaw::JacobianTranspose, [200.0; 2], [5.0; 2], [0.2; 2]);
//! let settings = HapticLoopSettings::for_rig(&rig, law);
//! let start = RigModel::position(&rig, &settings.zero_offset);
//! let mut haptic = HapticLoop::new(rig, TaskReference::at_rest(start), &settings).expect("rates");
//!
//! let mut impedance_ticks = 0;
//! for _ in 0..ParallelLink2dof::CURRENT_LOOP_HZ {
//!     let measured_currents = [0.0; 2]; // A
//!     let (outputs, due) = haptic.current_tick(&measured_currents);
//!     let _volts = [outputs[0].voltage, outputs[1].voltage];
//!     if due {
//!         impedance_ticks += 1;
//!         let inputs = ImpedanceInputs { encoder_counts: [0; 2], force_readings: [0.0; 2], tick: impedance_ticks };
//!         let report = haptic.impedance_tick_fused(&inputs);
//!         assert_eq!(report.command.fault, None);
//!     }
//! }
//! assert_eq!(impedance_ticks, ParallelLink2dof::IMPEDANCE_LOOP_HZ); // 1 kHz for one second
//! ```

use crate::control::{
    ControlOutput, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
    TaskSensing,
};
use crate::current_loop::{CurrentLoopBank, CurrentLoopGains, CurrentLoopOutput, CurrentLoopStatus};
use crate::estimation::{
    EstimationStatus, EstimatorSettings, ForceSensorCalibration, JointState, JointStateEstimator,
};
use crate::fused::{fused_torque, FusedImpedance};
use crate::linalg;
use crate::render::Scene;
use crate::safety::{FaultCode, SafeCommand, SafetyMonitor};
use crate::schedule::Scheduler;
use crate::{Real, RigModel};

/// Marks "no impedance tick pending" in the current loop's watchdog.
const NO_IMPEDANCE_PENDING: u32 = u32::MAX;

/// Supplies the impedance law's reference each tick, and may set `K_d`, `B_d`.
pub trait ReferenceSource<S, const M: usize> {
    /// The reference for a device at task position `task_position`.
    fn update_reference(
        &mut self,
        task_position: &[S; M],
        parameters: &mut ImpedanceParameters<S, M>,
    ) -> TaskReference<S, M>;
}

impl<S: Real, const M: usize> ReferenceSource<S, M> for TaskReference<S, M> {
    fn update_reference(
        &mut self,
        _task_position: &[S; M],
        _parameters: &mut ImpedanceParameters<S, M>,
    ) -> TaskReference<S, M> {
        *self
    }
}

impl<S: Real, const K: usize, const V: usize> ReferenceSource<S, 2> for Scene<S, K, V> {
    fn update_reference(
        &mut self,
        task_position: &[S; 2],
        parameters: &mut ImpedanceParameters<S, 2>,
    ) -> TaskReference<S, 2> {
        Scene::update_reference(self, task_position, parameters)
    }
}

/// Sensor readings for one impedance tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceInputs<S, const N: usize, const M: usize> {
    /// Raw encoder counters, one per joint.
    pub encoder_counts: [i32; N],
    /// Raw force-sensor readings (used by Controller 1 only).
    pub force_readings: [S; M],
    /// Impedance-tick counter, +1 per period (watchdog).
    pub tick: u32,
}

/// What one impedance tick did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImpedanceReport<S, const N: usize> {
    /// Torques and current setpoints after the safety rules.
    pub command: SafeCommand<S, N>,
    /// Status of the impedance law.
    pub control_status: ControlStatus,
    /// Status of the sensing.
    pub estimation_status: EstimationStatus,
}

/// Configuration of [`HapticLoop::new`] besides the rig and the reference source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HapticLoopSettings<S, const N: usize, const M: usize> {
    /// Law, `K_d`, `B_d`, `M_d` (the source may override `K_d`, `B_d`) and options.
    pub controller: ImpedanceController<S, M>,
    /// Velocity and acceleration filters (sample period = impedance period).
    pub estimator: EstimatorSettings<S>,
    /// Joint angles at the initial counter readings.
    pub zero_offset: [S; N],
    /// Counter readings at start-up.
    pub initial_counts: [i32; N],
    /// Force-sensor calibration.
    pub force_calibration: ForceSensorCalibration<S, M>,
    /// Each motor's current-loop gains, in the order of `q` ([`RigModel::current_loop_gains`]:
    /// designed per joint from the model's motor, rates and filter).
    pub current_gains: [CurrentLoopGains<S>; N],
    /// Impedance periods allowed between ticks before the watchdog trips.
    pub max_tick_gap: u32,
}

impl<S: Real, const N: usize, const M: usize> HapticLoopSettings<S, N, M> {
    /// Everything the rig determines, in one call: the estimator at the rig's impedance rate
    /// ([`EstimatorSettings::at_rate`]: 50 Hz velocity and 20 Hz acceleration filters), the
    /// joints' start pose in the middle of each joint's limits (as `hapticgen simulate` starts),
    /// counters reading zero there, each motor's own current-loop gains
    /// ([`RigModel::current_loop_gains`]), an identity force calibration (`f = reading`) and a
    /// watchdog that trips when one impedance tick is skipped.
    ///
    /// Change the fields that differ on your rig afterwards — the start pose (`zero_offset`,
    /// `initial_counts`: where the device is homed) and the force sensor's calibration:
    ///
    /// ```
    /// hapticgen_macros::rig!(mod arm = "../models/planar_arm_2dof.yaml", variant = "horizontal");
    /// use arm::PlanarArm2dof;
    /// use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw};
    /// use hapticgen_runtime::tick::HapticLoopSettings;
    ///
    /// let rig = PlanarArm2dof::NOMINAL;
    /// let controller = ImpedanceController::new(ImpedanceLaw::JacobianTranspose, [200.0; 2], [5.0; 2], [0.2; 2]);
    /// let mut settings = HapticLoopSettings::for_rig(&rig, controller);
    /// assert_eq!(settings.estimator.sample_period, 1e-3); // the model's 1 kHz impedance loop
    /// settings.zero_offset = [0.5, 1.2]; // homed at q = (0.5, 1.2) rad
    /// ```
    pub fn for_rig<R: RigModel<N, M, Scalar = S>>(rig: &R, controller: ImpedanceController<S, M>) -> Self {
        let drives = rig.drives();
        let half = S::from_f64(0.5);
        let mut zero_offset = [S::ZERO; N];
        for (q, drive) in zero_offset.iter_mut().zip(drives.iter()) {
            *q = (drive.position_lower + drive.position_upper) * half;
        }
        Self {
            controller,
            estimator: EstimatorSettings::at_rate(R::IMPEDANCE_LOOP_HZ),
            zero_offset,
            initial_counts: [0; N],
            force_calibration: ForceSensorCalibration { scale: [S::ONE; M], offset: [S::ZERO; M] },
            current_gains: rig.current_loop_gains(),
            max_tick_gap: 1,
        }
    }
}

/// All run-time state of one rig's controller.
///
/// Laid out in the order written (`repr(C)`), the current loop's state first and the reference
/// source last: the source (a renderer with its objects, hundreds of bytes) would otherwise sit
/// between the start of the state and the fields the 7.5 kHz current-loop tick reads, beyond
/// the reach of a Cortex-M4F's `vldr` offset (1,020 bytes), and every such load takes an extra
/// address computation (22 instructions a tick on the Delta's scene images).
#[repr(C)]
pub struct HapticLoop<R, Source, const N: usize, const M: usize>
where
    R: RigModel<N, M>,
{
    scheduler: Scheduler,
    /// Current ticks since an impedance tick became due without running
    /// ([`NO_IMPEDANCE_PENDING`]: none pending).
    pending_impedance: u32,
    /// Current ticks a due impedance tick may wait before `MissedTicks` is latched.
    impedance_grace: u32,
    safety: SafetyMonitor<R::Scalar, N>,
    current_loops: CurrentLoopBank<R::Scalar, N>,
    current_setpoints: [R::Scalar; N],
    /// Back-EMF feedforward of each current loop, `k_t N ȧ` (volts), from the last tick.
    back_emf_volts: [R::Scalar; N],
    /// `k_t N` of each drive (V·s/rad at its output; at the joint for an uncoupled rig).
    back_emf_constants: [R::Scalar; N],
    /// The impedance controller in use (its law may be switched at run time).
    pub controller: ImpedanceController<R::Scalar, M>,
    estimator: JointStateEstimator<R::Scalar, N>,
    force_calibration: ForceSensorCalibration<R::Scalar, M>,
    rig: R,
    /// Reference source (renderer or fixed reference).
    pub source: Source,
}

impl<R, Source, const N: usize, const M: usize> HapticLoop<R, Source, N, M>
where
    R: RigModel<N, M>,
    Source: ReferenceSource<R::Scalar, M>,
{
    /// Builds the loop; `None` if the rig's loop rates are unusable
    /// (`0 < IMPEDANCE_LOOP_HZ <= CURRENT_LOOP_HZ` is required).
    pub fn new(rig: R, source: Source, settings: &HapticLoopSettings<R::Scalar, N, M>) -> Option<Self> {
        let drives = rig.drives();
        let mut back_emf_constants = [R::Scalar::ZERO; N];
        for (k, drive) in back_emf_constants.iter_mut().zip(drives.iter()) {
            *k = drive.torque_constant * drive.gear_ratio;
        }
        // The estimator counts each drive's output; the homing pose is given in joints.
        let drive_zero_offset = match &rig.coupling() {
            Some(coupling) => linalg::mat_vec(&coupling.drive_from_joint, &settings.zero_offset),
            None => settings.zero_offset,
        };
        let drives = rig.drives();
        let mut supply = [R::Scalar::ZERO; N];
        for (slot, drive) in supply.iter_mut().zip(drives.iter()) {
            *slot = drive.supply_voltage;
        }
        Some(Self {
            scheduler: Scheduler::new(R::CURRENT_LOOP_HZ, R::IMPEDANCE_LOOP_HZ)?,
            estimator: JointStateEstimator::new(
                &drives,
                &settings.estimator,
                drive_zero_offset,
                settings.initial_counts,
            ),
            safety: SafetyMonitor::new(&drives, settings.max_tick_gap),
            current_loops: CurrentLoopBank::with_gains(&settings.current_gains, &supply),
            force_calibration: settings.force_calibration,
            controller: settings.controller,
            current_setpoints: [R::Scalar::ZERO; N],
            back_emf_volts: [R::Scalar::ZERO; N],
            back_emf_constants,
            pending_impedance: NO_IMPEDANCE_PENDING,
            // Half an impedance period (rounded up) in current ticks: 4 at 7.5 kHz / 1 kHz.
            impedance_grace: (R::CURRENT_LOOP_HZ / R::IMPEDANCE_LOOP_HZ.max(1) + 1) / 2 + 1,
            rig,
            source,
        })
    }

    /// Replaces the motors' current-loop gains while running (the loop starts with
    /// `HapticLoopSettings::current_gains`). Integrals and supply limits are kept.
    pub fn set_current_loop_gains(&mut self, gains: &[CurrentLoopGains<R::Scalar>; N]) {
        self.current_loops.set_gains(gains);
    }

    /// The safety monitor (latched fault, limits).
    pub fn safety(&self) -> &SafetyMonitor<R::Scalar, N> {
        &self.safety
    }

    /// Sets the loop margin below which the tick latches `FaultCode::LoopSingular`
    /// ([`SafetyMonitor::set_min_loop_margin`]; closed chains only, see
    /// [`RigModel::loop_margin`]).
    pub fn set_min_loop_margin(&mut self, margin: R::Scalar) {
        self.safety.set_min_loop_margin(margin);
    }

    /// Clears a latched fault and the current loops' integrators.
    pub fn reset_fault(&mut self) {
        self.safety.reset();
        self.current_loops.reset();
        self.estimator.resynchronize();
        self.pending_impedance = NO_IMPEDANCE_PENDING;
    }

    /// The state estimator: of the joints, or of the drives' outputs `a = C q` for a rig with
    /// a [`RigModel::coupling`] (see [`HapticLoop::joint_state`]).
    pub fn estimator(&self) -> &JointStateEstimator<R::Scalar, N> {
        &self.estimator
    }

    /// The joints' last estimate: the estimator's, mapped from the drives' outputs by `C⁻¹`
    /// for a rig with a [`RigModel::coupling`].
    pub fn joint_state(&self) -> JointState<R::Scalar, N> {
        // The rig's coupling is read where it is used, not stored: a generated rig's is a
        // constant or the default `None`, so an uncoupled rig pays neither a branch nor a copy.
        let drive_state = *self.estimator.state();
        match &self.rig.coupling() {
            Some(coupling) => JointState {
                position: linalg::mat_vec(&coupling.joint_from_drive, &drive_state.position),
                velocity: linalg::mat_vec(&coupling.joint_from_drive, &drive_state.velocity),
                acceleration: linalg::mat_vec(&coupling.joint_from_drive, &drive_state.acceleration),
            },
            None => drive_state,
        }
    }

    /// The current setpoints the current loops track, A.
    pub fn current_setpoints(&self) -> &[R::Scalar; N] {
        &self.current_setpoints
    }

    /// One impedance tick with the runtime's generic law (`ImpedanceController::torque`):
    /// encoders → state → rig terms → reference → law → safety → current setpoints.
    pub fn impedance_tick(
        &mut self,
        inputs: &ImpedanceInputs<R::Scalar, N, M>,
    ) -> ImpedanceReport<R::Scalar, N> {
        let (state, estimation_status) = self.estimate(inputs);
        let terms = self.rig.terms(&state.position, &state.velocity);
        let sensed = self.sensed(inputs, &state, &terms.jacobian, &terms.jacobian_dot_times_qdot);
        let reference = self.source.update_reference(&terms.position, &mut self.controller.parameters);
        let output = self.controller.torque(&self.rig, &terms, &state.velocity, &reference, &sensed);
        self.finish(output, estimation_status)
    }

    /// An impedance tick with a joint-space law instead of the impedance controller: the
    /// same watchdog, estimation, loop check and safety rules, with the torque the caller's
    /// `law` computes from the rig, its terms at the estimated state and that state (e.g.
    /// [`crate::excitation::JointTracking::torque`] playing an identification excitation).
    /// A `None` from the law, or a non-finite torque, latches
    /// [`FaultCode::NonFiniteTorque`] as the impedance laws' would.
    pub fn joint_tick<F>(
        &mut self,
        inputs: &ImpedanceInputs<R::Scalar, N, M>,
        law: F,
    ) -> ImpedanceReport<R::Scalar, N>
    where
        F: FnOnce(&R, &crate::RigTerms<R::Scalar, N, M>, &JointState<R::Scalar, N>) -> Option<[R::Scalar; N]>,
    {
        let (state, estimation_status) = self.estimate(inputs);
        let terms = self.rig.terms(&state.position, &state.velocity);
        let output = match law(&self.rig, &terms, &state) {
            Some(torque) if torque.iter().all(|t| t.is_finite()) => {
                ControlOutput { torque, status: ControlStatus::Ok }
            }
            _ => ControlOutput { torque: [R::Scalar::ZERO; N], status: ControlStatus::NonFiniteResult },
        };
        self.finish(output, estimation_status)
    }

    /// Watchdog, estimation and the loops' singularity check: the first step of every
    /// impedance tick. The joint state, mapped from the drives' by `C⁻¹` for a coupled rig.
    fn estimate(
        &mut self,
        inputs: &ImpedanceInputs<R::Scalar, N, M>,
    ) -> (JointState<R::Scalar, N>, EstimationStatus) {
        self.pending_impedance = NO_IMPEDANCE_PENDING;
        self.safety.check_tick(inputs.tick);
        let estimation_status = self.estimator.update(&inputs.encoder_counts);
        match estimation_status {
            EstimationStatus::Ok => {}
            EstimationStatus::NonFinite => self.safety.latch(FaultCode::NonFiniteInput),
            EstimationStatus::Implausible => self.safety.latch(FaultCode::SensorImplausible),
        }
        let state = self.joint_state();
        if R::HAS_LOOPS {
            self.safety.check_loop_margin(self.rig.loop_margin(&state.position));
        }
        (state, estimation_status)
    }

    /// The task-space signals the selected law reads: the calibrated force (Controller 1) or
    /// the acceleration estimate `ẍ = J q̈ + J̇ q̇` of eq. (2) (first variant of Controller 2).
    fn sensed(
        &mut self,
        inputs: &ImpedanceInputs<R::Scalar, N, M>,
        state: &JointState<R::Scalar, N>,
        jacobian: &[[R::Scalar; N]; M],
        jacobian_dot_times_qdot: &[R::Scalar; M],
    ) -> TaskSensing<R::Scalar, M> {
        let mut sensed = TaskSensing::default();
        match self.controller.law {
            ImpedanceLaw::ForceFeedback => {
                let (force, status) = self.force_calibration.force(&inputs.force_readings);
                if status != EstimationStatus::Ok {
                    self.safety.latch(FaultCode::NonFiniteInput);
                }
                sensed.operator_force = force;
            }
            ImpedanceLaw::AccelerationFeedback => {
                let accel = linalg::mat_vec(jacobian, &state.acceleration);
                for ((slot, &a), &bias) in
                    sensed.acceleration.iter_mut().zip(accel.iter()).zip(jacobian_dot_times_qdot.iter())
                {
                    *slot = a + bias;
                }
            }
            ImpedanceLaw::NaturalInertia | ImpedanceLaw::JacobianTranspose => {}
        }
        sensed
    }

    /// Safety rules and current setpoints: the last step of every impedance tick.
    fn finish(
        &mut self,
        output: ControlOutput<R::Scalar, N>,
        estimation_status: EstimationStatus,
    ) -> ImpedanceReport<R::Scalar, N> {
        match output.status {
            ControlStatus::Ok | ControlStatus::SingularFallback => {}
            ControlStatus::NonFiniteInput => self.safety.latch(FaultCode::NonFiniteInput),
            ControlStatus::NonFiniteResult => self.safety.latch(FaultCode::NonFiniteTorque),
            ControlStatus::NonSquareTask
            | ControlStatus::InertiaNotPositiveDefinite
            | ControlStatus::InvalidParameters => self.safety.latch(FaultCode::ControlRefused),
        }
        // A coupled rig's limits hold per drive: `τ_a = C⁻ᵀ τ`, limited, and the joints then get
        // `Cᵀ τ_a` (the torques the limited currents make).
        let command = match self.rig.coupling() {
            Some(coupling) => {
                let drive_torque = linalg::transpose_mul_vec(&coupling.joint_from_drive, &output.torque);
                let mut command = self.safety.limit(&drive_torque);
                command.torque = linalg::transpose_mul_vec(&coupling.drive_from_joint, &command.torque);
                command
            }
            None => self.safety.limit(&output.torque),
        };
        self.current_setpoints = command.current;
        // Each motor's back EMF follows its own output's velocity, which the estimator keeps
        // (the joints' for an uncoupled rig).
        let drive_velocity = self.estimator.state().velocity;
        for ((volts, &k), &velocity) in
            self.back_emf_volts.iter_mut().zip(self.back_emf_constants.iter()).zip(drive_velocity.iter())
        {
            *volts = if velocity.is_finite() { k * velocity } else { R::Scalar::ZERO };
        }
        if command.fault.is_some() {
            self.current_loops.reset();
            self.back_emf_volts = [R::Scalar::ZERO; N];
        }
        ImpedanceReport { command, control_status: output.status, estimation_status }
    }

    /// One current-loop tick with the measured (filtered) motor currents. Returns the
    /// armature voltages and whether the impedance tick is due now (the caller then runs
    /// [`HapticLoop::impedance_tick`], in the interrupt or in a lower-priority task).
    /// Zero volts while a fault is latched.
    pub fn current_tick(
        &mut self,
        measured_currents: &[R::Scalar; N],
    ) -> ([CurrentLoopOutput<R::Scalar>; N], bool) {
        let due = self.scheduler.tick();
        // Watchdog on the impedance task as seen from the current loop: a due impedance tick
        // that has not run within half an impedance period (the caller stalled or skipped it)
        // latches `MissedTicks`, so the motors stop within about 0.6 ms instead of driving the
        // last setpoint until the next impedance tick notices the gap.
        if self.pending_impedance != NO_IMPEDANCE_PENDING {
            self.pending_impedance += 1;
        } else if due {
            self.pending_impedance = 0;
        }
        if self.pending_impedance > self.impedance_grace
            && self.pending_impedance != NO_IMPEDANCE_PENDING
            && self.safety.fault().is_none()
        {
            self.safety.latch(FaultCode::MissedTicks);
            // The safe state, without waiting for an impedance tick: no current demanded.
            self.current_setpoints = [R::Scalar::ZERO; N];
            self.back_emf_volts = [R::Scalar::ZERO; N];
            self.current_loops.reset();
        }
        if self.safety.fault().is_some() {
            let off = CurrentLoopOutput { voltage: R::Scalar::ZERO, status: CurrentLoopStatus::Ok };
            return ([off; N], due);
        }
        (
            self.current_loops.step_with_feedforward(
                &self.current_setpoints,
                measured_currents,
                &self.back_emf_volts,
            ),
            due,
        )
    }
}

impl<R, Source, const N: usize, const M: usize> HapticLoop<R, Source, N, M>
where
    R: FusedImpedance<N, M>,
    Source: ReferenceSource<R::Scalar, M>,
{
    /// One impedance tick with the rig's fused, generated law ([`fused_torque`]): the same
    /// steps, checks and statuses as [`HapticLoop::impedance_tick`], but the law's arithmetic
    /// is the straight-line code codegen emitted for this rig, and only the terms the law
    /// needs are computed (Controller 3 reads `p(q)` for the reference and nothing else).
    pub fn impedance_tick_fused(
        &mut self,
        inputs: &ImpedanceInputs<R::Scalar, N, M>,
    ) -> ImpedanceReport<R::Scalar, N> {
        let (state, estimation_status) = self.estimate(inputs);
        let (position, sensed) = if self.controller.law == ImpedanceLaw::AccelerationFeedback {
            let terms = self.rig.terms(&state.position, &state.velocity);
            let sensed = self.sensed(inputs, &state, &terms.jacobian, &terms.jacobian_dot_times_qdot);
            (terms.position, sensed)
        } else {
            let no_jacobian = [[R::Scalar::ZERO; N]; M];
            let sensed = self.sensed(inputs, &state, &no_jacobian, &[R::Scalar::ZERO; M]);
            (self.rig.position(&state.position), sensed)
        };
        let reference = self.source.update_reference(&position, &mut self.controller.parameters);
        let output =
            fused_torque(&self.rig, &self.controller, &state.position, &state.velocity, &reference, &sensed);
        self.finish(output, estimation_status)
    }
}
