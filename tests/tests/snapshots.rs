//! Snapshots of the generated code of every shipped model, variant and scalar type.
//!
//! A change to the generator or to a model shows up here as a diff to review
//! (`cargo insta review`); CI runs with `INSTA_UPDATE=no`, so an unreviewed change fails.

use hapticgen_codegen::{model, Scalar};
use hapticgen_tests::workspace_root;

#[test]
fn generated_code_of_every_shipped_model() {
    let dir = workspace_root().join("models");
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    let mut count = 0;
    for path in files.into_iter().filter(|p| p.extension().is_some_and(|x| x == "yaml")) {
        let display = format!("models/{}", path.file_name().unwrap().to_string_lossy());
        let base = model::load_file(&path, &display, None).unwrap();
        let variants: Vec<Option<String>> = if base.variants.is_empty() {
            vec![None]
        } else {
            base.variants.iter().cloned().map(Some).collect()
        };
        for variant in variants {
            for scalar in [Scalar::F64, Scalar::F32] {
                let m = model::load_file(&path, &display, variant.as_deref()).unwrap();
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
