//! The `joints` section: names, limits, axes and drives of the actuated joints, the passive
//! joints of closed chains, the measured passive joints (an encoder, no motor), the mimic
//! joints (following another joint), and the index of each joint (actuated first, then
//! passive, measured, mimic).

use super::{is_identifier, key, Resolver};
use crate::model::positions::Segment;
use crate::model::schema::{Assembly, JointKind, ModelFile};
use crate::model::types::{MeasuredJoint, MimicJoint, PassiveJoint, ResolvedJoint};
use crate::sym::poly::Poly;

/// The resolved joints: actuated, passive, and each file joint's coordinate.
pub(super) struct Joints {
    /// The actuated joints, in file order.
    pub(super) actuated: Vec<ResolvedJoint>,
    /// The passive joints, in file order.
    pub(super) passive: Vec<PassiveJoint>,
    /// The measured joints, in file order.
    pub(super) measured: Vec<MeasuredJoint>,
    /// The mimic joints, in file order.
    pub(super) mimic: Vec<MimicJoint>,
    /// The index of each joint of the file: actuated first, then passive, measured, mimic.
    pub(super) coordinate_of: Vec<usize>,
}

/// Resolves the joints; fills the resolver's joint index for later references.
pub(super) fn joints(r: &mut Resolver<'_, '_>, file: &ModelFile) -> Joints {
    let planar = r.planar;
    // Joints.
    let mut joints = Vec::new();
    let mut passive = Vec::new();
    let mut measured = Vec::new();
    // Mimic joints with their leader's file index, renumbered once every index is known.
    let mut mimic: Vec<(MimicJoint, usize)> = Vec::new();
    if file.joints.is_empty() {
        r.error(&[key("joints")], "a model needs at least one joint");
    }
    for (i, j) in file.joints.iter().enumerate() {
        // Universal and spherical joints are revolute joints by now (`compound`).
        let kind = j.kind.single().unwrap_or(JointKind::Revolute);
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
                "use snake_case letters, digits and underscores, starting with a letter",
            );
        }
        if let Some(first) = r.joint_index.get(&j.name) {
            r.duplicate_joints.push(i);
            r.error_hint(
                &at("name"),
                format!("joint `{}` is defined twice", j.name),
                format!("the first definition is `joints[{}]`", r.sources.joint_entry(*first)),
            );
        } else {
            r.joint_index.insert(j.name.clone(), i);
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
            None if j.passive || j.measured.is_some() || j.mimic.is_some() => {
                (-std::f64::consts::PI, std::f64::consts::PI)
            }
            None => {
                r.error(&base, "missing key `limits`");
                (0.0, 0.0)
            }
        };
        if let Some(follows) = &j.mimic {
            for (present, field) in [
                (j.passive, "passive"),
                (j.drive.is_some(), "drive"),
                (j.damping.is_some(), "damping"),
                (j.assembly.is_some(), "assembly"),
                (j.measured.is_some(), "measured"),
            ] {
                if present {
                    r.error_hint(
                        &at(field),
                        format!("joint `{}` mimics `{}`: it takes no `{field}`", j.name, follows.joint),
                        "a mimic joint turns with its leader, which the leader's drive moves",
                    );
                }
            }
        } else if let Some(m) = &j.measured {
            for (present, field, why) in [
                (j.passive, "passive", "a measured joint is outside every loop; a loop's passive joints are eliminated, not measured"),
                (j.drive.is_some(), "drive", "a measured joint has an encoder and no motor: remove `drive`, or `measured` if a motor turns it"),
                (j.damping.is_some(), "damping", "its bodies are lumped out of the dynamics (`dynamics: lumped`), so nothing would feel it"),
                (j.assembly.is_some(), "assembly", "only a loop's passive joints have an assembly angle"),
            ] {
                if present {
                    r.error_hint(&at(field), format!("joint `{}` is measured: it takes no `{field}`", j.name), why);
                }
            }
            if m.counts_per_turn == 0 {
                r.error(
                    &[key("joints"), Segment::Index(i), key("measured"), key("counts_per_turn")],
                    "must be positive",
                );
            }
        } else if j.passive {
            let label = r.sources.joint_label(i, &j.name);
            if j.drive.is_some() {
                r.error_hint(
                    &at("drive"),
                    format!("{label} is passive: it has no drive"),
                    "remove `drive`, or `passive: true` if a motor turns the joint",
                );
            }
            if j.damping.is_some() {
                r.error_hint(
                    &at("damping"),
                    format!("{label} is passive: damping of passive joints is not supported"),
                    "model the friction at the actuated joints",
                );
            }
            // A planar closure's closed form intersects two circles: its passive joints turn.
            // Spatial loops are solved numerically over any coordinate.
            if planar && kind != JointKind::Revolute {
                r.error_hint(
                    &at("type"),
                    format!("passive joint `{}` of a planar loop must be revolute", j.name),
                    "a planar closure eliminates the two revolute joints of a dyad in closed form; a spatial model's loops may have passive prismatic joints",
                );
            }
            if planar && j.assembly.is_some() {
                r.error_hint(
                    &at("assembly"),
                    format!("joint `{}` is in a planar loop: it has no `assembly` angle", j.name),
                    "a planar closure chooses its assembly with `branch`",
                );
            }
        } else if j.assembly.is_some() {
            r.error_hint(
                &at("assembly"),
                format!("joint `{}` is actuated: only passive joints have an `assembly` angle", j.name),
                "the elimination starts from the middle of the actuated joints' ranges",
            );
        }
        let assembly = match j.assembly {
            Some(Assembly::Single(value)) => value,
            // A list on a one-coordinate joint is refused by `compound`.
            Some(Assembly::PerAxis(_)) | None => 0.0,
        };
        if !assembly.is_finite() {
            let what = if kind == JointKind::Prismatic { "a finite travel" } else { "a finite angle" };
            r.error(&at("assembly"), format!("must be {what}"));
        }
        let damping = match &j.damping {
            Some(v) => {
                let (poly, x) = r.value(v, &at("damping"));
                r.non_negative(x, &at("damping"));
                poly
            }
            None => Poly::zero(),
        };
        let drive = match (&j.drive, j.passive || j.measured.is_some() || j.mimic.is_some()) {
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
        let axis = match (&j.axis, planar, kind) {
            (None, true, JointKind::Revolute) => [0.0, 0.0, 1.0],
            (None, true, JointKind::Prismatic) => [1.0, 0.0, 0.0],
            (None, false, _) => [0.0, 0.0, 1.0],
            (Some(a), _, _) => {
                let full: Option<[f64; 3]> = match (a.len(), planar, kind) {
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
                            if planar && kind == JointKind::Revolute && (u[0] != 0.0 || u[1] != 0.0) {
                                r.error_hint(
                                    &at("axis"),
                                    "a planar revolute joint turns about z",
                                    "use [0, 0, 1] or [0, 0, -1]",
                                );
                            }
                            if planar && kind == JointKind::Prismatic && u[2] != 0.0 {
                                r.error(&at("axis"), "a planar prismatic joint slides in the x–y plane");
                            }
                            u
                        }
                    }
                }
            }
        };
        if let (Some(follows), None) = (&j.mimic, &drive) {
            let mimic_at = |k: &str| {
                let mut p = at("mimic");
                p.push(key(k));
                p
            };
            let leader = file.joints.iter().position(|l| l.name == follows.joint);
            let leader = match leader {
                Some(l) if file.joints[l].drive.is_some() && file.joints[l].mimic.is_none() => {
                    if file.joints[l].kind != j.kind {
                        r.error(
                            &mimic_at("joint"),
                            format!(
                                "joint `{}` and its leader `{}` are not of one type",
                                j.name, follows.joint
                            ),
                        );
                    }
                    l
                }
                _ => {
                    r.error_hint(
                        &mimic_at("joint"),
                        format!("joint `{}` mimics `{}`, which is no actuated joint", j.name, follows.joint),
                        "a mimic joint follows an actuated joint (one with a `drive`)",
                    );
                    continue;
                }
            };
            let multiplier = follows.multiplier.unwrap_or(1.0);
            let offset = follows.offset.unwrap_or(0.0);
            if !multiplier.is_finite() || !offset.is_finite() {
                r.error(&at("mimic"), "multiplier and offset must be finite");
            } else if kind == JointKind::Revolute && multiplier.abs() != 1.0 {
                r.error_hint(
                    &mimic_at("multiplier"),
                    format!("a revolute mimic joint's multiplier must be 1 or -1, not {multiplier}"),
                    "the kinematics are polynomials in the leader's sine and cosine: sin(k q) for other k is not one",
                );
            }
            mimic.push((
                MimicJoint {
                    name: j.name.clone(),
                    description: j.description.clone(),
                    kind,
                    axis,
                    leader: 0,
                    multiplier,
                    offset,
                },
                leader,
            ));
            continue;
        }
        if let (Some(m), None) = (&j.measured, &drive) {
            measured.push(MeasuredJoint {
                name: j.name.clone(),
                description: j.description.clone(),
                kind,
                axis,
                lower,
                upper,
                counts_per_turn: m.counts_per_turn,
            });
            continue;
        }
        let Some(drive) = drive else {
            passive.push(PassiveJoint {
                name: j.name.clone(),
                description: j.description.clone(),
                kind,
                axis,
                assembly,
            });
            continue;
        };
        joints.push(ResolvedJoint {
            name: j.name.clone(),
            kind,
            description: j.description.clone(),
            axis,
            lower,
            upper,
            damping,
            drive_name: j.drive.clone().unwrap_or_default(),
            drive,
        });
    }
    // Coordinates: the actuated joints in file order, then the passive ones, then the
    // measured ones.
    let is_mimic = |j: &crate::model::schema::Joint| j.mimic.is_some();
    let is_measured = |j: &crate::model::schema::Joint| j.measured.is_some() && !is_mimic(j);
    let is_passive = |j: &crate::model::schema::Joint| j.passive && !is_measured(j) && !is_mimic(j);
    let count =
        |pred: &dyn Fn(&crate::model::schema::Joint) -> bool| file.joints.iter().filter(|j| pred(j)).count();
    let (passive_count, measured_count) = (count(&is_passive), count(&is_measured));
    let actuated_count = file.joints.len() - passive_count - measured_count - count(&is_mimic);
    let coordinate_of: Vec<usize> = {
        let mut a = 0;
        let mut p = actuated_count;
        let mut m = actuated_count + passive_count;
        let mut f = actuated_count + passive_count + measured_count;
        file.joints
            .iter()
            .map(|j| {
                let slot = if is_mimic(j) {
                    &mut f
                } else if is_measured(j) {
                    &mut m
                } else if is_passive(j) {
                    &mut p
                } else {
                    &mut a
                };
                *slot += 1;
                *slot - 1
            })
            .collect()
    };
    let mimic = mimic
        .into_iter()
        .map(|(joint, leader)| MimicJoint { leader: coordinate_of[leader], ..joint })
        .collect();

    Joints { actuated: joints, passive, measured, mimic, coordinate_of }
}
