//! The model format's public face: the checked-in JSON Schema, the good example models and
//! the examples of the model format's guide (`docs/model-format.md` and the pages of
//! `docs/model-format/`).
//!
//! - `schema/model.schema.json` must equal what the Rust types generate;
//! - every shipped and good model must validate against that schema (with a small validator
//!   for the subset of JSON Schema that schemars emits, so no heavy dependency is needed);
//! - every good model must load with every variant, and together they use every feature;
//! - every ```yaml block of the guide whose first line is `# complete model` must load, and
//!   one that names a file must be that file, verbatim.

use std::path::{Path, PathBuf};

use hapticgen_codegen::model::{json_schema, JointKind, Model, Motion, Source, TaskSpec};
use hapticgen_codegen::Scalar;
use hapticgen_codegen::{load, CheckedModel};
use serde_json::Value as Json;

const UPDATE_COMMAND: &str = "cargo run -p hapticgen -- schema > schema/model.schema.json";

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

fn yaml_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    files
}

fn good_models() -> Vec<PathBuf> {
    yaml_files(&repo_root().join("codegen/tests/good-models"))
}

fn shipped_models() -> Vec<PathBuf> {
    yaml_files(&repo_root().join("models"))
}

/// Loads a model with its default variant and then with each of its variants.
fn load_every_variant(name: &str, text: &str) -> Vec<CheckedModel> {
    let source = Source { name, text };
    let first = load(&source, None).unwrap_or_else(|d| panic!("{name} does not load:\n{d}"));
    let mut models = vec![first.clone()];
    for variant in &first.variants {
        let m = load(&source, Some(variant))
            .unwrap_or_else(|d| panic!("{name} does not load with variant {variant}:\n{d}"));
        assert_eq!(m.variant.as_deref(), Some(variant.as_str()));
        models.push(m);
    }
    models
}

fn schema() -> Json {
    serde_json::from_str(&json_schema()).expect("the generated schema is JSON")
}

#[test]
fn checked_in_schema_is_up_to_date() {
    let path = repo_root().join("schema/model.schema.json");
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == json_schema(),
        "{} is missing or out of date with the Rust types in codegen/src/model/schema.rs; \
         regenerate it from the repository root with:\n    {UPDATE_COMMAND}",
        path.display()
    );
}

// ---------------------------------------------------------------------------------------
// A validator for the JSON Schema subset schemars 0.8 emits (draft-07): `$ref` into
// `definitions`, `type`, `enum`, `properties`, `required`, `additionalProperties`, `items`,
// `allOf`, `anyOf`, `oneOf`, `minimum` and the integer `format`s.

fn resolve<'s>(root: &'s Json, schema: &'s Json) -> &'s Json {
    match schema.get("$ref").and_then(Json::as_str) {
        Some(reference) => {
            let name = reference
                .strip_prefix("#/definitions/")
                .unwrap_or_else(|| panic!("unsupported $ref {reference}"));
            resolve(root, &root["definitions"][name])
        }
        None => schema,
    }
}

fn type_matches(name: &str, value: &Json) -> bool {
    match name {
        "object" => value.is_object(),
        "array" => value.is_array(),
        "string" => value.is_string(),
        "boolean" => value.is_boolean(),
        "null" => value.is_null(),
        "number" => value.is_number(),
        "integer" => value.is_i64() || value.is_u64() || value.as_f64().is_some_and(|x| x.fract() == 0.0),
        other => panic!("unsupported type {other}"),
    }
}

/// Appends a message per violation of `schema` by `value` at `at` (a JSON pointer).
fn validate(root: &Json, schema: &Json, value: &Json, at: &str, errors: &mut Vec<String>) {
    let schema = resolve(root, schema);
    let object = match schema {
        Json::Bool(true) => return,
        Json::Bool(false) => return errors.push(format!("{at}: not allowed")),
        Json::Object(o) => o,
        other => panic!("unsupported schema {other}"),
    };
    for keyword in object.keys() {
        let known = [
            "$schema",
            "title",
            "description",
            "default",
            "definitions",
            "$ref",
            "type",
            "enum",
            "properties",
            "required",
            "additionalProperties",
            "items",
            "allOf",
            "anyOf",
            "oneOf",
            "minimum",
            "format",
        ];
        assert!(known.contains(&keyword.as_str()), "the schema uses `{keyword}`, unknown to this validator");
    }
    if let Some(types) = object.get("type") {
        let names: Vec<&str> = match types {
            Json::String(s) => vec![s.as_str()],
            Json::Array(a) => a.iter().filter_map(Json::as_str).collect(),
            other => panic!("unsupported type {other}"),
        };
        if !names.iter().any(|n| type_matches(n, value)) {
            return errors.push(format!("{at}: expected {}, got {value}", names.join(" or ")));
        }
    }
    if let Some(Json::Array(allowed)) = object.get("enum") {
        if !allowed.contains(value) {
            errors.push(format!("{at}: {value} is not one of {allowed:?}"));
        }
    }
    if let (Some(minimum), Some(x)) = (object.get("minimum").and_then(Json::as_f64), value.as_f64()) {
        if x < minimum {
            errors.push(format!("{at}: {x} is below the minimum {minimum}"));
        }
    }
    if let (Some("uint32"), Some(x)) = (object.get("format").and_then(Json::as_str), value.as_f64()) {
        if !(0.0..=f64::from(u32::MAX)).contains(&x) {
            errors.push(format!("{at}: {x} is not a uint32"));
        }
    }
    if let Json::Object(map) = value {
        let properties = object.get("properties").and_then(Json::as_object);
        for required in object.get("required").and_then(Json::as_array).into_iter().flatten() {
            let key = required.as_str().expect("required names are strings");
            if !map.contains_key(key) {
                errors.push(format!("{at}: missing required key `{key}`"));
            }
        }
        for (key, item) in map {
            let here = format!("{at}/{key}");
            // A key that is neither a property nor covered by `additionalProperties` is allowed.
            if let Some(sub) =
                properties.and_then(|p| p.get(key)).or_else(|| object.get("additionalProperties"))
            {
                validate(root, sub, item, &here, errors);
            }
        }
    }
    if let (Json::Array(items), Some(item_schema)) = (value, object.get("items")) {
        for (i, item) in items.iter().enumerate() {
            validate(root, item_schema, item, &format!("{at}/{i}"), errors);
        }
    }
    for sub in object.get("allOf").and_then(Json::as_array).into_iter().flatten() {
        validate(root, sub, value, at, errors);
    }
    let passing = |list: &Vec<Json>| {
        list.iter()
            .filter(|sub| {
                let mut e = Vec::new();
                validate(root, sub, value, at, &mut e);
                e.is_empty()
            })
            .count()
    };
    if let Some(Json::Array(list)) = object.get("anyOf") {
        if passing(list) == 0 {
            errors.push(format!("{at}: {value} matches none of the alternatives"));
            // And why the closest alternative fails: the first with the fewest violations of
            // the value itself (then the fewest in all), so that a drive with one wrong key
            // deep inside is reported at that key.
            let closest = list
                .iter()
                .map(|sub| {
                    let mut e = Vec::new();
                    validate(root, sub, value, at, &mut e);
                    e
                })
                .min_by_key(|e| (e.iter().filter(|m| m.starts_with(&format!("{at}: "))).count(), e.len()));
            errors.extend(closest.into_iter().flatten());
        }
    }
    if let Some(Json::Array(list)) = object.get("oneOf") {
        let n = passing(list);
        if n != 1 {
            errors.push(format!("{at}: {value} matches {n} alternatives, expected exactly one"));
        }
    }
}

/// The schema violations of a YAML model text.
fn schema_errors(text: &str) -> Vec<String> {
    let yaml: serde_yaml::Value = serde_yaml::from_str(text).expect("valid YAML");
    let json: Json = serde_json::to_value(&yaml).expect("YAML with string keys converts to JSON");
    let root = schema();
    let mut errors = Vec::new();
    validate(&root, &root, &json, "", &mut errors);
    errors
}

#[test]
fn shipped_and_good_models_validate_against_the_schema() {
    let files: Vec<PathBuf> = shipped_models().into_iter().chain(good_models()).collect();
    assert!(files.len() >= 6, "{files:?}");
    for path in files {
        let errors = schema_errors(&read(&path));
        assert!(errors.is_empty(), "{} violates the schema:\n{}", path.display(), errors.join("\n"));
    }
}

#[test]
fn schema_rejects_what_the_loader_rejects_structurally() {
    let root = repo_root().join("codegen/tests/bad-models");
    let cases = [
        ("unknown-key-top", "/colour: not allowed"),
        ("unknown-key-nested", "/drives/re40_gp42/motor/winding: not allowed"),
        ("value-not-a-number", "/bodies/1/mass: [0.05] matches none of the alternatives"),
        // (`drive` is required of actuated joints only, which the loader checks; the schema
        // cannot say "unless passive", so `missing-key` is not a structural case.)
        ("unknown-joint-type", "/joints/0/type: \"rotary\" matches 0 alternatives"),
        (
            "negative-counts",
            "/drives/re40_gp42/encoder/counts_per_turn: -2000 matches none of the alternatives",
        ),
        ("empty-value", "/drives/re40_gp42/motor/inductance: expected number, got null"),
    ];
    for (name, expected) in cases {
        let errors = schema_errors(&read(&root.join(format!("{name}.yaml"))));
        assert!(
            errors.iter().any(|e| e.starts_with(expected)),
            "{name}: expected an error starting with `{expected}`, got {errors:#?}"
        );
    }
}

#[test]
fn good_models_load_with_every_variant_and_cover_every_feature() {
    let mut all = Vec::new();
    for path in good_models() {
        let name = path.file_name().expect("file name").to_string_lossy().into_owned();
        all.extend(load_every_variant(&name, &read(&path)));
    }
    // And they generate code.
    for m in &all {
        let generated = hapticgen_codegen::generate_model(m.clone(), Scalar::F64);
        assert!(generated.file_text().contains(&format!("from {}", m.file)), "{}", m.file);
    }
    let any = |what: &str, f: &dyn Fn(&Model) -> bool| {
        assert!(all.iter().any(|m| f(m)), "no good model has {what}")
    };
    any("a spatial model", &|m| !m.planar);
    any("a tunable parameter", &|m| !m.tunable.is_empty());
    any("a prismatic joint", &|m| m.joints.iter().any(|j| j.kind == JointKind::Prismatic));
    any("a welded body", &|m| {
        m.bodies.iter().any(|b| matches!(b.motion, Motion::Serial { joint: None, .. }))
    });
    any("a direct pose", &|m| m.bodies.iter().any(|b| matches!(b.motion, Motion::Direct { .. })));
    any("a direct pose on the base", &|m| {
        m.bodies.iter().any(|b| matches!(b.motion, Motion::Direct { origin_body: None, .. }))
    });
    any("a rotated origin", &|m| {
        m.bodies.iter().any(|b| matches!(&b.motion, Motion::Serial { rotation, .. } if rotation[1][1] < 0.5))
    });
    any("a product of inertia", &|m| m.bodies.iter().any(|b| !b.inertia[0][1].is_zero()));
    any("a joint-space task", &|m| matches!(m.task, TaskSpec::Joints(_)));
    any("a point task", &|m| matches!(m.task, TaskSpec::Point(_)));
    any("a force sensor", &|m| !m.sensors.is_empty());
    any("rendering settings", &|m| m.rendering.is_some());
    any("a frame (orientation output)", &|m| !m.frames.is_empty());
    any("a frame turned by rpy", &|m| m.frames.iter().any(|f| f.rotation[0][0] < 0.5));

    // The variants of the planar arm do what they say.
    let arm = |variant: &str| {
        all.iter()
            .find(|m| m.name == "planar_arm_2dof" && m.variant.as_deref() == Some(variant))
            .unwrap_or_else(|| panic!("planar_arm_2dof variant {variant}"))
    };
    assert_eq!(arm("standard").joints[0].drive.gear_ratio, 12.0);
    assert_eq!(arm("high_gear").joints[0].drive.gear_ratio, 25.0);
    assert_eq!(arm("standard").sensors.len(), 1);
    assert!(arm("no_force_sensor").sensors.is_empty());
    let elbow_damping = |m: &Model| m.joints[1].damping.clone();
    assert_ne!(elbow_damping(arm("standard")), elbow_damping(arm("stiff_elbow")));
}

// ---------------------------------------------------------------------------------------
// The guide's examples.

/// The ```yaml blocks of a Markdown text, with the line each starts on.
fn yaml_blocks(markdown: &str) -> Vec<(usize, String)> {
    let mut blocks = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (i, line) in markdown.lines().enumerate() {
        match &mut current {
            None if line.trim_start().starts_with("```yaml") => current = Some((i + 2, String::new())),
            Some(_) if line.trim_start().starts_with("```") => blocks.extend(current.take()),
            Some((_, text)) => {
                text.push_str(line);
                text.push('\n');
            }
            None => {}
        }
    }
    assert!(current.is_none(), "unterminated ```yaml block");
    blocks
}

/// The model format's guide: `docs/model-format.md` and every page of `docs/model-format/`
/// (each of which the first links), as (path from the repository root, text).
fn guide_pages() -> Vec<(String, String)> {
    let index = "docs/model-format.md".to_string();
    let index_text = read(&repo_root().join(&index));
    let mut pages: Vec<String> = std::fs::read_dir(repo_root().join("docs/model-format"))
        .expect("docs/model-format/")
        .map(|e| e.expect("directory entry").file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/model-format/{name}"))
        .collect();
    pages.sort();
    assert!(pages.len() >= 5, "docs/model-format/ holds only {} pages", pages.len());
    for page in &pages {
        let link = format!("]({})", page.trim_start_matches("docs/"));
        assert!(index_text.contains(&link), "docs/model-format.md does not link {page}");
    }
    let mut guide = vec![(index, index_text)];
    guide.extend(pages.into_iter().map(|page| {
        let text = read(&repo_root().join(&page));
        (page, text)
    }));
    guide
}

/// A relative link `target` of the page at `page` (both from the repository root), as a path
/// from the repository root: `../../models/x.yaml` of `docs/model-format/a.md` is
/// `models/x.yaml`.
fn resolve_link(page: &str, target: &str) -> String {
    let mut parts: Vec<&str> = page.split('/').collect();
    parts.pop();
    for part in target.split('/') {
        match part {
            ".." => assert!(parts.pop().is_some(), "{page}: the link {target} leaves the repository"),
            "." | "" => {}
            part => parts.push(part),
        }
    }
    parts.join("/")
}

/// The repository paths of the `.yaml` files a Markdown page (`page`, from the repository
/// root) links to (`[…](../models/x.yaml)`), in order.
fn linked_models(page: &str, markdown: &str) -> Vec<String> {
    markdown
        .split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .filter(|target| target.ends_with(".yaml") && !target.contains("://"))
        .map(|target| resolve_link(page, target))
        .collect()
}

#[test]
fn every_model_linked_from_the_guide_loads() {
    let linked: Vec<String> =
        guide_pages().iter().flat_map(|(page, text)| linked_models(page, text)).collect();
    assert!(linked.len() >= 8, "the guide links only {} complete models", linked.len());
    for file in &linked {
        let text = read(&repo_root().join(file));
        let models = load_every_variant(file, &text);
        assert!(!models.is_empty());
        let errors = schema_errors(&text);
        assert!(errors.is_empty(), "{file} violates the schema:\n{}", errors.join("\n"));
    }
    // Every good model is linked from the guide.
    for path in good_models() {
        let file = path.file_name().expect("file name").to_string_lossy();
        let relative = format!("codegen/tests/good-models/{file}");
        assert!(linked.contains(&relative), "no page of the model format's guide links {relative}");
    }
}

#[test]
fn linked_model_extraction_sees_every_link() {
    let text = "a [`models/a.yaml`](../models/a.yaml) b [c](../docs/c.md) [d](../x/d.yaml) [e](e.yaml).";
    assert_eq!(linked_models("docs/model-format.md", text), vec!["models/a.yaml", "x/d.yaml", "docs/e.yaml"]);
    let text = "[a](../../models/a.yaml) [b](../c.md) [c](https://example.com/c.yaml)";
    assert_eq!(linked_models("docs/model-format/examples.md", text), vec!["models/a.yaml"]);
}

/// The tutorial's model, as it stands after each step, loads; its last step is the complete
/// model of the repository it names, identical to that file.
#[test]
fn the_tutorials_models_load() {
    let tutorial = read(&repo_root().join("docs/tutorial.md"));
    let mut complete = 0;
    for (line, text) in yaml_blocks(&tutorial) {
        let Some(first) = text.lines().next() else { continue };
        let Some(rest) = first.strip_prefix("# complete model") else { continue };
        complete += 1;
        let name = format!("docs/tutorial.md:{line}");
        let body = &text[first.len() + 1..];
        if let Some(file) = rest.split_whitespace().find(|w| w.ends_with(".yaml")) {
            assert_eq!(body, read(&repo_root().join(file)), "{name}: the block differs from {file}");
        }
        assert!(!load_every_variant(&name, &text).is_empty());
        let errors = schema_errors(&text);
        assert!(errors.is_empty(), "{name} violates the schema:\n{}", errors.join("\n"));
    }
    assert!(complete >= 1, "the tutorial shows no complete model");
}

/// The guide's `frames:` example is an excerpt of the PHANToM-like model (which the guide
/// shows complete, and which is loaded above).
#[test]
fn frames_example_in_the_guide_is_part_of_the_phantom_model() {
    let phantom = read(&repo_root().join("models/phantom_3dof.yaml"));
    let excerpts: Vec<String> = guide_pages()
        .iter()
        .flat_map(|(_, text)| yaml_blocks(text))
        .map(|(_, t)| t)
        .filter(|t| t.starts_with("frames:"))
        .collect();
    assert_eq!(excerpts.len(), 1, "the guide's frames section shows one example");
    assert!(
        phantom.contains(&excerpts[0]),
        "the example differs from models/phantom_3dof.yaml:\n{}",
        excerpts[0]
    );
}

#[test]
fn yaml_block_extraction_sees_every_block() {
    let text =
        "intro\n```yaml\n# complete model\na: 1\n```\ntext\n```yaml\nb: 2\n```\n```rust\nfn f() {}\n```\n";
    let blocks = yaml_blocks(text);
    assert_eq!(blocks, vec![(3, "# complete model\na: 1\n".to_string()), (8, "b: 2\n".to_string())]);
}

/// The `$ hapticgen check FILE [--variant V]` transcripts in ```text blocks of the guide print
/// what the loader reports.
#[test]
fn diagnostic_transcripts_in_the_guide_are_real() {
    let mut transcripts: Vec<(Vec<String>, String)> = Vec::new();
    let mut in_text = false;
    for line in guide_pages().iter().flat_map(|(_, text)| text.lines()) {
        if line.starts_with("```") {
            in_text = line == "```text";
            continue;
        }
        if !in_text {
            continue;
        }
        if let Some(command) = line.strip_prefix("$ hapticgen check ") {
            transcripts.push((command.split_whitespace().map(str::to_string).collect(), String::new()));
        } else if let Some((_, output)) = transcripts.last_mut() {
            output.push_str(line);
            output.push('\n');
        }
    }
    assert!(transcripts.len() >= 4, "the guide shows {} transcripts", transcripts.len());
    for (args, expected) in transcripts {
        let (file, variant) = match args.as_slice() {
            [file] => (file, None),
            [file, flag, v] if flag == "--variant" => (file, Some(v.as_str())),
            other => panic!("unsupported transcript command {other:?}"),
        };
        let result = hapticgen_codegen::load_file(&repo_root().join(file), file, variant);
        let shown = match result {
            Ok(_) => String::new(),
            Err(d) => format!("{d}\n"),
        };
        assert_eq!(shown, expected, "`hapticgen check {}` prints something else", args.join(" "));
    }
}
