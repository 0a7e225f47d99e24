//! Excitation runs in simulation (`hapticgen simulate --scenario excite`): the device plays an
//! excitation trajectory with the runtime's joint-space tracking law
//! ([`hapticgen_runtime::excitation`], computed torque on the **model file's** dynamics), while
//! the simulated device ([`crate::plant`]) may be **another** model file (`--plant`): the
//! device's true masses and frictions, which the identification is to find. Every sensor
//! effect of the simulator stays on (encoder quantisation, the current loop through its
//! anti-aliasing filter, friction, backlash, saturation), and the log holds only what a device
//! measures ([`super::log`]).

use std::sync::Arc;

use hapticgen_runtime::excitation::{JointReference, JointTracking};
use hapticgen_runtime::tick::{HapticLoop, ImpedanceInputs};
use hapticgen_runtime::{linalg, Coupling, RigModel};

use super::log::IdentificationLog;
use super::trajectory::{Series, TrajectoryFile};
use crate::closed_loop::{
    self, DeviceController, ImpedanceOutcome, PeriodCommand, PeriodSensors, SimConfig, SimSource, Trace,
};
use crate::generated::RigVisitor;
use crate::rig::{CompiledModel, SimRig};
use crate::simulation::Simulation;

/// The tracking bandwidth of excitation runs, Hz: critically damped error dynamics, well under
/// the 1 kHz impedance loop and its velocity filter.
pub const TRACKING_HZ: f64 = 8.0;

/// The runtime's loop playing an excitation, on the host.
pub struct ExcitationController<R, const N: usize, const M: usize>
where
    R: RigModel<N, M, Scalar = f64>,
{
    haptic: HapticLoop<SimRig<R, N>, SimSource<M>, N, M>,
    series: Series,
    tracking: JointTracking<f64, N>,
    tick: u32,
    /// Each drive's torque per ampere, `k_t N η`.
    torque_per_amp: [f64; N],
    /// The rig's transmission, if any (joint torques `Cᵀ τ_a`).
    coupling: Option<Coupling<f64, N>>,
    /// What the run measured.
    pub log: IdentificationLog,
}

impl<R, const N: usize, const M: usize> DeviceController<N, M> for ExcitationController<R, N, M>
where
    R: RigModel<N, M, Scalar = f64>,
{
    fn period(&mut self, sensors: &PeriodSensors<N, M>) -> Result<PeriodCommand<N, M>, String> {
        let haptic = &mut self.haptic;
        let (voltages, _) = haptic.current_tick(&sensors.measured_current);
        let mut impedance = None;
        if sensors.force_readings.is_some() {
            self.tick = self.tick.wrapping_add(1);
            let inputs = ImpedanceInputs {
                encoder_counts: sensors.encoder_counts,
                force_readings: [0.0; M],
                tick: self.tick,
            };
            let full = self.series.reference(sensors.time);
            let reference = JointReference::<f64, N> {
                position: std::array::from_fn(|j| full.position[j]),
                velocity: std::array::from_fn(|j| full.velocity[j]),
                acceleration: std::array::from_fn(|j| full.acceleration[j]),
            };
            let tracking = self.tracking;
            let report = haptic.joint_tick(&inputs, |rig, terms, state| {
                tracking.torque(rig, terms, &state.position, &state.velocity, &reference)
            });
            let drive_torque: [f64; N] =
                std::array::from_fn(|k| self.torque_per_amp[k] * sensors.measured_current[k]);
            let measured = match &self.coupling {
                Some(coupling) => linalg::transpose_mul_vec(&coupling.drive_from_joint, &drive_torque),
                None => drive_torque,
            };
            self.log.push(sensors.time, &haptic.joint_state().position, &measured, &report.command.torque);
            impedance = Some(ImpedanceOutcome {
                torque: report.command.torque,
                clamped: report.command.any_clamped(),
                fallback: false,
                fault: report.command.fault.map(|fault| format!("{fault:?}")),
            });
        }
        Ok(PeriodCommand {
            volts: std::array::from_fn(|j| voltages[j].voltage),
            current_setpoints: *haptic.current_setpoints(),
            impedance,
            reference: haptic.source.last,
            hip: haptic.source.last_hip,
            rendered_at: f64::NAN,
        })
    }
}

struct ExciteVisitor<'a> {
    plant: Arc<CompiledModel>,
    simulation: &'a Simulation,
    cfg: &'a SimConfig,
    series: Series,
}

impl RigVisitor for ExciteVisitor<'_> {
    type Output = Result<(Trace, IdentificationLog), String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        let joints: Vec<String> = self.simulation.model.joints.iter().map(|j| j.name.clone()).collect();
        let series = self.series;
        let (trace, controller) = closed_loop::run_with::<R, ExcitationController<R, N, M>, _, N, M>(
            rig,
            self.plant,
            &self.simulation.data,
            self.cfg,
            |rig, source, settings| {
                let drives = rig.drives();
                let torque_per_amp = std::array::from_fn(|k| {
                    drives[k].torque_constant * drives[k].gear_ratio * drives[k].efficiency
                });
                let coupling = rig.coupling();
                let haptic = HapticLoop::new(rig, source, settings)
                    .ok_or_else(|| "error: unusable loop rates in the generated rig".to_string())?;
                Ok(ExcitationController {
                    haptic,
                    series,
                    tracking: JointTracking::critically_damped(TRACKING_HZ),
                    tick: 0,
                    torque_per_amp,
                    coupling,
                    log: IdentificationLog::new(joints),
                })
            },
        )?;
        Ok((trace, controller.log))
    }
}

impl Simulation {
    /// Plays `trajectory` for `cfg.duration` on the device `plant` (the model's own mechanics
    /// when `None`; another model file's, with the same joints, for identification), the
    /// controller on this model; returns the trace and the identification log. `cfg`'s start
    /// pose is replaced by the trajectory's.
    pub fn run_excitation(
        &self,
        trajectory: &TrajectoryFile,
        plant: Option<&hapticgen_codegen::CheckedModel>,
        cfg: &SimConfig,
    ) -> Result<(Trace, IdentificationLog), String> {
        trajectory.check(&self.model).map_err(|e| format!("error: the trajectory: {e}"))?;
        let plant = match plant {
            None => self.nominal.clone(),
            Some(device) => self.device(device)?,
        };
        let series = trajectory.series();
        let n = self.joints();
        let start = series.reference(0.0).position[..n].to_vec();
        let mut cfg = cfg.clone();
        cfg.initial_q = start;
        self.dispatch(ExciteVisitor { plant, simulation: self, cfg: &cfg, series })
    }
}
