//! serde's "data did not match any variant of untagged enum …" never reaches a model author:
//! every untagged enum of the model schema (`src/model/schema.rs`) and of the scene schema
//! (`src/scene/file.rs`), given a value of the wrong type in a shipped model, gets a message that
//! names the forms it accepts, at the value's line and column.

use hapticgen_codegen::model::{load, Source};

/// The names of the `#[serde(untagged)]` enums of a Rust source file.
fn untagged_enums(source: &str) -> Vec<String> {
    source
        .match_indices("#[serde(untagged)]")
        .filter_map(|(at, _)| {
            let rest = &source[at..];
            let start = rest.find("enum ")? + "enum ".len();
            let name: String =
                rest[start..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            Some(name)
        })
        .collect()
}

/// Per untagged enum: a line of `models/falcon_delta.yaml` (occurring once, or its first
/// occurrence) and its replacement with a value of the wrong type where the enum is expected.
const CASES: &[(&str, &str, &str)] = &[
    ("Value", "    mass: 10 g\n", "    mass: [10 g]\n"),
    ("Quantity", "    gear_ratio: 7.72\n", "    gear_ratio: {ratio: 7.72}\n"),
    ("WholeQuantity", "      counts_per_turn: 1280\n", "      counts_per_turn: [1280]\n"),
    ("DriveEntry", "drives:\n", "drives:\n  broken: [1, 2]\n"),
    ("Assembly", "    assembly: [1.924, 0.0]\n", "    assembly: {angle: 1.924}\n"),
    ("Inertia", "    inertia: {ixx: 0.0, iyy: 8.7552083e-6, izz: 8.7552083e-6}\n", "    inertia: [1, 2]\n"),
];

#[test]
fn every_untagged_enum_names_its_forms() {
    let schema = include_str!("../src/model/schema.rs");
    let scene = include_str!("../src/scene/file.rs");
    let mut enums = untagged_enums(schema);
    enums.extend(untagged_enums(scene));
    assert!(enums.len() >= 4, "the scan found {enums:?}");
    for name in &enums {
        assert!(CASES.iter().any(|(n, _, _)| n == name), "untagged enum {name} has no case here: add one");
    }
    let model = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/falcon_delta.yaml"))
        .expect("the shipped model");
    for (name, line, wrong) in CASES {
        assert!(model.contains(line), "{name}: `{line}` is not in the model");
        let text = model.replacen(line, wrong, 1);
        let errors = load(&Source { name: "delta.yaml", text: &text }, None)
            .err()
            .unwrap_or_else(|| panic!("{name}: `{wrong}` was accepted"));
        let shown = errors.to_string();
        assert!(!shown.contains("untagged"), "{name}: {shown}");
        assert!(!shown.contains("did not match any variant"), "{name}: {shown}");
        // At the wrong value's line, naming what it should be.
        let line_number = text[..text.find(wrong).expect("replaced")].matches('\n').count()
            + 1
            + wrong.trim_end().matches('\n').count();
        assert!(shown.contains(&format!("delta.yaml:{line_number}:")), "{name}: {shown}");
        assert!(
            ["e.g.", "help: write"].iter().any(|form| shown.contains(form)),
            "{name}: names no form: {shown}"
        );
        eprintln!("{name}: {shown}");
    }
}

/// A reported case: an assembly angle written without the space before its unit.
#[test]
fn an_assembly_with_a_glued_unit_names_the_forms() {
    let model = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/falcon_delta.yaml"))
        .expect("the shipped model");
    let text = model.replacen("    assembly: [1.924, 0.0]\n", "    assembly: [2.08deg, 0.0]\n", 1);
    match load(&Source { name: "delta.yaml", text: &text }, None) {
        Ok(_) => {}
        Err(errors) => {
            let shown = errors.to_string();
            assert!(!shown.contains("untagged"), "{shown}");
            assert!(shown.contains("deg"), "{shown}");
        }
    }
}
