//! Dynamic identification: from a model file of estimates to a model file of the device.
//!
//! `τ = Y(q, q̇, q̈) β` is linear in the base parameters β ([`regressor`]); an excitation
//! trajectory designed for a well-conditioned stacked regressor ([`excite`]), played on the
//! device or the simulator ([`experiment`]) and logged ([`log`]), gives β by weighted least
//! squares ([`fit`]); physically consistent standard parameters that reproduce β
//! ([`consistent`]) are written back into the model file's own text ([`model_file`]). Where
//! the device is known (a simulated one), [`truth`] says how far the identified model is from
//! it.

pub mod commands;
pub mod consistent;
pub mod excite;
pub mod experiment;
pub mod fit;
pub mod log;
pub mod model_file;
pub mod regressor;
pub mod trajectory;
pub mod truth;
