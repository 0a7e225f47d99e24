//! The `hapticgen` command line: a thin shell over `hapticgen_codegen`.
//!
//! `check` validates a model, `generate` prints its Rust code, `eval` evaluates the derived
//! quantities of eq. (1)–(2) at one state, and `stats` counts the operations of each emitted
//! function, `simulate` runs a model in closed loop with the runtime's controllers and writes
//! a CSV trace and plots, and `paper` reproduces the experiments of the paper's section 6
//! with figures and a report. Exit code 0 on success; on failure a diagnostic with file, line
//! and column on standard error and exit code 1 (2 for bad command-line usage).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use hapticgen_codegen::check::{plausibility, stability};
use hapticgen_codegen::{eval, model, Scalar};
use hapticgen_host::contact::{Contact, ContactSetup};
use hapticgen_host::paper;
use hapticgen_host::plant::Effects;
use hapticgen_host::simulate::{PilTarget, Scenario, ScenarioSettings, Simulation};
use hapticgen_runtime::control::ImpedanceLaw;

#[derive(Parser)]
#[command(
    name = "hapticgen",
    version,
    about = "Generate specialised dynamics and control code for haptic rigs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum ScalarArg {
    F32,
    F64,
}

#[derive(Subcommand)]
enum Command {
    /// Write a commented starting model file for a Delta, a five-bar or a serial arm from a
    /// few named dimensions, masses and motor data; it passes `check` as written.
    New {
        /// The kind of rig.
        #[command(subcommand)]
        rig: hapticgen_host::template::NewRig,
    },
    /// The device design figures of a model: its workspace and inscribed cube, the force it
    /// holds in every direction, its apparent inertia, isotropy, gravity load and resolution
    /// over the cube and as maps, the stiffest wall it renders stably at the cube's centre and
    /// corners; writes DIR/index.html (with a 3-D view of the rig, docs/design-report.md),
    /// DIR/summary.json, DIR/workspace.csv and DIR/maps/; with --replay, the page replays a run
    /// in that view.
    Report {
        /// The model file.
        model: PathBuf,
        /// The variant (default: the model's `default_variant`).
        #[arg(long)]
        variant: Option<String>,
        /// Grid points per actuated joint over the box of the joint limits (default: 21, fewer
        /// for more than three joints, at most 20,000 points in all).
        #[arg(long)]
        steps: Option<usize>,
        /// Leave out the stiffest stable wall (its search simulates about a hundred 1 s runs);
        /// summary.json then has no `renderable_stiffness`.
        #[arg(long)]
        no_zwidth: bool,
        /// Replay this run in the page's 3-D view: the directory `hapticgen simulate -o RUN`
        /// wrote (or one run's of `hapticgen contact -o DIR`, DIR/wall…) or its trace.csv; the
        /// rig at the trace's joint angles (at most 2,000 frames), the task point's path, the
        /// proxy and the scene's objects (RUN/scene.json). The trace must be of this model.
        #[arg(long, value_name = "RUN")]
        replay: Option<PathBuf>,
        /// Output directory.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Validate a model file (and one variant).
    Check {
        /// The model file.
        model: PathBuf,
        /// The variant (default: the model's `default_variant`).
        #[arg(long)]
        variant: Option<String>,
    },
    /// Print the generated Rust code of a model.
    Generate {
        /// The model file.
        model: PathBuf,
        /// The variant (default: the model's `default_variant`).
        #[arg(long)]
        variant: Option<String>,
        /// Scalar type of the generated code.
        #[arg(long, value_enum, default_value = "f64")]
        scalar: ScalarArg,
        /// Fuse each multiplication used once into the addition or subtraction consuming it,
        /// emitted as `hapticgen_runtime::Real::mul_add` and its sign variants (one correctly
        /// rounded operation).
        #[arg(long)]
        fma: bool,
        /// Also emit the dynamic-identification regressor `regressor(q, qd, qdd)` over the base
        /// parameters, with `BASE_PARAMETERS` and `base_parameters()` (docs/identification.md).
        #[arg(long)]
        regressor: bool,
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Evaluate p, J, J̇, J̇q̇, D, C, Cq̇, g, B at one state (JSON on standard output). Exits 1,
    /// with the reason on standard error, for a state outside the joints' limits (unless
    /// --beyond-limits), where a closed chain's loops cannot close on the file's assembly branch,
    /// or where a value is not finite.
    Eval {
        /// The model file.
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// Joint coordinates, comma-separated.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        q: Vec<f64>,
        /// Joint velocities, comma-separated (default zero).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        qd: Vec<f64>,
        /// Use this named point instead of the task coordinates for p, J, J̇.
        #[arg(long)]
        point: Option<String>,
        /// Print this named frame's rotation matrix `R` and angular-velocity Jacobian
        /// `J_omega` instead.
        #[arg(long, conflicts_with = "point")]
        frame: Option<String>,
        /// With --frame: the measured joints' angles, comma-separated (default zero).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true, requires = "frame")]
        measured: Vec<f64>,
        /// Evaluate even where the state is outside the joints' limits (the values are still
        /// refused where a closed chain's loops cannot close or a value is not finite).
        #[arg(long)]
        beyond_limits: bool,
    },
    /// Count the operations of each emitted function.
    Stats {
        /// The model file.
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Count the code emitted with `generate --fma`: a fused multiply-add is one operation
        /// (two flops) in the `fused` column.
        #[arg(long)]
        fma: bool,
        /// Also count the identification regressor (`generate --regressor`).
        #[arg(long)]
        regressor: bool,
    },
    /// Print the JSON Schema of the model format.
    Schema,
    /// Write a model file from a URDF robot (drives, gravity and rates are defaults, listed
    /// in the written file's header).
    ImportUrdf {
        /// The URDF file.
        urdf: PathBuf,
        /// A YAML file with one drive (the keys of a `drives` entry) used for every joint
        /// (default: the paper's RE40-class motor with a 12:1 gearhead).
        #[arg(long)]
        drive: Option<PathBuf>,
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Write a serial model as URDF (named points become massless links `point_NAME`).
    ExportUrdf {
        /// The model file.
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Simulate a model in closed loop with one of the paper's controllers; writes
    /// DIR/trace.csv, DIR/scene.json (the objects it rendered, for `report --replay`) and plots
    /// (DIR/*.svg, DIR/*.png).
    Simulate(SimulateArgs),
    /// Processor in the loop: the rig's firmware image under QEMU (Cortex-M4F) controls the
    /// simulated plant of `simulate`, lock-step over the board's UART (one exchange per
    /// current-loop period); writes DIR/trace.csv, plots and DIR/qemu.out (the image's report).
    Pil(PilArgs),
    /// Drive a running device over its link, as an application does: open the link (the
    /// device's identity is printed), set the impedance, load a scene, enable the bridges and
    /// keep them enabled with heartbeats, show a live status line, log the state stream to
    /// CSV; disable at the end (docs/link.md).
    Connect(ConnectArgs),
    /// Run every contact scenario (a floor, sliding with and without friction, a ball, a box's
    /// edges and corner, a thin plate, meshes) on a rig with a 3-D task, with the runtime's
    /// god object rendering; writes each run's trace, scene and figures and DIR/report.md with a
    /// pass/fail row per check, and fails if a check fails.
    Contact {
        /// The model file (3 task coordinates).
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// The impedance controller.
        #[arg(long, value_enum, default_value = "jacobian-transpose")]
        controller: ControllerArg,
        /// The static and dynamic friction coefficients of the run with friction.
        #[arg(long, value_delimiter = ',', default_value = "0.5,0.4")]
        friction: Vec<f64>,
        /// One more mesh run on this OBJ or STL file (metres), e.g. scenes/meshes/knob.obj.
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// How far the hand presses into a surface, m (at most 0.02).
        #[arg(long, default_value_t = 0.01)]
        push: f64,
        /// Only these runs, comma-separated (wall, slide, slide-friction, sphere, box-edges,
        /// thin-plate, mesh, and mesh-NAME for --mesh NAME.obj).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// Output directory.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Run every experiment of the paper's section 6; writes figures and DIR/report.md.
    Paper {
        /// Output directory.
        #[arg(short, long)]
        output: PathBuf,
        /// Shortened runs (a quick check; the report says so).
        #[arg(long)]
        quick: bool,
    },
    /// Inject faults (sensors, schedule, operator, model mismatch) into the simulated closed
    /// loop and check the safety criteria; prints a table and writes DIR/faults.md.
    Faults {
        /// The model file (a shipped model runs on its generated code).
        #[arg(default_value = "models/parallel_link_2dof.yaml")]
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// Output directory.
        #[arg(short, long, default_value = "out/faults")]
        output: PathBuf,
    },
    /// Design an excitation trajectory for identification: a Fourier series per joint inside the
    /// limits, optimised for the condition number of the stacked base regressor.
    Excite {
        /// The model file.
        model: PathBuf,
        /// The variant (default: the model's `default_variant`).
        #[arg(long)]
        variant: Option<String>,
        /// Period of the series, s.
        #[arg(long, default_value_t = 10.0)]
        period: f64,
        /// Harmonics per joint.
        #[arg(long, default_value_t = 5)]
        harmonics: usize,
        /// Margin inside each joint's limits, fraction of its range.
        #[arg(long, default_value_t = 0.1)]
        margin: f64,
        /// Largest drive speed, fraction of its no-load speed.
        #[arg(long, default_value_t = 0.5)]
        speed_fraction: f64,
        /// Largest drive torque, fraction of its limit.
        #[arg(long, default_value_t = 0.8)]
        torque_fraction: f64,
        /// Candidate trajectories the search evaluates.
        #[arg(long, default_value_t = 1500)]
        evaluations: usize,
        /// Seed of the search.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The trajectory file to write.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Identify the base parameters of a model from excitation logs (weighted least squares on
    /// the base regressor); prints them with their standard deviations.
    Identify {
        /// The model file.
        model: PathBuf,
        /// The variant (default: the model's `default_variant`).
        #[arg(long)]
        variant: Option<String>,
        /// An excitation log (`simulate --scenario excite` writes DIR/log.csv); repeatable.
        #[arg(long = "log", required = true)]
        logs: Vec<PathBuf>,
        /// A second log to validate the identified model on (torque prediction error).
        #[arg(long)]
        validate: Option<PathBuf>,
        /// Cutoff of the zero-phase low-pass filter, Hz.
        #[arg(long, default_value_t = 15.0)]
        cutoff: f64,
        /// Fit the torque of the measured currents (the log's tau_* columns) instead of the
        /// commanded torque (tau_cmd_*); see docs/identification.md.
        #[arg(long)]
        measured_torque: bool,
        /// Write a report into this directory: identification.md (the parameter table with σ,
        /// the fit's figures, and each joint's measured torque against the torque the model
        /// file's and the identified parameters predict) and those figures as SVG and PNG.
        #[arg(long, value_name = "DIR")]
        report: Option<PathBuf>,
        /// Write the identified model file here: the input file with physically consistent
        /// masses, centres of mass, inertias and frictions, every changed value marked.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Map the stable (K, B) region of a virtual wall by simulation (in parallel) and plot it
    /// against the analytic passivity and stability bounds; writes DIR/zwidth.{csv,svg,png,md}.
    Zwidth {
        /// The model file (2-D task).
        model: PathBuf,
        /// The variant.
        #[arg(long)]
        variant: Option<String>,
        /// Output directory.
        #[arg(short, long, default_value = "out/zwidth")]
        output: PathBuf,
        /// A short sweep (3 damping values, 6 bisection steps).
        #[arg(long)]
        quick: bool,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum ControllerArg {
    /// Force feedback, the paper's Controller 1 (also `1`): sensed force, eq. (7).
    #[value(name = "force-feedback", alias = "1")]
    One,
    /// Acceleration feedback, the paper's Controller 2, first variant (also `2a`): acceleration
    /// estimate, eq. (8) and (10).
    #[value(name = "acceleration-feedback", alias = "2a")]
    TwoA,
    /// Natural-inertia impedance, the paper's Controller 2, second variant (also `2b`):
    /// M_d = W⁻¹, eq. (11).
    #[value(name = "natural-inertia", alias = "2b")]
    TwoB,
    /// Jacobian-transpose impedance, the paper's Controller 3 (also `3`): no J⁻¹, no J̇,
    /// eq. (12)–(13).
    #[value(name = "jacobian-transpose", alias = "3")]
    Three,
}

#[derive(Clone, Copy, ValueEnum)]
enum ScenarioArg {
    /// A 1 N·m (or N) step on the first task axis.
    Step,
    /// Trace a virtual circle from the inside (2-D tasks).
    TraceCircle,
    /// Trace a virtual square from the inside (2-D tasks).
    TraceSquare,
    /// Drag the end-effector onto the nearest singular configuration (2 joints).
    Singularity,
    /// No operator force: free-space drift.
    FreeDrift,
    /// Press into a floor 2 cm below the start, across the last task axis (any task; the
    /// contact scenarios render with the runtime's god object).
    Wall,
    /// Press onto the floor and slide 3 cm along it (3-D tasks; see --friction).
    Slide,
    /// Trace a circle on a ball of radius 3 cm, pressed 1 cm in (3-D tasks).
    Sphere,
    /// Press in next to a box's edge and corner, then slide off over the corner (3-D tasks).
    BoxEdges,
    /// Push hard through a 1 mm plate: the proxy must not pop through (3-D tasks).
    ThinPlate,
    /// Press on a closed triangle mesh and circle on it (3-D tasks; see --mesh).
    Mesh,
    /// Play an excitation trajectory (--trajectory, from `hapticgen excite`) with joint-space
    /// tracking on the model's dynamics, the device another model file if --plant says so;
    /// writes DIR/log.csv for `hapticgen identify` (docs/identification.md).
    Excite,
}

#[derive(clap::Args)]
struct SimulateArgs {
    /// The model file.
    model: PathBuf,
    /// The variant (default: the model's `default_variant`).
    #[arg(long)]
    variant: Option<String>,
    /// The impedance controller (every scenario but `excite`, which tracks in joint space).
    #[arg(long, value_enum, required_unless_present = "trajectory")]
    controller: Option<ControllerArg>,
    /// Desired stiffness K_d (default per scenario: 1 for a step, the model's wall stiffness
    /// or 1500 for rendering, 100 for singularity).
    #[arg(long)]
    kd: Option<f64>,
    /// Desired damping B_d (default per scenario: 0.01, wall damping or 5, 2).
    #[arg(long)]
    bd: Option<f64>,
    /// Desired mass M_d (Controllers 1 and 2a; default 0.01).
    #[arg(long)]
    md: Option<f64>,
    /// The scenario.
    #[arg(long, value_enum)]
    scenario: ScenarioArg,
    /// Start pose: the joint coordinates, rad (or m), comma-separated (default: the middle of
    /// every joint's limits, which for a joint with symmetric limits is 0: a serial arm then
    /// starts stretched out, a singular pose).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    start: Option<Vec<f64>>,
    /// Simulated time, s (default 5; tracing scenarios run at least one lap).
    #[arg(long)]
    duration: Option<f64>,
    /// Output directory.
    #[arg(short, long)]
    output: PathBuf,
    /// Effects to switch off, comma-separated: friction, backlash, encoder, sensor,
    /// saturation, electrics, or all.
    #[arg(long, default_value = "")]
    without: String,
    /// Factor on the plant's body masses (model mismatch; the controller keeps the model's).
    #[arg(long, default_value_t = 1.0)]
    mass_scale: f64,
    /// Free-space anti-drift grid spacing, m (default: the model's rendering.grid_spacing).
    #[arg(long)]
    grid: Option<f64>,
    /// |det J| below which Controllers 1 and 2 fall back to Controller 3 (0: never).
    #[arg(long, default_value_t = 0.0)]
    singular_fallback: f64,
    /// Lead time of the spring term, s: compensates the sampled loop's delay (0: the paper's law).
    #[arg(long, default_value_t = 0.0)]
    spring_lead: f64,
    /// Feed the model's Coulomb friction forward (off: the paper's law), with this velocity
    /// band, rad/s (m/s); without a value, the model's velocity quantum (one encoder count per
    /// impedance period, at the joint).
    #[arg(long, value_name = "BAND", num_args = 0..=1, require_equals = true)]
    friction_compensation: Option<Option<f64>>,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Contact scenarios: the surfaces' static and dynamic friction coefficients,
    /// `MU_S,MU_D` (0 ≤ MU_D ≤ MU_S; default frictionless).
    #[arg(long, value_delimiter = ',')]
    friction: Option<Vec<f64>>,
    /// The mesh scenario's mesh, an OBJ or STL file in metres (default: a UV sphere of radius
    /// 3 cm, 960 triangles).
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Contact scenarios: render this scene file's objects (docs/scenes.md) instead of the
    /// scenario's own; the scenario gives the hand's path, placed from the start's task point,
    /// and only the checks that hold for any scene are made.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// The excite scenario's trajectory file (`hapticgen excite -o TRAJ.yaml`).
    #[arg(long)]
    trajectory: Option<PathBuf>,
    /// The simulated device: another model file with the same joints and task (its "true"
    /// masses, inertias and frictions), while the controller runs on MODEL's; default: the
    /// model itself. Any scenario (e.g. the model file of estimates against the device, then
    /// the identified one against it).
    #[arg(long)]
    plant: Option<PathBuf>,
}

#[derive(clap::Args)]
struct PilArgs {
    #[command(flatten)]
    run: SimulateArgs,
    /// The PIL image (default: `$HAPTICGEN_PIL_IMAGE`, else `<target dir>/images/<image>.pil.elf`
    /// as `scripts/firmware.sh --only pil` builds it).
    #[arg(long)]
    image: Option<PathBuf>,
    /// qemu-system-arm (default: the first on PATH).
    #[arg(long)]
    qemu: Option<PathBuf>,
    /// Also run `simulate` of the same scenario (DIR/simulate/trace.csv) and print the largest
    /// differences of the two traces (DIR/compare.csv: the differences over time).
    #[arg(long)]
    compare: bool,
    /// With --compare: fail unless the largest joint-angle difference is within this many
    /// encoder counts (motor side); with a rendered scene, unless every task coordinate is
    /// within this many counts mapped through |J(q0)| plus two grid spacings (docs/link.md).
    #[arg(long)]
    max_counts: Option<f64>,
    /// Fault test: stop sending sensor frames after this much simulated time, s; fails unless
    /// the firmware reaches its safe state within 10 ms of simulated time (its periods).
    #[arg(long)]
    stop_after: Option<f64>,
    /// Fault test: before every N-th sensor frame, send a copy with one bit flipped; fails
    /// unless the image dropped exactly those frames and missed no period because of them.
    #[arg(long)]
    corrupt_every: Option<u64>,
    /// Fault test: before every N-th sensor frame, send a burst of 96 random bytes (zeros among
    /// them) and a zero; fails unless the image dropped every frame of garbage (and every
    /// corrupted frame) and missed no period because of them.
    #[arg(long)]
    garbage_every: Option<u64>,
}

#[derive(clap::Args)]
struct ConnectArgs {
    /// Where the device is: `tcp:HOST:PORT` (e.g. the device image under QEMU with
    /// `-serial tcp:127.0.0.1:4500,server=on,wait=off`), `unix:PATH` (`-serial
    /// unix:PATH,server=on,wait=off`) or a serial device path (set its speed first, e.g.
    /// `stty -F /dev/ttyACM0 1000000 raw`).
    #[arg(long)]
    port: hapticgen_host::connect::Port,
    /// Target impedance on every task axis: `K,B` or `K,B,M` (N/m, N·s/m, kg).
    #[arg(long)]
    impedance: Option<String>,
    /// A scene file to load into the device (YAML `objects:` of `sphere`, `box`, `half_space`;
    /// docs/link.md); the device's other slots are emptied. Its moving objects are sent again
    /// every `--motion-period`.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// How often a moving object of the scene is sent again where it is by then, ms (each
    /// update is one `SetObject` frame of about 40 bytes per moving object).
    #[arg(long, default_value_t = 10.0)]
    motion_period: f64,
    /// Enable the bridges (heartbeats are sent from the start, every 2 ms).
    #[arg(long)]
    enable: bool,
    /// Clear a latched fault first (a device whose heartbeat was lost stays off until this).
    #[arg(long)]
    reset: bool,
    /// How long to stay connected, s.
    #[arg(long, default_value_t = 5.0)]
    duration: f64,
    /// Log every state frame to this CSV file (SI units; a row per impedance tick).
    #[arg(long)]
    log: Option<PathBuf>,
    /// Try the link's safety rules on the device first (enables it): garbage at full rate,
    /// heartbeat loss (safe state within 10 ms), no recovery without a reset; fails if one
    /// does not hold.
    #[arg(long)]
    check_safety: bool,
    /// No live status line.
    #[arg(long)]
    quiet: bool,
}

fn connect(args: ConnectArgs) -> Result<(), String> {
    use hapticgen_host::connect::{self as link, Event, Session};
    use hapticgen_protocol::HostMessage;
    if !(args.duration.is_finite() && args.duration >= 0.0) {
        return Err(format!("error: --duration must be a finite, non-negative time, got {}", args.duration));
    }
    if !(args.motion_period.is_finite() && args.motion_period >= 1.0) {
        return Err(format!("error: --motion-period must be at least 1 ms, got {}", args.motion_period));
    }
    let motion_period = std::time::Duration::from_secs_f64(args.motion_period * 1e-3);
    let impedance = args.impedance.as_deref().map(link::parse_impedance).transpose()?;
    let scene = args.scene.as_deref().map(link::load_scene).transpose()?;
    let mut session = Session::open(&args.port)?;
    let info = session.info;
    println!(
        "connected: protocol {}, {} joints, {} task axes, impedance loop {} Hz, rig name hash {:08x}",
        info.version, info.joints, info.task_dim, info.impedance_loop_hz, info.rig_name_hash
    );
    // The settings and the scene, sent after each Hello (again if the device starts afresh).
    let configure = |session: &mut Session| -> Result<(), String> {
        if let Some(settings) = impedance {
            session.send(&HostMessage::SetImpedance(settings))?;
        }
        if let Some(scene) = &scene {
            session.send_scene(scene)?;
        }
        Ok(())
    };
    configure(&mut session)?;
    if let Some(scene) = &scene {
        println!(
            "scene: {} objects rendered by the device (each answered), effect {:?}",
            scene.objects.len(),
            scene.effect
        );
        if !scene.moving.is_empty() {
            println!("scene: {} moving, sent again every {} ms", scene.moving.len(), args.motion_period);
        }
    }
    session.heartbeats(true);
    std::thread::sleep(link::HEARTBEAT_PERIOD * 3);
    if args.reset {
        session.send(&HostMessage::ResetFault)?;
    }
    if args.enable || args.check_safety {
        session.send(&HostMessage::Enable)?;
    }
    let mut failed = 0;
    if args.check_safety {
        for row in link::safety_check(&mut session)? {
            println!("{} {}: {}", if row.pass { "PASS" } else { "FAIL" }, row.what, row.measured);
            failed += usize::from(!row.pass);
        }
    }
    let mut log = match &args.log {
        Some(path) => {
            let mut writer =
                csv::Writer::from_path(path).map_err(|e| format!("error: {}: {e}", path.display()))?;
            writer
                .write_record(link::csv_header(&info))
                .map_err(|e| format!("error: {}: {e}", path.display()))?;
            Some(writer)
        }
        None => None,
    };
    let start = std::time::Instant::now();
    let deadline = start + std::time::Duration::from_secs_f64(args.duration);
    // The moving objects' time 0 (they were sent where they are then, and wait there through
    // the safety checks).
    let moving = scene.as_ref().filter(|scene| !scene.moving.is_empty());
    let mut next_motion = start + motion_period;
    let (mut frames, mut missing, mut resets) = (0u64, 0u64, 0u64);
    let mut first_tick = None;
    let mut last: Option<hapticgen_protocol::StateFrame> = None;
    let mut shown = start;
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        let now = std::time::Instant::now();
        if let Some(scene) = moving {
            if now >= next_motion {
                let time = now.duration_since(start).as_secs_f64();
                for (slot, object) in scene.moved_objects(time) {
                    session.send(&HostMessage::SetObject { slot, object })?;
                }
                // The next update on the period's grid (updates the link could not send in
                // time are skipped, not queued).
                while next_motion <= now {
                    next_motion += motion_period;
                }
            }
        }
        let wait = match moving {
            Some(_) => left.min(next_motion.saturating_duration_since(now)),
            None => left,
        };
        let event = match session.next(wait)? {
            Some(event) => event,
            None if moving.is_some() => continue,
            None => break,
        };
        let received = match event {
            Event::State(received) => received,
            // The answers to the moving objects' updates.
            Event::Scene(answer) => match scene.as_ref().and_then(|scene| link::refusal(scene, &answer)) {
                Some(error) => return Err(error),
                None => continue,
            },
            _ => continue,
        };
        let frame = received.frame;
        if let Some(previous) = &last {
            let was_enabled = previous.status & hapticgen_protocol::StateFrame::ENABLED != 0;
            if link::device_reset(previous, &frame, was_enabled) {
                // The device started again: it has forgotten the handshake, the settings and
                // the scene, and its bridges are off.
                println!(
                    "device reset (tick {} after {}): sending Hello, the settings and the scene again",
                    frame.tick, previous.tick
                );
                session.sync(link::HELLO_TIMEOUT)?;
                configure(&mut session)?;
                if args.enable || args.check_safety {
                    session.send(&HostMessage::Enable)?;
                }
                resets += 1;
                last = None;
                continue;
            }
            missing += link::missing_between(previous.tick, frame.tick);
        }
        first_tick.get_or_insert(frame.tick);
        frames += 1;
        if let (Some(writer), Some(path)) = (log.as_mut(), args.log.as_ref()) {
            let seconds = received.at.duration_since(start).as_secs_f64();
            writer
                .write_record(link::csv_row(&info, &frame, seconds))
                .map_err(|e| format!("error: {}: {e}", path.display()))?;
        }
        if !args.quiet && received.at.duration_since(shown) >= std::time::Duration::from_millis(100) {
            eprint!("\r{}   ", link::status_line(&info, &frame, frames, missing));
            shown = received.at;
        }
        last = Some(frame);
    }
    if !args.quiet {
        eprintln!();
    }
    if let (Some(mut writer), Some(path)) = (log, args.log.as_ref()) {
        writer.flush().map_err(|e| format!("error: {}: {e}", path.display()))?;
        println!("wrote {} ({frames} rows)", path.display());
    }
    let device_counters = session.device_counters;
    let host_dropped = session.host_dropped();
    let heartbeats = session.heartbeats_sent();
    session.close()?;
    println!(
        "{frames} state frames in {:.2} s (ticks {} to {}), {missing} missing; {heartbeats} heartbeats sent; host dropped \
         {host_dropped} frames{}",
        args.duration,
        first_tick.map_or("-".into(), |t| t.to_string()),
        last.map_or("-".into(), |f| f.tick.to_string()),
        device_counters.map_or(String::new(), |c| format!(
            "; device: {} frames received, {} dropped",
            c.frames,
            c.dropped()
        ))
    );
    if let Some(frame) = &last {
        println!("last: {}", link::status_line(&info, frame, frames, missing));
    }
    if resets > 0 {
        println!("the device started again {resets} times; each time it was sent Hello, the settings and the scene");
    }
    if failed > 0 {
        return Err(format!("error: {failed} of the link's safety checks failed"));
    }
    Ok(())
}

fn load(
    model_path: &std::path::Path,
    variant: Option<&str>,
) -> Result<hapticgen_codegen::CheckedModel, String> {
    hapticgen_codegen::load_file(model_path, &model_path.display().to_string(), variant)
        .map_err(|d| d.to_string())
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Report { model, variant, steps, no_zwidth, replay, output } => {
            let m = load(&model, variant.as_deref())?;
            let steps = steps.unwrap_or_else(|| hapticgen_host::design::default_steps(m.joints.len())).max(2);
            // Read before anything is written: a bad run leaves no report behind.
            let replay = replay.map(|run| hapticgen_host::replay::load(&m, &run)).transpose()?;
            if let Some(replay) = &replay {
                let scene = replay.scene.as_ref().map_or_else(
                    || format!("no {} beside it: no objects drawn", hapticgen_host::replay::SCENE_FILE),
                    |s| format!("objects drawn: {}", s.objects.len()),
                );
                eprintln!(
                    "report: replaying {} ({} rows as {} frames; {scene})",
                    replay.trace.display(),
                    replay.rows,
                    replay.frames.len()
                );
            }
            let summary =
                hapticgen_host::design_report::write_report(&m, steps, !no_zwidth, replay.as_ref(), &output)
                    .map_err(|e| format!("error: {e}"))?;
            println!(
                "{}: {}; wrote {}",
                model.display(),
                summary.describe(),
                output.join("summary.json").display()
            );
            Ok(())
        }
        Command::New { rig } => {
            let (path, written) =
                hapticgen_host::template::run_new(&rig).map_err(|e| format!("error: {e}"))?;
            for warning in &written.warnings {
                eprintln!("{warning}");
            }
            println!("{}: written; it passes `hapticgen check`", path.display());
            Ok(())
        }
        Command::Check { model, variant } => {
            let m = load(&model, variant.as_deref())?;
            // Without --variant, every variant is checked, not only the default one.
            if variant.is_none() {
                for other in m.variants.iter().filter(|v| Some(*v) != m.variant.as_ref()) {
                    load(&model, Some(other))?;
                }
            }
            let mech = hapticgen_codegen::derive(&m);
            let text = std::fs::read_to_string(&model).unwrap_or_default();
            // Virtual walls: passivity (warning) and stability (error) bounds, see
            // `hapticgen_codegen::check::stability`.
            if let Some(wall) = stability::check_wall(&m, &mech) {
                if let Some((error, d)) = wall.diagnostic(&model.display().to_string(), &text, &m) {
                    if error {
                        return Err(format!("error: {d}"));
                    }
                    eprintln!("warning: {d}");
                }
            }
            // The model as a device: gravity against the drives, masses, lengths and inertias
            // against the bodies' sizes, a closed chain's branch (`check::plausibility`).
            let plausible = plausibility::plausibility(&m, &mech, &text);
            let mut errors = Vec::new();
            for finding in &plausible.findings {
                let d = finding.diagnostic(&model.display().to_string(), &text, &m);
                match finding.severity {
                    plausibility::Severity::Error => errors.push(format!("error: {d}")),
                    plausibility::Severity::Warning => eprintln!("warning: {d}"),
                }
            }
            if !errors.is_empty() {
                return Err(errors.join("\n"));
            }

            // A closed chain also names its eliminated passive joints.
            let passive = match &m.analyses.closures {
                Some(c) => {
                    let closures = c.loops.len() + m.spatial_closures.len();
                    // A spatial chain's: in closed form, or by Newton's method and why.
                    let solver = match &c.spatial {
                        Some(s) if s.closed_form.is_some() => ", in closed form".to_string(),
                        Some(s) => format!(
                            ", by Newton's method at run time; no closed form: {}",
                            s.newton_reason.as_deref().unwrap_or("not a Delta")
                        ),
                        None => String::new(),
                    };
                    format!(
                        " (+{} passive, eliminated by {closures} closure{}{solver})",
                        m.passive.len(),
                        if closures == 1 { "" } else { "s" }
                    )
                }
                None => String::new(),
            };
            // Massless bodies are the crosses of universal and spherical joints (the loader
            // adds them for a joint written as one entry) and the bodies measured joints move
            // (their mass lumped on the body carrying them).
            let massless = m.bodies.iter().filter(|b| b.mass.is_zero()).count();
            let measured = match m.measured.len() {
                0 => String::new(),
                k => format!(
                    " (+{k} measured: {}, inputs of the frames)",
                    m.measured.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            };
            println!(
                "{}: ok: rig `{}`{}, {} joint{}{passive}{measured}, {} bodies{}, task dimension {}",
                model.display(),
                m.name,
                m.variant.as_ref().map(|v| format!(" (variant {v})")).unwrap_or_default(),
                m.joints.len(),
                if m.joints.len() == 1 { "" } else { "s" },
                m.bodies.len(),
                if massless > 0 { format!(" ({massless} of them massless)") } else { String::new() },
                m.task_dim()
            );
            if let Some(assembly) = &plausible.assembly {
                println!("{}: {}", model.display(), assembly.describe(&m));
            }
            Ok(())
        }
        Command::Generate { model, variant, scalar, fma, regressor, output } => {
            let m = load(&model, variant.as_deref())?;
            let scalar = match scalar {
                ScalarArg::F32 => Scalar::F32,
                ScalarArg::F64 => Scalar::F64,
            };
            let options = hapticgen_codegen::EmitOptions { fused_multiply_add: fma, regressor };
            let text = hapticgen_codegen::generate_model_with(m, scalar, options).file_text();
            write_or_print(output.as_deref(), &text)
        }
        Command::Eval { model, variant, q, qd, point, frame, measured, beyond_limits } => {
            let m = load(&model, variant.as_deref())?;
            let n = m.joints.len();
            if q.len() != n {
                return Err(format!("error: --q needs {n} values (one per joint), got {}", q.len()));
            }
            let qd = if qd.is_empty() { vec![0.0; n] } else { qd };
            if qd.len() != n {
                return Err(format!("error: --qd needs {n} values (one per joint), got {}", qd.len()));
            }
            let k = m.measured.len();
            let measured = if measured.is_empty() { vec![0.0; k] } else { measured };
            if measured.len() != k {
                return Err(format!(
                    "error: --measured needs {k} values (one per measured joint), got {}",
                    measured.len()
                ));
            }
            if let Some(bad) = q.iter().chain(&qd).chain(&measured).find(|v| !v.is_finite()) {
                return Err(format!("error: state values must be finite, got {bad}"));
            }
            if !beyond_limits {
                let limits = m
                    .joints
                    .iter()
                    .map(|j| (&j.name, j.kind, j.lower, j.upper))
                    .zip(&q)
                    // The measured joints' angles enter only a frame's evaluation.
                    .chain(
                        m.measured
                            .iter()
                            .filter(|_| frame.is_some())
                            .map(|j| (&j.name, j.kind, j.lower, j.upper))
                            .zip(&measured),
                    );
                for ((name, kind, lower, upper), &value) in limits {
                    if !(lower..=upper).contains(&value) {
                        let unit = match kind {
                            model::JointKind::Revolute => "rad",
                            model::JointKind::Prismatic => "m",
                        };
                        return Err(format!(
                            "error: joint `{name}` = {value} {unit} is outside its limits [{lower}, {upper}] {unit}{}; pass --beyond-limits to evaluate there anyway",
                            if unit == "rad" && value.abs() > std::f64::consts::TAU { " (degrees? --q takes radians)" } else { "" }
                        ));
                    }
                }
            }
            let mech = hapticgen_codegen::derive(&m);
            let selected = match &point {
                None => None,
                Some(name) => Some(mech.points.iter().find(|p| &p.name == name).ok_or_else(|| {
                    let names: Vec<&str> = mech.points.iter().map(|p| p.name.as_str()).collect();
                    format!("error: unknown point `{name}`; the model defines: {}", names.join(", "))
                })?),
            };
            let parameters = m.nominal_parameters();
            let state = eval::State { q: &q, qd: &qd, parameters: &parameters };
            if let Some(name) = &frame {
                let kin = mech.frames.iter().find(|f| &f.name == name).ok_or_else(|| {
                    let names: Vec<&str> = mech.frames.iter().map(|f| f.name.as_str()).collect();
                    if names.is_empty() {
                        format!("error: unknown frame `{name}`; the model defines no frames")
                    } else {
                        format!("error: unknown frame `{name}`; the model defines: {}", names.join(", "))
                    }
                })?;
                // The measured joints are the coordinates after the actuated ones (a model
                // with measured joints has no passive ones).
                let q_measured: Vec<f64> = q.iter().chain(&measured).copied().collect();
                let qd_measured = vec![0.0; q_measured.len()];
                let state = eval::State { q: &q_measured, qd: &qd_measured, parameters: &parameters };
                let values =
                    eval::try_evaluate_frame(&mech, &state, kin).map_err(|e| format!("error: {e}"))?;
                return print_json(&values);
            }
            let values = eval::try_evaluate(&mech, &state, selected).map_err(|e| format!("error: {e}"))?;
            print_json(&values)
        }
        Command::Stats { model, variant, json, fma, regressor } => {
            let m = load(&model, variant.as_deref())?;
            let options = hapticgen_codegen::EmitOptions { fused_multiply_add: fma, regressor };
            let generated = hapticgen_codegen::generate_model_with(m, Scalar::F64, options);
            if json {
                let map: serde_json::Map<String, serde_json::Value> = generated
                    .stats
                    .functions
                    .iter()
                    .map(|(name, c)| (name.clone(), serde_json::to_value(c).unwrap_or_default()))
                    .collect();
                println!("{}", serde_json::Value::Object(map));
            } else {
                println!(
                    "{:<40} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
                    "function", "add", "mul", "div", "sqrt", "trig", "neg", "fused"
                );
                for (name, c) in &generated.stats.functions {
                    println!(
                        "{:<40} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
                        name,
                        c.additions,
                        c.multiplications,
                        c.divisions,
                        c.square_roots,
                        c.trigonometric,
                        c.negations,
                        c.fused
                    );
                }
                let spatial = generated.mechanics.closures.as_ref().and_then(|c| c.spatial.as_ref());
                if spatial.is_some_and(|s| s.closed_form.is_some()) {
                    println!(
                        "note: each function above solves the loops in closed form first (three spheres, no\n\
                         Newton step); its counts include that"
                    );
                } else if let Some(spatial) = spatial {
                    // Its functions' counts leave out the loop solve, which is the runtime's.
                    println!(
                        "note: the functions above read the loops' solution; solving them is the runtime's\n\
                         (`hapticgen_runtime::loops::close_loops`, once per state): up to {} Newton steps, each\n\
                         `loop_constraints`, the passive angles' {p} sines and cosines (which the functions\n\
                         read from the solution) and a {p} × {p} LU factorisation; then `loop_actuated_jacobian` and\n\
                         {n} solves for `A`; with velocities `loop_convective` and one solve for `Ȧ q̇_a`\n\
                         (`C q̇`, `J̇ q̇`), and only for `C` itself `loop_jacobian_rates` and {n} solves for `Ȧ`",
                        spatial.newton_step_bound(),
                        p = spatial.passive,
                        n = spatial.actuated,
                    );
                }
            }
            Ok(())
        }
        Command::ImportUrdf { urdf, drive, output } => {
            let read = |p: &std::path::Path| {
                std::fs::read_to_string(p).map_err(|e| format!("error: cannot read {}: {e}", p.display()))
            };
            let text = read(&urdf)?;
            let drive = match &drive {
                Some(p) => read(p)?,
                None => hapticgen_codegen::urdf::DEFAULT_DRIVE.to_string(),
            };
            let display = urdf.display().to_string();
            let yaml = hapticgen_codegen::urdf::import(&text, &display, &drive).map_err(|d| d.to_string())?;
            // What was written must load: a bad drive template is reported against it.
            hapticgen_codegen::load(&model::Source { name: "<imported model>", text: &yaml }, None)
                .map_err(|d| d.to_string())?;
            write_or_print(output.as_deref(), &yaml)
        }
        Command::ExportUrdf { model, variant, output } => {
            let m = load(&model, variant.as_deref())?;
            let text = hapticgen_codegen::urdf::export(&m)
                .map_err(|e| format!("error: {}: {e}", model.display()))?;
            write_or_print(output.as_deref(), &text)
        }
        Command::Schema => {
            print!("{}", model::json_schema());
            Ok(())
        }
        Command::Simulate(args) => simulate(args),
        Command::Pil(args) => pil(args),
        Command::Connect(args) => connect(args),
        Command::Contact { model, variant, controller, friction: coefficients, mesh, push, only, output } => {
            let sim = Simulation::load(&model, variant.as_deref())?;
            let run = hapticgen_host::contact_report::ContactRun {
                law: law(controller),
                friction: friction(Some(&coefficients))?,
                mesh,
                push,
                only,
            };
            std::fs::create_dir_all(&output)
                .map_err(|e| format!("error: cannot create {}: {e}", output.display()))?;
            let (checks, summary) = hapticgen_host::contact_report::run_all(&sim, &run, &output)?;
            if checks.iter().all(|c| c.pass) {
                println!("{summary}");
                Ok(())
            } else {
                Err(summary)
            }
        }
        Command::Paper { output, quick } => {
            let summary = paper::run_all(&output, quick, true)?;
            println!("{summary}");
            Ok(())
        }
        Command::Excite {
            model,
            variant,
            period,
            harmonics,
            margin,
            speed_fraction,
            torque_fraction,
            evaluations,
            seed,
            output,
        } => {
            let settings = hapticgen_host::identify::excite::ExciteSettings {
                period,
                harmonics,
                position_margin: margin,
                speed_fraction,
                torque_fraction,
                evaluations,
                seed,
                ..Default::default()
            };
            let text = hapticgen_host::identify::commands::excite_command(
                &model,
                variant.as_deref(),
                &settings,
                &output,
            )?;
            println!("{text}");
            Ok(())
        }
        Command::Identify { model, variant, logs, validate, cutoff, measured_torque, report, output } => {
            use hapticgen_host::identify::fit::{FitSettings, TorqueSource};
            let torque = if measured_torque { TorqueSource::Measured } else { TorqueSource::Commanded };
            let settings = FitSettings { cutoff_hz: cutoff, torque, ..Default::default() };
            let identified = hapticgen_host::identify::commands::identify(
                &model,
                variant.as_deref(),
                &logs,
                validate.as_deref(),
                &settings,
            )?;
            let text = identified.describe();
            print!("{text}");
            // Everything is computed before anything is written.
            let written = output.as_ref().map(|_| identified.model_file(&model)).transpose()?;
            if let Some(dir) = report {
                let path = identified.write_report(&dir, &model)?;
                println!("wrote {} and a torque figure per joint", path.display());
            }
            if let (Some(path), Some((file, residual))) = (output, written) {
                std::fs::write(&path, file).map_err(|e| format!("error: {}: {e}", path.display()))?;
                println!(
                    "wrote {}: physically consistent, reproducing the identified base parameters to {:.1e} \
                     (relative, weighted by their σ)",
                    path.display(),
                    residual
                );
            }
            Ok(())
        }
        Command::Zwidth { model, variant, output, quick } => {
            let sim = Simulation::load(&model, variant.as_deref())?;
            let settings = if quick {
                hapticgen_host::zwidth::Sweep::quick()
            } else {
                hapticgen_host::zwidth::Sweep::full()
            };
            let z = hapticgen_host::zwidth::sweep(&sim, &settings)?;
            hapticgen_host::zwidth::write(&z, &model.display().to_string(), &output)?;
            println!("| B (N·s/m) | largest stable K, simulated (N/m) | stability bound 2(b + B)/T (N/m) |");
            for p in &z.boundary {
                println!("| {:.1} | {:.0} | {:.0} |", p.damping, p.stable_stiffness, p.stable_bound);
            }
            println!("wrote {}", output.join("zwidth.md").display());
            Ok(())
        }
        Command::Faults { model, variant, output } => {
            let sim = Simulation::load(&model, variant.as_deref())?;
            let results = hapticgen_host::faults::scenarios(&sim)
                .iter()
                .map(|f| hapticgen_host::faults::run(&sim, f))
                .collect::<Result<Vec<_>, String>>()?;
            let table = hapticgen_host::faults::table(&results);
            std::fs::create_dir_all(&output)
                .map_err(|e| format!("error: cannot create {}: {e}", output.display()))?;
            let path = output.join("faults.md");
            std::fs::write(&path, &table)
                .map_err(|e| format!("error: cannot write {}: {e}", path.display()))?;
            println!("{table}\nwrote {}", path.display());
            Ok(())
        }
    }
}

/// A run `simulate` and `pil` share: the model, its configuration, the scenario and whether
/// the start is singular.
struct Configured {
    sim: Simulation,
    cfg: hapticgen_host::sim::SimConfig,
    scenario: Scenario,
    singular_start: Option<f64>,
    /// A contact scenario's placement, for its checks.
    contact: Option<ContactSetup>,
}

fn configure(args: &SimulateArgs) -> Result<Configured, String> {
    let sim = Simulation::load(&args.model, args.variant.as_deref())?;
    for (name, value) in
        [("--kd", args.kd), ("--bd", args.bd), ("--md", args.md), ("--duration", args.duration)]
    {
        if let Some(v) = value {
            if !v.is_finite() || v < 0.0 {
                return Err(format!("error: {name} must be a finite, non-negative number, got {v}"));
            }
        }
    }
    if !(args.mass_scale.is_finite() && args.mass_scale > 0.0) {
        return Err(format!("error: --mass-scale must be positive, got {}", args.mass_scale));
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
        ScenarioArg::Excite => return Err("error: the excite scenario is run by excite_run".into()),
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
    let mut cfg = hapticgen_host::sim::SimConfig::new(start.clone());
    cfg.law = law(args.controller.ok_or("error: --controller is needed for this scenario")?);
    cfg.stiffness = args.kd.unwrap_or(kd);
    cfg.damping = args.bd.unwrap_or(bd);
    cfg.mass = args.md.unwrap_or(0.01);
    cfg.duration = args.duration.unwrap_or(5.0);
    cfg.effects = Effects::ALL.without(&args.without).map_err(|e| format!("error: --without: {e}"))?;
    cfg.plant_mass_scale = args.mass_scale;
    if let Some(path) = &args.plant {
        if args.mass_scale != 1.0 {
            return Err(
                "error: give --plant (another model file as the device) or --mass-scale, not both".into()
            );
        }
        let device = hapticgen_codegen::load_file(path, &path.display().to_string(), args.variant.as_deref())
            .map_err(|d| d.to_string())?;
        cfg.plant_model = Some(sim.device(&device)?);
    }
    cfg.seed = args.seed;
    cfg.singular_fallback = args.singular_fallback;
    cfg.spring_lead_time = args.spring_lead;
    cfg.friction_compensation = match args.friction_compensation {
        None => None,
        Some(None) => Some(sim.friction_compensation_band()),
        Some(Some(band)) if band.is_finite() && band >= 0.0 => Some(band),
        Some(Some(band)) => {
            return Err(format!("error: --friction-compensation: the band must be ≥ 0 rad/s, got {band}"))
        }
    };
    cfg.progress = true;
    let scene = match &args.scene {
        None => None,
        Some(_) if !matches!(scenario, Scenario::Contact(_)) => {
            return Err(
                "error: --scene needs a contact scenario (wall, slide, sphere, box-edges, thin-plate, \
                        mesh), whose hand path it keeps"
                    .into(),
            )
        }
        Some(path) => Some(hapticgen_host::scene::load(path)?),
    };
    let settings = ScenarioSettings {
        grid_spacing: args.grid,
        start: Some(start.clone()),
        friction: friction(args.friction.as_deref())?,
        mesh: args.mesh.as_deref().map(hapticgen_host::contact::mesh_file).transpose()?,
        scene: scene
            .as_ref()
            .map(|scene| hapticgen_host::scene::solids(scene, sim.task_dim()))
            .transpose()?,
        effect: scene.and_then(|scene| scene.effect),
        ..ScenarioSettings::default()
    };
    let contact = sim.apply_scenario(scenario, &settings, &mut cfg)?;
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
    std::fs::create_dir_all(&args.output)
        .map_err(|e| format!("error: cannot create {}: {e}", args.output.display()))?;
    Ok(Configured { sim, cfg, scenario, singular_start, contact })
}

/// The impedance law a `--controller` names.
fn law(controller: ControllerArg) -> ImpedanceLaw {
    match controller {
        ControllerArg::One => ImpedanceLaw::ForceFeedback,
        ControllerArg::TwoA => ImpedanceLaw::AccelerationFeedback,
        ControllerArg::TwoB => ImpedanceLaw::NaturalInertia,
        ControllerArg::Three => ImpedanceLaw::JacobianTranspose,
    }
}

/// `--friction MU_S,MU_D` as the two coefficients (none given: frictionless).
fn friction(values: Option<&[f64]>) -> Result<(f64, f64), String> {
    match values {
        None => Ok((0.0, 0.0)),
        Some(&[static_friction, dynamic_friction])
            if static_friction.is_finite() && (0.0..=static_friction).contains(&dynamic_friction) =>
        {
            Ok((static_friction, dynamic_friction))
        }
        Some(other) => Err(format!(
            "error: --friction takes MU_S,MU_D with 0 ≤ MU_D ≤ MU_S, got {}",
            other.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",")
        )),
    }
}

/// The plausibility findings of `hapticgen check` for a model about to be simulated, as
/// printed lines: a model the drives cannot hold is simulated all the same (its faults are what
/// the user may want to see), but the cause is named before the run.
fn plausibility_lines(model: &std::path::Path, variant: Option<&str>) -> Vec<String> {
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

fn simulate(args: SimulateArgs) -> Result<(), String> {
    let plausible = plausibility_lines(&args.model, args.variant.as_deref());
    for line in &plausible {
        eprintln!("{line}");
    }
    if matches!(args.scenario, ScenarioArg::Excite) || args.trajectory.is_some() {
        return excite_run(&args);
    }
    let Configured { sim, cfg, scenario, singular_start, contact } = configure(&args)?;
    let largest_det = sim.largest_jacobian_determinant();
    let singularity = |q: &[f64]| largest_det.map(|largest| sim.task_at(q).1.abs() / largest);
    let trace = sim.run(&cfg)?;
    hapticgen_host::output::write_csv(&trace, &args.output.join("trace.csv"))?;
    hapticgen_host::replay::write_scene(&cfg.reference, sim.task_dim(), &args.output)?;
    let figures = paper::trace_figures(&trace, &args.output)?;
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
        let checks = hapticgen_host::contact::checks(setup, &trace, setup.contact.name());
        let table = hapticgen_host::report::table(&checks);
        print!("{table}");
        std::fs::write(args.output.join("checks.md"), &table)
            .map_err(|e| format!("error: cannot write {}: {e}", args.output.join("checks.md").display()))?;
        let failures = hapticgen_host::report::failures(&checks);
        if !failures.is_empty() {
            return Err(format!("{}error: {} contact check(s) failed", failures, failures.lines().count()));
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

/// `simulate --scenario excite`: the identification run (hapticgen_host::identify).
fn excite_run(args: &SimulateArgs) -> Result<(), String> {
    if !matches!(args.scenario, ScenarioArg::Excite) {
        return Err("error: --trajectory belongs to the excite scenario (--scenario excite)".into());
    }
    let trajectory =
        args.trajectory.as_deref().ok_or("error: the excite scenario needs --trajectory TRAJ.yaml")?;
    let sim = Simulation::load(&args.model, args.variant.as_deref())?;
    let mut cfg = hapticgen_host::sim::SimConfig::new(sim.home());
    cfg.effects = Effects::ALL.without(&args.without).map_err(|e| format!("error: --without: {e}"))?;
    cfg.seed = args.seed;
    if let Some(duration) = args.duration {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(format!("error: --duration must be a positive number of seconds, got {duration}"));
        }
    }
    let run = hapticgen_host::identify::commands::ExciteRun {
        trajectory,
        plant: args.plant.as_deref(),
        cfg,
        duration: args.duration,
        output: &args.output,
    };
    let text =
        hapticgen_host::identify::commands::excite_run(&sim, &args.model, args.variant.as_deref(), run)?;
    print!("{text}");
    Ok(())
}

fn pil(args: PilArgs) -> Result<(), String> {
    let Configured { sim, cfg, scenario: _, singular_start: _, contact: _ } = configure(&args.run)?;
    let run = &args.run;
    // The variant applied: the one asked for, else the model's default.
    let name = hapticgen_host::pil::image_name(&run.model, sim.model.variant.as_deref())?;
    let image = hapticgen_host::pil::locate_image(&name, args.image.as_deref())?;
    let qemu = hapticgen_host::pil::locate_qemu(args.qemu.as_deref())?;
    let period = 1.0 / f64::from(sim.data.current_loop_hz);
    if let Some(t) = args.stop_after {
        if !(t.is_finite() && t >= 0.0) {
            return Err(format!("error: --stop-after must be a finite, non-negative time, got {t}"));
        }
    }
    let target = PilTarget {
        qemu,
        image: image.clone(),
        name: name.clone(),
        log: run.output.join("qemu.out"),
        stop_after: args.stop_after.map(|t| (t / period).round() as u64),
        corrupt_every: args.corrupt_every,
        garbage_every: args.garbage_every,
    };
    eprintln!("pil: image {} ({name}) under {}", image.display(), target.qemu.display());
    let (trace, report) = sim.run_pil(&cfg, &target)?;
    hapticgen_host::output::write_csv(&trace, &run.output.join("trace.csv"))?;
    let figures = paper::trace_figures(&trace, &run.output)?;
    println!(
        "simulated {:.2} s of {} in {:.2} s ({:.2}× real time), controller: firmware `{name}` under QEMU; wrote {} and \
         {} figures",
        trace.duration(),
        run.model.display(),
        trace.wall_seconds,
        trace.duration() / trace.wall_seconds.max(1e-9),
        run.output.join("trace.csv").display(),
        figures
    );
    for line in &report.lines {
        println!("  {line}");
    }
    if let Some((t, fault)) = &trace.fault {
        println!("note: the firmware's safety monitor latched {fault} at t = {t:.3} s");
    }
    let mut failures = Vec::new();
    if let Some(stop) = target.stop_after {
        // The host went silent after `stop` periods: the image must have reached its safe state
        // within 10 ms of its own (simulated) time.
        match report.value("PIL_SAFE", None, "us") {
            Some(us) => {
                let missed = report.value("PIL_SAFE", None, "missed_periods").unwrap_or(-1);
                println!(
                    "fault test: host silent after {stop} periods ({:.3} s); safe state after {missed} periods \
                     without a sensor frame = {:.2} ms (bound 10 ms)",
                    stop as f64 * period,
                    us as f64 / 1000.0
                );
                if us > 10_000 {
                    failures.push(format!("the safe state took {:.2} ms, over 10 ms", us as f64 / 1000.0));
                }
            }
            None => failures.push("the firmware did not report reaching its safe state (PIL_SAFE)".into()),
        }
    }
    if args.corrupt_every.is_some() || args.garbage_every.is_some() {
        let dropped = report.value("PIL_DONE", None, "dropped_frames").unwrap_or(-1);
        let missed = report.value("PIL_DONE", None, "missed").unwrap_or(-1);
        let silent = report.value("PIL_SAFE", None, "missed_periods").unwrap_or(0);
        let bad = report.corrupted + report.garbage_frames;
        println!(
            "fault test: {} sensor frames sent with one bit flipped and {} frames of random bytes; the image \
             dropped {dropped} frames and missed {} periods because of them",
            report.corrupted,
            report.garbage_frames,
            missed - silent
        );
        if dropped != bad as i64 || missed != silent {
            failures.push(format!(
                "{} corrupted frames and {} frames of garbage sent, {dropped} dropped, {} periods missed",
                report.corrupted,
                report.garbage_frames,
                missed - silent
            ));
        }
    }
    if args.compare {
        let reference = sim.run(&cfg)?;
        std::fs::create_dir_all(run.output.join("simulate"))
            .map_err(|e| format!("error: cannot create {}: {e}", run.output.join("simulate").display()))?;
        hapticgen_host::output::write_csv(&reference, &run.output.join("simulate/trace.csv"))?;
        let comparison = compare_traces(&trace, &reference, args.stop_after);
        let rad_per_count: Vec<f64> = sim.model.joints.iter().map(|j| j.drive.count_size()).collect();
        println!("PIL vs simulate of the same scenario (every {:.1} ms):", 1000.0 * comparison.sample_period);
        for (column, (difference, t)) in &comparison.largest {
            let counts = column
                .strip_prefix('q')
                .filter(|rest| !rest.starts_with('d'))
                .and_then(|j| j.parse::<usize>().ok())
                .and_then(|j| rad_per_count.get(j))
                .map(|per| format!(" = {:.2} encoder counts", difference / per));
            println!(
                "  largest |Δ{column}| = {difference:.3e} at t = {t:.4} s{}",
                counts.unwrap_or_default()
            );
        }
        write_comparison(&comparison, &run.output.join("compare.csv"))?;
        if let Some(limit) = args.max_counts {
            let before = failures.len();
            if let hapticgen_host::sim::Reference::Scene { grid_spacing, .. } = &cfg.reference {
                // A rendered scene: the rule of the firmware check (docs/firmware.md, `TOL x`):
                // the counts mapped to the task through |J(q0)|, plus two grid spacings (after
                // a contact the proxies may rest on neighbouring grid nodes); joint angles are
                // not compared (a different node is a different pose).
                let jacobian = sim.jacobian_at(&cfg.initial_q);
                let through = jacobian
                    .iter()
                    .map(|row| row.iter().zip(&rad_per_count).map(|(a, per)| a.abs() * per).sum::<f64>())
                    .fold(0.0, f64::max);
                let bound = limit * through + 2.0 * grid_spacing;
                for (column, (difference, t)) in &comparison.largest {
                    if column.starts_with('x') && !column.starts_with("xp") && *difference > bound {
                        failures.push(format!(
                            "|Δ{column}| = {:.1} µm at t = {t:.4} s, over the bound of {:.1} µm",
                            difference * 1e6,
                            bound * 1e6
                        ));
                    }
                }
                if failures.len() == before {
                    println!(
                        "check: every task coordinate within {:.1} µm of simulate ({limit} counts through |J(q0)| \
                         and two grid spacings)",
                        bound * 1e6
                    );
                }
            } else {
                for (j, per) in rad_per_count.iter().enumerate() {
                    let name = format!("q{j}");
                    if let Some((difference, t)) =
                        comparison.largest.iter().find(|(c, _)| *c == name).map(|(_, d)| *d)
                    {
                        if difference > limit * per {
                            failures.push(format!(
                                "|Δ{name}| = {:.2} counts at t = {t:.4} s, over the bound of {limit} counts",
                                difference / per
                            ));
                        }
                    }
                }
                if failures.len() == before {
                    println!("check: every joint within {limit} encoder counts of simulate");
                }
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.iter().map(|f| format!("FAIL pil: {f}")).collect::<Vec<_>>().join("\n"))
    }
}

/// The largest absolute difference per column of two traces of the same run, and when.
struct Comparison {
    sample_period: f64,
    /// `(column, (largest |difference|, time))`, in the traces' column order (time excluded).
    largest: Vec<(String, (f64, f64))>,
    /// Time and every column's difference, per row.
    rows: Vec<Vec<f64>>,
    columns: Vec<String>,
}

fn compare_traces(
    pil: &hapticgen_host::sim::Trace,
    reference: &hapticgen_host::sim::Trace,
    until: Option<f64>,
) -> Comparison {
    // Every column but time, the HIP (`xh*`) and the time the proxy was rendered (`tr`), which
    // the firmware does not report.
    let compared: Vec<usize> = (1..pil.columns.len())
        .filter(|&i| !pil.columns[i].starts_with("xh") && pil.columns[i] != "tr")
        .collect();
    let columns: Vec<String> = compared.iter().map(|&i| pil.columns[i].clone()).collect();
    let mut largest: Vec<(String, (f64, f64))> = columns.iter().map(|c| (c.clone(), (0.0, 0.0))).collect();
    let mut rows = Vec::new();
    for (a, b) in pil.rows.iter().zip(&reference.rows) {
        let t = a[0];
        if until.is_some_and(|stop| t > stop) {
            break;
        }
        let mut row = vec![t];
        for (slot, &i) in compared.iter().enumerate() {
            let (x, y) = (a.get(i).copied().unwrap_or(f64::NAN), b.get(i).copied().unwrap_or(f64::NAN));
            let d = (x - y).abs();
            row.push(x - y);
            if d > largest[slot].1 .0 {
                largest[slot].1 = (d, t);
            }
        }
        rows.push(row);
    }
    let sample_period = pil.rows.get(1).map_or(0.0, |r| r[0]) - pil.rows.first().map_or(0.0, |r| r[0]);
    Comparison { sample_period, largest, rows, columns }
}

fn write_comparison(comparison: &Comparison, path: &std::path::Path) -> Result<(), String> {
    let mut text = String::from("t");
    for c in &comparison.columns {
        text.push_str(&format!(",d{c}"));
    }
    text.push('\n');
    for row in &comparison.rows {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:.9e}")).collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    std::fs::write(path, text).map_err(|e| format!("error: cannot write {}: {e}", path.display()))
}

/// `|det J|` under this fraction of its largest value over the joint limits is singular.
const SINGULAR: f64 = 0.02;

/// `--start`: one coordinate per joint, within the joint's limits.
fn start_pose(sim: &Simulation, q: &[f64]) -> Result<Vec<f64>, String> {
    let joints = &sim.model.joints;
    if q.len() != joints.len() {
        return Err(format!("error: --start needs {} joint coordinates, got {}", joints.len(), q.len()));
    }
    for (joint, &value) in joints.iter().zip(q) {
        if !(value.is_finite() && joint.lower <= value && value <= joint.upper) {
            return Err(format!(
                "error: --start: joint `{}` at {value} is outside its limits [{}, {}]",
                joint.name, joint.lower, joint.upper
            ));
        }
    }
    Ok(q.to_vec())
}

/// The first sample of a run (after the start) at a singular pose, with its time and joints.
fn first_singular_sample(
    sim: &Simulation,
    trace: &hapticgen_host::sim::Trace,
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

fn format_pose(q: &[f64]) -> String {
    let parts: Vec<String> = q.iter().map(|v| format!("{v:.3}")).collect();
    format!("({}) rad", parts.join(", "))
}

/// Writes `text` to `path`, or to standard output without one.
fn write_or_print(path: Option<&std::path::Path>, text: &str) -> Result<(), String> {
    match path {
        Some(path) => {
            std::fs::write(path, text).map_err(|e| format!("error: cannot write {}: {e}", path.display()))
        }
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

/// Prints `value` as one line of JSON, every negative zero as `0.0`.
fn print_json(value: &impl serde::Serialize) -> Result<(), String> {
    println!("{}", hapticgen_host::output::to_json(value, false).map_err(|e| format!("error: {e}"))?);
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{message}");
            ExitCode::FAILURE
        }
    }
}
