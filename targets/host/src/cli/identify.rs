//! The dynamic-identification commands (the work is [`crate::identify`]'s): `excite` (an
//! excitation trajectory) and `identify` (the base parameters from excitation logs, and the
//! identified model file and report). `simulate --scenario excite` plays a trajectory.

use super::args::{ExciteArgs, IdentifyArgs};
use super::{CliError, FileOp};
use crate::identify::commands;
use crate::identify::excite::ExciteSettings;
use crate::identify::fit::{FitSettings, TorqueSource};

/// `hapticgen excite`: designs the trajectory and writes it to `--output`; prints what it is.
pub fn excite(args: ExciteArgs) -> Result<(), CliError> {
    let ExciteArgs {
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
    } = args;
    let settings = ExciteSettings {
        period,
        harmonics,
        position_margin: margin,
        speed_fraction,
        torque_fraction,
        evaluations,
        seed,
        ..Default::default()
    };
    let text = commands::excite_command(&model, variant.as_deref(), &settings, &output)
        .map_err(CliError::Identification)?;
    println!("{text}");
    Ok(())
}

/// `hapticgen identify`: fits the base parameters to the logs and prints them; writes the
/// report and the identified model file if asked, once everything is computed.
pub fn identify(args: IdentifyArgs) -> Result<(), CliError> {
    let IdentifyArgs { model, variant, logs, validate, cutoff, measured_torque, report, output, truth } =
        args;
    let torque = if measured_torque { TorqueSource::Measured } else { TorqueSource::Commanded };
    let settings = FitSettings { torque, ..FitSettings::with_cutoff(cutoff) };
    let identified = commands::identify(&model, variant.as_deref(), &logs, validate.as_deref(), &settings)
        .map_err(CliError::Identification)?;
    let text = identified.describe();
    print!("{text}");
    let verdict = truth
        .as_deref()
        .map(|truth| commands::against_truth(&identified, truth).map_err(CliError::Identification))
        .transpose()?;
    if let Some((text, _)) = &verdict {
        print!("{text}");
    }
    // Everything is computed before anything is written.
    let written = output
        .as_ref()
        .map(|_| identified.model_file(&model))
        .transpose()
        .map_err(CliError::Identification)?;
    if let Some(dir) = report {
        let path = identified.write_report(&dir, &model).map_err(CliError::Identification)?;
        println!("wrote {} and a torque figure per joint", path.display());
    }
    if let (Some(path), Some((file, residual))) = (output, written) {
        std::fs::write(&path, file).map_err(CliError::file(FileOp::Save, &path))?;
        println!(
            "wrote {}: physically consistent, reproducing the identified base parameters to {:.1e} \
             (relative, weighted by their σ)",
            path.display(),
            residual
        );
    }
    match verdict {
        Some((_, failures)) if !failures.is_empty() => Err(CliError::Verdict(
            failures.iter().map(|f| format!("FAIL identify: {f}")).collect::<Vec<_>>().join("\n"),
        )),
        _ => Ok(()),
    }
}
