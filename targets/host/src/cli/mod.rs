//! The `hapticgen` command line's work: the parsed arguments ([`args`]), the dispatch to one
//! function per command ([`run`]) and the error every command returns ([`CliError`]). The
//! binary (`src/main.rs`) only parses, calls [`run`] and prints the error.
//!
//! A module per group of commands: [`model`] (`new`, `report`, `check`, `schema`,
//! `import-urdf`, `export-urdf`), [`generate`] (`generate`, `stats`), [`eval`], [`simulate`]
//! (`simulate`, and the set-up `pil` shares), [`pil`], [`connect`], [`experiments`]
//! (`contact`, `paper`, `faults`, `zwidth`) and [`identify`] (`excite`, `identify`).

use std::path::Path;

pub mod args;
pub mod connect;
pub mod error;
pub mod eval;
pub mod experiments;
pub mod generate;
pub mod identify;
pub mod model;
pub mod pil;
pub mod simulate;

pub use args::{Cli, Command};
pub use error::{CliError, FileOp};

/// Runs the command of a parsed command line: its output on standard output (warnings and
/// progress on standard error), or why it failed.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::New { rig } => model::new(&rig),
        Command::Report { model, variant, steps, no_zwidth, replay, output } => {
            model::report(&model, variant.as_deref(), steps, !no_zwidth, replay.as_deref(), &output)
        }
        Command::Check { model, variant } => model::check(&model, variant.as_deref()),
        Command::Generate { model, variant, scalar, fma, regressor, output } => {
            generate::generate(&model, variant.as_deref(), scalar, fma, regressor, output.as_deref())
        }
        Command::Eval(args) => eval::eval(args),
        Command::Stats { model, variant, json, fma, regressor } => {
            generate::stats(&model, variant.as_deref(), json, fma, regressor)
        }
        Command::Schema => model::schema(),
        Command::ImportUrdf { urdf, drive, output } => {
            model::import_urdf(&urdf, drive.as_deref(), output.as_deref())
        }
        Command::ExportUrdf { model, variant, output } => {
            model::export_urdf(&model, variant.as_deref(), output.as_deref())
        }
        Command::Simulate(args) => simulate::simulate(args),
        Command::Pil(args) => pil::pil(args),
        Command::Connect(args) => connect::connect(args),
        Command::Contact(args) => experiments::contact(args),
        Command::Paper { output, quick } => experiments::paper(&output, quick),
        Command::Faults { model, variant, output } => {
            experiments::faults(&model, variant.as_deref(), &output)
        }
        Command::Excite(args) => identify::excite(args),
        Command::Identify(args) => identify::identify(args),
        Command::Zwidth { model, variant, output, quick } => {
            experiments::zwidth(&model, variant.as_deref(), &output, quick)
        }
    }
}

/// Loads and checks a model file (one variant), its diagnostics naming the file as given.
pub fn load(model_path: &Path, variant: Option<&str>) -> Result<hapticgen_codegen::CheckedModel, CliError> {
    Ok(hapticgen_codegen::load_file(model_path, &model_path.display().to_string(), variant)?)
}

/// Writes `text` to `path`, or to standard output without one.
pub fn write_or_print(path: Option<&Path>, text: &str) -> Result<(), CliError> {
    match path {
        Some(path) => std::fs::write(path, text).map_err(CliError::file(FileOp::Write, path)),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}
