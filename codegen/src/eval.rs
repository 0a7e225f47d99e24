//! Numeric evaluator of the derived expressions, without compiling anything.
//!
//! It evaluates the canonical polynomials of [`crate::dynamics::mechanics`] directly, term by term, so
//! it is independent of the optimiser and emitter: tests compare the compiled, emitted code
//! against it, and the CLI's `eval` command uses it.

use crate::dynamics::kinematics::{FrameKinematics, PointKinematics};
use crate::dynamics::mechanics::Mechanics;
use crate::sym::poly::{Atom, AtomValues, Poly};

/// Atom values at a state `(q, q̇)` with given tunable parameters (the generator's own, re-exported).
pub use crate::sym::poly::State;

/// Atom values at a state of a model's mechanics: the state's own atoms, and for a closed
/// chain the eliminated ones (passive joints' sines, cosines and velocities, `∂q_p/∂q_a`
/// and its rate), computed in closed form from the actuated state.
pub struct Full<'a> {
    state: &'a State<'a>,
    /// Looked up once per atom of every term: a spatial chain has about a hundred.
    eliminated: std::collections::HashMap<Atom, f64>,
}

impl<'a> Full<'a> {
    /// The values at `state` for `mech`.
    pub fn new(mech: &Mechanics, state: &'a State<'a>) -> Self {
        let eliminated = match &mech.closures {
            Some(c) => c.values(state.q, state.qd, state.parameters).into_iter().collect(),
            None => std::collections::HashMap::new(),
        };
        Full { state, eliminated }
    }

    /// The values at `state` for `mech`, or why a closed chain's loops cannot be closed
    /// there on the file's assembly branch ([`crate::dynamics::closure::Closures::checked_values`]).
    pub fn checked(mech: &Mechanics, state: &'a State<'a>) -> Result<Self, String> {
        let eliminated = match &mech.closures {
            Some(c) => c.checked_values(state.q, state.qd, state.parameters)?.into_iter().collect(),
            None => std::collections::HashMap::new(),
        };
        Ok(Full { state, eliminated })
    }
}

impl AtomValues for Full<'_> {
    fn value(&self, atom: Atom) -> f64 {
        match self.eliminated.get(&atom) {
            Some(&v) => v,
            None => self.state.value(atom),
        }
    }
}

/// Values of the tunable parameters only (everything else zero).
pub struct NominalAtoms<'a>(pub &'a [f64]);

impl AtomValues for NominalAtoms<'_> {
    fn value(&self, atom: Atom) -> f64 {
        match atom {
            Atom::Param(k) => self.0.get(usize::from(k)).copied().unwrap_or(0.0),
            Atom::Cos(_) => 1.0,
            _ => 0.0,
        }
    }
}

/// Every quantity at one state, as plain numbers (matrices row-major as rows).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Evaluated {
    /// Task (or selected point) position.
    pub p: Vec<f64>,
    /// Its Jacobian.
    #[serde(rename = "J")]
    pub jacobian: Vec<Vec<f64>>,
    /// Its Jacobian's time derivative.
    #[serde(rename = "Jdot")]
    pub jacobian_dot: Vec<Vec<f64>>,
    /// `J̇ q̇`.
    #[serde(rename = "Jdot_qd")]
    pub jacobian_dot_times_qdot: Vec<f64>,
    /// Inertia matrix.
    #[serde(rename = "D")]
    pub inertia_matrix: Vec<Vec<f64>>,
    /// Coriolis matrix.
    #[serde(rename = "C")]
    pub coriolis_matrix: Vec<Vec<f64>>,
    /// `C q̇`.
    #[serde(rename = "C_qd")]
    pub coriolis_times_qdot: Vec<f64>,
    /// Gravity vector.
    pub g: Vec<f64>,
    /// Damping matrix (diagonal).
    #[serde(rename = "B")]
    pub damping: Vec<Vec<f64>>,
    /// Potential energy.
    #[serde(rename = "V")]
    pub potential_energy: f64,
    /// A closed chain's passive joint angles (in `(−π, π]`), eliminated from the actuated
    /// state; empty for open chains.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub passive: Vec<f64>,
}

fn vector(v: &[Poly], s: &Full<'_>) -> Vec<f64> {
    v.iter().map(|p| p.eval(s)).collect()
}

fn matrix(m: &[Vec<Poly>], s: &Full<'_>) -> Vec<Vec<f64>> {
    m.iter().map(|row| vector(row, s)).collect()
}

/// Evaluates everything at a state; `point` selects a named point instead of the task.
/// Where a closed chain's loops cannot be closed the values are NaN ([`try_evaluate`] says
/// why).
pub fn evaluate(mech: &Mechanics, state: &State<'_>, point: Option<&PointKinematics>) -> Evaluated {
    evaluate_at(mech, &Full::new(mech, state), point)
}

/// [`evaluate`], or why its numbers would not be valid: a closed chain's loops that cannot be
/// closed at the state on the file's assembly branch, or any value that is not finite (named).
pub fn try_evaluate(
    mech: &Mechanics,
    state: &State<'_>,
    point: Option<&PointKinematics>,
) -> Result<Evaluated, String> {
    let evaluated = evaluate_at(mech, &Full::checked(mech, state)?, point);
    let vector = |name: &str, v: &[f64]| {
        first_non_finite(v.iter().copied()).map(|(i, x)| format!("{name}[{i}] = {x}"))
    };
    let matrix = |name: &str, m: &[Vec<f64>]| {
        let n = m.first().map_or(1, Vec::len).max(1);
        first_non_finite(m.iter().flatten().copied())
            .map(|(k, x)| format!("{name}[{}][{}] = {x}", k / n, k % n))
    };
    let bad = vector("p", &evaluated.p)
        .or_else(|| matrix("J", &evaluated.jacobian))
        .or_else(|| matrix("Jdot", &evaluated.jacobian_dot))
        .or_else(|| vector("Jdot_qd", &evaluated.jacobian_dot_times_qdot))
        .or_else(|| matrix("D", &evaluated.inertia_matrix))
        .or_else(|| matrix("C", &evaluated.coriolis_matrix))
        .or_else(|| vector("C_qd", &evaluated.coriolis_times_qdot))
        .or_else(|| vector("g", &evaluated.g))
        .or_else(|| matrix("B", &evaluated.damping))
        .or_else(|| vector("V", &[evaluated.potential_energy]))
        .or_else(|| vector("passive", &evaluated.passive));
    match bad {
        Some(what) => Err(format!("a value is not finite at this state: {what}")),
        None => Ok(evaluated),
    }
}

/// The first value that is not finite, with its index.
fn first_non_finite(values: impl Iterator<Item = f64>) -> Option<(usize, f64)> {
    values.enumerate().find(|(_, x)| !x.is_finite())
}

fn evaluate_at(mech: &Mechanics, state: &Full<'_>, point: Option<&PointKinematics>) -> Evaluated {
    let kin = point.unwrap_or(&mech.task);
    let n = mech.joints;
    let damping = vector(&mech.damping, state);
    Evaluated {
        p: vector(&kin.position, state),
        jacobian: matrix(&kin.jacobian, state),
        jacobian_dot: matrix(&kin.jacobian_dot, state),
        jacobian_dot_times_qdot: vector(&kin.jacobian_dot_times_qdot, state),
        inertia_matrix: matrix(&mech.inertia_matrix, state),
        coriolis_matrix: matrix(&mech.coriolis_matrix, state),
        coriolis_times_qdot: vector(&mech.coriolis_times_qdot, state),
        g: vector(&mech.gravity, state),
        damping: (0..n).map(|i| (0..n).map(|j| if i == j { damping[i] } else { 0.0 }).collect()).collect(),
        potential_energy: mech.potential_energy.eval(state),
        passive: match &mech.closures {
            Some(c) => (c.actuated..c.names.len())
                .map(|j| state.value(Atom::Sin(j as u16)).atan2(state.value(Atom::Cos(j as u16))))
                .collect(),
            None => Vec::new(),
        },
    }
}

/// A named frame's orientation at one state.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EvaluatedFrame {
    /// Rotation matrix of the frame in the base frame.
    #[serde(rename = "R")]
    pub rotation: Vec<Vec<f64>>,
    /// Angular-velocity Jacobian (3 × joints), base-frame coordinates.
    #[serde(rename = "J_omega")]
    pub angular_jacobian: Vec<Vec<f64>>,
}

/// Evaluates a named frame's rotation and angular-velocity Jacobian at a state.
pub fn evaluate_frame(mech: &Mechanics, state: &State<'_>, frame: &FrameKinematics) -> EvaluatedFrame {
    let state = &Full::new(mech, state);
    EvaluatedFrame {
        rotation: matrix(&frame.rotation, state),
        angular_jacobian: matrix(&frame.angular_jacobian, state),
    }
}

/// [`evaluate_frame`], or why its numbers would not be valid (as [`try_evaluate`]).
pub fn try_evaluate_frame(
    mech: &Mechanics,
    state: &State<'_>,
    frame: &FrameKinematics,
) -> Result<EvaluatedFrame, String> {
    let full = &Full::checked(mech, state)?;
    let evaluated = EvaluatedFrame {
        rotation: matrix(&frame.rotation, full),
        angular_jacobian: matrix(&frame.angular_jacobian, full),
    };
    let values = evaluated.rotation.iter().chain(&evaluated.angular_jacobian).flatten().copied();
    match first_non_finite(values) {
        Some((k, x)) => {
            Err(format!("a value of frame `{}` is not finite at this state: {x} (entry {k})", frame.name))
        }
        None => Ok(evaluated),
    }
}
