//! Model-level analyses that produce diagnostics: the current-loop design of every drive and
//! the stability of virtual walls.

pub mod current_loop;
pub mod stability;
