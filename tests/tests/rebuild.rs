//! Rebuild tracking of the `rig!` macro, end to end: a small crate that uses `rig!` on a model
//! file is built with cargo; editing the model makes cargo rebuild it (the expansion
//! `include_bytes!`s the file) and the new numbers come out; building again without an edit
//! compiles nothing. The probe crate lives in `<target dir>/tests/trybuild/rebuild-probe` (the
//! workspace's target directory, wherever `CARGO_TARGET_DIR` puts it) and builds with the
//! settings and in the target directory of the `rig!` macro's trybuild cases
//! (`hapticgen_tests::nested_builds`), so the macro, the generator, the runtime and their
//! dependencies are compiled once for both.

use std::path::Path;
use std::process::Command;

use hapticgen_tests::nested_builds::{self, TRYBUILD_RUSTFLAGS};
use hapticgen_tests::workspace_root;

/// `cargo SUBCOMMAND` on the probe, in its directory (so that the nested builds' configuration
/// applies), with trybuild's target directory, rustflags and environment.
fn cargo(probe: &Path, target: &Path, subcommand: &str) -> Command {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .current_dir(probe)
        .arg(subcommand)
        .arg(format!("--config=build.rustflags={TRYBUILD_RUSTFLAGS}"))
        .args(["--target", &nested_builds::host_triple()])
        .env("CARGO_TARGET_DIR", target)
        .env("CARGO_INCREMENTAL", "0")
        .env_remove("RUSTFLAGS");
    command
}

fn cargo_run(probe: &Path, target: &Path) -> (String, String) {
    let output = cargo(probe, target, "run")
        .arg("--quiet")
        .env("CARGO_TERM_QUIET", "false")
        .output()
        .expect("cargo runs");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "probe build failed:\n{stderr}");
    (stdout, stderr)
}

fn build_log(probe: &Path, target: &Path) -> String {
    let output = cargo(probe, target, "build").output().expect("cargo runs");
    assert!(output.status.success());
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn editing_the_model_file_rebuilds_the_crate_that_uses_it() {
    let root = workspace_root().canonicalize().expect("workspace root");
    let target = nested_builds::prepare();
    let probe = target.join("rebuild-probe");
    std::fs::create_dir_all(probe.join("src")).unwrap();
    let manifest = format!(
        "[package]\nname = \"rebuild-probe\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n\
         [dependencies]\nhapticgen-macros = {{ path = {:?} }}\nhapticgen-runtime = {{ path = {:?} }}\n\n[workspace]\n",
        root.join("macros"),
        root.join("runtime")
    );
    std::fs::write(probe.join("Cargo.toml"), manifest).unwrap();
    if !probe.join("Cargo.lock").exists() {
        // The workspace's lockfile pins the same dependency versions.
        std::fs::copy(root.join("Cargo.lock"), probe.join("Cargo.lock")).unwrap();
    }
    std::fs::write(
        probe.join("src/main.rs"),
        "hapticgen_macros::rig!(mod pendulum = \"model.yaml\");\n\n\
         fn main() {\n    println!(\"{:e}\", pendulum::Pendulum::NOMINAL.inertia_matrix(&[0.0])[0][0]);\n}\n",
    )
    .unwrap();
    let original = std::fs::read_to_string(root.join("tests/ui/models/pendulum.yaml")).unwrap();
    std::fs::write(probe.join("model.yaml"), &original).unwrap();
    let (before, _) = cargo_run(&probe, &target);

    // The same model with a heavier rod: D = N² J_m + m L²/3 grows.
    let heavier = original.replace("    mass: 0.1\n", "    mass: 0.2\n");
    assert_ne!(heavier, original);
    std::fs::write(probe.join("model.yaml"), &heavier).unwrap();
    let log = build_log(&probe, &target);
    assert!(log.contains("Compiling rebuild-probe"), "editing the model did not rebuild the crate:\n{log}");
    let (after, _) = cargo_run(&probe, &target);
    let (d_before, d_after): (f64, f64) = (before.trim().parse().unwrap(), after.trim().parse().unwrap());
    // Independent value of the change: Δm · L_com² + Δm L²/12 = 0.1 · (0.1² + 0.2²/12).
    let expected = 0.1 * (0.1f64.powi(2) + 0.2f64.powi(2) / 12.0);
    assert!(
        ((d_after - d_before) - expected).abs() < 1e-12,
        "D changed by {} (expected {expected})",
        d_after - d_before
    );

    let log = build_log(&probe, &target);
    assert!(!log.contains("Compiling rebuild-probe"), "an unchanged model rebuilt the crate:\n{log}");
}
