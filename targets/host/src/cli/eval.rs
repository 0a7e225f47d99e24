//! `hapticgen eval`: the derived quantities of eq. (1)–(2) (or a named frame's rotation and
//! angular-velocity Jacobian) at one state, as JSON, after checking the state against the
//! model's joints.

use hapticgen_codegen::{eval, model};

use super::args::EvalArgs;
use super::{load, CliError};

/// `hapticgen eval`: refuses a state of the wrong size, not finite or (without
/// `--beyond-limits`) outside the joints' limits; prints the values as one line of JSON.
pub fn eval(args: EvalArgs) -> Result<(), CliError> {
    let EvalArgs { model, variant, q, qd, point, frame, measured, beyond_limits } = args;
    let m = load(&model, variant.as_deref())?;
    let n = m.joints.len();
    if q.len() != n {
        return Err(CliError::Usage(format!("--q needs {n} values (one per joint), got {}", q.len())));
    }
    let qd = if qd.is_empty() { vec![0.0; n] } else { qd };
    if qd.len() != n {
        return Err(CliError::Usage(format!("--qd needs {n} values (one per joint), got {}", qd.len())));
    }
    let k = m.measured.len();
    let measured = if measured.is_empty() { vec![0.0; k] } else { measured };
    if measured.len() != k {
        return Err(CliError::Usage(format!(
            "--measured needs {k} values (one per measured joint), got {}",
            measured.len()
        )));
    }
    if let Some(bad) = q.iter().chain(&qd).chain(&measured).find(|v| !v.is_finite()) {
        return Err(CliError::Usage(format!("state values must be finite, got {bad}")));
    }
    if !beyond_limits {
        let limits = m
            .joints
            .iter()
            .map(|j| (&j.name, j.kind, j.lower, j.upper))
            .zip(&q)
            // The measured joints' angles enter only a frame's evaluation.
            .chain(
                m.measured
                    .iter()
                    .filter(|_| frame.is_some())
                    .map(|j| (&j.name, j.kind, j.lower, j.upper))
                    .zip(&measured),
            );
        for ((name, kind, lower, upper), &value) in limits {
            if !(lower..=upper).contains(&value) {
                let unit = match kind {
                    model::JointKind::Revolute => "rad",
                    model::JointKind::Prismatic => "m",
                };
                return Err(CliError::Usage(format!(
                    "joint `{name}` = {value} {unit} is outside its limits [{lower}, {upper}] {unit}{}; pass --beyond-limits to evaluate there anyway",
                    if unit == "rad" && value.abs() > std::f64::consts::TAU { " (degrees? --q takes radians)" } else { "" }
                )));
            }
        }
    }
    let mech = hapticgen_codegen::derive(&m);
    let selected = match &point {
        None => None,
        Some(name) => Some(mech.points.iter().find(|p| &p.name == name).ok_or_else(|| {
            let names: Vec<&str> = mech.points.iter().map(|p| p.name.as_str()).collect();
            CliError::Usage(format!("unknown point `{name}`; the model defines: {}", names.join(", ")))
        })?),
    };
    let parameters = m.nominal_parameters();
    let state = eval::State { q: &q, qd: &qd, parameters: &parameters };
    if let Some(name) = &frame {
        let kin = mech.frames.iter().find(|f| &f.name == name).ok_or_else(|| {
            let names: Vec<&str> = mech.frames.iter().map(|f| f.name.as_str()).collect();
            CliError::Usage(if names.is_empty() {
                format!("unknown frame `{name}`; the model defines no frames")
            } else {
                format!("unknown frame `{name}`; the model defines: {}", names.join(", "))
            })
        })?;
        // The measured joints are the coordinates after the actuated ones (a model
        // with measured joints has no passive ones).
        let q_measured: Vec<f64> = q.iter().chain(&measured).copied().collect();
        let qd_measured = vec![0.0; q_measured.len()];
        let state = eval::State { q: &q_measured, qd: &qd_measured, parameters: &parameters };
        let values = eval::try_evaluate_frame(&mech, &state, kin).map_err(CliError::Evaluation)?;
        return print_json(&values);
    }
    let values = eval::try_evaluate(&mech, &state, selected).map_err(CliError::Evaluation)?;
    print_json(&values)
}

/// Prints `value` as one line of JSON, every negative zero as `0.0`.
fn print_json(value: &impl serde::Serialize) -> Result<(), CliError> {
    println!("{}", crate::output::to_json(value, false).map_err(CliError::Evaluation)?);
    Ok(())
}
