//! The mechanics of a model, derived symbolically: the terms of the paper's eq. (1)–(2),
//! `D(q) q̈ + C(q, q̇) q̇ + g(q) + B q̇ = τ`, and the task kinematics `p(q)`, `J(q)`, `J̇ q̇`.
//!
//! [`mechanics`] holds the derived quantities and the polynomial derivation (Lagrangian,
//! Christoffel symbols); [`recursive`] runs Newton–Euler and composite-rigid-body on the
//! expression DAG; [`closure`] eliminates the passive joints of closed chains.

pub mod closure;
pub mod mechanics;
pub mod recursive;
