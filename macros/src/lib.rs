//! The `rig!` proc-macro: generates a rig's dynamics from its model file at compile time.
//!
//! A thin shell over [`hapticgen_codegen::rig_macro::expand`]; the generated items implement
//! `hapticgen_runtime::RigModel`, so the invoking crate depends on `hapticgen-runtime` too.
//!
//! ```
//! hapticgen_macros::rig!(pub mod parallel_link = "../models/parallel_link_2dof.yaml", variant = "horizontal", scalar = f64);
//!
//! let rig = parallel_link::ParallelLink2dof::NOMINAL;
//! let d = rig.inertia_matrix(&[1.2, 0.3]);
//! assert!(d[0][0] > 0.0 && d[0][1] == d[1][0]);
//! ```
//!
//! The path is relative to the invoking crate's `CARGO_MANIFEST_DIR`. Editing the model file
//! rebuilds the crate (the expansion `include_bytes!`s it). A bad model is a compile error
//! naming the file, line, column, key path and rule, spanned on the path literal.

use proc_macro::TokenStream;

/// Generates `mod NAME { ... }` with the rig's struct, its functions and its
/// `hapticgen_runtime::RigModel` implementation.
///
/// Syntax: `rig!(VIS mod NAME = "MODEL.yaml" [, variant = "VARIANT"] [, scalar = f32 | f64]);`
#[proc_macro]
pub fn rig(input: TokenStream) -> TokenStream {
    let manifest_dir =
        std::env::var_os("CARGO_MANIFEST_DIR").map(std::path::PathBuf::from).unwrap_or_default();
    hapticgen_codegen::rig_macro::expand(input.into(), &manifest_dir).into()
}
