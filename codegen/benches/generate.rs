//! Generation time of each shipped rig: load and validate the model, derive the mechanics,
//! emit and format every function (target: under 50 ms per rig). Run with
//! `cargo bench -p hapticgen-codegen --bench generate`.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use hapticgen_codegen::{generate, Scalar, Source};

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for (file, variant) in [
        ("models/joystick_1dof.yaml", None),
        ("models/parallel_link_2dof.yaml", Some("vertical")),
        ("models/parallel_link_2dof.yaml", Some("horizontal")),
    ] {
        let text = std::fs::read_to_string(root.join(file)).expect("shipped model");
        let name = format!("generate {file}{}", variant.map(|v| format!(" ({v})")).unwrap_or_default());
        let manifest_dir = root.clone();
        let input: proc_macro2::TokenStream = match variant {
            Some(v) => format!("mod rig = {file:?}, variant = {v:?}").parse().expect("tokens"),
            None => format!("mod rig = {file:?}").parse().expect("tokens"),
        };
        c.bench_function(
            &format!("rig! expansion {file}{}", variant.map(|v| format!(" ({v})")).unwrap_or_default()),
            |b| {
                b.iter(|| {
                    std::hint::black_box(hapticgen_codegen::rig_macro::expand(input.clone(), &manifest_dir))
                })
            },
        );
        c.bench_function(&name, |b| {
            b.iter(|| {
                let generated = generate(&Source { name: file, text: &text }, variant, Scalar::F64)
                    .expect("shipped models are valid");
                std::hint::black_box(generated.file_text())
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
