//! Semantic validation and resolution of a typed model file into a [`Model`], one file per
//! section of the model file, run in the file's order so that diagnostics come in it too.
//!
//! Checks what types cannot: positive masses, valid inertia tensors, references to defined
//! joints, bodies, drives and parameters, acyclic body dependencies, vector dimensions,
//! consistent limits and rates. Values become polynomials in the tunable parameters.

use std::collections::HashMap;

mod bodies;
mod closures;
mod compound;
mod drives;
mod joints;
mod parameters;
mod points;
mod settings;
mod task;
mod transmission;

use super::positions::Segment;
use super::quantity;
use super::schema::{ModelFile, Space, Value};
use super::types::{LoopClosure, Model};
use super::{Locator, ParameterValues};
use crate::diag::{Diagnostic, Diagnostics};
use crate::sym::poly::Poly;

fn key(k: &str) -> Segment {
    Segment::Key(k.to_string())
}

struct Resolver<'a, 'b> {
    locator: &'a Locator<'b>,
    errors: Vec<Diagnostic>,
    parameters: ParameterValues,
    nominal: HashMap<String, f64>,
    /// Some reference to a joint could not be resolved.
    unresolved_joint_reference: bool,
    /// Planar (vectors of 2) or spatial (vectors of 3).
    planar: bool,
    /// 2 or 3.
    dim: usize,
    /// File index of each joint by name.
    joint_index: HashMap<String, usize>,
    /// File indices of joints defined a second time.
    duplicate_joints: Vec<usize>,
    /// File index of each body by name.
    body_index: HashMap<String, usize>,
    /// Where the expanded file's joints and bodies were written (universal and spherical
    /// joints are expanded before everything else).
    sources: compound::Sources,
}

impl Resolver<'_, '_> {
    fn error(&mut self, path: &[Segment], message: impl Into<String>) {
        let d = self.locator.at(&self.sources.original(path), message);
        self.push(d);
    }

    fn error_hint(&mut self, path: &[Segment], message: impl Into<String>, hint: impl Into<String>) {
        let d = self.locator.at(&self.sources.original(path), message).with_hint(hint);
        self.push(d);
    }

    /// An error at the key that introduces `path` (a name written as a key), with a hint.
    fn key_error_hint(&mut self, path: &[Segment], message: impl Into<String>, hint: impl Into<String>) {
        let d = self.locator.at_key(&self.sources.original(path), message).with_hint(hint);
        self.push(d);
    }

    /// Records a diagnostic, once per place: the angles of one universal or spherical joint
    /// share its entry, and a rule broken by the entry is broken by each of them.
    fn push(&mut self, d: Diagnostic) {
        let repeated = self.errors.iter().any(|e| e.path == d.path && e.hint == d.hint && e.line == d.line);
        if !repeated {
            self.errors.push(d);
        }
    }

    /// A value as a polynomial, and its nominal number.
    fn value(&mut self, v: &Value, path: &[Segment]) -> (Poly, f64) {
        match v {
            Value::Number(x) => (Poly::constant(*x), *x),
            Value::Parameter(name) => match self.parameters.get(name) {
                Some(p) => (p.clone(), self.nominal[name]),
                None if !is_identifier(name) => self.expression(name, path),
                None => {
                    let mut known: Vec<&String> = self.nominal.keys().collect();
                    known.sort();
                    let hint = if known.is_empty() {
                        "the model has no `parameters`".to_string()
                    } else {
                        format!(
                            "defined parameters: {}",
                            known.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                        )
                    };
                    self.error_hint(path, format!("unknown parameter `{name}`"), hint);
                    (Poly::zero(), 0.0)
                }
            },
        }
    }

    /// An expression that uses tunable parameters (the loader evaluated all others to numbers
    /// and checked this one): its polynomial and nominal value.
    fn expression(&mut self, text: &str, path: &[Segment]) -> (Poly, f64) {
        let lookup = |name: &str| {
            let poly = self.parameters.get(name)?;
            Some(quantity::Operand {
                value: self.nominal[name],
                dim: quantity::UNKNOWN,
                poly: poly.as_constant().is_none().then(|| poly.clone()),
            })
        };
        match quantity::parse(text).and_then(|e| e.eval(&lookup)) {
            Ok(q) => {
                let poly = q.poly.unwrap_or_else(|| Poly::constant(q.value));
                (poly, q.value)
            }
            Err(e) => {
                let d = self.locator.at_offset(&self.sources.original(path), e.offset, e.message, e.hint);
                self.push(d);
                (Poly::zero(), 0.0)
            }
        }
    }

    fn positive(&mut self, x: f64, path: &[Segment]) {
        if x <= 0.0 {
            self.error(path, format!("must be positive, got {x}"));
        }
    }

    fn non_negative(&mut self, x: f64, path: &[Segment]) {
        if x < 0.0 {
            self.error(path, format!("must not be negative, got {x}"));
        }
    }

    /// A vector of `dim` values, padded to 3-D with zeros.
    fn vector(&mut self, values: &[Value], dim: usize, path: &[Segment]) -> ([Poly; 3], [f64; 3]) {
        let mut polys = [Poly::zero(), Poly::zero(), Poly::zero()];
        let mut nominal = [0.0; 3];
        if values.len() != dim {
            self.error(
                path,
                format!(
                    "expected {dim} entries ({}), got {}",
                    if dim == 2 { "x, y" } else { "x, y, z" },
                    values.len()
                ),
            );
            return (polys, nominal);
        }
        for (i, v) in values.iter().enumerate() {
            let mut p = path.to_vec();
            p.push(Segment::Index(i));
            let (poly, x) = self.value(v, &p);
            polys[i] = poly;
            nominal[i] = x;
        }
        (polys, nominal)
    }
}

fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_lowercase() || c == '_')
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !RESERVED.contains(&name)
}

/// Rust keywords and names the generated code uses itself.
const RESERVED: &[&str] = &[
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for", "if",
    "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return", "self", "static",
    "struct", "super", "trait", "true", "type", "unsafe", "use", "where", "while", "async", "await", "dyn",
    "abstract", "become", "box", "do", "final", "macro", "override", "priv", "typeof", "unsized", "virtual",
    "yield", "try", "base", "gen",
];

/// Whether a joint's `axis` (as written; absent = z) is the +z axis a DH joint needs.
fn dh_axis(axis: &Option<Vec<f64>>) -> bool {
    match axis.as_deref() {
        None => true,
        Some([x, y, z]) => *x == 0.0 && *y == 0.0 && *z > 0.0,
        Some(_) => false,
    }
}

/// The body named `name` (`None` for `base`); an unknown name is an error at `path`.
fn lookup_body(
    r: &mut Resolver<'_, '_>,
    name: &str,
    path: &[Segment],
    what: &str,
) -> Result<Option<usize>, ()> {
    if name == "base" {
        return Ok(None);
    }
    match r.body_index.get(name) {
        Some(i) => Ok(Some(*i)),
        None => {
            r.error_hint(
                path,
                format!("{what} references unknown body `{name}`"),
                "name a body of `bodies`, or `base` for the fixed ground",
            );
            Err(())
        }
    }
}

/// The joint named `name` (file index); an unknown name is an error at `path`.
fn lookup_joint(r: &mut Resolver<'_, '_>, name: &str, path: &[Segment], what: &str) -> Option<usize> {
    match r.joint_index.get(name) {
        Some(i) => Some(*i),
        None => {
            r.unresolved_joint_reference = true;
            let mut known: Vec<&String> = r.joint_index.keys().collect();
            known.sort();
            let hint = format!(
                "defined joints: {}",
                known.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
            );
            r.error_hint(path, format!("{what} references unknown joint `{name}`"), hint);
            None
        }
    }
}

/// Validates and resolves a typed model.
pub(crate) fn resolve(
    file: ModelFile,
    locator: &Locator<'_>,
    variant: Option<String>,
    variants: Vec<String>,
) -> Result<Model, Diagnostics> {
    let mut r = Resolver {
        locator,
        errors: Vec::new(),
        parameters: HashMap::new(),
        nominal: HashMap::new(),
        unresolved_joint_reference: false,
        planar: file.space == Space::Planar,
        dim: if file.space == Space::Planar { 2 } else { 3 },
        joint_index: HashMap::new(),
        duplicate_joints: Vec::new(),
        body_index: HashMap::new(),
        sources: compound::Sources::default(),
    };
    let (planar, dim) = (r.planar, r.dim);
    let (file, sources) = compound::expand(&mut r, file);
    r.sources = sources;

    if !is_identifier(&file.name) {
        r.error_hint(
            &[key("name")],
            format!("`{}` is not a valid rig name", file.name),
            "use snake_case letters, digits and underscores, starting with a letter",
        );
    }

    let tunable = parameters::parameters(&mut r, &file);
    let (gravity, _) = r.vector(&file.gravity, dim, &[key("gravity")]);
    drives::drives(&mut r, &file);
    let joints::Joints { actuated: joints, passive, measured, mimic, coordinate_of } =
        joints::joints(&mut r, &file);
    let (bodies, depends_on) = bodies::bodies(&mut r, &file);
    let (mut points, point_index) = points::points(&mut r, &file);
    let mut frames = points::frames(&mut r, &file, &point_index);
    let task = task::task(&mut r, &file, &points);
    let (declared, mut spatial_closures) = closures::closures(&mut r, &file, &points);
    let coupling = transmission::transmission(&mut r, &file, &joints);
    settings::settings(&mut r, &file, &variant);
    let order = bodies::dependency_order(&mut r, &file, &depends_on);
    if !measured.is_empty() {
        bodies::lumped_bodies(&mut r, &file, &bodies, &depends_on, &order, &points);
        if !declared.is_empty() || !spatial_closures.is_empty() {
            r.error_hint(
                &[key("closures")],
                "a model with measured joints has no closures",
                "measured joints (a gimbal) on a closed chain are not supported yet: see docs/model-format/limits.md",
            );
        }
    }
    settings::current_loop_filter(&mut r, &file);
    if !r.errors.is_empty() {
        return Err(Diagnostics(r.errors));
    }
    let (ordered, task) =
        bodies::into_dependency_order(bodies, &order, &mut points, &mut frames, &coordinate_of, task);
    // The spatial closures' axes name bodies by their file index: renumber them as the bodies.
    let mut new_body_index = vec![0; order.len()];
    for (new, &old) in order.iter().enumerate() {
        new_body_index[old] = new;
    }
    for closure in &mut spatial_closures {
        for (body, _) in closure.perpendicular.iter_mut().flatten() {
            *body = body.map(|b| new_body_index[b]);
        }
    }
    let closures = declared
        .iter()
        .map(|&(i, j1, j2, p1, p2, branch)| LoopClosure {
            name: file.closures[i].name.clone(),
            joints: [coordinate_of[j1], coordinate_of[j2]],
            points: [p1, p2],
            branch,
        })
        .collect();
    let model = Model {
        file: locator.file.to_string(),
        variant,
        variants,
        name: file.name,
        description: file.description,
        planar,
        gravity,
        tunable,
        joints,
        bodies: ordered,
        points,
        frames,
        task,
        sensors: file.sensors,
        rates: file.rates,
        current_loop: file.current_loop,
        rendering: file.rendering,
        passive,
        closures,
        spatial_closures,
        coupling,
        measured,
        mimic,
    };
    Ok(model)
}
