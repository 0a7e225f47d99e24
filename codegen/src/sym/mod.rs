//! The symbolic engine: canonical polynomials ([`poly`]) for derivation and simplification,
//! a hash-consed expression DAG ([`dag`]) for optimisation and emission.
pub mod dag;
pub mod poly;
pub mod signs;
