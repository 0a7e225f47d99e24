//! The base regressor `Y(q, q̇, q̈)` of any model file, compiled into an evaluation tape.
//!
//! `τ = Y(q, q̇, q̈) β` (`hapticgen_codegen::dynamics::regressor`: the base parameters β, with
//! rotor inertia, viscous and Coulomb friction and an offset per joint). Generated code has the
//! same function (`generate --regressor`); the host evaluates it for model files it was not
//! built with, from the same derivation, so excitation design and identification work on
//! any model.

use hapticgen_codegen::dynamics::regressor::Regressor;
use hapticgen_codegen::CheckedModel;

use crate::tape::Tape;

/// A model's base regressor, ready to evaluate.
#[derive(Clone, Debug)]
pub struct RegressorTape {
    /// The base parameters and their combinations of standard parameters.
    pub regressor: Regressor,
    tape: Tape,
    parameters: Vec<f64>,
}

/// A register file for [`RegressorTape::eval`], reused across calls.
pub struct RegressorScratch(Vec<f64>);

impl RegressorTape {
    /// Derives and compiles the base regressor of `model`.
    pub fn new(model: &CheckedModel) -> RegressorTape {
        let closures = model.analyses.closures.as_ref();
        let regressor = Regressor::new(model, closures);
        let tape = Tape::compile_built(model.joints.len(), closures, |dag| regressor.build(dag, model));
        RegressorTape { regressor, tape, parameters: model.nominal_parameters() }
    }

    /// Number of rows (actuated joints).
    pub fn joints(&self) -> usize {
        self.regressor.joints
    }

    /// Number of columns (base parameters).
    pub fn columns(&self) -> usize {
        self.regressor.base.len()
    }

    /// A register file for this tape.
    pub fn scratch(&self) -> RegressorScratch {
        RegressorScratch(self.tape.scratch())
    }

    /// `Y(q, q̇, q̈)`, row-major (`joints()` rows of `columns()`), into `out`.
    pub fn eval(&self, scratch: &mut RegressorScratch, q: &[f64], qd: &[f64], qdd: &[f64], out: &mut [f64]) {
        self.tape.eval_with_accelerations(&mut scratch.0, q, qd, qdd, &self.parameters, out);
    }

    /// The model's own base parameters (`β` at the file's values).
    pub fn nominal(&self) -> Vec<f64> {
        self.regressor.base.iter().map(|b| b.nominal).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::CompiledModel;

    /// `Y β_nominal` against the compiled inverse dynamics `D q̈ + C q̇ + g` plus `B q̇` and the
    /// smoothed Coulomb friction: two derivations (regressor columns; D, C, g) of one model.
    #[test]
    fn the_nominal_parameters_reproduce_the_inverse_dynamics() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for (file, variant) in [
            ("models/joystick_1dof.yaml", None),
            ("models/parallel_link_2dof.yaml", Some("vertical")),
            ("models/pantograph_5bar.yaml", Some("vertical")),
            ("models/differential_wrist.yaml", None),
            ("models/phantom_premium.yaml", None),
            ("models/falcon_delta.yaml", None),
        ] {
            let model = hapticgen_codegen::load_file(&root.join(file), file, variant)
                .unwrap_or_else(|e| panic!("{e}"));
            let regressor = RegressorTape::new(&model);
            let compiled = CompiledModel::new(&model, 1.0);
            let n = regressor.joints();
            let p = regressor.columns();
            let beta = regressor.nominal();
            let mut scratch = regressor.scratch();
            let mut y = vec![0.0; n * p];
            let mut dynamics_scratch = compiled.dynamics.scratch();
            let mut dynamics = vec![0.0; compiled.dynamics.len()];
            for (i, fraction) in [0.3, 0.5, 0.65].into_iter().enumerate() {
                let q: Vec<f64> = model
                    .joints
                    .iter()
                    .enumerate()
                    .map(|(j, joint)| {
                        let t = (fraction + 0.1 * j as f64) % 1.0;
                        joint.lower + (0.2 + 0.6 * t) * (joint.upper - joint.lower)
                    })
                    .collect();
                let qd: Vec<f64> = (0..n).map(|j| 0.7 - 0.4 * j as f64 + 0.1 * i as f64).collect();
                let qdd: Vec<f64> = (0..n).map(|j| -1.5 + 1.1 * j as f64).collect();
                regressor.eval(&mut scratch, &q, &qd, &qdd, &mut y);
                compiled.dynamics.eval(&mut dynamics_scratch, &q, &qd, &compiled.parameters, &mut dynamics);
                for row in 0..n {
                    let predicted: f64 = (0..p).map(|c| y[row * p + c] * beta[c]).sum();
                    let inertial: f64 = (0..n).map(|k| dynamics[row * n + k] * qdd[k]).sum();
                    let band = hapticgen_codegen::dynamics::regressor::COULOMB_BAND;
                    let coulomb = compiled.drive_extras[row].coulomb_friction * qd[row]
                        / (qd[row].powi(2) + band * band).sqrt();
                    let want = inertial
                        + dynamics[n * n + row]
                        + dynamics[n * n + n + row]
                        + compiled.damping[row] * qd[row]
                        + coulomb;
                    assert!(
                        (predicted - want).abs() <= 1e-9 * want.abs().max(1e-3),
                        "{file} row {row}: Y β = {predicted}, D q̈ + C q̇ + g + B q̇ + F_c = {want}"
                    );
                }
            }
        }
    }
}
