//! The identification commands' work, for the CLI's thin shell: `hapticgen excite` (design a
//! trajectory), `hapticgen simulate --scenario excite` (play it on a simulated device) and
//! `hapticgen identify` (fit the base parameters to the logs).

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};

use hapticgen_codegen::CheckedModel;

use super::excite::{self, ExciteSettings};
use super::fit::{self, FitSettings, Segment};
use super::log::IdentificationLog;
use super::regressor::RegressorTape;
use super::trajectory::TrajectoryFile;
use crate::closed_loop::SimConfig;
use crate::simulation::Simulation;

fn load(path: &Path, variant: Option<&str>) -> Result<CheckedModel, String> {
    hapticgen_codegen::load_file(path, &path.display().to_string(), variant).map_err(|d| d.to_string())
}

fn progress_bar(total: u64, what: &'static str) -> Option<indicatif::ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(&format!("{{bar:40}} {{pos}}/{{len}} {what} {{msg}}"))
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    })
}

/// `hapticgen excite`: designs a trajectory and writes it to `output`; returns what to print.
pub fn excite_command(
    model_path: &Path,
    variant: Option<&str>,
    settings: &ExciteSettings,
    output: &Path,
) -> Result<String, String> {
    let model = load(model_path, variant)?;
    let started = std::time::Instant::now();
    let bar = progress_bar(settings.evaluations as u64, "candidates");
    let design = excite::design(&model, variant, settings, |done, best| {
        if let Some(bar) = &bar {
            bar.set_position(done as u64);
            bar.set_message(format!("cond {best:.1}"));
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let a = &design.assessment;
    let header = format!(
        "Excitation trajectory for {} (hapticgen excite): {} harmonics of a {} s period.\n\
         Condition number of the stacked base regressor (unit-length columns, {} samples a period): {:.2}.\n\
         Peak drive torque {:.0} % of its limit, peak drive speed {:.0} % of its no-load speed.",
        model_path.display(),
        settings.harmonics,
        settings.period,
        settings.samples,
        a.condition_number,
        100.0 * a.torque_fraction,
        100.0 * a.speed_fraction
    );
    let text = design.file.to_yaml(&header)?;
    std::fs::write(output, text).map_err(|e| format!("error: {}: {e}", output.display()))?;
    Ok(format!(
        "{}: condition number {:.2} (start {:.2}) after {} candidates in {:.1} s; peak torque {:.0} %, peak \
         speed {:.0} % of the drives' limits; wrote {}",
        model_path.display(),
        a.condition_number,
        design.initial_condition_number,
        design.evaluations,
        started.elapsed().as_secs_f64(),
        100.0 * a.torque_fraction,
        100.0 * a.speed_fraction,
        output.display()
    ))
}

/// The line (1-based) of joint `name`'s entry in a trajectory file's text.
fn joint_entry_line(text: &str, name: &str) -> Option<usize> {
    text.lines()
        .position(|line| {
            let entry = line.trim_start().trim_start_matches("- ").trim_start();
            entry.strip_prefix("name:").is_some_and(|value| value.trim().trim_matches(['"', '\'']) == name)
        })
        .map(|index| index + 1)
}

/// What an excitation run needs besides the model.
pub struct ExciteRun<'a> {
    /// The trajectory file.
    pub trajectory: &'a Path,
    /// The simulated device's model file (`None`: the model itself).
    pub plant: Option<&'a Path>,
    /// The simulation's settings (effects, seed, duration).
    pub cfg: SimConfig,
    /// `None`: the trajectory's ramp and four periods.
    pub duration: Option<f64>,
    /// Where `log.csv` goes.
    pub output: &'a Path,
    /// `Some`: the rig's firmware image under QEMU plays the trajectory (`hapticgen pil`);
    /// `None`: the runtime on the host.
    pub pil: Option<&'a crate::simulation::PilTarget>,
}

/// Reads the trajectory file at `path` for `model` and checks that the device can play it
/// (limits, speeds, torques); an error names the file, and the line of the joint that cannot.
pub fn read_playable(model: &CheckedModel, path: &Path) -> Result<TrajectoryFile, String> {
    let trajectory = TrajectoryFile::read(path, model)?;
    if let Err((joint, what)) = super::excite::check_playable(model, &trajectory) {
        let name = &model.joints[joint].name;
        let line = std::fs::read_to_string(path)
            .ok()
            .and_then(|text| joint_entry_line(&text, name))
            .map_or_else(String::new, |line| format!("{line}:"));
        return Err(format!(
            "error: {}:{line} the trajectory cannot be played on this device: {what} \
             (design one with `hapticgen excite`, or shrink this joint's coefficients)",
            path.display()
        ));
    }
    Ok(trajectory)
}

/// `hapticgen simulate --scenario excite`: plays the trajectory, writes `DIR/log.csv` (and
/// the full trace as `DIR/trace.csv`); returns what to print.
pub fn excite_run(
    sim: &Simulation,
    model_path: &Path,
    variant: Option<&str>,
    run: ExciteRun,
) -> Result<String, String> {
    let trajectory = read_playable(&sim.model, run.trajectory)?;
    let plant = run.plant.map(|path| load(path, variant)).transpose()?;
    let mut cfg = run.cfg;
    cfg.duration = run.duration.unwrap_or(trajectory.ramp + 4.0 * trajectory.period);
    cfg.progress = true;
    let (trace, log, report) = match run.pil {
        None => {
            let (trace, log) = sim.run_excitation(&trajectory, plant.as_ref(), &cfg)?;
            (trace, log, None)
        }
        Some(target) => {
            let (trace, log, report) = sim.run_pil_excitation(&trajectory, plant.as_ref(), &cfg, target)?;
            (trace, log, Some(report))
        }
    };
    std::fs::create_dir_all(run.output).map_err(|e| format!("error: {}: {e}", run.output.display()))?;
    let log_path = run.output.join("log.csv");
    log.write(&log_path)?;
    crate::output::write_csv(&trace, &run.output.join("trace.csv"))?;
    // Tracking: the encoder angle against the reference, after the blend.
    let series = trajectory.series();
    let n = sim.joints();
    let worst = super::experiment::tracking_errors(&series, trajectory.ramp, &log, n);
    let mut text = format!(
        "simulated {:.2} s of {} playing {} in {:.2} s, controller on {}, device {}; wrote {} ({} samples)\n",
        trace.duration(),
        model_path.display(),
        run.trajectory.display(),
        trace.wall_seconds,
        match (run.pil, sim.uses_generated_code()) {
            (Some(target), _) => format!("firmware `{}` under QEMU", target.name),
            (None, true) => "generated code".to_string(),
            (None, false) => "the model's tapes".to_string(),
        },
        run.plant.map_or_else(|| "the same model".to_string(), |p| p.display().to_string()),
        log_path.display(),
        log.len()
    );
    for (joint, error) in sim.model.joints.iter().zip(&worst) {
        text.push_str(&format!("  joint {}: largest tracking error {:.3e}\n", joint.name, error));
    }
    for line in report.iter().flat_map(|report| &report.lines) {
        text.push_str(&format!("  {line}\n"));
    }
    if let Some((t, fault)) = &trace.fault {
        return Err(format!(
            "{text}error: the safety monitor latched {fault} at t = {t:.3} s: the log is not usable"
        ));
    }
    if trace.clamped_ticks > 0 {
        text.push_str(&format!(
            "warning: {} of {} ticks clamped a torque at its limit: those samples measure the limit, not the \
             dynamics; lower the trajectory's torque (hapticgen excite --torque-fraction)\n",
            trace.clamped_ticks, trace.impedance_ticks
        ));
    }
    Ok(text)
}

/// Per joint, how much later the logged torque acts on the device
/// ([`FitSettings::torque_lead`]), from the model's rates and current-loop design: a commanded
/// torque takes effect from the next current-loop period and reaches the motor through the
/// loop's mean delay; a measured one trails the motor by the current sensor's filter lag.
pub fn torque_leads(model: &CheckedModel, source: fit::TorqueSource) -> Result<Vec<f64>, String> {
    let designs = crate::simulation::current_loop_designs(model)?;
    let period = 1.0 / f64::from(model.rates.current_loop_hz);
    Ok(designs
        .iter()
        .map(|design| match source {
            fit::TorqueSource::Commanded => period + design.mean_delay,
            fit::TorqueSource::Measured => -design.filter_time_constant,
        })
        .collect())
}

/// `hapticgen identify --truth`: the identified model against the true device's model file
/// ([`super::truth`], 100 states); returns the markdown section and every figure over its bound.
pub fn against_truth(identified: &Identified, truth_path: &Path) -> Result<(String, Vec<String>), String> {
    let truth = load(truth_path, identified.model.variant.as_deref())?;
    let comparison = super::truth::compare(
        &identified.regressor,
        &identified.model,
        &identified.fit.beta,
        &truth,
        100,
        1,
    )?;
    let validation = identified.validation.as_ref().map(|(error, torque)| {
        let total = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        total(error) / total(torque).max(1e-300)
    });
    Ok((comparison.describe(&truth_path.display().to_string(), validation), comparison.failures(validation)))
}

/// What `hapticgen identify` found.
pub struct Identified {
    /// The fit.
    pub fit: fit::Fit,
    /// The regressor (names, combinations, nominal values).
    pub regressor: RegressorTape,
    /// Per joint: prediction error and torque RMS on the validation log, if one was given.
    pub validation: Option<(Vec<f64>, Vec<f64>)>,
    /// The model.
    pub model: CheckedModel,
    /// The log the report's figures show (the validation log if given, else the first log),
    /// prepared, and its path.
    pub figure_log: (PathBuf, Segment),
    /// The fit's settings.
    pub settings: FitSettings,
}

/// Reads logs (checked against the model's joints), prepared for the fit.
fn read_samples(
    model: &CheckedModel,
    logs: &[PathBuf],
    settings: &FitSettings,
) -> Result<Vec<Segment>, String> {
    let joints: Vec<String> = model.joints.iter().map(|j| j.name.clone()).collect();
    let mut segments = Vec::new();
    for path in logs {
        let log = IdentificationLog::read(path, &joints)?;
        segments.push(fit::prepare(&log, settings, &path.display().to_string())?);
    }
    Ok(segments)
}

/// `hapticgen identify`'s fit: the base parameters from `logs`, validated on `validate`.
pub fn identify(
    model_path: &Path,
    variant: Option<&str>,
    logs: &[PathBuf],
    validate: Option<&Path>,
    settings: &FitSettings,
) -> Result<Identified, String> {
    let model = load(model_path, variant)?;
    if logs.is_empty() {
        return Err("error: give at least one --log".into());
    }
    let joints: Vec<String> = model.joints.iter().map(|j| j.name.clone()).collect();
    // A joint that never moves leaves its parameters unexcited: say which, by name.
    for path in logs {
        let log = IdentificationLog::read(path, &joints)?;
        for (j, name) in joints.iter().enumerate() {
            let (lo, hi) = log
                .q
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| (lo.min(q[j]), hi.max(q[j])));
            let moved = hi - lo;
            if moved.is_nan() || moved <= 1e-3 {
                return Err(format!(
                    "error: {}: joint `{name}` moves {:.2e} over the whole log: its parameters cannot be identified \
                     from it (an excitation moves every joint)",
                    path.display(),
                    (hi - lo).max(0.0)
                ));
            }
        }
    }
    let mut settings = settings.clone();
    if settings.torque_lead.is_empty() {
        settings.torque_lead = torque_leads(&model, settings.torque)?;
    }
    let settings = &settings;
    let samples = read_samples(&model, logs, settings)?;
    let regressor = RegressorTape::new(&model);
    let fit = fit::fit(&regressor, &samples, settings)?;
    let (validation, figure_log) = match validate {
        Some(path) => {
            let mut samples = read_samples(&model, &[path.to_path_buf()], settings)?;
            let error = fit::prediction_error(&regressor, &fit.beta, &samples, settings);
            (Some(error), (path.to_path_buf(), samples.remove(0)))
        }
        None => (None, (logs[0].clone(), samples.into_iter().next().ok_or("error: no log")?)),
    };
    Ok(Identified { fit, regressor, validation, model, figure_log, settings: settings.clone() })
}

impl Identified {
    /// The identified model file: physically consistent standard parameters for the fitted
    /// base parameters ([`super::consistent`]), written into the model file's own text
    /// ([`super::model_file`]); `model_path` is the file it was loaded from. Returns the text
    /// and the fit's relative residual.
    pub fn model_file(&self, model_path: &Path) -> Result<(String, f64), String> {
        let text = std::fs::read_to_string(model_path)
            .map_err(|e| format!("error: {}: {e}", model_path.display()))?;
        let consistent = super::consistent::fit(
            &self.model,
            &self.regressor.regressor,
            &self.fit.beta,
            Some(&self.fit.sigma),
            &super::consistent::FitOptions::default(),
        )
        .map_err(|e| format!("error: the consistent fit: {e}"))?;
        let written = super::model_file::write_model_file(&text, &self.model, &consistent)
            .map_err(|e| format!("error: {}: {e}", model_path.display()))?;
        // What is written must load, as the model it claims to be.
        hapticgen_codegen::load(
            &hapticgen_codegen::Source { name: &model_path.display().to_string(), text: &written },
            self.model.variant.as_deref(),
        )
        .map_err(|d| format!("error: the identified model does not load (nothing written):\n{d}"))?;
        Ok((written, consistent.residual))
    }

    /// Writes the report into `dir`: `identification.md` (what [`Identified::describe`]
    /// prints, then the measured torque against the torque the model file's and the identified
    /// parameters predict, per joint, on the figure log) and one figure per joint,
    /// `torque_<joint>.svg` and `.png`. Returns the markdown's path.
    pub fn write_report(&self, dir: &Path, model_path: &Path) -> Result<PathBuf, String> {
        let (log_path, segment) = &self.figure_log;
        let nominal: Vec<f64> = self.regressor.regressor.base.iter().map(|b| b.nominal).collect();
        let trace =
            fit::prediction_trace(&self.regressor, &[&nominal, &self.fit.beta], segment, &self.settings);
        if trace.time.is_empty() {
            return Err(format!("error: {}: too short for the report's figures", log_path.display()));
        }
        std::fs::create_dir_all(dir).map_err(|e| format!("error: {}: {e}", dir.display()))?;
        let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt();
        let difference = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x - y).collect() };
        let role = if self.validation.is_some() {
            "the validation log, not used by the fit"
        } else {
            "a log of the fit; --validate gives one it did not see"
        };
        let mut text = format!("# Identification of {}\n\n{}", model_path.display(), self.describe());
        text.push_str(&format!(
            "\n## Measured and predicted torque\n\nOn {} ({role}): each joint's torque as the fit sees it \
             (zero-phase filtered at {} Hz) beside the torque predicted by the model file's base parameters and by \
             the identified ones; the errors are RMS over the {} samples shown.\n\n\
             | joint | torque RMS | error RMS, model file | % | error RMS, identified | % |\n\
             |---|---|---|---|---|---|\n",
            log_path.display(),
            self.settings.cutoff_hz,
            trace.time.len()
        ));
        // At most this many points per curve in a figure.
        const FIGURE_POINTS: usize = 4000;
        let stride = trace.time.len().div_ceil(FIGURE_POINTS);
        for (j, joint) in self.model.joints.iter().enumerate() {
            let measured = &trace.measured[j];
            let torque = rms(measured);
            let before = rms(&difference(&trace.predicted[0][j], measured));
            let after = rms(&difference(&trace.predicted[1][j], measured));
            text.push_str(&format!(
                "| {} | {torque:.4e} | {before:.4e} | {:.2} | {after:.4e} | {:.2} |\n",
                joint.name,
                100.0 * before / torque.max(1e-300),
                100.0 * after / torque.max(1e-300)
            ));
            let points = |y: &[f64]| -> Vec<(f64, f64)> {
                trace.time.iter().zip(y).step_by(stride).map(|(&t, &v)| (t, v)).collect()
            };
            let chart = crate::plot::Chart {
                title: format!("Joint {}: measured and predicted torque", joint.name),
                x_label: "time (s)".into(),
                y_label: match joint.kind {
                    hapticgen_codegen::model::JointKind::Prismatic => "joint force (N)".into(),
                    hapticgen_codegen::model::JointKind::Revolute => "joint torque (N·m)".into(),
                },
                series: vec![
                    crate::plot::Series::line("measured", points(measured)),
                    crate::plot::Series::dashed("model file", points(&trace.predicted[0][j])),
                    crate::plot::Series::line("identified", points(&trace.predicted[1][j])),
                ],
                equal_aspect: false,
            };
            crate::plot::save(&chart, &dir.join(format!("torque_{}", joint.name)))?;
        }
        text.push('\n');
        for joint in &self.model.joints {
            text.push_str(&format!("![joint {0}](torque_{0}.svg)\n\n", joint.name));
        }
        let path = dir.join("identification.md");
        std::fs::write(&path, text).map_err(|e| format!("error: {}: {e}", path.display()))?;
        Ok(path)
    }

    /// The parameter table and the figures, as markdown.
    pub fn describe(&self) -> String {
        let base = &self.regressor.regressor.base;
        let standard = &self.regressor.regressor.standard;
        let mut text = String::from(
            "| base parameter | combines | model file | identified | σ | σ % |\n|---|---|---|---|---|---|\n",
        );
        for (c, b) in base.iter().enumerate() {
            let (beta, sigma) = (self.fit.beta[c], self.fit.sigma[c]);
            let relative = if beta != 0.0 { 100.0 * sigma / beta.abs() } else { f64::INFINITY };
            text.push_str(&format!(
                "| {} | {} | {:.6e} | {:.6e} | {:.2e} | {:.1} |\n",
                b.name,
                b.describe(standard),
                b.nominal,
                beta,
                sigma,
                relative
            ));
        }
        text.push_str(&format!(
            "\nCondition number of the stacked regressor (unit columns): {:.2}\n",
            self.fit.condition_number
        ));
        let leads: Vec<String> = self
            .model
            .joints
            .iter()
            .zip(&self.settings.torque_lead)
            .map(|(joint, lead)| format!("{} {:.3} ms", joint.name, 1e3 * lead))
            .collect();
        if !leads.is_empty() {
            text.push_str(&format!(
                "Torque timing: the logged {} torque taken to act on the device this long after its time stamp \
                 (negative: before; the current loop's delay): {}\n",
                match self.settings.torque {
                    fit::TorqueSource::Commanded => "commanded",
                    fit::TorqueSource::Measured => "measured",
                },
                leads.join(", ")
            ));
        }
        text.push('\n');
        text.push_str("| joint | rows | torque RMS | residual RMS | residual % |");
        let validation = self.validation.as_ref();
        if validation.is_some() {
            text.push_str(" validation error RMS | validation % |");
        }
        text.push('\n');
        text.push_str(if validation.is_some() {
            "|---|---|---|---|---|---|---|\n"
        } else {
            "|---|---|---|---|---|\n"
        });
        for (j, joint) in self.model.joints.iter().enumerate() {
            let (residual, torque) = (self.fit.residual_rms[j], self.fit.torque_rms[j]);
            text.push_str(&format!(
                "| {} | {} | {:.4e} | {:.4e} | {:.2} |",
                joint.name,
                self.fit.rows[j],
                torque,
                residual,
                100.0 * residual / torque.max(1e-300)
            ));
            if let Some((error, torque)) = validation {
                text.push_str(&format!(
                    " {:.4e} | {:.2} |",
                    error[j],
                    100.0 * error[j] / torque[j].max(1e-300)
                ));
            }
            text.push('\n');
        }
        text
    }
}
