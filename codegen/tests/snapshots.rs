//! The generated code of every shipped model equals its reviewed snapshot in
//! `tests/tests/snapshots/` (the files `cargo insta review` maintains for the tests crate's
//! snapshot test): each model, variant and scalar type unfused, and the parallel link with fused
//! multiply-adds in `f32`.
//!
//! The tests crate asserts the same snapshots, but it builds every shipped rig in its build
//! script first; here the generator's own tests see a change to the emitted text, which is what
//! lets mutation testing of `codegen/src/emit` run on `cargo test -p hapticgen-codegen`
//! (docs/mutation-testing.md). The snapshot files are only read.

use std::path::{Path, PathBuf};

use hapticgen_codegen::{build, EmitOptions, Scalar};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The text of a snapshot after insta's header (`---` … `---`).
fn snapshot_body(name: &str) -> String {
    let path = root().join(format!("tests/tests/snapshots/snapshots__{name}.snap"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let rest = text.strip_prefix("---\n").unwrap_or_else(|| panic!("{}: no insta header", path.display()));
    let end = rest.find("\n---\n").unwrap_or_else(|| panic!("{}: no end of header", path.display()));
    rest[end + "\n---\n".len()..].to_string()
}

fn check(
    name: &str,
    path: &Path,
    display: &str,
    variant: Option<&str>,
    scalar: Scalar,
    options: EmitOptions,
) {
    let model = hapticgen_codegen::load_file(path, display, variant).unwrap_or_else(|e| panic!("{e}"));
    // `…_newton_f64`: a Delta with its loops solved by Newton's method.
    let model = if name.ends_with("_newton_f64") { model.with_loops_solved_numerically() } else { model };
    let generated = hapticgen_codegen::generate_model_with(model, scalar, options).file_text();
    let expected = snapshot_body(name);
    if generated.trim_end() != expected.trim_end() {
        let line = generated
            .lines()
            .zip(expected.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| generated.lines().count().min(expected.lines().count()));
        panic!(
            "{name}: the generated code differs from its snapshot from line {} on:\n  generated: {:?}\n  snapshot:  {:?}",
            line + 1,
            generated.lines().nth(line),
            expected.lines().nth(line)
        );
    }
}

#[test]
fn generated_code_equals_the_reviewed_snapshots() {
    let models = build::models_in(&root().join("models"), "models").unwrap_or_else(|e| panic!("{e}"));
    let mut checked = 0;
    for entry in &models {
        let model =
            hapticgen_codegen::load_file(&entry.path, &entry.display, None).unwrap_or_else(|e| panic!("{e}"));
        for variant in &entry.variants {
            for scalar in [Scalar::F64, Scalar::F32] {
                let name = format!(
                    "{}{}_{}",
                    model.name,
                    variant.as_ref().map(|v| format!("_{v}")).unwrap_or_default(),
                    scalar.name()
                );
                let options = EmitOptions { fused_multiply_add: false, ..Default::default() };
                check(&name, &entry.path, &entry.display, variant.as_deref(), scalar, options);
                checked += 1;
            }
        }
        if model
            .analyses
            .closures
            .as_ref()
            .and_then(|c| c.spatial.as_ref())
            .is_some_and(|s| s.closed_form.is_some())
        {
            let name = format!("{}_newton_f64", model.name);
            let options = EmitOptions { fused_multiply_add: false, ..Default::default() };
            check(&name, &entry.path, &entry.display, None, Scalar::F64, options);
            checked += 1;
        }
    }
    for variant in ["vertical", "horizontal"] {
        check(
            &format!("parallel_link_2dof_{variant}_f32_fma"),
            &root().join("models/parallel_link_2dof.yaml"),
            "models/parallel_link_2dof.yaml",
            Some(variant),
            Scalar::F32,
            EmitOptions { fused_multiply_add: true, ..Default::default() },
        );
        checked += 1;
    }
    // The identification regressor (`EmitOptions::regressor`), as the tests crate's cases.
    for (file, variant) in [
        ("planar_arm_2dof", Some("vertical")),
        ("pantograph_5bar", Some("vertical")),
        ("joystick_1dof", None),
    ] {
        let display = format!("models/{file}.yaml");
        check(
            &format!("{file}_{}f64_regressor", variant.map(|v| format!("{v}_")).unwrap_or_default()),
            &root().join(&display),
            &display,
            variant,
            Scalar::F64,
            EmitOptions { regressor: true, ..Default::default() },
        );
        checked += 1;
    }
    // Every snapshot file was compared (the tests crate checks that the folder holds no others).
    let on_disk = std::fs::read_dir(root().join("tests/tests/snapshots"))
        .expect("the snapshot folder exists")
        .filter(|e| e.as_ref().is_ok_and(|e| e.path().extension().is_some_and(|x| x == "snap")))
        .count();
    assert_eq!(checked, on_disk);
}
