//! Universal and spherical joints, each written as one entry of `joints`, expanded into what
//! they are mechanically: two or three passive revolute joints in series, joined by massless
//! crosses. The rest of the resolver, and the generator after it, see only one-coordinate
//! joints and ordinary bodies.
//!
//! A body moved by universal joint `u` (axes `a₁`, `a₂`, angles `u_1`, `u_2`) becomes
//!
//! ```text
//! parent ──origin──▶ u_cross  (massless, turned by u_1 about a₁)
//!        ──────────▶ body     (turned by u_2 about a₂)
//! ```
//!
//! so the body's orientation is `R(a₁, u_1) R(a₂, u_2)` relative to the joint frame: the first
//! axis is fixed in the parent, the last in the body, each axis given in the joint frame with
//! every angle zero. A spherical joint has two crosses and three angles, `R(a₁) R(a₂) R(a₃)`.
//! A cross has no mass, so it adds no term to the dynamics; its frame only carries the next
//! axis.
//!
//! Diagnostics stay where the user wrote the joint: [`Sources`] maps a path in the expanded
//! file (`joints[5].axis`) back to the entry it came from (`joints[2].axes[1]`).

use std::collections::{HashMap, HashSet};

use super::{key, Resolver};
use crate::math::vector::{cross, dot, norm};
use crate::model::positions::{KeyPath, Segment};
use crate::model::schema::{Assembly, Body, Inertia, InertiaTensor, Joint, JointType, ModelFile, Value};

/// Where an entry of the expanded `joints` list was written.
#[derive(Clone, Copy, Debug)]
struct JointSource {
    /// Index of the entry in the file's `joints`.
    index: usize,
    /// For an angle of a universal or spherical joint: which of its axes.
    axis: Option<usize>,
    /// The entry lists its angles' names in `coordinates` (else they are derived from `name`).
    named_coordinates: bool,
    /// The entry lists its axes (a spherical joint's default x, y, z is written nowhere).
    listed_axes: bool,
    /// The entry's `assembly` is a list, one angle per axis.
    listed_assembly: bool,
}

/// Where an entry of the expanded `bodies` list was written.
#[derive(Clone, Copy, Debug)]
struct BodySource {
    /// Index of the entry in the file's `bodies`.
    index: usize,
    /// The entry is a cross inserted for the universal or spherical joint that moves that body.
    cross: bool,
}

/// The map from the expanded file's joints and bodies to the entries the user wrote.
#[derive(Debug, Default)]
pub(super) struct Sources {
    joints: Vec<JointSource>,
    bodies: Vec<BodySource>,
    /// File index of each universal or spherical joint → its name and kind.
    compound_names: HashMap<usize, (String, &'static str)>,
}

impl Sources {
    /// The path of the file as written for a path of the expanded file (unchanged before the
    /// expansion, and for every section but `joints` and `bodies`).
    pub(super) fn original(&self, path: &[Segment]) -> KeyPath {
        match path {
            [Segment::Key(list), Segment::Index(k), rest @ ..] if list == "joints" => {
                let Some(source) = self.joints.get(*k) else {
                    return path.to_vec();
                };
                let mut original = vec![key("joints"), Segment::Index(source.index)];
                let listed = |name: &str, listed: bool, axis: usize| {
                    let mut p = vec![key(name)];
                    if listed {
                        p.push(Segment::Index(axis));
                    }
                    p
                };
                match (source.axis, rest.split_first()) {
                    (Some(axis), Some((Segment::Key(field), tail))) => {
                        let head = match field.as_str() {
                            "axis" => listed("axes", source.listed_axes, axis),
                            "assembly" => listed("assembly", source.listed_assembly, axis),
                            "name" if source.named_coordinates => {
                                vec![key("coordinates"), Segment::Index(axis)]
                            }
                            _ => vec![Segment::Key(field.clone())],
                        };
                        original.extend(head);
                        original.extend_from_slice(tail);
                    }
                    _ => original.extend_from_slice(rest),
                }
                original
            }
            [Segment::Key(list), Segment::Index(k), rest @ ..] if list == "bodies" => {
                let Some(source) = self.bodies.get(*k) else {
                    return path.to_vec();
                };
                let mut original = vec![key("bodies"), Segment::Index(source.index)];
                match rest.first() {
                    // A cross takes the body's parent and origin; whatever else is wrong with it
                    // comes from the joint the body names.
                    Some(Segment::Key(field)) if source.cross && field != "parent" && field != "origin" => {
                        original.push(key("joint"));
                    }
                    _ => original.extend_from_slice(rest),
                }
                original
            }
            _ => path.to_vec(),
        }
    }

    /// The file index of the entry the expanded file's joint `j` was written as.
    pub(super) fn joint_entry(&self, j: usize) -> usize {
        self.joints.get(j).map_or(j, |s| s.index)
    }

    /// How diagnostics name the expanded file's joint `j`, called `name` there: the universal
    /// or spherical joint it is an angle of, or the joint itself.
    pub(super) fn joint_label(&self, j: usize, name: &str) -> String {
        let compound = self.joints.get(j).and_then(|s| self.compound_names.get(&s.index));
        match compound {
            Some((joint, kind)) => format!("{kind} joint `{joint}`"),
            None => format!("joint `{name}`"),
        }
    }
}

/// The number of angles and the name of a universal or spherical joint.
fn compound(kind: JointType) -> Option<(usize, &'static str)> {
    match kind {
        JointType::Universal => Some((2, "universal")),
        JointType::Spherical => Some((3, "spherical")),
        JointType::Revolute | JointType::Prismatic => None,
    }
}

fn unit(v: &[f64]) -> Option<[f64; 3]> {
    let [x, y, z] = <[f64; 3]>::try_from(v).ok()?;
    let length = norm([x, y, z]);
    (length.is_finite() && length > 1e-9).then(|| [x / length, y / length, z / length])
}

/// Below this, the axes' cross product (universal) or triple product (spherical) makes the
/// joint lose a rotation: two axes parallel, or three in one plane.
const INDEPENDENT_AXES: f64 = 1e-6;

/// A universal or spherical joint's angles, as the expansion names them.
struct Angles {
    kind: &'static str,
    names: Vec<String>,
    /// Names of the crosses between consecutive angles.
    crosses: Vec<String>,
    /// The file index of the joint.
    entry: usize,
    /// The first body the joint moves (a second one is an error).
    moves: Option<usize>,
}

/// Expands the file's universal and spherical joints; errors are reported at the entries as
/// written (the resolver's sources are still empty while this runs).
pub(super) fn expand(r: &mut Resolver<'_, '_>, mut file: ModelFile) -> (ModelFile, Sources) {
    let mut sources = Sources::default();
    let mut joints = Vec::with_capacity(file.joints.len());
    let mut angles: HashMap<String, Angles> = HashMap::new();
    // Angle name → its joint's name, to refuse a body naming one angle of a universal joint.
    let mut angle_of: HashMap<String, String> = HashMap::new();
    for (i, j) in std::mem::take(&mut file.joints).into_iter().enumerate() {
        let at = |k: &str| vec![key("joints"), Segment::Index(i), key(k)];
        let Some((count, kind)) = compound(j.kind) else {
            let what = if j.kind == JointType::Prismatic { "prismatic" } else { "revolute" };
            if j.axes.is_some() {
                r.error_hint(
                    &at("axes"),
                    format!("a {what} joint has one `axis`"),
                    "`axes` lists the axes of a universal or spherical joint",
                );
            }
            if j.coordinates.is_some() {
                r.error_hint(
                    &at("coordinates"),
                    format!("a {what} joint is one coordinate, named by its `name`"),
                    "`coordinates` names the angles of a universal or spherical joint",
                );
            }
            let mut j = j;
            if let Some(Assembly::PerAxis(_)) = j.assembly {
                r.error_hint(
                    &at("assembly"),
                    format!("joint `{}` has one coordinate: its `assembly` is one number", j.name),
                    "a list gives one angle per axis of a universal or spherical joint",
                );
                j.assembly = None;
            }
            sources.joints.push(JointSource {
                index: i,
                axis: None,
                named_coordinates: false,
                listed_axes: false,
                listed_assembly: false,
            });
            joints.push(j);
            continue;
        };
        if r.planar {
            r.error_hint(
                &at("type"),
                format!("a {kind} joint needs a spatial model"),
                "a planar model's joints turn about z or slide in the plane; write `space: spatial`",
            );
        }
        if j.mimic.is_some() {
            r.error_hint(
                &at("mimic"),
                format!("{kind} joint `{}` cannot mimic a joint", j.name),
                "a mimic joint is one revolute or prismatic joint following one actuated joint",
            );
        } else if j.measured.is_some() {
            r.error_hint(
                &at("measured"),
                format!("{kind} joint `{}` cannot be measured", j.name),
                "write a measured gimbal as one revolute joint per axis, each with `measured`, and massless bodies between",
            );
        } else if !j.passive {
            r.error_hint(
                &[key("joints"), Segment::Index(i)],
                format!("{kind} joint `{}` must be passive", j.name),
                format!(
                    "add `passive: true`: a {kind} joint is {count} unactuated angles a loop closure eliminates; a motor drives one coordinate, written as its own revolute joint"
                ),
            );
        }
        if j.axis.is_some() {
            r.error_hint(
                &at("axis"),
                format!("a {kind} joint turns about {count} `axes`, not one `axis`"),
                "write `axes: [[x, y, z], ...]`, in the joint frame with every angle zero",
            );
        }
        let axes: Vec<Vec<f64>> = match (&j.axes, j.kind) {
            (Some(axes), _) => {
                if axes.len() != count {
                    r.error(&at("axes"), format!("a {kind} joint has {count} axes, got {}", axes.len()));
                }
                axes.clone()
            }
            (None, JointType::Spherical) => {
                vec![vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]]
            }
            (None, _) => {
                r.error_hint(
                    &[key("joints"), Segment::Index(i)],
                    "missing key `axes`",
                    "a universal joint turns about two axes: `axes: [[x, y, z], [x, y, z]]`, the first fixed in the parent, the second in the child",
                );
                Vec::new()
            }
        };
        let units: Option<Vec<[f64; 3]>> = axes.iter().map(|a| unit(a)).collect();
        if let Some(units) = units.filter(|u| u.len() == count) {
            let independence = match units.as_slice() {
                [a, b] => dot(cross(*a, *b), cross(*a, *b)).sqrt(),
                [a, b, c] => dot(cross(*a, *b), *c).abs(),
                _ => 1.0,
            };
            if independence < INDEPENDENT_AXES {
                r.error_hint(
                    &at("axes"),
                    format!(
                        "the axes of {kind} joint `{}` are {}: it would lose a rotation",
                        j.name,
                        if count == 2 { "parallel" } else { "in one plane" }
                    ),
                    if count == 2 {
                        "give two axes that are not parallel (a Cardan joint's are square to each other)"
                    } else {
                        "give three axes not in one plane (x, y and z, say)"
                    },
                );
            }
        }
        let names: Vec<String> = match &j.coordinates {
            Some(names) => {
                if names.len() != count {
                    r.error(
                        &at("coordinates"),
                        format!("a {kind} joint has {count} angles to name, got {}", names.len()),
                    );
                }
                names.clone()
            }
            None => (1..=count).map(|k| format!("{}_{k}", j.name)).collect(),
        };
        let assembly: Vec<f64> = match &j.assembly {
            None => vec![0.0; count],
            Some(Assembly::PerAxis(values)) if values.len() == count => values.clone(),
            Some(Assembly::PerAxis(values)) => {
                r.error(
                    &at("assembly"),
                    format!(
                        "a {kind} joint takes {count} assembly angles, one per axis, got {}",
                        values.len()
                    ),
                );
                vec![0.0; count]
            }
            Some(Assembly::Single(_)) => {
                r.error_hint(
                    &at("assembly"),
                    format!("a {kind} joint takes {count} assembly angles, one per axis"),
                    format!("write a list of {count} angles in rad, in the order of `axes`"),
                );
                vec![0.0; count]
            }
        };
        let crosses: Vec<String> = match count {
            2 => vec![format!("{}_cross", j.name)],
            _ => (1..count).map(|k| format!("{}_cross{k}", j.name)).collect(),
        };
        let what = j.description.clone().unwrap_or_else(|| format!("{kind} joint `{}`", j.name));
        // Padded (or cut) to the joint's count, so that the expanded file stays whole after an
        // error above; the resolution stops at the errors anyway.
        let angle_name = |m: usize| names.get(m).cloned().unwrap_or_else(|| format!("{}_{}", j.name, m + 1));
        for m in 0..count {
            angle_of.insert(angle_name(m), j.name.clone());
            sources.joints.push(JointSource {
                index: i,
                axis: Some(m),
                named_coordinates: j.coordinates.is_some(),
                listed_axes: j.axes.is_some(),
                listed_assembly: matches!(j.assembly, Some(Assembly::PerAxis(_))),
            });
            joints.push(Joint {
                name: angle_name(m),
                kind: JointType::Revolute,
                description: Some(format!("{what}: angle {} of {count}", m + 1)),
                axis: Some(axes.get(m).cloned().unwrap_or_else(|| vec![0.0, 0.0, 1.0])),
                axes: None,
                coordinates: None,
                limits: j.limits.clone(),
                damping: j.damping.clone(),
                drive: j.drive.clone(),
                passive: true,
                assembly: Some(Assembly::Single(assembly.get(m).copied().unwrap_or(0.0))),
                measured: None,
                mimic: None,
            });
        }
        sources.compound_names.insert(i, (j.name.clone(), kind));
        let names = (0..count).map(angle_name).collect();
        angles.insert(j.name.clone(), Angles { kind, names, crosses, entry: i, moves: None });
    }
    file.joints = joints;

    let single_joints: HashSet<&str> = file
        .joints
        .iter()
        .zip(&sources.joints)
        .filter(|(_, s)| s.axis.is_none())
        .map(|(j, _)| j.name.as_str())
        .collect();
    let body_names: HashSet<String> = file.bodies.iter().map(|b| b.name.clone()).collect();
    let mut bodies = Vec::with_capacity(file.bodies.len());
    let zero = || Value::Number(0.0);
    for (i, mut b) in std::mem::take(&mut file.bodies).into_iter().enumerate() {
        let at = |k: &str| vec![key("bodies"), Segment::Index(i), key(k)];
        let named = b.joint.clone().unwrap_or_default();
        if let Some(joint) = angle_of.get(&named).filter(|_| !single_joints.contains(named.as_str())) {
            r.error_hint(
                &at("joint"),
                format!("`{named}` is an angle of joint `{joint}`, not a joint"),
                format!("name the joint: `joint: {joint}`"),
            );
        }
        let Some(compound) = angles.get_mut(&named).filter(|_| b.parent.is_some()) else {
            sources.bodies.push(BodySource { index: i, cross: false });
            bodies.push(b);
            continue;
        };
        if let Some(first) = compound.moves {
            r.error(
                &at("joint"),
                format!(
                    "{} joint `{named}` already moves body `{}`; a joint moves one body",
                    compound.kind,
                    bodies_name(&bodies, &sources, first)
                ),
            );
            b.joint = None;
            sources.bodies.push(BodySource { index: i, cross: false });
            bodies.push(b);
            continue;
        }
        compound.moves = Some(i);
        if b.dh.is_some() {
            r.error_hint(
                &at("dh"),
                format!("body `{}` is moved by {} joint `{named}`: it cannot be placed with `dh`", b.name, compound.kind),
                "a Denavit–Hartenberg joint turns about z; place the body with `origin` and give the joint's `axes`",
            );
        }
        for cross_name in &compound.crosses {
            if body_names.contains(cross_name) {
                r.error_hint(
                    &[key("joints"), Segment::Index(compound.entry), key("name")],
                    format!(
                        "{} joint `{named}` needs a massless body `{cross_name}` for its cross, and a body of that name exists",
                        compound.kind
                    ),
                    "rename that body or the joint",
                );
            }
        }
        let mut parent = b.parent.take();
        let mut origin = b.origin.take();
        for (k, cross_name) in compound.crosses.iter().enumerate() {
            let com = vec![zero(); r.dim];
            let inertia = if r.planar {
                Inertia::Scalar(zero())
            } else {
                Inertia::Tensor(InertiaTensor {
                    ixx: zero(),
                    iyy: zero(),
                    izz: zero(),
                    ixy: None,
                    ixz: None,
                    iyz: None,
                })
            };
            sources.bodies.push(BodySource { index: i, cross: true });
            bodies.push(Body {
                name: cross_name.clone(),
                description: Some(format!("the massless cross of {} joint `{named}`", compound.kind)),
                mass: zero(),
                com,
                inertia,
                parent: parent.replace(cross_name.clone()),
                origin: origin.take(),
                dh: None,
                joint: Some(compound.names[k].clone()),
                pose: None,
            });
        }
        b.parent = parent;
        b.joint = compound.names.last().cloned();
        sources.bodies.push(BodySource { index: i, cross: false });
        bodies.push(b);
    }
    file.bodies = bodies;
    (file, sources)
}

/// The name of the body written as entry `entry` of the file's `bodies`, from the expanded list.
fn bodies_name<'a>(bodies: &'a [Body], sources: &Sources, entry: usize) -> &'a str {
    sources
        .bodies
        .iter()
        .zip(bodies)
        .find(|(s, _)| s.index == entry && !s.cross)
        .map_or("", |(_, b)| b.name.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The axes are normalised before the independence test: scaled axes are the same axes.
    #[test]
    fn axes_are_normalised_by_their_length() {
        assert_eq!(unit(&[3.0, 4.0, 0.0]), Some([0.6, 0.8, 0.0]));
        assert_eq!(unit(&[0.0, 0.0, -2.0e-3]), Some([0.0, 0.0, -1.0]));
        assert_eq!(unit(&[0.0, 0.0, 0.0]), None);
        assert_eq!(unit(&[1.0, 2.0]), None);
        assert_eq!(unit(&[f64::NAN, 0.0, 1.0]), None);
    }

    /// The products the independence test is made of, worked out by hand.
    #[test]
    fn cross_and_dot_products_by_hand() {
        assert_eq!(cross([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]), [-3.0, 6.0, -3.0]);
        assert_eq!(cross([2.0, -1.0, 0.5], [1.0, 2.0, 3.0]), [-4.0, -5.5, 5.0]);
        assert_eq!(dot([1.0, 2.0, 3.0], [4.0, -5.0, 6.0]), 12.0);
    }
}
