//! The model-file format: the Rust types a YAML model deserialises into.
//!
//! These types are the single source of truth for the format: `docs/model-format.md`
//! documents them, and `schema/model.schema.json` is generated from them (see
//! [`crate::model::json_schema`]). Every quantity is in SI units. Unknown keys are errors.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::Deserialize;

/// A number, or the name of an entry of `parameters`.
///
/// Parameters marked `tunable` stay symbolic in the generated code (fields of the rig
/// struct); all others are folded into constants.
#[derive(Clone, Debug, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum Value {
    /// A literal number in SI units.
    Number(f64),
    /// A reference to a named parameter.
    Parameter(String),
}

/// How the JSON schema describes a numeric field: the loader evaluates units and expressions to
/// a number before typing the file, so the Rust field is a plain number.
#[derive(JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum Quantity {
    /// A number in the field's SI unit.
    Number(f64),
    /// A number with a unit (`30 g`, `120 deg`) or an expression of numbers and parameters
    /// (`shin_mass * shin_length^2 / 12`), evaluated when the file is loaded.
    Expression(String),
}

/// How the JSON schema describes a whole-number field (counts, rates, orders).
#[derive(JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum WholeQuantity {
    /// A whole number.
    Number(u32),
    /// A number with a unit (`7.5 kHz`) or an expression (`4 * 500`) whose value is whole.
    Expression(String),
}

/// How the JSON schema describes an entry of `drives`: a drive, or one `like` another.
#[derive(JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum DriveEntry {
    /// A drive given in full.
    Drive(Drive),
    /// A drive that reuses another.
    Like(DriveLike),
}

/// A drive that reuses another: a copy of the drive `like` names, with the keys given here
/// replacing its own (`motor` and `encoder` merged key by key).
#[derive(JsonSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct DriveLike {
    /// The drive this one copies.
    like: String,
    /// Motor constants that differ.
    #[serde(default)]
    motor: Option<serde_json::Value>,
    /// Motor turns per joint turn.
    #[schemars(with = "Option<Quantity>")]
    gear_ratio: Option<f64>,
    /// Gearhead efficiency in (0, 1].
    #[schemars(with = "Option<Quantity>")]
    efficiency: Option<f64>,
    /// Largest joint-side torque, N·m (N for prismatic joints).
    #[schemars(with = "Option<Quantity>")]
    torque_limit: Option<f64>,
    /// Largest motor current, A.
    #[schemars(with = "Option<Quantity>")]
    current_limit: Option<f64>,
    /// Supply voltage, V.
    #[schemars(with = "Option<Quantity>")]
    supply_voltage: Option<f64>,
    /// Encoder settings that differ.
    #[serde(default)]
    encoder: Option<serde_json::Value>,
    /// Gearhead backlash, rad.
    #[schemars(with = "Option<Quantity>")]
    backlash: Option<f64>,
    /// Coulomb friction at the joint, N·m.
    #[schemars(with = "Option<Quantity>")]
    coulomb_friction: Option<f64>,
    /// Static friction at the joint, N·m.
    #[schemars(with = "Option<Quantity>")]
    static_friction: Option<f64>,
}

/// Whether bodies move in a plane (x, y; rotations about z) or in space.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Space {
    /// Motion in the x–y plane: vectors have 2 entries, inertias are scalars about z.
    Planar,
    /// Motion in 3-D space: vectors have 3 entries, inertias are full tensors.
    Spatial,
}

/// A complete model file.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Identifier of the rig (snake_case); names the generated Rust type.
    pub name: String,
    /// One-line description, copied into the generated documentation.
    #[serde(default)]
    pub description: Option<String>,
    /// `planar` or `spatial`.
    pub space: Space,
    /// Gravitational acceleration vector in the base frame, m/s² (2 or 3 entries).
    pub gravity: Vec<Value>,
    /// Named values that other fields may reference by name.
    #[serde(default)]
    pub parameters: BTreeMap<String, Parameter>,
    /// Drive trains (motor, gearhead, encoder, limits), referenced by joints by name. An entry
    /// may reuse another with `like: NAME` and override some of its keys.
    #[schemars(with = "BTreeMap<String, DriveEntry>")]
    pub drives: BTreeMap<String, Drive>,
    /// The joints, one per generalised coordinate, in the order of `q`.
    pub joints: Vec<Joint>,
    /// Couplings between the joints and their drives (a cable or bevel differential, a motor
    /// on the base that turns an absolute angle): for an actuated joint, what its drive's
    /// output turns per joint coordinate (`a = C q`; `{pitch: 1, roll: 1}`: the sum of the
    /// two angles). A joint not listed has its drive turn it alone.
    #[serde(default)]
    #[schemars(with = "BTreeMap<String, BTreeMap<String, Quantity>>")]
    pub transmission: BTreeMap<String, BTreeMap<String, f64>>,
    /// The rigid bodies and how each one moves.
    pub bodies: Vec<Body>,
    /// Named points fixed on bodies (operational points, sensor locations, plot points).
    #[serde(default)]
    pub points: Vec<Point>,
    /// Named frames fixed on bodies whose orientation the generated code reports (spatial
    /// models): the rotation matrix in the base frame and the angular-velocity Jacobian.
    #[serde(default)]
    pub frames: Vec<Frame>,
    /// Loop-closure constraints of a closed chain: each one eliminates two passive joints.
    #[serde(default)]
    pub closures: Vec<Closure>,
    /// The task coordinates `x` the impedance controllers act on.
    pub task: Task,
    /// Sensors besides the joint encoders.
    #[serde(default)]
    pub sensors: Vec<Sensor>,
    /// Sample rates of the control loops.
    pub rates: Rates,
    /// Design targets of the inner current loop.
    pub current_loop: CurrentLoopSpec,
    /// Haptic rendering settings (virtual walls, anti-drift grid).
    #[serde(default)]
    pub rendering: Option<Rendering>,
    /// The variant used when none is named; required when `variants` is not empty.
    #[serde(default)]
    pub default_variant: Option<String>,
    /// Named variants, each overriding some values of this file.
    #[serde(default)]
    pub variants: BTreeMap<String, Variant>,
}

/// A named value.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Parameter {
    /// The nominal value, SI units.
    #[schemars(with = "Quantity")]
    pub value: f64,
    /// Keep the parameter symbolic: it becomes a field of the generated rig struct, with
    /// `value` as its default, and can be changed at run time (e.g. a tool mass).
    #[serde(default)]
    pub tunable: bool,
    /// Unit, for documentation only (e.g. `kg`).
    #[serde(default)]
    pub unit: Option<String>,
    /// What the value is.
    #[serde(default)]
    pub description: Option<String>,
}

/// A motor with its gearhead, encoder and limits.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Drive {
    /// The electric motor.
    pub motor: Motor,
    /// Motor turns per joint turn (N); the rotor inertia reflects to the joint as N²·J_m.
    #[schemars(with = "Quantity")]
    pub gear_ratio: f64,
    /// Gearhead efficiency in (0, 1].
    #[serde(default = "one")]
    #[schemars(with = "Quantity")]
    pub efficiency: f64,
    /// Largest joint-side torque the controllers may command, N·m (N for prismatic joints).
    #[schemars(with = "Quantity")]
    pub torque_limit: f64,
    /// Largest motor current, A.
    #[schemars(with = "Quantity")]
    pub current_limit: f64,
    /// Supply voltage, V.
    #[schemars(with = "Quantity")]
    pub supply_voltage: f64,
    /// Incremental encoder on the motor shaft.
    pub encoder: Encoder,
    /// Gearhead backlash, rad (joint side); used by the simulator only.
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub backlash: f64,
    /// Coulomb friction at the drive's output, N·m; simulated, and fed forward by the runtime's
    /// friction compensation when it is on.
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub coulomb_friction: f64,
    /// Static (breakaway) friction at the drive's output, N·m; used by the simulator only (no
    /// feed-forward can tell which way a resting joint will break away).
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub static_friction: f64,
}

impl Drive {
    /// The joint-side angle of one encoder count, rad: `2π / (counts_per_turn · N)` (a
    /// prismatic joint's drive: its length per count, m, through the same ratio).
    pub fn count_size(&self) -> f64 {
        std::f64::consts::TAU / (f64::from(self.encoder.counts_per_turn) * self.gear_ratio)
    }
}

fn one() -> f64 {
    1.0
}

/// A DC motor's electrical and mechanical constants.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Motor {
    /// Rotor inertia J_m, kg·m².
    #[schemars(with = "Quantity")]
    pub rotor_inertia: f64,
    /// Terminal resistance R, Ω.
    #[schemars(with = "Quantity")]
    pub resistance: f64,
    /// Terminal inductance L, H.
    #[schemars(with = "Quantity")]
    pub inductance: f64,
    /// Torque constant k_t, N·m/A.
    #[schemars(with = "Quantity")]
    pub torque_constant: f64,
}

/// An incremental encoder.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Encoder {
    /// Counts per motor turn after quadrature decoding (4 × lines).
    #[schemars(with = "WholeQuantity")]
    pub counts_per_turn: u32,
}

/// Kind of a one-coordinate joint: what every joint of a resolved model is.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointKind {
    /// Rotation about `axis`; the coordinate is an angle in rad.
    Revolute,
    /// Translation along `axis`; the coordinate is a length in m.
    Prismatic,
}

/// Kind of joint as the file writes it: a one-coordinate joint, or a passive joint of two or
/// three rotations that the loader expands into revolute joints joined by massless crosses.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointType {
    /// Rotation about `axis`; the coordinate is an angle in rad.
    Revolute,
    /// Translation along `axis`; the coordinate is a length in m.
    Prismatic,
    /// Two rotations about the two `axes` (a Hooke or Cardan joint); spatial models, passive.
    Universal,
    /// Three rotations about the three `axes` (a ball joint as three revolute joints, singular
    /// where the first and third axes line up); spatial models, passive.
    Spherical,
}

impl JointType {
    /// The kind of a one-coordinate joint; `None` for a universal or spherical joint.
    pub fn single(self) -> Option<JointKind> {
        match self {
            JointType::Revolute => Some(JointKind::Revolute),
            JointType::Prismatic => Some(JointKind::Prismatic),
            JointType::Universal | JointType::Spherical => None,
        }
    }
}

/// A passive joint's position in the assembly the file chooses: one number for a one-coordinate
/// joint, a list with one per axis for a universal or spherical joint.
#[derive(Clone, Debug, Deserialize, JsonSchema, PartialEq)]
#[serde(untagged)]
pub enum Assembly {
    /// A revolute joint's angle (rad) or a prismatic joint's travel (m).
    Single(#[schemars(with = "Quantity")] f64),
    /// A universal or spherical joint's angles about its axes, in order (rad).
    PerAxis(#[schemars(with = "Vec<Quantity>")] Vec<f64>),
}

/// One joint: an actuated generalised coordinate with its drive, or a passive joint of a
/// closed chain (`passive: true`, no drive), eliminated by a [`Closure`].
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Joint {
    /// Name of the coordinate (used in generated code, e.g. `sin_q1`).
    pub name: String,
    /// `revolute`, `prismatic`, or (passive, spatial models) `universal` or `spherical`.
    #[serde(rename = "type")]
    pub kind: JointType,
    /// What the coordinate measures.
    #[serde(default)]
    pub description: Option<String>,
    /// Unit axis in the joint frame; planar models take `[0, 0, 1]` (default) or
    /// `[0, 0, -1]` for revolute joints and a 2-vector for prismatic ones.
    #[serde(default)]
    #[schemars(with = "Option<Vec<Quantity>>")]
    pub axis: Option<Vec<f64>>,
    /// Universal (two) and spherical (three) joints: the axes of their rotations, unit or not,
    /// in the joint frame with every angle zero. Each axis turns with the rotations before it:
    /// the first is fixed in the parent, the last in the child. A spherical joint's default is
    /// x, y, z.
    #[serde(default)]
    #[schemars(with = "Option<Vec<Vec<Quantity>>>")]
    pub axes: Option<Vec<Vec<f64>>>,
    /// Universal and spherical joints: the names of their angles, one per axis, as they appear
    /// in the generated code (default `NAME_1`, `NAME_2`, ...).
    #[serde(default)]
    pub coordinates: Option<Vec<String>>,
    /// Range of motion (required for actuated joints; optional, documentation only, for
    /// passive ones).
    #[serde(default)]
    pub limits: Option<Limits>,
    /// Viscous damping at the joint, N·m·s/rad (N·s/m for prismatic joints); actuated
    /// joints only.
    #[serde(default)]
    pub damping: Option<Value>,
    /// Name of the entry of `drives` that actuates this joint (required unless `passive`).
    #[serde(default)]
    pub drive: Option<String>,
    /// An unactuated joint of a closed chain, eliminated by an entry of `closures`; it is
    /// not a coordinate of the generated code.
    #[serde(default)]
    pub passive: bool,
    /// Spatial closed chains: the passive joint's angle (rad; a prismatic joint's travel, m) in
    /// the assembly the file chooses,
    /// at the middle of the actuated joints' ranges, to within the loops' convergence basin.
    /// The elimination starts from it, so it picks the branch (assembly mode). Planar loops
    /// choose theirs with the closure's `branch`. A universal or spherical joint takes a list,
    /// one angle per axis.
    #[serde(default)]
    pub assembly: Option<Assembly>,
    /// A measured passive joint: an encoder and no motor (a gimbal's joints), outside any
    /// loop. Its angle is an input of the generated frame functions; it is not a coordinate of
    /// the dynamics.
    #[serde(default)]
    pub measured: Option<Measured>,
    /// A joint that follows another: its coordinate is `multiplier · q_leader + offset` (URDF's
    /// `<mimic>`: a link coupled to another joint, such as a parallelogram's link cut open).
    /// It has no drive and is not a coordinate.
    #[serde(default)]
    pub mimic: Option<Mimic>,
}

/// The joint a mimic joint follows, and how.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Mimic {
    /// The actuated joint it follows (of the same type).
    pub joint: String,
    /// `multiplier` in `multiplier · q_leader + offset` (default 1): ±1 for a revolute joint
    /// (the kinematics stay polynomials in the leader's sine and cosine), any number for a
    /// prismatic one.
    #[serde(default)]
    #[schemars(with = "Option<Quantity>")]
    pub multiplier: Option<f64>,
    /// `offset`, rad or m (default 0).
    #[serde(default)]
    #[schemars(with = "Option<Quantity>")]
    pub offset: Option<f64>,
}

/// A measured passive joint's encoder, and how the bodies it moves enter the dynamics.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Measured {
    /// Encoder counts per turn of the joint (after quadrature decoding).
    #[schemars(with = "WholeQuantity")]
    pub counts_per_turn: u32,
    /// How the bodies the joint moves enter the dynamics.
    pub dynamics: MeasuredDynamics,
}

/// How a measured joint's bodies enter the dynamics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MeasuredDynamics {
    /// Lumped: the bodies the joint moves are massless in the file, their mass given to the
    /// body that carries the joint (a gimbal's mass at its centre); the dynamics have the
    /// actuated coordinates only.
    Lumped,
}

/// A loop-closure constraint.
///
/// **Planar** models: two passive revolute joints (the distal joints of an RRR dyad, e.g.
/// the elbows of a five-bar) and one point on the chain of each, which must coincide; the
/// passive angles are eliminated in closed form (intersection of two circles) on `branch`.
///
/// **Spatial** models: two points that coincide (3 equations) and, optionally, two axes kept
/// perpendicular (1 equation: a universal joint cut open). The passive joints of all spatial
/// closures are eliminated together, numerically, from the assembly the joints' `assembly`
/// angles give; `joints` and `branch` are not used.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Closure {
    /// Identifier, used to name intermediates in the generated code.
    pub name: String,
    /// What the loop is.
    #[serde(default)]
    pub description: Option<String>,
    /// Planar: the two passive revolute joints `[j1, j2]` the constraint eliminates.
    #[serde(default)]
    pub joints: Vec<String>,
    /// The two points `[p1, p2]` (names of `points`) that coincide: planar, `p1` is moved by
    /// `j1`, `p2` by `j2`.
    pub points: Vec<String>,
    /// Planar: which of the two assemblies; the joined point lies to the `left` or `right` of
    /// the line from the axis of `j1` to the axis of `j2`.
    #[serde(default)]
    pub branch: Option<Branch>,
    /// Spatial: two axes, each fixed in a body, kept perpendicular (the two axes of a
    /// universal joint cut open by the closure).
    #[serde(default)]
    pub perpendicular: Option<Vec<BodyAxis>>,
}

/// A direction fixed in a body.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BodyAxis {
    /// The body's name (`base` for the fixed ground).
    pub body: String,
    /// The direction in the body's frame (3 entries; normalised).
    #[schemars(with = "Vec<Quantity>")]
    pub axis: Vec<f64>,
}

/// One of the two assemblies of a closure.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Branch {
    /// Counter-clockwise of the line from `j1`'s axis to `j2`'s axis:
    /// `(P2 − P1) × (E − P1) > 0`.
    Left,
    /// Clockwise of that line: `(P2 − P1) × (E − P1) < 0`.
    Right,
}

/// A closed interval.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Lower bound, rad or m.
    #[schemars(with = "Quantity")]
    pub lower: f64,
    /// Upper bound, rad or m.
    #[schemars(with = "Quantity")]
    pub upper: f64,
}

/// A rigid body.
///
/// Exactly one of `parent` (serial chain: parent frame, fixed `origin`, then `joint`) or
/// `pose` (the frame given directly by generalised coordinates) says how it moves.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// Name, unique among bodies; `base` is reserved for the fixed ground.
    pub name: String,
    /// What the body is.
    #[serde(default)]
    pub description: Option<String>,
    /// Mass, kg.
    pub mass: Value,
    /// Centre of mass in the body frame, m.
    pub com: Vec<Value>,
    /// Inertia about the centre of mass, in body-frame axes.
    pub inertia: Inertia,
    /// Serial chain: the parent body (`base` for the ground).
    #[serde(default)]
    pub parent: Option<String>,
    /// Serial chain: the fixed transform from the parent frame to the joint frame.
    #[serde(default)]
    pub origin: Option<Origin>,
    /// Serial chain: the fixed transform and the joint given as Denavit–Hartenberg
    /// parameters instead of `origin` (spatial models; the joint turns about or slides
    /// along z).
    #[serde(default)]
    pub dh: Option<DenavitHartenberg>,
    /// Serial chain: the joint between the parent and this body; absent = welded.
    #[serde(default)]
    pub joint: Option<String>,
    /// Direct pose: the frame's origin and orientation given by the coordinates.
    #[serde(default)]
    pub pose: Option<DirectPose>,
}

/// Inertia about the centre of mass.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(untagged)]
pub enum Inertia {
    /// A uniform solid of the body's mass, centred on the centre of mass (before `Scalar`:
    /// `point_mass` is a shape, not a parameter name).
    Shape(InertiaShape),
    /// Planar models: the moment of inertia about the z axis, kg·m².
    Scalar(Value),
    /// A uniform slender rod along the body's x axis (planar) of this length: m·L²/12.
    SlenderRod(SlenderRod),
    /// Spatial models: the symmetric tensor, kg·m².
    Tensor(InertiaTensor),
}

/// A uniform solid whose inertia tensor about its centre of mass follows from the body's mass
/// and its dimensions (the textbook formulas). In a planar model, its moment about z.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum InertiaShape {
    /// A slender rod (no thickness) of `length` along `axis`: m·L²/12 about every axis
    /// perpendicular to it, zero about it.
    Rod {
        /// Length, m.
        #[schemars(with = "Quantity")]
        length: f64,
        /// Direction of the rod in body axes (3 entries, normalised).
        #[schemars(with = "Vec<Quantity>")]
        axis: Vec<f64>,
    },
    /// A solid box with edges `x`, `y`, `z` along the body axes: I_xx = m·(y² + z²)/12, ...
    Box {
        /// Edge along x, m.
        #[schemars(with = "Quantity")]
        x: f64,
        /// Edge along y, m.
        #[schemars(with = "Quantity")]
        y: f64,
        /// Edge along z, m.
        #[schemars(with = "Quantity")]
        z: f64,
    },
    /// A solid cylinder of `radius` and `length` along `axis`: m·r²/2 about the axis,
    /// m·(3r² + L²)/12 about every axis perpendicular to it.
    Cylinder {
        /// Radius, m.
        #[schemars(with = "Quantity")]
        radius: f64,
        /// Length, m.
        #[schemars(with = "Quantity")]
        length: f64,
        /// Direction of the cylinder's axis in body axes (3 entries, normalised).
        #[schemars(with = "Vec<Quantity>")]
        axis: Vec<f64>,
    },
    /// A solid sphere: 2·m·r²/5 about every axis.
    Sphere {
        /// Radius, m.
        #[schemars(with = "Quantity")]
        radius: f64,
    },
    /// A point mass at the centre of mass: no inertia about it.
    PointMass,
}

/// A uniform slender rod.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SlenderRod {
    /// Length of the rod, m.
    pub slender_rod: Value,
}

/// The entries of a symmetric inertia tensor (products of inertia default to 0).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InertiaTensor {
    /// I_xx, kg·m².
    pub ixx: Value,
    /// I_yy, kg·m².
    pub iyy: Value,
    /// I_zz, kg·m².
    pub izz: Value,
    /// I_xy, kg·m².
    #[serde(default)]
    pub ixy: Option<Value>,
    /// I_xz, kg·m².
    #[serde(default)]
    pub ixz: Option<Value>,
    /// I_yz, kg·m².
    #[serde(default)]
    pub iyz: Option<Value>,
}

/// A fixed transform: translation, then roll–pitch–yaw (URDF convention, fixed axes x, y, z).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Origin {
    /// Translation, m (2 or 3 entries).
    #[serde(default)]
    pub xyz: Option<Vec<Value>>,
    /// Roll, pitch, yaw, rad (spatial); a single angle about z for planar models.
    #[serde(default)]
    #[schemars(with = "Option<Vec<Quantity>>")]
    pub rpy: Option<Vec<f64>>,
}

/// Which Denavit–Hartenberg convention a body's `dh` parameters follow.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DhConvention {
    /// Standard (distal) DH, as in Denavit & Hartenberg (1955), Spong and Corke's `DH`
    /// links: `frame = parent · Rz(theta) · Tz(d) · Joint(q) · Tx(a) · Rx(alpha)`; the
    /// joint moves about or along the parent's z axis and the body frame sits at the
    /// link's distal end.
    Standard,
    /// Modified (proximal) DH, as in Craig (1986) and Corke's `modified` links:
    /// `frame = parent · Rx(alpha) · Tx(a) · Rz(theta) · Tz(d) · Joint(q)`; the joint moves
    /// about or along the body's own z axis.
    Modified,
}

/// Denavit–Hartenberg parameters of one link (lengths in m, angles in rad).
///
/// `theta` and `d` are the fixed offsets of the joint: a revolute joint's angle is
/// `theta + q`, a prismatic joint's displacement `d + q`.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DenavitHartenberg {
    /// `standard` or `modified`.
    pub convention: DhConvention,
    /// Link length `a` along x, m (default 0).
    #[serde(default)]
    pub a: Option<Value>,
    /// Link twist `alpha` about x, rad (default 0).
    #[serde(default)]
    #[schemars(with = "Option<Quantity>")]
    pub alpha: Option<f64>,
    /// Link offset `d` along z, m (default 0).
    #[serde(default)]
    pub d: Option<Value>,
    /// Joint-angle offset `theta` about z, rad (default 0).
    #[serde(default)]
    #[schemars(with = "Option<Quantity>")]
    pub theta: Option<f64>,
}

/// A frame placed directly by the generalised coordinates (e.g. the parallelogram's links).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DirectPose {
    /// Where the frame's origin is: a point fixed on another body (or on `base`).
    pub origin: BodyPoint,
    /// The joint whose coordinate is the frame's absolute angle: from the base's x axis about
    /// z in a planar model, from the `plane`'s x axis about its z axis in a spatial one.
    pub angle: String,
    /// Spatial models: the plane the angle turns in (a planar loop carried by a moving body,
    /// such as a parallelogram on a turret).
    #[serde(default)]
    pub plane: Option<DirectPlane>,
}

/// The plane a spatial direct pose's angle turns in: the xy plane of a body's frame turned
/// by `rpy`. The posed frame is that frame turned by the angle about its z axis.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DirectPlane {
    /// The body whose frame carries the plane (or `base`).
    pub body: String,
    /// Fixed roll, pitch, yaw from that body's frame to the plane's (rad; default none).
    #[serde(default)]
    #[schemars(with = "Option<Vec<Quantity>>")]
    pub rpy: Option<Vec<f64>>,
}

/// A point fixed on a body.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BodyPoint {
    /// The body (or `base`).
    pub body: String,
    /// Coordinates in that body's frame, m.
    pub point: Vec<Value>,
}

/// A named point.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Point {
    /// Name (e.g. `end_effector`).
    pub name: String,
    /// What the point is.
    #[serde(default)]
    pub description: Option<String>,
    /// The body it is fixed on.
    pub body: String,
    /// Its coordinates in the body frame, m.
    pub position: Vec<Value>,
}

/// A named frame fixed on a body, whose orientation is an output of the generated code
/// (`<name>_orientation` and `<name>_angular_jacobian`); spatial models only.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Name (e.g. `flange`); names the generated methods.
    pub name: String,
    /// What the frame is.
    #[serde(default)]
    pub description: Option<String>,
    /// The body it is fixed on (its frame, after any Denavit–Hartenberg tail), or `base`.
    pub body: String,
    /// Fixed rotation from the body frame, roll–pitch–yaw in rad (URDF convention, fixed
    /// axes x, y, z); default none.
    #[serde(default)]
    #[schemars(with = "Option<Vec<Quantity>>")]
    pub rpy: Option<Vec<f64>>,
}

/// The task coordinates of the impedance controllers.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Task {
    /// The Cartesian position of this named point (2-D for planar models, 3-D for spatial).
    #[serde(default)]
    pub point: Option<String>,
    /// Or: these joint coordinates themselves (x = q, J = I).
    #[serde(default)]
    pub joints: Option<Vec<String>>,
}

/// Kind of sensor.
#[derive(Clone, Copy, Debug, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// Measures the operator's force f_l in task coordinates.
    Force,
}

/// A sensor besides the joint encoders.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    /// Name.
    pub name: String,
    /// `force`.
    pub kind: SensorKind,
    /// What it is (part number, mounting).
    #[serde(default)]
    pub description: Option<String>,
    /// Task units per raw sensor unit (e.g. N/V).
    #[schemars(with = "Quantity")]
    pub scale: f64,
    /// Raw reading at zero force.
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub offset: f64,
    /// Largest measurable magnitude, task units.
    #[schemars(with = "Quantity")]
    pub full_scale: f64,
    /// Standard deviation of the noise, task units (simulation only).
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub noise: f64,
    /// Resolution (quantisation step), task units (simulation only).
    #[serde(default)]
    #[schemars(with = "Quantity")]
    pub resolution: f64,
}

/// Sample rates.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Rates {
    /// Inner current loop, Hz (7500 in the paper).
    #[schemars(with = "WholeQuantity")]
    pub current_loop_hz: u32,
    /// Outer impedance loop, Hz.
    #[schemars(with = "WholeQuantity")]
    pub impedance_loop_hz: u32,
}

/// Design targets of the inner current loop (paper, section 2).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CurrentLoopSpec {
    /// Closed-loop bandwidth, Hz (700 in the paper).
    #[schemars(with = "Quantity")]
    pub bandwidth_hz: f64,
    /// Closed-loop damping ratio (slightly above 1: slightly overdamped).
    #[schemars(with = "Quantity")]
    pub damping_ratio: f64,
    /// Cut-off of the anti-aliasing (Bessel) filter on the current sense, Hz.
    #[schemars(with = "Quantity")]
    pub anti_alias_cutoff_hz: f64,
    /// Order of that Bessel filter, 1 to 4 (default 2).
    #[serde(default = "two")]
    #[schemars(with = "WholeQuantity")]
    pub anti_alias_filter_order: u32,
}

fn two() -> u32 {
    2
}

/// Haptic rendering settings (paper, section 4).
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Rendering {
    /// Spacing of the free-space anti-drift grid, m (0.3 mm in the paper).
    #[schemars(with = "Quantity")]
    pub grid_spacing: f64,
    /// Stiffness of virtual walls, N/m.
    #[schemars(with = "Quantity")]
    pub wall_stiffness: f64,
    /// Damping of virtual walls, N·s/m.
    #[schemars(with = "Quantity")]
    pub wall_damping: f64,
    /// Accept a wall stiffness beyond the passivity bound (you know what you are doing).
    #[serde(default)]
    pub allow_unstable_stiffness: bool,
}

/// A variant: a name and the values it overrides.
#[derive(Clone, Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    /// What distinguishes this variant.
    #[serde(default)]
    pub description: Option<String>,
    /// Values to replace, by dotted key path; list items are addressed by their `name`
    /// (e.g. `bodies.grip.mass: 0.1`, `drives.re40.gear_ratio: 25`, `gravity: [0, 0]`).
    #[serde(default)]
    pub set: BTreeMap<String, serde_json::Value>,
    /// Entries to delete, by dotted key path (e.g. `sensors.handle_force`).
    #[serde(default)]
    pub remove: Vec<String>,
}
