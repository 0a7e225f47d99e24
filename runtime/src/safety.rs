//! Safety rules around the torque of eq. (3): what the impedance loop may command and when it
//! must command nothing.
//!
//! * **Limits.** Each joint's torque is clamped to `±min(torque_limit, k·current_limit)`, with
//!   `k = N·η·k_t` the joint torque per motor ampere of its [`DriveTrain`]; the current
//!   setpoint is `τ/k`. Every clamp is reported in [`SafeCommand::clamped`], never silent.
//! * **Non-finite values.** NaN or infinity in any checked input or in the torque gives zero
//!   torque and latches [`FaultCode::NonFiniteInput`] / [`FaultCode::NonFiniteTorque`].
//! * **Watchdog.** The caller reports a tick counter that must advance by one per period;
//!   a gap of more than `max_tick_gap` periods (or a counter that does not advance) latches
//!   [`FaultCode::MissedTicks`] (or [`FaultCode::TickCounterStalled`]).
//! * **Refusals.** A control law that refuses (see `control::ControlStatus`) latches
//!   [`FaultCode::ControlRefused`].
//! * **Singular loops.** A closed chain's own loops become singular where the constraint
//!   Jacobian of its passive joints loses rank (the five-bar's distal links aligned): the
//!   reduced inertia `D` grows without bound there and no law can be trusted. Below
//!   [`SafetyMonitor::min_loop_margin`] of the rig's [`RigModel::loop_margin`](crate::RigModel::loop_margin)
//!   (the squared sine of the worst loop's angle, `1` for open chains) the tick latches
//!   [`FaultCode::LoopSingular`]: a haptic device's handle can be moved out by hand, then reset.
//! * **Near-singular configurations.** Controllers 1 and 2 need `J⁻¹` (eq. (4)); below
//!   `|det J| = min_abs_jacobian_determinant` they fall back to Controller 3 for that tick
//!   (implemented in `control`, reported as `ControlStatus::SingularFallback`, not latched):
//!   Controller 3 stays stable at the workspace boundary (paper, section 6.1), and latching
//!   would trap the operator at the boundary.
//!
//! A latched fault holds zero torque until an explicit [`SafetyMonitor::reset`]; the first
//! fault is kept (later ones do not overwrite it).

use crate::{DriveTrain, Real};

/// Why the monitor commands zero torque.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultCode {
    /// A sensor value, state or parameter was NaN or infinite.
    NonFiniteInput,
    /// The computed torque was NaN or infinite.
    NonFiniteTorque,
    /// More than the allowed number of periods passed between two ticks.
    MissedTicks,
    /// The tick counter did not advance (repeated or stuck tick).
    TickCounterStalled,
    /// The control law refused to compute a torque (non-square task, indefinite inertia, …).
    ControlRefused,
    /// A sensor reading was physically implausible (an encoder counter jumped).
    SensorImplausible,
    /// A closed chain's loop was at or near its singularity (see the module docs).
    LoopSingular,
}

impl FaultCode {
    /// The fault's number on the wire and in reports (`0` is kept for "no fault"): 1
    /// non-finite input, 2 non-finite torque, 3 missed ticks, 4 tick counter stalled, 5 control
    /// refused, 6 sensor implausible, 7 loop singular.
    pub const fn number(self) -> u8 {
        match self {
            FaultCode::NonFiniteInput => 1,
            FaultCode::NonFiniteTorque => 2,
            FaultCode::MissedTicks => 3,
            FaultCode::TickCounterStalled => 4,
            FaultCode::ControlRefused => 5,
            FaultCode::SensorImplausible => 6,
            FaultCode::LoopSingular => 7,
        }
    }
}

/// The default [`SafetyMonitor::min_loop_margin`]: a loop's squared sine of `10⁻³`, its links
/// within about 1.8° of aligned.
pub const DEFAULT_MIN_LOOP_MARGIN: f64 = 1e-3;

/// The torque and current setpoints the monitor lets through.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafeCommand<S, const N: usize> {
    /// Joint torques after limiting (zero while a fault is latched). For a rig with a
    /// [`crate::RigModel::coupling`], the [`SafetyMonitor`] limits the drives' output torques
    /// `τ_a = C⁻ᵀ τ` and the haptic loop reports the joint torques `Cᵀ τ_a` they make.
    pub torque: [S; N],
    /// Motor current setpoints `τ/(N·η·k_t)` (of `τ_a` for a coupled rig), A.
    pub current: [S; N],
    /// `true` for each joint (drive, for a coupled rig) whose torque was clamped this tick.
    pub clamped: [bool; N],
    /// The latched fault, if any.
    pub fault: Option<FaultCode>,
}

impl<S: Real, const N: usize> SafeCommand<S, N> {
    /// `true` when any joint was clamped.
    pub fn any_clamped(&self) -> bool {
        self.clamped.iter().any(|&c| c)
    }
}

/// Limits, watchdog and the latched fault of one rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyMonitor<S, const N: usize> {
    torque_limit: [S; N],
    torque_per_amp: [S; N],
    max_tick_gap: u32,
    last_tick: Option<u32>,
    fault: Option<FaultCode>,
    min_loop_margin: S,
}

impl<S: Real, const N: usize> SafetyMonitor<S, N> {
    /// Limits from the drive trains; `max_tick_gap` periods allowed between ticks (1 = no
    /// missed tick tolerated). A drive with non-finite or non-positive limits or torque
    /// constant gets a zero torque limit.
    pub fn new(drives: &[DriveTrain<S>; N], max_tick_gap: u32) -> Self {
        let mut torque_limit = [S::ZERO; N];
        let mut torque_per_amp = [S::ZERO; N];
        for ((limit, per_amp), drive) in
            torque_limit.iter_mut().zip(torque_per_amp.iter_mut()).zip(drives.iter())
        {
            let k = drive.gear_ratio * drive.efficiency * drive.torque_constant;
            let from_current = k * drive.current_limit;
            if k.is_finite() && k > S::ZERO && from_current.is_finite() && drive.torque_limit.is_finite() {
                *per_amp = k;
                let candidate = drive.torque_limit.min(from_current);
                *limit = if candidate.is_finite() && candidate > S::ZERO { candidate } else { S::ZERO };
            }
        }
        Self {
            torque_limit,
            torque_per_amp,
            max_tick_gap,
            last_tick: None,
            fault: None,
            min_loop_margin: S::from_f64(DEFAULT_MIN_LOOP_MARGIN),
        }
    }

    /// The loop margin below which [`SafetyMonitor::check_loop_margin`] latches
    /// [`FaultCode::LoopSingular`] ([`DEFAULT_MIN_LOOP_MARGIN`] unless set).
    pub fn min_loop_margin(&self) -> S {
        self.min_loop_margin
    }

    /// Sets the loop margin threshold; a NaN threshold makes every check fail (fault).
    pub fn set_min_loop_margin(&mut self, margin: S) {
        self.min_loop_margin = margin;
    }

    /// Latches [`FaultCode::LoopSingular`] unless `margin ≥ min_loop_margin` (a NaN margin, a
    /// loop that cannot close, fails).
    pub fn check_loop_margin(&mut self, margin: S) -> bool {
        // Written so that NaN on either side counts as singular.
        let safe = margin >= self.min_loop_margin;
        if !safe {
            self.latch(FaultCode::LoopSingular);
        }
        safe
    }

    /// The effective joint torque limits `min(torque_limit, N·η·k_t·current_limit)`.
    pub fn torque_limits(&self) -> &[S; N] {
        &self.torque_limit
    }

    /// The latched fault.
    pub fn fault(&self) -> Option<FaultCode> {
        self.fault
    }

    /// Latches `code` unless a fault is already latched.
    pub fn latch(&mut self, code: FaultCode) {
        if self.fault.is_none() {
            self.fault = Some(code);
        }
    }

    /// Clears the latched fault and restarts the watchdog (the next tick is accepted as is).
    pub fn reset(&mut self) {
        self.fault = None;
        self.last_tick = None;
    }

    /// Reports a tick; latches a watchdog fault if the counter jumped by more than
    /// `max_tick_gap` or did not advance. Wrap-around of the `u32` counter is fine.
    pub fn check_tick(&mut self, tick: u32) -> bool {
        if let Some(previous) = self.last_tick {
            let gap = tick.wrapping_sub(previous);
            if gap == 0 {
                self.latch(FaultCode::TickCounterStalled);
            } else if gap > self.max_tick_gap {
                self.latch(FaultCode::MissedTicks);
            }
        }
        self.last_tick = Some(tick);
        self.fault.is_none()
    }

    /// Latches [`FaultCode::NonFiniteInput`] if any value is NaN or infinite.
    pub fn check_finite(&mut self, values: &[S]) -> bool {
        let finite = values.iter().all(|v| v.is_finite());
        if !finite {
            self.latch(FaultCode::NonFiniteInput);
        }
        finite
    }

    /// Limits a torque command; zero torque and current while a fault is latched.
    pub fn limit(&mut self, torque: &[S; N]) -> SafeCommand<S, N> {
        if !torque.iter().all(|t| t.is_finite()) {
            self.latch(FaultCode::NonFiniteTorque);
        }
        let mut command = SafeCommand {
            torque: [S::ZERO; N],
            current: [S::ZERO; N],
            clamped: [false; N],
            fault: self.fault,
        };
        if self.fault.is_some() {
            return command;
        }
        for (i, &requested) in torque.iter().enumerate() {
            let limit = self.torque_limit[i];
            let per_amp = self.torque_per_amp[i];
            let limited = requested.clamp_to(-limit, limit);
            command.clamped[i] = limited != requested;
            command.torque[i] = limited;
            command.current[i] = if per_amp > S::ZERO { limited / per_amp } else { S::ZERO };
        }
        command
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive(torque_limit: f64, current_limit: f64) -> DriveTrain<f64> {
        DriveTrain {
            gear_ratio: 12.0,
            efficiency: 0.8,
            torque_constant: 0.0302,
            resistance: 0.299,
            inductance: 0.082e-3,
            rotor_inertia: 1.42e-5,
            torque_limit,
            current_limit,
            supply_voltage: 24.0,
            encoder_counts_per_turn: 2000,
            position_lower: -1.0,
            position_upper: 1.0,
        }
    }

    #[test]
    fn check_finite_passes_finite_values_and_latches_on_nan_or_infinity() {
        let mut monitor = SafetyMonitor::new(&[drive(3.0, 20.0)], 1);
        assert!(monitor.check_finite(&[1.0, -2.5, 0.0]));
        assert_eq!(monitor.fault(), None);
        assert!(!monitor.check_finite(&[1.0, f64::INFINITY]));
        assert_eq!(monitor.fault(), Some(FaultCode::NonFiniteInput));
        // Latched: finite values now pass the check, the fault stays until reset.
        assert!(monitor.check_finite(&[1.0]));
        assert_eq!(monitor.fault(), Some(FaultCode::NonFiniteInput));
        monitor.reset();
        assert!(!monitor.check_finite(&[f64::NAN]));
        assert_eq!(monitor.fault(), Some(FaultCode::NonFiniteInput));
    }

    /// A drive with no torque constant (zero, negative or NaN in its data) can exert nothing:
    /// its torque limit is zero, and so is the current commanded, never `0 / 0`. (A held-out
    /// survivor: `per_amp > 0` → `>=` divided the zero torque by the zero constant.)
    #[test]
    fn a_drive_without_a_torque_constant_gets_no_torque_and_no_current() {
        for constant in [0.0, -0.03, f64::NAN] {
            let dead = DriveTrain { torque_constant: constant, ..drive(3.0, 20.0) };
            let mut monitor = SafetyMonitor::new(&[dead, drive(3.0, 20.0)], 1);
            let command = monitor.limit(&[1.0, 1.0]);
            assert_eq!((command.torque[0], command.current[0]), (0.0, 0.0), "torque constant {constant}");
            assert_eq!(command.clamped, [true, false]);
            assert_eq!(command.fault, None);
        }
    }

    #[test]
    fn torque_is_clamped_to_torque_and_current_limits_and_reported() {
        // Joint 0: 3 N·m torque limit binds (current limit allows 12·0.8·0.0302·20 = 5.8 N·m).
        // Joint 1: current limit binds: 12·0.8·0.0302·5 = 1.4496 N·m < 3 N·m.
        let mut monitor = SafetyMonitor::new(&[drive(3.0, 20.0), drive(3.0, 5.0)], 1);
        let command = monitor.limit(&[-4.0, 2.0]);
        assert_eq!(command.torque[0], -3.0);
        assert!((command.torque[1] - 1.4496).abs() < 1e-12);
        assert_eq!(command.clamped, [true, true]);
        assert!(command.any_clamped());
        assert!((command.current[1] - 5.0).abs() < 1e-12);
        // One joint over its limit is enough.
        let command = monitor.limit(&[1.0, -2.0]);
        assert_eq!(command.clamped, [false, true]);
        assert!(command.any_clamped());
        let command = monitor.limit(&[1.0, -1.0]);
        assert_eq!(command.torque, [1.0, -1.0]);
        assert!(!command.any_clamped());
        assert!((command.current[0] - 1.0 / (12.0 * 0.8 * 0.0302)).abs() < 1e-12);
        assert_eq!(command.fault, None);
    }

    #[test]
    fn non_finite_torque_latches_until_reset() {
        let mut monitor = SafetyMonitor::new(&[drive(3.0, 20.0), drive(3.0, 20.0)], 1);
        let command = monitor.limit(&[f64::NAN, 1.0]);
        assert_eq!(command.torque, [0.0, 0.0]);
        assert_eq!(command.current, [0.0, 0.0]);
        assert_eq!(command.fault, Some(FaultCode::NonFiniteTorque));
        // Latched: a good torque is still refused.
        assert_eq!(monitor.limit(&[1.0, 1.0]).torque, [0.0, 0.0]);
        monitor.reset();
        assert_eq!(monitor.limit(&[1.0, 1.0]).torque, [1.0, 1.0]);
    }

    #[test]
    fn non_finite_input_latches_and_first_fault_is_kept() {
        let mut monitor = SafetyMonitor::new(&[drive(3.0, 20.0)], 1);
        assert!(monitor.check_finite(&[0.0, 1.0]));
        assert!(!monitor.check_finite(&[0.0, f64::INFINITY]));
        monitor.latch(FaultCode::MissedTicks);
        assert_eq!(monitor.fault(), Some(FaultCode::NonFiniteInput));
        assert_eq!(monitor.limit(&[1.0]).torque, [0.0]);
    }

    #[test]
    fn watchdog_latches_on_missed_and_stalled_ticks_and_handles_wrap() {
        let mut monitor = SafetyMonitor::new(&[drive(3.0, 20.0)], 2);
        assert!(monitor.check_tick(u32::MAX - 1));
        assert!(monitor.check_tick(u32::MAX));
        assert!(monitor.check_tick(1)); // wrapped, gap 2: allowed
        assert!(!monitor.check_tick(4)); // gap 3 > 2
        assert_eq!(monitor.fault(), Some(FaultCode::MissedTicks));
        assert_eq!(monitor.limit(&[1.0]).torque, [0.0]);
        monitor.reset();
        assert!(monitor.check_tick(100));
        assert!(!monitor.check_tick(100));
        assert_eq!(monitor.fault(), Some(FaultCode::TickCounterStalled));
        monitor.reset();
        assert!(monitor.check_tick(50)); // after reset any counter value is accepted
        assert!(!monitor.check_tick(40)); // backwards = huge wrapped gap
        assert_eq!(monitor.fault(), Some(FaultCode::MissedTicks));
    }

    #[test]
    fn broken_drive_data_gives_zero_limit() {
        let mut monitor = SafetyMonitor::new(&[drive(f64::NAN, 20.0), drive(3.0, -1.0)], 1);
        assert_eq!(monitor.torque_limits(), &[0.0, 0.0]);
        let command = monitor.limit(&[1.0, -1.0]);
        assert_eq!(command.torque, [0.0, 0.0]);
        assert_eq!(command.clamped, [true, true]);
    }

    #[test]
    fn loop_margin_below_the_threshold_latches_loop_singular() {
        let mut monitor = SafetyMonitor::<f64, 2>::new(&[drive(1.0, 10.0), drive(1.0, 10.0)], 1);
        assert_eq!(monitor.min_loop_margin(), DEFAULT_MIN_LOOP_MARGIN);
        assert!(monitor.check_loop_margin(DEFAULT_MIN_LOOP_MARGIN));
        assert!(monitor.check_loop_margin(0.5));
        assert_eq!(monitor.fault(), None);
        monitor.set_min_loop_margin(0.6);
        assert!(!monitor.check_loop_margin(0.5));
        assert_eq!(monitor.fault(), Some(FaultCode::LoopSingular));
        assert_eq!(monitor.limit(&[0.1, 0.1]).torque, [0.0, 0.0]);
        monitor.reset();
        assert!(!monitor.check_loop_margin(f64::NAN));
        monitor.reset();
        monitor.set_min_loop_margin(f64::NAN);
        assert!(!monitor.check_loop_margin(1.0), "a NaN threshold must fail safe");
        assert_eq!(FaultCode::LoopSingular.number(), 7);
        assert_eq!(FaultCode::NonFiniteInput.number(), 1);
    }
}
