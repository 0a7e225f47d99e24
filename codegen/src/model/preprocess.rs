//! What the loader does to the YAML document before typing it: drives that reuse another
//! (`like:`) are filled in from it, and every quantity written with units or as an expression
//! is evaluated to a number in SI units, its dimension checked against the field's.
//!
//! The typed schema then sees plain numbers, as in a file written by hand. A field that keeps
//! tunable parameters symbolic (a [`Value`](super::schema::Value)) keeps an expression that
//! uses one as text: the resolver turns it into the polynomial (see
//! [`super::resolve`]); everything about it is checked here first.

use std::collections::{BTreeMap, HashMap};

use serde_yaml::Value as Yaml;

use super::positions::{KeyPath, Segment};
use super::quantity::{self, dim_name, Dim, ExprError, Operand, Quantity};
use super::Locator;
use crate::diag::{Diagnostic, Diagnostics};
use crate::sym::poly::{Atom, Poly};

fn key(k: &str) -> Segment {
    Segment::Key(k.to_string())
}

/// How a numeric field accepts a quantity.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// A fixed number (`f64` in the schema): constants and non-tunable parameters only.
    Fixed(&'static [Dim]),
    /// A whole number (`u32` in the schema).
    Whole(&'static [Dim]),
    /// A [`Value`](super::schema::Value): may keep tunable parameters as a polynomial.
    Symbolic(&'static [Dim]),
}

use quantity::*;

const ANY: &[Dim] = &[];
const ANGLE_OR_LENGTH: &[Dim] = &[ANGLE, LENGTH];

/// The slot of the field at a normalised path (names of drives, parameters and transmission
/// entries as `*`, list indices as `#`).
fn slot(pattern: &[&str]) -> Option<Slot> {
    use Slot::*;
    Some(match pattern {
        ["gravity", "#"] => Symbolic(&[ACCELERATION]),
        ["drives", "*", "motor", "rotor_inertia"] => Fixed(&[INERTIA]),
        ["drives", "*", "motor", "resistance"] => Fixed(&[RESISTANCE]),
        ["drives", "*", "motor", "inductance"] => Fixed(&[INDUCTANCE]),
        ["drives", "*", "motor", "torque_constant"] => Fixed(&[TORQUE_CONSTANT, TORQUE_CONSTANT_PER_RAD]),
        ["drives", "*", "gear_ratio" | "efficiency"] => Fixed(&[ONE]),
        ["drives", "*", "torque_limit" | "coulomb_friction" | "static_friction"] => Fixed(&[TORQUE, FORCE]),
        ["drives", "*", "current_limit"] => Fixed(&[CURRENT]),
        ["drives", "*", "supply_voltage"] => Fixed(&[VOLTAGE]),
        ["drives", "*", "backlash"] => Fixed(ANGLE_OR_LENGTH),
        ["drives", "*", "encoder", "counts_per_turn"] => Whole(&[ONE]),
        ["transmission", "*", "*"] => Fixed(ANY),
        ["joints", "#", "axis", "#"] | ["joints", "#", "axes", "#", "#"] => Fixed(&[ONE]),
        ["joints", "#", "limits", "lower" | "upper"] => Fixed(ANGLE_OR_LENGTH),
        ["joints", "#", "damping"] => Symbolic(&[ROTARY_DAMPING, ROTARY_DAMPING_PER_RAD, LINEAR_DAMPING]),
        ["joints", "#", "assembly"] => Fixed(ANGLE_OR_LENGTH),
        ["joints", "#", "assembly", "#"] => Fixed(&[ANGLE]),
        ["joints", "#", "mimic", "multiplier"] => Fixed(ANY),
        ["joints", "#", "mimic", "offset"] => Fixed(ANGLE_OR_LENGTH),
        ["joints", "#", "measured", "counts_per_turn"] => Whole(&[ONE]),
        ["closures", "#", "perpendicular", "#", "axis", "#"] => Fixed(&[ONE]),
        ["bodies", "#", "mass"] => Symbolic(&[MASS]),
        ["bodies", "#", "com", "#"] => Symbolic(&[LENGTH]),
        ["bodies", "#", "inertia"] => Symbolic(&[INERTIA]),
        ["bodies", "#", "inertia", "slender_rod"] => Symbolic(&[LENGTH]),
        ["bodies", "#", "inertia", "ixx" | "iyy" | "izz" | "ixy" | "ixz" | "iyz"] => Symbolic(&[INERTIA]),
        ["bodies", "#", "inertia", "rod" | "cylinder", "length"]
        | ["bodies", "#", "inertia", "cylinder" | "sphere", "radius"]
        | ["bodies", "#", "inertia", "box", "x" | "y" | "z"] => Fixed(&[LENGTH]),
        ["bodies", "#", "inertia", "rod" | "cylinder", "axis", "#"] => Fixed(&[ONE]),
        ["bodies", "#", "origin", "xyz", "#"] => Symbolic(&[LENGTH]),
        ["bodies", "#", "origin", "rpy", "#"] => Fixed(&[ANGLE]),
        ["bodies", "#", "dh", "a" | "d"] => Symbolic(&[LENGTH]),
        ["bodies", "#", "dh", "alpha" | "theta"] => Fixed(&[ANGLE]),
        ["bodies", "#", "pose", "origin", "point", "#"] => Symbolic(&[LENGTH]),
        ["bodies", "#", "pose", "plane", "rpy", "#"] => Fixed(&[ANGLE]),
        ["points", "#", "position", "#"] => Symbolic(&[LENGTH]),
        ["frames", "#", "rpy", "#"] => Fixed(&[ANGLE]),
        ["sensors", "#", "scale" | "offset" | "full_scale" | "noise" | "resolution"] => Fixed(ANY),
        ["rates", "current_loop_hz" | "impedance_loop_hz"] => Whole(&[FREQUENCY]),
        ["current_loop", "bandwidth_hz" | "anti_alias_cutoff_hz"] => Fixed(&[FREQUENCY]),
        ["current_loop", "damping_ratio"] => Fixed(&[ONE]),
        ["current_loop", "anti_alias_filter_order"] => Whole(&[ONE]),
        ["rendering", "grid_spacing"] => Fixed(&[LENGTH]),
        ["rendering", "wall_stiffness"] => Fixed(&[STIFFNESS]),
        ["rendering", "wall_damping"] => Fixed(&[LINEAR_DAMPING]),
        _ => return None,
    })
}

/// Fills in drives written as `like: OTHER` plus overrides, then evaluates every quantity.
pub(super) fn preprocess(document: &mut Yaml, locator: &mut Locator<'_>) -> Result<(), Diagnostics> {
    expand_drives(document, locator).map_err(Diagnostics::from)?;
    let parameters = evaluate_parameters(document, locator)?;
    let mut errors = Vec::new();
    let mut path = KeyPath::new();
    let mut pattern = Vec::new();
    if let Yaml::Mapping(map) = document {
        for (k, v) in map.iter_mut() {
            let Some(k) = k.as_str() else { continue };
            if k == "parameters" || k == "variants" {
                continue;
            }
            path.push(key(k));
            pattern.push(k.to_string());
            walk(v, &mut path, &mut pattern, &parameters, locator, &mut errors);
            path.pop();
            pattern.pop();
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(Diagnostics(errors))
    }
}

/// A parameter's evaluated value.
#[derive(Clone, Debug)]
struct ParameterValue {
    value: f64,
    dim: Dim,
    tunable: bool,
}

type ParameterTable = HashMap<String, ParameterValue>;

fn operand(table: &ParameterTable) -> impl Fn(&str) -> Option<Operand> + '_ {
    |name| {
        table.get(name).map(|p| Operand {
            value: p.value,
            dim: p.dim,
            // The atom stands for any tunable parameter: what matters here is only that the
            // value depends on one; the resolver builds the real polynomial.
            poly: p.tunable.then(|| Poly::atom(Atom::Param(0))),
        })
    }
}

/// Evaluates the parameters' values in the order they depend on each other; a cycle is an
/// error at the value that closes it.
fn evaluate_parameters(document: &mut Yaml, locator: &Locator<'_>) -> Result<ParameterTable, Diagnostics> {
    let mut table = ParameterTable::new();
    let Some(Yaml::Mapping(parameters)) = document.get_mut("parameters") else { return Ok(table) };
    // Name → (text or number, tunable), in file order.
    let mut entries: BTreeMap<String, (Yaml, bool)> = BTreeMap::new();
    for (k, v) in parameters.iter() {
        let (Some(name), Some(value)) = (k.as_str(), v.get("value")) else { continue };
        let tunable = v.get("tunable").and_then(Yaml::as_bool).unwrap_or(false);
        entries.insert(name.to_string(), (value.clone(), tunable));
    }
    let mut errors = Vec::new();
    let mut state: HashMap<String, bool> = HashMap::new(); // false: in progress, true: done
    let names: Vec<String> = entries.keys().cloned().collect();
    for name in &names {
        let mut stack = Vec::new();
        visit(name, &entries, &mut table, &mut state, &mut stack, locator, &mut errors);
    }
    if !errors.is_empty() {
        return Err(Diagnostics(errors));
    }
    for (k, v) in parameters.iter_mut() {
        let Some(name) = k.as_str() else { continue };
        if let (Some(p), Yaml::Mapping(entry)) = (table.get(name), v) {
            if entry.get("value").is_some_and(|x| x.is_string()) {
                entry.insert(Yaml::String("value".into()), Yaml::from(p.value));
            }
        }
    }
    Ok(table)
}

#[allow(clippy::too_many_arguments)]
fn visit(
    name: &str,
    entries: &BTreeMap<String, (Yaml, bool)>,
    table: &mut ParameterTable,
    state: &mut HashMap<String, bool>,
    stack: &mut Vec<String>,
    locator: &Locator<'_>,
    errors: &mut Vec<Diagnostic>,
) -> bool {
    match state.get(name) {
        Some(true) => return table.contains_key(name),
        Some(false) => return false,
        None => {}
    }
    let Some((value, tunable)) = entries.get(name) else { return false };
    let path = [key("parameters"), key(name), key("value")];
    let Some(text) = value.as_str() else {
        state.insert(name.to_string(), true);
        if let Some(x) = value.as_f64() {
            table.insert(name.to_string(), ParameterValue { value: x, dim: UNKNOWN, tunable: *tunable });
        }
        return table.contains_key(name);
    };
    state.insert(name.to_string(), false);
    stack.push(name.to_string());
    let result = quantity::parse(text).and_then(|expr| {
        // Evaluate the parameters it names first; a name on the stack closes a cycle.
        for (used, at) in expr.names() {
            if !entries.contains_key(&used) {
                continue;
            }
            if state.get(&used) == Some(&false) {
                let i = stack.iter().position(|s| *s == used).unwrap_or(0);
                let mut cycle: Vec<&str> = stack[i..].iter().map(String::as_str).collect();
                cycle.push(&used);
                return Err(ExprError {
                    offset: at,
                    message: format!("the parameters depend on each other in a cycle: {}", cycle.join(" → ")),
                    hint: Some("a parameter's value may use other parameters, not itself".into()),
                });
            }
            if !visit(&used, entries, table, state, stack, locator, errors) {
                return Err(ExprError { offset: at, message: format!("`{used}` has no value"), hint: None });
            }
        }
        let q = expr.eval(&operand(table))?;
        if let Some((at, used)) = &q.tunable_at {
            return Err(ExprError {
                offset: *at,
                message: format!("a parameter's value cannot use the tunable parameter `{used}`"),
                hint: Some("only a field of the model keeps a tunable parameter symbolic".into()),
            });
        }
        Ok(q)
    });
    stack.pop();
    state.insert(name.to_string(), true);
    match result {
        Ok(q) => {
            // Without a unit anywhere, a value is a plain number of unknown dimension.
            let dim = if q.dim == ONE && q.unit_at.is_none() { UNKNOWN } else { q.dim };
            table.insert(name.to_string(), ParameterValue { value: q.value, dim, tunable: *tunable });
            true
        }
        Err(e) => {
            // A dependency's own error is reported once, where it is.
            if !e.message.ends_with("has no value") {
                errors.push(locator.at_offset(&path, e.offset, e.message, e.hint));
            }
            false
        }
    }
}

fn walk(
    value: &mut Yaml,
    path: &mut KeyPath,
    pattern: &mut Vec<String>,
    parameters: &ParameterTable,
    locator: &Locator<'_>,
    errors: &mut Vec<Diagnostic>,
) {
    match value {
        Yaml::Mapping(map) => {
            // The names of drives and transmission entries are not part of the pattern.
            let named = matches!(pattern.as_slice(), [a] if a == "drives" || a == "transmission")
                || matches!(pattern.as_slice(), [a, _] if a == "transmission");
            for (k, v) in map.iter_mut() {
                let Some(k) = k.as_str() else { continue };
                path.push(key(k));
                pattern.push(if named { "*".into() } else { k.to_string() });
                walk(v, path, pattern, parameters, locator, errors);
                path.pop();
                pattern.pop();
            }
        }
        Yaml::Sequence(items) => {
            for (i, item) in items.iter_mut().enumerate() {
                path.push(Segment::Index(i));
                pattern.push("#".into());
                walk(item, path, pattern, parameters, locator, errors);
                path.pop();
                pattern.pop();
            }
        }
        Yaml::String(text) => {
            let normalised: Vec<&str> = pattern.iter().map(String::as_str).collect();
            let Some(slot) = slot(&normalised) else { return };
            match evaluate(text, slot, parameters) {
                Ok(Some(number)) => *value = number,
                Ok(None) => {}
                Err(mut e) => {
                    if e.hint.is_none() && e.message.starts_with("unknown parameter") {
                        let mut known: Vec<&str> = parameters.keys().map(String::as_str).collect();
                        known.sort_unstable();
                        e.hint = Some(if known.is_empty() {
                            "the model has no `parameters`".to_string()
                        } else {
                            format!("defined parameters: {}", known.join(", "))
                        });
                    }
                    errors.push(locator.at_offset(path, e.offset, e.message, e.hint))
                }
            }
        }
        _ => {}
    }
}

/// The number a quantity's text stands for; `None` to keep the text (a bare parameter name
/// or an expression of tunable parameters in a symbolic field, which the resolver turns into
/// a polynomial).
fn evaluate(text: &str, slot: Slot, parameters: &ParameterTable) -> Result<Option<Yaml>, ExprError> {
    let expr = quantity::parse(text)?;
    let (dims, symbolic) = match slot {
        Slot::Fixed(d) | Slot::Whole(d) => (d, false),
        Slot::Symbolic(d) => (d, true),
    };
    // A bare name in a symbolic field keeps the resolver's path (and its message for an
    // unknown parameter, which lists the defined ones).
    if symbolic && expr.bare_name().is_some_and(|n| !parameters.contains_key(n) && n != "pi") {
        return Ok(None);
    }
    let q = expr.eval(&operand(parameters))?;
    if let Some((at, name)) = &q.tunable_at {
        if symbolic {
            check_dimension(&q, dims)?;
            return Ok(None);
        }
        return Err(ExprError {
            offset: *at,
            message: format!("the tunable parameter `{name}` cannot be used here: this field is a fixed number"),
            hint: Some("tunable parameters may be used in masses, centres of mass, inertias, positions, gravity and damping".into()),
        });
    }
    check_dimension(&q, dims)?;
    if symbolic && expr.bare_name().is_some() {
        return Ok(None);
    }
    if let Slot::Whole(_) = slot {
        if q.value.fract() != 0.0 || !(0.0..=f64::from(u32::MAX)).contains(&q.value) {
            return Err(ExprError {
                offset: 0,
                message: format!("expected a whole number from 0 to 4294967295, got {}", q.value),
                hint: None,
            });
        }
        return Ok(Some(Yaml::from(q.value as u64)));
    }
    Ok(Some(Yaml::from(q.value)))
}

fn check_dimension(q: &Quantity, dims: &[Dim]) -> Result<(), ExprError> {
    // A dimensionless result is a plain number in the field's SI unit.
    if dims.is_empty() || q.dim == ONE || q.dim == UNKNOWN || dims.contains(&q.dim) {
        return Ok(());
    }
    let expected: Vec<String> = dims.iter().map(|d| dim_name(*d)).collect();
    Err(ExprError {
        offset: q.unit_at.unwrap_or(0),
        message: format!("expected {}, got {}", expected.join(" or "), dim_name(q.dim)),
        hint: Some("a number without a unit is read in SI units".into()),
    })
}

/// Fills in each drive written as `like: OTHER`: a copy of the other drive (itself filled in
/// first) with this entry's keys replacing its own, mappings (`motor`, `encoder`) merged key
/// by key. Diagnostics about an inherited value point at the drive it was written in.
fn expand_drives(document: &mut Yaml, locator: &mut Locator<'_>) -> Result<(), Diagnostic> {
    let Some(Yaml::Mapping(drives)) = document.get_mut("drives") else { return Ok(()) };
    let names: Vec<String> = drives.keys().filter_map(|k| k.as_str().map(String::from)).collect();
    let mut done: HashMap<String, bool> = HashMap::new();
    for name in &names {
        expand_drive(name, drives, &names, &mut done, &mut Vec::new(), locator)?;
    }
    Ok(())
}

fn expand_drive(
    name: &str,
    drives: &mut serde_yaml::Mapping,
    names: &[String],
    done: &mut HashMap<String, bool>,
    stack: &mut Vec<String>,
    locator: &mut Locator<'_>,
) -> Result<(), Diagnostic> {
    if done.get(name) == Some(&true) {
        return Ok(());
    }
    let like_path = [key("drives"), key(name), key("like")];
    let Some(like) = drives.get(name).and_then(|d| d.get("like")).cloned() else {
        done.insert(name.to_string(), true);
        return Ok(());
    };
    let Some(base) = like.as_str().map(String::from) else {
        return Err(locator.at(&like_path, "`like` names another drive"));
    };
    if stack.contains(&base) || base == name {
        let mut cycle = stack.clone();
        cycle.push(name.to_string());
        cycle.push(base.clone());
        let start = cycle.iter().position(|s| *s == base).unwrap_or(0);
        return Err(locator
            .at(
                &like_path,
                format!("the drives are `like` each other in a cycle: {}", cycle[start..].join(" → ")),
            )
            .with_hint("one of them must give its motor, gear ratio and limits itself"));
    }
    if !names.contains(&base) {
        return Err(locator
            .at(&like_path, format!("unknown drive `{base}`"))
            .with_hint(format!("defined drives: {}", names.join(", "))));
    }
    stack.push(name.to_string());
    expand_drive(&base, drives, names, done, stack, locator)?;
    stack.pop();
    let Some(base_entry) = drives.get(base.as_str()).cloned() else { return Ok(()) };
    let own_path = vec![key("drives"), key(name)];
    let base_path = vec![key("drives"), key(&base)];
    if let Some(entry) = drives.get_mut(name) {
        if let Yaml::Mapping(m) = entry {
            m.remove("like");
        }
        inherit(entry, &base_entry, &own_path, &base_path, locator);
    }
    done.insert(name.to_string(), true);
    Ok(())
}

/// Adds to `own` what `base` has and it lacks; mappings inside are merged key by key.
fn inherit(own: &mut Yaml, base: &Yaml, own_path: &KeyPath, base_path: &KeyPath, locator: &mut Locator<'_>) {
    let (Yaml::Mapping(own_map), Yaml::Mapping(base_map)) = (own, base) else { return };
    for (k, base_value) in base_map {
        let Some(name) = k.as_str() else { continue };
        let mut own_child = own_path.clone();
        own_child.push(key(name));
        let mut base_child = base_path.clone();
        base_child.push(key(name));
        match own_map.get_mut(k) {
            Some(own_value) => {
                if own_value.is_mapping() && base_value.is_mapping() {
                    inherit(own_value, base_value, &own_child, &base_child, locator);
                }
            }
            None => {
                own_map.insert(k.clone(), base_value.clone());
                let source = locator.source_path(&base_child);
                locator.overrides.push((own_child, source));
            }
        }
    }
}
