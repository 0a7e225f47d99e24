//! Compile-fail tests of the `rig!` macro, like thiserror's `tests/ui/`: one problem per file,
//! each expected error naming the model file, line, column, key path and rule, spanned on the
//! macro's path literal. The `.stderr` files were written with the toolchain pinned in
//! `rust-toolchain.toml` (Rust 1.95.0); another compiler version may word rustc's own parts
//! differently.
//!
//! trybuild compiles each case in `target/tests/trybuild/hapticgen-tests/`, which is the
//! `CARGO_MANIFEST_DIR` the macro resolves model paths against; hence the `../../../../`.

#[test]
fn rig_macro_reports_bad_input_as_compile_errors() {
    let cases = trybuild::TestCases::new();
    cases.compile_fail("ui/fail/*.rs");
    cases.pass("ui/pass/*.rs");
}
