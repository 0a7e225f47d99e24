//! Compile-fail tests of the `rig!` macro, like thiserror's `tests/ui/`: one problem per file,
//! each expected error naming the model file, line, column, key path and rule, spanned on the
//! macro's path literal. The `.stderr` files were written with the toolchain pinned in
//! `rust-toolchain.toml` (Rust 1.95.0); another compiler version may word rustc's own parts
//! differently.
//!
//! trybuild compiles each case as a crate of its own, whose manifest directory — the
//! `CARGO_MANIFEST_DIR` the macro resolves model paths against — is
//! `<target dir>/tests/trybuild/hapticgen-macros/`, wherever the target directory is
//! (`CARGO_TARGET_DIR` may put it outside the repository). So that the cases do not depend on
//! where that is, the test first mirrors the model files the cases read into that directory at
//! their workspace-relative paths (`models/`, `tests/ui/models/`, `codegen/tests/closed-chains/`): a case names
//! `"tests/ui/models/negative-mass.yaml"`, and its expected error reads
//! `tests/ui/models/negative-mass.yaml:20:11: …`.
//!
//! The cases live in this crate rather than in `hapticgen-tests` because trybuild builds the
//! crate under test with all its dependencies: here the macro, the generator and the runtime,
//! not the tests crate's every generated rig, nalgebra and proptest. They build with the
//! profile `tests/src/nested_builds.rs` writes for trybuild's directory (the generator
//! optimised, no debug information), and share the built dependencies with the rebuild probe.

use std::path::{Path, PathBuf};

// The nested builds' shared directory and settings (this crate cannot depend on
// `hapticgen-tests`, whose module it is).
#[path = "../../tests/src/nested_builds.rs"]
#[allow(dead_code)] // the probe's part (`TRYBUILD_RUSTFLAGS`) is not used here
mod nested_builds;

/// The directories of model files the cases name, relative to the workspace root.
const MODEL_DIRS: [&str; 3] = ["models", "tests/ui/models", "codegen/tests/closed-chains"];

/// Copies every `.yaml` file of `from` into `to` (rewriting only files whose content differs).
fn mirror_yaml_files(from: &Path, to: &Path) -> usize {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("{}: {e}", to.display()));
    let mut copied = 0;
    for entry in std::fs::read_dir(from).unwrap_or_else(|e| panic!("{}: {e}", from.display())) {
        let path = entry.expect("directory entry").path();
        if path.extension().is_some_and(|x| x == "yaml") {
            let text = std::fs::read(&path).expect("readable model file");
            let copy = to.join(path.file_name().expect("a file name"));
            if std::fs::read(&copy).ok().as_deref() != Some(text.as_slice()) {
                std::fs::write(&copy, &text).unwrap_or_else(|e| panic!("{}: {e}", copy.display()));
            }
            copied += 1;
        }
    }
    copied
}

/// The `.rs` cases of a folder of this crate.
fn case_files(dir: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    entries
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect()
}

#[test]
fn rig_macro_reports_bad_input_as_compile_errors() {
    // trybuild passes when a glob matches nothing: make an emptied case folder fail here.
    for (dir, expect_stderr) in [("tests/ui/fail", true), ("tests/ui/pass", false)] {
        let cases = case_files(dir);
        assert!(!cases.is_empty(), "no cases in {dir}");
        for case in cases.iter().filter(|_| expect_stderr) {
            let stderr = case.with_extension("stderr");
            assert!(stderr.exists(), "{} has no expected {}", case.display(), stderr.display());
        }
    }
    // trybuild's project directory for this crate (its `Runner::prepare`), below the nested
    // builds' directory with its shared profile.
    let project = nested_builds::prepare().join(env!("CARGO_PKG_NAME"));
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for dir in MODEL_DIRS {
        let copied = mirror_yaml_files(&workspace.join(dir), &project.join(dir));
        assert!(copied > 0, "no model files in {dir}");
    }
    let cases = trybuild::TestCases::new();
    cases.compile_fail("tests/ui/fail/*.rs");
    cases.pass("tests/ui/pass/*.rs");
}
