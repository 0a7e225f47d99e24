//! The resolved model: pure data, as the file describes the rig, with every value a
//! polynomial in the tunable parameters and every reference an index. Nothing here is
//! computed from the model (closure eliminations and current-loop designs are analyses,
//! [`crate::check::Analyses`], which travel beside it).

use super::schema::{Branch, CurrentLoopSpec, Drive, JointKind, Rates, Rendering, Sensor};
use crate::sym::poly::Poly;

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
    /// Origin at a point of another body; orientation: the plane's frame turned about its z
    /// axis by a coordinate (`R = R_plane_body · plane_rotation · Rz(q)`; planar models: the
    /// base, so `R = Rz(q)`).
    Direct {
        /// Body carrying the origin point, `None` for the base.
        origin_body: Option<usize>,
        /// The origin point in that body's frame.
        point: [Poly; 3],
        /// The coordinate giving the absolute angle.
        angle_joint: usize,
        /// Body whose frame carries the plane the angle turns in, `None` for the base.
        plane_body: Option<usize>,
        /// Fixed rotation from that body's frame to the plane's.
        plane_rotation: [[f64; 3]; 3],
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
    /// Passive joints of closed chains: coordinates `joints.len() + k` of the mechanics'
    /// open tree, eliminated by `closures`, not coordinates of the generated code.
    pub passive: Vec<PassiveJoint>,
    /// The loop closures of a planar closed chain, as declared (none for an open tree).
    pub closures: Vec<LoopClosure>,
    /// The loop closures of a spatial closed chain, as declared: their passive joints are
    /// eliminated together.
    pub spatial_closures: Vec<SpatialClosure>,
    /// The model's `transmission`, if it has one.
    pub coupling: Option<Coupling>,
    /// Measured passive joints: coordinates `tree_coordinates() + k` of the kinematics, inputs
    /// of the frame functions, not coordinates of the dynamics.
    pub measured: Vec<MeasuredJoint>,
    /// Mimic joints: numbered `tree_coordinates() + measured.len() + k` where a body names its
    /// joint, but no coordinate of anything (their angle is their leader's, scaled and offset).
    pub mimic: Vec<MimicJoint>,
}

/// A constant coupling between the joint coordinates and the drives' outputs, `a = C q`
/// (`hapticgen_runtime::Coupling`): drive `k` is the one in actuated joint `k`'s slot.
#[derive(Clone, Debug, PartialEq)]
pub struct Coupling {
    /// `C`, row-major: each drive's output angle per joint coordinate.
    pub drive_from_joint: Vec<Vec<f64>>,
    /// `C⁻¹`.
    pub joint_from_drive: Vec<Vec<f64>>,
}

/// A passive (unactuated) revolute joint of a closed chain.
#[derive(Clone, Debug)]
pub struct PassiveJoint {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Revolute, or (spatial loops only) prismatic.
    pub kind: JointKind,
    /// Unit axis in the joint frame (`[0, 0, ±1]` in planar models).
    pub axis: [f64; 3],
    /// Spatial closed chains: the angle (a prismatic joint's travel) in the file's assembly at
    /// the middle of the actuated ranges (where the elimination starts; 0 unless given).
    pub assembly: f64,
}

/// A measured passive joint: an encoder, no motor, outside any loop (a gimbal's joint); the
/// bodies it moves are massless (their mass lumped on the body carrying it).
#[derive(Clone, Debug)]
pub struct MeasuredJoint {
    /// Name of its angle.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
    /// Lower limit (rad or m): the range its encoder reading is trusted in.
    pub lower: f64,
    /// Upper limit.
    pub upper: f64,
    /// Encoder counts per turn of the joint (per metre for a prismatic joint).
    pub counts_per_turn: u32,
}

/// A mimic joint: its coordinate is `multiplier · q_leader + offset` (URDF's `<mimic>`); it has
/// no drive and is not a coordinate of the generated code.
#[derive(Clone, Debug)]
pub struct MimicJoint {
    /// Name.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// Revolute or prismatic (as its leader).
    pub kind: JointKind,
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
    /// The actuated joint it follows (its coordinate).
    pub leader: usize,
    /// ±1 for a revolute joint; any finite number for a prismatic one.
    pub multiplier: f64,
    /// rad or m.
    pub offset: f64,
}

/// A loop closure of a spatial closed chain as declared: two points coincide and, optionally,
/// two body axes stay perpendicular.
#[derive(Clone, Debug)]
pub struct SpatialClosure {
    /// The closure's name.
    pub name: String,
    /// The two points that coincide (indices into the model's points).
    pub points: [usize; 2],
    /// Two axes kept perpendicular: each a body (`None`: the base) and a unit direction in
    /// its frame.
    pub perpendicular: Option<[(Option<usize>, [f64; 3]); 2]>,
}

impl SpatialClosure {
    /// The number of scalar constraint equations: 3, and 1 more for a perpendicularity.
    pub fn equations(&self) -> usize {
        3 + usize::from(self.perpendicular.is_some())
    }
}

/// A loop closure as declared in the model file: two points, each on a link turned by one of
/// two passive joints, coincide.
#[derive(Clone, Debug)]
pub struct LoopClosure {
    /// The closure's name.
    pub name: String,
    /// The two passive joints, as coordinates of the open tree.
    pub joints: [usize; 2],
    /// The two points (indices into the model's points).
    pub points: [usize; 2],
    /// Which assembly.
    pub branch: Branch,
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

    /// The mimic joint a body's joint index `j` names, if it is one.
    pub fn mimic_joint(&self, j: usize) -> Option<&MimicJoint> {
        j.checked_sub(self.tree_coordinates() + self.measured.len()).and_then(|k| self.mimic.get(k))
    }

    /// Kind and axis of coordinate `j` of the kinematics (actuated, passive, measured, then
    /// mimic joints).
    pub fn coordinate_axis(&self, j: usize) -> (JointKind, [f64; 3]) {
        if let Some(joint) = self.joints.get(j) {
            return (joint.kind, joint.axis);
        }
        if let Some(p) = self.passive.get(j - self.joints.len()) {
            return (p.kind, p.axis);
        }
        if let Some(m) = self.measured.get(j - self.tree_coordinates()) {
            return (m.kind, m.axis);
        }
        self.mimic_joint(j).map_or((JointKind::Revolute, [0.0, 0.0, 1.0]), |m| (m.kind, m.axis))
    }

    /// Name of coordinate `j` of the kinematics.
    pub fn coordinate_name(&self, j: usize) -> &str {
        if let Some(joint) = self.joints.get(j) {
            return &joint.name;
        }
        if let Some(p) = self.passive.get(j - self.joints.len()) {
            return &p.name;
        }
        if let Some(m) = self.measured.get(j - self.tree_coordinates()) {
            return &m.name;
        }
        self.mimic_joint(j).map_or("passive", |m| m.name.as_str())
    }

    /// Nominal values of the tunable parameters.
    pub fn nominal_parameters(&self) -> Vec<f64> {
        self.tunable.iter().map(|p| p.value).collect()
    }
}
