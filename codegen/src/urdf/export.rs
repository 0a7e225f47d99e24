//! URDF export of serial models, for independent checks (Pinocchio) and other tools, and of a
//! closed chain's open tree ([`export_open_tree`]), for a tool that closes the loops itself.
//!
//! A URDF link's frame is its joint's frame, and a model body's frame is that too, except for
//! standard Denavit–Hartenberg links, whose frame lies a fixed `tail` (`Tx(a) · Rx(alpha)`)
//! beyond the joint. The export therefore writes each body as a link in its joint frame and
//! moves the tail into what is expressed in the body frame: the centre of mass and inertia
//! (`<inertial>`), the origins of child joints and the named points. Each named point becomes a
//! massless link `point_<name>` on a fixed joint, so that a URDF tool can ask for its frame
//! Jacobian; each named frame a massless link `frame_<name>` turned as the frame (after the
//! body's tail). Tunable parameters take their nominal values. What URDF has no place for (the
//! drives' rotor inertia, gear ratio and motor data, the task, the rates) is listed in a
//! comment at the top; viscous damping goes into `<dynamics damping>`.
//!
//! A URDF describes a tree, so it cannot state a closed chain's loops: [`export`] refuses closed
//! chains (what a user asking for the rig's URDF gets), and [`export_open_tree`] writes the tree
//! the loops were cut into (every joint, the passive ones included) and returns beside it what
//! the URDF leaves out: which joints are actuated and the cut closures ([`OpenTree`]).

use std::fmt::Write as _;

use crate::eval::NominalAtoms;
use crate::math::matrix::{mat3_mul, mat3_vec, transpose3, Numbers, IDENTITY};
use crate::math::rotation::rpy_of;
use crate::model::{FixedTransform, JointKind, Model, Motion};
use crate::sym::poly::Poly;

type Mat3 = [[f64; 3]; 3];

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    mat3_mul(&mut Numbers, a, b)
}

fn mat_vec(a: &Mat3, v: &[f64; 3]) -> [f64; 3] {
    mat3_vec(&mut Numbers, a, v)
}

fn number(x: f64) -> String {
    // Shortest representation that reads back to the same f64; −0 is written as 0.
    let x = if x == 0.0 { 0.0 } else { x };
    format!("{x:?}")
}

fn triple(v: &[f64; 3]) -> String {
    format!("{} {} {}", number(v[0]), number(v[1]), number(v[2]))
}

/// A rigid transform with nominal numbers.
#[derive(Clone, Copy)]
struct Transform {
    xyz: [f64; 3],
    rotation: Mat3,
}

impl Transform {
    const IDENTITY: Self = Transform { xyz: [0.0; 3], rotation: IDENTITY };

    fn then(&self, other: &Transform) -> Transform {
        let moved = mat_vec(&self.rotation, &other.xyz);
        Transform {
            xyz: std::array::from_fn(|i| self.xyz[i] + moved[i]),
            rotation: mat_mul(&self.rotation, &other.rotation),
        }
    }

    fn apply(&self, p: &[f64; 3]) -> [f64; 3] {
        let r = mat_vec(&self.rotation, p);
        std::array::from_fn(|i| self.xyz[i] + r[i])
    }

    fn origin_element(&self) -> String {
        format!("<origin xyz=\"{}\" rpy=\"{}\"/>", triple(&self.xyz), triple(&rpy_of(&self.rotation)))
    }
}

fn nominal(p: &Poly, parameters: &[f64]) -> f64 {
    p.eval(&NominalAtoms(parameters))
}

fn nominal3(v: &[Poly; 3], parameters: &[f64]) -> [f64; 3] {
    std::array::from_fn(|i| nominal(&v[i], parameters))
}

fn tail_transform(tail: &Option<Box<FixedTransform>>, parameters: &[f64]) -> Transform {
    match tail {
        None => Transform::IDENTITY,
        Some(t) => Transform { xyz: nominal3(&t.xyz, parameters), rotation: t.rotation },
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace("--", "- -")
}

/// The opening of a moving joint's element: its name, type, links, origin and axis.
struct JointHead<'a> {
    name: &'a str,
    kind: JointKind,
    axis: &'a [f64; 3],
}

impl JointHead<'_> {
    fn write(&self, out: &mut String, parent_link: &str, child_link: &str, origin: &Transform) {
        let kind = match self.kind {
            JointKind::Revolute => "revolute",
            JointKind::Prismatic => "prismatic",
        };
        let _ = writeln!(out, "  <joint name=\"{}\" type=\"{kind}\">", self.name);
        let _ = writeln!(out, "    <parent link=\"{parent_link}\"/>");
        let _ = writeln!(out, "    <child link=\"{child_link}\"/>");
        let _ = writeln!(out, "    {}", origin.origin_element());
        let _ = writeln!(out, "    <axis xyz=\"{}\"/>", triple(self.axis));
    }
}

/// The name of the URDF link that carries a named point.
pub fn point_link_name(point: &str) -> String {
    format!("point_{point}")
}

/// The name of the URDF link of a named (orientation) frame.
pub fn frame_link_name(frame: &str) -> String {
    format!("frame_{frame}")
}

/// Writes a serial model as URDF (the robot is named after the model). Closed chains (passive
/// joints) are rejected, and so are models with direct poses, closed chains in disguise, with a
/// message naming the body.
pub fn export(model: &Model) -> Result<String, String> {
    if let Some(passive) = model.passive.first() {
        return Err(format!(
            "joint `{}` is passive, part of a closed chain (`closures`): URDF describes trees of actuated joints",
            passive.name
        ));
    }
    write_tree(model)
}

/// A closed chain's open tree as URDF ([`export_open_tree`]), with what the URDF cannot state.
#[derive(Clone, Debug)]
pub struct OpenTree {
    /// The URDF: every body and joint of the tree, the passive joints as revolute joints.
    pub urdf: String,
    /// The URDF names of the tree's joints in the order of the mechanics' coordinates: the
    /// actuated joints (`q` of the generated code) first, then the passive ones.
    pub coordinates: Vec<String>,
    /// How many of `coordinates` are actuated (the first ones).
    pub actuated: usize,
    /// The loop closures that were cut, in the model's order.
    pub closures: Vec<CutClosure>,
}

/// One loop closure of an [`OpenTree`], in the URDF's terms: the two links (named points)
/// whose origins coincide when the loop is closed, and for a spatial closure that keeps two
/// body axes square, those axes.
#[derive(Clone, Debug)]
pub struct CutClosure {
    /// The closure's name in the model.
    pub name: String,
    /// The URDF links of the two points that coincide ([`point_link_name`]).
    pub point_links: [String; 2],
    /// Two axes kept perpendicular, if the closure asks for it: each the URDF link it is fixed
    /// in (`base` for the base) and its unit direction in that link's frame.
    pub perpendicular_axes: Option<[(String, [f64; 3]); 2]>,
}

/// Writes a closed chain's open tree as URDF: every joint of the tree, the passive ones
/// included (as revolute joints within ±π, which the model does not bound), with the loops cut
/// where the model's closures cut them. The URDF alone describes a different mechanism (the
/// tree's passive joints move freely); what closes it, which joints are actuated and the cut
/// closures, is returned beside it and listed in the URDF's top comment. A model without
/// closures is refused (use [`export`]).
pub fn export_open_tree(model: &Model) -> Result<OpenTree, String> {
    if model.passive.is_empty() {
        return Err("the model has no passive joints: it is serial, export it with `export`".to_string());
    }
    let parameters = model.nominal_parameters();
    let tails = serial_tails(model, &parameters)?;
    let link_of = |body: Option<usize>| match body {
        Some(b) => (model.bodies[b].name.clone(), tails[b]),
        None => ("base".to_string(), Transform::IDENTITY),
    };
    let point_links = |points: &[usize; 2]| points.map(|p| point_link_name(&model.points[p].name));
    let mut closures: Vec<CutClosure> = model
        .closures
        .iter()
        .map(|c| CutClosure {
            name: c.name.clone(),
            point_links: point_links(&c.points),
            perpendicular_axes: None,
        })
        .collect();
    closures.extend(model.spatial_closures.iter().map(|c| CutClosure {
        name: c.name.clone(),
        point_links: point_links(&c.points),
        perpendicular_axes: c.perpendicular.map(|axes| {
            axes.map(|(body, axis)| {
                // The axis is in the body frame; the link frame lies the body's tail before it.
                let (link, tail) = link_of(body);
                (link, mat_vec(&tail.rotation, &axis))
            })
        }),
    }));
    Ok(OpenTree {
        urdf: write_tree(model)?,
        coordinates: (0..model.tree_coordinates()).map(|j| model.coordinate_name(j).to_string()).collect(),
        actuated: model.joints.len(),
        closures,
    })
}

/// The tail of every body (identity but for standard DH links); an error for a directly
/// posed body.
fn serial_tails(model: &Model, parameters: &[f64]) -> Result<Vec<Transform>, String> {
    model
        .bodies
        .iter()
        .map(|body| match &body.motion {
            Motion::Serial { tail, .. } => Ok(tail_transform(tail, parameters)),
            Motion::Direct { .. } => Err(format!(
                "body `{}` is directly posed (`pose`): URDF describes trees of joints, and a directly posed body closes a loop",
                body.name
            )),
        })
        .collect()
}

/// The URDF of the model's tree: every body and joint (passive joints included), the named
/// points and frames.
fn write_tree(model: &Model) -> Result<String, String> {
    let parameters = model.nominal_parameters();
    let tails = serial_tails(model, &parameters)?;
    let mut out = String::new();
    let _ = writeln!(out, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        out,
        "<!-- @generated by hapticgen {} from {}",
        crate::version::VERSION,
        escape(&model.file)
    );
    if let Some(v) = &model.variant {
        let _ = writeln!(out, "     variant: {}", escape(v));
    }
    let _ =
        writeln!(out, "     gravity (m/s², base frame): {}", triple(&nominal3(&model.gravity, &parameters)));
    for joint in &model.joints {
        let d = &joint.drive;
        let _ = writeln!(
            out,
            "     joint {}: drive {}, gear ratio {}, rotor inertia {} kg·m² (adds N²·J_m = {} to D's diagonal; not part of URDF)",
            joint.name,
            escape(&joint.drive_name),
            number(d.gear_ratio),
            number(d.motor.rotor_inertia),
            number(d.gear_ratio * d.gear_ratio * d.motor.rotor_inertia)
        );
    }
    // A transmission couples the drives: its rows, and the rotor inertia it reflects, which
    // replaces the diagonal above (URDF's joints carry neither).
    if let Some(coupling) = &model.coupling {
        for (joint, row) in model.joints.iter().zip(&coupling.drive_from_joint) {
            let turns: Vec<String> = model
                .joints
                .iter()
                .zip(row)
                .filter(|(_, &ratio)| ratio != 0.0)
                .map(|(other, &ratio)| format!("{} {}", other.name, number(ratio)))
                .collect();
            let _ = writeln!(
                out,
                "     transmission: joint {}'s drive turns {} (not part of URDF)",
                joint.name,
                turns.join(", ")
            );
        }
        let reflected = crate::dynamics::reflected_rotor_inertia(model);
        let rows: Vec<String> = reflected
            .iter()
            .map(|row| row.iter().map(|&x| number(x)).collect::<Vec<_>>().join(" "))
            .collect();
        let _ = writeln!(
            out,
            "     reflected rotor inertia Cᵀ diag(N² J_m) C (adds to D instead): [{}]",
            rows.join("; ")
        );
    }
    for passive in &model.passive {
        let _ = writeln!(out, "     joint {}: passive (a closed chain's loop moves it)", passive.name);
    }
    for closure in &model.closures {
        let [a, b] = closure.points.map(|p| point_link_name(&model.points[p].name));
        let _ = writeln!(
            out,
            "     loop closure {} (cut; not part of URDF): {a} meets {b}",
            escape(&closure.name)
        );
    }
    for closure in &model.spatial_closures {
        let [a, b] = closure.points.map(|p| point_link_name(&model.points[p].name));
        let _ =
            write!(out, "     loop closure {} (cut; not part of URDF): {a} meets {b}", escape(&closure.name));
        if let Some(axes) = &closure.perpendicular {
            let [(x, u), (y, v)] =
                axes.map(|(body, axis)| (body.map_or("base", |b| model.bodies[b].name.as_str()), axis));
            let _ =
                write!(out, ", {x}'s axis ({}) square to {y}'s ({}) (body frames)", triple(&u), triple(&v));
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(out, "-->");
    let _ = writeln!(out, "<robot name=\"{}\">", model.name);
    let _ = writeln!(out, "  <link name=\"base\"/>");
    for (index, body) in model.bodies.iter().enumerate() {
        let Motion::Serial { parent, xyz, rotation, joint, .. } = &body.motion else { continue };
        let tail = tails[index];
        // Inertial properties in the link (joint) frame: tail · body frame.
        let com = tail.apply(&nominal3(&body.com, &parameters));
        let inertia: Mat3 =
            std::array::from_fn(|i| std::array::from_fn(|j| nominal(&body.inertia[i][j], &parameters)));
        let i_link = mat_mul(&mat_mul(&tail.rotation, &inertia), &transpose3(&tail.rotation));
        let _ = writeln!(out, "  <link name=\"{}\">", body.name);
        let _ = writeln!(out, "    <inertial>");
        let _ = writeln!(out, "      <origin xyz=\"{}\" rpy=\"0 0 0\"/>", triple(&com));
        let _ = writeln!(out, "      <mass value=\"{}\"/>", number(nominal(&body.mass, &parameters)));
        let _ = writeln!(
            out,
            "      <inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\"/>",
            number(i_link[0][0]),
            number(i_link[0][1]),
            number(i_link[0][2]),
            number(i_link[1][1]),
            number(i_link[1][2]),
            number(i_link[2][2])
        );
        let _ = writeln!(out, "    </inertial>");
        let _ = writeln!(out, "  </link>");
        // The joint from the parent's link frame: the parent's tail, then this origin.
        let (parent_link, parent_tail) = match parent {
            Some(p) => (model.bodies[*p].name.as_str(), tails[*p]),
            None => ("base", Transform::IDENTITY),
        };
        let origin = parent_tail.then(&Transform { xyz: nominal3(xyz, &parameters), rotation: *rotation });
        match joint.map(|j| (j, model.mimic_joint(j))) {
            Some((_, Some(mimic))) => {
                let head = JointHead { name: &mimic.name, kind: mimic.kind, axis: &mimic.axis };
                head.write(&mut out, parent_link, &body.name, &origin);
                let pi = number(std::f64::consts::PI);
                let _ = writeln!(
                    out,
                    "    <limit lower=\"-{pi}\" upper=\"{pi}\" effort=\"0.0\" velocity=\"100.0\"/>"
                );
                let _ = writeln!(
                    out,
                    "    <mimic joint=\"{}\" multiplier=\"{}\" offset=\"{}\"/>",
                    model.coordinate_name(mimic.leader),
                    number(mimic.multiplier),
                    number(mimic.offset)
                );
                let _ = writeln!(out, "  </joint>");
            }
            Some((j, None)) if j >= model.tree_coordinates() => {
                // A measured joint (a gimbal's): an encoder, no motor, its bodies massless.
                let measured = model.measured.get(j - model.tree_coordinates()).ok_or_else(|| {
                    format!("body `{}`: coordinate {j} is no joint of the model", body.name)
                })?;
                let head = JointHead { name: &measured.name, kind: measured.kind, axis: &measured.axis };
                head.write(&mut out, parent_link, &body.name, &origin);
                let _ = writeln!(
                    out,
                    "    <!-- measured: {} counts per turn, no motor -->",
                    measured.counts_per_turn
                );
                let _ = writeln!(
                    out,
                    "    <limit lower=\"{}\" upper=\"{}\" effort=\"0.0\" velocity=\"100.0\"/>",
                    number(measured.lower),
                    number(measured.upper)
                );
                let _ = writeln!(out, "  </joint>");
            }
            Some((j, None)) if j >= model.joints.len() => {
                // A passive joint of a closed chain's open tree: undamped, no drive.
                let passive = model.passive.get(j - model.joints.len()).ok_or_else(|| {
                    format!("body `{}`: coordinate {j} is neither an actuated nor a passive joint", body.name)
                })?;
                let head = JointHead { name: &passive.name, kind: passive.kind, axis: &passive.axis };
                head.write(&mut out, parent_link, &body.name, &origin);
                // The model bounds a passive joint by nothing; URDF requires limits (±π, read
                // as metres for a prismatic joint: wider than any rig's loops reach).
                let pi = number(std::f64::consts::PI);
                let _ = writeln!(
                    out,
                    "    <limit lower=\"-{pi}\" upper=\"{pi}\" effort=\"0.0\" velocity=\"100.0\"/>"
                );
                let _ = writeln!(out, "  </joint>");
            }
            Some((j, None)) => {
                let joint = &model.joints[j];
                let head = JointHead { name: &joint.name, kind: joint.kind, axis: &joint.axis };
                head.write(&mut out, parent_link, &body.name, &origin);
                // URDF requires a velocity limit; the model has none, so a generous one.
                let _ = writeln!(
                    out,
                    "    <limit lower=\"{}\" upper=\"{}\" effort=\"{}\" velocity=\"100.0\"/>",
                    number(joint.lower),
                    number(joint.upper),
                    number(joint.drive.torque_limit)
                );
                let damping = nominal(&joint.damping, &parameters);
                if damping != 0.0 {
                    let _ = writeln!(out, "    <dynamics damping=\"{}\"/>", number(damping));
                }
                let _ = writeln!(out, "  </joint>");
            }
            None => {
                let _ = writeln!(out, "  <joint name=\"{}_weld\" type=\"fixed\">", body.name);
                let _ = writeln!(out, "    <parent link=\"{parent_link}\"/>");
                let _ = writeln!(out, "    <child link=\"{}\"/>", body.name);
                let _ = writeln!(out, "    {}", origin.origin_element());
                let _ = writeln!(out, "  </joint>");
            }
        }
    }
    for point in &model.points {
        let (link, tail) = match point.body {
            Some(b) => (model.bodies[b].name.as_str(), tails[b]),
            None => ("base", Transform::IDENTITY),
        };
        let at = Transform { xyz: tail.apply(&nominal3(&point.position, &parameters)), rotation: IDENTITY };
        let name = point_link_name(&point.name);
        let _ = writeln!(out, "  <link name=\"{name}\"/>");
        let _ = writeln!(out, "  <joint name=\"{name}_joint\" type=\"fixed\">");
        let _ = writeln!(out, "    <parent link=\"{link}\"/>");
        let _ = writeln!(out, "    <child link=\"{name}\"/>");
        let _ = writeln!(out, "    {}", at.origin_element());
        let _ = writeln!(out, "  </joint>");
    }
    for frame in &model.frames {
        let (link, tail) = match frame.body {
            Some(b) => (model.bodies[b].name.as_str(), tails[b]),
            None => ("base", Transform::IDENTITY),
        };
        let at = tail.then(&Transform { xyz: [0.0; 3], rotation: frame.rotation });
        let name = frame_link_name(&frame.name);
        let _ = writeln!(out, "  <link name=\"{name}\"/>");
        let _ = writeln!(out, "  <joint name=\"{name}_joint\" type=\"fixed\">");
        let _ = writeln!(out, "    <parent link=\"{link}\"/>");
        let _ = writeln!(out, "    <child link=\"{name}\"/>");
        let _ = writeln!(out, "    {}", at.origin_element());
        let _ = writeln!(out, "  </joint>");
    }
    let _ = writeln!(out, "</robot>");
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_exactly() {
        for x in [0.1, -0.15005, std::f64::consts::FRAC_PI_2, 1e-17, -0.0] {
            let text = number(x);
            assert_eq!(text.parse::<f64>().unwrap(), if x == 0.0 { 0.0 } else { x });
        }
        assert_eq!(number(-0.0), "0.0");
    }
}
