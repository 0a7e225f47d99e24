//! Semantic validation and resolution of a typed model file into a [`Model`].
//!
//! Checks what types cannot: positive masses, valid inertia tensors, references to defined
//! joints, bodies, drives and parameters, acyclic body dependencies, vector dimensions,
//! consistent limits and rates. Values become polynomials in the tunable parameters.

use std::collections::{HashMap, HashSet};

use super::positions::Segment;
use super::schema::{
    CurrentLoopSpec, DhConvention, Drive, Inertia, JointKind, ModelFile, Rates, Rendering, Sensor, Space,
    Value,
};
use super::{Locator, ParameterValues};
use crate::diag::{Diagnostic, Diagnostics};
use crate::sym::poly::{Atom, Poly};

/// A model parameter after resolution.
#[derive(Clone, Debug)]
pub struct ResolvedParameter {
    /// Name (a Rust identifier).
    pub name: String,
    /// Nominal value.
    pub value: f64,
    /// Documentation.
    pub description: Option<String>,
    /// Unit, for documentation.
    pub unit: Option<String>,
}

/// A joint after resolution.
#[derive(Clone, Debug)]
pub struct ResolvedJoint {
    /// Name of the coordinate.
    pub name: String,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Documentation.
    pub description: Option<String>,
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
    /// Lower limit.
    pub lower: f64,
    /// Upper limit.
    pub upper: f64,
    /// Viscous damping coefficient.
    pub damping: Poly,
    /// Name of its drive.
    pub drive_name: String,
    /// Its drive train.
    pub drive: Drive,
}

/// A fixed rigid transform: translation, then rotation (`Trans(xyz) · rotation`).
#[derive(Clone, Debug)]
pub struct FixedTransform {
    /// Translation.
    pub xyz: [Poly; 3],
    /// Rotation.
    pub rotation: [[f64; 3]; 3],
}

/// How a body's frame moves.
#[derive(Clone, Debug)]
pub enum Motion {
    /// Parent frame (None = base), then a fixed transform, then the joint (None = welded),
    /// then an optional fixed `tail` (standard Denavit–Hartenberg links).
    Serial {
        /// Parent body index, `None` for the base.
        parent: Option<usize>,
        /// Fixed translation in the parent frame.
        xyz: [Poly; 3],
        /// Fixed rotation from the parent frame (roll–pitch–yaw).
        rotation: [[f64; 3]; 3],
        /// The joint, if any.
        joint: Option<usize>,
        /// A fixed transform after the joint (standard DH: `Tx(a) · Rx(alpha)`), if any.
        tail: Option<Box<FixedTransform>>,
    },
    /// Origin at a point of another body; orientation: rotation about z by a coordinate.
    Direct {
        /// Body carrying the origin point, `None` for the base.
        origin_body: Option<usize>,
        /// The origin point in that body's frame.
        point: [Poly; 3],
        /// The coordinate giving the absolute angle.
        angle_joint: usize,
    },
}

/// A rigid body after resolution.
#[derive(Clone, Debug)]
pub struct ResolvedBody {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Mass, kg.
    pub mass: Poly,
    /// Centre of mass in the body frame.
    pub com: [Poly; 3],
    /// Inertia tensor about the centre of mass, body axes.
    pub inertia: [[Poly; 3]; 3],
    /// How the frame moves.
    pub motion: Motion,
}

/// A named point after resolution.
#[derive(Clone, Debug)]
pub struct ResolvedPoint {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Body index, `None` for the base.
    pub body: Option<usize>,
    /// Position in the body frame.
    pub position: [Poly; 3],
}

/// A named frame after resolution: its orientation is an output of the generated code.
#[derive(Clone, Debug)]
pub struct ResolvedFrame {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Body index, `None` for the base.
    pub body: Option<usize>,
    /// Fixed rotation from the body frame (roll–pitch–yaw, right angles exact).
    pub rotation: [[f64; 3]; 3],
}

/// The task coordinates.
#[derive(Clone, Debug)]
pub enum TaskSpec {
    /// The Cartesian position of a named point.
    Point(usize),
    /// Joint coordinates.
    Joints(Vec<usize>),
}

/// A validated model with one variant applied.
#[derive(Clone, Debug)]
pub struct Model {
    /// The file, as named in diagnostics and generated headers.
    pub file: String,
    /// The variant applied, if any.
    pub variant: Option<String>,
    /// All variants the file defines.
    pub variants: Vec<String>,
    /// The rig's name.
    pub name: String,
    /// Its description.
    pub description: Option<String>,
    /// Planar (true) or spatial.
    pub planar: bool,
    /// Gravity vector (3-D; z = 0 for planar models).
    pub gravity: [Poly; 3],
    /// Tunable parameters, in the order of their `Atom::Param` indices.
    pub tunable: Vec<ResolvedParameter>,
    /// Joints in the order of `q`.
    pub joints: Vec<ResolvedJoint>,
    /// Bodies, each after the bodies it depends on.
    pub bodies: Vec<ResolvedBody>,
    /// Named points.
    pub points: Vec<ResolvedPoint>,
    /// Named frames whose orientation is emitted (spatial models).
    pub frames: Vec<ResolvedFrame>,
    /// Task coordinates.
    pub task: TaskSpec,
    /// Force sensors and others.
    pub sensors: Vec<Sensor>,
    /// Loop rates.
    pub rates: Rates,
    /// Current-loop design targets.
    pub current_loop: CurrentLoopSpec,
    /// Rendering settings.
    pub rendering: Option<Rendering>,
    /// The current-loop design of each joint's drive, in the order of `q`.
    pub current_loop_designs: Vec<crate::check::current_loop::CurrentLoopDesign>,
    /// Passive joints of closed chains: coordinates `joints.len() + k` of the mechanics'
    /// open tree, eliminated by `closures`, not coordinates of the generated code.
    pub passive: Vec<PassiveJoint>,
    /// The loop closures and their elimination, if the model is a closed chain.
    pub closures: Option<crate::dynamics::closure::Closures>,
}

/// A passive (unactuated) revolute joint of a closed chain.
#[derive(Clone, Debug)]
pub struct PassiveJoint {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Unit axis in the joint frame (`[0, 0, ±1]`).
    pub axis: [f64; 3],
}

impl Model {
    /// Spatial dimension of vectors in the model file (2 or 3).
    pub fn dim(&self) -> usize {
        if self.planar {
            2
        } else {
            3
        }
    }

    /// Number of task coordinates.
    pub fn task_dim(&self) -> usize {
        match &self.task {
            TaskSpec::Point(_) => self.dim(),
            TaskSpec::Joints(j) => j.len(),
        }
    }

    /// Number of coordinates of the open tree: actuated plus passive joints.
    pub fn tree_coordinates(&self) -> usize {
        self.joints.len() + self.passive.len()
    }

    /// Kind and axis of coordinate `j` of the open tree (actuated, then passive joints).
    pub fn coordinate_axis(&self, j: usize) -> (JointKind, [f64; 3]) {
        match self.joints.get(j) {
            Some(joint) => (joint.kind, joint.axis),
            None => {
                let axis = self.passive.get(j - self.joints.len()).map(|p| p.axis).unwrap_or([0.0, 0.0, 1.0]);
                (JointKind::Revolute, axis)
            }
        }
    }

    /// Name of coordinate `j` of the open tree.
    pub fn coordinate_name(&self, j: usize) -> &str {
        match self.joints.get(j) {
            Some(joint) => &joint.name,
            None => self.passive.get(j - self.joints.len()).map(|p| p.name.as_str()).unwrap_or("passive"),
        }
    }

    /// Nominal values of the tunable parameters.
    pub fn nominal_parameters(&self) -> Vec<f64> {
        self.tunable.iter().map(|p| p.value).collect()
    }
}

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
}

impl Resolver<'_, '_> {
    fn error(&mut self, path: &[Segment], message: impl Into<String>) {
        let d = self.locator.at(path, message);
        self.errors.push(d);
    }

    fn error_hint(&mut self, path: &[Segment], message: impl Into<String>, hint: impl Into<String>) {
        let d = self.locator.at(path, message).with_hint(hint);
        self.errors.push(d);
    }

    /// A value as a polynomial, and its nominal number.
    fn value(&mut self, v: &Value, path: &[Segment]) -> (Poly, f64) {
        match v {
            Value::Number(x) => (Poly::constant(*x), *x),
            Value::Parameter(name) => match self.parameters.get(name) {
                Some(p) => (p.clone(), self.nominal[name]),
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

/// Right angles are exact: cos(π/2) evaluates to 6e-17, which would otherwise leave spurious
/// terms in every expression downstream.
pub(crate) fn snap_entry(x: f64) -> f64 {
    if x.abs() < 1e-14 {
        0.0
    } else if (x.abs() - 1.0).abs() < 1e-14 {
        x.signum()
    } else {
        x
    }
}

fn snap(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    m.map(|row| row.map(snap_entry))
}

/// `(sin x, cos x)` with right angles exact.
fn exact_sin_cos(x: f64) -> (f64, f64) {
    let (s, c) = x.sin_cos();
    (snap_entry(s), snap_entry(c))
}

/// Rotation about x, right angles exact.
fn rotation_x(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = exact_sin_cos(angle);
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

/// Rotation about z, right angles exact.
fn rotation_z(angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = exact_sin_cos(angle);
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

pub(crate) fn mat3_mul(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// Whether a joint's `axis` (as written; absent = z) is the +z axis a DH joint needs.
fn dh_axis(axis: &Option<Vec<f64>>) -> bool {
    match axis.as_deref() {
        None => true,
        Some([x, y, z]) => *x == 0.0 && *y == 0.0 && *z > 0.0,
        Some(_) => false,
    }
}

fn rotation_rpy(rpy: [f64; 3]) -> [[f64; 3]; 3] {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    // R = Rz(yaw) · Ry(pitch) · Rx(roll), the URDF convention.
    let r = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ];
    snap(r)
}

/// Eigenvalues of a symmetric 3×3 matrix (analytic, ascending).
fn symmetric_eigenvalues(m: [[f64; 3]; 3]) -> [f64; 3] {
    let p1 = m[0][1].powi(2) + m[0][2].powi(2) + m[1][2].powi(2);
    if p1 == 0.0 {
        let mut e = [m[0][0], m[1][1], m[2][2]];
        e.sort_by(|a, b| a.total_cmp(b));
        return e;
    }
    let q = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    let p2 = (m[0][0] - q).powi(2) + (m[1][1] - q).powi(2) + (m[2][2] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let mut b = m;
    for (i, row) in b.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (m[i][j] - if i == j { q } else { 0.0 }) / p;
        }
    }
    let det_b = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let r = (det_b / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e1 = q + 2.0 * p * phi.cos();
    let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    let e2 = 3.0 * q - e1 - e3;
    let mut e = [e1, e2, e3];
    e.sort_by(|a, b| a.total_cmp(b));
    e
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
    };
    let planar = file.space == Space::Planar;
    let dim = if planar { 2 } else { 3 };

    if !is_identifier(&file.name) {
        r.error_hint(
            &[key("name")],
            format!("`{}` is not a valid rig name", file.name),
            "use snake_case letters, digits and underscores, starting with a letter",
        );
    }

    // Parameters.
    let mut tunable = Vec::new();
    for (name, p) in &file.parameters {
        let path = [key("parameters"), key(name)];
        if !is_identifier(name) {
            r.error_hint(
                &path,
                format!("`{name}` is not a valid parameter name"),
                "use snake_case letters, digits and underscores, starting with a letter",
            );
        }
        r.nominal.insert(name.clone(), p.value);
        let poly = if p.tunable {
            tunable.push(ResolvedParameter {
                name: name.clone(),
                value: p.value,
                description: p.description.clone(),
                unit: p.unit.clone(),
            });
            Poly::atom(Atom::Param((tunable.len() - 1) as u16))
        } else {
            Poly::constant(p.value)
        };
        r.parameters.insert(name.clone(), poly);
    }

    let (gravity, _) = r.vector(&file.gravity, dim, &[key("gravity")]);

    // Drives.
    for (name, d) in &file.drives {
        let base = vec![key("drives"), key(name)];
        let at = |k: &[&str]| {
            let mut p = base.clone();
            p.extend(k.iter().map(|s| key(s)));
            p
        };
        r.positive(d.gear_ratio, &at(&["gear_ratio"]));
        if !(d.efficiency > 0.0 && d.efficiency <= 1.0) {
            r.error(&at(&["efficiency"]), format!("must be in (0, 1], got {}", d.efficiency));
        }
        r.positive(d.torque_limit, &at(&["torque_limit"]));
        r.positive(d.current_limit, &at(&["current_limit"]));
        r.positive(d.supply_voltage, &at(&["supply_voltage"]));
        r.non_negative(d.motor.rotor_inertia, &at(&["motor", "rotor_inertia"]));
        r.positive(d.motor.resistance, &at(&["motor", "resistance"]));
        r.positive(d.motor.inductance, &at(&["motor", "inductance"]));
        r.positive(d.motor.torque_constant, &at(&["motor", "torque_constant"]));
        if d.encoder.counts_per_turn == 0 {
            r.error(&at(&["encoder", "counts_per_turn"]), "must be positive, got 0");
        }
        r.non_negative(d.backlash, &at(&["backlash"]));
        r.non_negative(d.coulomb_friction, &at(&["coulomb_friction"]));
        r.non_negative(d.static_friction, &at(&["static_friction"]));
    }

    // Joints.
    let mut joint_index: HashMap<String, usize> = HashMap::new();
    let mut duplicate_joints = Vec::new();
    let mut joints = Vec::new();
    let mut passive = Vec::new();
    if file.joints.is_empty() {
        r.error(&[key("joints")], "a model needs at least one joint");
    }
    for (i, j) in file.joints.iter().enumerate() {
        let base = vec![key("joints"), Segment::Index(i)];
        let at = |k: &str| {
            let mut p = base.clone();
            p.push(key(k));
            p
        };
        if !is_identifier(&j.name) {
            r.error_hint(
                &at("name"),
                format!("`{}` is not a valid joint name", j.name),
                "use snake_case letters, digits and underscores, starting with a letter ",
            );
        }
        if let Some(first) = joint_index.get(&j.name) {
            duplicate_joints.push(i);
            r.error_hint(
                &at("name"),
                format!("joint `{}` is defined twice", j.name),
                format!("the first definition is `joints[{first}]`"),
            );
        } else {
            joint_index.insert(j.name.clone(), i);
        }
        let (lower, upper) = match &j.limits {
            Some(l) => {
                if l.lower >= l.upper || l.lower.is_nan() || l.upper.is_nan() {
                    r.error(
                        &at("limits"),
                        format!("lower limit {} must be below upper limit {}", l.lower, l.upper),
                    );
                }
                (l.lower, l.upper)
            }
            None if j.passive => (-std::f64::consts::PI, std::f64::consts::PI),
            None => {
                r.error(&base, "missing key `limits`");
                (0.0, 0.0)
            }
        };
        if j.passive {
            if j.drive.is_some() {
                r.error_hint(
                    &at("drive"),
                    format!("joint `{}` is passive: it has no drive", j.name),
                    "remove `drive`, or `passive: true` if a motor turns the joint",
                );
            }
            if j.damping.is_some() {
                r.error_hint(
                    &at("damping"),
                    format!("joint `{}` is passive: damping of passive joints is not supported", j.name),
                    "model the friction at the actuated joints",
                );
            }
            if j.kind != JointKind::Revolute {
                r.error_hint(
                    &at("type"),
                    format!("passive joint `{}` must be revolute", j.name),
                    "closures eliminate the revolute distal joints of a planar dyad",
                );
            }
        }
        let damping = match &j.damping {
            Some(v) => {
                let (poly, x) = r.value(v, &at("damping"));
                r.non_negative(x, &at("damping"));
                poly
            }
            None => Poly::zero(),
        };
        let drive = match (&j.drive, j.passive) {
            (_, true) => None,
            (None, false) => {
                r.error_hint(
                    &base,
                    "missing key `drive`",
                    "an actuated joint names its entry of `drives`; a joint without a motor in a closed chain is `passive: true`",
                );
                continue;
            }
            (Some(name), false) => match file.drives.get(name) {
                Some(d) => Some(d.clone()),
                None => {
                    let mut known: Vec<&String> = file.drives.keys().collect();
                    known.sort();
                    r.error_hint(
                        &at("drive"),
                        format!("joint `{}` references unknown drive `{}`", j.name, name),
                        format!(
                            "defined drives: {}",
                            known.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                        ),
                    );
                    continue;
                }
            },
        };
        let axis = match (&j.axis, planar, j.kind) {
            (None, true, JointKind::Revolute) => [0.0, 0.0, 1.0],
            (None, true, JointKind::Prismatic) => [1.0, 0.0, 0.0],
            (None, false, _) => [0.0, 0.0, 1.0],
            (Some(a), _, _) => {
                let full: Option<[f64; 3]> = match (a.len(), planar, j.kind) {
                    (3, _, _) => Some([a[0], a[1], a[2]]),
                    (2, true, JointKind::Prismatic) => Some([a[0], a[1], 0.0]),
                    _ => None,
                };
                match full {
                    None => {
                        r.error(&at("axis"), format!("expected 3 entries, got {}", a.len()));
                        [0.0, 0.0, 1.0]
                    }
                    Some(v) => {
                        let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                        if norm < 1e-9 {
                            r.error(&at("axis"), "must not be the zero vector");
                            [0.0, 0.0, 1.0]
                        } else {
                            let u = [v[0] / norm, v[1] / norm, v[2] / norm];
                            if planar && j.kind == JointKind::Revolute && (u[0] != 0.0 || u[1] != 0.0) {
                                r.error_hint(
                                    &at("axis"),
                                    "a planar revolute joint turns about z",
                                    "use [0, 0, 1] or [0, 0, -1]",
                                );
                            }
                            if planar && j.kind == JointKind::Prismatic && u[2] != 0.0 {
                                r.error(&at("axis"), "a planar prismatic joint slides in the x–y plane");
                            }
                            u
                        }
                    }
                }
            }
        };
        let Some(drive) = drive else {
            passive.push(PassiveJoint { name: j.name.clone(), description: j.description.clone(), axis });
            continue;
        };
        joints.push(ResolvedJoint {
            name: j.name.clone(),
            kind: j.kind,
            description: j.description.clone(),
            axis,
            lower,
            upper,
            damping,
            drive_name: j.drive.clone().unwrap_or_default(),
            drive,
        });
    }
    // Coordinates: the actuated joints in file order, then the passive ones.
    let actuated_count = file.joints.iter().filter(|j| !j.passive).count();
    let coordinate_of: Vec<usize> = {
        let (mut a, mut p) = (0, actuated_count);
        file.joints
            .iter()
            .map(|j| {
                let slot = if j.passive { &mut p } else { &mut a };
                *slot += 1;
                *slot - 1
            })
            .collect()
    };

    // Bodies: names first, so that references can point forwards.
    let mut body_index: HashMap<String, usize> = HashMap::new();
    for (i, b) in file.bodies.iter().enumerate() {
        let path = [key("bodies"), Segment::Index(i), key("name")];
        if b.name == "base" {
            r.error_hint(&path, "`base` is reserved for the fixed ground", "rename the body");
        } else if !is_identifier(&b.name) {
            r.error(&path, format!("`{}` is not a valid body name", b.name));
        }
        if body_index.insert(b.name.clone(), i).is_some() {
            r.error(&path, format!("body `{}` is defined twice", b.name));
        }
    }
    if file.bodies.is_empty() {
        r.error(&[key("bodies")], "a model needs at least one body");
    }
    let lookup_body =
        |r: &mut Resolver<'_, '_>, name: &str, path: &[Segment], what: &str| -> Result<Option<usize>, ()> {
            if name == "base" {
                return Ok(None);
            }
            match body_index.get(name) {
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
        };
    let lookup_joint =
        |r: &mut Resolver<'_, '_>, name: &str, path: &[Segment], what: &str| -> Option<usize> {
            match joint_index.get(name) {
                Some(i) => Some(*i),
                None => {
                    r.unresolved_joint_reference = true;
                    let mut known: Vec<&String> = joint_index.keys().collect();
                    known.sort();
                    r.error_hint(
                        path,
                        format!("{what} references unknown joint `{name}`"),
                        format!(
                            "defined joints: {}",
                            known.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                        ),
                    );
                    None
                }
            }
        };

    let mut bodies: Vec<Option<ResolvedBody>> = Vec::new();
    let mut depends_on: Vec<Option<usize>> = Vec::new();
    let mut serial_joint_users: HashMap<usize, usize> = HashMap::new();
    let mut joint_used = vec![false; file.joints.len()];
    for (i, b) in file.bodies.iter().enumerate() {
        let base = vec![key("bodies"), Segment::Index(i)];
        let at = |k: &[&str]| {
            let mut p = base.clone();
            p.extend(k.iter().map(|s| key(s)));
            p
        };
        let what = format!("body `{}`", b.name);
        let (mass, mass_nominal) = r.value(&b.mass, &at(&["mass"]));
        r.positive(mass_nominal, &at(&["mass"]));
        let (com, _) = r.vector(&b.com, dim, &at(&["com"]));
        let zero = || Poly::zero();
        let mut inertia = [[zero(), zero(), zero()], [zero(), zero(), zero()], [zero(), zero(), zero()]];
        match (&b.inertia, planar) {
            (Inertia::Scalar(v), true) => {
                let (poly, x) = r.value(v, &at(&["inertia"]));
                r.non_negative(x, &at(&["inertia"]));
                inertia[2][2] = poly;
            }
            (Inertia::SlenderRod(rod), true) => {
                let (length, x) = r.value(&rod.slender_rod, &at(&["inertia", "slender_rod"]));
                r.positive(x, &at(&["inertia", "slender_rod"]));
                inertia[2][2] = mass.mul(&length).mul(&length).scale(1.0 / 12.0);
            }
            (Inertia::Tensor(t), false) => {
                let entries: [(&str, Option<&Value>); 6] = [
                    ("ixx", Some(&t.ixx)),
                    ("iyy", Some(&t.iyy)),
                    ("izz", Some(&t.izz)),
                    ("ixy", t.ixy.as_ref()),
                    ("ixz", t.ixz.as_ref()),
                    ("iyz", t.iyz.as_ref()),
                ];
                let mut nominal = [0.0; 6];
                let mut polys: Vec<Poly> = Vec::new();
                for (k, (name, v)) in entries.iter().enumerate() {
                    match v {
                        Some(v) => {
                            let (poly, x) = r.value(v, &at(&["inertia", name]));
                            polys.push(poly);
                            nominal[k] = x;
                        }
                        None => polys.push(Poly::zero()),
                    }
                }
                let m = [
                    [nominal[0], nominal[3], nominal[4]],
                    [nominal[3], nominal[1], nominal[5]],
                    [nominal[4], nominal[5], nominal[2]],
                ];
                let e = symmetric_eigenvalues(m);
                if e[0] < -1e-12 * e[2].abs().max(1e-30) {
                    r.error_hint(
                        &at(&["inertia"]),
                        format!(
                            "invalid inertia tensor: not positive semi-definite (principal moments {:.6e}, {:.6e}, {:.6e})",
                            e[0], e[1], e[2]
                        ),
                        "an inertia tensor about the centre of mass is symmetric positive (semi-)definite",
                    );
                } else if e[0] + e[1] < e[2] * (1.0 - 1e-9) {
                    r.error_hint(
                        &at(&["inertia"]),
                        format!(
                            "invalid inertia tensor: principal moments {:.6e}, {:.6e}, {:.6e} violate the triangle inequality",
                            e[0], e[1], e[2]
                        ),
                        "for a real body each principal moment is at most the sum of the other two",
                    );
                }
                let [ixx, iyy, izz, ixy, ixz, iyz] = <[Poly; 6]>::try_from(polys).unwrap_or_default();
                inertia = [[ixx, ixy.clone(), ixz.clone()], [ixy, iyy, iyz.clone()], [ixz, iyz, izz]];
            }
            (_, true) => r.error_hint(
                &at(&["inertia"]),
                "a planar model takes a scalar inertia about z",
                "write a number, or `{slender_rod: LENGTH}`",
            ),
            (_, false) => r.error_hint(
                &at(&["inertia"]),
                "invalid inertia: a spatial model takes a full tensor",
                "write `{ixx, iyy, izz, ixy, ixz, iyz}` about the centre of mass, in body axes",
            ),
        }

        let motion = match (&b.parent, &b.pose) {
            (Some(_), Some(_)) | (None, None) => {
                r.error_hint(
                    &base,
                    format!("{what} must have exactly one of `parent` (serial chain) or `pose` (direct pose)"),
                    "a serial body names `parent`, optional `origin` and `joint`; a directly posed body names `pose`",
                );
                depends_on.push(None);
                bodies.push(None);
                continue;
            }
            (Some(parent), None) => {
                let Ok(parent_index) = lookup_body(&mut r, parent, &at(&["parent"]), &what) else {
                    depends_on.push(None);
                    bodies.push(None);
                    continue;
                };
                let mut tail = None;
                let (xyz, rotation) = match (&b.origin, &b.dh) {
                    (Some(_), Some(_)) => {
                        r.error_hint(
                            &at(&["dh"]),
                            format!("{what} has both `origin` and `dh`"),
                            "place a body with either `origin` (xyz, rpy) or `dh` (Denavit–Hartenberg parameters)",
                        );
                        ([zero(), zero(), zero()], rotation_rpy([0.0; 3]))
                    }
                    (None, Some(dh)) => {
                        if planar {
                            r.error_hint(
                                &at(&["dh"]),
                                "Denavit–Hartenberg parameters need a spatial model",
                                "use `origin: {xyz, rpy}` in a planar model, or `space: spatial`",
                            );
                        }
                        let length = |r: &mut Resolver<'_, '_>, v: &Option<Value>, k: &str| match v {
                            Some(v) => r.value(v, &at(&["dh", k])).0,
                            None => zero(),
                        };
                        let a = length(&mut r, &dh.a, "a");
                        let d = length(&mut r, &dh.d, "d");
                        let (alpha, theta) = (dh.alpha.unwrap_or(0.0), dh.theta.unwrap_or(0.0));
                        let (s_alpha, c_alpha) = exact_sin_cos(alpha);
                        match dh.convention {
                            DhConvention::Standard => {
                                tail = Some(Box::new(FixedTransform {
                                    xyz: [a, zero(), zero()],
                                    rotation: rotation_x(alpha),
                                }));
                                ([zero(), zero(), d], rotation_z(theta))
                            }
                            DhConvention::Modified => {
                                // Rx(α)·Tx(a)·Rz(θ)·Tz(d) = Trans(a, −d sin α, d cos α)·Rx(α)Rz(θ).
                                let rotation = snap(mat3_mul(rotation_x(alpha), rotation_z(theta)));
                                ([a, d.scale(-s_alpha), d.scale(c_alpha)], rotation)
                            }
                        }
                    }
                    (None, None) => ([zero(), zero(), zero()], rotation_rpy([0.0; 3])),
                    (Some(o), None) => {
                        let xyz = match &o.xyz {
                            Some(v) => r.vector(v, dim, &at(&["origin", "xyz"])).0,
                            None => [zero(), zero(), zero()],
                        };
                        let rpy = match (&o.rpy, planar) {
                            (None, _) => [0.0; 3],
                            (Some(v), true) if v.len() == 1 => [0.0, 0.0, v[0]],
                            (Some(v), false) if v.len() == 3 => [v[0], v[1], v[2]],
                            (Some(v), _) => {
                                r.error(
                                    &at(&["origin", "rpy"]),
                                    format!(
                                        "expected {} entries, got {}",
                                        if planar { "1 (the angle about z)" } else { "3 (roll, pitch, yaw)" },
                                        v.len()
                                    ),
                                );
                                [0.0; 3]
                            }
                        };
                        (xyz, rotation_rpy(rpy))
                    }
                };
                let joint = match &b.joint {
                    None => None,
                    Some(name) => {
                        let j = lookup_joint(&mut r, name, &at(&["joint"]), &what);
                        if let Some(j) = j {
                            joint_used[j] = true;
                            if b.dh.is_some() && !dh_axis(&file.joints[j].axis) {
                                r.error_hint(
                                    &[key("joints"), Segment::Index(j), key("axis")],
                                    format!(
                                        "joint `{name}` moves body `{}`, placed with Denavit–Hartenberg parameters: its axis must be z",
                                        b.name
                                    ),
                                    "a DH joint turns about (or slides along) z: remove `axis` or write [0.0, 0.0, 1.0]; orient the frame with `theta` and `alpha`",
                                );
                            }
                            if let Some(other) = serial_joint_users.insert(j, i) {
                                r.error(
                                    &at(&["joint"]),
                                    format!(
                                        "joint `{name}` already moves body `{}`; a serial joint moves one body",
                                        file.bodies[other].name
                                    ),
                                );
                            }
                        }
                        j
                    }
                };
                depends_on.push(parent_index);
                Motion::Serial { parent: parent_index, xyz, rotation, joint, tail }
            }
            (None, Some(pose)) => {
                if b.dh.is_some() {
                    r.error_hint(
                        &at(&["dh"]),
                        format!("{what} is directly posed: `dh` applies to serial bodies only"),
                        "a serial body names `parent`, then `dh` (or `origin`) and `joint`",
                    );
                }
                if !planar {
                    r.error_hint(
                        &at(&["pose"]),
                        "direct poses are supported for planar models only",
                        "describe spatial bodies as a serial chain (`parent`, `origin`, `joint`)",
                    );
                }
                let Ok(origin_body) =
                    lookup_body(&mut r, &pose.origin.body, &at(&["pose", "origin", "body"]), &what)
                else {
                    depends_on.push(None);
                    bodies.push(None);
                    continue;
                };
                let (point, _) = r.vector(&pose.origin.point, dim, &at(&["pose", "origin", "point"]));
                let Some(angle_joint) = lookup_joint(&mut r, &pose.angle, &at(&["pose", "angle"]), &what)
                else {
                    depends_on.push(None);
                    bodies.push(None);
                    continue;
                };
                joint_used[angle_joint] = true;
                if file.joints[angle_joint].kind != JointKind::Revolute {
                    r.error(&at(&["pose", "angle"]), format!("joint `{}` is not revolute", pose.angle));
                }
                depends_on.push(origin_body);
                Motion::Direct { origin_body, point, angle_joint }
            }
        };
        bodies.push(Some(ResolvedBody {
            name: b.name.clone(),
            description: b.description.clone(),
            mass,
            com,
            inertia,
            motion,
        }));
    }
    // A joint is reported as unused only when every body resolved: otherwise the unresolved
    // reference is the one error to fix, and this would be its echo.
    let bodies_resolved = bodies.iter().all(Option::is_some) && !r.unresolved_joint_reference;
    for (j, used) in joint_used.iter().enumerate() {
        if bodies_resolved && !used && j < file.joints.len() && !duplicate_joints.contains(&j) {
            r.error_hint(
                &[key("joints"), Segment::Index(j), key("name")],
                format!("joint `{}` moves no body", file.joints[j].name),
                "name it as a body's `joint` or a direct pose's `angle`",
            );
        }
    }

    // Points.
    let mut points = Vec::new();
    let mut point_index: HashMap<String, usize> = HashMap::new();
    for (i, p) in file.points.iter().enumerate() {
        let base = vec![key("points"), Segment::Index(i)];
        let at = |k: &str| {
            let mut q = base.clone();
            q.push(key(k));
            q
        };
        if !is_identifier(&p.name) {
            r.error(&at("name"), format!("`{}` is not a valid point name", p.name));
        }
        if point_index.insert(p.name.clone(), i).is_some() {
            r.error(&at("name"), format!("point `{}` is defined twice", p.name));
        }
        let Ok(body) = lookup_body(&mut r, &p.body, &at("body"), &format!("point `{}`", p.name)) else {
            continue;
        };
        let (position, _) = r.vector(&p.position, dim, &at("position"));
        points.push(ResolvedPoint {
            name: p.name.clone(),
            description: p.description.clone(),
            body,
            position,
        });
    }

    // Frames (orientation outputs).
    let mut frames = Vec::new();
    let mut frame_names = HashSet::new();
    for (i, f) in file.frames.iter().enumerate() {
        let base = vec![key("frames"), Segment::Index(i)];
        let at = |k: &str| {
            let mut q = base.clone();
            q.push(key(k));
            q
        };
        if planar {
            r.error_hint(
                &base,
                "frames (orientation outputs) need a spatial model",
                "a planar body's orientation is its angle about z; name a point for its position",
            );
            continue;
        }
        if !is_identifier(&f.name) {
            r.error(&at("name"), format!("`{}` is not a valid frame name", f.name));
        }
        if !frame_names.insert(f.name.clone()) {
            r.error(&at("name"), format!("frame `{}` is defined twice", f.name));
        }
        // `<frame>_angular_jacobian` must not be a point's `<point>_jacobian`.
        let clash = format!("{}_angular", f.name);
        if point_index.contains_key(&clash) {
            r.error_hint(
                &at("name"),
                format!(
                    "frame `{}` clashes with point `{clash}`: both would emit `{clash}_jacobian`",
                    f.name
                ),
                "rename the frame or the point",
            );
        }
        let Ok(body) = lookup_body(&mut r, &f.body, &at("body"), &format!("frame `{}`", f.name)) else {
            continue;
        };
        let rotation = match f.rpy.as_deref() {
            None => rotation_rpy([0.0; 3]),
            Some(&[roll, pitch, yaw]) => rotation_rpy([roll, pitch, yaw]),
            Some(v) => {
                r.error(&at("rpy"), format!("expected 3 entries (roll, pitch, yaw), got {}", v.len()));
                rotation_rpy([0.0; 3])
            }
        };
        frames.push(ResolvedFrame {
            name: f.name.clone(),
            description: f.description.clone(),
            body,
            rotation,
        });
    }

    // Task.
    let task = match (&file.task.point, &file.task.joints) {
        (Some(name), None) => match points.iter().position(|p| &p.name == name) {
            Some(i) => TaskSpec::Point(i),
            None => {
                r.error_hint(
                    &[key("task"), key("point")],
                    format!("task references unknown point `{name}`"),
                    "name an entry of `points`",
                );
                TaskSpec::Joints(vec![])
            }
        },
        (None, Some(names)) => {
            let mut list = Vec::new();
            let mut seen = HashSet::new();
            for (i, name) in names.iter().enumerate() {
                let path = [key("task"), key("joints"), Segment::Index(i)];
                if let Some(j) = lookup_joint(&mut r, name, &path, "task") {
                    if !seen.insert(j) {
                        r.error(&path, format!("joint `{name}` is listed twice"));
                    }
                    if file.joints[j].passive {
                        r.error_hint(
                            &path,
                            format!("joint `{name}` is passive: a joint-space task uses actuated joints"),
                            "make the task a point (`task: {point: ...}`)",
                        );
                    }
                    list.push(j);
                }
            }
            if names.is_empty() {
                r.error(&[key("task"), key("joints")], "must list at least one joint");
            }
            TaskSpec::Joints(list)
        }
        _ => {
            r.error_hint(
                &[key("task")],
                "must have exactly one of `point` or `joints`",
                "e.g. `task: {point: end_effector}` or `task: {joints: [q]}`",
            );
            TaskSpec::Joints(vec![])
        }
    };

    // Closures.
    let mut declared = Vec::new();
    let mut closing: HashMap<usize, usize> = HashMap::new();
    let mut closure_names = HashSet::new();
    for (i, c) in file.closures.iter().enumerate() {
        let base = vec![key("closures"), Segment::Index(i)];
        let at = |k: &str| {
            let mut p = base.clone();
            p.push(key(k));
            p
        };
        if !planar {
            r.error_hint(
                &base,
                "closures are supported for planar models only",
                "a spatial closed chain (Delta robot, Stewart platform) cannot be described yet",
            );
            continue;
        }
        if !is_identifier(&c.name) {
            r.error(&at("name"), format!("`{}` is not a valid closure name", c.name));
        }
        if !closure_names.insert(c.name.clone()) {
            r.error(&at("name"), format!("closure `{}` is defined twice", c.name));
        }
        let what = format!("closure `{}`", c.name);
        let mut resolved_joints = Vec::new();
        if c.joints.len() != 2 {
            r.error_hint(
                &at("joints"),
                format!("expected 2 joints, got {}", c.joints.len()),
                "name the two passive distal joints of the dyad: `joints: [left_elbow, right_elbow]`",
            );
        } else {
            for (k, name) in c.joints.iter().enumerate() {
                let mut path = at("joints");
                path.push(Segment::Index(k));
                let Some(j) = lookup_joint(&mut r, name, &path, &what) else { continue };
                if !file.joints[j].passive {
                    r.error_hint(
                        &path,
                        format!("joint `{name}` is actuated: a closure eliminates passive joints"),
                        "mark the distal joints of the dyad `passive: true` (without a drive)",
                    );
                } else if let Some(other) = closing.insert(j, i) {
                    r.error(
                        &path,
                        format!(
                            "joint `{name}` is already eliminated by closure `{}`",
                            file.closures[other].name
                        ),
                    );
                }
                resolved_joints.push(j);
            }
        }
        let mut resolved_points = Vec::new();
        if c.points.len() != 2 {
            r.error_hint(
                &at("points"),
                format!("expected 2 points, got {}", c.points.len()),
                "name the point of each joint's link that meets the other: `points: [left_tip, right_tip]`",
            );
        } else {
            for (k, name) in c.points.iter().enumerate() {
                let mut path = at("points");
                path.push(Segment::Index(k));
                match points.iter().position(|p| &p.name == name) {
                    Some(p) => resolved_points.push(p),
                    None => r.error_hint(
                        &path,
                        format!("{what} references unknown point `{name}`"),
                        "name an entry of `points`",
                    ),
                }
            }
        }
        if let (&[j1, j2], &[p1, p2]) = (&resolved_joints[..], &resolved_points[..]) {
            if j1 == j2 {
                r.error(&at("joints"), "the two joints must differ");
            } else if p1 == p2 {
                r.error(&at("points"), "the two points must differ");
            } else {
                declared.push((i, j1, j2, p1, p2, c.branch));
            }
        }
    }
    for (j, joint) in file.joints.iter().enumerate() {
        if joint.passive && !closing.contains_key(&j) && !duplicate_joints.contains(&j) {
            r.error_hint(
                &[key("joints"), Segment::Index(j), key("passive")],
                format!("passive joint `{}` is not eliminated by any closure", joint.name),
                "list it in the `joints` of an entry of `closures`",
            );
        }
    }

    // Sensors, rates, current loop, rendering.
    let mut sensor_names = HashSet::new();
    for (i, s) in file.sensors.iter().enumerate() {
        let at = |k: &str| vec![key("sensors"), Segment::Index(i), key(k)];
        if !sensor_names.insert(s.name.clone()) {
            r.error(&at("name"), format!("sensor `{}` is defined twice", s.name));
        }
        if s.scale == 0.0 {
            r.error(&at("scale"), "must not be zero");
        }
        r.positive(s.full_scale, &at("full_scale"));
        r.non_negative(s.noise, &at("noise"));
        r.non_negative(s.resolution, &at("resolution"));
    }
    let rates_path = |k: &str| vec![key("rates"), key(k)];
    if file.rates.current_loop_hz == 0 {
        r.error(&rates_path("current_loop_hz"), "must be positive, got 0");
    }
    if file.rates.impedance_loop_hz == 0 {
        r.error(&rates_path("impedance_loop_hz"), "must be positive, got 0");
    } else if file.rates.impedance_loop_hz > file.rates.current_loop_hz {
        r.error(
            &rates_path("impedance_loop_hz"),
            format!(
                "the impedance loop ({} Hz) cannot run faster than the current loop ({} Hz)",
                file.rates.impedance_loop_hz, file.rates.current_loop_hz
            ),
        );
    }
    let cl = |k: &str| vec![key("current_loop"), key(k)];
    r.positive(file.current_loop.bandwidth_hz, &cl("bandwidth_hz"));
    r.positive(file.current_loop.damping_ratio, &cl("damping_ratio"));
    r.positive(file.current_loop.anti_alias_cutoff_hz, &cl("anti_alias_cutoff_hz"));
    let nyquist = f64::from(file.rates.current_loop_hz) / 2.0;
    if file.current_loop.bandwidth_hz >= nyquist && nyquist > 0.0 {
        r.error(
            &cl("bandwidth_hz"),
            format!("must be below the Nyquist frequency of the current loop ({nyquist} Hz)"),
        );
    }
    if let Some(rend) = &file.rendering {
        let at = |k: &str| vec![key("rendering"), key(k)];
        r.positive(rend.grid_spacing, &at("grid_spacing"));
        r.non_negative(rend.wall_stiffness, &at("wall_stiffness"));
        r.non_negative(rend.wall_damping, &at("wall_damping"));
    }
    if let Some(d) = &file.default_variant {
        if !file.variants.contains_key(d) && variant.is_none() {
            r.error(&[key("default_variant")], format!("unknown variant `{d}`"));
        }
    }

    // Dependency order of bodies (parents and pose origins first); cycles are errors.
    let n = bodies.len();
    let mut order = Vec::with_capacity(n);
    let mut state = vec![0u8; n]; // 0 new, 1 visiting, 2 done
    for start in 0..n {
        let mut chain = Vec::new();
        let mut current = Some(start);
        while let Some(c) = current {
            if state[c] == 2 {
                break;
            }
            if state[c] == 1 {
                let cycle: Vec<&str> = chain
                    .iter()
                    .skip_while(|&&x| x != c)
                    .map(|&x: &usize| file.bodies[x].name.as_str())
                    .collect();
                r.error_hint(
                    &[key("bodies"), Segment::Index(c)],
                    format!("bodies form a cycle: {} → {}", cycle.join(" → "), file.bodies[c].name),
                    "each body must be placed relative to bodies closer to the base",
                );
                break;
            }
            state[c] = 1;
            chain.push(c);
            current = depends_on.get(c).copied().flatten();
        }
        for &c in chain.iter().rev() {
            if state[c] == 1 {
                state[c] = 2;
                order.push(c);
            }
        }
    }

    // The current loop of every joint is designed now, so that an infeasible design is a
    // diagnostic at the model's `current_loop` section.
    let mut current_loop_designs = Vec::new();
    if !(1..=4).contains(&file.current_loop.anti_alias_filter_order) {
        r.error(
            &cl("anti_alias_filter_order"),
            format!("must be 1, 2, 3 or 4, got {}", file.current_loop.anti_alias_filter_order),
        );
    } else if r.errors.is_empty() {
        for j in &joints {
            let input = crate::check::current_loop::CurrentLoopDesignInput {
                resistance: j.drive.motor.resistance,
                inductance: j.drive.motor.inductance,
                sample_rate_hz: f64::from(file.rates.current_loop_hz),
                bandwidth_hz: file.current_loop.bandwidth_hz,
                damping_ratio: file.current_loop.damping_ratio,
                filter_cutoff_hz: file.current_loop.anti_alias_cutoff_hz,
                filter_order: file.current_loop.anti_alias_filter_order,
            };
            // Joints sharing a drive share its design.
            let earlier = joints.iter().position(|other| other.drive_name == j.drive_name);
            if let Some(&design) = earlier.and_then(|k| current_loop_designs.get(k)) {
                current_loop_designs.push(design);
                continue;
            }
            match crate::check::current_loop::design_current_loop(&input) {
                Ok(design) => current_loop_designs.push(design),
                Err(why) => {
                    r.error(
                        &[key("current_loop")],
                        format!(
                            "no current-loop design for joint `{}` (drive `{}`): {why}",
                            j.name, j.drive_name
                        ),
                    );
                    break;
                }
            }
        }
    }

    if !r.errors.is_empty() {
        return Err(Diagnostics(r.errors));
    }
    // Reindex bodies in dependency order.
    let mut new_index = vec![0usize; n];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new;
    }
    let remap = |i: Option<usize>| i.map(|x| new_index[x]);
    let mut ordered = Vec::with_capacity(n);
    for &old in &order {
        let Some(mut body) = bodies[old].take() else {
            continue;
        };
        body.motion = match body.motion {
            Motion::Serial { parent, xyz, rotation, joint, tail } => {
                Motion::Serial { parent: remap(parent), xyz, rotation, joint, tail }
            }
            Motion::Direct { origin_body, point, angle_joint } => {
                Motion::Direct { origin_body: remap(origin_body), point, angle_joint }
            }
        };
        ordered.push(body);
    }
    for p in &mut points {
        p.body = remap(p.body);
    }
    for f in &mut frames {
        f.body = remap(f.body);
    }
    // Joint references become coordinate indices (actuated first, then passive).
    for body in &mut ordered {
        match &mut body.motion {
            Motion::Serial { joint, .. } => *joint = joint.map(|j| coordinate_of[j]),
            Motion::Direct { angle_joint, .. } => *angle_joint = coordinate_of[*angle_joint],
        }
    }
    let task = match task {
        TaskSpec::Joints(list) => TaskSpec::Joints(list.into_iter().map(|j| coordinate_of[j]).collect()),
        point => point,
    };
    let mut model = Model {
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
        current_loop_designs,
        passive,
        closures: None,
    };
    if !declared.is_empty() {
        let declarations: Vec<crate::dynamics::closure::Declaration> = declared
            .iter()
            .map(|&(i, j1, j2, p1, p2, branch)| crate::dynamics::closure::Declaration {
                name: file.closures[i].name.clone(),
                joints: [coordinate_of[j1], coordinate_of[j2]],
                points: [p1, p2],
                branch,
            })
            .collect();
        match crate::dynamics::closure::analyse(&model, &declarations) {
            Ok(closures) => model.closures = Some(closures),
            Err(problems) => {
                let errors = problems
                    .into_iter()
                    .map(|p| {
                        let (i, ..) = declared[p.closure];
                        let mut path = vec![key("closures"), Segment::Index(i)];
                        path.extend(p.key.map(key));
                        let d = locator.at(&path, p.message);
                        match p.hint {
                            Some(h) => d.with_hint(h),
                            None => d,
                        }
                    })
                    .collect();
                return Err(Diagnostics(errors));
            }
        }
    }
    Ok(model)
}
