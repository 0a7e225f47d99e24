//! `hapticgen simulate`: a model in closed loop with one of the paper's controllers on the
//! simulated plant, its trace, scene and figures written, a contact scenario's checks made;
//! `--scenario excite` plays an identification trajectory instead. Also the run's set-up from
//! the command line (`configure`), which `pil` shares.

use std::path::Path;

use hapticgen_codegen::check::plausibility;
use hapticgen_runtime::control::ImpedanceLaw;

use super::args::{ControllerArg, ScenarioArg, SimulateArgs};
use super::{load, CliError, FileOp};
use crate::closed_loop::{SimConfig, Trace};
use crate::contact::{Contact, ContactSetup};
use crate::paper;
use crate::plant::Effects;
use crate::simulation::{Scenario, ScenarioSettings, Simulation};

/// `|det J|` under this fraction of its largest value over the joint limits is singular.
const SINGULAR: f64 = 0.02;

/// A run `simulate` and `pil` share: the model, its configuration, the scenario and whether
/// the start is singular.
pub(crate) struct Configured {
    /// The loaded model.
    pub sim: Simulation,
    /// The closed loop's configuration.
    pub cfg: SimConfig,
    /// The scenario.
    pub scenario: Scenario,
    /// How singular the start pose is (`|det J|` over its largest value), if it is.
    pub singular_start: Option<f64>,
    /// A contact scenario's placement, for its checks.
    pub contact: Option<ContactSetup>,
}

/// The run the arguments of `simulate` (or `pil`) describe, its output directory created;
/// warns on standard error of a singular start pose.
pub(crate) fn configure(args: &SimulateArgs) -> Result<Configured, CliError> {
    let sim = Simulation::load(&args.model, args.variant.as_deref()).map_err(CliError::Simulation)?;
    for (name, value) in
        [("--kd", args.kd), ("--bd", args.bd), ("--md", args.md), ("--duration", args.duration)]
    {
        if let Some(v) = value {
            if !v.is_finite() || v < 0.0 {
                return Err(CliError::Usage(format!(
                    "{name} must be a finite, non-negative number, got {v}"
                )));
            }
        }
    }
    if !(args.mass_scale.is_finite() && args.mass_scale > 0.0) {
        return Err(CliError::Usage(format!("--mass-scale must be positive, got {}", args.mass_scale)));
    }
    let scenario = match args.scenario {
        ScenarioArg::Step => Scenario::Step,
        ScenarioArg::TraceCircle => Scenario::TraceCircle,
        ScenarioArg::TraceSquare => Scenario::TraceSquare,
        ScenarioArg::Singularity => Scenario::Singularity,
        ScenarioArg::FreeDrift => Scenario::FreeDrift,
        ScenarioArg::Wall => Scenario::Contact(Contact::Wall),
        ScenarioArg::Slide => Scenario::Contact(Contact::Slide),
        ScenarioArg::Sphere => Scenario::Contact(Contact::Sphere),
        ScenarioArg::BoxEdges => Scenario::Contact(Contact::BoxEdges),
        ScenarioArg::ThinPlate => Scenario::Contact(Contact::ThinPlate),
        ScenarioArg::Mesh => Scenario::Contact(Contact::Mesh),
        ScenarioArg::Excite => {
            return Err(CliError::Usage("the excite scenario is run by excite_run".into()))
        }
    };
    let rendering = sim.model.rendering.as_ref();
    let (kd, bd) = match scenario {
        Scenario::Step => (1.0, 0.01),
        Scenario::Singularity => (100.0, 2.0),
        _ => rendering.map_or((1500.0, 5.0), |r| (r.wall_stiffness, r.wall_damping)),
    };
    let start = match &args.start {
        Some(q) => start_pose(&sim, q)?,
        None => sim.home(),
    };
    let mut cfg = SimConfig::new(start.clone());
    let controller =
        args.controller.ok_or_else(|| CliError::Usage("--controller is needed for this scenario".into()))?;
    cfg.law = law(controller);
    cfg.stiffness = args.kd.unwrap_or(kd);
    cfg.damping = args.bd.unwrap_or(bd);
    cfg.mass = args.md.unwrap_or(0.01);
    cfg.duration = args.duration.unwrap_or(5.0);
    cfg.effects = effects(&args.without)?;
    cfg.plant_mass_scale = args.mass_scale;
    if let Some(path) = &args.plant {
        if args.mass_scale != 1.0 {
            return Err(CliError::Usage(
                "give --plant (another model file as the device) or --mass-scale, not both".into(),
            ));
        }
        let device = load(path, args.variant.as_deref())?;
        cfg.plant_model = Some(sim.device(&device).map_err(CliError::Simulation)?);
    }
    cfg.seed = args.seed;
    cfg.singular_fallback = args.singular_fallback;
    cfg.spring_lead_time = args.spring_lead;
    cfg.friction_compensation = match args.friction_compensation {
        None => None,
        Some(None) => Some(sim.friction_compensation_band()),
        Some(Some(band)) if band.is_finite() && band >= 0.0 => Some(band),
        Some(Some(band)) => {
            return Err(CliError::Usage(format!(
                "--friction-compensation: the band must be ≥ 0 rad/s, got {band}"
            )))
        }
    };
    cfg.progress = true;
    let scene = match &args.scene {
        None => None,
        Some(_) if !matches!(scenario, Scenario::Contact(_)) => {
            return Err(CliError::Usage(
                "--scene needs a contact scenario (wall, slide, sphere, box-edges, thin-plate, \
                        mesh), whose hand path it keeps"
                    .into(),
            ))
        }
        Some(path) => Some(crate::scene::load(path).map_err(CliError::Input)?),
    };
    let settings = ScenarioSettings {
        grid_spacing: args.grid,
        start: Some(start.clone()),
        friction: friction(args.friction.as_deref())?,
        mesh: args.mesh.as_deref().map(crate::contact::mesh_file).transpose().map_err(CliError::Input)?,
        scene: scene
            .as_ref()
            .map(|scene| crate::scene::objects_for_task(scene, sim.task_dim()))
            .transpose()
            .map_err(CliError::Input)?,
        effect: scene.and_then(|scene| scene.effect),
        ..ScenarioSettings::default()
    };
    let contact = sim.apply_scenario(scenario, &settings, &mut cfg).map_err(CliError::Simulation)?;
    let largest_det = sim.largest_jacobian_determinant();
    let singularity = |q: &[f64]| largest_det.map(|largest| sim.task_at(q).1.abs() / largest);
    let singular_start = singularity(&start).filter(|&m| m < SINGULAR);
    if let Some(measure) = singular_start {
        eprintln!(
            "warning: the start pose q = {} is singular (|det J| is {:.1} % of its largest value over the joint \
             limits){}; the scenario's motion there is clipped. Start elsewhere with --start q1,q2",
            format_pose(&start),
            100.0 * measure,
            if args.start.is_none() { " — the default start is the middle of the joint limits" } else { "" },
        );
    }
    if args.duration.is_some() {
        cfg.duration = args.duration.unwrap_or(cfg.duration);
    }
    std::fs::create_dir_all(&args.output).map_err(CliError::file(FileOp::Create, &args.output))?;
    Ok(Configured { sim, cfg, scenario, singular_start, contact })
}

/// The impedance law a `--controller` names.
pub(crate) fn law(controller: ControllerArg) -> ImpedanceLaw {
    match controller {
        ControllerArg::One => ImpedanceLaw::ForceFeedback,
        ControllerArg::TwoA => ImpedanceLaw::AccelerationFeedback,
        ControllerArg::TwoB => ImpedanceLaw::NaturalInertia,
        ControllerArg::Three => ImpedanceLaw::JacobianTranspose,
    }
}

/// `--friction MU_S,MU_D` as the two coefficients (none given: frictionless).
pub(crate) fn friction(values: Option<&[f64]>) -> Result<(f64, f64), CliError> {
    match values {
        None => Ok((0.0, 0.0)),
        Some(&[static_friction, dynamic_friction])
            if static_friction.is_finite() && (0.0..=static_friction).contains(&dynamic_friction) =>
        {
            Ok((static_friction, dynamic_friction))
        }
        Some(other) => Err(CliError::Usage(format!(
            "--friction takes MU_S,MU_D with 0 ≤ MU_D ≤ MU_S, got {}",
            other.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",")
        ))),
    }
}

/// `--without`: every effect of the plant but those named.
fn effects(without: &str) -> Result<Effects, CliError> {
    Effects::ALL.without(without).map_err(|e| CliError::Usage(format!("--without: {e}")))
}

/// The plausibility findings of `hapticgen check` for a model about to be simulated, as
/// printed lines: a model the drives cannot hold is simulated all the same (its faults are what
/// the user may want to see), but the cause is named before the run.
fn plausibility_lines(model: &Path, variant: Option<&str>) -> Vec<String> {
    let (Ok(m), Ok(text)) = (load(model, variant), std::fs::read_to_string(model)) else { return Vec::new() };
    let found = plausibility::plausibility(&m, &hapticgen_codegen::derive(&m), &text);
    found
        .findings
        .iter()
        .map(|f| {
            let d = f.diagnostic(&model.display().to_string(), &text, &m);
            match f.severity {
                plausibility::Severity::Error => {
                    format!("warning: `hapticgen check` refuses this model: {d}")
                }
                plausibility::Severity::Warning => format!("warning: {d}"),
            }
        })
        .collect()
}

/// `hapticgen simulate`: runs the scenario, writes DIR/trace.csv, DIR/scene.json and the
/// figures, prints a summary; a contact scenario's checks are printed, written to
/// DIR/checks.md and fail the command if one fails.
pub fn simulate(args: SimulateArgs) -> Result<(), CliError> {
    let plausible = plausibility_lines(&args.model, args.variant.as_deref());
    for line in &plausible {
        eprintln!("{line}");
    }
    if matches!(args.scenario, ScenarioArg::Excite) || args.trajectory.is_some() {
        return excite_run(&args, None);
    }
    let Configured { sim, cfg, scenario, singular_start, contact } = configure(&args)?;
    let largest_det = sim.largest_jacobian_determinant();
    let singularity = |q: &[f64]| largest_det.map(|largest| sim.task_at(q).1.abs() / largest);
    let trace = sim.run(&cfg).map_err(CliError::Simulation)?;
    crate::output::write_csv(&trace, &args.output.join("trace.csv")).map_err(CliError::Simulation)?;
    crate::replay::write_scene(&cfg.reference, sim.task_dim(), &args.output).map_err(CliError::Simulation)?;
    let figures = paper::trace_figures(&trace, &args.output).map_err(CliError::Simulation)?;
    println!(
        "simulated {:.2} s of {} in {:.2} s ({:.2}× real time), controller on {}{}; wrote {} and {} figures",
        trace.duration(),
        args.model.display(),
        trace.wall_seconds,
        trace.duration() / trace.wall_seconds.max(1e-9),
        if sim.uses_generated_code() { "generated code" } else { "the model's tapes" },
        args.plant.as_ref().map_or_else(String::new, |p| format!(", device {}", p.display())),
        args.output.join("trace.csv").display(),
        figures
    );
    if let Some((rms, largest)) = trace.rendering_error() {
        println!(
            "task position against the rendered reference |x − x_p|: RMS {rms:.4e}, largest {largest:.4e}"
        );
    }
    if let Some(band) = cfg.friction_compensation {
        println!(
            "note: friction compensation on: the model's Coulomb friction fed forward, band {band:.4} rad/s"
        );
    }
    if let Some((t, fault)) = &trace.fault {
        println!("note: the safety monitor latched {fault} at t = {t:.3} s");
        if !plausible.is_empty() {
            println!("note: the model's plausibility warnings above may be the cause");
        }
    }
    if let Some(setup) = &contact {
        // A contact scenario's checks: printed, and written next to the trace.
        let checks = crate::contact::checks(setup, &trace, setup.contact.name());
        let table = crate::report::table(&checks);
        print!("{table}");
        let path = args.output.join("checks.md");
        std::fs::write(&path, &table).map_err(CliError::file(FileOp::Write, &path))?;
        let failures = crate::report::failures(&checks);
        if !failures.is_empty() {
            return Err(CliError::Verdict(format!(
                "{}error: {} contact check(s) failed",
                failures,
                failures.lines().count()
            )));
        }
    }
    if scenario != Scenario::Singularity && singular_start.is_none() {
        if let Some((t, q)) = first_singular_sample(&sim, &trace, singularity) {
            eprintln!(
                "warning: the run reached a singular pose at t = {t:.3} s (q = {}); the task-space motion \
                 is clipped there. Start elsewhere with --start q1,q2",
                format_pose(&q)
            );
        }
    }
    Ok(())
}

/// `simulate --scenario excite`: the identification run (crate::identify); with `pil`, the
/// firmware image under QEMU plays it (`hapticgen pil --scenario excite`).
pub(super) fn excite_run(args: &SimulateArgs, pil: Option<&super::args::PilArgs>) -> Result<(), CliError> {
    if !matches!(args.scenario, ScenarioArg::Excite) {
        return Err(CliError::Usage(
            "--trajectory belongs to the excite scenario (--scenario excite)".into(),
        ));
    }
    let trajectory = args
        .trajectory
        .as_deref()
        .ok_or_else(|| CliError::Usage("the excite scenario needs --trajectory TRAJ.yaml".into()))?;
    let sim = Simulation::load(&args.model, args.variant.as_deref()).map_err(CliError::Simulation)?;
    let target = match pil {
        None => None,
        Some(pil) => {
            // The variant applied: the one asked for, else the model's default.
            let name = crate::pil::chosen_image_name(
                pil.image_name.as_deref(),
                &args.model,
                sim.model.variant.as_deref(),
            )
            .map_err(CliError::Simulation)?;
            let image =
                crate::pil::locate_image(&name, pil.image.as_deref()).map_err(CliError::Simulation)?;
            let qemu = crate::pil::locate_qemu(pil.qemu.as_deref()).map_err(CliError::Simulation)?;
            std::fs::create_dir_all(&args.output).map_err(CliError::file(FileOp::Create, &args.output))?;
            eprintln!("pil: image {} ({name}) under {}", image.display(), qemu.display());
            Some(crate::simulation::PilTarget {
                qemu,
                image,
                name,
                log: args.output.join("qemu.out"),
                stop_after: None,
                corrupt_every: None,
                garbage_every: None,
            })
        }
    };
    let mut cfg = SimConfig::new(sim.home());
    cfg.effects = effects(&args.without)?;
    cfg.seed = args.seed;
    if let Some(duration) = args.duration {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(CliError::Usage(format!(
                "--duration must be a positive number of seconds, got {duration}"
            )));
        }
    }
    let run = crate::identify::commands::ExciteRun {
        trajectory,
        plant: args.plant.as_deref(),
        cfg,
        duration: args.duration,
        output: &args.output,
        pil: target.as_ref(),
    };
    let text = crate::identify::commands::excite_run(&sim, &args.model, args.variant.as_deref(), run)
        .map_err(CliError::Identification)?;
    print!("{text}");
    Ok(())
}

/// `--start`: one coordinate per joint, within the joint's limits.
fn start_pose(sim: &Simulation, q: &[f64]) -> Result<Vec<f64>, CliError> {
    let joints = &sim.model.joints;
    if q.len() != joints.len() {
        return Err(CliError::Usage(format!(
            "--start needs {} joint coordinates, got {}",
            joints.len(),
            q.len()
        )));
    }
    for (joint, &value) in joints.iter().zip(q) {
        if !(value.is_finite() && joint.lower <= value && value <= joint.upper) {
            return Err(CliError::Usage(format!(
                "--start: joint `{}` at {value} is outside its limits [{}, {}]",
                joint.name, joint.lower, joint.upper
            )));
        }
    }
    Ok(q.to_vec())
}

/// The first sample of a run (after the start) at a singular pose, with its time and joints.
fn first_singular_sample(
    sim: &Simulation,
    trace: &Trace,
    singularity: impl Fn(&[f64]) -> Option<f64>,
) -> Option<(f64, Vec<f64>)> {
    let columns: Vec<Vec<f64>> =
        (0..sim.joints()).map(|j| trace.column(&format!("q{j}"))).collect::<Option<_>>()?;
    let times = trace.column("t")?;
    // Every 10 ms of simulated time.
    let mut next = 0.0;
    for (i, &t) in times.iter().enumerate() {
        if t < next {
            continue;
        }
        next = t + 0.01;
        let q: Vec<f64> = columns.iter().map(|c| c[i]).collect();
        if singularity(&q)? < SINGULAR {
            return Some((t, q));
        }
    }
    None
}

/// Joint coordinates as `(q0, q1, …) rad`, three decimals.
fn format_pose(q: &[f64]) -> String {
    let parts: Vec<String> = q.iter().map(|v| format!("{v:.3}")).collect();
    format!("({}) rad", parts.join(", "))
}
