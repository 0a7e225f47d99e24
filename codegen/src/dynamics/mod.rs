//! The mechanics of a model, derived symbolically: the terms of the paper's eq. (1)–(2),
//! `D(q) q̈ + C(q, q̇) q̇ + g(q) + B q̇ = τ`, and the task kinematics `p(q)`, `J(q)`, `J̇ q̇`.
//!
//! [`kinematics`] composes the body frames; `lagrangian` and [`recursive`] are the two
//! derivations of the dynamics (expanded polynomials; Newton–Euler and composite rigid body on
//! the expression DAG); [`mechanics`] holds the derived quantities and builds them into a DAG
//! by either derivation; [`closure`] analyses a closed chain's loops (planar ones in closed
//! form, spatial ones numerically in [`spatial_loops`], or in closed form where they are a
//! Delta's, [`three_spheres`]) and `reduction` reduces the open tree's mechanics to the
//! actuated coordinates; [`regressor`] writes the inverse dynamics linear in the base
//! parameters for identification.

pub mod closure;
pub mod kinematics;
mod lagrangian;
pub mod mechanics;
mod projection;
pub mod recursive;
mod reduction;
pub mod regressor;
pub mod spatial_loops;
pub mod three_spheres;

use crate::model::Model;
use closure::Closures;
pub use lagrangian::reflected_rotor_inertia;
use mechanics::{choose_derivations, derive_tree, Mechanics};
use reduction::reduce;

/// Derives every quantity of the model as polynomials (what the evaluator, the simulator and
/// the checks use), and chooses the derivation of the emitted code.
pub fn derive(model: &Model, closures: Option<&Closures>) -> Mechanics {
    derive_with(model, closures, true)
}

/// Derives what emission needs: on the recursive path the polynomials of `D`, `C`, `C q̇` and
/// `g` are not expanded at all (the emitter builds them recursively), which is what keeps
/// generation of long chains fast.
pub fn derive_for_emission(model: &Model, closures: Option<&Closures>) -> Mechanics {
    derive_with(model, closures, false)
}

fn derive_with(model: &Model, closures: Option<&Closures>, all_polynomials: bool) -> Mechanics {
    if let Some(closures) = closures {
        // A closed chain: reduced to the actuated coordinates as polynomials (see
        // `crate::dynamics::closure`), from the open tree's; the emitted code uses those
        // polynomials as they are, or a spatial chain's tree projected on the DAG
        // (`projection`), whichever is cheaper.
        let mut mechanics = reduce(derive_tree(model, true), closures);
        choose_derivations(model, &mut mechanics);
        return mechanics;
    }
    let mut mechanics = derive_tree(model, all_polynomials);
    choose_derivations(model, &mut mechanics);
    mechanics
}
