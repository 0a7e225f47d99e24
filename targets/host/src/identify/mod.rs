//! Dynamic identification (docs/identification.md): from identified base parameters to a
//! physically consistent model file.
//!
//! * [`consistent`]: standard parameters that reproduce the identified base parameters with
//!   every body's pseudo-inertia positive semi-definite;
//! * [`model_file`]: those parameters written back into the model file's text.

pub mod consistent;
pub mod model_file;
