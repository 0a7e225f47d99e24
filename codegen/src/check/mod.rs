//! Model-level analyses that produce diagnostics at the model file's lines: the current-loop
//! design of every drive ([`current_loop`]), the model's plausibility as a device
//! ([`plausibility`]: gravity against the drives, masses, lengths and inertias against the bodies'
//! sizes, a closed chain's assembly branch), the elimination of every loop closure
//! ([`crate::dynamics::closure::analyse`], reported here at the closure's entry), and the
//! stability of virtual walls ([`stability`]).
//!
//! Their results, [`Analyses`], travel beside the [`Model`] in a [`CheckedModel`]: the model
//! stays what the file says, the analyses what hapticgen computed from it.

pub mod current_loop;
pub mod plausibility;
pub mod stability;

use crate::diag::Diagnostics;
use crate::dynamics::closure::{self, Closures};
use crate::model::positions::Segment;
use crate::model::{Locator, Model};
use current_loop::{CurrentLoopDesign, CurrentLoopDesignInput};

/// What the analyses computed from a model.
#[derive(Clone, Debug)]
pub struct Analyses {
    /// The current-loop design of each joint's drive, in the order of `q`.
    pub current_loop_designs: Vec<CurrentLoopDesign>,
    /// The elimination of the loop closures, if the model is a closed chain.
    pub closures: Option<Closures>,
}

/// A model that passed every analysis, with their results.
#[derive(Clone, Debug)]
pub struct CheckedModel {
    /// The model, as its file describes the rig.
    pub model: Model,
    /// What the analyses computed from it.
    pub analyses: Analyses,
}

impl CheckedModel {
    /// The same model with its spatial loops solved by Newton's method in the generated code
    /// even where they have a closed form (`dynamics::three_spheres`): the numerical solver's
    /// code, for comparing the two and for testing the solver on a shipped mechanism. The
    /// rig's name gets the suffix `_newton`. Any other model is returned unchanged.
    pub fn with_loops_solved_numerically(mut self) -> CheckedModel {
        let spatial = self.analyses.closures.as_mut().and_then(|c| c.spatial.as_mut());
        if let Some(spatial) = spatial.filter(|s| s.closed_form.is_some()) {
            spatial.newton_reason = Some("asked for (`CheckedModel::with_loops_solved_numerically`)".into());
            spatial.closed_form = None;
            self.model.name.push_str("_newton");
        }
        self
    }
}

/// A checked model reads as its model: `checked.joints`, `&checked` where a `&Model` is asked.
impl std::ops::Deref for CheckedModel {
    type Target = Model;

    fn deref(&self) -> &Model {
        &self.model
    }
}

fn key(k: &str) -> Segment {
    Segment::Key(k.to_string())
}

/// Runs the analyses, reporting an infeasible current loop or a loop that cannot close at the
/// model file's line and column.
pub(crate) fn analyse(model: Model, locator: &Locator<'_>) -> Result<CheckedModel, Diagnostics> {
    let current_loop_designs = design_current_loops(&model, locator)?;
    let closures = analyse_closures(&model, locator)?;
    Ok(CheckedModel { model, analyses: Analyses { current_loop_designs, closures } })
}

/// The current loop of every joint's drive (joints sharing a drive share its design).
fn design_current_loops(model: &Model, locator: &Locator<'_>) -> Result<Vec<CurrentLoopDesign>, Diagnostics> {
    let mut designs: Vec<CurrentLoopDesign> = Vec::new();
    for j in &model.joints {
        let input = CurrentLoopDesignInput {
            resistance: j.drive.motor.resistance,
            inductance: j.drive.motor.inductance,
            sample_rate_hz: f64::from(model.rates.current_loop_hz),
            bandwidth_hz: model.current_loop.bandwidth_hz,
            damping_ratio: model.current_loop.damping_ratio,
            filter_cutoff_hz: model.current_loop.anti_alias_cutoff_hz,
            filter_order: model.current_loop.anti_alias_filter_order,
        };
        let earlier = model.joints.iter().position(|other| other.drive_name == j.drive_name);
        if let Some(&design) = earlier.and_then(|k| designs.get(k)) {
            designs.push(design);
            continue;
        }
        match current_loop::design_current_loop(&input) {
            Ok(design) => designs.push(design),
            Err(why) => {
                let message = format!(
                    "no current-loop design for joint `{}` (drive `{}`): {why}",
                    j.name, j.drive_name
                );
                return Err(locator.at(&[key("current_loop")], message).into());
            }
        }
    }
    Ok(designs)
}

/// The elimination of the model's loop closures; a closure that cannot close is reported at
/// its entry (or the key of it that is at fault).
fn analyse_closures(model: &Model, locator: &Locator<'_>) -> Result<Option<Closures>, Diagnostics> {
    if !model.spatial_closures.is_empty() {
        if !model.frames.is_empty() {
            return Err(Diagnostics(vec![locator
                .at(&[key("frames")], "frames (orientation outputs) of a closed chain are not supported yet")
                .with_hint("name a point for the position you need")]));
        }
        return closure::analyse_spatial(model, &model.spatial_closures).map(Some).map_err(|problems| {
            let errors = problems
                .into_iter()
                .map(|p| {
                    let mut path = vec![key("closures")];
                    path.extend(p.closure.map(Segment::Index));
                    locator.at(&path, p.message).with_hint(p.hint)
                })
                .collect();
            Diagnostics(errors)
        });
    }
    if model.closures.is_empty() {
        return Ok(None);
    }
    closure::analyse(model, &model.closures).map(Some).map_err(|problems| {
        let errors = problems
            .into_iter()
            .map(|p| {
                let mut path = vec![key("closures"), Segment::Index(p.closure)];
                path.extend(p.key.map(key));
                let d = locator.at(&path, p.message);
                match p.hint {
                    Some(h) => d.with_hint(h),
                    None => d,
                }
            })
            .collect();
        Diagnostics(errors)
    })
}
