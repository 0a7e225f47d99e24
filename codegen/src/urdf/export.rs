//! URDF export of serial models, for independent checks (Pinocchio) and other tools.
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

use std::fmt::Write as _;

use crate::eval::NominalAtoms;
use crate::model::{FixedTransform, JointKind, Model, Motion};
use crate::sym::poly::Poly;

type Mat3 = [[f64; 3]; 3];

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn mat_vec(a: &Mat3, v: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

fn transpose(a: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Roll, pitch, yaw (URDF: `R = Rz(yaw) · Ry(pitch) · Rx(roll)`) of a rotation matrix.
pub fn rpy_of(r: &Mat3) -> [f64; 3] {
    let pitch = (-r[2][0]).atan2((r[0][0] * r[0][0] + r[1][0] * r[1][0]).sqrt());
    if (r[0][0] * r[0][0] + r[1][0] * r[1][0]).sqrt() < 1e-12 {
        // Gimbal lock: roll and yaw turn about the same axis; put it all in yaw.
        return [0.0, pitch, (-r[0][1]).atan2(r[1][1])];
    }
    [r[2][1].atan2(r[2][2]), pitch, r[1][0].atan2(r[0][0])]
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

/// The name of the URDF link that carries a named point.
pub fn point_link_name(point: &str) -> String {
    format!("point_{point}")
}

/// The name of the URDF link of a named (orientation) frame.
pub fn frame_link_name(frame: &str) -> String {
    format!("frame_{frame}")
}

/// Writes a serial model as URDF (the robot is named after the model). Models with direct
/// poses are closed chains in disguise and are rejected with a message naming the body.
pub fn export(model: &Model) -> Result<String, String> {
    if let Some(passive) = model.passive.first() {
        return Err(format!(
            "joint `{}` is passive, part of a closed chain (`closures`): URDF describes trees of actuated joints",
            passive.name
        ));
    }
    let parameters = model.nominal_parameters();
    let mut tails = Vec::with_capacity(model.bodies.len());
    for body in &model.bodies {
        match &body.motion {
            Motion::Serial { tail, .. } => tails.push(tail_transform(tail, &parameters)),
            Motion::Direct { .. } => {
                return Err(format!(
                    "body `{}` is directly posed (`pose`): URDF describes trees of joints, and a directly posed body closes a loop",
                    body.name
                ))
            }
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "<?xml version=\"1.0\"?>");
    let _ = writeln!(out, "<!-- @generated by hapticgen {} from {}", crate::VERSION, escape(&model.file));
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
        let i_link = mat_mul(&mat_mul(&tail.rotation, &inertia), &transpose(&tail.rotation));
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
        match joint {
            Some(j) => {
                let joint = &model.joints[*j];
                let kind = match joint.kind {
                    JointKind::Revolute => "revolute",
                    JointKind::Prismatic => "prismatic",
                };
                let _ = writeln!(out, "  <joint name=\"{}\" type=\"{kind}\">", joint.name);
                let _ = writeln!(out, "    <parent link=\"{parent_link}\"/>");
                let _ = writeln!(out, "    <child link=\"{}\"/>", body.name);
                let _ = writeln!(out, "    {}", origin.origin_element());
                let _ = writeln!(out, "    <axis xyz=\"{}\"/>", triple(&joint.axis));
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

    fn rpy_matrix(rpy: [f64; 3]) -> Mat3 {
        let (sr, cr) = rpy[0].sin_cos();
        let (sp, cp) = rpy[1].sin_cos();
        let (sy, cy) = rpy[2].sin_cos();
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    }

    #[test]
    fn rpy_round_trips_including_gimbal_lock() {
        for rpy in
            [[0.3, -0.2, 1.1], [-2.0, 1.2, 3.0], [0.4, std::f64::consts::FRAC_PI_2, -0.7], [0.0, 0.0, 0.0]]
        {
            let r = rpy_matrix(rpy);
            let back = rpy_matrix(rpy_of(&r));
            for i in 0..3 {
                for j in 0..3 {
                    assert!((r[i][j] - back[i][j]).abs() < 1e-12, "{rpy:?}: entry {i}{j}");
                }
            }
        }
    }

    #[test]
    fn numbers_read_back_exactly() {
        for x in [0.1, -0.15005, std::f64::consts::FRAC_PI_2, 1e-17, -0.0] {
            let text = number(x);
            assert_eq!(text.parse::<f64>().unwrap(), if x == 0.0 { 0.0 } else { x });
        }
        assert_eq!(number(-0.0), "0.0");
    }
}
