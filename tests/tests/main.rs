//! The workspace-level tests as one test binary: each file of this folder is a module of it, so
//! that the generated rigs of the tests crate (and nalgebra, proptest, insta) are linked once
//! rather than once per file. `cargo test -p hapticgen-tests --test workspace MODULE::` runs one
//! file's tests, e.g. `properties::`.

mod baseline;
mod current_loop;
mod fused;
mod macro_rigs;
mod no_alloc;
mod numerical;
mod orientation;
mod properties;
mod proxy;
mod random_chain;
mod rebuild;
mod recursive_properties;
mod regressor;
mod snapshot_text;
mod snapshots;
mod structure;
mod tick;
