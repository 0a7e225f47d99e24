//! Loading a model for simulation, the named scenarios of `hapticgen simulate`, and the
//! dispatch from a run-time model to the const-generic closed loop of [`crate::closed_loop::run`].
//!
//! The controller's rig is the **generated code** compiled into this binary when the model
//! file generates exactly that code (the shipped `models/*.yaml`, see [`crate::generated`]),
//! else a [`TapeRig`] on the same derivation. The plant always runs on tapes, so that a
//! parameter mismatch ([`SimConfig::plant_mass_scale`]) can be applied to the plant only.

use std::path::Path;
use std::sync::Arc;

use hapticgen_codegen::check::current_loop::{
    design_current_loop, CurrentLoopDesign, CurrentLoopDesignInput,
};
use hapticgen_codegen::mesh::TriangleMesh;
use hapticgen_codegen::scene::SceneEffect;
use hapticgen_codegen::CheckedModel;
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::render::{ObjectKind, Shape, VirtualObject};
use hapticgen_runtime::RigModel;

use crate::closed_loop::SCENE_VERTICES;
use crate::closed_loop::{
    self, LoopData, Operator, Path as HandPath, Reference, SensorSpec, SimConfig, Trace,
};
use crate::contact::{Contact, ContactSettings, ContactSetup};
use crate::generated::{self, RigVisitor};
use crate::pil::{Pil, PilPlay, PilReport, PilScene};
use crate::rig::{CompiledModel, TapeRig};
use crate::tape::Tape;
use hapticgen_protocol::SceneObject;

/// A model ready to simulate.
pub struct Simulation {
    /// The validated model (variant applied).
    pub model: CheckedModel,
    /// Its mechanics, compiled.
    pub nominal: Arc<CompiledModel>,
    /// Index of the generated rig in [`generated::SHIPPED`] used as the controller's model.
    pub shipped: Option<usize>,
    /// Rates, current-loop gains and sensors.
    pub data: LoopData,
    /// The first joint's current-loop design (its delay and bandwidth are reported; the
    /// filter and the bandwidth target are the model's, common to all joints).
    pub design: CurrentLoopDesign,
}

/// Each joint's PI current loop designed for its own motor, as the generator designs the
/// `CURRENT_LOOP_GAINS` of the generated code (the motors of a rig may differ).
pub fn current_loop_designs(model: &CheckedModel) -> Result<Vec<CurrentLoopDesign>, String> {
    let spec = &model.current_loop;
    model
        .joints
        .iter()
        .map(|joint| {
            design_current_loop(&CurrentLoopDesignInput {
                resistance: joint.drive.motor.resistance,
                inductance: joint.drive.motor.inductance,
                sample_rate_hz: f64::from(model.rates.current_loop_hz),
                bandwidth_hz: spec.bandwidth_hz,
                damping_ratio: spec.damping_ratio,
                filter_cutoff_hz: spec.anti_alias_cutoff_hz,
                filter_order: spec.anti_alias_filter_order,
            })
            .map_err(|e| format!("error: {}: current_loop of joint `{}`: {e}", model.file, joint.name))
        })
        .collect()
}

impl Simulation {
    /// The delay of the sampled control loop seen by the spring term, s: half an impedance
    /// period (zero-order hold), one current-loop period (a new setpoint takes effect from the
    /// next current tick) and the current loop's mean delay. Used as the law's
    /// `spring_lead_time` to display the damping of eq. (6), (11), (13).
    pub fn sampled_loop_delay(&self) -> f64 {
        0.5 / f64::from(self.model.rates.impedance_loop_hz)
            + 1.0 / f64::from(self.model.rates.current_loop_hz)
            + self.design.mean_delay
    }

    /// The friction compensation's default velocity band, rad/s (m/s): the velocity of one
    /// encoder count per impedance period at the joint (the coarsest drive's), the smallest
    /// non-zero step of the estimator's backward difference. An estimate dithering by a count
    /// at rest stays inside it, where the compensation is a ramp, not `±F_c`.
    pub fn friction_compensation_band(&self) -> f64 {
        let rate = f64::from(self.model.rates.impedance_loop_hz);
        self.nominal.drives.iter().map(|d| d.count_size() * rate).fold(0.0, f64::max)
    }
}

/// The named scenarios of `hapticgen simulate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// A force/torque step on the first task axis (paper, Fig. 4–6).
    Step,
    /// A hand tracing a virtual circle from the inside, pushing outward (Fig. 7b).
    TraceCircle,
    /// A hand tracing a virtual square from the inside, pushing outward (Fig. 7a).
    TraceSquare,
    /// A hand dragging the task point onto the nearest singular configuration (section 6.1).
    Singularity,
    /// No operator force; free space with the anti-drift grid (section 4).
    FreeDrift,
    /// A hand pressing the task point onto solids rendered by the runtime's god object
    /// ([`crate::contact`]; the wall in any task dimension, the others in 3-D).
    Contact(Contact),
}

impl Scenario {
    /// Parses a scenario name.
    pub fn parse(name: &str) -> Option<Scenario> {
        Some(match name {
            "step" => Scenario::Step,
            "trace-circle" => Scenario::TraceCircle,
            "trace-square" => Scenario::TraceSquare,
            "singularity" => Scenario::Singularity,
            "free-drift" => Scenario::FreeDrift,
            "wall" => Scenario::Contact(Contact::Wall),
            "slide" => Scenario::Contact(Contact::Slide),
            "sphere" => Scenario::Contact(Contact::Sphere),
            "box-edges" => Scenario::Contact(Contact::BoxEdges),
            "thin-plate" => Scenario::Contact(Contact::ThinPlate),
            "mesh" => Scenario::Contact(Contact::Mesh),
            _ => return None,
        })
    }
}

/// Settings of the scenarios (defaults from [`ScenarioSettings::default`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioSettings {
    /// Step magnitude (N or N·m) and its time, s.
    pub step: (f64, f64),
    /// Circle radius / half side of the square, m.
    pub shape_size: f64,
    /// How far outside the boundary the hand's path runs (the commanded push), m.
    pub push_depth: f64,
    /// Hand stiffness, N/m, and damping, N·s/m.
    pub hand: (f64, f64),
    /// Time for one lap of the outline, s.
    pub lap_time: f64,
    /// Anti-drift grid spacing, m (`None`: the model's `rendering.grid_spacing`).
    pub grid_spacing: Option<f64>,
    /// Joint configuration the singularity scenario drags towards (`None`: the nearest
    /// configuration with `|det J|` under 2 % of its maximum).
    pub singular_target: Option<Vec<f64>>,
    /// How far beyond the singular configuration's task point the hand pulls (fraction of
    /// the distance from the start).
    pub singular_overshoot: f64,
    /// Joint configuration the scenario starts at (`None`: [`Simulation::home`], the middle
    /// of every joint's limits).
    pub start: Option<Vec<f64>>,
    /// Contact scenarios: static and dynamic friction coefficients of every surface.
    pub friction: (f64, f64),
    /// The `mesh` scenario's mesh (`None`: a UV sphere of radius 3 cm).
    pub mesh: Option<Arc<TriangleMesh>>,
    /// Contact scenarios: the solids to render instead of the scenario's own (a scene file's,
    /// [`crate::scene`]); the scenario still gives the hand's path.
    pub scene: Option<Vec<crate::scene::SceneObject>>,
    /// Contact scenarios: the scene file's free-space effect, if it names one.
    pub effect: Option<SceneEffect>,
}

impl Default for ScenarioSettings {
    fn default() -> Self {
        ScenarioSettings {
            step: (1.0, 0.2),
            shape_size: 0.02,
            push_depth: 0.01,
            hand: (200.0, 1.0),
            lap_time: 6.0,
            grid_spacing: None,
            singular_target: None,
            singular_overshoot: 0.3,
            start: None,
            friction: (0.0, 0.0),
            mesh: None,
            scene: None,
            effect: None,
        }
    }
}

struct RunVisitor<'a> {
    plant: Arc<CompiledModel>,
    data: &'a LoopData,
    cfg: &'a SimConfig,
}

impl RigVisitor for RunVisitor<'_> {
    type Output = Result<Trace, String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        closed_loop::run::<R, N, M>(rig, self.plant, self.data, self.cfg)
    }
}

/// Where a processor-in-the-loop run finds its firmware, and how it runs
/// ([`Simulation::run_pil`]).
#[derive(Clone, Debug)]
pub struct PilTarget {
    /// `qemu-system-arm`.
    pub qemu: std::path::PathBuf,
    /// The PIL image (`hapticgen-fw-qemu-pil` built for the rig's line of `variants.txt`).
    pub image: std::path::PathBuf,
    /// The image's name (its line of `variants.txt`).
    pub name: String,
    /// Where QEMU's output (the image's semihosting lines) goes.
    pub log: std::path::PathBuf,
    /// Stop sending sensor frames after this many current-loop periods (fault test).
    pub stop_after: Option<u64>,
    /// Send a corrupted copy before every this many sensor frames (fault test).
    pub corrupt_every: Option<u64>,
    /// Send a burst of random bytes before every this many sensor frames (fault test).
    pub garbage_every: Option<u64>,
}

struct PilVisitor<'a> {
    plant: Arc<CompiledModel>,
    data: &'a LoopData,
    cfg: &'a SimConfig,
    target: &'a PilTarget,
}

impl RigVisitor for PilVisitor<'_> {
    type Output = Result<(Trace, PilReport), String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        let target = self.target;
        let (trace, pil) = closed_loop::run_with::<R, Pil<N, M>, _, N, M>(
            rig,
            self.plant,
            self.data,
            self.cfg,
            |_, source, settings| {
                let scene = match &self.cfg.reference {
                    Reference::Fixed(_) => None,
                    Reference::Solids { .. } => {
                        return Err(
                            "error: the contact scenarios render with the host's god object, which the \
                                    firmware images do not run yet; run them without --pil"
                                .to_string(),
                        )
                    }
                    Reference::Scene { objects, free_stiffness, free_damping, grid_spacing } => {
                        Some(PilScene {
                            objects: objects.iter().map(scene_object).collect::<Result<_, _>>()?,
                            free_stiffness: *free_stiffness,
                            free_damping: *free_damping,
                            grid_spacing: *grid_spacing,
                        })
                    }
                };
                // A scene's reference starts at the device's start position, as on the host.
                let reference = source.fixed_position().unwrap_or(source.last);
                let mut padded = [0.0; hapticgen_protocol::MAX_TASK];
                for (slot, value) in padded.iter_mut().zip(reference) {
                    *slot = value;
                }
                let play = PilPlay::Impedance { reference: padded, scene: scene.as_ref() };
                let mut pil =
                    Pil::start(&target.qemu, &target.image, &target.name, &target.log, settings, play)?;
                pil.stop_after = target.stop_after;
                pil.corrupt_every = target.corrupt_every;
                pil.garbage_every = target.garbage_every;
                Ok(pil)
            },
        )?;
        Ok((trace, pil.finish()?))
    }
}

/// A planar virtual object of the simulator as a scene object of the link: a circle is a
/// sphere, an axis-aligned rectangle a box (solid only); other shapes are not sent yet.
fn scene_object(object: &VirtualObject<f64, SCENE_VERTICES>) -> Result<SceneObject, String> {
    let (stiffness, damping) = (object.stiffness as f32, object.damping as f32);
    match (object.shape, object.kind) {
        (Shape::Circle { center, radius }, kind) => Ok(SceneObject::Sphere {
            centre: [center[0] as f32, center[1] as f32, 0.0],
            radius: radius as f32,
            cavity: kind == ObjectKind::Cavity,
            stiffness,
            damping,
        }),
        (Shape::Rectangle { center, half_extents, angle: 0.0 }, ObjectKind::Solid) => Ok(SceneObject::Box {
            centre: [center[0] as f32, center[1] as f32, 0.0],
            half_extents: [half_extents[0] as f32, half_extents[1] as f32, 1.0],
            stiffness,
            damping,
        }),
        _ => {
            Err("error: hapticgen pil sends circles and axis-aligned solid rectangles only; this scene has \
                  another shape (the trace-square scenario's cavity)"
                .into())
        }
    }
}

impl Simulation {
    /// Loads a model file; errors are the code generator's diagnostics.
    pub fn load(path: &Path, variant: Option<&str>) -> Result<Simulation, String> {
        let model = hapticgen_codegen::load_file(path, &path.display().to_string(), variant)
            .map_err(|d| d.to_string())?;
        Simulation::from_model(model)
    }

    /// Prepares a loaded model.
    pub fn from_model(model: CheckedModel) -> Result<Simulation, String> {
        let (n, m) = (model.joints.len(), model.task_dim());
        // Up to three joints from the model's tapes; a shipped model (its generated code built
        // in, `crate::generated`) up to six, such as the PUMA 560.
        let most_joints = if generated::find(&model).is_some() { 6 } else { 3 };
        if !(1..=most_joints).contains(&n) || !(1..=3).contains(&m) {
            return Err(format!(
                "error: {}: the simulator handles 1 to 3 joints (a shipped model: up to 6) and 1 to 3 task \
                 coordinates, this model has {n} joints and {m} task coordinates",
                model.file
            ));
        }
        let designs = current_loop_designs(&model)?;
        let design = designs[0];
        let data = LoopData {
            current_loop_hz: model.rates.current_loop_hz,
            impedance_loop_hz: model.rates.impedance_loop_hz,
            current_gains: designs
                .iter()
                .map(|design| CurrentLoopGains {
                    kp: design.kp,
                    ki: design.ki,
                    sample_period: design.sample_period,
                    proportional_setpoint_weight: design.proportional_setpoint_weight,
                })
                .collect(),
            filter_time_constant: design.filter_time_constant,
            sensors: model
                .sensors
                .iter()
                .map(|s| SensorSpec {
                    scale: s.scale,
                    offset: s.offset,
                    full_scale: s.full_scale,
                    noise: s.noise,
                    resolution: s.resolution,
                })
                .collect(),
        };
        let nominal = Arc::new(CompiledModel::new(&model, 1.0));
        let shipped = generated::find(&model);
        Ok(Simulation { model, nominal, shipped, data, design })
    }

    /// `true` when the controller runs on code generated at build time.
    pub fn uses_generated_code(&self) -> bool {
        self.shipped.is_some()
    }

    /// Joints `N`.
    pub fn joints(&self) -> usize {
        self.nominal.joints
    }

    /// Task dimension `M`.
    pub fn task_dim(&self) -> usize {
        self.nominal.task_dim
    }

    /// The middle of every joint's range: the default start.
    pub fn home(&self) -> Vec<f64> {
        self.model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect()
    }

    /// The task Jacobian at `q`, row by row (`task_dim` rows of `joints` entries).
    pub fn jacobian_at(&self, q: &[f64]) -> Vec<Vec<f64>> {
        let (n, m) = (self.joints(), self.task_dim());
        let tape: &Tape = &self.nominal.kinematics;
        let mut scratch = tape.scratch();
        let mut out = vec![0.0; tape.len()];
        tape.eval(&mut scratch, q, &vec![0.0; n], &self.nominal.parameters, &mut out);
        (0..m).map(|k| out[m + k * n..m + (k + 1) * n].to_vec()).collect()
    }

    /// Integration substeps per current-loop period that keep an operator's hand of
    /// `stiffness` and `damping` (task space) numerically stable on the rig's lightest axis at
    /// `q`: the hand's rates there, `b |J_j|² / D_jj` and `√(k |J_j|² / D_jj)`, times a
    /// substep at most 0.5 (1 for every rig whose axes are heavy enough, the paper's included).
    pub fn hand_substeps(&self, q: &[f64], stiffness: f64, damping: f64) -> usize {
        let (n, m) = (self.joints(), self.task_dim());
        let evaluate = |tape: &Tape| {
            let mut out = vec![0.0; tape.len()];
            tape.eval(&mut tape.scratch(), q, &vec![0.0; n], &self.nominal.parameters, &mut out);
            out
        };
        let (dynamics, kinematics) = (evaluate(&self.nominal.dynamics), evaluate(&self.nominal.kinematics));
        let period = 1.0 / f64::from(self.data.current_loop_hz);
        let fastest = (0..n)
            .map(|j| {
                let lever: f64 = (0..m).map(|k| kinematics[m + k * n + j].powi(2)).sum();
                let inertia = dynamics[j * n + j];
                let rate = damping.abs() * lever / inertia;
                let frequency = (stiffness.abs() * lever / inertia).sqrt();
                rate.max(frequency)
            })
            .fold(0.0, f64::max);
        let substeps = (fastest * period / 0.5).ceil();
        if substeps.is_finite() && substeps > 1.0 {
            substeps.min(1000.0) as usize
        } else {
            1
        }
    }

    /// Task position and Jacobian determinant (square tasks; 0 otherwise) at `q`.
    pub fn task_at(&self, q: &[f64]) -> (Vec<f64>, f64) {
        let (n, m) = (self.joints(), self.task_dim());
        let tape: &Tape = &self.nominal.kinematics;
        let mut scratch = tape.scratch();
        let mut out = vec![0.0; tape.len()];
        tape.eval(&mut scratch, q, &vec![0.0; n], &self.nominal.parameters, &mut out);
        let position = out[..m].to_vec();
        let j = &out[m..m + m * n];
        let det = match (n, m) {
            (1, 1) => j[0],
            (2, 2) => j[0] * j[3] - j[1] * j[2],
            (3, 3) => {
                j[0] * (j[4] * j[8] - j[5] * j[7]) - j[1] * (j[3] * j[8] - j[5] * j[6])
                    + j[2] * (j[3] * j[7] - j[4] * j[6])
            }
            _ => 0.0,
        };
        (position, det)
    }

    /// The simulated device `device` (another model file: its own masses, inertias and
    /// frictions) for this simulation's controller, checked to have the same joints and task.
    pub fn device(&self, device: &hapticgen_codegen::CheckedModel) -> Result<Arc<CompiledModel>, String> {
        let ours: Vec<&str> = self.model.joints.iter().map(|j| j.name.as_str()).collect();
        let theirs: Vec<&str> = device.joints.iter().map(|j| j.name.as_str()).collect();
        if ours != theirs || device.task_dim() != self.model.task_dim() {
            return Err(format!(
                "error: {}: the plant's joints [{}] and task ({} coordinates) must be the model's [{}] ({})",
                device.file,
                theirs.join(", "),
                device.task_dim(),
                ours.join(", "),
                self.model.task_dim()
            ));
        }
        Ok(Arc::new(CompiledModel::new(device, 1.0)))
    }

    fn plant(&self, cfg: &SimConfig) -> Arc<CompiledModel> {
        if let Some(device) = &cfg.plant_model {
            device.clone()
        } else if cfg.plant_mass_scale == 1.0 {
            self.nominal.clone()
        } else {
            Arc::new(CompiledModel::new(&self.model, cfg.plant_mass_scale))
        }
    }

    /// Runs one simulation.
    pub fn run(&self, cfg: &SimConfig) -> Result<Trace, String> {
        self.dispatch(RunVisitor { plant: self.plant(cfg), data: &self.data, cfg })
    }

    /// Runs one processor-in-the-loop run: the same plant, operator, sensors and trace as
    /// [`Simulation::run`], the controller the firmware image under QEMU (`crate::pil`).
    pub fn run_pil(&self, cfg: &SimConfig, target: &PilTarget) -> Result<(Trace, PilReport), String> {
        self.dispatch(PilVisitor { plant: self.plant(cfg), data: &self.data, cfg, target })
    }

    /// Calls `visitor` with the controller's rig: the generated code of a shipped model, else
    /// the model's tapes.
    pub(crate) fn dispatch<T, V: RigVisitor<Output = Result<T, String>>>(
        &self,
        visitor: V,
    ) -> Result<T, String> {
        if let Some(index) = self.shipped {
            if let Some(result) = generated::visit(index, visitor) {
                return result;
            }
            return Err("error: the generated rig registry is inconsistent".into());
        }
        let model = self.nominal.clone();
        macro_rules! dispatch {
            ($(($n:literal, $m:literal)),*) => {
                match (self.joints(), self.task_dim()) {
                    $(($n, $m) => match TapeRig::<$n, $m>::new(model, &self.data.current_gains) {
                        Some(rig) => visitor.visit::<TapeRig<$n, $m>, $n, $m>(rig),
                        None => Err("error: model dimensions changed".into()),
                    },)*
                    (n, m) => Err(format!("error: {n} joints and {m} task coordinates are not supported")),
                }
            };
        }
        dispatch!((1, 1), (1, 2), (1, 3), (2, 1), (2, 2), (2, 3), (3, 1), (3, 2), (3, 3))
    }

    /// Fills `cfg`'s operator, reference and start for `scenario` (keeps `K_d`, `B_d`, `M_d`);
    /// a contact scenario's placement is returned for its checks ([`crate::contact::checks`]).
    pub fn apply_scenario(
        &self,
        scenario: Scenario,
        settings: &ScenarioSettings,
        cfg: &mut SimConfig,
    ) -> Result<Option<ContactSetup>, String> {
        let m = self.task_dim();
        let q0 = settings.start.clone().unwrap_or_else(|| self.home());
        let (x0, _) = self.task_at(&q0);
        cfg.initial_q = q0.clone();
        let rendering = self.model.rendering.as_ref();
        let grid = settings.grid_spacing.or(rendering.map(|r| r.grid_spacing)).unwrap_or(0.0);
        let (hand_k, hand_b) = settings.hand;
        match scenario {
            Scenario::Step => {
                let mut force = vec![0.0; m];
                force[0] = settings.step.0;
                cfg.operator = Operator::Step { force, start: settings.step.1 };
                cfg.reference = Reference::Fixed(None);
            }
            Scenario::TraceCircle | Scenario::TraceSquare => {
                if m != 2 {
                    return Err(format!(
                        "error: scenario {} needs a 2-D task space; {} has {m} task coordinates",
                        if scenario == Scenario::TraceCircle { "trace-circle" } else { "trace-square" },
                        self.model.file
                    ));
                }
                let c = [x0[0], x0[1]];
                let size = settings.shape_size;
                let reach = size + settings.push_depth;
                let shape = if scenario == Scenario::TraceCircle {
                    Shape::Circle { center: c, radius: size }
                } else {
                    Shape::Rectangle { center: c, half_extents: [size, size], angle: 0.0 }
                };
                let object = VirtualObject {
                    shape,
                    kind: ObjectKind::Cavity,
                    stiffness: cfg.stiffness,
                    damping: cfg.damping,
                };
                cfg.reference = Reference::Scene {
                    objects: vec![object],
                    free_stiffness: cfg.stiffness,
                    free_damping: cfg.damping,
                    grid_spacing: grid,
                };
                let mut keys = vec![(0.0, x0.clone()), (0.3, x0.clone())];
                let lap_start = 1.3;
                let outline: Vec<[f64; 2]> = if scenario == Scenario::TraceCircle {
                    (0..=120)
                        .map(|i| {
                            let a = std::f64::consts::TAU * f64::from(i) / 120.0;
                            [reach * a.cos(), reach * a.sin()]
                        })
                        .collect()
                } else {
                    vec![
                        [reach, 0.0],
                        [reach, reach],
                        [-reach, reach],
                        [-reach, -reach],
                        [reach, -reach],
                        [reach, 0.0],
                    ]
                };
                // Even speed along the outline.
                let lengths: Vec<f64> =
                    outline.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).collect();
                let total: f64 = lengths.iter().sum();
                let mut t = lap_start;
                keys.push((t, vec![c[0] + outline[0][0], c[1] + outline[0][1]]));
                for (segment, point) in lengths.iter().zip(&outline[1..]) {
                    t += settings.lap_time * segment / total;
                    keys.push((t, vec![c[0] + point[0], c[1] + point[1]]));
                }
                keys.push((t + 1.0, x0.clone()));
                cfg.operator = Operator::Hand { stiffness: hand_k, damping: hand_b, path: HandPath { keys } };
                cfg.duration = cfg.duration.max(t + 1.5);
            }
            Scenario::Singularity => {
                if m != 2 || self.joints() != 2 {
                    return Err(format!(
                        "error: scenario singularity needs 2 joints and a 2-D task; {} has {} joints and {m} task \
                         coordinates",
                        self.model.file,
                        self.joints()
                    ));
                }
                let target_q = match &settings.singular_target {
                    Some(q) => q.clone(),
                    None => self.nearest_singular(&q0)?,
                };
                let (target, _) = self.task_at(&target_q);
                let beyond: Vec<f64> =
                    x0.iter().zip(&target).map(|(a, b)| b + settings.singular_overshoot * (b - a)).collect();
                let keys = vec![(0.0, x0.clone()), (0.3, x0.clone()), (2.3, beyond)];
                cfg.operator = Operator::Hand { stiffness: hand_k, damping: hand_b, path: HandPath { keys } };
                cfg.reference = Reference::Fixed(None);
            }
            Scenario::Contact(contact) => {
                let placed = crate::contact::setup(
                    contact,
                    &x0,
                    &ContactSettings {
                        surface: (cfg.stiffness, cfg.damping),
                        friction: settings.friction,
                        hand: settings.hand,
                        push: settings.push_depth,
                        mesh: settings.mesh.clone(),
                    },
                )?;
                let placed = match &settings.scene {
                    Some(solids) => placed.with_scene(solids.clone()),
                    None => placed,
                };
                cfg.operator = Operator::Hand {
                    stiffness: hand_k,
                    damping: hand_b,
                    path: HandPath { keys: placed.keys.clone() },
                };
                cfg.reference =
                    Reference::Solids { solids: placed.solids.clone(), effect: settings.effect.clone() };
                cfg.duration = cfg.duration.max(placed.duration);
                cfg.substeps = cfg.substeps.max(self.hand_substeps(&q0, hand_k, hand_b));
                return Ok(Some(placed));
            }
            Scenario::FreeDrift => {
                cfg.operator = Operator::Free;
                cfg.reference = if m == 2 {
                    Reference::Scene {
                        objects: Vec::new(),
                        free_stiffness: cfg.stiffness,
                        free_damping: cfg.damping,
                        grid_spacing: grid,
                    }
                } else {
                    Reference::Fixed(None)
                };
            }
        }
        if let Operator::Hand { stiffness, damping, .. } = &cfg.operator {
            cfg.substeps = cfg.substeps.max(self.hand_substeps(&q0, *stiffness, *damping));
        }
        Ok(None)
    }

    /// The largest `|det J|` over the joint limits (a 41 × 41 grid) of a 2-joint rig with a
    /// 2-D task (`None` for other rigs). Under 2 % of it is what the singularity scenario and
    /// `hapticgen simulate`'s warnings call singular.
    pub fn largest_jacobian_determinant(&self) -> Option<f64> {
        if (self.joints(), self.task_dim()) != (2, 2) {
            return None;
        }
        let joints = &self.model.joints;
        let steps = 40u32;
        let at = |j: usize, i: u32| {
            joints[j].lower + (joints[j].upper - joints[j].lower) * f64::from(i) / f64::from(steps)
        };
        let largest = (0..=steps)
            .flat_map(|a| (0..=steps).map(move |b| (a, b)))
            .map(|(a, b)| self.task_at(&[at(0, a), at(1, b)]).1.abs())
            .fold(0.0, f64::max);
        (largest > 0.0).then_some(largest)
    }

    /// The configuration within the joint limits nearest to `q0` (joint-space distance)
    /// where `|det J|` is under 2 % of its largest value over the limits.
    pub fn nearest_singular(&self, q0: &[f64]) -> Result<Vec<f64>, String> {
        let joints = &self.model.joints;
        let steps = 80usize;
        let grid_point = |a: usize, b: usize| {
            let lerp = |j: usize, i: usize| {
                joints[j].lower + (joints[j].upper - joints[j].lower) * i as f64 / steps as f64
            };
            vec![lerp(0, a), lerp(1, b)]
        };
        let mut samples = Vec::with_capacity((steps + 1) * (steps + 1));
        for a in 0..=steps {
            for b in 0..=steps {
                let q = grid_point(a, b);
                let (_, det) = self.task_at(&q);
                samples.push((q, det.abs()));
            }
        }
        let largest = samples.iter().map(|s| s.1).fold(0.0, f64::max);
        samples
            .into_iter()
            .filter(|(_, d)| *d <= 0.02 * largest)
            .map(|(q, _)| {
                let distance = q.iter().zip(q0).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
                (q, distance)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(q, _)| q)
            .ok_or_else(|| "error: no singular configuration within the joint limits".to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::Simulation;

    /// The scenarios' hand (200 N/m, 1 N·s/m) needs no substeps on any shipped rig but the
    /// differential wrist, so every other rig's runs, the paper's included, are integrated as
    /// before substeps were chosen.
    #[test]
    fn only_the_wrist_needs_substeps_under_the_hand() {
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut checked = 0;
        for entry in std::fs::read_dir(&models).unwrap() {
            let path = entry.unwrap().path();
            // Every shipped model loads (the PUMA 560's six joints too).
            let simulation = Simulation::load(&path, None).unwrap();
            let substeps = simulation.hand_substeps(&simulation.home(), 200.0, 1.0);
            let wrist = path.ends_with("differential_wrist.yaml");
            assert_eq!(substeps > 1, wrist, "{}: {substeps} substeps", path.display());
            checked += 1;
        }
        assert!(checked >= 9, "{checked} models");
    }
}
