//! Snapshots of the generated code of every shipped model, variant and scalar type.
//!
//! A change to the generator or to a model shows up here as a diff to review
//! (`cargo insta review`); CI runs with `INSTA_UPDATE=no`, so an unreviewed change fails.

use hapticgen_codegen::{build, EmitOptions, Scalar};
use hapticgen_tests::workspace_root;

#[test]
fn generated_code_of_every_shipped_model() {
    let mut count = 0;
    for entry in build::models_in(&workspace_root().join("models"), "models").unwrap() {
        let (path, display) = (&entry.path, &entry.display);
        for variant in entry.variants {
            for scalar in [Scalar::F64, Scalar::F32] {
                let m = hapticgen_codegen::load_file(path, display, variant.as_deref()).unwrap();
                let name = format!(
                    "{}{}_{}",
                    m.name,
                    variant.as_ref().map(|v| format!("_{v}")).unwrap_or_default(),
                    scalar.name()
                );
                let text = hapticgen_codegen::generate_model(m, scalar).file_text();
                insta::assert_snapshot!(name, text);
                count += 1;
            }
        }
    }
    assert!(count >= 6);
}

/// The parallel link generated with fused multiply-adds (`hapticgen generate --fma`), in the
/// firmware's `f32`.
#[test]
fn generated_code_with_fused_multiply_adds() {
    for variant in ["vertical", "horizontal"] {
        let path = workspace_root().join("models/parallel_link_2dof.yaml");
        let m = hapticgen_codegen::load_file(&path, "models/parallel_link_2dof.yaml", Some(variant)).unwrap();
        let options = EmitOptions { fused_multiply_add: true };
        let text = hapticgen_codegen::generate_model_with(m, Scalar::F32, options).file_text();
        insta::assert_snapshot!(format!("parallel_link_2dof_{variant}_f32_fma"), text);
    }
}
