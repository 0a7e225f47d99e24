//! hapticgen's side of the side-by-side benchmark against Pinocchio
//! (`bench/pinocchio-side-by-side.sh`, not part of the test command).
//!
//! ```text
//! pinocchio_side_by_side urdf   MODEL VARIANT|- OUT      # the URDF Pinocchio loads
//! pinocchio_side_by_side states MODEL VARIANT|- OUT      # the states both sides use
//! pinocchio_side_by_side check  MODEL VARIANT|- STATES PINOCCHIO_RESULTS
//! pinocchio_side_by_side time   MODEL VARIANT|- STATES
//! ```
//!
//! MODEL is a shipped model file relative to the workspace root (`models/phantom_3dof.yaml`):
//! the code timed is what this crate's build script generates from it (f64, without fused
//! multiply-adds), so the benchmark follows the model file and the generator, not a copy of
//! generated code.
//!
//! `urdf` writes what `hapticgen export-urdf` writes for a serial model
//! (`hapticgen_codegen::urdf::export`). For a spatial closed chain, which `export-urdf` refuses
//! (a URDF cannot state the loops), it writes the open tree the loops were cut into
//! (`hapticgen_codegen::urdf::export_open_tree`: every joint, the passive ones included); what
//! closes the loops goes into the states file.
//!
//! `states` writes the joint names, gravity, rotor inertias `N²·J_m` (Pinocchio's armature),
//! the task point's URDF frame and the states, in a plain text format that
//! `bench/pinocchio/side_by_side.cpp` reads: for a serial model 64 random states within the
//! joint limits (velocities in ±2); for a spatial closed chain also the open tree's coordinates
//! (actuated first), the assembly its Newton's method starts from (the middle of the actuated
//! ranges, the file's `assembly` angles), the generated code's loop-solver bounds and the cut
//! closures, and 1,000 states along a smooth closed trajectory of the actuated coordinates
//! inside their ranges ([`trajectory`]), so that each state's loop solve starts, on both sides,
//! from the previous state's solution, as in a control loop.
//!
//! `check` compares Pinocchio's D, C·q̇ + g, g, p, J and J̇·q̇ at every state (all three ways the
//! C++ program computes them) with the generated functions and the fused `terms`: every entry
//! must agree to 1e-9 relative to the quantity's largest entry (no absolute floor). It exits
//! with status 1 otherwise.
//!
//! `time` prints `KEY NS` lines: nanoseconds per call of each generated function and of
//! `terms`, the best of 25 batches of 2,000 calls cycling over the states (as the C++ side). A
//! closed chain's functions are called as a user calls them: each solves the loops at its state
//! (the Falcon-like Delta's in closed form).
//!
//! `time-newton` (the Falcon-like Delta only) times the same rig generated with its loops
//! solved by Newton's method instead (`CheckedModel::with_loops_solved_numerically`, the solver
//! of every other spatial chain: `hapticgen_runtime::loops::close_loops`, from the solution of
//! the state before; functions called at the same state reuse it), and `loop-steps` prints the
//! mean number of Newton steps that rig's loop solve takes per state along the states.

use std::hint::black_box;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use hapticgen_codegen::dynamics::spatial_loops::{SpatialLoops, WARM_START_RADIUS};
use hapticgen_codegen::model::{Model, TaskSpec};
use hapticgen_codegen::urdf;
use hapticgen_codegen::CheckedModel;
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_tests::check::random_state;
use hapticgen_tests::{visit_all, workspace_root, RigInfo, RigVisitor};
use rand::rngs::SmallRng;
use rand::SeedableRng;

/// Random states written by `states` for a serial model.
const STATES: usize = 64;
/// States along the closed trajectory written by `states` for a closed chain.
const TRAJECTORY_STATES: usize = 1000;
/// Calls per batch and batches (the same as the C++ side).
const CALLS: usize = 2000;
const BATCHES: usize = 25;
/// Agreement required between Pinocchio and the generated code, relative to each quantity's
/// largest entry.
const TOLERANCE: f64 = 1e-9;

/// Nanoseconds per call, best batch.
fn nanoseconds(states: usize, mut call: impl FnMut(usize)) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..BATCHES {
        let start = Instant::now();
        for k in 0..CALLS {
            call(k % states);
        }
        best = best.min(start.elapsed().as_secs_f64() * 1e9 / CALLS as f64);
    }
    best
}

fn load(file: &str, variant: Option<&str>) -> Result<CheckedModel, String> {
    hapticgen_codegen::load_file(&workspace_root().join(file), file, variant).map_err(|e| e.to_string())
}

/// The URDF Pinocchio loads: the serial model, or a spatial closed chain's open tree.
fn write_urdf(m: &Model, out: &Path) -> Result<(), String> {
    let text = if m.passive.is_empty() { urdf::export(m)? } else { urdf::export_open_tree(m)?.urdf };
    std::fs::write(out, text).map_err(|e| format!("{}: {e}", out.display()))
}

/// A smooth closed trajectory of the actuated coordinates about the middle of their ranges,
/// `k` of `count` states, one period in a second: each coordinate
/// `q_i = mid_i + h_i (0.6 sin(2πt + 2πi/N) + 0.15 sin(4πt))` with `h_i` half its range, so
/// every state stays within 75 % of the ranges, consecutive states are 2π·0.9·h/count apart
/// (2.8 mrad for the Falcon's 0.5 rad half ranges, far within the generated code's warm-start
/// radius), and the last state leads back to the first. Positions and velocities (rad/s).
fn trajectory(m: &Model, k: usize, count: usize) -> (Vec<f64>, Vec<f64>) {
    use std::f64::consts::TAU;
    let t = k as f64 / count as f64;
    let n = m.joints.len() as f64;
    m.joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let (middle, half) = (0.5 * (j.lower + j.upper), 0.5 * (j.upper - j.lower));
            let phase = TAU * t + TAU * i as f64 / n;
            let position = middle + half * (0.6 * phase.sin() + 0.15 * (2.0 * TAU * t).sin());
            let velocity = half * (0.6 * TAU * phase.cos() + 0.15 * 2.0 * TAU * (2.0 * TAU * t).cos());
            (position, velocity)
        })
        .unzip()
}

/// The closed-chain lines of the states file: the open tree's coordinates, the assembly, the
/// generated code's loop-solver bounds, the cut closures.
fn closed_chain_header(checked: &CheckedModel, spatial: &SpatialLoops) -> Result<String, String> {
    let m = &checked.model;
    let tree = urdf::export_open_tree(m)?;
    let mut text = format!("tree {}\n", tree.coordinates.join(" "));
    // Newton starts from the file's assembly angles at the middle of the actuated ranges (the
    // model's data, not hapticgen's solution) and continues to the first state.
    let assembly: Vec<String> = m
        .joints
        .iter()
        .map(|j| 0.5 * (j.lower + j.upper))
        .chain(m.passive.iter().map(|p| p.assembly))
        .map(|x| format!("{x:e}"))
        .collect();
    text += &format!("assembly {}\n", assembly.join(" "));
    // The generated f64 code's bounds (`LoopConstraints::LOOP_SOLVER`, codegen/src/emit/loops.rs).
    text += &format!(
        "loop_solver {:e} {} {:e}\n",
        32.0 * f64::EPSILON * spatial.length_scale(),
        spatial.newton_step_bound(),
        WARM_START_RADIUS
    );
    for closure in &tree.closures {
        text += &format!("closure {} {} {}", closure.name, closure.point_links[0], closure.point_links[1]);
        if let Some(axes) = &closure.perpendicular_axes {
            text += " perpendicular";
            for (link, axis) in axes {
                text += &format!(" {link} {:e} {:e} {:e}", axis[0], axis[1], axis[2]);
            }
        }
        text.push('\n');
    }
    Ok(text)
}

fn write_states(checked: &CheckedModel, out: &Path) -> Result<(), String> {
    let m = &checked.model;
    let TaskSpec::Point(point) = m.task else {
        return Err(format!("{}: the task must be a point for a frame Jacobian", m.file));
    };
    let params = m.nominal_parameters();
    let atoms = hapticgen_codegen::eval::NominalAtoms(&params);
    let numbers =
        |v: &mut dyn Iterator<Item = f64>| v.map(|x| format!("{x:e}")).collect::<Vec<_>>().join(" ");
    let mut text = String::from(
        "# hapticgen/Pinocchio side-by-side states (tests/examples/pinocchio_side_by_side.rs)\n",
    );
    text += &format!("dof {}\n", m.joints.len());
    text += &format!("joints {}\n", m.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(" "));
    text += &format!("frame {}\n", urdf::point_link_name(&m.points[point].name));
    text += &format!("gravity {}\n", numbers(&mut m.gravity.iter().map(|g| g.eval(&atoms))));
    text += &format!(
        "armature {}\n",
        numbers(&mut m.joints.iter().map(|j| j.drive.gear_ratio.powi(2) * j.drive.motor.rotor_inertia))
    );
    let spatial = checked.analyses.closures.as_ref().and_then(|c| c.spatial.as_ref());
    match spatial {
        Some(spatial) => {
            text += &closed_chain_header(checked, spatial)?;
            text += &format!("states {TRAJECTORY_STATES}\n");
            for k in 0..TRAJECTORY_STATES {
                let (q, qd) = trajectory(m, k, TRAJECTORY_STATES);
                text += &numbers(&mut q.iter().chain(&qd).copied());
                text.push('\n');
            }
        }
        None if !m.passive.is_empty() => {
            return Err(format!(
                "{}: a planar closed chain; the benchmark's loop solve is for spatial closures",
                m.file
            ))
        }
        None => {
            text += &format!("states {STATES}\n");
            let mut rng = SmallRng::seed_from_u64(0x51de_b51d);
            for _ in 0..STATES {
                let (q, qd) = random_state(m, &mut rng);
                text += &numbers(&mut q.iter().chain(&qd).copied());
                text.push('\n');
            }
        }
    }
    std::fs::write(out, text).map_err(|e| format!("{}: {e}", out.display()))
}

/// Joint positions and velocities.
type States<const N: usize> = Vec<([f64; N], [f64; N])>;

/// The states, as written by [`write_states`].
fn read_states<const N: usize>(path: &str) -> Result<States<N>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let dof: usize = lines
        .next()
        .and_then(|l| l.strip_prefix("dof "))
        .and_then(|n| n.trim().parse().ok())
        .ok_or(format!("{path}: no dof line"))?;
    if dof != N {
        return Err(format!("{path}: {dof} joints, the generated rig has {N}"));
    }
    let mut states = Vec::new();
    let mut in_states = false;
    for line in lines {
        if in_states {
            let x: Vec<f64> = line
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| format!("{path}: {e}"))?;
            if x.len() != 2 * N {
                return Err(format!("{path}: a state needs {} numbers: {line}", 2 * N));
            }
            states.push((std::array::from_fn(|i| x[i]), std::array::from_fn(|i| x[N + i])));
        } else if line.starts_with("states ") {
            in_states = true;
        }
    }
    if states.is_empty() {
        return Err(format!("{path}: no states"));
    }
    Ok(states)
}

/// The largest error of each quantity (relative to its scale: its largest entry) and every
/// disagreement.
#[derive(Default)]
struct Worst {
    errors: Vec<(String, f64)>,
    failures: Vec<String>,
}

impl Worst {
    fn compare(&mut self, what: &str, tag: &str, state: usize, pinocchio: &[f64], generated: &[f64]) {
        assert_eq!(pinocchio.len(), generated.len(), "{what}: lengths");
        // Relative to the largest entry of either side, without an absolute floor; a quantity
        // that is exactly zero on both sides agrees.
        let scale = generated.iter().chain(pinocchio).fold(0.0f64, |m, x| m.max(x.abs()));
        let error = if scale == 0.0 {
            0.0
        } else {
            pinocchio.iter().zip(generated).map(|(a, b)| (a - b).abs() / scale).fold(0.0, f64::max)
        };
        // A NaN anywhere fails (f64::max would skip it).
        let error = if pinocchio.iter().chain(generated).any(|x| !x.is_finite()) { f64::NAN } else { error };
        if error.is_nan() || error > TOLERANCE {
            self.failures.push(format!(
                "state {state}: {what} ({tag}) differs by {error:.3e} (relative to {scale:.3})\n  Pinocchio {pinocchio:?}\n  hapticgen {generated:?}"
            ));
        }
        match self.errors.iter_mut().find(|(w, _)| w == what) {
            Some((_, e)) => *e = if error.is_nan() { error } else { e.max(error) },
            None => self.errors.push((what.to_string(), error)),
        }
    }
}

enum Action {
    Check { states: String, results: String },
    Time { states: String },
}

struct Run {
    file: String,
    variant: Option<String>,
    action: Action,
    /// Time the rig generated with its loops solved by Newton's method (`time-newton`).
    numerical: bool,
    found: bool,
    outcome: Result<(), String>,
}

impl Run {
    fn run<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &self,
        rig: &R,
    ) -> Result<(), String> {
        match &self.action {
            Action::Check { states, results } => check(rig, &read_states::<N>(states)?, results),
            Action::Time { states } => {
                time(rig, &read_states::<N>(states)?);
                Ok(())
            }
        }
    }
}

impl RigVisitor for Run {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    ) {
        // The unfused code (the build script also generates each rig with fused multiply-adds).
        // The closed form where a rig has one, unless Newton's method was asked for.
        if info.file == self.file
            && info.variant == self.variant.as_deref()
            && !info.module.ends_with("_fma")
            && info.module.contains("_newton_") == self.numerical
        {
            self.found = true;
            self.outcome = self.run(rig);
        }
    }

    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        _info: &RigInfo,
        _rig: &R,
    ) {
    }
}

fn flat<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

fn check<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
    rig: &R,
    states: &[([f64; N], [f64; N])],
    results: &str,
) -> Result<(), String> {
    let text = std::fs::read_to_string(results).map_err(|e| format!("{results}: {e}"))?;
    // D, C q̇ + g, g, p, J (3 rows), J̇ q̇.
    let per_line = N * N + N + N + 3 + 3 * N + 3;
    let mut worst = Worst::default();
    let mut seen = [0usize; 3];
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let mut words = line.split_whitespace();
        let tag = words.next().ok_or(format!("{results}: empty line"))?;
        let way = ["separate", "bundle", "allterms"]
            .iter()
            .position(|t| *t == tag)
            .ok_or(format!("{results}: unknown tag {tag}"))?;
        let state: usize =
            words.next().and_then(|k| k.parse().ok()).ok_or(format!("{results}: no state index"))?;
        let x: Vec<f64> =
            words.map(str::parse).collect::<Result<_, _>>().map_err(|e| format!("{results}: {e}"))?;
        if x.len() != per_line || state >= states.len() {
            return Err(format!("{results}: malformed line for state {state}"));
        }
        seen[way] += 1;
        let (d, rest) = x.split_at(N * N);
        let (nle, rest) = rest.split_at(N);
        let (g, rest) = rest.split_at(N);
        let (p, rest) = rest.split_at(3);
        let (j, jdqd) = rest.split_at(3 * N);
        let (q, qd) = &states[state];
        // Pinocchio's C q̇ alone: C q̇ + g − g.
        let cqd: Vec<f64> = nle.iter().zip(g).map(|(a, b)| a - b).collect();
        // Planar models: hapticgen's task is (x, y); Pinocchio's z row must then vanish.
        let pad = |v: Vec<f64>, width: usize| {
            let mut v = v;
            v.resize(3 * width, 0.0);
            v
        };
        let generated_cqd = rig.coriolis_times_qdot(q, qd);
        let generated_g = rig.gravity(q);
        let generated_nle: Vec<f64> = generated_cqd.iter().zip(&generated_g).map(|(a, b)| a + b).collect();
        let t = rig.terms(q, qd);
        let terms_nle: Vec<f64> = t.coriolis_times_qdot.iter().zip(&t.gravity).map(|(a, b)| a + b).collect();
        let compare =
            |worst: &mut Worst, what: &str, p: &[f64], h: &[f64]| worst.compare(what, tag, state, p, h);
        compare(&mut worst, "D", d, &flat(&rig.inertia_matrix(q)));
        compare(&mut worst, "C q̇ + g", nle, &generated_nle);
        compare(&mut worst, "C q̇", &cqd, &generated_cqd);
        compare(&mut worst, "g", g, &generated_g);
        compare(&mut worst, "p", p, &pad(rig.position(q).to_vec(), 1));
        compare(&mut worst, "J", j, &pad(flat(&rig.jacobian(q)), N));
        compare(&mut worst, "J̇ q̇", jdqd, &pad(rig.jacobian_dot_times_qdot(q, qd).to_vec(), 1));
        compare(&mut worst, "terms: D", d, &flat(&t.inertia_matrix));
        compare(&mut worst, "terms: C q̇ + g", nle, &terms_nle);
        compare(&mut worst, "terms: g", g, &t.gravity);
        compare(&mut worst, "terms: p", p, &pad(t.position.to_vec(), 1));
        compare(&mut worst, "terms: J", j, &pad(flat(&t.jacobian), N));
        compare(&mut worst, "terms: J̇ q̇", jdqd, &pad(t.jacobian_dot_times_qdot.to_vec(), 1));
    }
    if seen.iter().any(|&n| n != states.len()) {
        return Err(format!("{results}: expected {} states of each kind, got {seen:?}", states.len()));
    }
    println!(
        "agreement with Pinocchio at {} states (crba/nonLinearEffects/…, the same as one bundle, computeAllTerms; \
         generated functions and `terms`), largest relative difference per quantity (tolerance {TOLERANCE:e}):",
        states.len()
    );
    let summary: Vec<String> = worst.errors.iter().map(|(w, e)| format!("{w} {e:.1e}")).collect();
    println!("  {}", summary.join(", "));
    if worst.failures.is_empty() {
        Ok(())
    } else {
        let n = worst.failures.len();
        let first: Vec<String> = worst.failures.into_iter().take(10).collect();
        Err(format!("{n} disagreements with Pinocchio (first 10):\n{}", first.join("\n")))
    }
}

fn time<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
    rig: &R,
    states: &[([f64; N], [f64; N])],
) {
    let s = states.len();
    macro_rules! report {
        ($key:expr, |$q:ident, $qd:ident| $call:expr) => {{
            let ns = nanoseconds(s, |k| {
                let ($q, $qd) = &states[k];
                let ($q, $qd) = (black_box($q), black_box($qd));
                let _ = $qd;
                black_box($call);
            });
            println!("{} {ns:.2}", $key);
        }};
    }
    report!("D", |q, qd| rig.inertia_matrix(q));
    report!("nle", |q, qd| (rig.coriolis_times_qdot(q, qd), rig.gravity(q)));
    report!("Cqd", |q, qd| rig.coriolis_times_qdot(q, qd));
    report!("g", |q, qd| rig.gravity(q));
    report!("p", |q, qd| rig.position(q));
    report!("J", |q, qd| rig.jacobian(q));
    report!("Jdqd", |q, qd| rig.jacobian_dot_times_qdot(q, qd));
    report!("terms", |q, qd| rig.terms(q, qd));
}

/// The generated code's mean Newton steps per state, closing the Falcon-like Delta's loops
/// along the states in order (each from the solution of the state before, as in `time`).
fn falcon_loop_steps(states: &str) -> Result<(), String> {
    use hapticgen_runtime::loops::{close_loops, LoopLevel};
    use hapticgen_tests::falcon_delta_newton_f64::FalconDeltaNewton;
    let states = read_states::<3>(states)?;
    let rig = FalconDeltaNewton::NOMINAL;
    // Once around to warm up (the first state continues from the assembly), once counted.
    let mut steps = 0u64;
    for round in 0..2 {
        for (q, qd) in &states {
            let closed = close_loops(&rig, q, LoopLevel::Sensitivity, Some(qd));
            if let Some(error) = closed.error {
                return Err(format!("the generated code's loops do not close at {q:?}: {error:?}"));
            }
            if round == 1 {
                steps += u64::from(closed.steps);
            }
        }
    }
    println!("newton_steps_per_solve {:.2}", steps as f64 / states.len() as f64);
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage =
        "usage: pinocchio_side_by_side urdf|states|check|time|time-newton|loop-steps MODEL VARIANT|- [STATES [RESULTS]] | OUT";
    let outcome = (|| -> Result<(), String> {
        let [command, file, variant, rest @ ..] = args.as_slice() else {
            return Err(usage.into());
        };
        let variant = (variant != "-").then(|| variant.clone());
        let m = load(file, variant.as_deref())?;
        if variant.is_none() && !m.variants.is_empty() {
            return Err(format!("{file} has variants: name one of {}", m.variants.join(", ")));
        }
        let action = match (command.as_str(), rest) {
            ("urdf", [out]) => return write_urdf(&m, Path::new(out)),
            ("states", [out]) => return write_states(&m, Path::new(out)),
            ("check", [states, results]) => {
                Action::Check { states: states.clone(), results: results.clone() }
            }
            ("time" | "time-newton", [states]) => Action::Time { states: states.clone() },
            ("loop-steps", [states]) if file == "models/falcon_delta.yaml" => {
                return falcon_loop_steps(states)
            }
            _ => return Err(usage.into()),
        };
        let numerical = command == "time-newton";
        let mut run = Run { file: file.clone(), variant, action, numerical, found: false, outcome: Ok(()) };
        visit_all(&mut run);
        if !run.found {
            return Err(format!(
                "{file}{}: not a model this crate generates (a file in models/, named relative to the workspace root)",
                run.variant.map(|v| format!(" variant {v}")).unwrap_or_default()
            ));
        }
        run.outcome
    })();
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("pinocchio_side_by_side: {e}");
            ExitCode::FAILURE
        }
    }
}
