//! Build-time stability checks of virtual walls: the largest stiffness a rig can render at
//! its impedance-loop rate, from its physical damping, compared with the model's
//! `rendering.wall_stiffness`.
//!
//! A virtual wall `K`, `B` rendered by a sampled loop of period `T` (zero-order hold, velocity
//! by backward difference) on a device of mass `m` and physical viscous damping `b`:
//!
//! * **Passivity** (Colgate & Schenkel, *Passivity of a class of sampled-data systems:
//!   application to haptic interfaces*, 1997): the device and wall are passive — stable
//!   against any passive operator — if and only if `b > K·T/2 + |B|`. So the passively
//!   renderable stiffness is `K_passive = 2 (b − |B|) / T` (none when `|B| ≥ b`): the
//!   sampled virtual damper does not add to the margin, it uses it up.
//! * **Stability of the device alone** (Gil, Avello, Rubio & Flórez, *Stability analysis of
//!   a 1-DOF haptic interface using the Routh–Hurwitz criterion*, 2004; Hulin et al. 2006):
//!   for a small `T` the loop without an operator is stable if `b > K·T/2 − B`, i.e.
//!   `K < K_stable = 2 (b + B) / T`: here the virtual damping helps.
//!
//! The check uses both: a wall stiffer than `K_passive` is a **warning** (stability then
//! depends on the operator's grip and the drive's friction, which the bound does not count),
//! and a wall stiffer than `K_stable` — beyond the margin the virtual damping buys — is an
//! **error** unless the model sets `rendering.allow_unstable_stiffness: true`.
//!
//! **The physical damping `b`** is the joints' viscous damping `B_q = diag(damping)` seen at
//! the task point, `B_x = (J B_q⁻¹ Jᵀ)⁻¹` (`= J⁻ᵀ B_q J⁻¹` for a square `J`), at a
//! representative pose — the middle of every joint's range, the simulator's start pose —
//! taking its smallest eigenvalue (the least damped direction). Friction and the motors'
//! back-EMF are not counted: the current loop cancels the back-EMF, and Coulomb friction is
//! not viscous. [`WallCheck::worst_task_damping`] gives the smallest `b` over a grid of
//! poses for information.

use crate::diag::Diagnostic;
use crate::dynamics::mechanics::Mechanics;
use crate::eval::State;
use crate::math::eigen::symmetric_eigenvalues;
use crate::math::grid::box_grid;
use crate::model::positions::{PositionIndex, Segment};
use crate::model::Model;

/// Where a requested wall stiffness stands against the bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WallVerdict {
    /// `K ≤ K_passive`: passive against any passive operator.
    Passive,
    /// `K_passive < K ≤ K_stable`: not guaranteed passive; a warning.
    BeyondPassivity,
    /// `K > K_stable`: unstable even without an operator; an error unless overridden.
    BeyondStability,
}

/// The result of checking a model's virtual-wall settings.
#[derive(Clone, Debug, PartialEq)]
pub struct WallCheck {
    /// The pose at which `b` is evaluated (the middle of every joint's range).
    pub pose: Vec<f64>,
    /// `b`: the smallest eigenvalue of the task-space damping at [`WallCheck::pose`], N·s/m
    /// (N·m·s/rad for a joint-space task).
    pub task_damping: f64,
    /// The smallest `b` over a grid of 5 poses per joint across the joint ranges.
    pub worst_task_damping: f64,
    /// `T`, the impedance-loop period, s.
    pub sample_period: f64,
    /// The requested wall stiffness `K`.
    pub wall_stiffness: f64,
    /// The requested wall damping `B`.
    pub wall_damping: f64,
    /// `2 (b − |B|) / T`, at least 0.
    pub passive_stiffness: f64,
    /// `2 (b + B) / T`.
    pub stable_stiffness: f64,
    /// Where `K` stands.
    pub verdict: WallVerdict,
    /// `rendering.allow_unstable_stiffness`.
    pub override_allowed: bool,
}

/// `2 (b − |B|) / T`, at least 0: the passively renderable stiffness (Colgate & Schenkel).
pub fn passive_stiffness(physical_damping: f64, virtual_damping: f64, period: f64) -> f64 {
    (2.0 * (physical_damping - virtual_damping.abs()) / period).max(0.0)
}

/// `2 (b + B) / T`: the stiffness beyond which the sampled wall is unstable even without an
/// operator (Gil et al.).
pub fn stable_stiffness(physical_damping: f64, virtual_damping: f64, period: f64) -> f64 {
    2.0 * (physical_damping + virtual_damping) / period
}

/// The smallest eigenvalue of the task-space damping `(J B_q⁻¹ Jᵀ)⁻¹` at `q`: the physical
/// damping `b` of the least damped task direction. 0 when a joint that moves the task point
/// has no damping; `None` when the task point does not move at all (`J = 0`) or a value is
/// not finite.
pub fn task_damping(model: &Model, mech: &Mechanics, q: &[f64]) -> Option<f64> {
    let parameters = model.nominal_parameters();
    let qd = vec![0.0; q.len()];
    let state = State { q, qd: &qd, parameters: &parameters };
    let state = crate::eval::Full::new(mech, &state);
    let damping: Vec<f64> = mech.damping.iter().map(|p| p.eval(&state)).collect();
    let jacobian: Vec<Vec<f64>> =
        mech.task.jacobian.iter().map(|row| row.iter().map(|p| p.eval(&state)).collect()).collect();
    if !damping.iter().chain(jacobian.iter().flatten()).all(|v| v.is_finite()) {
        return None;
    }
    let scale = jacobian.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return None;
    }
    // A joint without damping that moves the task point leaves a direction undamped.
    for (k, &b) in damping.iter().enumerate() {
        if b <= 0.0 && jacobian.iter().any(|row| row[k].abs() > 1e-12 * scale) {
            return Some(0.0);
        }
    }
    let m = jacobian.len();
    let mobility: Vec<Vec<f64>> = (0..m)
        .map(|r| {
            (0..m)
                .map(|c| {
                    damping
                        .iter()
                        .enumerate()
                        .filter(|(_, &b)| b > 0.0)
                        .map(|(k, &b)| jacobian[r][k] * jacobian[c][k] / b)
                        .sum()
                })
                .collect()
        })
        .collect();
    let largest = symmetric_eigenvalues(mobility).into_iter().fold(0.0f64, f64::max);
    if largest > 0.0 && largest.is_finite() {
        Some(1.0 / largest)
    } else {
        None
    }
}

/// Checks the model's `rendering` settings; `None` when the model renders nothing (no
/// `rendering` section) or its task point does not move.
pub fn check_wall(model: &Model, mech: &Mechanics) -> Option<WallCheck> {
    let rendering = model.rendering.as_ref()?;
    let pose: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
    let b = task_damping(model, mech, &pose)?;
    // The least damped pose on a grid of 5 values per joint (at most 5⁴ poses).
    let steps: usize = if model.joints.len() <= 4 { 5 } else { 2 };
    let mut worst = b;
    let bounds: Vec<(f64, f64)> = model.joints.iter().map(|j| (j.lower, j.upper)).collect();
    for q in box_grid(&bounds, steps).take(1 << 12) {
        if let Some(d) = task_damping(model, mech, &q) {
            worst = worst.min(d);
        }
    }
    let period = 1.0 / f64::from(model.rates.impedance_loop_hz);
    let (k, bd) = (rendering.wall_stiffness, rendering.wall_damping);
    let passive = passive_stiffness(b, bd, period);
    let stable = stable_stiffness(b, bd, period);
    let verdict = if k <= passive {
        WallVerdict::Passive
    } else if k <= stable {
        WallVerdict::BeyondPassivity
    } else {
        WallVerdict::BeyondStability
    };
    Some(WallCheck {
        pose,
        task_damping: b,
        worst_task_damping: worst,
        sample_period: period,
        wall_stiffness: k,
        wall_damping: bd,
        passive_stiffness: passive,
        stable_stiffness: stable,
        verdict,
        override_allowed: rendering.allow_unstable_stiffness,
    })
}

/// Line and column of the model's `rendering.wall_stiffness` value in `text` (the variant's
/// override when the model's variant sets it).
pub fn wall_stiffness_position(text: &str, model: &Model) -> (usize, usize) {
    let index = PositionIndex::build(text);
    let key = |k: &str| Segment::Key(k.to_string());
    if let Some(variant) = &model.variant {
        let set = [key("variants"), key(variant), key("set")];
        let dotted = [&set[..], &[key("rendering.wall_stiffness")]].concat();
        if index.contains(&dotted) {
            return index.value(&dotted);
        }
        let nested = [&set[..], &[key("rendering"), key("wall_stiffness")]].concat();
        if index.contains(&nested) {
            return index.value(&nested);
        }
    }
    index.value(&[key("rendering"), key("wall_stiffness")])
}

impl WallCheck {
    /// The explanation shared by the warning and the error.
    fn explain(&self) -> String {
        format!(
            "b = {:.3} N·s/m physical damping in the task space at the mid-range pose, B = {} N·s/m wall \
             damping, T = {} ms: passive up to 2(b − |B|)/T = {:.0} N/m (Colgate & Schenkel), stable without an \
             operator up to 2(b + B)/T = {:.0} N/m",
            self.task_damping,
            self.wall_damping,
            self.sample_period * 1e3,
            self.passive_stiffness,
            self.stable_stiffness
        )
    }

    /// A diagnostic at `rendering.wall_stiffness`: the error when the stiffness is beyond the
    /// stability bound and not overridden, else a warning (`None` when the wall is passive).
    /// The first element is `true` for an error.
    pub fn diagnostic(&self, file: &str, text: &str, model: &Model) -> Option<(bool, Diagnostic)> {
        if self.verdict == WallVerdict::Passive {
            return None;
        }
        let (line, column) = wall_stiffness_position(text, model);
        let error = self.verdict == WallVerdict::BeyondStability && !self.override_allowed;
        let message = match self.verdict {
            WallVerdict::BeyondStability => format!(
                "wall stiffness {} N/m is beyond the stability bound {:.0} N/m of this rig at {} Hz",
                self.wall_stiffness,
                self.stable_stiffness,
                self.model_rate()
            ),
            _ => format!(
                "wall stiffness {} N/m exceeds the passivity bound {:.0} N/m of this rig at {} Hz",
                self.wall_stiffness,
                self.passive_stiffness,
                self.model_rate()
            ),
        };
        let hint = if error {
            format!(
                "{}; lower `wall_stiffness`, raise `wall_damping` or `rates.impedance_loop_hz`, or set \
                 `rendering.allow_unstable_stiffness: true`",
                self.explain()
            )
        } else {
            self.explain()
        };
        let d = Diagnostic {
            file: file.to_string(),
            line,
            column,
            path: "rendering.wall_stiffness".into(),
            message,
            hint: Some(hint),
        };
        Some((error, d))
    }

    fn model_rate(&self) -> String {
        format!("{:.0}", 1.0 / self.sample_period)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_follow_colgate_and_gil() {
        // b = 0.5, B = 0.1, T = 1 ms: passive below 2·0.4/0.001 = 800, stable below 1200.
        assert!((passive_stiffness(0.5, 0.1, 1e-3) - 800.0).abs() < 1e-9);
        assert!((passive_stiffness(0.5, -0.1, 1e-3) - 800.0).abs() < 1e-9);
        assert!((stable_stiffness(0.5, 0.1, 1e-3) - 1200.0).abs() < 1e-9);
        assert_eq!(passive_stiffness(0.1, 5.0, 1e-3), 0.0);
    }

    #[test]
    fn jacobi_finds_eigenvalues() {
        let mut e =
            symmetric_eigenvalues(vec![vec![2.0, 1.0, 0.0], vec![1.0, 2.0, 0.0], vec![0.0, 0.0, 5.0]]);
        e.sort_by(f64::total_cmp);
        for (got, want) in e.iter().zip([1.0, 3.0, 5.0]) {
            assert!((got - want).abs() < 1e-12, "{e:?}");
        }
    }
}
