//! URDF import: a URDF robot (a tree of links and joints) becomes a model file.
//!
//! The root link becomes `base` (the fixed ground; its inertia is dropped). Every other link
//! becomes a body placed by its parent joint's `<origin>` (`xyz` + `rpy`, the model's own
//! convention), moved by the joint (`revolute`, `continuous`, `prismatic`) or welded
//! (`fixed`). A massless leaf link on a fixed joint (a tool or sensor frame) becomes a named
//! point, or a named frame if its name starts with `frame_` (as `urdf::export` writes them). `<inertial>` gives mass, centre of mass and inertia; an inertial frame turned by `rpy`
//! is rotated into the link frame. `<dynamics damping>` becomes the joint's damping.
//!
//! URDF has no drives, gravity, task or loop rates: every joint gets its own drive, a copy of
//! the template (by default [`DEFAULT_DRIVE`]) whose torque limit is the joint's `effort`
//! when given; gravity is `[0, 0, −9.81]`; the task is the last named point (else the origin of
//! the last body); rates and current-loop targets are the paper's. The header of the written
//! model says so. What the format cannot express is an error naming the element, with its line
//! and column: floating and planar joints, a revolute `mimic` whose multiplier is not ±1 (a
//! `<mimic>` becomes a mimic joint, following its leader), several roots, a link with two parents
//! (a closed loop), massless moving links, joints without limits other than `continuous`
//! (which get ±π).

use std::collections::HashMap;
use std::fmt::Write as _;

use crate::diag::{Diagnostic, Diagnostics};
use crate::math::rotation::rotation_rpy;

/// The drive every imported joint gets unless a template is given (the paper's RE40-class
/// motor with a 12:1 gearhead), as the YAML of one entry of `drives`.
pub const DEFAULT_DRIVE: &str =
    "motor: {rotor_inertia: 1.42e-5, resistance: 0.299, inductance: 0.082e-3, torque_constant: 30.2e-3}
gear_ratio: 12.0
torque_limit: 3.0
current_limit: 8.28
supply_voltage: 24.0
encoder: {counts_per_turn: 2000}
";

struct Reader<'a> {
    file: &'a str,
    doc: &'a roxmltree::Document<'a>,
}

impl Reader<'_> {
    fn error(&self, node: roxmltree::Node<'_, '_>, message: impl Into<String>) -> Diagnostic {
        let pos = self.doc.text_pos_at(node.range().start);
        Diagnostic {
            file: self.file.to_string(),
            line: pos.row as usize,
            column: pos.col as usize,
            path: element_path(node),
            message: message.into(),
            hint: None,
        }
    }

    fn numbers<const N: usize>(
        &self,
        node: roxmltree::Node<'_, '_>,
        attribute: &str,
        default: [f64; N],
    ) -> Result<[f64; N], Diagnostic> {
        let Some(text) = node.attribute(attribute) else { return Ok(default) };
        let values: Vec<f64> = text
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| self.error(node, format!("`{attribute}=\"{text}\"`: expected {N} numbers")))?;
        let finite = values.iter().all(|v| v.is_finite());
        match <[f64; N]>::try_from(values) {
            Ok(v) if finite => Ok(v),
            _ => Err(self.error(node, format!("`{attribute}=\"{text}\"`: expected {N} finite numbers"))),
        }
    }

    fn number(&self, node: roxmltree::Node<'_, '_>, attribute: &str) -> Result<Option<f64>, Diagnostic> {
        match node.attribute(attribute) {
            None => Ok(None),
            Some(_) => Ok(Some(self.numbers::<1>(node, attribute, [0.0])?[0])),
        }
    }
}

/// `robot/joint[name=q1]/limit`, for diagnostics.
fn element_path(node: roxmltree::Node<'_, '_>) -> String {
    let mut parts = Vec::new();
    let mut current = Some(node);
    while let Some(n) = current {
        if n.is_element() {
            let name = n.tag_name().name();
            parts.push(match n.attribute("name") {
                Some(v) if name != "robot" => format!("{name}[name={v}]"),
                _ => name.to_string(),
            });
        }
        current = n.parent();
    }
    parts.reverse();
    parts.join("/")
}

fn child<'a, 'input>(node: roxmltree::Node<'a, 'input>, tag: &str) -> Option<roxmltree::Node<'a, 'input>> {
    node.children().find(|c| c.has_tag_name(tag))
}

/// A model identifier from a URDF name: lower case, other characters replaced by `_`.
fn identifier(name: &str) -> String {
    let mut out: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() { c.to_ascii_lowercase() } else { '_' }).collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

fn number(x: f64) -> String {
    let x = if x == 0.0 { 0.0 } else { x };
    format!("{x:?}")
}

fn list(v: &[f64]) -> String {
    format!("[{}]", v.iter().map(|x| number(*x)).collect::<Vec<_>>().join(", "))
}

struct Inertial {
    mass: f64,
    com: [f64; 3],
    /// ixx, iyy, izz, ixy, ixz, iyz in the link frame.
    inertia: [f64; 6],
}

struct Joint<'a, 'input> {
    node: roxmltree::Node<'a, 'input>,
    name: String,
    kind: &'static str,
    parent: String,
    child: String,
    /// `<mimic>`: its element, the leader's URDF name, the multiplier and the offset.
    mimic: Option<(roxmltree::Node<'a, 'input>, String, f64, f64)>,
}

/// Imports a URDF document; `file` names it in diagnostics, `drive` is the YAML of the drive
/// template (see [`DEFAULT_DRIVE`]). Returns the text of a model file.
pub fn import(text: &str, file: &str, drive: &str) -> Result<String, Diagnostics> {
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        Diagnostic {
            file: file.to_string(),
            line: pos.row as usize,
            column: pos.col as usize,
            path: String::new(),
            message: format!("invalid XML: {e}"),
            hint: None,
        }
    })?;
    let r = Reader { file, doc: &doc };
    let robot = doc.root_element();
    if !robot.has_tag_name("robot") {
        return Err(r.error(robot, "the root element must be <robot>").into());
    }
    let mut errors = Vec::new();

    // Links.
    let mut links: Vec<(String, roxmltree::Node<'_, '_>)> = Vec::new();
    for link in robot.children().filter(|c| c.has_tag_name("link")) {
        let Some(name) = link.attribute("name") else {
            errors.push(r.error(link, "a <link> needs a `name`"));
            continue;
        };
        links.push((name.to_string(), link));
    }
    let link_node: HashMap<&str, roxmltree::Node<'_, '_>> =
        links.iter().map(|(n, l)| (n.as_str(), *l)).collect();

    // Joints.
    let mut joints: Vec<Joint<'_, '_>> = Vec::new();
    for node in robot.children().filter(|c| c.has_tag_name("joint")) {
        let name = node.attribute("name").unwrap_or_default().to_string();
        let kind = match node.attribute("type").unwrap_or_default() {
            "revolute" => "revolute",
            "continuous" => "continuous",
            "prismatic" => "prismatic",
            "fixed" => "fixed",
            other @ ("floating" | "planar") => {
                errors.push(
                    r.error(
                        node,
                        format!("joint `{name}` is `{other}`: the model has single-axis joints only"),
                    )
                    .with_hint(
                        "replace it by revolute/prismatic joints (one per degree of freedom) or fix the link",
                    ),
                );
                continue;
            }
            other => {
                errors.push(r.error(node, format!("joint `{name}` has an unknown type `{other}`")));
                continue;
            }
        };
        let mimic = match child(node, "mimic") {
            None => None,
            Some(element) => {
                let Some(leader) = element.attribute("joint") else {
                    errors.push(r.error(element, format!("joint `{name}`: a <mimic> names its `joint`")));
                    continue;
                };
                let multiplier = r.number(element, "multiplier")?.unwrap_or(1.0);
                let offset = r.number(element, "offset")?.unwrap_or(0.0);
                if kind != "prismatic" && multiplier.abs() != 1.0 {
                    errors.push(
                        r.error(
                            element,
                            format!(
                                "joint `{name}` mimics `{leader}` with multiplier {multiplier}: a revolute mimic joint's multiplier must be 1 or -1"
                            ),
                        )
                        .with_hint("the model's kinematics are polynomials in the leader's sine and cosine; sin(k q) for other k is not one"),
                    );
                    continue;
                }
                Some((element, leader.to_string(), multiplier, offset))
            }
        };
        let parent = child(node, "parent").and_then(|p| p.attribute("link"));
        let child_link = child(node, "child").and_then(|p| p.attribute("link"));
        let (Some(parent), Some(child_link)) = (parent, child_link) else {
            errors.push(r.error(node, format!("joint `{name}` needs <parent link=…> and <child link=…>")));
            continue;
        };
        for l in [parent, child_link] {
            if !link_node.contains_key(l) {
                errors.push(r.error(node, format!("joint `{name}` names unknown link `{l}`")));
            }
        }
        joints.push(Joint {
            node,
            name,
            kind,
            parent: parent.to_string(),
            child: child_link.to_string(),
            mimic,
        });
    }

    // A mimic joint follows a moving joint that follows none (the model's leader is actuated).
    for j in &joints {
        let Some((element, leader, ..)) = &j.mimic else { continue };
        match joints.iter().find(|l| &l.name == leader) {
            Some(l)
                if l.mimic.is_none()
                    && l.kind != "fixed"
                    && (l.kind == "prismatic") == (j.kind == "prismatic") => {}
            Some(_) => errors.push(r.error(
                *element,
                format!(
                    "joint `{}` mimics `{leader}`, which is fixed, a mimic itself, or of another type",
                    j.name
                ),
            )),
            None => {
                errors.push(r.error(*element, format!("joint `{}` mimics unknown joint `{leader}`", j.name)))
            }
        }
    }

    // The tree: one parent joint per link, one root.
    let mut parent_joint: HashMap<&str, usize> = HashMap::new();
    for (i, j) in joints.iter().enumerate() {
        if let Some(&first) = parent_joint.get(j.child.as_str()) {
            errors.push(
                r.error(
                    j.node,
                    format!(
                        "link `{}` is the child of joints `{}` and `{}`: a closed kinematic loop",
                        j.child, joints[first].name, j.name
                    ),
                )
                .with_hint("closed chains cannot be imported; cut the loop at one joint"),
            );
        } else {
            parent_joint.insert(j.child.as_str(), i);
        }
    }
    let roots: Vec<&(String, roxmltree::Node<'_, '_>)> =
        links.iter().filter(|(n, _)| !parent_joint.contains_key(n.as_str())).collect();
    if roots.len() > 1 {
        let names: Vec<&str> = roots.iter().map(|(n, _)| n.as_str()).collect();
        errors.push(
            r.error(roots[1].1, format!("several root links: {}", names.join(", ")))
                .with_hint("a robot is one tree: connect every link to the base by a joint"),
        );
    }
    if roots.is_empty() && !links.is_empty() {
        errors.push(r.error(robot, "no root link: the joints form a loop"));
    }
    if !errors.is_empty() {
        return Err(Diagnostics(errors));
    }
    let Some((root, _)) = roots.first().map(|x| (x.0.as_str(), x.1)) else {
        return Err(r.error(robot, "the robot has no links").into());
    };

    // Bodies in tree order (parents first): breadth-first from the root.
    let mut order: Vec<&str> = vec![root];
    let mut k = 0;
    while k < order.len() {
        let current = order[k];
        for j in &joints {
            if j.parent == current {
                order.push(j.child.as_str());
            }
        }
        k += 1;
    }
    let has_children = |link: &str| joints.iter().any(|j| j.parent == link);
    let mut names: HashMap<String, String> = HashMap::new();
    let mut name_of = |urdf: &str| -> String {
        if urdf == root {
            return "base".into();
        }
        names.entry(urdf.to_string()).or_insert_with(|| identifier(urdf)).clone()
    };

    let mut joint_yaml = String::new();
    let mut body_yaml = String::new();
    let mut point_yaml = String::new();
    let mut frame_yaml = String::new();
    let mut drive_yaml = String::new();
    let mut last_point = None;
    let mut last_body = None;
    let mut seen = HashMap::new();
    let drive_lines: String = drive.lines().map(|l| format!("    {l}\n")).collect();
    for link in order.iter().skip(1) {
        let j = &joints[parent_joint[link]];
        let node = link_node[link];
        let body = name_of(link);
        let parent = name_of(&j.parent);
        if let Some(other) = seen.insert(body.clone(), link.to_string()) {
            errors.push(r.error(node, format!("links `{other}` and `{link}` both become `{body}`")));
            continue;
        }
        let origin = child(j.node, "origin");
        let (xyz, rpy) = match origin {
            Some(o) => (r.numbers::<3>(o, "xyz", [0.0; 3])?, r.numbers::<3>(o, "rpy", [0.0; 3])?),
            None => ([0.0; 3], [0.0; 3]),
        };
        let inertial = match child(node, "inertial") {
            None => None,
            Some(i) => {
                let (com, i_rpy) = match child(i, "origin") {
                    Some(o) => (r.numbers::<3>(o, "xyz", [0.0; 3])?, r.numbers::<3>(o, "rpy", [0.0; 3])?),
                    None => ([0.0; 3], [0.0; 3]),
                };
                let mass = match child(i, "mass") {
                    Some(m) => r.number(m, "value")?.unwrap_or(0.0),
                    None => 0.0,
                };
                let t = match child(i, "inertia") {
                    Some(t) => {
                        let get = |k: &str| r.number(t, k).map(|v| v.unwrap_or(0.0));
                        [get("ixx")?, get("iyy")?, get("izz")?, get("ixy")?, get("ixz")?, get("iyz")?]
                    }
                    None => [0.0; 6],
                };
                let m = [[t[0], t[3], t[4]], [t[3], t[1], t[5]], [t[4], t[5], t[2]]];
                let rot = rotation_rpy(i_rpy);
                let turned: [[f64; 3]; 3] = std::array::from_fn(|a| {
                    std::array::from_fn(|b| {
                        (0..3).map(|c| (0..3).map(|d| rot[a][c] * m[c][d] * rot[b][d]).sum::<f64>()).sum()
                    })
                });
                Some(Inertial {
                    mass,
                    com,
                    inertia: [
                        turned[0][0],
                        turned[1][1],
                        turned[2][2],
                        turned[0][1],
                        turned[0][2],
                        turned[1][2],
                    ],
                })
            }
        };
        let massless = inertial.as_ref().is_none_or(|i| i.mass == 0.0);
        if let (true, Some(frame)) =
            (massless && j.kind == "fixed" && !has_children(link), body.strip_prefix("frame_"))
        {
            // An orientation frame (as `export` writes them): a named frame; its origin's
            // translation is irrelevant, its rotation is the frame's `rpy`.
            let _ = writeln!(frame_yaml, "  - name: {frame}\n    body: {}\n    rpy: {}", parent, list(&rpy));
            continue;
        }
        if massless && j.kind == "fixed" && !has_children(link) {
            // A frame: a named point.
            let point = body.strip_prefix("point_").unwrap_or(&body).to_string();
            let carrier = parent.clone();
            // A point's orientation is irrelevant; its position is the joint origin.
            let _ =
                writeln!(point_yaml, "  - name: {point}\n    body: {carrier}\n    position: {}", list(&xyz));
            last_point = Some(point);
            continue;
        }
        let Some(inertial) = inertial.filter(|i| i.mass > 0.0) else {
            errors.push(
                r.error(node, format!("link `{link}` has no mass"))
                    .with_hint("every body of a model has a positive mass; give the link an <inertial>"),
            );
            continue;
        };
        let _ = writeln!(body_yaml, "  - name: {body}");
        let _ = writeln!(body_yaml, "    mass: {}", number(inertial.mass));
        let _ = writeln!(body_yaml, "    com: {}", list(&inertial.com));
        let t = inertial.inertia;
        let _ = writeln!(
            body_yaml,
            "    inertia: {{ixx: {}, iyy: {}, izz: {}, ixy: {}, ixz: {}, iyz: {}}}",
            number(t[0]),
            number(t[1]),
            number(t[2]),
            number(t[3]),
            number(t[4]),
            number(t[5])
        );
        let _ = writeln!(body_yaml, "    parent: {parent}");
        let _ = writeln!(body_yaml, "    origin: {{xyz: {}, rpy: {}}}", list(&xyz), list(&rpy));
        last_body = Some(body.clone());
        if j.kind == "fixed" {
            continue;
        }
        let joint_name = identifier(&j.name);
        let _ = writeln!(body_yaml, "    joint: {joint_name}");
        let axis = match child(j.node, "axis") {
            Some(a) => r.numbers::<3>(a, "xyz", [1.0, 0.0, 0.0])?,
            None => [1.0, 0.0, 0.0], // the URDF default
        };
        let limit = child(j.node, "limit");
        let (lower, upper) = match (j.kind, limit) {
            ("continuous", _) => (-std::f64::consts::PI, std::f64::consts::PI),
            (_, Some(l)) => (r.number(l, "lower")?.unwrap_or(0.0), r.number(l, "upper")?.unwrap_or(0.0)),
            (_, None) => {
                errors.push(r.error(j.node, format!("joint `{}` has no <limit>", j.name)));
                continue;
            }
        };
        let effort = limit.map(|l| r.number(l, "effort")).transpose()?.flatten().filter(|e| *e > 0.0);
        let damping = child(j.node, "dynamics").map(|d| r.number(d, "damping")).transpose()?.flatten();
        let _ = writeln!(joint_yaml, "  - name: {joint_name}");
        let _ = writeln!(
            joint_yaml,
            "    type: {}",
            if j.kind == "prismatic" { "prismatic" } else { "revolute" }
        );
        if j.kind == "continuous" {
            let _ = writeln!(joint_yaml, "    description: continuous in the URDF; limited to ±π here");
        }
        let _ = writeln!(joint_yaml, "    axis: {}", list(&axis));
        let _ = writeln!(joint_yaml, "    limits: {{lower: {}, upper: {}}}", number(lower), number(upper));
        if let Some((element, leader, multiplier, offset)) = &j.mimic {
            // A mimic joint: no drive of its own, and no damping (nothing drives it against one).
            if damping.is_some_and(|d| d != 0.0) {
                errors.push(
                    r.error(*element, format!("joint `{}` mimics `{leader}` and has damping", j.name))
                        .with_hint(
                            "a mimic joint has no damping of its own: model the friction at its leader",
                        ),
                );
            }
            let _ = writeln!(
                joint_yaml,
                "    mimic: {{joint: {}, multiplier: {}, offset: {}}}",
                identifier(leader),
                number(*multiplier),
                number(*offset)
            );
            continue;
        }
        if let Some(d) = damping.filter(|d| *d != 0.0) {
            let _ = writeln!(joint_yaml, "    damping: {}", number(d));
        }
        let _ = writeln!(joint_yaml, "    drive: {joint_name}_drive");
        let _ = writeln!(drive_yaml, "  {joint_name}_drive:");
        match effort {
            Some(e) => {
                let replaced: String = drive_lines
                    .lines()
                    .map(|l| {
                        if l.trim_start().starts_with("torque_limit:") {
                            format!("    torque_limit: {}\n", number(e))
                        } else {
                            format!("{l}\n")
                        }
                    })
                    .collect();
                drive_yaml.push_str(&replaced);
            }
            None => drive_yaml.push_str(&drive_lines),
        }
    }
    if !errors.is_empty() {
        return Err(Diagnostics(errors));
    }
    if joint_yaml.is_empty() {
        return Err(r.error(robot, "the robot has no moving joint").into());
    }
    let task = match (&last_point, &last_body) {
        (Some(p), _) => p.clone(),
        (None, Some(b)) => {
            let _ =
                writeln!(point_yaml, "  - name: {b}_origin\n    body: {b}\n    position: [0.0, 0.0, 0.0]");
            format!("{b}_origin")
        }
        (None, None) => return Err(r.error(robot, "the robot has no body").into()),
    };
    let robot_name = identifier(robot.attribute("name").unwrap_or("robot"));
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Imported by hapticgen {} from {file} (`hapticgen import-urdf`).",
        crate::version::VERSION
    );
    let _ = writeln!(
        out,
        "# Not in the URDF, set to defaults here — review them: gravity [0, 0, -9.81]; one drive per"
    );
    let _ = writeln!(
        out,
        "# joint from the drive template (torque limit = the joint's effort where given); the task"
    );
    let _ = writeln!(out, "# point `{task}`; the paper's loop rates and current-loop targets.");
    let _ = writeln!(out, "name: {robot_name}");
    let _ = writeln!(out, "description: imported from {}", file.replace(['\n', ':'], " "));
    let _ = writeln!(out, "space: spatial");
    let _ = writeln!(out, "gravity: [0.0, 0.0, -9.81]\n");
    let _ = writeln!(out, "drives:\n{drive_yaml}");
    let _ = writeln!(out, "joints:\n{joint_yaml}");
    let _ = writeln!(out, "bodies:\n{body_yaml}");
    if !point_yaml.is_empty() {
        let _ = writeln!(out, "points:\n{point_yaml}");
    }
    if !frame_yaml.is_empty() {
        let _ = writeln!(out, "frames:\n{frame_yaml}");
    }
    let _ = writeln!(out, "task:\n  point: {task}\n");
    let _ = writeln!(out, "rates:\n  current_loop_hz: 7500\n  impedance_loop_hz: 1000\n");
    let _ = write!(
        out,
        "current_loop:\n  bandwidth_hz: 700.0\n  damping_ratio: 1.05\n  anti_alias_cutoff_hz: 2500.0\n"
    );
    Ok(out)
}
