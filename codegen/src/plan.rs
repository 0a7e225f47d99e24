//! Plan: which derivation each emitted function uses, between the dynamics and the emission.
//!
//! Every quantity of eq. (1)–(2) can be derived in more than one way ([`Choice`]: Lagrangian
//! polynomials, or recursive Newton–Euler, composite-rigid-body and frame composition). An
//! [`Output`] names what one entry of a function is; [`cheapest_choice`] builds the outputs
//! under each admissible choice and keeps the one whose optimised DAG takes the fewest
//! operations (the default on a tie), and [`derivation_note`] says in the function's doc
//! comment which derivation was used.

use rustc_hash::FxHashMap as HashMap;

use crate::dynamics::mechanics::{Choice, Derivation, Mechanics};
use crate::dynamics::recursive::{PointQuantity, Quantity};
use crate::model::Model;
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::Poly;

/// Where an output's expression comes from.
#[derive(Clone, Copy, Debug)]
pub enum Output<'a> {
    /// A polynomial of the mechanics.
    Poly(&'a Poly),
    /// Entry `k` (row-major) of a quantity built with the model's derivation
    /// ([`Mechanics::build`]): polynomial or recursive.
    Quantity(Quantity, usize),
}

/// The DAG nodes of `outputs` with the model's default derivations; each quantity is built
/// once per DAG.
pub(crate) fn output_roots(
    dag: &mut Dag,
    model: &Model,
    mech: &Mechanics,
    outputs: &[Output<'_>],
) -> Vec<NodeId> {
    output_roots_with(dag, model, mech, outputs, mech.choice())
}

/// The DAG nodes of `outputs` with the derivations of `choice`; each quantity is built once
/// per DAG.
pub(crate) fn output_roots_with(
    dag: &mut Dag,
    model: &Model,
    mech: &Mechanics,
    outputs: &[Output<'_>],
    choice: Choice,
) -> Vec<NodeId> {
    let mut built: HashMap<Quantity, Vec<NodeId>> = HashMap::default();
    outputs
        .iter()
        .map(|output| match *output {
            Output::Poly(p) => dag.polynomial(p),
            Output::Quantity(q, k) => {
                built.entry(q).or_insert_with(|| mech.build_with(dag, model, q, choice))[k]
            }
        })
        .collect()
}

/// How a function's outputs were derived, for its doc comment (empty for the Lagrangian
/// polynomials, which the module documentation describes).
pub(crate) fn derivation_note(outputs: &[Output<'_>], choice: Choice) -> &'static str {
    let Some(Output::Quantity(quantity, _)) = outputs.iter().find(|o| matches!(o, Output::Quantity(..)))
    else {
        return "";
    };
    match (quantity, choice.dynamics, choice.kinematics) {
        (Quantity::Point(_, PointQuantity::JacobianDotTimesQdot), _, Derivation::Recursive) => {
            " Built by the Newton–Euler forward pass at `q̈ = 0`."
        }
        (Quantity::Point(_, PointQuantity::Jacobian), _, Derivation::Recursive) => {
            " Built by composing the joint frames (columns `z_k × (p − o_k)`)."
        }
        (Quantity::Point(..) | Quantity::Frame(..), _, Derivation::Recursive) => {
            " Built by composing the joint frames."
        }
        (Quantity::Point(_, PointQuantity::Position), _, Derivation::Projected) => "",
        (Quantity::Point(_, PointQuantity::Jacobian), _, Derivation::Projected) => {
            " Projected from the open tree's: `J S`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (Quantity::Point(..) | Quantity::Frame(..), _, Derivation::Projected) => {
            " Projected from the open tree's: `J̇ q̇ + J (Ṡ q̇_a)`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (Quantity::Point(..) | Quantity::Frame(..), _, Derivation::Polynomial) => "",
        (Quantity::InertiaMatrix, Derivation::Projected, _) => {
            " Projected from the open tree's: `Sᵀ D S`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (Quantity::CoriolisMatrix, Derivation::Projected, _) => {
            " Projected from the open tree's: `Sᵀ (C S + D Ṡ)`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (Quantity::Gravity, Derivation::Projected, _) => {
            " Projected from the open tree's: `Sᵀ g`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (_, Derivation::Projected, _) => {
            " Projected from the open tree's: `Sᵀ D S`, `Sᵀ (C q̇ + D (Ṡ q̇_a))`, `Sᵀ g`, with `S = ∂q/∂q_a` from the loop solution."
        }
        (Quantity::InertiaMatrix, Derivation::Recursive, _) => {
            " Built by the composite-rigid-body algorithm."
        }
        (Quantity::CoriolisMatrix, Derivation::Recursive, _) => {
            " `D` from the composite-rigid-body algorithm, differentiated on the expression graph."
        }
        (_, Derivation::Recursive, _) => " Built by the recursive Newton–Euler algorithm.",
        (Quantity::CoriolisTimesQdot | Quantity::InverseDynamics, Derivation::Polynomial, _)
            if choice.structured_coriolis =>
        {
            " `C q̇` in the Christoffel form `Σ_{i≤j} Γ_kij q̇_i q̇_j` over shared partial derivatives of `D`."
        }
        _ => "",
    }
}

/// The derivation choice under which `outputs` take the fewest operations on their own,
/// counted as emitted with or without fused multiply-adds.
pub(crate) fn cheapest_choice(
    model: &Model,
    mech: &Mechanics,
    outputs: &[Output<'_>],
    fused_multiply_add: bool,
) -> Choice {
    if !outputs.iter().any(|o| matches!(o, Output::Quantity(..))) {
        return mech.choice();
    }
    let cost = |choice: Choice| {
        // With a closed chain's elimination in front, as the emitted function has it: its
        // cost counts where a derivation reads it.
        let (mut dag, _) = crate::dynamics::closure::graph_with(mech.closures.as_ref());
        let roots = output_roots_with(&mut dag, model, mech, outputs, choice);
        let counts = dag.optimised_count_with(&roots, fused_multiply_add);
        counts.arithmetic() + counts.trigonometric
    };
    // The default first, so that a tie keeps it. The candidates are costed on two threads
    // (each builds and optimises its own graph; the machine this targets has two cores).
    let candidates: Vec<Choice> = std::iter::once(mech.choice()).chain(mech.choices(model)).collect();
    let costs: Vec<usize> = if candidates.len() > 2 {
        let (first, second) = candidates.split_at(candidates.len() / 2);
        std::thread::scope(|scope| {
            let other = scope.spawn(|| second.iter().map(|&c| cost(c)).collect::<Vec<_>>());
            let mut costs: Vec<usize> = first.iter().map(|&c| cost(c)).collect();
            // A panic on the other thread is the generator's bug: passed on as it is.
            costs.extend(other.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)));
            costs
        })
    } else {
        candidates.iter().map(|&c| cost(c)).collect()
    };
    let mut best = (costs[0], candidates[0]);
    for (&c, &choice) in costs.iter().zip(&candidates).skip(1) {
        if c < best.0 {
            best = (c, choice);
        }
    }
    best.1
}
