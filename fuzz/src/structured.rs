//! Structured inputs: random but plausible model documents, drawn from an
//! [`arbitrary::Unstructured`] byte source and serialised to YAML.
//!
//! The documents follow the model format's shape (bodies, joints, drives, values, parameter
//! references, variants with `set`/`remove` paths) with values that are mostly plausible and
//! sometimes broken on purpose: a wrong type, a dangling reference, a missing or unknown key,
//! a cycle, a non-finite or extreme number. Names come from small pools so that references
//! resolve most of the time, which gets inputs past the parser into validation, the
//! mechanics and emission.

use arbitrary::{Result, Unstructured};
use serde_yaml::{Mapping, Value};

/// Parameter names the generator uses (values may reference them).
const PARAMETERS: [&str; 3] = ["p_len", "p_mass", "p_damp"];

/// A random model document and the variant to load.
#[derive(Clone, Debug)]
pub struct Document {
    /// The YAML text.
    pub text: String,
    /// The variant to request (`None`: the model's default).
    pub variant: Option<String>,
}

fn s(text: &str) -> Value {
    Value::String(text.to_string())
}

fn map(entries: Vec<(&str, Value)>) -> Value {
    let mut m = Mapping::new();
    for (k, v) in entries {
        m.insert(s(k), v);
    }
    Value::Mapping(m)
}

/// The byte source and how often a value is broken on purpose (per cent): half the
/// documents are clean, so that many inputs reach the mechanics and the emitter.
struct Gen<'a, 'b> {
    u: &'b mut Unstructured<'a>,
    edge: u8,
}

impl<'a> std::ops::Deref for Gen<'a, '_> {
    type Target = Unstructured<'a>;
    fn deref(&self) -> &Unstructured<'a> {
        self.u
    }
}

impl<'a> std::ops::DerefMut for Gen<'a, '_> {
    fn deref_mut(&mut self) -> &mut Unstructured<'a> {
        self.u
    }
}

fn broken(u: &mut Gen<'_, '_>) -> Result<bool> {
    let edge = u.edge;
    Ok(u.int_in_range(0..=999u16)? < u16::from(edge) * 10)
}

fn chance(u: &mut Gen<'_, '_>, percent: u8) -> Result<bool> {
    Ok(u.int_in_range(0..=99u8)? < percent)
}

/// A number: mostly uniform in `lo..hi`, sometimes an edge case.
fn number(u: &mut Gen<'_, '_>, lo: f64, hi: f64) -> Result<Value> {
    if !broken(u)? {
        let t = f64::from(u.int_in_range(0..=10_000u32)?) / 10_000.0;
        return Ok(Value::from(round_to_digits(lo + t * (hi - lo), 4)));
    }
    Ok(match u.int_in_range(0..=11u8)? {
        0 => Value::from(0.0),
        1 => Value::from(-1.0),
        2 => Value::from(1e300),
        3 => Value::from(-1e-300),
        4 => Value::from(f64::NAN),
        5 => Value::from(f64::INFINITY),
        6 => Value::from(u64::MAX),
        7 => Value::from(-7i64),
        8 => Value::from(f64::from_bits(u.arbitrary::<u64>()?)),
        9 => s("twelve"),
        10 => Value::Null,
        _ => Value::Sequence(vec![Value::from(1.0)]),
    })
}

/// A *value*: a number or (sometimes) a parameter name, possibly an undefined one.
fn value(u: &mut Gen<'_, '_>, lo: f64, hi: f64) -> Result<Value> {
    if chance(u, 10)? {
        let name = if !broken(u)? { *u.choose(&PARAMETERS)? } else { "p_undefined" };
        return Ok(s(name));
    }
    number(u, lo, hi)
}

fn vector(u: &mut Gen<'_, '_>, dim: usize, lo: f64, hi: f64) -> Result<Value> {
    let len = if !broken(u)? { dim } else { u.int_in_range(0..=4usize)? };
    Ok(Value::Sequence((0..len).map(|_| value(u, lo, hi)).collect::<Result<_>>()?))
}

/// A list of plain numbers (axes and angles take no parameter names).
fn numbers(u: &mut Gen<'_, '_>, dim: usize, lo: f64, hi: f64) -> Result<Value> {
    let len = if !broken(u)? { dim } else { u.int_in_range(0..=4usize)? };
    Ok(Value::Sequence((0..len).map(|_| number(u, lo, hi)).collect::<Result<_>>()?))
}

fn identifier(u: &mut Gen<'_, '_>, prefix: &str, count: usize) -> Result<String> {
    if !broken(u)? {
        let i = u.int_in_range(0..=count.saturating_sub(1))?;
        return Ok(format!("{prefix}{i}"));
    }
    Ok(u.choose(&["base", "fn", "Bad Name", "", "a.b", "ünïcode", "x"])?.to_string())
}

fn drive(u: &mut Gen<'_, '_>) -> Result<Value> {
    let mut entries = vec![
        (
            "motor",
            map(vec![
                ("rotor_inertia", number(u, 0.0, 1e-4)?),
                ("resistance", number(u, 0.05, 5.0)?),
                ("inductance", number(u, 1e-5, 1e-3)?),
                ("torque_constant", number(u, 0.005, 0.1)?),
            ]),
        ),
        ("gear_ratio", number(u, 1.0, 50.0)?),
        ("torque_limit", number(u, 0.1, 10.0)?),
        ("current_limit", number(u, 1.0, 20.0)?),
        ("supply_voltage", number(u, 6.0, 48.0)?),
        ("encoder", map(vec![("counts_per_turn", Value::from(u.int_in_range(0..=40_000u32)?))])),
    ];
    if chance(u, 30)? {
        entries.push(("efficiency", number(u, 0.5, 1.0)?));
    }
    if chance(u, 30)? {
        entries.push(("backlash", number(u, 0.0, 0.02)?));
        entries.push(("coulomb_friction", number(u, 0.0, 0.05)?));
        entries.push(("static_friction", number(u, 0.0, 0.08)?));
    }
    Ok(map(entries))
}

fn inertia(u: &mut Gen<'_, '_>, planar: bool) -> Result<Value> {
    Ok(match (planar, u.int_in_range(0..=9u8)?) {
        (true, 0..=3) => value(u, 0.0, 1e-3)?,
        (true, 4..=8) => map(vec![("slender_rod", value(u, 0.01, 0.3)?)]),
        (false, 0..=8) => {
            // Principal moments that satisfy the triangle inequality (unless broken).
            let a = f64::from(u.int_in_range(1..=1000u32)?) / 1e6;
            let b = f64::from(u.int_in_range(1..=1000u32)?) / 1e6;
            let t = f64::from(u.int_in_range(0..=100u32)?) / 100.0;
            let c = (a - b).abs() + t * (a + b - (a - b).abs());
            let mut e = if broken(u)? {
                vec![
                    ("ixx", value(u, 0.0, 1e-3)?),
                    ("iyy", value(u, 0.0, 1e-3)?),
                    ("izz", value(u, 0.0, 1e-3)?),
                ]
            } else {
                vec![("ixx", Value::from(a)), ("iyy", Value::from(b)), ("izz", Value::from(c))]
            };
            if chance(u, 40)? {
                e.push(("ixy", number(u, -1e-5, 1e-5)?));
                e.push(("ixz", number(u, -1e-5, 1e-5)?));
                e.push(("iyz", number(u, -1e-5, 1e-5)?));
            }
            map(e)
        }
        _ if !broken(u)? => map(vec![("slender_rod", value(u, 0.01, 0.3)?)]),
        _ => map(vec![("slender_rod", value(u, 0.01, 0.3)?), ("ixx", number(u, 0.0, 1.0)?)]),
    })
}

/// Builds one random model document.
pub fn document(u: &mut Unstructured<'_>) -> Result<Document> {
    let edge = if u.arbitrary::<bool>()? { 0 } else { u.int_in_range(1..=5u8)? };
    document_with(&mut Gen { u, edge })
}

fn document_with(u: &mut Gen<'_, '_>) -> Result<Document> {
    let planar = chance(u, 60)?;
    let dim = if planar { 2 } else { 3 };
    let joints = if !broken(u)? { u.int_in_range(1..=4usize)? } else { u.int_in_range(0..=6usize)? };
    let drives = u.int_in_range(1..=2usize)?;
    let mut top: Vec<(&str, Value)> = Vec::new();
    top.push(("name", s(&identifier(u, "rig", 1)?)));
    if chance(u, 30)? {
        top.push(("description", s("a fuzzed rig")));
    }
    let space = if !broken(u)? {
        if planar {
            "planar"
        } else {
            "spatial"
        }
    } else {
        "lunar"
    };
    top.push(("space", s(space)));
    top.push(("gravity", vector(u, dim, -10.0, 10.0)?));
    if !broken(u)? || chance(u, 50)? {
        let mut m = Mapping::new();
        for name in PARAMETERS {
            if !broken(u)? || chance(u, 70)? {
                let mut e = vec![("value", number(u, 0.01, 0.5)?)];
                if chance(u, 40)? {
                    e.push(("tunable", Value::Bool(u.arbitrary()?)));
                }
                if chance(u, 20)? {
                    e.push(("unit", s("m")));
                }
                m.insert(s(name), map(e));
            }
        }
        top.push(("parameters", Value::Mapping(m)));
    }
    let mut drive_map = Mapping::new();
    for i in 0..drives {
        drive_map.insert(s(&format!("d{i}")), drive(u)?);
    }
    top.push(("drives", Value::Mapping(drive_map)));

    let mut joint_list = Vec::new();
    for i in 0..joints {
        let prismatic = chance(u, 20)?;
        let mut e = vec![
            ("name", s(&if !broken(u)? { format!("j{i}") } else { identifier(u, "j", joints)? })),
            (
                "type",
                s(if !broken(u)? {
                    if prismatic {
                        "prismatic"
                    } else {
                        "revolute"
                    }
                } else {
                    "rotary"
                }),
            ),
        ];
        if chance(u, 60)? {
            let axis = if planar && !prismatic {
                let sign = if u.arbitrary()? { 1.0 } else { -1.0 };
                if !broken(u)? {
                    Value::Sequence(vec![Value::from(0.0), Value::from(0.0), Value::from(sign)])
                } else {
                    numbers(u, 3, -1.0, 1.0)?
                }
            } else if planar {
                numbers(u, 2, -1.0, 1.0)?
            } else {
                numbers(u, 3, -1.0, 1.0)?
            };
            e.push(("axis", axis));
        }
        let lower = number(u, -3.0, 0.0)?;
        let upper = number(u, 0.0, 3.0)?;
        e.push(("limits", map(vec![("lower", lower), ("upper", upper)])));
        if chance(u, 70)? {
            e.push(("damping", value(u, 0.0, 0.01)?));
        }
        e.push(("drive", s(&identifier(u, "d", drives)?)));
        if broken(u)? && chance(u, 10)? {
            e.push(("stiffness", Value::from(1.0)));
        }
        joint_list.push(map(e));
    }
    top.push(("joints", Value::Sequence(joint_list)));

    // A serial chain (sometimes branched, sometimes with a dangling or cyclic parent), plus
    // welded bodies and, for planar models, direct poses.
    let extra = u.int_in_range(0..=2usize)?;
    let bodies = joints + extra;
    let mut body_list = Vec::new();
    for i in 0..bodies {
        let mut e = vec![
            ("name", s(&if !broken(u)? { format!("b{i}") } else { identifier(u, "b", bodies)? })),
            ("mass", value(u, 0.01, 1.0)?),
            ("com", vector(u, dim, -0.2, 0.2)?),
            ("inertia", inertia(u, planar)?),
        ];
        let direct = planar && i >= joints && joints > 0 && chance(u, 40)?;
        if direct {
            let carrier = if i == 0 || chance(u, 20)? { "base".to_string() } else { format!("b{}", i - 1) };
            e.push((
                "pose",
                map(vec![
                    ("origin", map(vec![("body", s(&carrier)), ("point", vector(u, 2, -0.2, 0.2)?)])),
                    ("angle", s(&identifier(u, "j", joints)?)),
                ]),
            ));
        } else {
            let parent = match u.int_in_range(0..=19u8)? {
                0 => identifier(u, "b", bodies)?,
                1 if i > 1 => format!("b{}", u.int_in_range(0..=i - 2)?),
                _ if i == 0 => "base".to_string(),
                _ => format!("b{}", i - 1),
            };
            e.push(("parent", s(&parent)));
            if chance(u, 70)? {
                let mut origin = vec![("xyz", vector(u, dim, -0.3, 0.3)?)];
                if chance(u, 40)? {
                    let rpy = if planar { numbers(u, 1, -3.2, 3.2)? } else { numbers(u, 3, -3.2, 3.2)? };
                    origin.push(("rpy", rpy));
                }
                e.push(("origin", map(origin)));
            }
            if i < joints {
                e.push((
                    "joint",
                    s(&if !broken(u)? { format!("j{i}") } else { identifier(u, "j", joints)? }),
                ));
            }
        }
        body_list.push(map(e));
    }
    top.push(("bodies", Value::Sequence(body_list)));

    let points = u.int_in_range(0..=2usize)?;
    let mut point_list = Vec::new();
    for i in 0..points {
        point_list.push(map(vec![
            ("name", s(&format!("pt{i}"))),
            ("body", s(&if chance(u, 10)? { "base".to_string() } else { identifier(u, "b", bodies)? })),
            ("position", vector(u, dim, -0.3, 0.3)?),
        ]));
    }
    if points > 0 || chance(u, 50)? {
        top.push(("points", Value::Sequence(point_list)));
    }
    let task = if points > 0 && chance(u, 60)? {
        map(vec![("point", s(&identifier(u, "pt", points)?))])
    } else {
        let count = u.int_in_range(1..=joints.max(1))?;
        let list = if broken(u)? {
            (0..count).map(|_| identifier(u, "j", joints).map(|n| s(&n))).collect::<Result<Vec<_>>>()?
        } else {
            (0..count).map(|i| s(&format!("j{i}"))).collect()
        };
        map(vec![("joints", Value::Sequence(list))])
    };
    top.push(("task", task));
    if chance(u, 30)? {
        top.push((
            "sensors",
            Value::Sequence(vec![map(vec![
                ("name", s("force")),
                ("kind", s(if !broken(u)? { "force" } else { "torque" })),
                ("scale", number(u, -5.0, 5.0)?),
                ("full_scale", number(u, 0.1, 20.0)?),
                ("noise", number(u, 0.0, 0.1)?),
            ])]),
        ));
    }
    let current_hz = if !broken(u)? { Value::from(7500) } else { number(u, 0.0, 20_000.0)? };
    let impedance_hz = if !broken(u)? { Value::from(1000) } else { number(u, 0.0, 20_000.0)? };
    top.push(("rates", map(vec![("current_loop_hz", current_hz), ("impedance_loop_hz", impedance_hz)])));
    let mut current_loop = vec![
        ("bandwidth_hz", if !broken(u)? { Value::from(700.0) } else { number(u, 0.0, 5000.0)? }),
        ("damping_ratio", if !broken(u)? { Value::from(1.05) } else { number(u, 0.0, 3.0)? }),
        ("anti_alias_cutoff_hz", if !broken(u)? { Value::from(2500.0) } else { number(u, 0.0, 8000.0)? }),
    ];
    if chance(u, 20)? {
        current_loop.push(("anti_alias_filter_order", Value::from(u.int_in_range(0..=6u8)?)));
    }
    top.push(("current_loop", map(current_loop)));
    if chance(u, 40)? {
        let mut r = vec![
            ("grid_spacing", number(u, 1e-4, 1e-3)?),
            ("wall_stiffness", number(u, 0.0, 5000.0)?),
            ("wall_damping", number(u, 0.0, 10.0)?),
        ];
        if chance(u, 30)? {
            r.push(("allow_unstable_stiffness", Value::Bool(u.arbitrary()?)));
        }
        top.push(("rendering", map(r)));
    }

    // Variants.
    let variant_count = if chance(u, 35)? { u.int_in_range(1..=2usize)? } else { 0 };
    let mut variant = None;
    if variant_count > 0 {
        const PATHS: [&str; 12] = [
            "gravity",
            "bodies.b0.mass",
            "bodies.b1.com",
            "joints.j0.damping",
            "joints.j1.limits.upper",
            "drives.d0.gear_ratio",
            "drives.d0.motor.resistance",
            "rendering.wall_stiffness",
            "rates.impedance_loop_hz",
            "bodies.0.inertia",
            "nonexistent.key",
            "joints..name",
        ];
        let mut variants = Mapping::new();
        for k in 0..variant_count {
            let mut set = Mapping::new();
            for _ in 0..u.int_in_range(0..=3usize)? {
                let usable = if broken(u)? { PATHS.len() } else { PATHS.len() - 2 };
                let path = PATHS[u.int_in_range(0..=usable - 1)?];
                let v = if path == "gravity" || path.ends_with("com") {
                    vector(u, dim, -10.0, 10.0)?
                } else {
                    value(u, 0.0, 2.0)?
                };
                set.insert(s(path), v);
            }
            let mut e = vec![("set", Value::Mapping(set))];
            if chance(u, 25)? {
                let path =
                    *u.choose(&["sensors.force", "points.pt0", "rendering", "bodies.b2", "parameters"])?;
                e.push(("remove", Value::Sequence(vec![s(path)])));
            }
            variants.insert(s(&format!("v{k}")), map(e));
        }
        if chance(u, 95)? {
            let default = identifier(u, "v", variant_count)?;
            top.push(("default_variant", s(&default)));
        }
        top.push(("variants", Value::Mapping(variants)));
        variant = match u.int_in_range(0..=4u8)? {
            0 => Some(identifier(u, "v", variant_count)?),
            1 if broken(u)? => Some("no_such_variant".to_string()),
            _ => None,
        };
    }

    // Structural damage: drop a required key, add an unknown one, or repeat the document
    // inside itself.
    if broken(u)? && chance(u, 20)? && !top.is_empty() {
        let i = u.int_in_range(0..=top.len() - 1)?;
        top.remove(i);
    }
    if broken(u)? && chance(u, 20)? {
        top.push(("colour", s("red")));
    }
    // Most documents are written compactly (a fifth of serde_yaml's emitter's instructions,
    // about 100,000 against 540,000, and a tenth fewer bytes: the loader's time per input
    // follows its size); one in eight by serde_yaml, block style throughout, as the model
    // files the mutator starts from are written.
    let document = map(top);
    let text = if u.ratio(1, SERDE_YAML_EMITTER_ODDS)? {
        serde_yaml::to_string(&document).unwrap_or_default()
    } else {
        compact_yaml(&document)
    };
    Ok(Document { text, variant })
}

/// One structured document in this many is written by serde_yaml's emitter, the others by
/// [`compact_yaml`].
const SERDE_YAML_EMITTER_ODDS: u8 = 8;

/// The document as compact YAML: block mappings indented by one space, block sequences of
/// mappings, every other sequence and small mapping in flow style (`[0.1, -2.5]`, `{lower:
/// -1.5, upper: 1.5}`), plain scalars
/// where they cannot be read as anything else and double-quoted ones otherwise. The fuzzer's
/// own documents only (strings from small pools, no tags); test
/// `compact_documents_read_back_as_the_same_values` reads every shape back with serde_yaml.
pub fn compact_yaml(document: &Value) -> String {
    let mut out = String::with_capacity(1024);
    match document {
        Value::Mapping(m) if !m.is_empty() => block_mapping(m, 0, &mut out),
        other => {
            flow(other, &mut out);
            out.push('\n');
        }
    }
    out
}

fn indent(depth: usize, out: &mut String) {
    out.extend(std::iter::repeat_n(' ', depth));
}

/// A mapping written in flow style inside a block one (`limits: {lower: -1.5, upper: 1.5}`,
/// as the model files write them): up to four entries, none a collection.
fn is_small(m: &Mapping) -> bool {
    m.len() <= 4 && m.values().all(|v| !matches!(v, Value::Mapping(_) | Value::Sequence(_)))
}

/// A sequence written as a block: one with a non-empty mapping among its items.
fn is_block_sequence(items: &[Value]) -> bool {
    items.iter().any(|item| matches!(item, Value::Mapping(m) if !m.is_empty()))
}

/// The entries of `m`, each on its own line at `depth` (the caller has written the first
/// line's indentation when `first_inline`).
fn block_entries(m: &Mapping, depth: usize, first_inline: bool, out: &mut String) {
    for (i, (key, value)) in m.iter().enumerate() {
        if i > 0 || !first_inline {
            indent(depth, out);
        }
        flow(key, out);
        out.push(':');
        match value {
            Value::Mapping(inner) if !inner.is_empty() && !is_small(inner) => {
                out.push('\n');
                block_mapping(inner, depth + 1, out);
            }
            Value::Sequence(items) if is_block_sequence(items) => {
                out.push('\n');
                block_sequence(items, depth, out);
            }
            _ => {
                out.push(' ');
                flow(value, out);
                out.push('\n');
            }
        }
    }
}

fn block_mapping(m: &Mapping, depth: usize, out: &mut String) {
    block_entries(m, depth, false, out);
}

/// Items as `- ` lines at `depth` (a mapping's first entry on the dash's line).
fn block_sequence(items: &[Value], depth: usize, out: &mut String) {
    for item in items {
        indent(depth, out);
        out.push_str("- ");
        match item {
            Value::Mapping(m) if !m.is_empty() => block_entries(m, depth + 2, true, out),
            Value::Sequence(inner) if is_block_sequence(inner) => {
                out.push('\n');
                block_sequence(inner, depth + 2, out);
            }
            _ => {
                flow(item, out);
                out.push('\n');
            }
        }
    }
}

/// A value in flow style.
fn flow(value: &Value, out: &mut String) {
    use std::fmt::Write as _;
    match value {
        Value::Null => out.push_str("null"),
        Value::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
        Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
            (Some(u), _, _) => {
                let _ = write!(out, "{u}");
            }
            (None, Some(i), _) => {
                let _ = write!(out, "{i}");
            }
            (None, None, Some(f)) if f.is_nan() => out.push_str(".nan"),
            (None, None, Some(f)) if f.is_infinite() => out.push_str(if f > 0.0 { ".inf" } else { "-.inf" }),
            // Debug keeps a float a float (`2.0`, `1e300`) in the shortest exact digits.
            (None, None, Some(f)) => {
                let _ = write!(out, "{f:?}");
            }
            _ => out.push_str("null"),
        },
        Value::String(text) => string(text, out),
        Value::Sequence(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                flow(item, out);
            }
            out.push(']');
        }
        Value::Mapping(m) => {
            out.push('{');
            for (i, (key, value)) in m.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                flow(key, out);
                out.push_str(": ");
                flow(value, out);
            }
            out.push('}');
        }
        // The generator draws no tags; should one appear, serde_yaml writes it.
        Value::Tagged(_) => out.push_str(serde_yaml::to_string(value).unwrap_or_default().trim_end()),
    }
}

/// A string scalar: plain when it is a name (a letter or `_`, then letters, digits, `_`, `.`)
/// that YAML reads as no other type, else double-quoted.
fn string(text: &str, out: &mut String) {
    let mut chars = text.chars();
    let name = chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
    let reserved = ["null", "true", "false", "yes", "no", "on", "off", "y", "n", "nan", "inf"]
        .iter()
        .any(|word| text.eq_ignore_ascii_case(word));
    if name && !reserved {
        out.push_str(text);
        return;
    }
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => {
                use std::fmt::Write as _;
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// `x` to `digits` significant decimal digits, as the nearest double to that decimal (so
/// that it prints in those digits, not as `0.48401200000000003`).
fn round_to_digits(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let decimals = digits - 1 - x.abs().log10().floor() as i32;
    match decimals {
        0..=22 => {
            let scale = 10f64.powi(decimals);
            (x * scale).round() / scale
        }
        -22..=-1 => {
            let scale = 10f64.powi(-decimals);
            (x / scale).round() * scale
        }
        _ => x,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngCore, SeedableRng};

    /// Every document [`compact_yaml`] writes reads back, with serde_yaml, as the value it
    /// was written from (what the loader then sees), and is well under serde_yaml's size.
    #[test]
    fn compact_documents_read_back_as_the_same_values() {
        let mut rng = rand::rngs::SmallRng::seed_from_u64(11);
        let mut bytes = vec![0u8; 8192];
        let (mut compact_bytes, mut serde_bytes) = (0, 0);
        for _ in 0..500 {
            rng.fill_bytes(&mut bytes);
            let mut u = Unstructured::new(&bytes);
            let edge = if u.arbitrary::<bool>().unwrap() { 0 } else { u.int_in_range(1..=5u8).unwrap() };
            let mut gen = Gen { u: &mut u, edge };
            let Ok(Document { text, .. }) = document_with(&mut gen) else { continue };
            let value: Value = serde_yaml::from_str(&text).unwrap();
            let compact = compact_yaml(&value);
            let back: Value =
                serde_yaml::from_str(&compact).unwrap_or_else(|e| panic!("{e}\n{compact}\nfrom\n{text}"));
            assert_eq!(back, value, "{compact}\nfrom\n{text}");
            compact_bytes += compact.len();
            serde_bytes += serde_yaml::to_string(&value).unwrap().len();
        }
        assert!(
            compact_bytes * 100 < serde_bytes * 95,
            "compact {compact_bytes} bytes, serde_yaml {serde_bytes}"
        );
        // The shapes the pools do not draw.
        let odd = map(vec![
            ("", s("yes")),
            ("a: b", s("say \"hi\" \\ \u{1}")),
            ("empty", Value::Mapping(Mapping::new())),
            ("list", Value::Sequence(vec![])),
            ("nested", Value::Sequence(vec![Value::Sequence(vec![map(vec![("k", Value::Null)])])])),
            (
                "numbers",
                Value::Sequence(vec![
                    Value::from(-7i64),
                    Value::from(u64::MAX),
                    Value::from(1e300),
                    Value::from(f64::NEG_INFINITY),
                    Value::from(2.0),
                ]),
            ),
            ("ünïcode", s("0x7f")),
        ]);
        let compact = compact_yaml(&odd);
        assert_eq!(serde_yaml::from_str::<Value>(&compact).unwrap(), odd, "{compact}");
    }

    #[test]
    fn numbers_are_rounded_to_their_digits() {
        assert_eq!(format!("{:?}", round_to_digits(0.48401200000000003e-3, 4)), "0.000484");
        assert_eq!(format!("{:?}", round_to_digits(29.390600000000003, 4)), "29.39");
        assert_eq!(format!("{:?}", round_to_digits(-12345.6, 3)), "-12300.0");
        assert_eq!(round_to_digits(0.0, 4), 0.0);
        assert!(round_to_digits(f64::NAN, 4).is_nan());
    }
}
