//! Excitation runs in simulation (`hapticgen simulate --scenario excite`): the device plays an
//! excitation trajectory with the runtime's joint-space tracking law
//! ([`hapticgen_runtime::excitation`], computed torque on the **model file's** dynamics), while
//! the simulated device ([`crate::plant`]) may be **another** model file (`--plant`): the
//! device's true masses and frictions, which the identification is to find. Every sensor
//! effect of the simulator stays on (encoder quantisation, the current loop through its
//! anti-aliasing filter, friction, backlash, saturation), and the log holds only what a device
//! measures ([`super::log`]).
//!
//! The same run under QEMU (`hapticgen pil --scenario excite`, [`PilExcitation`]): the rig's
//! firmware image plays the trajectory with the same law in `f32` (`PilLaw::Excitation`), the
//! host's plant and sensors are the simulator's, and the host logs what the device measured
//! (the encoder angles, the measured currents as joint torques) and the torques the firmware
//! commanded: the log `hapticgen identify` reads, from the firmware's control path.
//!
//! And on a device over the link (`hapticgen connect --excite`, [`DeviceSample`],
//! [`Simulation::device_log`]): the device plays the trajectory from where it is, its state
//! stream carries the encoder counts, the measured motor currents and the commanded torques of
//! every impedance tick, and the host turns them into the same log.

use std::sync::Arc;

use hapticgen_protocol::{ExcitationJoint, EXCITATION_HARMONICS};
use hapticgen_runtime::excitation::{JointReference, JointTracking};
use hapticgen_runtime::tick::{HapticLoop, ImpedanceInputs};
use hapticgen_runtime::{linalg, Coupling, DriveTrain, RigModel};

use super::log::IdentificationLog;
use super::trajectory::{Series, TrajectoryFile};
use crate::closed_loop::{
    self, DeviceController, ImpedanceOutcome, PeriodCommand, PeriodSensors, SimConfig, SimSource, Trace,
};
use crate::generated::RigVisitor;
use crate::pil::{Pil, PilPlay, PilReport};
use crate::rig::{CompiledModel, SimRig};
use crate::simulation::{PilTarget, Simulation};

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
    meter: TorqueMeter<N>,
    /// What the run measured.
    pub log: IdentificationLog,
}

/// The joint torques a device's measured motor currents stand for: each drive's torque per
/// ampere `k_t N η`, then the rig's transmission, if any (`Cᵀ τ_a`).
struct TorqueMeter<const N: usize> {
    torque_per_amp: [f64; N],
    coupling: Option<Coupling<f64, N>>,
}

impl<const N: usize> TorqueMeter<N> {
    fn new(drives: &[DriveTrain<f64>; N], coupling: Option<Coupling<f64, N>>) -> Self {
        let torque_per_amp =
            std::array::from_fn(|k| drives[k].torque_constant * drives[k].gear_ratio * drives[k].efficiency);
        Self { torque_per_amp, coupling }
    }

    fn joint_torques(&self, measured_current: &[f64; N]) -> [f64; N] {
        let drive_torque: [f64; N] = std::array::from_fn(|k| self.torque_per_amp[k] * measured_current[k]);
        match &self.coupling {
            Some(coupling) => linalg::transpose_mul_vec(&coupling.drive_from_joint, &drive_torque),
            None => drive_torque,
        }
    }
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
            let measured = self.meter.joint_torques(&sensors.measured_current);
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
                let meter = TorqueMeter::new(&rig.drives(), rig.coupling());
                let haptic = HapticLoop::new(rig, source, settings)
                    .ok_or_else(|| "error: unusable loop rates in the generated rig".to_string())?;
                Ok(ExcitationController {
                    haptic,
                    series,
                    tracking: JointTracking::critically_damped(TRACKING_HZ),
                    tick: 0,
                    meter,
                    log: IdentificationLog::new(joints),
                })
            },
        )?;
        Ok((trace, controller.log))
    }
}

/// The firmware under QEMU playing an excitation, the host logging what the device measured
/// and the torques the firmware commanded (module documentation).
pub struct PilExcitation<const N: usize, const M: usize> {
    pil: Pil<N, M>,
    meter: TorqueMeter<N>,
    drives: [DriveTrain<f64>; N],
    coupling: Option<Coupling<f64, N>>,
    /// The joint angles at the start, and the counts there.
    zero_offset: [f64; N],
    initial_counts: [i32; N],
    /// What the run measured.
    pub log: IdentificationLog,
}

impl<const N: usize, const M: usize> PilExcitation<N, M> {
    /// The joint angles at `counts`: the start's angles plus the counts since, through the
    /// gears and the transmission (as the firmware's estimator computes them).
    fn joint_angles(&self, counts: &[i32; N]) -> [f64; N] {
        let moved: [i32; N] = std::array::from_fn(|j| counts[j].wrapping_sub(self.initial_counts[j]));
        let angles = closed_loop::joint_angles_at_counts(&moved, &self.drives, self.coupling.as_ref());
        std::array::from_fn(|j| self.zero_offset[j] + angles[j])
    }
}

impl<const N: usize, const M: usize> DeviceController<N, M> for PilExcitation<N, M> {
    fn period(&mut self, sensors: &PeriodSensors<N, M>) -> Result<PeriodCommand<N, M>, String> {
        let command = self.pil.period(sensors)?;
        if let Some(outcome) = &command.impedance {
            let q = self.joint_angles(&sensors.encoder_counts);
            let measured = self.meter.joint_torques(&sensors.measured_current);
            self.log.push(sensors.time, &q, &measured, &outcome.torque);
        }
        Ok(command)
    }
}

/// The trajectory as the link carries it: one message per joint. Refused: more harmonics than
/// a message holds, or a period that is not a whole number of impedance ticks (the firmware
/// wraps the series' time in whole ticks).
pub fn excitation_messages(
    series: &Series,
    joints: usize,
    impedance_loop_hz: u32,
    tracking_hz: f64,
) -> Result<Vec<ExcitationJoint>, String> {
    let trajectory = series;
    let ticks = trajectory.period * f64::from(impedance_loop_hz);
    if (ticks - ticks.round()).abs() > 1e-6 * ticks.max(1.0) || ticks < 1.0 {
        return Err(format!(
            "error: the trajectory's period of {} s is not a whole number of the firmware's impedance ticks              ({impedance_loop_hz} Hz); design it with such a period (hapticgen excite --period)",
            trajectory.period
        ));
    }
    if joints > trajectory.offset.len() || joints > hapticgen_protocol::MAX_JOINTS {
        return Err(format!("error: {joints} joints: more than a trajectory or the link carries"));
    }
    (0..joints)
        .map(|j| {
            let used = |row: &[f64]| row.iter().rposition(|&c| c != 0.0).map_or(0, |last| last + 1);
            let harmonics = used(&trajectory.sine[j]).max(used(&trajectory.cosine[j]));
            if harmonics > EXCITATION_HARMONICS {
                return Err(format!(
                    "error: the trajectory has {harmonics} harmonics on joint {j}; the link carries at most                      {EXCITATION_HARMONICS}"
                ));
            }
            let coefficients = |row: &[f64]| -> [f32; EXCITATION_HARMONICS] {
                std::array::from_fn(|k| row.get(k).map_or(0.0, |&c| c as f32))
            };
            Ok(ExcitationJoint {
                joint: u8::try_from(j).map_err(|_| "error: too many joints for the link".to_string())?,
                period: trajectory.period as f32,
                ramp: trajectory.ramp as f32,
                tracking_hz: tracking_hz as f32,
                offset: trajectory.offset[j] as f32,
                sine: coefficients(&trajectory.sine[j]),
                cosine: coefficients(&trajectory.cosine[j]),
            })
        })
        .collect()
}

/// One impedance tick of a device's state stream during an excitation (`hapticgen connect
/// --excite`), in the device's units.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceSample {
    /// Since the excitation's first tick, s (from the device's tick counter).
    pub time: f64,
    /// The encoders' counts (0 at the device's home pose).
    pub counts: Vec<i32>,
    /// The measured motor currents, A.
    pub currents: Vec<f64>,
    /// The commanded joint torques, N·m (N).
    pub torques: Vec<f64>,
}

struct DeviceLogVisitor<'a> {
    joints: Vec<String>,
    samples: &'a [DeviceSample],
    home: &'a [f64],
}

impl RigVisitor for DeviceLogVisitor<'_> {
    type Output = Result<IdentificationLog, String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        if self.home.len() != N {
            return Err(format!("error: a home pose of {} values for {N} joints", self.home.len()));
        }
        let (drives, coupling) = (rig.drives(), rig.coupling());
        let meter = TorqueMeter::new(&drives, coupling);
        let mut log = IdentificationLog::new(self.joints);
        for sample in self.samples {
            let array = |values: &[f64]| -> Result<[f64; N], String> {
                values
                    .try_into()
                    .map_err(|_| format!("error: a state frame of {} joints, not {N}", values.len()))
            };
            let counts: [i32; N] =
                sample.counts.as_slice().try_into().map_err(|_| {
                    format!("error: a state frame of {} joints, not {N}", sample.counts.len())
                })?;
            let angles = closed_loop::joint_angles_at_counts(&counts, &drives, coupling.as_ref());
            let q: [f64; N] = std::array::from_fn(|j| self.home[j] + angles[j]);
            let measured = meter.joint_torques(&array(&sample.currents)?);
            log.push(sample.time, &q, &measured, &array(&sample.torques)?);
        }
        Ok(log)
    }
}

struct ExcitePilVisitor<'a> {
    plant: Arc<CompiledModel>,
    simulation: &'a Simulation,
    cfg: &'a SimConfig,
    target: &'a PilTarget,
    messages: Vec<ExcitationJoint>,
}

impl RigVisitor for ExcitePilVisitor<'_> {
    type Output = Result<(Trace, IdentificationLog, PilReport), String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        let joints: Vec<String> = self.simulation.model.joints.iter().map(|j| j.name.clone()).collect();
        let target = self.target;
        let messages = &self.messages;
        let (trace, controller) = closed_loop::run_with::<R, PilExcitation<N, M>, _, N, M>(
            rig,
            self.plant,
            &self.simulation.data,
            self.cfg,
            |rig, _, settings| {
                let play = PilPlay::Excitation(messages);
                let pil = Pil::start(&target.qemu, &target.image, &target.name, &target.log, settings, play)?;
                Ok(PilExcitation {
                    pil,
                    meter: TorqueMeter::new(&rig.drives(), rig.coupling()),
                    drives: rig.drives(),
                    coupling: rig.coupling(),
                    zero_offset: settings.zero_offset,
                    initial_counts: settings.initial_counts,
                    log: IdentificationLog::new(joints),
                })
            },
        )?;
        let report = controller.pil.finish()?;
        Ok((trace, controller.log, report))
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
        let (plant, series, cfg) = self.excitation_run(trajectory, plant, cfg)?;
        self.dispatch(ExciteVisitor { plant, simulation: self, cfg: &cfg, series })
    }

    /// What both kinds of excitation run start from: the trajectory checked against the
    /// model, the simulated device, the series, and `cfg` starting at the series' start.
    fn excitation_run(
        &self,
        trajectory: &TrajectoryFile,
        plant: Option<&hapticgen_codegen::CheckedModel>,
        cfg: &SimConfig,
    ) -> Result<(Arc<CompiledModel>, Series, SimConfig), String> {
        trajectory.check(&self.model).map_err(|e| format!("error: the trajectory: {e}"))?;
        let plant = match plant {
            None => self.nominal.clone(),
            Some(device) => self.device(device)?,
        };
        let series = trajectory.series();
        let mut cfg = cfg.clone();
        cfg.initial_q = series.reference(0.0).position[..self.joints()].to_vec();
        Ok((plant, series, cfg))
    }

    /// The identification log of an excitation played on a device (`hapticgen connect
    /// --excite`): each sample's counts decoded into joint angles from `home` (the joint
    /// angles where the device's counts are 0) through the drives and the transmission, its
    /// measured currents into joint torques (`TorqueMeter`), its commanded torques as sent.
    pub fn device_log(&self, samples: &[DeviceSample], home: &[f64]) -> Result<IdentificationLog, String> {
        let joints = self.model.joints.iter().map(|j| j.name.clone()).collect();
        self.dispatch(DeviceLogVisitor { joints, samples, home })
    }

    /// [`Self::run_excitation`] with the rig's firmware image under QEMU as the controller
    /// ([`PilExcitation`]); also returns the image's report.
    pub fn run_pil_excitation(
        &self,
        trajectory: &TrajectoryFile,
        plant: Option<&hapticgen_codegen::CheckedModel>,
        cfg: &SimConfig,
        target: &PilTarget,
    ) -> Result<(Trace, IdentificationLog, PilReport), String> {
        let (plant, series, cfg) = self.excitation_run(trajectory, plant, cfg)?;
        let messages =
            excitation_messages(&series, self.joints(), self.model.rates.impedance_loop_hz, TRACKING_HZ)?;
        self.dispatch(ExcitePilVisitor { plant, simulation: self, cfg: &cfg, target, messages })
    }
}

/// Per joint, the largest distance of a log's angle from the trajectory's reference after the
/// blend (`ramp` s): how well a run tracked what it was asked to play.
pub fn tracking_errors(series: &Series, ramp: f64, log: &IdentificationLog, joints: usize) -> Vec<f64> {
    let mut worst = vec![0.0_f64; joints];
    for (t, q) in log.time.iter().zip(&log.q) {
        if *t >= ramp {
            let reference = series.reference(*t).position;
            for j in 0..joints {
                worst[j] = worst[j].max((reference[j] - q[j]).abs());
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(period: f64, harmonics: usize) -> Series {
        let mut series = Series {
            period,
            ramp: 1.0,
            offset: [0.0; super::super::trajectory::MAX_JOINTS],
            sine: [[0.0; super::super::trajectory::MAX_HARMONICS]; super::super::trajectory::MAX_JOINTS],
            cosine: [[0.0; super::super::trajectory::MAX_HARMONICS]; super::super::trajectory::MAX_JOINTS],
        };
        series.offset[1] = 0.25;
        for k in 0..harmonics {
            series.sine[1][k] = 0.1 / (k + 1) as f64;
            series.cosine[0][k] = -0.05;
        }
        series
    }

    /// One message per joint, carrying the series as `f32`; a period that is not a whole
    /// number of impedance ticks is refused, as the firmware would.
    #[test]
    fn an_excitation_goes_over_the_link_joint_by_joint() {
        let messages = excitation_messages(&series(2.0, 5), 2, 1000, 8.0).unwrap();
        assert_eq!(messages.len(), 2);
        assert_eq!((messages[1].joint, messages[1].offset, messages[1].sine[4]), (1, 0.25, 0.02));
        assert_eq!((messages[0].period, messages[0].ramp, messages[0].tracking_hz), (2.0, 1.0, 8.0));
        assert_eq!(messages[0].cosine[..5], [-0.05; 5]);
        assert_eq!(messages[0].cosine[5..], [0.0; EXCITATION_HARMONICS - 5]);
        let refused = excitation_messages(&series(2.0005, 5), 2, 1000, 8.0).unwrap_err();
        assert!(refused.contains("not a whole number of the firmware's impedance ticks"), "{refused}");
        assert!(excitation_messages(&series(2.0, 5), 7, 1000, 8.0).is_err());
    }

    /// A device's samples become the log `simulate --scenario excite` writes: counts decoded
    /// from the home pose through the gears (the parallel link: 12:1, 2,000 counts per turn of
    /// the motor), currents through `k_t N η`; a frame of the wrong size is an error.
    #[test]
    fn a_device_s_state_stream_becomes_an_identification_log() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let sim = Simulation::load(&root.join("models/parallel_link_2dof.yaml"), Some("horizontal")).unwrap();
        let home = [std::f64::consts::FRAC_PI_2, 0.0];
        let samples = vec![
            DeviceSample { time: 0.0, counts: vec![0, 0], currents: vec![0.0, 0.0], torques: vec![0.0, 0.0] },
            DeviceSample {
                time: 0.001,
                counts: vec![100, -50],
                currents: vec![1.0, -0.5],
                torques: vec![0.3, -0.2],
            },
        ];
        let log = sim.device_log(&samples, &home).unwrap();
        assert_eq!(log.joints.len(), 2);
        assert_eq!((log.time.clone(), log.q[0].clone()), (vec![0.0, 0.001], home.to_vec()));
        let per_count = std::f64::consts::TAU / (2000.0 * 12.0);
        assert!((log.q[1][0] - (home[0] + 100.0 * per_count)).abs() < 1e-12, "{:?}", log.q[1]);
        assert!((log.q[1][1] - (-50.0 * per_count)).abs() < 1e-12, "{:?}", log.q[1]);
        assert!((log.tau[1][0] - 30.2e-3 * 12.0).abs() < 1e-12, "{:?}", log.tau[1]);
        assert!((log.tau[1][1] + 0.5 * 30.2e-3 * 12.0).abs() < 1e-12, "{:?}", log.tau[1]);
        assert_eq!(log.tau_command[1], vec![0.3, -0.2]);
        let short = [DeviceSample { time: 0.0, counts: vec![0], currents: vec![0.0], torques: vec![0.0] }];
        assert!(sim.device_log(&short, &home).unwrap_err().contains("1 joints, not 2"));
    }
}
