//! The commands that run a set of simulations and report on them: `contact` (every contact
//! scenario and its checks), `paper` (the experiments of the paper's section 6), `faults`
//! (fault injection against the safety criteria) and `zwidth` (a virtual wall's stable
//! region).

use std::path::Path;

use super::args::ContactArgs;
use super::simulate::{friction, law};
use super::{CliError, FileOp};
use crate::simulation::Simulation;

/// `hapticgen contact`: runs the contact scenarios, writes their traces, figures and
/// DIR/report.md, prints the summary; fails if a check fails.
pub fn contact(args: ContactArgs) -> Result<(), CliError> {
    let ContactArgs { model, variant, controller, friction: coefficients, mesh, push, only, output } = args;
    let sim = Simulation::load(&model, variant.as_deref()).map_err(CliError::Simulation)?;
    let run = crate::contact_report::ContactRun {
        law: law(controller),
        friction: friction(Some(&coefficients))?,
        mesh,
        push,
        only,
    };
    std::fs::create_dir_all(&output).map_err(CliError::file(FileOp::Create, &output))?;
    let (checks, summary) =
        crate::contact_report::run_all(&sim, &run, &output).map_err(CliError::Simulation)?;
    if checks.iter().all(|c| c.pass) {
        println!("{summary}");
        Ok(())
    } else {
        Err(CliError::Verdict(summary))
    }
}

/// `hapticgen paper`: every experiment of the paper's section 6 (shortened if `quick`),
/// figures and report in `output`; prints the summary.
pub fn paper(output: &Path, quick: bool) -> Result<(), CliError> {
    let summary = crate::paper::run_all(output, quick, true).map_err(CliError::Simulation)?;
    println!("{summary}");
    Ok(())
}

/// `hapticgen faults`: every fault scenario on `model_path`; prints the table and writes it
/// to `output`/faults.md.
pub fn faults(model_path: &Path, variant: Option<&str>, output: &Path) -> Result<(), CliError> {
    let sim = Simulation::load(model_path, variant).map_err(CliError::Simulation)?;
    let results = crate::faults::scenarios(&sim)
        .iter()
        .map(|f| crate::faults::run(&sim, f))
        .collect::<Result<Vec<_>, String>>()
        .map_err(CliError::Simulation)?;
    let table = crate::faults::table(&results);
    std::fs::create_dir_all(output).map_err(CliError::file(FileOp::Create, output))?;
    let path = output.join("faults.md");
    std::fs::write(&path, &table).map_err(CliError::file(FileOp::Write, &path))?;
    println!("{table}\nwrote {}", path.display());
    Ok(())
}

/// `hapticgen zwidth`: the stable (K, B) region of a virtual wall on `model_path` (a short
/// sweep if `quick`), written to `output`; prints its boundary as a table.
pub fn zwidth(model_path: &Path, variant: Option<&str>, output: &Path, quick: bool) -> Result<(), CliError> {
    let sim = Simulation::load(model_path, variant).map_err(CliError::Simulation)?;
    let settings = if quick { crate::zwidth::Sweep::quick() } else { crate::zwidth::Sweep::full() };
    let z = crate::zwidth::sweep(&sim, &settings).map_err(CliError::Simulation)?;
    crate::zwidth::write(&z, &model_path.display().to_string(), output).map_err(CliError::Simulation)?;
    println!("| B (N·s/m) | largest stable K, simulated (N/m) | stability bound 2(b + B)/T (N/m) |");
    for p in &z.boundary {
        println!("| {:.1} | {:.0} | {:.0} |", p.damping, p.stable_stiffness, p.stable_bound);
    }
    println!("wrote {}", output.join("zwidth.md").display());
    Ok(())
}
