//! `hapticgen pil`: processor in the loop. The rig's firmware image under QEMU controls the
//! simulated plant of `simulate` (the same set-up, [`super::simulate`]); the fault tests'
//! verdicts, and with `--compare` the differences from `simulate`'s trace of the same run
//! ([`compare_traces`]) and their bound.

use std::path::Path;

use super::args::{PilArgs, ScenarioArg};
use super::simulate::{configure, excite_run, Configured};
use super::{CliError, FileOp};
use crate::closed_loop::Trace;
use crate::simulation::PilTarget;

/// `hapticgen pil`: runs the image against the plant, writes DIR/trace.csv, the figures and
/// DIR/qemu.out; fails with a `FAIL pil: …` line per failed fault test or bound.
pub fn pil(args: PilArgs) -> Result<(), CliError> {
    if matches!(args.run.scenario, ScenarioArg::Excite) || args.run.trajectory.is_some() {
        return excite(&args);
    }
    let Configured { sim, cfg, scenario: _, singular_start: _, contact: _ } = configure(&args.run)?;
    let run = &args.run;
    // The variant applied: the one asked for, else the model's default.
    let name =
        crate::pil::chosen_image_name(args.image_name.as_deref(), &run.model, sim.model.variant.as_deref())
            .map_err(CliError::Simulation)?;
    let image = crate::pil::locate_image(&name, args.image.as_deref()).map_err(CliError::Simulation)?;
    let qemu = crate::pil::locate_qemu(args.qemu.as_deref()).map_err(CliError::Simulation)?;
    let period = 1.0 / f64::from(sim.data.current_loop_hz);
    if let Some(t) = args.stop_after {
        if !(t.is_finite() && t >= 0.0) {
            return Err(CliError::Usage(format!(
                "--stop-after must be a finite, non-negative time, got {t}"
            )));
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
    let (trace, report) = sim.run_pil(&cfg, &target).map_err(CliError::Simulation)?;
    crate::output::write_csv(&trace, &run.output.join("trace.csv")).map_err(CliError::Simulation)?;
    let figures = crate::paper::trace_figures(&trace, &run.output).map_err(CliError::Simulation)?;
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
        let reference = sim.run(&cfg).map_err(CliError::Simulation)?;
        let directory = run.output.join("simulate");
        std::fs::create_dir_all(&directory).map_err(CliError::file(FileOp::Create, &directory))?;
        crate::output::write_csv(&reference, &run.output.join("simulate/trace.csv"))
            .map_err(CliError::Simulation)?;
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
            if let crate::closed_loop::Reference::Scene { grid_spacing, .. } = &cfg.reference {
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
        Err(CliError::Verdict(
            failures.iter().map(|f| format!("FAIL pil: {f}")).collect::<Vec<_>>().join("\n"),
        ))
    }
}

/// `hapticgen pil --scenario excite`: the image plays the identification trajectory against
/// the simulated device and the host writes `DIR/log.csv` as `simulate --scenario excite` does.
/// The fault tests and the comparison belong to the impedance scenarios.
fn excite(args: &PilArgs) -> Result<(), CliError> {
    if args.compare
        || args.stop_after.is_some()
        || args.corrupt_every.is_some()
        || args.garbage_every.is_some()
    {
        return Err(CliError::Usage(
            "the excite scenario takes none of --compare, --stop-after, --corrupt-every, --garbage-every"
                .into(),
        ));
    }
    excite_run(&args.run, Some(args))
}

/// The largest absolute difference per column of two traces of the same run, and when.
pub struct Comparison {
    /// The traces' sample period, s.
    pub sample_period: f64,
    /// `(column, (largest |difference|, time))`, in the traces' column order (time excluded).
    pub largest: Vec<(String, (f64, f64))>,
    /// Time and every column's difference, per row.
    pub rows: Vec<Vec<f64>>,
    /// The compared columns' names, in order.
    pub columns: Vec<String>,
}

/// The differences of a PIL trace from `simulate`'s of the same run, up to time `until`.
pub fn compare_traces(pil: &Trace, reference: &Trace, until: Option<f64>) -> Comparison {
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

/// Writes the differences over time as CSV: `t` and a `dCOLUMN` per compared column.
pub fn write_comparison(comparison: &Comparison, path: &Path) -> Result<(), CliError> {
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
    std::fs::write(path, text).map_err(CliError::file(FileOp::Write, path))
}
