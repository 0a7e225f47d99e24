//! The catalogue of emitted functions: one [`FunctionSpec`] per quantity of eq. (1)–(2)
//! (`D`, `C`, `C q̇`, `g`, inverse dynamics, `V`, task `p`, `J`, `J̇`, `J̇ q̇`) and per named
//! point and frame, the outputs of the fused per-tick `terms`, and their operation counts.

use crate::dynamics::mechanics::Mechanics;
use crate::dynamics::recursive::{FrameQuantity, PointQuantity, Quantity};
use crate::model::Model;
use crate::plan::{output_roots, Output};
use crate::sym::dag::OpCounts;
use crate::sym::poly::Poly;

use super::literal::Scalar;
use super::lower::{BodyEmitter, EmitOptions};

/// The shape of a function's result.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// `S`.
    Scalar,
    /// `[S; n]`.
    Vector(usize),
    /// `[[S; cols]; rows]`.
    Matrix(usize, usize),
}

/// One emitted function: its name, documentation and output polynomials (row-major).
pub struct FunctionSpec<'a> {
    /// Rust name.
    pub name: String,
    /// Doc comment.
    pub doc: String,
    /// Result shape.
    pub shape: Shape,
    /// The outputs, row-major.
    pub outputs: Vec<Output<'a>>,
    /// Takes `qd` (the trait signature may require it even if unused).
    pub takes_qd: bool,
    /// Takes `qdd` (the inverse dynamics).
    pub takes_qdd: bool,
    /// Takes `measured`, the measured joints' angles (a frame a gimbal turns).
    pub takes_measured: bool,
    /// The task function with the same outputs (a function of the task's point), which this
    /// one calls instead of repeating its body.
    pub same_as: Option<String>,
}

/// Entries `0..len` of a quantity.
fn quantity(q: Quantity, len: usize) -> Vec<Output<'static>> {
    (0..len).map(|k| Output::Quantity(q, k)).collect()
}

/// The names of a function's outputs (row-major) as values: the function's quantity and the
/// entry's index (`inertia_01`, `gravity_2`, `tool_position_0`).
pub(crate) fn output_names(function: &str, shape: Shape) -> Vec<String> {
    let base = match function {
        "inertia_matrix" => "inertia",
        "coriolis_matrix" => "coriolis",
        "coriolis_times_qdot" => "coriolis_torque",
        "inverse_dynamics" => "torque",
        "jacobian_dot_times_qdot" => "jacobian_dot_qdot",
        other => other,
    };
    match shape {
        Shape::Scalar => vec![base.to_string()],
        Shape::Vector(n) => (0..n).map(|i| format!("{base}_{i}")).collect(),
        Shape::Matrix(rows, cols) => {
            let sep = if rows > 10 || cols > 10 { "_" } else { "" };
            (0..rows).flat_map(|r| (0..cols).map(move |c| format!("{base}_{r}{sep}{c}"))).collect()
        }
    }
}

/// A matrix of polynomials, row-major.
fn row_major(m: &[Vec<Poly>]) -> Vec<Output<'_>> {
    m.iter().flatten().map(Output::Poly).collect()
}

/// A list of polynomials.
fn each(list: &[Poly]) -> Vec<Output<'_>> {
    list.iter().map(Output::Poly).collect()
}

/// The task's position, Jacobian or `J̇ q̇`: a point's quantity, or joint-coordinate polynomials.
fn task(mech: &Mechanics, what: PointQuantity) -> Vec<Output<'_>> {
    let (m, n) = (mech.task_dim, mech.joints);
    match (mech.task_point, what) {
        (Some(i), PointQuantity::Jacobian) => quantity(Quantity::Point(i, what), m * n),
        (Some(i), _) => quantity(Quantity::Point(i, what), m),
        (None, PointQuantity::Position) => each(&mech.task.position),
        (None, PointQuantity::Jacobian) => row_major(&mech.task.jacobian),
        (None, PointQuantity::JacobianDotTimesQdot) => each(&mech.task.jacobian_dot_times_qdot),
    }
}

/// The specs of every per-quantity function (shared by emission and statistics).
pub fn function_specs<'a>(model: &Model, mech: &'a Mechanics) -> Vec<FunctionSpec<'a>> {
    let n = mech.joints;
    let m = mech.task_dim;
    let task_doc = match &model.task {
        crate::model::TaskSpec::Point(i) => format!("the point `{}`", model.points[*i].name),
        crate::model::TaskSpec::Joints(j) => format!(
            "the joint coordinates {}",
            j.iter().map(|&k| format!("`{}`", model.joints[k].name)).collect::<Vec<_>>().join(", ")
        ),
    };
    let mut specs = vec![
        FunctionSpec {
            name: "inertia_matrix".into(),
            doc: match model.coupling {
                None => " Inertia matrix `D(q)` of eq. (1), including the reflected rotor inertias `N² J_m`."
                    .into(),
                Some(_) => {
                    " Inertia matrix `D(q)` of eq. (1), including the rotor inertias reflected through the \
                            transmission, `Cᵀ diag(N² J_m) C`."
                        .into()
                }
            },
            shape: Shape::Matrix(n, n),
            outputs: quantity(Quantity::InertiaMatrix, n * n),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "coriolis_matrix".into(),
            doc: " Coriolis/centrifugal matrix `C(q, q̇)` of eq. (1), from the Christoffel symbols of `D`."
                .into(),
            shape: Shape::Matrix(n, n),
            outputs: quantity(Quantity::CoriolisMatrix, n * n),
            takes_qd: true,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "coriolis_times_qdot".into(),
            doc: " Coriolis and centrifugal torques `C(q, q̇) q̇`.".into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::CoriolisTimesQdot, n),
            takes_qd: true,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "gravity".into(),
            doc: " Gravity torques `g(q) = ∂V/∂q` of eq. (1).".into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::Gravity, n),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "inverse_dynamics".into(),
            doc:
                " Inverse dynamics of eq. (1) without damping and friction: `τ = D(q) q̈ + C(q, q̇) q̇ + g(q)`."
                    .into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::InverseDynamics, n),
            takes_qd: true,
            takes_qdd: true,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "potential_energy".into(),
            doc: " Gravitational potential energy `V(q)`, J (zero at the origin of the base frame).".into(),
            shape: Shape::Scalar,
            outputs: vec![Output::Poly(&mech.potential_energy)],
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "position".into(),
            doc: format!(" Task position `p(q)`: {task_doc}."),
            shape: Shape::Vector(m),
            outputs: task(mech, PointQuantity::Position),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "jacobian".into(),
            doc: " Task Jacobian `J(q) = ∂p/∂q` of eq. (2).".into(),
            shape: Shape::Matrix(m, n),
            outputs: task(mech, PointQuantity::Jacobian),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "jacobian_dot".into(),
            doc: " Time derivative of the task Jacobian `J̇(q, q̇)`.".into(),
            shape: Shape::Matrix(m, n),
            outputs: row_major(&mech.task.jacobian_dot),
            takes_qd: true,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
        FunctionSpec {
            name: "jacobian_dot_times_qdot".into(),
            doc: " `J̇(q, q̇) q̇`, the velocity term of eq. (2) and (4).".into(),
            shape: Shape::Vector(m),
            outputs: task(mech, PointQuantity::JacobianDotTimesQdot),
            takes_qd: true,
            takes_qdd: false,
            takes_measured: false,
            same_as: None,
        },
    ];
    for (index, (point, kin)) in model.points.iter().zip(&mech.points).enumerate() {
        let d = kin.position.len();
        let point_outputs = |what: PointQuantity, len: usize| quantity(Quantity::Point(index, what), len);
        let what = point.description.clone().unwrap_or_else(|| format!("point `{}`", point.name));
        // The task's own point: its functions are the task's `position`, `jacobian` and
        // `jacobian_dot_times_qdot`, which these call.
        let is_task = matches!(model.task, crate::model::TaskSpec::Point(i) if i == index) && d == m;
        let task_fn = |name: &'static str| is_task.then(|| name.to_string());
        // On a Delta's platform (its loops in closed form) every point moves as the platform's
        // origin: its Jacobian and `J̇ q̇` are those of the task's point if that is on the
        // platform too, else those of the first point on it.
        let on_platform = |i: usize| {
            mech.closures
                .as_ref()
                .and_then(|c| c.spatial.as_ref())
                .and_then(|s| s.closed_form.as_ref())
                .is_some_and(|closed_form| closed_form.platform_point(i).is_some())
        };
        let motion_fn = |what: &'static str| -> Option<String> {
            if is_task || !on_platform(index) {
                return task_fn(what);
            }
            match (mech.task_point, (0..model.points.len()).find(|&i| on_platform(i))) {
                (Some(task), _) if on_platform(task) && mech.points[task].position.len() == m => {
                    Some(what.to_string())
                }
                (_, Some(first)) if first != index => Some(format!("{}_{what}", model.points[first].name)),
                _ => None,
            }
        };
        specs.push(FunctionSpec {
            name: format!("{}_position", point.name),
            doc: format!(" Position of {what} in the base frame."),
            shape: Shape::Vector(d),
            outputs: point_outputs(PointQuantity::Position, d),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: task_fn("position"),
        });
        specs.push(FunctionSpec {
            name: format!("{}_jacobian", point.name),
            doc: format!(" Jacobian of the position of {what}."),
            shape: Shape::Matrix(d, n),
            outputs: point_outputs(PointQuantity::Jacobian, d * n),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: false,
            same_as: motion_fn("jacobian"),
        });
        specs.push(FunctionSpec {
            name: format!("{}_jacobian_dot_times_qdot", point.name),
            doc: format!(" `J̇ q̇` of {what}."),
            shape: Shape::Vector(d),
            outputs: point_outputs(PointQuantity::JacobianDotTimesQdot, d),
            takes_qd: true,
            takes_qdd: false,
            takes_measured: false,
            same_as: motion_fn("jacobian_dot_times_qdot"),
        });
    }
    // With measured joints (a gimbal), every frame takes their angles, and its `J_ω` has a
    // column per actuated joint, then per measured joint.
    let measured = !model.measured.is_empty();
    let columns = n + model.measured.len();
    let measured_note = if measured { ", `measured` the measured joints' angles" } else { "" };
    let jacobian_note = if measured {
        ", with `q̇` the actuated joints' velocities followed by the measured joints'"
    } else {
        ""
    };
    for (index, frame) in model.frames.iter().enumerate() {
        let what = frame.description.clone().unwrap_or_else(|| format!("frame `{}`", frame.name));
        specs.push(FunctionSpec {
            name: format!("{}_orientation", frame.name),
            doc: format!(" Orientation of {what}: the rotation matrix `R(q)` from the frame to the base frame (columns: its axes in base coordinates){}.", measured_note),
            shape: Shape::Matrix(3, 3),
            outputs: quantity(Quantity::Frame(index, FrameQuantity::Orientation), 9),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: measured,
            same_as: None,
        });
        specs.push(FunctionSpec {
            name: format!("{}_angular_jacobian", frame.name),
            doc: format!(" Angular-velocity Jacobian of {what}: `ω = J_ω(q) q̇` in base-frame coordinates (`Ṙ Rᵀ = [ω]×`){}.", jacobian_note),
            shape: Shape::Matrix(3, columns),
            outputs: quantity(Quantity::Frame(index, FrameQuantity::AngularJacobian), 3 * columns),
            takes_qd: false,
            takes_qdd: false,
            takes_measured: measured,
            same_as: None,
        });
    }
    specs
}

/// The outputs of the fused per-tick function, in the order of `RigTerms`' fields.
pub(crate) fn tick_outputs(mech: &Mechanics, include_position: bool) -> Vec<Output<'_>> {
    let n = mech.joints;
    let mut outputs = quantity(Quantity::InertiaMatrix, n * n);
    outputs.extend(quantity(Quantity::CoriolisTimesQdot, n));
    outputs.extend(quantity(Quantity::Gravity, n));
    if include_position {
        outputs.extend(task(mech, PointQuantity::Position));
    }
    outputs.extend(task(mech, PointQuantity::Jacobian));
    outputs.extend(task(mech, PointQuantity::JacobianDotTimesQdot));
    outputs
}

/// Operation counts of the quantities one control tick needs (D, C q̇, g, p, J, J̇ q̇),
/// computed together with shared subexpressions.
pub fn tick_counts(model: &Model, mech: &Mechanics, include_position: bool) -> OpCounts {
    tick_counts_with(model, mech, include_position, EmitOptions::default())
}

/// [`tick_counts`] for code emitted with `options` (with fused multiply-adds, they count once
/// in [`OpCounts::fused`]).
pub fn tick_counts_with(
    model: &Model,
    mech: &Mechanics,
    include_position: bool,
    options: EmitOptions,
) -> OpCounts {
    let mut body = BodyEmitter::new(model, mech, Scalar::F64, options);
    let roots = output_roots(&mut body.dag, model, mech, &tick_outputs(mech, include_position));
    body.dag.optimised_count_with(&roots, options.fused_multiply_add)
}
