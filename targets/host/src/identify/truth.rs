//! How far an identified model is from the device it was identified on, when that device is
//! known: a simulated one, another model file (`hapticgen identify --truth TRUE.yaml`, and the
//! identification tests).
//!
//! The rigid-body terms are compared through the base regressor, so that only what the
//! identification can see is compared: with friction and offsets zeroed,
//! `Y(q, 0, 0) β = g(q)`, `Y(q, 0, e_k) β − g(q)` is column `k` of `D(q)` and
//! `Y(q, q̇, 0) β − g(q) = C(q, q̇) q̇`. At random states inside the joint limits (each joint
//! in the middle 70 % of its range, `q̇` uniform in ±1 rad/s), each of `D`, `C q̇` and `g` is
//! compared by the largest norm of its difference over the states, relative to the term's own
//! norm, its RMS over the same states: `max_s ‖T̂(s) − T(s)‖ / (Σ_s ‖T(s)‖² / S)^½`. A
//! state-by-state ratio would not do: `g` of a pendulum and `C q̇` pass through zero inside
//! the limits, where any error, however small, is an unbounded fraction of the term. Each
//! joint's viscous and Coulomb friction base parameter is compared by its relative
//! difference.

use hapticgen_codegen::CheckedModel;

use super::regressor::RegressorTape;

/// What the identification is to reach against a known device: `D`, `C q̇` and `g` within 2 %
/// of their norms at every compared state, each friction parameter within 10 %, the torque of
/// a validation run predicted within 5 % RMS.
pub const RIGID_BODY_BOUND: f64 = 0.02;
/// See [`RIGID_BODY_BOUND`].
pub const FRICTION_BOUND: f64 = 0.10;
/// See [`RIGID_BODY_BOUND`].
pub const VALIDATION_BOUND: f64 = 0.05;

/// The largest errors of the rigid-body terms over the compared states, each relative to the
/// term's RMS norm over them (module documentation). `None`: neither the true device nor the
/// identified model has the term at any compared state (C q̇ of a single joint, g of a
/// horizontal rig), so there was nothing to compare.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TermErrors {
    /// `max ‖D̂ − D‖ / rms ‖D‖`.
    pub inertia: Option<f64>,
    /// `max ‖Ĉq̇ − Cq̇‖ / rms ‖Cq̇‖`.
    pub coriolis: Option<f64>,
    /// `max ‖ĝ − g‖ / rms ‖g‖`.
    pub gravity: Option<f64>,
}

impl TermErrors {
    /// `(name in a table, short name, error)` of D, C q̇ and g, in that order.
    fn named(&self) -> [(&'static str, &'static str, Option<f64>); 3] {
        [("D(q)", "D", self.inertia), ("C(q, q̇) q̇", "C q̇", self.coriolis), ("g(q)", "g", self.gravity)]
    }
}

/// One friction base parameter, identified and true.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionError {
    /// The base parameter's name (`fv_<joint>` or `fc_<joint>`).
    pub name: String,
    /// The identified value.
    pub identified: f64,
    /// The true device's.
    pub truth: f64,
}

impl FrictionError {
    /// `|identified − true| / |true|`.
    pub fn relative(&self) -> f64 {
        (self.identified - self.truth).abs() / self.truth.abs()
    }

    /// Viscous (`fv_`) rather than Coulomb.
    pub fn is_viscous(&self) -> bool {
        self.name.starts_with("fv_")
    }
}

/// An identified model against the true device.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// The states compared.
    pub states: usize,
    /// The largest relative errors of `D`, `C q̇`, `g` over them.
    pub terms: TermErrors,
    /// Every viscous and Coulomb friction parameter.
    pub friction: Vec<FrictionError>,
}

/// The true device's base parameters: the regressor's combinations of `truth`'s standard
/// parameters. `truth` must have the regressor's model's joints and bodies.
pub fn true_base_parameters(regressor: &RegressorTape, truth: &CheckedModel) -> Vec<f64> {
    regressor.regressor.base_values(&regressor.regressor.standard_values(truth))
}

/// `beta` (identified on `model`) against the device `truth` at `states` random states
/// (deterministic for a `seed`). Refused: a `truth` whose joints or bodies differ from
/// `model`'s by name.
pub fn compare(
    regressor: &RegressorTape,
    model: &CheckedModel,
    beta: &[f64],
    truth: &CheckedModel,
    states: usize,
    seed: u64,
) -> Result<Comparison, String> {
    let names = |m: &CheckedModel| -> (Vec<String>, Vec<String>) {
        (
            m.joints.iter().map(|j| j.name.clone()).collect(),
            m.model.bodies.iter().map(|b| b.name.clone()).collect(),
        )
    };
    if names(model) != names(truth) {
        return Err(format!(
            "error: the true device {} does not have the joints and bodies of {}",
            truth.file, model.file
        ));
    }
    let true_beta = true_base_parameters(regressor, truth);
    let mut friction = Vec::new();
    for (c, base) in regressor.regressor.base.iter().enumerate() {
        if base.name.starts_with("fv_") || base.name.starts_with("fc_") {
            friction.push(FrictionError {
                name: base.name.clone(),
                identified: beta[c],
                truth: true_beta[c],
            });
        }
    }
    let n = regressor.joints();
    let mut random = seed ^ 0x5eed;
    let mut uniform = move || {
        random = random.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (random >> 11) as f64 / (1u64 << 53) as f64
    };
    // Per term (D, C q̇, g): the largest error norm, and the sum of the true term's squared
    // norms.
    let mut largest_error = [0.0_f64; 3];
    let mut squared_norms = [0.0_f64; 3];
    for _ in 0..states {
        let q: Vec<f64> =
            model.joints.iter().map(|j| j.lower + (0.15 + 0.7 * uniform()) * (j.upper - j.lower)).collect();
        let qd: Vec<f64> = (0..n).map(|_| 2.0 * uniform() - 1.0).collect();
        let identified = rigid_body_terms(regressor, beta, &q, &qd);
        let true_terms = rigid_body_terms(regressor, &true_beta, &q, &qd);
        for (k, range) in [0..n * n, n * n..n * n + n, n * n + n..n * n + 2 * n].into_iter().enumerate() {
            let error: f64 =
                range.clone().map(|i| (identified[i] - true_terms[i]).powi(2)).sum::<f64>().sqrt();
            largest_error[k] = largest_error[k].max(error);
            squared_norms[k] += range.map(|i| true_terms[i].powi(2)).sum::<f64>();
        }
    }
    let relative = |k: usize| {
        let rms = (squared_norms[k] / states.max(1) as f64).sqrt();
        if rms > 0.0 {
            Some(largest_error[k] / rms)
        } else if largest_error[k] > 0.0 {
            // A term the true device does not have that the identified model has.
            Some(f64::INFINITY)
        } else {
            None
        }
    };
    let terms = TermErrors { inertia: relative(0), coriolis: relative(1), gravity: relative(2) };
    Ok(Comparison { states, terms, friction })
}

/// `D(q)` (row by row), `C(q, q̇) q̇` and `g(q)` of the rigid-body part of `beta` (friction and
/// offsets zeroed), from the regressor (module documentation).
pub fn rigid_body_terms(regressor: &RegressorTape, beta: &[f64], q: &[f64], qd: &[f64]) -> Vec<f64> {
    let (n, p) = (regressor.joints(), regressor.columns());
    let rigid: Vec<f64> = regressor
        .regressor
        .base
        .iter()
        .zip(beta)
        .map(|(b, &v)| {
            let name = &b.name;
            if name.starts_with("fv_") || name.starts_with("fc_") || name.starts_with("off_") {
                0.0
            } else {
                v
            }
        })
        .collect();
    let mut scratch = regressor.scratch();
    let mut y = vec![0.0; n * p];
    let mut torque = |qd: &[f64], qdd: &[f64]| -> Vec<f64> {
        regressor.eval(&mut scratch, q, qd, qdd, &mut y);
        (0..n).map(|r| (0..p).map(|c| y[r * p + c] * rigid[c]).sum()).collect()
    };
    let zero = vec![0.0; n];
    let gravity = torque(&zero, &zero);
    let mut out = Vec::new();
    for k in 0..n {
        let mut unit = zero.clone();
        unit[k] = 1.0;
        out.extend(torque(&zero, &unit).iter().zip(&gravity).map(|(a, g)| a - g));
    }
    out.extend(torque(qd, &zero).iter().zip(&gravity).map(|(a, g)| a - g));
    out.extend(gravity);
    out
}

impl Comparison {
    /// A markdown section: the figures and their bounds; with `validation` (the torque
    /// prediction error's RMS over the torque's RMS on a validation run), that too.
    pub fn describe(&self, truth: &str, validation: Option<f64>) -> String {
        let percent = |x: f64| format!("{:.2} %", 100.0 * x);
        let mut text = format!(
            "\nAgainst the true device {truth} ({} random states inside the joint limits: the largest error of \
             D, C q̇ and g relative to the term's RMS norm over the states; bounds: {} for those, {} for \
             friction, {} for the validation torque):\n\n| figure | error | bound |\n|---|---|---|\n",
            self.states,
            percent(RIGID_BODY_BOUND),
            percent(FRICTION_BOUND),
            percent(VALIDATION_BOUND)
        );
        for (name, _, error) in self.terms.named() {
            let error =
                error.map_or_else(|| "— (zero in both at every state: not compared)".to_string(), percent);
            text.push_str(&format!("| {name} | {error} | {} |\n", percent(RIGID_BODY_BOUND)));
        }
        for f in &self.friction {
            text.push_str(&format!(
                "| {} (identified {:.4e}, true {:.4e}) | {} | {} |\n",
                f.name,
                f.identified,
                f.truth,
                percent(f.relative()),
                percent(FRICTION_BOUND)
            ));
        }
        if let Some(error) = validation {
            text.push_str(&format!(
                "| validation torque | {} | {} |\n",
                percent(error),
                percent(VALIDATION_BOUND)
            ));
        }
        text
    }

    /// Every figure over its bound ([`RIGID_BODY_BOUND`], [`FRICTION_BOUND`],
    /// [`VALIDATION_BOUND`]), one line each; empty when all hold.
    pub fn failures(&self, validation: Option<f64>) -> Vec<String> {
        let mut failures = Vec::new();
        for (_, name, error) in self.terms.named() {
            let Some(error) = error else { continue };
            if !within(error, RIGID_BODY_BOUND) {
                failures.push(format!(
                    "{name} is {:.2} % off the true device's, over {:.0} %",
                    100.0 * error,
                    100.0 * RIGID_BODY_BOUND
                ));
            }
        }
        for f in &self.friction {
            if !within(f.relative(), FRICTION_BOUND) {
                failures.push(format!(
                    "{} is {:.2} % off the true device's, over {:.0} %",
                    f.name,
                    100.0 * f.relative(),
                    100.0 * FRICTION_BOUND
                ));
            }
        }
        if let Some(error) = validation {
            if !within(error, VALIDATION_BOUND) {
                failures.push(format!(
                    "the validation torque is predicted {:.2} % RMS off, over {:.0} %",
                    100.0 * error,
                    100.0 * VALIDATION_BOUND
                ));
            }
        }
        failures
    }
}

/// `error` is a number at most `bound` (a NaN is not).
fn within(error: f64, bound: f64) -> bool {
    error <= bound
}
