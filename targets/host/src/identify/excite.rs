//! Excitation design (`hapticgen excite`): the Fourier series of [`super::trajectory`] chosen
//! so that the stacked base regressor is well conditioned, inside the device's limits.
//!
//! **Objective.** At `S` samples `t_i = i T / S` of one period, the regressor rows
//! `Y(q(t_i), q̇(t_i), q̈(t_i))` stacked into `W` (`S·N` rows, one column per base parameter),
//! each column scaled to unit length so that the figure does not depend on the parameters'
//! units: minimise `cond(W) = σ_max / σ_min` (Swevers et al. 1997; Gautier & Khalil 1992).
//! A column that no sample excites makes it infinite.
//!
//! **Constraints**, at every sample: each joint inside its limits less a margin (a fraction of
//! its range); each drive's output speed `|C q̇|` under a fraction of its no-load speed
//! `V_supply / (k_t N)`; each drive's torque for the motion, `C⁻ᵀ (D q̈ + C q̇ + g + B q̇ +
//! F_c sgn q̇)` with the model file's dynamics, under a fraction of its torque limit; every value
//! finite (a closed chain's loops close). The blend from rest (`ramp`) is a convex combination
//! of two poses inside the limits, so it keeps the position constraints.
//!
//! **Search.** A (1+1) evolution strategy with the one-fifth success rule (Rechenberg;
//! Beyer & Schwefel 2002) over the offsets and the coefficients, each coordinate's step scaled
//! by its joint's range (divided by the harmonic number for the coefficients); an infeasible
//! candidate always ranks below a feasible one. Deterministic for a given seed. The start is a
//! small random series, scaled down until it is feasible.

use std::sync::Arc;

use hapticgen_codegen::CheckedModel;
use nalgebra::DMatrix;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use super::regressor::{RegressorScratch, RegressorTape};
use super::trajectory::{JointSeries, TrajectoryFile, MAX_HARMONICS, MAX_JOINTS};
use crate::rig::CompiledModel;

/// Settings of the design.
#[derive(Clone, Debug, PartialEq)]
pub struct ExciteSettings {
    /// Period `T`, s.
    pub period: f64,
    /// Harmonics per joint.
    pub harmonics: usize,
    /// The blend from rest written into the file, s.
    pub ramp: f64,
    /// Margin inside each joint's limits, fraction of its range.
    pub position_margin: f64,
    /// Largest drive output speed, fraction of its no-load speed.
    pub speed_fraction: f64,
    /// Largest drive torque, fraction of its torque limit.
    pub torque_fraction: f64,
    /// Samples per period at which the constraints and `W` are evaluated.
    pub samples: usize,
    /// Candidate trajectories evaluated by the search.
    pub evaluations: usize,
    /// Seed of the search.
    pub seed: u64,
}

impl Default for ExciteSettings {
    fn default() -> Self {
        ExciteSettings {
            period: 10.0,
            harmonics: 5,
            ramp: 1.0,
            position_margin: 0.1,
            speed_fraction: 0.5,
            torque_fraction: 0.8,
            samples: 100,
            evaluations: 1500,
            seed: 1,
        }
    }
}

/// How a trajectory fares against the objective and the constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct Assessment {
    /// `cond(W)` with unit-length columns (infinite: some base parameter unexcited).
    pub condition_number: f64,
    /// The largest constraint excess, as a fraction of its bound (0: feasible).
    pub violation: f64,
    /// What the largest excess is, if any.
    pub worst: Option<String>,
    /// The joint (index in the model) whose position or drive has the largest excess.
    pub worst_joint: Option<usize>,
    /// Largest drive torque over the samples, fraction of its limit.
    pub torque_fraction: f64,
    /// Largest drive speed, fraction of its no-load speed.
    pub speed_fraction: f64,
    /// Base parameters whose column is (numerically) zero over the samples.
    pub unexcited: Vec<String>,
}

/// The designed trajectory and its figures.
#[derive(Clone, Debug)]
pub struct Design {
    /// The trajectory.
    pub file: TrajectoryFile,
    /// Its assessment.
    pub assessment: Assessment,
    /// The start's condition number (before the search).
    pub initial_condition_number: f64,
    /// Candidates evaluated.
    pub evaluations: usize,
}

/// Evaluates trajectories of one model (its regressor, dynamics and limits).
pub struct Assessor {
    model: CheckedModel,
    regressor: RegressorTape,
    compiled: Arc<CompiledModel>,
    scratch: RegressorScratch,
    dynamics_scratch: Vec<f64>,
    dynamics: Vec<f64>,
    row: Vec<f64>,
    /// Joint-side no-load speed of each drive's output, rad/s.
    no_load_speed: Vec<f64>,
}

impl Assessor {
    /// Prepares `model` (derives its regressor and dynamics).
    pub fn new(model: &CheckedModel) -> Assessor {
        let regressor = RegressorTape::new(model);
        let compiled = Arc::new(CompiledModel::new(model, 1.0));
        let no_load_speed = compiled
            .drives
            .iter()
            .map(|d| d.supply_voltage / (d.torque_constant * d.gear_ratio).max(1e-300))
            .collect();
        Assessor {
            scratch: regressor.scratch(),
            row: vec![0.0; regressor.joints() * regressor.columns()],
            dynamics_scratch: compiled.dynamics.scratch(),
            dynamics: vec![0.0; compiled.dynamics.len()],
            model: model.clone(),
            regressor,
            compiled,
            no_load_speed,
        }
    }

    /// The model's regressor.
    pub fn regressor(&self) -> &RegressorTape {
        &self.regressor
    }

    /// Assesses `file` at `samples` points of one period.
    pub fn assess(&mut self, file: &TrajectoryFile, samples: usize, settings: &ExciteSettings) -> Assessment {
        let n = self.regressor.joints();
        let p = self.regressor.columns();
        let series = file.series();
        let samples = samples.max(1);
        let mut w = DMatrix::<f64>::zeros(samples * n, p);
        let mut violation = 0.0_f64;
        let mut worst = None;
        let mut worst_joint = None;
        let mut peak_torque = 0.0_f64;
        let mut peak_speed = 0.0_f64;
        let mut exceed = |excess: f64, joint: usize, what: &dyn Fn() -> String, violation: &mut f64| {
            if excess > *violation {
                *violation = excess;
                worst = Some(what());
                worst_joint = Some(joint);
            }
        };
        for i in 0..samples {
            let t = file.period * i as f64 / samples as f64;
            let (q, qd, qdd) = TrajectoryFile::reference(&series, t + file.ramp.max(0.0), n);
            // Positions, with the margin.
            for (j, joint) in self.model.joints.iter().enumerate() {
                let margin = settings.position_margin * (joint.upper - joint.lower);
                let (lo, hi) = (joint.lower + margin, joint.upper - margin);
                let excess = ((lo - q[j]).max(q[j] - hi)) / (joint.upper - joint.lower);
                if excess > 0.0 || !q[j].is_finite() {
                    let excess = if q[j].is_finite() { excess } else { f64::INFINITY };
                    exceed(
                        excess,
                        j,
                        &|| {
                            format!(
                                "joint `{}` at {:.4} outside [{lo:.4}, {hi:.4}] at t = {t:.3} s",
                                joint.name, q[j]
                            )
                        },
                        &mut violation,
                    );
                }
            }
            // Drive speeds and torques.
            self.compiled.dynamics.eval(
                &mut self.dynamics_scratch,
                &q,
                &qd,
                &self.compiled.parameters,
                &mut self.dynamics,
            );
            let band = hapticgen_codegen::dynamics::regressor::COULOMB_BAND;
            let joint_torque: Vec<f64> = (0..n)
                .map(|r| {
                    let inertial: f64 = (0..n).map(|k| self.dynamics[r * n + k] * qdd[k]).sum();
                    inertial
                        + self.dynamics[n * n + r]
                        + self.dynamics[n * n + n + r]
                        + self.compiled.damping[r] * qd[r]
                        + self.compiled.drive_extras[r].coulomb_friction * qd[r]
                            / (qd[r] * qd[r] + band * band).sqrt()
                })
                .collect();
            let (drive_speed, drive_torque): (Vec<f64>, Vec<f64>) = match &self.compiled.coupling {
                Some(c) => (
                    (0..n).map(|k| (0..n).map(|j| c.drive_from_joint[k][j] * qd[j]).sum()).collect(),
                    // τ_a = C⁻ᵀ τ: drive k's torque is Σ_j (C⁻¹)_jk τ_j.
                    (0..n)
                        .map(|k| (0..n).map(|j| c.joint_from_drive[j][k] * joint_torque[j]).sum())
                        .collect(),
                ),
                None => (qd.clone(), joint_torque),
            };
            for k in 0..n {
                let speed = drive_speed[k].abs() / self.no_load_speed[k];
                let torque = drive_torque[k].abs() / self.compiled.drives[k].torque_limit;
                peak_speed = peak_speed.max(speed);
                peak_torque = peak_torque.max(torque);
                let name = &self.model.joints[k].name;
                if speed.is_nan() || speed > settings.speed_fraction {
                    let excess =
                        if speed.is_finite() { speed / settings.speed_fraction - 1.0 } else { f64::INFINITY };
                    exceed(
                        excess,
                        k,
                        &|| {
                            format!(
                                "drive of `{name}` at {:.0} % of its no-load speed at t = {t:.3} s",
                                100.0 * speed
                            )
                        },
                        &mut violation,
                    );
                }
                if torque.is_nan() || torque > settings.torque_fraction {
                    let excess = if torque.is_finite() {
                        torque / settings.torque_fraction - 1.0
                    } else {
                        f64::INFINITY
                    };
                    exceed(
                        excess,
                        k,
                        &|| {
                            format!(
                                "drive of `{name}` at {:.0} % of its torque limit at t = {t:.3} s",
                                100.0 * torque
                            )
                        },
                        &mut violation,
                    );
                }
            }
            self.regressor.eval(&mut self.scratch, &q, &qd, &qdd, &mut self.row);
            for r in 0..n {
                for c in 0..p {
                    w[(i * n + r, c)] = self.row[r * p + c];
                }
            }
        }
        let mut unexcited = Vec::new();
        for c in 0..p {
            let norm = w.column(c).norm();
            if norm.is_finite() && norm > 1e-12 {
                w.column_mut(c).scale_mut(1.0 / norm);
            } else {
                unexcited.push(self.regressor.regressor.base[c].name.clone());
            }
        }
        let condition_number = if !unexcited.is_empty() || !w.iter().all(|v| v.is_finite()) {
            f64::INFINITY
        } else {
            let singular = w.singular_values();
            let (max, min) =
                singular.iter().fold((0.0_f64, f64::INFINITY), |(hi, lo), &s| (hi.max(s), lo.min(s)));
            if min > 0.0 {
                max / min
            } else {
                f64::INFINITY
            }
        };
        Assessment {
            condition_number,
            violation: if violation.is_nan() { f64::INFINITY } else { violation },
            worst,
            worst_joint,
            torque_fraction: peak_torque,
            speed_fraction: peak_speed,
            unexcited,
        }
    }
}

/// The search's ranking: feasible candidates by `log cond`, infeasible ones after every
/// feasible one, by their violation.
fn rank(a: &Assessment) -> f64 {
    if a.violation > 0.0 {
        1e6 + a.violation.min(1e12)
    } else if a.condition_number.is_finite() {
        a.condition_number.ln()
    } else {
        1e5
    }
}

/// The optimisation variables of a trajectory: offsets, then per joint its sines and cosines.
fn to_vector(file: &TrajectoryFile) -> Vec<f64> {
    let mut x = Vec::new();
    for joint in &file.joints {
        x.push(joint.offset);
        x.extend(&joint.sine);
        x.extend(&joint.cosine);
    }
    x
}

fn from_vector(template: &TrajectoryFile, x: &[f64]) -> TrajectoryFile {
    let mut file = template.clone();
    let mut at = 0;
    for joint in &mut file.joints {
        let h = joint.sine.len();
        joint.offset = x[at];
        joint.sine.copy_from_slice(&x[at + 1..at + 1 + h]);
        joint.cosine.copy_from_slice(&x[at + 1 + h..at + 1 + 2 * h]);
        at += 1 + 2 * h;
    }
    file
}

/// Designs an excitation trajectory for `model` (`variant`: the variant's name, written into
/// the file). `progress(done, best condition number)` is called as the search goes.
pub fn design(
    model: &CheckedModel,
    variant: Option<&str>,
    settings: &ExciteSettings,
    mut progress: impl FnMut(usize, f64),
) -> Result<Design, String> {
    let n = model.joints.len();
    if n > MAX_JOINTS {
        return Err(format!("error: {}: at most {MAX_JOINTS} joints, this model has {n}", model.file));
    }
    if settings.harmonics == 0 || settings.harmonics > MAX_HARMONICS {
        return Err(format!("error: --harmonics must be 1 to {MAX_HARMONICS}, not {}", settings.harmonics));
    }
    if !(settings.period.is_finite() && settings.period > 0.0) {
        return Err(format!("error: --period must be a positive number of seconds, not {}", settings.period));
    }
    for (what, value, upper) in [
        ("--margin", settings.position_margin, 0.5),
        ("--speed-fraction", settings.speed_fraction, 1.0),
        ("--torque-fraction", settings.torque_fraction, 1.0),
    ] {
        if !(value.is_finite() && value >= 0.0 && value < upper) || (what != "--margin" && value == 0.0) {
            return Err(format!("error: {what} must lie in (0, {upper}), not {value}"));
        }
    }
    let h = settings.harmonics;
    let ranges: Vec<f64> = model.joints.iter().map(|j| j.upper - j.lower).collect();
    if let Some(joint) = model.joints.iter().find(|j| !(j.upper - j.lower).is_finite()) {
        return Err(format!(
            "error: {}: joint `{}` has no finite limits; an excitation needs them to stay inside",
            model.file, joint.name
        ));
    }
    let mut assessor = Assessor::new(model);
    let mut rng = SmallRng::seed_from_u64(settings.seed);
    let template = TrajectoryFile {
        model: model.name.clone(),
        variant: variant.map(str::to_string),
        period: settings.period,
        ramp: settings.ramp,
        joints: model
            .joints
            .iter()
            .map(|j| JointSeries {
                name: j.name.clone(),
                offset: 0.5 * (j.lower + j.upper),
                sine: vec![0.0; h],
                cosine: vec![0.0; h],
            })
            .collect(),
    };
    // Each variable's scale: the joint's range, over the harmonic number for coefficients.
    let mut scale = Vec::new();
    for range in &ranges {
        scale.push(0.1 * range);
        for _ in 0..2 {
            scale.extend((1..=h).map(|k| 0.25 * range / k as f64));
        }
    }
    // A small random start, halved until feasible.
    let mut x = to_vector(&template);
    let centre = x.clone();
    for (i, value) in x.iter_mut().enumerate() {
        if !is_offset(i, h) {
            *value = scale[i] * (rng.gen::<f64>() * 2.0 - 1.0);
        }
    }
    let mut best = assessor.assess(&from_vector(&template, &x), settings.samples, settings);
    let mut evaluations = 1;
    while best.violation > 0.0 && evaluations < 40 {
        for (i, value) in x.iter_mut().enumerate() {
            *value = centre[i] + 0.5 * (*value - centre[i]);
        }
        best = assessor.assess(&from_vector(&template, &x), settings.samples, settings);
        evaluations += 1;
    }
    if best.violation > 0.0 {
        return Err(format!(
            "error: {}: no feasible excitation found near the middle of the joints' ranges: {}",
            model.file,
            best.worst.as_deref().unwrap_or("the dynamics are not finite there")
        ));
    }
    let initial_condition_number = best.condition_number;
    let mut step = 0.3;
    let mut best_rank = rank(&best);
    while evaluations < settings.evaluations {
        let candidate: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, &v)| v + step * scale[i] * crate::closed_loop::gaussian(&mut rng))
            .collect();
        let assessment = assessor.assess(&from_vector(&template, &candidate), settings.samples, settings);
        evaluations += 1;
        let candidate_rank = rank(&assessment);
        if candidate_rank <= best_rank {
            x = candidate;
            best = assessment;
            best_rank = candidate_rank;
            step *= 1.5;
        } else {
            step *= 1.5_f64.powf(-0.25);
        }
        step = step.clamp(1e-4, 2.0);
        if evaluations % 50 == 0 {
            progress(evaluations, best.condition_number);
        }
    }
    Ok(Design { file: from_vector(&template, &x), assessment: best, initial_condition_number, evaluations })
}

/// Samples per period at which [`check_playable`] checks a trajectory.
pub const PLAYABLE_SAMPLES: usize = 1000;

/// Checks that `file` can be played on the device of `model` as it stands: every joint inside
/// its limits (no margin), every drive under its no-load speed and its torque limit, at
/// [`PLAYABLE_SAMPLES`] points of a period (the blend from rest stays between the rest pose
/// and the series, so the period bounds it). A trajectory written by `excite` passes with its
/// margins to spare; a hand-edited one may not. Err: the offending joint (index in the model)
/// and what exceeds which bound, when.
pub fn check_playable(model: &CheckedModel, file: &TrajectoryFile) -> Result<(), (usize, String)> {
    let settings = ExciteSettings {
        position_margin: 0.0,
        speed_fraction: 1.0,
        torque_fraction: 1.0,
        ..Default::default()
    };
    let assessment = Assessor::new(model).assess(file, PLAYABLE_SAMPLES, &settings);
    if assessment.violation > 0.0 {
        let joint = assessment.worst_joint.unwrap_or(0);
        let what = assessment.worst.unwrap_or_else(|| "the dynamics are not finite along it".to_string());
        return Err((joint, what));
    }
    Ok(())
}

fn is_offset(index: usize, harmonics: usize) -> bool {
    index.is_multiple_of(1 + 2 * harmonics)
}
