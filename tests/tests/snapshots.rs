//! Snapshots of the generated code of every shipped model, variant and scalar type, of the
//! parallel link with fused multiply-adds, and of three rigs with the identification regressor.
//!
//! A change to the generator or to a model shows up here as a diff to review
//! (`cargo insta review`); CI runs with `INSTA_UPDATE=no`, so an unreviewed change fails.
//!
//! The snapshot folder must hold exactly the snapshots these tests produce: a `.snap` file no
//! test asserts any more (a model, variant or snapshot renamed or removed) fails
//! [`the_snapshot_folder_holds_exactly_the_asserted_snapshots`], and so does a generated rig
//! of the registry (`visit_all`, one per shipped model, variant and scalar) without its
//! snapshot.

use std::collections::BTreeSet;
use std::path::PathBuf;

use hapticgen_codegen::{build, EmitOptions, Scalar};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_tests::{visit_all, workspace_root, RigInfo, RigVisitor};

/// One snapshot: its name and what to generate.
struct Case {
    name: String,
    path: PathBuf,
    display: String,
    variant: Option<String>,
    scalar: Scalar,
    options: EmitOptions,
    /// Its spatial loops solved by Newton's method even where they have a closed form.
    numerical: bool,
}

impl Case {
    fn generate(&self) -> String {
        let m = hapticgen_codegen::load_file(&self.path, &self.display, self.variant.as_deref())
            .unwrap_or_else(|e| panic!("{e}"));
        let m = if self.numerical { m.with_loops_solved_numerically() } else { m };
        hapticgen_codegen::generate_model_with(m, self.scalar, self.options).file_text()
    }
}

/// Every snapshot the tests assert: each shipped model, variant and scalar type (unfused), a
/// Delta with its loops solved by Newton's method (`f64`), and the parallel link with fused
/// multiply-adds in the firmware's `f32`.
fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let models =
        build::models_in(&workspace_root().join("models"), "models").unwrap_or_else(|e| panic!("{e}"));
    for entry in models {
        let m =
            hapticgen_codegen::load_file(&entry.path, &entry.display, None).unwrap_or_else(|e| panic!("{e}"));
        for variant in &entry.variants {
            for scalar in [Scalar::F64, Scalar::F32] {
                let name = format!(
                    "{}{}_{}",
                    m.name,
                    variant.as_ref().map(|v| format!("_{v}")).unwrap_or_default(),
                    scalar.name()
                );
                cases.push(Case {
                    name,
                    path: entry.path.clone(),
                    display: entry.display.clone(),
                    variant: variant.clone(),
                    scalar,
                    options: EmitOptions { fused_multiply_add: false, ..Default::default() },
                    numerical: false,
                });
            }
        }
        // A Delta also with its loops solved by Newton's method (the solver of every other
        // spatial chain), as the build script generates it.
        if m.analyses
            .closures
            .as_ref()
            .and_then(|c| c.spatial.as_ref())
            .is_some_and(|s| s.closed_form.is_some())
        {
            cases.push(Case {
                name: format!("{}_newton_f64", m.name),
                path: entry.path.clone(),
                display: entry.display.clone(),
                variant: None,
                scalar: Scalar::F64,
                options: EmitOptions { fused_multiply_add: false, ..Default::default() },
                numerical: true,
            });
        }
    }
    for variant in ["vertical", "horizontal"] {
        cases.push(Case {
            name: format!("parallel_link_2dof_{variant}_f32_fma"),
            path: workspace_root().join("models/parallel_link_2dof.yaml"),
            display: "models/parallel_link_2dof.yaml".into(),
            variant: Some(variant.into()),
            scalar: Scalar::F32,
            options: EmitOptions { fused_multiply_add: true, ..Default::default() },
            numerical: false,
        });
    }
    // The identification regressor (`EmitOptions::regressor`), off by default: a serial arm, a
    // planar closed chain and a spatial one, `f64`, named as the build script's modules.
    for (file, variant) in [
        ("planar_arm_2dof", Some("vertical")),
        ("pantograph_5bar", Some("vertical")),
        ("joystick_1dof", None),
    ] {
        let display = format!("models/{file}.yaml");
        cases.push(Case {
            name: format!("{file}_{}f64_regressor", variant.map(|v| format!("{v}_")).unwrap_or_default()),
            path: workspace_root().join(&display),
            display,
            variant: variant.map(String::from),
            scalar: Scalar::F64,
            options: EmitOptions { regressor: true, ..Default::default() },
            numerical: false,
        });
    }
    cases
}

/// The snapshot's name for insta: `snapshots__NAME`, kept in `snapshots/snapshots__NAME.snap`
/// (the names these files had when this module was a test binary of its own).
fn snapshot_name(name: &str) -> String {
    format!("snapshots__{name}")
}

/// The `.snap` file insta keeps a snapshot in.
fn snapshot_file(name: &str) -> String {
    format!("{}.snap", snapshot_name(name))
}

#[test]
fn generated_code_of_every_shipped_model() {
    let cases = cases();
    assert!(!cases.is_empty(), "no snapshot cases: is models/ empty?");
    // The file name is the snapshot's name alone (not prefixed with the test binary's modules).
    let mut settings = insta::Settings::clone_current();
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        for case in cases {
            let text = case.generate();
            insta::assert_snapshot!(snapshot_name(&case.name), text);
        }
    });
}

/// The names of the unfused generated rigs of the tests crate's registry.
#[derive(Default)]
struct RegistryNames(BTreeSet<String>);

impl RigVisitor for RegistryNames {
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        _rig: &R,
    ) {
        self.0.insert(info.module.to_string());
    }
    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        _rig: &R,
    ) {
        self.0.insert(info.module.to_string());
    }
}

#[test]
fn the_snapshot_folder_holds_exactly_the_asserted_snapshots() {
    let asserted: BTreeSet<String> = cases().iter().map(|c| snapshot_file(&c.name)).collect();
    let folder = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots");
    let on_disk: BTreeSet<String> = std::fs::read_dir(&folder)
        .unwrap_or_else(|e| panic!("{}: {e}", folder.display()))
        .map(|e| e.expect("directory entry").file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".snap"))
        .collect();
    let stale: Vec<&String> = on_disk.difference(&asserted).collect();
    let missing: Vec<&String> = asserted.difference(&on_disk).collect();
    assert!(
        stale.is_empty() && missing.is_empty(),
        "the snapshot folder {} differs from the snapshots the tests assert:\n  stale (no test asserts \
         them; delete them with `git rm`): {stale:?}\n  missing (run `cargo insta review` and commit \
         them): {missing:?}",
        folder.display()
    );

    // Every generated rig the tests compile (the build script's registry, one per shipped model,
    // variant and scalar, unfused and fused) whose module name is a snapshot's is asserted, and
    // every unfused one has a snapshot: the registry and the snapshots cover the same rigs.
    let mut registry = RegistryNames::default();
    visit_all(&mut registry);
    let names: BTreeSet<String> = cases().into_iter().map(|c| c.name).collect();
    let unfused: BTreeSet<String> = registry.0.iter().filter(|m| !m.ends_with("_fma")).cloned().collect();
    assert!(!unfused.is_empty(), "the registry of generated rigs is empty");
    let without_snapshot: Vec<&String> = unfused.difference(&names).collect();
    let generated: BTreeSet<String> = registry
        .0
        .iter()
        .cloned()
        .chain(hapticgen_tests::REGRESSOR_MODULES.iter().map(|m| m.to_string()))
        .collect();
    let not_generated: Vec<&String> = names.difference(&generated).collect();
    assert!(
        without_snapshot.is_empty() && not_generated.is_empty(),
        "generated rigs without a snapshot: {without_snapshot:?}; snapshots of no generated rig: {not_generated:?}"
    );
}
