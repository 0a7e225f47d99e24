//! The `hapticgen` command line: a thin shell over `hapticgen_codegen`.
//!
//! `check` validates a model, `generate` prints its Rust code, `eval` evaluates the derived
//! quantities of eq. (1)–(2) at one state, and `stats` counts the operations of each emitted
//! function. Exit code 0 on success; on failure a diagnostic with file, line and column on
//! standard error and exit code 1 (2 for bad command-line usage).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use hapticgen_codegen::{eval, model, Scalar};

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
        /// Write to this file instead of standard output.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Evaluate p, J, J̇, J̇q̇, D, C, Cq̇, g, B at one state.
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
        /// Print JSON (the only format).
        #[arg(long)]
        json: bool,
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
    },
    /// Print the JSON Schema of the model format.
    Schema,
}

fn load(model_path: &std::path::Path, variant: Option<&str>) -> Result<model::Model, String> {
    model::load_file(model_path, &model_path.display().to_string(), variant).map_err(|d| d.to_string())
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Check { model, variant } => {
            let m = load(&model, variant.as_deref())?;
            println!(
                "{}: ok: rig `{}`{}, {} joints, {} bodies, task dimension {}",
                model.display(),
                m.name,
                m.variant.as_ref().map(|v| format!(" (variant {v})")).unwrap_or_default(),
                m.joints.len(),
                m.bodies.len(),
                m.task_dim()
            );
            Ok(())
        }
        Command::Generate { model, variant, scalar, output } => {
            let m = load(&model, variant.as_deref())?;
            let scalar = match scalar {
                ScalarArg::F32 => Scalar::F32,
                ScalarArg::F64 => Scalar::F64,
            };
            let text = hapticgen_codegen::generate_model(m, scalar).file_text();
            match output {
                Some(path) => std::fs::write(&path, text)
                    .map_err(|e| format!("error: cannot write {}: {e}", path.display())),
                None => {
                    print!("{text}");
                    Ok(())
                }
            }
        }
        Command::Eval { model, variant, q, qd, point, json: _ } => {
            let m = load(&model, variant.as_deref())?;
            let n = m.joints.len();
            if q.len() != n {
                return Err(format!("error: --q needs {n} values (one per joint), got {}", q.len()));
            }
            let qd = if qd.is_empty() { vec![0.0; n] } else { qd };
            if qd.len() != n {
                return Err(format!("error: --qd needs {n} values (one per joint), got {}", qd.len()));
            }
            if let Some(bad) = q.iter().chain(&qd).find(|v| !v.is_finite()) {
                return Err(format!("error: state values must be finite, got {bad}"));
            }
            let mech = hapticgen_codegen::mechanics::derive(&m);
            let selected = match &point {
                None => None,
                Some(name) => Some(mech.points.iter().find(|p| &p.name == name).ok_or_else(|| {
                    let names: Vec<&str> = mech.points.iter().map(|p| p.name.as_str()).collect();
                    format!("error: unknown point `{name}`; the model defines: {}", names.join(", "))
                })?),
            };
            let parameters = m.nominal_parameters();
            let state = eval::State { q: &q, qd: &qd, parameters: &parameters };
            let values = eval::evaluate(&mech, &state, selected);
            println!("{}", serde_json::to_string(&values).map_err(|e| e.to_string())?);
            Ok(())
        }
        Command::Stats { model, variant, json } => {
            let m = load(&model, variant.as_deref())?;
            let generated = hapticgen_codegen::generate_model(m, Scalar::F64);
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
                    "{:<40} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
                    "function", "add", "mul", "div", "sqrt", "trig", "neg"
                );
                for (name, c) in &generated.stats.functions {
                    println!(
                        "{:<40} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
                        name,
                        c.additions,
                        c.multiplications,
                        c.divisions,
                        c.square_roots,
                        c.trigonometric,
                        c.negations
                    );
                }
            }
            Ok(())
        }
        Command::Schema => {
            print!("{}", model::json_schema());
            Ok(())
        }
    }
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
