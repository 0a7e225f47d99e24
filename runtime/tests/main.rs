//! The runtime's integration tests as one test binary: each file of this folder is a module of
//! it (`common` holds the hand-derived test rigs they share). `cargo test -p hapticgen-runtime
//! --test runtime MODULE::` runs one file's tests, e.g. `closed_loop::`.

mod closed_loop;
mod common;
mod coupling;
mod friction;
mod laws;
mod loops;
mod proxy;
mod render;
mod safety_rules;
mod tick;
