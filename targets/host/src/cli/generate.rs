//! The commands on a model's generated code: `generate` (the Rust code) and `stats` (the
//! operations each emitted function counts).

use std::path::Path;

use hapticgen_codegen::{EmitOptions, Scalar};

use super::args::ScalarArg;
use super::{load, write_or_print, CliError};

/// `hapticgen generate`: the generated code of `model_path` in `scalar`, with fused
/// multiply-adds if `fma` and the identification regressor if `regressor`, to `output` or
/// standard output.
pub fn generate(
    model_path: &Path,
    variant: Option<&str>,
    scalar: ScalarArg,
    fma: bool,
    regressor: bool,
    output: Option<&Path>,
) -> Result<(), CliError> {
    let m = load(model_path, variant)?;
    let scalar = match scalar {
        ScalarArg::F32 => Scalar::F32,
        ScalarArg::F64 => Scalar::F64,
    };
    let options = EmitOptions { fused_multiply_add: fma, regressor };
    let text = hapticgen_codegen::generate_model_with(m, scalar, options).file_text();
    write_or_print(output, &text)
}

/// `hapticgen stats`: the operation counts of each function `generate` emits (with the same
/// `fma` and `regressor`), as a table or, with `json`, one JSON object.
pub fn stats(
    model_path: &Path,
    variant: Option<&str>,
    json: bool,
    fma: bool,
    regressor: bool,
) -> Result<(), CliError> {
    let m = load(model_path, variant)?;
    let options = EmitOptions { fused_multiply_add: fma, regressor };
    let generated = hapticgen_codegen::generate_model_with(m, Scalar::F64, options);
    if json {
        let map: serde_json::Map<String, serde_json::Value> = generated
            .stats
            .functions
            .iter()
            .map(|(name, c)| (name.clone(), serde_json::to_value(c).unwrap_or_default()))
            .collect();
        println!("{}", serde_json::Value::Object(map));
        return Ok(());
    }
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
    Ok(())
}
