//! The plant model behind the simulated board: the rig's own terms (generated code) in
//!
//! ```text
//! D(q) q̈ = τ − C(q, q̇) q̇ − B q̇ − g(q) + Jᵀ f_op,     τ_j = N_j η_j k_t,j i_j
//! L di/dt = V − R i − k_t N q̇                        (per motor, back-EMF on the motor side)
//! ```
//!
//! stepped once per current-loop period `T`: the armature current exactly for a voltage and
//! back-EMF held over the period (`i ← a i + (1 − a)(V − e)/R`, `a = e^{−RT/L}`), then the
//! mechanics by semi-implicit Euler (`q̇ ← q̇ + T q̈`, `q ← q + T q̇`; the slowest mechanical
//! pole pair of the scenarios is below 20 Hz, so `ωT < 0.02`).
//!
//! Sensors as the firmware sees them: the current through a first-order lag standing for the
//! anti-aliasing Bessel filter (time constant = the filter's DC group delay, as the current
//! loop's designer models it) and a 12-bit ADC over ±20 A; the encoders as `floor` of the
//! motor-shaft angle in counts (quantisation); the force sensor reads `f_op` exactly.
//! End stops at the joint limits, on request ([`SimBoard::stop_at_limits`] after each
//! [`SimBoard::advance`]: the device image, whose plant hangs unpowered until the host enables
//! it): a joint past its limit is put back on it, its velocity into the stop lost (a hard,
//! inelastic stop). The self-contained images' scenarios stay within their limits and do not
//! call it (their code and runs are as before).
//! Not modelled: gear backlash, Coulomb/static friction, PWM ripple.

use hapticgen_fw_control::board::{CurrentSense, Encoders, ForceSense, VoltageOutput};
use hapticgen_runtime::linalg;
use hapticgen_runtime::{Coupling, DriveTrain, Real, RigModel};

/// Full scale of the simulated current ADC, A (±).
pub const ADC_FULL_SCALE_AMPS: f64 = 20.0;
/// Resolution of the simulated current ADC, bits.
pub const ADC_BITS: u32 = 12;

/// The rig, its motors and sensors, stepped once per current-loop period.
#[derive(Clone, Copy, Debug)]
pub struct SimBoard<R, const N: usize, const M: usize>
where
    R: RigModel<N, M>,
{
    rig: R,
    drives: [DriveTrain<R::Scalar>; N],
    damping: [R::Scalar; N],
    period: R::Scalar,
    /// Joint angles, rad.
    pub q: [R::Scalar; N],
    /// Joint velocities, rad/s.
    pub qd: [R::Scalar; N],
    /// Armature currents, A.
    pub current: [R::Scalar; N],
    filtered_current: [R::Scalar; N],
    volts: [R::Scalar; N],
    home: [R::Scalar; N],
    counts_per_radian: [R::Scalar; N],
    electrical_decay: [R::Scalar; N],
    sense_decay: R::Scalar,
    adc_step: R::Scalar,
    operator_force: [R::Scalar; M],
    /// The rig's transmission (`a = C q`): the motors turn, and are counted, at the drives'
    /// outputs; `None`: each drive turns its joint.
    coupling: Option<Coupling<R::Scalar, N>>,
    /// Set when `D` could not be factorised (the state then stops changing).
    pub broken: bool,
}

impl<R, const N: usize, const M: usize> SimBoard<R, N, M>
where
    R: RigModel<N, M>,
{
    /// The rig at rest at `q0` (also the encoders' home: counters read 0 there), stepped every
    /// `period` s, with the current sensed through a lag of `sense_time_constant` s.
    pub fn new(rig: R, q0: [R::Scalar; N], period: R::Scalar, sense_time_constant: R::Scalar) -> Self {
        let drives = rig.drives();
        let damping = rig.damping();
        let coupling = rig.coupling();
        let zero = R::Scalar::ZERO;
        let mut counts_per_radian = [zero; N];
        let mut electrical_decay = [zero; N];
        for j in 0..N {
            let d = &drives[j];
            counts_per_radian[j] = R::Scalar::from_f64(f64::from(d.encoder_counts_per_turn)) * d.gear_ratio
                / R::Scalar::from_f64(2.0 * core::f64::consts::PI);
            electrical_decay[j] =
                R::Scalar::from_f64(libm::exp(-(d.resistance * period / d.inductance).to_f64()));
        }
        let sense_decay = R::Scalar::from_f64(libm::exp(-(period / sense_time_constant).to_f64()));
        let adc_step = R::Scalar::from_f64(2.0 * ADC_FULL_SCALE_AMPS / f64::from(1u32 << ADC_BITS));
        Self {
            rig,
            drives,
            damping,
            period,
            q: q0,
            qd: [zero; N],
            current: [zero; N],
            filtered_current: [zero; N],
            volts: [zero; N],
            home: q0,
            counts_per_radian,
            electrical_decay,
            sense_decay,
            adc_step,
            operator_force: [zero; M],
            coupling,
            broken: false,
        }
    }

    /// End stops at each joint's limits (the drives' `position_lower`, `position_upper`),
    /// called after each [`SimBoard::advance`]: a joint past one is put back on it, its velocity
    /// into it lost, until it is driven or pushed away. Without them an unpowered arm sags
    /// through its limits under gravity (a real device rests on its stops). A separate call,
    /// not a setting of `advance`, so that the images that do not use it carry no code for it.
    pub fn stop_at_limits(&mut self) {
        for ((q, qd), drive) in self.q.iter_mut().zip(self.qd.iter_mut()).zip(self.drives.iter()) {
            if *q > drive.position_upper {
                *q = drive.position_upper;
                *qd = qd.min(R::Scalar::ZERO);
            } else if *q < drive.position_lower {
                *q = drive.position_lower;
                *qd = qd.max(R::Scalar::ZERO);
            }
        }
    }

    /// The rig model.
    pub fn rig(&self) -> &R {
        &self.rig
    }

    /// The drives' outputs `C x` for joint-side values `x` (travel, velocities); `x` itself
    /// without a transmission.
    fn drive_outputs(&self, joint_side: &[R::Scalar; N]) -> [R::Scalar; N] {
        match &self.coupling {
            Some(coupling) => linalg::mat_vec(&coupling.drive_from_joint, joint_side),
            None => *joint_side,
        }
    }

    /// The voltages last applied.
    pub fn volts(&self) -> &[R::Scalar; N] {
        &self.volts
    }

    /// Advances the plant by one period with the voltages last set and the operator force
    /// `force` (task space, applied through `Jᵀ`), held over the period.
    pub fn advance(&mut self, force: &[R::Scalar; M]) {
        if self.broken {
            return;
        }
        self.operator_force = *force;
        let one = R::Scalar::ONE;
        let terms = self.rig.terms(&self.q, &self.qd);
        let external = linalg::transpose_mul_vec(&terms.jacobian, force);
        let output_velocity = self.drive_outputs(&self.qd);
        let mut output_torque = [R::Scalar::ZERO; N];
        for j in 0..N {
            let d = &self.drives[j];
            let back_emf = d.torque_constant * d.gear_ratio * output_velocity[j];
            let a = self.electrical_decay[j];
            let i = a * self.current[j] + (one - a) * (self.volts[j] - back_emf) / d.resistance;
            self.current[j] = i;
            let c = self.sense_decay;
            self.filtered_current[j] = c * self.filtered_current[j] + (one - c) * i;
            output_torque[j] = d.gear_ratio * d.efficiency * d.torque_constant * i;
        }
        // The joints feel `Cᵀ τ_a` through a transmission.
        let torque = match &self.coupling {
            Some(coupling) => linalg::transpose_mul_vec(&coupling.drive_from_joint, &output_torque),
            None => output_torque,
        };
        let mut rhs = [R::Scalar::ZERO; N];
        for j in 0..N {
            rhs[j] =
                torque[j] - terms.coriolis_times_qdot[j] - self.damping[j] * self.qd[j] - terms.gravity[j]
                    + external[j];
        }
        match linalg::cholesky_solve(&terms.inertia_matrix, &rhs) {
            Ok(qdd) => {
                for j in 0..N {
                    self.qd[j] += self.period * qdd[j];
                    self.q[j] += self.period * self.qd[j];
                }
            }
            Err(_) => self.broken = true,
        }
    }
}

impl<R, const N: usize, const M: usize> Encoders<N> for SimBoard<R, N, M>
where
    R: RigModel<N, M>,
{
    fn counts(&mut self) -> [i32; N] {
        let mut travel = [R::Scalar::ZERO; N];
        for j in 0..N {
            travel[j] = self.q[j] - self.home[j];
        }
        let output_travel = self.drive_outputs(&travel);
        let mut counts = [0; N];
        for j in 0..N {
            let c = (output_travel[j] * self.counts_per_radian[j]).floor();
            counts[j] = c.to_f64() as i32;
        }
        counts
    }
}

impl<R, const N: usize, const M: usize> CurrentSense<R::Scalar, N> for SimBoard<R, N, M>
where
    R: RigModel<N, M>,
{
    fn currents(&mut self) -> [R::Scalar; N] {
        let mut sensed = [R::Scalar::ZERO; N];
        for j in 0..N {
            sensed[j] = (self.filtered_current[j] / self.adc_step).round() * self.adc_step;
        }
        sensed
    }
}

impl<R, const N: usize, const M: usize> ForceSense<R::Scalar, M> for SimBoard<R, N, M>
where
    R: RigModel<N, M>,
{
    fn force_readings(&mut self) -> [R::Scalar; M] {
        self.operator_force
    }
}

impl<R, const N: usize, const M: usize> VoltageOutput<R::Scalar, N> for SimBoard<R, N, M>
where
    R: RigModel<N, M>,
{
    fn set_voltages(&mut self, volts: &[R::Scalar; N]) {
        self.volts = *volts;
    }

    fn disable(&mut self) {
        self.volts = [R::Scalar::ZERO; N];
    }
}
