//! The command line's grammar: the clap types [`Cli`] and [`Command`] with each command's
//! arguments. Their doc comments are the `--help` texts; [`super::run`] dispatches a parsed
//! [`Cli`] to the commands' modules.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

/// The command line: one subcommand.
#[derive(Parser)]
#[command(
    name = "hapticgen",
    version,
    about = "Generate specialised dynamics and control code for haptic rigs"
)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// `generate --scalar`: the scalar type of the generated code.
#[derive(Clone, Copy, ValueEnum)]
pub enum ScalarArg {
    // No doc comments on the values: clap would list them, one line each, in `--help`.
    #[allow(missing_docs)]
    F32,
    #[allow(missing_docs)]
    F64,
}

/// The commands, each with its arguments (the doc comments are their `--help` texts).
#[derive(Subcommand)]
pub enum Command {
    /// Write a commented starting model file for a Delta, a five-bar or a serial arm from a
    /// few named dimensions, masses and motor data; it passes `check` as written.
    New {
        /// The kind of rig.
        #[command(subcommand)]
        rig: crate::template::NewRig,
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
    Eval(EvalArgs),
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
    Contact(ContactArgs),
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
    Excite(ExciteArgs),
    /// Identify the base parameters of a model from excitation logs (weighted least squares on
    /// the base regressor); prints them with their standard deviations.
    Identify(IdentifyArgs),
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

/// `--controller`: the impedance law, one of the paper's controllers.
#[derive(Clone, Copy, ValueEnum)]
pub enum ControllerArg {
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

/// `simulate --scenario`: what the simulated operator does.
#[derive(Clone, Copy, ValueEnum)]
pub enum ScenarioArg {
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

/// The arguments of `simulate` (and of `pil`, which runs the same scenario).
#[derive(clap::Args)]
pub struct SimulateArgs {
    /// The model file.
    pub model: PathBuf,
    /// The variant (default: the model's `default_variant`).
    #[arg(long)]
    pub variant: Option<String>,
    /// The impedance controller (every scenario but `excite`, which tracks in joint space).
    #[arg(long, value_enum, required_unless_present = "trajectory")]
    pub controller: Option<ControllerArg>,
    /// Desired stiffness K_d (default per scenario: 1 for a step, the model's wall stiffness
    /// or 1500 for rendering, 100 for singularity).
    #[arg(long)]
    pub kd: Option<f64>,
    /// Desired damping B_d (default per scenario: 0.01, wall damping or 5, 2).
    #[arg(long)]
    pub bd: Option<f64>,
    /// Desired mass M_d (Controllers 1 and 2a; default 0.01).
    #[arg(long)]
    pub md: Option<f64>,
    /// The scenario.
    #[arg(long, value_enum)]
    pub scenario: ScenarioArg,
    /// Start pose: the joint coordinates, rad (or m), comma-separated (default: the middle of
    /// every joint's limits, which for a joint with symmetric limits is 0: a serial arm then
    /// starts stretched out, a singular pose).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub start: Option<Vec<f64>>,
    /// Simulated time, s (default 5; tracing scenarios run at least one lap).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Output directory.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Effects to switch off, comma-separated: friction, backlash, encoder, sensor,
    /// saturation, electrics, or all.
    #[arg(long, default_value = "")]
    pub without: String,
    /// Factor on the plant's body masses (model mismatch; the controller keeps the model's).
    #[arg(long, default_value_t = 1.0)]
    pub mass_scale: f64,
    /// Free-space anti-drift grid spacing, m (default: the model's rendering.grid_spacing).
    #[arg(long)]
    pub grid: Option<f64>,
    /// |det J| below which Controllers 1 and 2 fall back to Controller 3 (0: never).
    #[arg(long, default_value_t = 0.0)]
    pub singular_fallback: f64,
    /// Lead time of the spring term, s: compensates the sampled loop's delay (0: the paper's law).
    #[arg(long, default_value_t = 0.0)]
    pub spring_lead: f64,
    /// Feed the model's Coulomb friction forward (off: the paper's law), with this velocity
    /// band, rad/s (m/s); without a value, the model's velocity quantum (one encoder count per
    /// impedance period, at the joint).
    #[arg(long, value_name = "BAND", num_args = 0..=1, require_equals = true)]
    pub friction_compensation: Option<Option<f64>>,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Contact scenarios: the surfaces' static and dynamic friction coefficients,
    /// `MU_S,MU_D` (0 ≤ MU_D ≤ MU_S; default frictionless).
    #[arg(long, value_delimiter = ',')]
    pub friction: Option<Vec<f64>>,
    /// The mesh scenario's mesh, an OBJ or STL file in metres (default: a UV sphere of radius
    /// 3 cm, 960 triangles).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Contact scenarios: render this scene file's objects (docs/scenes.md) instead of the
    /// scenario's own; the scenario gives the hand's path, placed from the start's task point,
    /// and only the checks that hold for any scene are made.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// The excite scenario's trajectory file (`hapticgen excite -o TRAJ.yaml`).
    #[arg(long)]
    pub trajectory: Option<PathBuf>,
    /// The simulated device: another model file with the same joints and task (its "true"
    /// masses, inertias and frictions), while the controller runs on MODEL's; default: the
    /// model itself. Any scenario (e.g. the model file of estimates against the device, then
    /// the identified one against it).
    #[arg(long)]
    pub plant: Option<PathBuf>,
}

/// The arguments of `pil`: those of `simulate` and the image, QEMU and the fault tests.
#[derive(clap::Args)]
pub struct PilArgs {
    /// The run, as `simulate` takes it.
    #[command(flatten)]
    pub run: SimulateArgs,
    /// The PIL image (default: `$HAPTICGEN_PIL_IMAGE`, else `<target dir>/images/<image>.pil.elf`
    /// as `scripts/firmware.sh --only pil` builds it).
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// The line of targets/firmware/variants.txt the image was built from (default: the line
    /// whose model file has the model's file name and variant); for a model file no line names,
    /// such as an identified one built in with `HAPTICGEN_FW_MODEL` (docs/firmware.md).
    #[arg(long)]
    pub image_name: Option<String>,
    /// qemu-system-arm (default: the first on PATH).
    #[arg(long)]
    pub qemu: Option<PathBuf>,
    /// Also run `simulate` of the same scenario (DIR/simulate/trace.csv) and print the largest
    /// differences of the two traces (DIR/compare.csv: the differences over time).
    #[arg(long)]
    pub compare: bool,
    /// With --compare: fail unless the largest joint-angle difference is within this many
    /// encoder counts (motor side); with a rendered scene, unless every task coordinate is
    /// within this many counts mapped through |J(q0)| plus two grid spacings (docs/link.md).
    #[arg(long)]
    pub max_counts: Option<f64>,
    /// Fault test: stop sending sensor frames after this much simulated time, s; fails unless
    /// the firmware reaches its safe state within 10 ms of simulated time (its periods).
    #[arg(long)]
    pub stop_after: Option<f64>,
    /// Fault test: before every N-th sensor frame, send a copy with one bit flipped; fails
    /// unless the image dropped exactly those frames and missed no period because of them.
    #[arg(long)]
    pub corrupt_every: Option<u64>,
    /// Fault test: before every N-th sensor frame, send a burst of 96 random bytes (zeros among
    /// them) and a zero; fails unless the image dropped every frame of garbage (and every
    /// corrupted frame) and missed no period because of them.
    #[arg(long)]
    pub garbage_every: Option<u64>,
}

/// The arguments of `connect`.
#[derive(clap::Args)]
pub struct ConnectArgs {
    /// Where the device is: `tcp:HOST:PORT` (e.g. the device image under QEMU with
    /// `-serial tcp:127.0.0.1:4500,server=on,wait=off`), `unix:PATH` (`-serial
    /// unix:PATH,server=on,wait=off`) or a serial device path (set its speed first, e.g.
    /// `stty -F /dev/ttyACM0 1000000 raw`).
    #[arg(long)]
    pub port: crate::connect::Port,
    /// Target impedance on every task axis: `K,B` or `K,B,M` (N/m, N·s/m, kg).
    #[arg(long)]
    pub impedance: Option<String>,
    /// A scene file to load into the device (YAML `objects:` of `sphere`, `box`, `half_space`;
    /// docs/link.md); the device's other slots are emptied. Its moving objects are sent again
    /// every `--motion-period`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// How often a moving object of the scene is sent again where it is by then, ms (each
    /// update is one `SetObject` frame of about 40 bytes per moving object).
    #[arg(long, default_value_t = 10.0)]
    pub motion_period: f64,
    /// Enable the bridges (heartbeats are sent from the start, every 2 ms).
    #[arg(long)]
    pub enable: bool,
    /// Clear a latched fault first (a device whose heartbeat was lost stays off until this).
    #[arg(long)]
    pub reset: bool,
    /// How long to stay connected, s (default 5); with `--excite`, how long the excitation
    /// plays, its blend included, in the device's time (default: the blend and four periods,
    /// as `simulate --scenario excite`).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Log every state frame to this CSV file (SI units; a row per impedance tick); with
    /// `--excite`, the identification log `hapticgen identify` reads instead.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Try the link's safety rules on the device first (enables it): garbage at full rate,
    /// heartbeat loss (safe state within 10 ms), no recovery without a reset; fails if one
    /// does not hold.
    #[arg(long)]
    pub check_safety: bool,
    /// Play this identification trajectory (`hapticgen excite -o TRAJ.yaml`) on the device,
    /// from where it is, and write the identification log of it to `--log` (the columns of
    /// `simulate --scenario excite`); enables the device. Needs `--model` and `--log`.
    #[arg(
        long,
        value_name = "TRAJ.yaml",
        requires_all = ["model", "log"],
        conflicts_with_all = ["scene", "check_safety", "impedance"]
    )]
    pub excite: Option<PathBuf>,
    /// The device's model file (with `--excite`): its joints, gears, encoders and torque
    /// constants turn the state stream into joint angles and torques.
    #[arg(long, requires = "excite")]
    pub model: Option<PathBuf>,
    /// The model's variant (with `--excite`).
    #[arg(long, requires = "excite")]
    pub variant: Option<String>,
    /// The joint angles (rad, or m) where the device's encoders read 0 (with `--excite`);
    /// default: the start pose of the firmware image of `--model` (targets/firmware/variants.txt),
    /// which the device must then be.
    #[arg(long, requires = "excite", value_delimiter = ',', allow_negative_numbers = true)]
    pub home: Option<Vec<f64>>,
    /// The line of targets/firmware/variants.txt whose start pose is the home (with `--excite`,
    /// without `--home`); default: the line whose model file has `--model`'s file name, which an
    /// identified file has not.
    #[arg(long, requires = "excite", conflicts_with = "home")]
    pub image_name: Option<String>,
    /// No live status line.
    #[arg(long)]
    pub quiet: bool,
}

/// The arguments of `contact`.
#[derive(clap::Args)]
pub struct ContactArgs {
    /// The model file (3 task coordinates).
    pub model: PathBuf,
    /// The variant.
    #[arg(long)]
    pub variant: Option<String>,
    /// The impedance controller.
    #[arg(long, value_enum, default_value = "jacobian-transpose")]
    pub controller: ControllerArg,
    /// The static and dynamic friction coefficients of the run with friction.
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.4")]
    pub friction: Vec<f64>,
    /// One more mesh run on this OBJ or STL file (metres), e.g. scenes/meshes/knob.obj.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// How far the hand presses into a surface, m (at most 0.02).
    #[arg(long, default_value_t = 0.01)]
    pub push: f64,
    /// Only these runs, comma-separated (wall, slide, slide-friction, sphere, box-edges,
    /// thin-plate, mesh, and mesh-NAME for --mesh NAME.obj).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Output directory.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// The arguments of `excite`.
#[derive(clap::Args)]
pub struct ExciteArgs {
    /// The model file.
    pub model: PathBuf,
    /// The variant (default: the model's `default_variant`).
    #[arg(long)]
    pub variant: Option<String>,
    /// Period of the series, s.
    #[arg(long, default_value_t = 10.0)]
    pub period: f64,
    /// Harmonics per joint.
    #[arg(long, default_value_t = 5)]
    pub harmonics: usize,
    /// Margin inside each joint's limits, fraction of its range.
    #[arg(long, default_value_t = 0.1)]
    pub margin: f64,
    /// Largest drive speed, fraction of its no-load speed.
    #[arg(long, default_value_t = 0.5)]
    pub speed_fraction: f64,
    /// Largest drive torque, fraction of its limit.
    #[arg(long, default_value_t = 0.8)]
    pub torque_fraction: f64,
    /// Candidate trajectories the search evaluates.
    #[arg(long, default_value_t = 1500)]
    pub evaluations: usize,
    /// Seed of the search.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The trajectory file to write.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// The arguments of `identify`.
#[derive(clap::Args)]
pub struct IdentifyArgs {
    /// The model file.
    pub model: PathBuf,
    /// The variant (default: the model's `default_variant`).
    #[arg(long)]
    pub variant: Option<String>,
    /// An excitation log (`simulate --scenario excite` writes DIR/log.csv); repeatable.
    #[arg(long = "log", required = true)]
    pub logs: Vec<PathBuf>,
    /// A second log to validate the identified model on (torque prediction error).
    #[arg(long)]
    pub validate: Option<PathBuf>,
    /// Cutoff of the zero-phase low-pass filter, Hz.
    #[arg(long, default_value_t = 15.0)]
    pub cutoff: f64,
    /// Fit the torque of the measured currents (the log's tau_* columns) instead of the
    /// commanded torque (tau_cmd_*); see docs/identification.md.
    #[arg(long)]
    pub measured_torque: bool,
    /// Write a report into this directory: identification.md (the parameter table with σ,
    /// the fit's figures, and each joint's measured torque against the torque the model
    /// file's and the identified parameters predict) and those figures as SVG and PNG.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Write the identified model file here: the input file with physically consistent
    /// masses, centres of mass, inertias and frictions, every changed value marked.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// The device's true model file, where it is known (a simulated device, `simulate --plant`):
    /// print how far the identification is from it (D, C q̇, g at 100 random states, each
    /// friction parameter, the validation torque) and fail if a figure is over its bound
    /// (2 % of the norm, 10 %, 5 %).
    #[arg(long, value_name = "TRUE.yaml")]
    pub truth: Option<PathBuf>,
}

/// The arguments of `eval`.
#[derive(clap::Args)]
pub struct EvalArgs {
    /// The model file.
    pub model: PathBuf,
    /// The variant.
    #[arg(long)]
    pub variant: Option<String>,
    /// Joint coordinates, comma-separated.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub q: Vec<f64>,
    /// Joint velocities, comma-separated (default zero).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub qd: Vec<f64>,
    /// Use this named point instead of the task coordinates for p, J, J̇.
    #[arg(long)]
    pub point: Option<String>,
    /// Print this named frame's rotation matrix `R` and angular-velocity Jacobian
    /// `J_omega` instead.
    #[arg(long, conflicts_with = "point")]
    pub frame: Option<String>,
    /// With --frame: the measured joints' angles, comma-separated (default zero).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, requires = "frame")]
    pub measured: Vec<f64>,
    /// Evaluate even where the state is outside the joints' limits (the values are still
    /// refused where a closed chain's loops cannot close or a value is not finite).
    #[arg(long)]
    pub beyond_limits: bool,
}
