//! The identified model written back as a model file: the input file's text with only the
//! changed numbers replaced, each marked `# identified (was OLD)`.
//!
//! What is written, in the file's conventions (docs/model-format.md), as plain SI numbers
//! (a replaced value may have been an expression, a parameter's name, a unit or a shorthand;
//! the comment keeps it):
//!
//! * a body's `mass`; `com` (the centre of mass `c = h / m` in the body frame, 2 entries in a
//!   planar model); `inertia` about the centre of mass in body axes,
//!   `I_c = Ī_o − m (|c|² 1 − c cᵀ)`, as a number (`I_zz`) in a planar model and as the tensor
//!   `{ixx, iyy, izz, ixy, ixz, iyz}` (the matrix entries, `ixy = −∫x·y dm`) in a spatial one;
//! * a joint's `damping` (inserted if the file has none);
//! * a drive's `coulomb_friction` (inserted if it has none) and, where it was fitted,
//!   `motor.rotor_inertia = ia / N²`.
//!
//! **Shared drives.** A drive entry several joints use takes the values of the first of its
//! joints (in `q` order); each other joint whose fitted value differs (beyond 10⁻⁹ relative)
//! gets a drive of its own, `DRIVE_JOINT: {like: DRIVE, coulomb_friction: …}` inserted before
//! `DRIVE`, and its `drive:` names it. Nothing else of the file changes, so every comment stays.
//!
//! Each value is found by the loader's position index
//! ([`hapticgen_codegen::model::positions::PositionIndex`]) and its text's extent by a small
//! scanner of YAML scalars and flow collections; block-style collections are edited entry by
//! entry, never re-serialised.
//!
//! Not written: a joint's torque offset (the file has no field for it), massless bodies (kept
//! massless), and values a variant's `set` replaces (an error: edit the variant instead).

use std::collections::BTreeMap;

use hapticgen_codegen::eval::NominalAtoms;
use hapticgen_codegen::model::positions::{display_path, PositionIndex, Segment};
use hapticgen_codegen::CheckedModel;
use serde_yaml::Value;

use super::consistent::ConsistentParameters;

/// Relative change below which a value counts as unchanged.
const UNCHANGED: f64 = 1e-9;

/// Why the identified model could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    /// The text is not YAML.
    #[error("the model file does not parse: {0}")]
    Parse(#[from] serde_yaml::Error),
    /// A key the edit needs is missing from the file.
    #[error("{path}: not found in the model file")]
    Missing {
        /// Its key path.
        path: String,
    },
    /// A value is written in a form the editor does not handle.
    #[error("{line}:{column}: {path}: {what}")]
    Unsupported {
        /// Key path.
        path: String,
        /// Line, 1-based.
        line: usize,
        /// Column, 1-based.
        column: usize,
        /// What is not handled.
        what: String,
    },
    /// The model's variant replaces a value the identification changes.
    #[error(
        "variant `{variant}` sets `{key}`, which the identified model changes: edit the variant by hand"
    )]
    SetByVariant {
        /// The variant.
        variant: String,
        /// Its `set` key.
        key: String,
    },
}

/// A number as written: 12 significant digits, the shortest text that reads back as that.
pub fn format_number(x: f64) -> String {
    crate::output::yaml_number(x, 12)
}

/// One text edit: replace `start..end` (byte offsets of the input) by `text`.
#[derive(Debug)]
struct Edit {
    start: usize,
    end: usize,
    text: String,
}

struct Editor<'a> {
    text: &'a str,
    index: PositionIndex,
    line_starts: Vec<usize>,
    edits: Vec<Edit>,
    /// Notes per line end (byte offset).
    notes: BTreeMap<usize, Vec<String>>,
}

fn key(k: &str) -> Segment {
    Segment::Key(k.to_string())
}

impl<'a> Editor<'a> {
    fn new(text: &'a str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Editor {
            text,
            index: PositionIndex::build(text),
            line_starts,
            edits: Vec::new(),
            notes: BTreeMap::new(),
        }
    }

    /// Byte offset of a (line, column) position (both 1-based, the column in characters).
    fn offset(&self, (line, column): (usize, usize)) -> usize {
        let start = self.line_starts.get(line.saturating_sub(1)).copied().unwrap_or(self.text.len());
        let rest = &self.text[start..];
        rest.char_indices().nth(column.saturating_sub(1)).map(|(i, _)| start + i).unwrap_or(self.text.len())
    }

    /// End of the line holding `offset` (before `\r\n` or `\n`).
    fn line_end(&self, offset: usize) -> usize {
        let end = self.text[offset..].find('\n').map(|i| offset + i).unwrap_or(self.text.len());
        if end > 0 && self.text.as_bytes()[end - 1] == b'\r' {
            end - 1
        } else {
            end
        }
    }

    /// Start of the next line after the one holding `offset`.
    fn next_line(&self, offset: usize) -> Option<usize> {
        self.text[offset..].find('\n').map(|i| offset + i + 1)
    }

    fn unsupported(&self, path: &[Segment], what: impl Into<String>) -> ModelFileError {
        let (line, column) = self.index.value(path);
        ModelFileError::Unsupported { path: display_path(path), line, column, what: what.into() }
    }

    /// Whether the value at `path` is written in flow style (`{…}` or `[…]`).
    fn is_flow(&self, path: &[Segment]) -> bool {
        let start = self.offset(self.index.value(path));
        matches!(self.text[start..].chars().next(), Some('{' | '['))
    }

    /// The byte range of the value at `path`.
    fn value_range(&self, path: &[Segment]) -> Result<(usize, usize), ModelFileError> {
        if !self.index.contains(path) {
            return Err(ModelFileError::Missing { path: display_path(path) });
        }
        let start = self.offset(self.index.value(path));
        let in_flow = path.len() > 1 && self.is_flow(&path[..path.len() - 1]);
        let bytes = self.text.as_bytes();
        let end = match bytes.get(start) {
            Some(b'{' | b'[') => {
                let mut depth = 0usize;
                let mut quote: Option<u8> = None;
                let mut end = None;
                let mut i = start;
                while i < bytes.len() {
                    let b = bytes[i];
                    match quote {
                        Some(q) if b == q => quote = None,
                        Some(_) => {}
                        None => match b {
                            b'"' | b'\'' => quote = Some(b),
                            b'{' | b'[' => depth += 1,
                            b'}' | b']' => {
                                depth -= 1;
                                if depth == 0 {
                                    end = Some(i + 1);
                                    break;
                                }
                            }
                            b'#' if i > 0 && bytes[i - 1].is_ascii_whitespace() => {
                                // A comment inside a flow collection spanning lines.
                                i = self.line_end(i);
                                continue;
                            }
                            _ => {}
                        },
                    }
                    i += 1;
                }
                end.ok_or_else(|| self.unsupported(path, "unterminated flow collection"))?
            }
            Some(&q @ (b'"' | b'\'')) => {
                let close = self.text[start + 1..]
                    .find(q as char)
                    .ok_or_else(|| self.unsupported(path, "unterminated quoted value"))?;
                start + 1 + close + 1
            }
            _ => {
                let line_end = self.line_end(start);
                let mut end = line_end;
                let segment = &self.text[start..line_end];
                for (i, c) in segment.char_indices() {
                    let comment = c == '#' && i > 0 && segment[..i].ends_with([' ', '\t']);
                    if comment || (in_flow && matches!(c, ',' | ']' | '}')) {
                        end = start + i;
                        break;
                    }
                }
                start + self.text[start..end].trim_end().len()
            }
        };
        Ok((start, end))
    }

    /// Whether the block mapping at `path` has its first key on a new line (not `{…}`).
    fn is_block_mapping(&self, path: &[Segment]) -> bool {
        self.index.contains(path) && !self.is_flow(path)
    }

    /// Replaces the value at `path`, noting the old text.
    fn replace(&mut self, path: &[Segment], text: String) -> Result<(), ModelFileError> {
        let (start, end) = self.value_range(path)?;
        let old = self.text[start..end].split_whitespace().collect::<Vec<_>>().join(" ");
        let last = path.last().map(|s| match s {
            Segment::Key(k) => k.clone(),
            Segment::Index(i) => format!("[{i}]"),
        });
        let line_end = self.line_end(end);
        self.edits.push(Edit { start, end, text });
        self.notes
            .entry(line_end)
            .or_default()
            .push(format!("{}{old}", last.map(|l| format!("{l} ")).unwrap_or_default()));
        Ok(())
    }

    /// Inserts `name: text` into the block mapping at `mapping`, on a new line after its entry
    /// `after` (a single-line scalar).
    fn insert(
        &mut self,
        mapping: &[Segment],
        after: &[&str],
        name: &str,
        text: String,
    ) -> Result<(), ModelFileError> {
        if !self.is_block_mapping(mapping) {
            return Err(self.unsupported(mapping, format!("cannot add `{name}` to a flow mapping")));
        }
        for sibling in after {
            let mut path = mapping.to_vec();
            path.push(key(sibling));
            if !self.index.contains(&path) || self.is_flow(&path) {
                continue;
            }
            let (key_line, key_column) = self.index.key(&path);
            let (value_line, _) = self.index.value(&path);
            if key_line != value_line {
                continue;
            }
            let (_, end) = self.value_range(&path)?;
            let indent = " ".repeat(key_column - 1);
            let line = format!("{indent}{name}: {text}  # identified (not in the file)\n");
            match self.next_line(end) {
                Some(at) => self.edits.push(Edit { start: at, end: at, text: line }),
                None => {
                    let at = self.text.len();
                    self.edits.push(Edit { start: at, end: at, text: format!("\n{}", line.trim_end()) });
                }
            }
            return Ok(());
        }
        Err(self.unsupported(mapping, format!("no single-line entry to add `{name}` after")))
    }

    fn finish(mut self) -> String {
        for (at, notes) in std::mem::take(&mut self.notes) {
            let text = format!("  # identified (was {})", notes.join("; "));
            self.edits.push(Edit { start: at, end: at, text });
        }
        // Later edits first, so that earlier offsets stay valid; at one offset, a line's note
        // (empty range) after the value it follows.
        self.edits.sort_by(|a, b| b.start.cmp(&a.start).then(b.end.cmp(&a.end)));
        let mut out = self.text.to_string();
        for e in &self.edits {
            out.replace_range(e.start..e.end, &e.text);
        }
        out
    }
}

fn changed(new: f64, old: f64, scale: f64) -> bool {
    (new - old).abs() > UNCHANGED * scale.max(old.abs()).max(1e-300)
}

/// The identified model as a model file: `text` (the file `model` was loaded from) with the
/// values of `fit` that differ from the file's replaced (see the module documentation).
pub fn write_model_file(
    text: &str,
    model: &CheckedModel,
    fit: &ConsistentParameters,
) -> Result<String, ModelFileError> {
    let doc: Value = serde_yaml::from_str(text)?;
    let mut editor = Editor::new(text);
    let params = model.nominal_parameters();
    let nominal = NominalAtoms(&params);
    let planar = model.planar;

    let mut changed_paths: Vec<String> = Vec::new();
    // Bodies.
    let file_bodies = doc.get("bodies").and_then(Value::as_sequence).cloned().unwrap_or_default();
    for (i, entry) in file_bodies.iter().enumerate() {
        let Some(name) = entry.get("name").and_then(Value::as_str) else { continue };
        let Some((body, fitted)) =
            model.bodies.iter().zip(&fit.bodies).find(|(b, f)| b.name == name && f.name == name)
        else {
            continue;
        };
        if !fitted.fitted {
            continue;
        }
        let at = |k: &str| vec![key("bodies"), Segment::Index(i), key(k)];
        let m_old = body.mass.eval(&nominal);
        let c_old = body.com.clone().map(|p| p.eval(&nominal));
        let i_old = body.inertia.clone().map(|row| row.map(|p| p.eval(&nominal)));
        let m = fitted.mass;
        let radius = ((i_old[0][0] + i_old[1][1] + i_old[2][2]) / m_old.max(1e-300)).abs().sqrt();
        let length = radius + c_old.iter().map(|x| x * x).sum::<f64>().sqrt();
        if changed(m, m_old, m_old) {
            editor.replace(&at("mass"), format_number(m))?;
            changed_paths.push(display_path(&at("mass")));
        }
        let dim = if planar { 2 } else { 3 };
        if (0..dim).any(|k| changed(fitted.com[k], c_old[k], length)) {
            let entries: Vec<String> = fitted.com[..dim].iter().map(|&x| format_number(x)).collect();
            editor.replace(&at("com"), format!("[{}]", entries.join(", ")))?;
            changed_paths.push(display_path(&at("com")));
        }
        let scale = m_old.max(m) * length * length;
        let inertia_changed = if planar {
            changed(fitted.inertia[2][2], i_old[2][2], scale)
        } else {
            (0..3).any(|r| (0..3).any(|s| changed(fitted.inertia[r][s], i_old[r][s], scale)))
        };
        if inertia_changed {
            let t = &fitted.inertia;
            let value = if planar {
                format_number(t[2][2].max(0.0))
            } else {
                format!(
                    "{{ixx: {}, iyy: {}, izz: {}, ixy: {}, ixz: {}, iyz: {}}}",
                    format_number(t[0][0]),
                    format_number(t[1][1]),
                    format_number(t[2][2]),
                    format_number(t[0][1]),
                    format_number(t[0][2]),
                    format_number(t[1][2]),
                )
            };
            let path = at("inertia");
            if entry.get("inertia").is_some_and(Value::is_mapping) && !editor.is_flow(&path) {
                return Err(
                    editor.unsupported(&path, "a block-style inertia mapping: write it as `{…}` on one line")
                );
            }
            editor.replace(&path, value)?;
            changed_paths.push(display_path(&path));
        }
    }

    // Joints: damping.
    let file_joints = doc.get("joints").and_then(Value::as_sequence).cloned().unwrap_or_default();
    let joint_entry =
        |name: &str| file_joints.iter().position(|j| j.get("name").and_then(Value::as_str) == Some(name));
    for (joint, fitted) in model.joints.iter().zip(&fit.joints) {
        let Some(j) = joint_entry(&joint.name) else { continue };
        let old = joint.damping.eval(&nominal);
        if !changed(fitted.damping, old, old) {
            continue;
        }
        let mapping = vec![key("joints"), Segment::Index(j)];
        let mut path = mapping.clone();
        path.push(key("damping"));
        if file_joints[j].get("damping").is_some() {
            editor.replace(&path, format_number(fitted.damping))?;
        } else {
            editor.insert(&mapping, &["drive", "type", "name"], "damping", format_number(fitted.damping))?;
        }
        changed_paths.push(display_path(&path));
    }

    // Drives: Coulomb friction and fitted rotor inertias, per drive entry.
    let drives = doc.get("drives").and_then(Value::as_mapping).cloned().unwrap_or_default();
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (j, joint) in model.joints.iter().enumerate() {
        groups.entry(joint.drive_name.clone()).or_default().push(j);
    }
    let mut taken: Vec<String> = drives.keys().filter_map(|k| k.as_str().map(str::to_string)).collect();
    for (drive, joints) in &groups {
        let Some(entry) = drives.get(drive.as_str()) else { continue };
        let first = joints[0];
        let resolved = &model.joints[first].drive;
        let n2 = resolved.gear_ratio * resolved.gear_ratio;
        let friction = |j: usize| fit.joints[j].coulomb_friction;
        let rotor = |j: usize| fit.joints[j].rotor_fitted.then(|| fit.joints[j].reflected_rotor_inertia / n2);
        let mapping = vec![key("drives"), key(drive)];
        if changed(friction(first), resolved.coulomb_friction, resolved.coulomb_friction) {
            let mut path = mapping.clone();
            path.push(key("coulomb_friction"));
            if entry.get("coulomb_friction").is_some() {
                editor.replace(&path, format_number(friction(first)))?;
            } else {
                let after =
                    ["gear_ratio", "torque_limit", "current_limit", "supply_voltage", "efficiency", "like"];
                editor.insert(&mapping, &after, "coulomb_friction", format_number(friction(first)))?;
            }
            changed_paths.push(display_path(&path));
        }
        if let Some(j_m) = rotor(first) {
            if changed(j_m, resolved.motor.rotor_inertia, resolved.motor.rotor_inertia) {
                let path = vec![key("drives"), key(drive), key("motor"), key("rotor_inertia")];
                if entry.get("motor").and_then(|m| m.get("rotor_inertia")).is_none() {
                    return Err(ModelFileError::Missing { path: display_path(&path) });
                }
                editor.replace(&path, format_number(j_m))?;
                changed_paths.push(display_path(&path));
            }
        }
        // The other joints of a shared drive, where their values differ.
        for &j in &joints[1..] {
            let scale_f = friction(first).abs().max(1e-300);
            let friction_differs =
                (friction(j) - friction(first)).abs() > UNCHANGED * scale_f.max(friction(j).abs());
            let rotor_differs = match (rotor(j), rotor(first)) {
                (Some(a), Some(b)) => (a - b).abs() > UNCHANGED * a.abs().max(b.abs()),
                _ => false,
            };
            if !(friction_differs || rotor_differs) {
                continue;
            }
            let joint = &model.joints[j].name;
            let mut name = format!("{drive}_{joint}");
            let mut k = 2;
            while taken.contains(&name) {
                name = format!("{drive}_{joint}_{k}");
                k += 1;
            }
            taken.push(name.clone());
            let mut fields =
                vec![format!("like: {drive}"), format!("coulomb_friction: {}", format_number(friction(j)))];
            if let Some(j_m) = rotor(j) {
                fields.push(format!("motor: {{rotor_inertia: {}}}", format_number(j_m)));
            }
            let (key_line, key_column) = editor.index.key(&mapping);
            let at = editor.offset((key_line, 1));
            let line = format!(
                "{}{name}: {{{}}}  # identified: joint `{joint}`'s own (it shared `{drive}`)\n",
                " ".repeat(key_column - 1),
                fields.join(", ")
            );
            editor.edits.push(Edit { start: at, end: at, text: line });
            let Some(e) = joint_entry(joint) else { continue };
            let path = vec![key("joints"), Segment::Index(e), key("drive")];
            editor.replace(&path, name)?;
            changed_paths.push(display_path(&path));
        }
    }

    // A variant that sets what changed would undo the edit.
    if let Some(variant) = &model.variant {
        let sets = doc
            .get("variants")
            .and_then(|v| v.get(variant.as_str()))
            .and_then(|v| v.get("set"))
            .and_then(Value::as_mapping)
            .cloned()
            .unwrap_or_default();
        for set in sets.keys().filter_map(Value::as_str) {
            let touches = changed_paths.iter().any(|p| p.starts_with(set) || set.starts_with(p.as_str()))
                || ["bodies", "joints", "drives"].iter().any(|section| {
                    set.starts_with(section) && changed_paths.iter().any(|p| p.starts_with(section))
                });
            if touches {
                return Err(ModelFileError::SetByVariant { variant: variant.clone(), key: set.to_string() });
            }
        }
    }
    Ok(editor.finish())
}
