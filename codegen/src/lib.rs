//! hapticgen's code generator: model files → symbolic mechanics → optimised, emitted Rust.
pub mod current_loop;
