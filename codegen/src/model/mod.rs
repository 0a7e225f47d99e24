//! Model files: parsing, variants, validation and resolution into a [`Model`].
//!
//! The pipeline is: YAML text → `serde_yaml::Value` (syntax errors) → literal check (NaN/inf)
//! → typed [`schema::ModelFile`] (types, unknown and missing keys) → the selected variant's
//! overrides → typed again → semantic validation → [`Model`], whose values are polynomials in
//! the tunable parameters, ready for the mechanics. Every rejection is a [`Diagnostic`] with
//! the file, line, column and key path of the offending value.

pub mod positions;
mod preprocess;
pub mod quantity;
mod resolve;
pub mod schema;
mod types;

use std::collections::HashMap;
use std::path::Path;

use serde::de::DeserializeOwned;

use crate::diag::{Diagnostic, Diagnostics};
use crate::sym::poly::Poly;
use positions::{display_path, KeyPath, PositionIndex, Segment};
pub use schema::{Branch, Drive, JointKind, ModelFile, Rendering, Sensor};
pub use types::{
    Coupling, FixedTransform, LoopClosure, MeasuredJoint, MimicJoint, Model, Motion, PassiveJoint,
    ResolvedBody, ResolvedFrame, ResolvedJoint, ResolvedParameter, ResolvedPoint, SpatialClosure, TaskSpec,
};

/// The text of a model file and how to name it in diagnostics.
pub struct Source<'a> {
    /// The file name shown in diagnostics (as the user wrote it).
    pub name: &'a str,
    /// The YAML text.
    pub text: &'a str,
}

/// Where diagnostics point: the position index plus the variant's overrides, so that a value
/// a variant replaced is reported at the variant's line.
///
/// The index needs a second parse of the text (by `yaml-rust2`, whose events carry
/// positions; serde_yaml's values do not), so it is built on the first diagnostic only: a
/// model that loads without one is parsed once.
pub(crate) struct Locator<'a> {
    file: &'a str,
    text: &'a str,
    index: std::cell::OnceCell<PositionIndex>,
    /// Path in the merged document → path in the source document.
    overrides: Vec<(KeyPath, KeyPath)>,
}

impl<'a> Locator<'a> {
    fn new(source: &Source<'a>) -> Self {
        Locator {
            file: source.name,
            text: source.text,
            index: std::cell::OnceCell::new(),
            overrides: Vec::new(),
        }
    }

    /// The position index, built on first use.
    fn index(&self) -> &PositionIndex {
        self.index.get_or_init(|| PositionIndex::build(self.text))
    }

    /// The path in the source document of the value at `path` in the merged one.
    fn source_path(&self, path: &[Segment]) -> KeyPath {
        let best = self
            .overrides
            .iter()
            .filter(|(merged, _)| path.starts_with(merged))
            .max_by_key(|(merged, _)| merged.len());
        match best {
            Some((merged, source)) => {
                let mut p = source.clone();
                p.extend_from_slice(&path[merged.len()..]);
                p
            }
            None => path.to_vec(),
        }
    }

    /// A diagnostic at the value found at `path`.
    pub(crate) fn at(&self, path: &[Segment], message: impl Into<String>) -> Diagnostic {
        self.diagnostic(self.index().value(&self.source_path(path)), path, message.into())
    }

    /// A diagnostic at the character `offset` of the scalar at `path` (past its opening quote,
    /// if it is quoted), for an error inside an expression.
    pub(crate) fn at_offset(
        &self,
        path: &[Segment],
        offset: usize,
        message: impl Into<String>,
        hint: Option<String>,
    ) -> Diagnostic {
        let (line, column) = self.index().value(&self.source_path(path));
        let opening = self
            .text
            .lines()
            .nth(line.saturating_sub(1))
            .and_then(|l| l.chars().nth(column.saturating_sub(1)));
        let quote = usize::from(matches!(opening, Some('"' | '\'')));
        let mut d = self.diagnostic((line, column + quote + offset), path, message.into());
        d.hint = hint;
        d
    }

    /// A diagnostic at the key that introduces `path`.
    pub(crate) fn at_key(&self, path: &[Segment], message: impl Into<String>) -> Diagnostic {
        self.diagnostic(self.index().key(&self.source_path(path)), path, message.into())
    }

    fn diagnostic(&self, (line, column): (usize, usize), path: &[Segment], message: String) -> Diagnostic {
        Diagnostic {
            file: self.file.to_string(),
            line,
            column,
            path: display_path(path),
            message,
            hint: None,
        }
    }
}

/// Reads and resolves a model file from disk. `display` names it in diagnostics.
pub fn load_file(path: &Path, display: &str, variant: Option<&str>) -> Result<Model, Diagnostics> {
    let text = read_file(path, display)?;
    load(&Source { name: display, text: &text }, variant)
}

/// The text of a model file; an unreadable file is a diagnostic naming it.
pub(crate) fn read_file(path: &Path, display: &str) -> Result<String, Diagnostics> {
    std::fs::read_to_string(path).map_err(|e| {
        Diagnostic {
            file: display.to_string(),
            line: 1,
            column: 1,
            path: String::new(),
            message: format!("cannot read the model file: {e}"),
            hint: None,
        }
        .into()
    })
}

/// Parses, applies the variant (the named one, else the model's default) and validates.
///
/// This is the model alone; the front ends load through [`crate::load`], which also runs the
/// model-level analyses ([`crate::check`]).
pub fn load(source: &Source<'_>, variant: Option<&str>) -> Result<Model, Diagnostics> {
    load_then(source, variant, |model, _| Ok(model))
}

/// [`load`], then `then` on the model and the locator of its file (the analyses that report
/// at the file's lines); diagnostics of both are kept inside the file.
pub(crate) fn load_then<T>(
    source: &Source<'_>,
    variant: Option<&str>,
    then: impl FnOnce(Model, &Locator<'_>) -> Result<T, Diagnostics>,
) -> Result<T, Diagnostics> {
    if source.text.len() > MAX_MODEL_BYTES {
        return Err(Diagnostic {
            file: source.name.to_string(),
            line: 1,
            column: 1,
            path: String::new(),
            message: format!(
                "the model file is {} bytes; the limit is {} (1 MiB)",
                source.text.len(),
                MAX_MODEL_BYTES
            ),
            hint: None,
        }
        .into());
    }
    load_unclamped(source, variant, then).map_err(|mut diagnostics| {
        let lines = line_lengths(source.text);
        for d in &mut diagnostics.0 {
            (d.line, d.column) = clamp_position(&lines, d.line, d.column);
        }
        diagnostics
    })
}

/// Model files larger than this are rejected before parsing (a rig's model is a few KiB).
pub const MAX_MODEL_BYTES: usize = 1 << 20;

/// The deepest nesting of flow collections (`[`, `{`) a model file may have. The YAML
/// deserializer stops at 128 levels anyway, but its scanner takes time quadratic in the
/// depth before it gets there (2.9 s for 28,000 `[`, a fuzz finding): deeper input is
/// rejected before parsing.
pub const MAX_FLOW_NESTING: usize = 256;

/// The line and column (1-based, lines broken as YAML breaks them) of the first `[` or `{`
/// that opens a flow collection deeper than `limit`, counting brackets outside comments
/// (quotes are not tracked: a bracket inside a quoted scalar counts, which can only
/// over-count, and no model has hundreds of them).
fn flow_nesting_beyond(text: &str, limit: usize) -> Option<(usize, usize)> {
    // The depth never exceeds the number of opening brackets: a count of bytes (vectorised)
    // settles nearly every file without decoding it character by character.
    if text.bytes().filter(|&b| b == b'[' || b == b'{').count() <= limit {
        return None;
    }
    let (mut depth, mut line, mut column) = (0usize, 1usize, 0usize);
    let mut in_comment = false;
    let mut previous_blank = true;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        column += 1;
        match c {
            '\r' | '\n' | '\u{85}' | '\u{2028}' | '\u{2029}' => {
                if c == '\r' && chars.peek() == Some(&'\n') {
                    chars.next();
                }
                (line, column, in_comment, previous_blank) = (line + 1, 0, false, true);
                continue;
            }
            '#' if previous_blank => in_comment = true,
            '[' | '{' if !in_comment => {
                depth += 1;
                if depth > limit {
                    return Some((line, column));
                }
            }
            ']' | '}' if !in_comment => depth = depth.saturating_sub(1),
            _ => {}
        }
        previous_blank = c == ' ' || c == '\t';
    }
    None
}

/// The length in characters of each line, with YAML's line breaks (LF, CRLF, CR, NEL, LS, PS).
fn line_lengths(text: &str) -> Vec<usize> {
    let mut lengths = vec![0usize];
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\r' => {
                if chars.peek() == Some(&'\n') {
                    chars.next();
                }
                lengths.push(0);
            }
            '\n' | '\u{85}' | '\u{2028}' | '\u{2029}' => lengths.push(0),
            _ => {
                if let Some(last) = lengths.last_mut() {
                    *last += 1;
                }
            }
        }
    }
    // A final line break does not start a line of its own.
    if lengths.len() > 1 && lengths.last() == Some(&0) {
        lengths.pop();
    }
    lengths
}

/// Keeps a position inside the file: the parsers report the end of a file without a final
/// line break on the line after the last one.
fn clamp_position(lines: &[usize], line: usize, column: usize) -> (usize, usize) {
    let last = lines.len().max(1);
    if line > last {
        return (last, lines.last().copied().unwrap_or(0) + 1);
    }
    let line = line.max(1);
    let width = lines.get(line - 1).copied().unwrap_or(0) + 1;
    (line, column.clamp(1, width))
}

fn load_unclamped<T>(
    source: &Source<'_>,
    variant: Option<&str>,
    then: impl FnOnce(Model, &Locator<'_>) -> Result<T, Diagnostics>,
) -> Result<T, Diagnostics> {
    if let Some((line, column)) = flow_nesting_beyond(source.text, MAX_FLOW_NESTING) {
        return Err(Diagnostic {
            file: source.name.to_string(),
            line,
            column,
            path: String::new(),
            message: format!("flow collections (`[`, `{{`) nested deeper than {MAX_FLOW_NESTING} levels"),
            hint: Some("a model file nests a few levels; the YAML parser cannot read deeper ones".into()),
        }
        .into());
    }
    let mut locator = Locator::new(source);
    let document: serde_yaml::Value = serde_yaml::from_str(source.text).map_err(|e| {
        let message = crate::diag::strip_location(&e.to_string());
        // serde_yaml reports a repeated key at the mapping, with the path inside the message.
        if let (true, Some((path, (line, column)))) =
            (message.contains("duplicate entry with key"), locator.index().duplicate_key())
        {
            let key = match path.last() {
                Some(Segment::Key(k)) => k.as_str(),
                _ => "",
            };
            return Diagnostic {
                file: source.name.to_string(),
                line,
                column,
                path: display_path(path),
                message: format!("duplicate key `{key}`"),
                hint: Some("a key may appear only once in a mapping".into()),
            };
        }
        let (line, column) = e.location().map(|l| (l.line(), l.column())).unwrap_or((1, 1));
        Diagnostic {
            file: source.name.to_string(),
            line,
            column,
            path: String::new(),
            message: format!("invalid YAML: {message}"),
            hint: None,
        }
    })?;
    check_literals(&document, &locator)?;
    let mut prepared = document.clone();
    preprocess::preprocess(&mut prepared, &mut locator)?;
    let base: ModelFile = typed(&prepared, &locator)?;

    let mut known: Vec<&str> = base.variants.keys().map(String::as_str).collect();
    known.sort_unstable();
    let listing = if known.is_empty() {
        "the model defines no variants".to_string()
    } else {
        format!("the model defines: {}", known.join(", "))
    };
    if !base.variants.is_empty() && base.default_variant.is_none() {
        let d = locator.at_key(
            &[Segment::Key("variants".into())],
            "a model with variants must name one of them as `default_variant`",
        );
        return Err(d.with_hint(listing).into());
    }
    let chosen = match variant {
        Some(v) => Some(v.to_string()),
        None => base.default_variant.clone(),
    };
    // Sorted like `known`; taken now, since `base` becomes the model when no variant applies.
    let variants: Vec<String> = known.iter().map(|name| name.to_string()).collect();
    // The variant is applied to the document itself: it is not needed unmerged any more.
    let mut merged = document;
    if let Some(name) = &chosen {
        let Some(spec) = base.variants.get(name) else {
            let d = if variant.is_none() {
                // The model's own `default_variant` names no variant.
                locator.at(&[Segment::Key("default_variant".into())], format!("unknown variant `{name}`"))
            } else {
                let path =
                    if base.variants.is_empty() { vec![] } else { vec![Segment::Key("variants".into())] };
                let mut d = locator.at_key(&path, format!("unknown variant `{name}`"));
                d.path = String::new();
                d
            };
            return Err(d.with_hint(listing).into());
        };
        if let serde_yaml::Value::Mapping(map) = &mut merged {
            map.remove("variants");
            map.remove("default_variant");
        }
        for (dotted, value) in &spec.set {
            let source_path = vec![
                Segment::Key("variants".into()),
                Segment::Key(name.clone()),
                Segment::Key("set".into()),
                Segment::Key(dotted.clone()),
            ];
            let yaml_value = serde_yaml::to_value(value)
                .map_err(|e| locator.at(&source_path, format!("cannot use this value: {e}")))?;
            let target =
                resolve_path(&mut merged, dotted, true).map_err(|rule| locator.at_key(&source_path, rule))?;
            let (merged_path, slot) = target;
            *slot = yaml_value;
            locator.overrides.push((merged_path, source_path));
        }
        for (i, dotted) in spec.remove.iter().enumerate() {
            let source_path = vec![
                Segment::Key("variants".into()),
                Segment::Key(name.clone()),
                Segment::Key("remove".into()),
                Segment::Index(i),
            ];
            remove_path(&mut merged, dotted).map_err(|rule| locator.at(&source_path, rule))?;
        }
    }
    let file: ModelFile = if chosen.is_some() {
        preprocess::preprocess(&mut merged, &mut locator)?;
        typed(&merged, &locator)?
    } else {
        base
    };
    let model = resolve::resolve(file, &locator, chosen, variants)?;
    then(model, &locator)
}

/// Rejects NaN and infinite literals anywhere in the document.
fn check_literals(document: &serde_yaml::Value, locator: &Locator<'_>) -> Result<(), Diagnostic> {
    /// A step of the walk: a mapping key (made a path segment only for the literal that is
    /// reported, not for every entry of every document) or a sequence index.
    enum Step<'v> {
        Key(&'v serde_yaml::Value),
        Index(usize),
    }
    /// The first non-finite number in document order, with `steps` leading to it.
    fn walk<'v>(value: &'v serde_yaml::Value, steps: &mut Vec<Step<'v>>) -> Option<f64> {
        match value {
            serde_yaml::Value::Number(n) => n.as_f64().filter(|f| !f.is_finite()),
            serde_yaml::Value::Sequence(items) => items.iter().enumerate().find_map(|(i, item)| {
                steps.push(Step::Index(i));
                let found = walk(item, steps);
                if found.is_none() {
                    steps.pop();
                }
                found
            }),
            serde_yaml::Value::Mapping(map) => map.iter().find_map(|(k, v)| {
                steps.push(Step::Key(k));
                let found = walk(v, steps);
                if found.is_none() {
                    steps.pop();
                }
                found
            }),
            serde_yaml::Value::Tagged(t) => walk(&t.value, steps),
            _ => None,
        }
    }
    let mut steps = Vec::new();
    let Some(f) = walk(document, &mut steps) else { return Ok(()) };
    let path: KeyPath = steps
        .iter()
        .map(|step| match step {
            Step::Key(serde_yaml::Value::String(s)) => Segment::Key(s.clone()),
            Step::Key(other) => {
                Segment::Key(serde_yaml::to_string(other).unwrap_or_default().trim().to_string())
            }
            Step::Index(i) => Segment::Index(*i),
        })
        .collect();
    Err(locator.at(&path, format!("must be a finite number, got {f}")))
}

/// Deserialises with the key path of any failure, mapped to a position.
fn typed<T: DeserializeOwned>(value: &serde_yaml::Value, locator: &Locator<'_>) -> Result<T, Diagnostic> {
    serde_path_to_error::deserialize(value).map_err(|error| {
        let mut path: KeyPath = Vec::new();
        for segment in error.path().iter() {
            match segment {
                serde_path_to_error::Segment::Seq { index } => path.push(Segment::Index(*index)),
                serde_path_to_error::Segment::Map { key } => path.push(Segment::Key(key.clone())),
                serde_path_to_error::Segment::Enum { .. } | serde_path_to_error::Segment::Unknown => {}
            }
        }
        let raw = crate::diag::strip_location(&error.inner().to_string());
        let (message, hint) = explain_serde_error(&raw);
        // An unknown key is reported at the key itself, and so is an empty value (which the
        // event parser places at the next token); anything else at the value.
        let d = if raw.starts_with("unknown field") || raw.contains("invalid type: unit value") {
            locator.at_key(&path, message)
        } else {
            locator.at(&path, message)
        };
        match hint {
            Some(h) => d.with_hint(h),
            None => d,
        }
    })
}

/// Rephrases serde's messages for model authors.
fn explain_serde_error(raw: &str) -> (String, Option<String>) {
    // serde's untagged enums say only that nothing matched: name the forms instead.
    if raw.contains("untagged enum Inertia") {
        return (
            "not a valid inertia".into(),
            Some(
                "write a number (planar I_zz about the centre of mass, kg·m²), \
                 `{slender_rod: LENGTH}` (planar), a tensor `{ixx, iyy, izz, ixy, ixz, iyz}` \
                 (spatial), or a shape of the body's mass: `{rod: {length, axis}}`, \
                 `{box: {x, y, z}}`, `{cylinder: {radius, length, axis}}`, `{sphere: {radius}}` \
                 or `point_mass`"
                    .into(),
            ),
        );
    }
    if raw.contains("untagged enum Value") {
        return (
            "expected a number, a number with a unit, a parameter name or an expression".into(),
            Some("e.g. `0.03`, `30 g`, `grip_mass` or `2 * grip_mass + 5 g`".into()),
        );
    }
    if raw.contains("untagged enum Assembly") {
        return (
            "expected an angle or a travel (a number, or a number with a unit), or a list of angles, one per axis".into(),
            Some("e.g. `0.5`, `30 deg`, `12 mm` or `[2.08 deg, 0]`".into()),
        );
    }
    if let Some(i) = raw.find("untagged enum ") {
        let name = raw[i + "untagged enum ".len()..].trim();
        return (format!("not a valid {}", name.to_lowercase()), None);
    }
    if let Some(rest) = raw.strip_prefix("unknown field ") {
        let (field, expected) = match rest.find(", expected") {
            Some(i) => (&rest[..i], Some(rest[i + 2..].to_string())),
            None => (rest, None),
        };
        return (format!("unknown key {field}"), expected);
    }
    if let Some(rest) = raw.strip_prefix("missing field ") {
        return (format!("missing key {rest}"), None);
    }
    // `unknown variant` is serde's word for a value outside a fixed set (`type: rotary`); in
    // a model file "variant" means something else.
    if let Some(rest) = raw.strip_prefix("unknown variant ") {
        return match rest.find(", expected") {
            Some(i) => (format!("unknown value {}", &rest[..i]), Some(rest[i + 2..].to_string())),
            None => (format!("unknown value {rest}"), None),
        };
    }
    // `invalid type: string "twelve", expected f64` → `expected a number, got string "twelve"`.
    for prefix in ["invalid type: ", "invalid value: "] {
        if let Some(rest) = raw.strip_prefix(prefix) {
            if let Some(i) = rest.rfind(", expected ") {
                let expected = match &rest[i + ", expected ".len()..] {
                    "f64" => "a number",
                    "u32" => "a whole number from 0 to 4294967295",
                    "a sequence" => "a list",
                    "a map" => "a mapping",
                    other if other.starts_with("struct ") => "a mapping",
                    other => other,
                };
                let got = match &rest[..i] {
                    "unit value" => "an empty value",
                    "map" => "a mapping",
                    "sequence" => "a list",
                    other => other,
                };
                // A list or mapping where one number belongs: say what a number may be written as.
                let hint = match (expected, got) {
                    ("a number", "a list" | "a mapping") => Some(
                        "one number, which may carry a unit or be arithmetic on numbers and parameters: e.g. `7.72`, `30 g` or `0.13 N m * 7.72`"
                            .to_string(),
                    ),
                    (whole, "a list" | "a mapping") if whole.starts_with("a whole number") => {
                        Some("one whole number, e.g. `1280`".to_string())
                    }
                    ("a mapping", _) => Some(
                        "write its keys as `key: value` lines below it, or `{key: value, …}` on one line, e.g. a drive `{like: capstan, gear_ratio: 5}`; docs/model-format.md lists each entry's keys"
                            .to_string(),
                    ),
                    _ => None,
                };
                return (format!("expected {expected}, got {got}"), hint);
            }
        }
    }
    (raw.to_string(), None)
}

/// Finds the slot a dotted path names; list items are addressed by `name` (or index).
/// With `allow_new_leaf`, a missing last key of a mapping is created.
fn resolve_path<'v>(
    doc: &'v mut serde_yaml::Value,
    dotted: &str,
    allow_new_leaf: bool,
) -> Result<(KeyPath, &'v mut serde_yaml::Value), String> {
    let parts: Vec<&str> = dotted.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("`{dotted}` is not a dotted key path"));
    }
    let mut path = KeyPath::new();
    let mut current = doc;
    for (i, part) in parts.iter().enumerate() {
        let last = i + 1 == parts.len();
        current = match current {
            serde_yaml::Value::Mapping(map) => {
                let key = serde_yaml::Value::String((*part).to_string());
                if !map.contains_key(&key) {
                    if last && allow_new_leaf {
                        map.insert(key.clone(), serde_yaml::Value::Null);
                    } else {
                        return Err(format!(
                            "`{dotted}` does not name a value of the model: no key `{part}` at `{}`",
                            if path.is_empty() { "the top level".to_string() } else { display_path(&path) }
                        ));
                    }
                }
                path.push(Segment::Key((*part).to_string()));
                map.get_mut(&key).ok_or_else(|| format!("no key `{part}`"))?
            }
            serde_yaml::Value::Sequence(items) => {
                let position = items
                    .iter()
                    .position(|item| item.get("name").and_then(|n| n.as_str()) == Some(*part))
                    .or_else(|| part.parse::<usize>().ok().filter(|i| *i < items.len()));
                let Some(position) = position else {
                    return Err(format!(
                        "`{dotted}` does not name a value of the model: no item named `{part}` in `{}`",
                        display_path(&path)
                    ));
                };
                path.push(Segment::Index(position));
                &mut items[position]
            }
            _ => {
                return Err(format!(
                    "`{dotted}` does not name a value of the model: `{}` has no entries",
                    display_path(&path)
                ))
            }
        };
    }
    Ok((path, current))
}

/// Deletes the entry a dotted path names.
fn remove_path(doc: &mut serde_yaml::Value, dotted: &str) -> Result<(), String> {
    let (parent, leaf) = match dotted.rfind('.') {
        Some(i) => (&dotted[..i], &dotted[i + 1..]),
        None => ("", dotted),
    };
    let container = if parent.is_empty() { doc } else { resolve_path(doc, parent, false)?.1 };
    match container {
        serde_yaml::Value::Mapping(map) => {
            if map.remove(leaf).is_none() {
                return Err(format!("`{dotted}` does not name a value of the model"));
            }
        }
        serde_yaml::Value::Sequence(items) => {
            let before = items.len();
            items.retain(|item| item.get("name").and_then(|n| n.as_str()) != Some(leaf));
            if items.len() == before {
                return Err(format!("`{dotted}` does not name an item of the model"));
            }
        }
        _ => return Err(format!("`{dotted}` does not name a value of the model")),
    }
    Ok(())
}

/// Generates the JSON Schema of the model format from the Rust types.
pub fn json_schema() -> String {
    let schema = schemars::schema_for!(ModelFile);
    let mut text = serde_json::to_string_pretty(&schema).unwrap_or_default();
    text.push('\n');
    text
}

/// Map from parameter name to its resolved polynomial (constant, or an atom if tunable).
pub(crate) type ParameterValues = HashMap<String, Poly>;
