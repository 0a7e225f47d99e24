//! The closed loop of the paper's Fig. 1 in simulation: the runtime's [`HapticLoop`]
//! (estimation → rig terms → rendering/reference → impedance law of eq. (3)–(13) → safety →
//! current setpoints, and the PI current loops of section 2) driving the [`Plant`], with an
//! operator model applying its force at the device's task point.
//!
//! Timing follows the firmware: the simulation advances one current-loop period
//! (`1/current_loop_hz`, 7.5 kHz) at a time — the operator's force is evaluated, the current
//! loop runs on the filtered measured currents, the impedance tick runs when the runtime's
//! `Scheduler` says it is due (1 kHz) on the encoder counts and force-sensor readings of that
//! instant, and the plant is integrated over the period (RK4, `substeps` steps) with the
//! armature voltages held. The operator's force is evaluated again at each substep, so that a
//! stiff hand on a light axis stays stable: `hapticgen simulate` chooses the substeps from the
//! hand and the rig's lightest axis (`Simulation::hand_substeps`; 1 for the paper's rigs, 25
//! for the differential wrist's 1.05e-5 kg·m² roll).
//!
//! **Signs.** The operator pushes the device with the force `f_op` (task space; N or N·m), a
//! joint torque `Jᵀ f_op`. In eq. (1) the operator's force `f_l` enters as `+Jᵀ f_l` on the
//! left-hand side, so `f_l = −f_op`: that is what the force sensors report to Controller 1,
//! and eq. (6) reads `M_d ẍ + B_d ẋ + K_d x̃ = f_op`. The trace's `f` columns are `f_op`.

use std::io::IsTerminal as _;
use std::sync::Arc;
use std::time::Instant;

use hapticgen_codegen::scene::{SceneEffect, SceneMotion};
use hapticgen_runtime::control::{
    ControlOptions, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
};
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::effects::Effect;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::linalg;
use hapticgen_runtime::motion::ObjectMotion;
use hapticgen_runtime::proxy::GodObject;
use hapticgen_runtime::render::{Scene, VirtualObject};
use hapticgen_runtime::schedule::Scheduler;
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs, ReferenceSource};
use hapticgen_runtime::{Coupling, DriveTrain, RigModel};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use crate::plant::{output_angle_at_counts, Effects, Plant};
use crate::rig::{CompiledModel, SimRig};
use crate::scene::SceneObject;
use crate::solids::ContactGeometry;

/// Encoder resolution used when quantisation is switched off, counts per motor turn.
pub const FINE_ENCODER_COUNTS: u32 = 1 << 22;

/// Capacity of the simulator's scenes (objects).
pub const SCENE_OBJECTS: usize = 4;
/// Capacity of the simulator's scenes (polygon vertices).
pub const SCENE_VERTICES: usize = 8;

/// A path in task space: positions at given times, linearly interpolated (held after the
/// last key).
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// `(time s, position)` keys in increasing time.
    pub keys: Vec<(f64, Vec<f64>)>,
}

impl Path {
    /// Position and velocity at time `t`.
    pub fn at(&self, t: f64) -> (Vec<f64>, Vec<f64>) {
        let keys = &self.keys;
        let Some(first) = keys.first() else {
            return (Vec::new(), Vec::new());
        };
        let zero = vec![0.0; first.1.len()];
        if t <= first.0 {
            return (first.1.clone(), zero);
        }
        for pair in keys.windows(2) {
            let (t0, p0) = &pair[0];
            let (t1, p1) = &pair[1];
            if t <= *t1 && t1 > t0 {
                let s = (t - t0) / (t1 - t0);
                let position = p0.iter().zip(p1).map(|(a, b)| a + s * (b - a)).collect();
                let velocity = p0.iter().zip(p1).map(|(a, b)| (b - a) / (t1 - t0)).collect();
                return (position, velocity);
            }
        }
        (keys[keys.len() - 1].1.clone(), zero)
    }
}

/// The operator (paper, section 6): what force acts on the device's task point.
#[derive(Clone, Debug, PartialEq)]
pub enum Operator {
    /// No hand on the device (free space, drift tests).
    Free,
    /// A pure force (torque for a joint-space task) step of `force`, from time `start`: the
    /// paper's 1 N·m step added through the current controller, i.e. an external torque.
    Step {
        /// The force after the step, task space.
        force: Vec<f64>,
        /// Time of the step, s.
        start: f64,
    },
    /// A hand holding the task point through a spring-damper whose other end follows `path`;
    /// a path outside a virtual object's boundary is a commanded push against it.
    Hand {
        /// Hand stiffness, N/m (N·m/rad).
        stiffness: f64,
        /// Hand damping, N·s/m.
        damping: f64,
        /// Where the hand goes.
        path: Path,
    },
}

impl Operator {
    /// The operator's force on the device at time `t`, task position `x` and velocity `v`.
    pub fn force(&self, t: f64, x: &[f64], v: &[f64]) -> Vec<f64> {
        match self {
            Operator::Free => vec![0.0; x.len()],
            Operator::Step { force, start } => {
                if t >= *start {
                    force.clone()
                } else {
                    vec![0.0; x.len()]
                }
            }
            Operator::Hand { stiffness, damping, path } => {
                let (target, target_velocity) = path.at(t);
                (0..x.len())
                    .map(|k| {
                        let p = target.get(k).copied().unwrap_or(x[k]);
                        let pv = target_velocity.get(k).copied().unwrap_or(0.0);
                        stiffness * (p - x[k]) + damping * (pv - v[k])
                    })
                    .collect()
            }
        }
    }
}

/// The impedance law's reference: a fixed `x_d`, a haptic scene (section 4; 2-D tasks), or
/// solids rendered by the runtime's god object (any task dimension).
#[derive(Clone, Debug)]
pub enum Reference {
    /// `x_d` at rest; `None` = the device's initial task position.
    Fixed(Option<Vec<f64>>),
    /// Virtual objects rendered with the proxy method and the anti-drift grid.
    Scene {
        /// The objects.
        objects: Vec<VirtualObject<f64, SCENE_VERTICES>>,
        /// Free-space `K_d`.
        free_stiffness: f64,
        /// Free-space `B_d`.
        free_damping: f64,
        /// Grid spacing, m (0 = pure collocation).
        grid_spacing: f64,
    },
    /// Solids rendered by [`GodObject`] (a point proxy that never enters them, with history);
    /// free space with the law's gains, or the scene's free-space effect.
    Solids {
        /// The solids: a scene file's objects or a contact scenario's.
        solids: Vec<SceneObject>,
        /// The free-space effect (`None`: none).
        effect: Option<SceneEffect>,
    },
}

/// The most solids a [`Reference::Solids`] scene holds (as many as a firmware scene, `SCENE_CAPACITY`).
pub const MAX_SOLIDS: usize = 8;

/// Everything one run needs besides the model.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// The impedance law.
    pub law: ImpedanceLaw,
    /// `K_d` (every task axis).
    pub stiffness: f64,
    /// `B_d`.
    pub damping: f64,
    /// `M_d` (Controller 1 and the first variant of Controller 2).
    pub mass: f64,
    /// Simulated time, s.
    pub duration: f64,
    /// Non-idealities.
    pub effects: Effects,
    /// Factor on the plant's body masses and inertias (the controller keeps the model's).
    pub plant_mass_scale: f64,
    /// The simulated device, if it is another model file than the controller's (`--plant`:
    /// the same joints and task, other masses and frictions; see
    /// [`crate::simulation::Simulation::device`]). Takes precedence over `plant_mass_scale`.
    pub plant_model: Option<Arc<CompiledModel>>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// The operator.
    pub operator: Operator,
    /// The reference.
    pub reference: Reference,
    /// Initial joint angles.
    pub initial_q: Vec<f64>,
    /// `|det J|` below which Controllers 1 and 2 fall back to Controller 3 (0 = never).
    pub singular_fallback: f64,
    /// Lead time of the spring term, s (`ControlOptions::spring_lead_time`; 0 = the paper's law).
    pub spring_lead_time: f64,
    /// The friction compensation's velocity band, rad/s (m/s): `Some(δ)` feeds the model's
    /// Coulomb friction forward (`ControlOptions::friction_compensation_band`); `None` (the
    /// paper's law) leaves it off.
    pub friction_compensation: Option<f64>,
    /// Velocity low-pass cut-off of the estimator, Hz.
    pub velocity_cutoff_hz: f64,
    /// Acceleration low-pass cut-off of the estimator, Hz.
    pub acceleration_cutoff_hz: f64,
    /// RK4 steps per current-loop period.
    pub substeps: usize,
    /// Trace rows per second.
    pub record_hz: f64,
    /// Show a progress bar on a terminal when the run takes over a second.
    pub progress: bool,
}

impl SimConfig {
    /// Defaults: Controller 3, `K_d = 1`, `B_d = 0.01`, `M_d = 0.01`, 5 s, every effect on,
    /// no operator, reference at the initial position.
    pub fn new(initial_q: Vec<f64>) -> SimConfig {
        SimConfig {
            law: ImpedanceLaw::JacobianTranspose,
            stiffness: 1.0,
            damping: 0.01,
            mass: 0.01,
            duration: 5.0,
            effects: Effects::ALL,
            plant_mass_scale: 1.0,
            plant_model: None,
            seed: 1,
            operator: Operator::Free,
            reference: Reference::Fixed(None),
            initial_q,
            singular_fallback: 0.0,
            spring_lead_time: 0.0,
            friction_compensation: None,
            velocity_cutoff_hz: 100.0,
            acceleration_cutoff_hz: 25.0,
            substeps: 1,
            record_hz: 1000.0,
            progress: false,
        }
    }
}

/// The model-level data a run needs (rates, current-loop gains, force sensors).
#[derive(Clone, Debug)]
pub struct LoopData {
    /// Current-loop rate, Hz.
    pub current_loop_hz: u32,
    /// Impedance-loop rate, Hz.
    pub impedance_loop_hz: u32,
    /// The PI current-loop gains of each joint, designed for its own motor.
    pub current_gains: Vec<CurrentLoopGains<f64>>,
    /// Time constant of the current-sense filter lag, s.
    pub filter_time_constant: f64,
    /// Force sensors, one per task axis (the last one repeated when there are fewer).
    pub sensors: Vec<SensorSpec>,
}

/// A force sensor's calibration and imperfections.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorSpec {
    /// Force per raw unit.
    pub scale: f64,
    /// Raw reading at zero force.
    pub offset: f64,
    /// Largest measurable magnitude.
    pub full_scale: f64,
    /// Noise standard deviation, force units.
    pub noise: f64,
    /// Quantisation step, force units.
    pub resolution: f64,
}

/// One simulated run: sampled signals and what the controller reported.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// Number of joints.
    pub joints: usize,
    /// Task dimension.
    pub task_dim: usize,
    /// Column names: `t`, `q*`, `qd*`, `x*`, `u*`, `f*`, `xp*` (the proxy), `xh*` (the HIP
    /// the proxy was rendered for: the task position as the controller measured it), `tr`
    /// (when the proxy was rendered, s; moving solids were where their motion had taken them
    /// then).
    pub columns: Vec<String>,
    /// Rows of samples.
    pub rows: Vec<Vec<f64>>,
    /// Impedance ticks run.
    pub impedance_ticks: usize,
    /// Impedance ticks with a joint torque clamped to its limit.
    pub clamped_ticks: usize,
    /// Impedance ticks where Controller 1 or 2 fell back to Controller 3 near a singularity.
    pub fallback_ticks: usize,
    /// Largest commanded joint torque magnitude (after limiting), N·m.
    pub peak_torque: f64,
    /// The first latched fault and when, if any.
    pub fault: Option<(f64, String)>,
    /// Wall-clock time of the run, s.
    pub wall_seconds: f64,
}

impl Trace {
    /// The task position's distance from the rendered reference (the `x` and `xp` columns)
    /// over the run: RMS and largest, in the task's units; `None` for an empty trace.
    pub fn rendering_error(&self) -> Option<(f64, f64)> {
        let columns = |prefix: &str| -> Option<Vec<Vec<f64>>> {
            (0..self.task_dim).map(|k| self.column(&format!("{prefix}{k}"))).collect()
        };
        let (position, reference) = (columns("x")?, columns("xp")?);
        let samples = position.first()?.len();
        if samples == 0 {
            return None;
        }
        let distances: Vec<f64> = (0..samples)
            .map(|i| {
                (0..self.task_dim).map(|k| (position[k][i] - reference[k][i]).powi(2)).sum::<f64>().sqrt()
            })
            .collect();
        let rms = (distances.iter().map(|d| d * d).sum::<f64>() / samples as f64).sqrt();
        Some((rms, distances.iter().copied().fold(0.0, f64::max)))
    }

    /// The samples of one column.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let index = self.columns.iter().position(|c| c == name)?;
        Some(self.rows.iter().map(|r| r[index]).collect())
    }

    /// Fraction of impedance ticks with a clamped torque.
    pub fn saturation_fraction(&self) -> f64 {
        if self.impedance_ticks == 0 {
            0.0
        } else {
            self.clamped_ticks as f64 / self.impedance_ticks as f64
        }
    }

    /// Simulated seconds.
    pub fn duration(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r[0])
    }
}

/// The contact scenarios' proxy tolerance, m: the god object stops a move shorter than this
/// (so a proxy may lag its goal by up to it) and holds the proxy this far outside a surface.
pub const PROXY_SKIN: f64 = 1e-6;

/// The reference source handed to the [`HapticLoop`]; remembers the last proxy for the trace.
pub struct SimSource<const M: usize> {
    fixed: Option<TaskReference<f64, M>>,
    scene: Option<Box<Scene<f64, SCENE_OBJECTS, SCENE_VERTICES>>>,
    god_object: Option<Box<GodObject<'static, f64, MAX_SOLIDS, M>>>,
    /// The god object's moving solids: slot and motion.
    motions: Vec<(usize, ObjectMotion<f64, M>)>,
    /// When the moving solids were last put where their motions take them, s.
    posed_at: f64,
    /// The simulated time of the current period, s (set by the controller before each tick).
    pub time: f64,
    /// When the last reference was rendered, s.
    pub rendered_at: f64,
    /// The first time the god object refused a solid's motion (not rigid: never for a motion
    /// read from a scene file), s.
    pub refused_motion_at: Option<f64>,
    /// The last reference position (proxy).
    pub last: [f64; M],
    /// The task position the last reference was rendered for (the HIP as the controller
    /// measured it).
    pub last_hip: [f64; M],
}

impl<const M: usize> SimSource<M> {
    /// A source of `reference` alone, the device at `hip`, before any tick.
    fn new(
        fixed: Option<TaskReference<f64, M>>,
        scene: Option<Box<Scene<f64, SCENE_OBJECTS, SCENE_VERTICES>>>,
        god_object: Option<Box<GodObject<'static, f64, MAX_SOLIDS, M>>>,
        reference: [f64; M],
        hip: [f64; M],
    ) -> Self {
        Self {
            fixed,
            scene,
            god_object,
            motions: Vec::new(),
            posed_at: 0.0,
            time: 0.0,
            rendered_at: 0.0,
            refused_motion_at: None,
            last: reference,
            last_hip: hip,
        }
    }

    /// Moves every moving solid from where it was at `posed_at` to where its motion has taken
    /// it at `time` (`ObjectMotion::between`: the runtime's, which a device moving its objects
    /// itself runs too; the simulator's checks take the solids where they are through the
    /// scene file's `SceneMotion`, written apart).
    fn pose_moving_solids(&mut self) {
        let (from, to) = (self.posed_at, self.time);
        if self.motions.is_empty() || to == from {
            return;
        }
        let Some(god_object) = self.god_object.as_mut() else { return };
        for (slot, motion) in &self.motions {
            if !god_object.move_object(*slot, &motion.between(from, to)) && self.refused_motion_at.is_none() {
                self.refused_motion_at = Some(to);
            }
        }
        self.posed_at = to;
    }
}

/// A scene file's motion as the runtime moves an object by it (coordinates beyond the file's
/// are zero; the file's vectors were checked against the task's dimension when it was read).
fn object_motion<const M: usize>(motion: &SceneMotion) -> ObjectMotion<f64, M> {
    let take =
        |values: &[f64]| -> [f64; M] { std::array::from_fn(|k| values.get(k).copied().unwrap_or(0.0)) };
    ObjectMotion {
        velocity: take(&motion.velocity),
        angular_velocity: std::array::from_fn(|k| motion.angular_velocity.get(k).copied().unwrap_or(0.0)),
        pivot: take(&motion.pivot),
    }
}

impl<const M: usize> ReferenceSource<f64, M> for SimSource<M> {
    fn update_reference(
        &mut self,
        task_position: &[f64; M],
        parameters: &mut ImpedanceParameters<f64, M>,
    ) -> TaskReference<f64, M> {
        self.last_hip = *task_position;
        self.rendered_at = self.time;
        self.pose_moving_solids();
        if let Some(god_object) = &mut self.god_object {
            let reference = god_object.update_reference(task_position, parameters);
            self.last = reference.position;
            return reference;
        }
        let reference = match (&mut self.scene, self.fixed) {
            (Some(scene), _) => {
                let hip = [task_position[0], task_position.get(1).copied().unwrap_or(0.0)];
                let out = scene.render(&hip);
                for k in 0..M.min(2) {
                    parameters.stiffness[k] = out.stiffness[k];
                    parameters.damping[k] = out.damping[k];
                }
                TaskReference::at_rest(std::array::from_fn(|k| out.proxy.get(k).copied().unwrap_or(0.0)))
            }
            (None, Some(fixed)) => fixed,
            (None, None) => TaskReference::at_rest(*task_position),
        };
        self.last = reference.position;
        reference
    }
}

/// A scene file's effect as the runtime's, updated every `period` seconds.
fn runtime_effect<const M: usize>(effect: &SceneEffect, period: f64) -> Result<Effect<f64, M>, String> {
    Ok(match effect {
        SceneEffect::Spring { anchor, stiffness } => {
            Effect::Spring { anchor: array(anchor, "the spring's anchor")?, stiffness: *stiffness }
        }
        SceneEffect::Viscous { damping } => Effect::Viscous { damping: *damping },
        SceneEffect::Force { force } => Effect::Force { force: array(force, "the force")? },
        SceneEffect::Vibration { direction, amplitude, frequency } => Effect::Vibration {
            direction: array(direction, "the vibration's direction")?,
            amplitude: *amplitude,
            frequency: *frequency,
            period,
        },
    })
}

/// A standard normal sample (Box–Muller).
pub(crate) fn gaussian(rng: &mut SmallRng) -> f64 {
    let u1: f64 = rng.gen::<f64>().max(1e-300);
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn array<const K: usize>(values: &[f64], name: &str) -> Result<[f64; K], String> {
    if values.len() != K {
        return Err(format!("error: {name} needs {K} values, got {}", values.len()));
    }
    Ok(std::array::from_fn(|k| values[k]))
}

/// What the device's controller is given in one current-loop period of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeriodSensors<const N: usize, const M: usize> {
    /// Motor currents as measured through the current-sense filter, A.
    pub measured_current: [f64; N],
    /// Encoder counters now.
    pub encoder_counts: [i32; N],
    /// Force-sensor readings (raw units), when the simulation's scheduler says an impedance
    /// tick is due this period.
    pub force_readings: Option<[f64; M]>,
    /// The simulated time at the start of the period, s.
    pub time: f64,
}

/// What one impedance tick of the device's controller did, for the trace.
#[derive(Clone, Debug, PartialEq)]
pub struct ImpedanceOutcome<const N: usize> {
    /// Commanded joint torques after the safety rules, N·m.
    pub torque: [f64; N],
    /// A torque was clamped to its limit.
    pub clamped: bool,
    /// Controller 1 or 2 fell back to Controller 3 near a singularity.
    pub fallback: bool,
    /// The latched fault, described, if there is one.
    pub fault: Option<String>,
}

/// What the device's controller commands in one current-loop period.
#[derive(Clone, Debug, PartialEq)]
pub struct PeriodCommand<const N: usize, const M: usize> {
    /// Armature voltages, held over the period, V.
    pub volts: [f64; N],
    /// Motor current setpoints (the plant's currents when its electrics are off), A.
    pub current_setpoints: [f64; N],
    /// The impedance tick's outcome, when one ran this period.
    pub impedance: Option<ImpedanceOutcome<N>>,
    /// The impedance law's reference position (the proxy) after this period.
    pub reference: [f64; M],
    /// The task position that reference was rendered for (the HIP the controller measured);
    /// NaN where the controller does not report it (the firmware under PIL).
    pub hip: [f64; M],
    /// When that reference was rendered, s (NaN where the controller does not report it).
    pub rendered_at: f64,
}

/// The controller in the closed loop of [`run_with`]: the runtime's [`HapticLoop`] on the host
/// ([`run`], `hapticgen simulate`), or the firmware on the emulated processor
/// (`hapticgen pil`, [`crate::pil`]).
pub trait DeviceController<const N: usize, const M: usize> {
    /// One current-loop period: the current loop on `sensors.measured_current`, and the
    /// impedance tick when `sensors.force_readings` is given.
    fn period(&mut self, sensors: &PeriodSensors<N, M>) -> Result<PeriodCommand<N, M>, String>;
}

/// The runtime's control cycle on the host, in `f64`.
pub struct LocalController<R, const N: usize, const M: usize>
where
    R: RigModel<N, M, Scalar = f64>,
{
    haptic: HapticLoop<SimRig<R, N>, SimSource<M>, N, M>,
    tick: u32,
}

impl<R, const N: usize, const M: usize> DeviceController<N, M> for LocalController<R, N, M>
where
    R: RigModel<N, M, Scalar = f64>,
{
    fn period(&mut self, sensors: &PeriodSensors<N, M>) -> Result<PeriodCommand<N, M>, String> {
        let haptic = &mut self.haptic;
        haptic.source.time = sensors.time;
        let (voltages, _) = haptic.current_tick(&sensors.measured_current);
        let impedance = sensors.force_readings.map(|readings| {
            self.tick = self.tick.wrapping_add(1);
            let inputs = ImpedanceInputs {
                encoder_counts: sensors.encoder_counts,
                force_readings: readings,
                tick: self.tick,
            };
            let report = haptic.impedance_tick(&inputs);
            ImpedanceOutcome {
                torque: report.command.torque,
                clamped: report.command.any_clamped(),
                fallback: report.control_status == ControlStatus::SingularFallback,
                fault: report
                    .command
                    .fault
                    .map(|fault| format!("{fault:?} (control {:?})", report.control_status)),
            }
        });
        Ok(PeriodCommand {
            volts: std::array::from_fn(|j| voltages[j].voltage),
            current_setpoints: *haptic.current_setpoints(),
            impedance,
            reference: haptic.source.last,
            hip: haptic.source.last_hip,
            rendered_at: haptic.source.rendered_at,
        })
    }
}

impl<const M: usize> SimSource<M> {
    /// The fixed reference position, if the reference is not a scene.
    pub fn fixed_position(&self) -> Option<[f64; M]> {
        if self.scene.is_some() || self.god_object.is_some() {
            return None;
        }
        Some(self.fixed.map_or(self.last, |r| r.position))
    }
}

/// Runs one simulation with `rig` as the controller's model and `plant_model` as the device.
pub fn run<R, const N: usize, const M: usize>(
    rig: R,
    plant_model: Arc<CompiledModel>,
    data: &LoopData,
    cfg: &SimConfig,
) -> Result<Trace, String>
where
    R: RigModel<N, M, Scalar = f64>,
{
    run_with(rig, plant_model, data, cfg, |rig, source, settings| {
        let haptic = HapticLoop::new(rig, source, settings)
            .ok_or_else(|| "error: unusable loop rates in the generated rig".to_string())?;
        Ok(LocalController { haptic, tick: 0 })
    })
    .and_then(|(trace, controller)| match controller.haptic.source.refused_motion_at {
        Some(time) => Err(format!("error: the renderer refused a moving solid's motion at t = {time:.4} s")),
        None => Ok(trace),
    })
}

/// Runs one simulation of `plant_model` with the controller `make` builds from the rig (with
/// the run's drive settings), the reference source and the loop settings that
/// [`run`] gives the runtime's [`HapticLoop`]: the plant, the operator, the sensors and the
/// trace are the same whichever controller closes the loop. Returns the trace and the
/// controller.
pub fn run_with<R, C, F, const N: usize, const M: usize>(
    rig: R,
    plant_model: Arc<CompiledModel>,
    data: &LoopData,
    cfg: &SimConfig,
    make: F,
) -> Result<(Trace, C), String>
where
    R: RigModel<N, M, Scalar = f64>,
    C: DeviceController<N, M>,
    F: FnOnce(SimRig<R, N>, SimSource<M>, &HapticLoopSettings<f64, N, M>) -> Result<C, String>,
{
    let effects = cfg.effects;
    let mut drives = rig.drives();
    for drive in drives.iter_mut() {
        if !effects.encoder_quantisation {
            drive.encoder_counts_per_turn = FINE_ENCODER_COUNTS;
        }
        if !effects.saturation {
            drive.torque_limit = 1e12;
            drive.current_limit = 1e12;
            drive.supply_voltage = 1e12;
        }
    }
    let rig = SimRig { inner: rig, drives };
    let q0: [f64; N] = array(&cfg.initial_q, "the initial joint angles")?;
    let counts_per_turn: [u32; N] = std::array::from_fn(|j| drives[j].encoder_counts_per_turn);
    let mut plant = Plant::<N, M>::new(plant_model, effects, q0, counts_per_turn, data.filter_time_constant)?;
    let initial_counts = plant.encoder_counts();
    let zero_offset = joint_angles_at_counts(&initial_counts, &drives, rig.coupling().as_ref());
    let start = plant.task();
    let source = match &cfg.reference {
        Reference::Fixed(position) => {
            let position = match position {
                Some(p) => array::<M>(p, "the reference position")?,
                None => start.position,
            };
            SimSource::new(Some(TaskReference::at_rest(position)), None, None, position, start.position)
        }
        Reference::Scene { objects, free_stiffness, free_damping, grid_spacing } => {
            if M != 2 {
                return Err(format!(
                    "error: virtual objects need a 2-D task space; this model's task has {M} coordinates"
                ));
            }
            let mut scene = Box::new(Scene::new(*free_stiffness, *free_damping, *grid_spacing));
            for object in objects {
                scene.add(*object).ok_or_else(|| "error: too many virtual objects".to_string())?;
            }
            SimSource::new(None, Some(scene), None, start.position, start.position)
        }
        Reference::Solids { solids, effect } => {
            // A point proxy (radius 0) with a 1 µm contact tolerance (see `GodObject::new`).
            let mut god_object = Box::new(GodObject::new(cfg.stiffness, cfg.damping, 0.0, PROXY_SKIN));
            if let Some(effect) = effect {
                god_object.effect = runtime_effect::<M>(effect, 1.0 / f64::from(data.impedance_loop_hz))?;
            }
            let mut motions = Vec::new();
            for solid in solids {
                let slot = god_object.add(solid.runtime_object::<M>()?).ok_or_else(|| {
                    format!("error: a scene holds at most {MAX_SOLIDS} solids, this one has {}", solids.len())
                })?;
                if let Some(motion) = &solid.motion {
                    motions.push((slot, object_motion::<M>(motion)));
                }
            }
            let mut source = SimSource::new(None, None, Some(god_object), start.position, start.position);
            source.motions = motions;
            source
        }
    };
    let sensors: [SensorSpec; M] = std::array::from_fn(|k| {
        data.sensors.get(k).or(data.sensors.last()).copied().unwrap_or(SensorSpec {
            scale: 1.0,
            offset: 0.0,
            full_scale: f64::INFINITY,
            noise: 0.0,
            resolution: 0.0,
        })
    });
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: cfg.law,
            parameters: ImpedanceParameters {
                stiffness: [cfg.stiffness; M],
                damping: [cfg.damping; M],
                mass: [cfg.mass; M],
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: cfg.singular_fallback,
                spring_lead_time: cfg.spring_lead_time,
                friction_compensation_band: cfg.friction_compensation,
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1.0 / f64::from(data.impedance_loop_hz),
            velocity_cutoff_hz: cfg.velocity_cutoff_hz,
            acceleration_cutoff_hz: cfg.acceleration_cutoff_hz,
        },
        zero_offset,
        initial_counts,
        force_calibration: ForceSensorCalibration {
            scale: std::array::from_fn(|k| sensors[k].scale),
            offset: std::array::from_fn(|k| sensors[k].offset),
        },
        current_gains: rig.current_loop_gains(),
        max_tick_gap: 1,
    };
    let mut reference = source.last;
    let mut hip = source.last_hip;
    let mut controller = make(rig, source, &settings)?;
    let mut scheduler = Scheduler::new(data.current_loop_hz, data.impedance_loop_hz).ok_or_else(|| {
        format!(
            "error: unusable loop rates: current loop {} Hz, impedance loop {} Hz",
            data.current_loop_hz, data.impedance_loop_hz
        )
    })?;
    let dt = 1.0 / f64::from(data.current_loop_hz);
    let substeps = cfg.substeps.max(1);
    let total = (cfg.duration / dt).round().max(0.0) as u64;
    let record_every = ((f64::from(data.current_loop_hz) / cfg.record_hz.max(1e-9)).round() as u64).max(1);
    let mut rng = SmallRng::seed_from_u64(cfg.seed);

    let mut trace = Trace { joints: N, task_dim: M, ..Trace::default() };
    trace.columns.push("t".into());
    for (prefix, count) in [("q", N), ("qd", N), ("x", M), ("u", N), ("f", M), ("xp", M), ("xh", M)] {
        trace.columns.extend((0..count).map(|k| format!("{prefix}{k}")));
    }
    trace.columns.push("tr".into());
    // The start's reference stands for one rendered at time 0.
    let mut rendered_at = 0.0;
    let mut torque = [0.0; N];
    let wall = Instant::now();
    let mut bar: Option<indicatif::ProgressBar> = None;
    let show_progress = cfg.progress && std::io::stderr().is_terminal();
    for k in 0..=total {
        let t = k as f64 * dt;
        let task = plant.task();
        let force = cfg.operator.force(t, &task.position, &task.velocity);
        let force: [f64; M] = std::array::from_fn(|i| force.get(i).copied().unwrap_or(0.0));
        if k % record_every == 0 {
            let s = &plant.state;
            let mut row = Vec::with_capacity(trace.columns.len());
            row.push(t);
            row.extend_from_slice(&s.q);
            row.extend_from_slice(&s.qd);
            row.extend_from_slice(&task.position);
            row.extend_from_slice(&torque);
            row.extend_from_slice(&force);
            row.extend_from_slice(&reference);
            row.extend_from_slice(&hip);
            row.push(rendered_at);
            trace.rows.push(row);
        }
        if k == total {
            break;
        }
        let readings = scheduler.tick().then(|| {
            std::array::from_fn(|i| {
                let spec = &sensors[i];
                let mut f_l = -force[i];
                if effects.sensor_noise {
                    f_l += spec.noise * gaussian(&mut rng);
                    if spec.resolution > 0.0 {
                        f_l = (f_l / spec.resolution).round() * spec.resolution;
                    }
                    if spec.full_scale > 0.0 {
                        f_l = f_l.clamp(-spec.full_scale, spec.full_scale);
                    }
                }
                spec.offset + f_l / spec.scale
            })
        });
        let command = controller.period(&PeriodSensors {
            measured_current: plant.state.measured_current,
            encoder_counts: plant.encoder_counts(),
            force_readings: readings,
            time: t,
        })?;
        if let Some(outcome) = command.impedance {
            trace.impedance_ticks += 1;
            if outcome.clamped {
                trace.clamped_ticks += 1;
            }
            if outcome.fallback {
                trace.fallback_ticks += 1;
            }
            if let (Some(fault), None) = (outcome.fault, &trace.fault) {
                trace.fault = Some((t, fault));
            }
            torque = outcome.torque;
            for u in torque {
                trace.peak_torque = trace.peak_torque.max(u.abs());
            }
        }
        reference = command.reference;
        hip = command.hip;
        rendered_at = command.rendered_at;
        let mut external = linalg::transpose_mul_vec(&task.jacobian, &force);
        let substep = dt / substeps as f64;
        for sub in 0..substeps {
            // With substeps, the operator's force follows the device within the period: a
            // stiff hand on a light axis, held over a whole period, would not be stable.
            if sub > 0 {
                let task = plant.task();
                let force = cfg.operator.force(t + sub as f64 * substep, &task.position, &task.velocity);
                let force: [f64; M] = std::array::from_fn(|i| force.get(i).copied().unwrap_or(0.0));
                external = linalg::transpose_mul_vec(&task.jacobian, &force);
            }
            plant.step(substep, &command.volts, &command.current_setpoints, &external);
        }
        if show_progress && k % 2000 == 0 {
            if bar.is_none() && wall.elapsed().as_secs_f64() > 1.0 {
                let b = indicatif::ProgressBar::new(total);
                b.set_style(
                    indicatif::ProgressStyle::with_template("{bar:40} {percent:>3}% simulated, eta {eta}")
                        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                bar = Some(b);
            }
            if let Some(b) = &bar {
                b.set_position(k);
            }
        }
        if !plant.state.q.iter().all(|v| v.is_finite()) {
            return Err(format!("error: the simulation diverged at t = {t:.4} s"));
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    trace.wall_seconds = wall.elapsed().as_secs_f64();
    Ok((trace, controller))
}

/// The joint angles a controller with `drives` (and a transmission's `coupling`) reads from
/// encoder `counts`: each drive's output angle `a` ([`output_angle_at_counts`]), and
/// the joints `q = C⁻¹ a`. Where the haptic loop is homed when it starts at those counts.
pub(crate) fn joint_angles_at_counts<const N: usize>(
    counts: &[i32; N],
    drives: &[DriveTrain<f64>; N],
    coupling: Option<&Coupling<f64, N>>,
) -> [f64; N] {
    let output_angle: [f64; N] = std::array::from_fn(|j| {
        output_angle_at_counts(counts[j], drives[j].encoder_counts_per_turn, drives[j].gear_ratio)
    });
    match coupling {
        Some(coupling) => linalg::mat_vec(&coupling.joint_from_drive, &output_angle),
        None => output_angle,
    }
}
