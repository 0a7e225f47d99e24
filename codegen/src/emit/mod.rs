//! Emission of straight-line Rust from the derived mechanics.
//!
//! For each quantity of eq. (1)–(2) (`D`, `C`, `C q̇`, `g`, `B`, `p`, `J`, `J̇`, `J̇ q̇`) and
//! for the fused per-tick `terms` function, the polynomials go into one hash-consed DAG, and
//! each node used more than once becomes a named `let`. Sines and cosines of each angle are
//! computed once per function. The items implement `::hapticgen_runtime::RigModel`; everything
//! that is the same for every rig stays in the runtime.
//!
//! One job per file; each uses only files listed before it (and `crate::plan`, which
//! decides the derivation of each function's outputs before emission):
//!
//! - `literal` — the scalar type and its literals;
//! - `naming` — the names of inputs and of the rig type;
//! - `lower` — lowering an optimised DAG to `let` statements and expressions;
//! - `catalogue` — which functions are emitted, their shapes and outputs, tick counts;
//! - `methods` — each catalogue entry, `terms` and `closure_margin` as a method;
//! - `loops` — a spatial closed chain's constraints, as the runtime's loop solver reads them;
//! - [`laws`] — the fused control laws' DAGs (uses none of the files above);
//! - `fused_impl` — those laws as the `FusedImpedance` implementation;
//! - `items` — the struct, its constants, methods and trait implementations.
//!
//! This file only declares the modules and re-exports the public interface.

mod catalogue;
mod fused_impl;
mod items;
pub mod laws;
mod literal;
mod loops;
mod lower;
mod methods;
mod naming;

pub(crate) use naming::camel_case;

pub use crate::plan::Output;
pub use catalogue::{function_specs, tick_counts, tick_counts_with, FunctionSpec, Shape};
pub use items::{items, Stats};
pub use literal::Scalar;
pub use lower::EmitOptions;
pub use methods::function;
pub use naming::rig_type_name;
