//! Cargo builds that tests start themselves — trybuild's compile-fail and pass cases of the
//! `rig!` macro (`macros/tests/compile_fail.rs`) and the rebuild probe
//! (`tests/tests/rebuild.rs`) — and the one target directory and settings they share.
//!
//! Both build the macro, the generator and the runtime with all their dependencies in a
//! workspace of their own, outside this one. trybuild places its project in
//! `<target dir>/tests/trybuild/<crate>` and builds it with `CARGO_TARGET_DIR` set to
//! `<target dir>/tests/trybuild` and its own rustflags ([`TRYBUILD_RUSTFLAGS`]), and with no
//! profile of ours (its manifest copies none): left alone, that is a full debug build at
//! `opt-level = 0` with full debug information, and the probe, with settings of its own, was a
//! third build of the same crates. Instead, [`prepare`] writes a cargo configuration into
//! `<target dir>/tests/trybuild/.cargo/` that both builds read (cargo reads configuration from
//! the directories above the one it runs in): no debug information. The probe runs in that
//! directory too, with trybuild's rustflags and `--target` ([`host_triple`]), so the
//! dependencies are compiled once for both.
//!
//! This file is a module of `hapticgen-tests` and is included by path into the macro crate's
//! test, which cannot depend on `hapticgen-tests`.

use std::path::{Path, PathBuf};

/// The rustflags trybuild gives the builds of its cases (`trybuild::rustflags`, 1.0.x):
/// `--config build.rustflags=…` with these makes another build's units identical to its.
pub const TRYBUILD_RUSTFLAGS: &str = r#"["--cfg", "trybuild", "--verbose", "-A", "dead_code"]"#;

/// The profile of the nested builds: cargo's `dev` profile without debug information, which
/// no nested build needs. It stays at `opt-level = 0` everywhere, the generator included:
/// the cases expand small models, for which compiling the generator with optimisation costs
/// far more than it saves (measured: trybuild's build took 13 CPU-minutes with the workspace's
/// `opt-level = 3` for the generator).
const NESTED_PROFILE: &str = r#"# Written by the tests (tests/src/nested_builds.rs): the profile of the builds that trybuild
# and the rebuild probe start in this directory.
[profile.dev]
debug = 0
incremental = false
"#;

/// The host's target triple (`rustc -vV`): trybuild builds with `--target` set to it, which
/// keeps the rustflags off build scripts and proc-macros; another build must do the same to
/// share their units.
pub fn host_triple() -> String {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let output = std::process::Command::new(rustc).arg("-vV").output().expect("rustc runs");
    let text = String::from_utf8_lossy(&output.stdout);
    text.lines()
        .find_map(|line| line.strip_prefix("host: "))
        .expect("rustc -vV names the host")
        .trim()
        .to_string()
}

/// The target directory cargo builds this workspace in, as `cargo metadata` reports it: the
/// default `<workspace>/target`, or wherever `CARGO_TARGET_DIR` or `build.target-dir` put it.
/// trybuild asks the same question to place its projects; tests that build or write files
/// put them under this directory, never at a path assumed inside the repository.
pub fn target_dir() -> PathBuf {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = std::process::Command::new(cargo)
        .args(["metadata", "--format-version=1", "--no-deps", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(output.status.success(), "cargo metadata failed:\n{}", String::from_utf8_lossy(&output.stderr));
    let metadata: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("cargo metadata prints JSON");
    let dir = metadata["target_directory"].as_str().expect("cargo metadata names the target directory");
    PathBuf::from(dir)
}

/// The directory of the nested builds, `<target dir>/tests/trybuild`, with the shared
/// configuration written into its `.cargo/config.toml` (rewritten only when it differs, so
/// that cargo sees no change).
pub fn prepare() -> PathBuf {
    let nested = target_dir().join("tests").join("trybuild");
    let config = nested.join(".cargo").join("config.toml");
    write_if_changed(&config, NESTED_PROFILE);
    nested
}

/// Writes `text` to `path` (creating its directory) unless it already holds exactly that.
pub fn write_if_changed(path: &Path, text: &str) {
    if std::fs::read_to_string(path).ok().as_deref() == Some(text) {
        return;
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    }
    std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}
