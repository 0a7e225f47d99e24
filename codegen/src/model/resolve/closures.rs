//! The `closures` section: each loop closure names two passive joints and two points that
//! coincide; every passive joint must be eliminated by exactly one closure.

use std::collections::{HashMap, HashSet};

use super::{is_identifier, key, lookup_joint, Resolver};
use crate::model::positions::Segment;
use crate::model::schema::{Branch, ModelFile};
use crate::model::types::ResolvedPoint;

/// A closure whose references resolved: file index, the two joints (file indices), the two
/// points, the branch.
pub(super) type DeclaredClosure = (usize, usize, usize, usize, usize, Branch);

/// Resolves the closures.
pub(super) fn closures(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    points: &[ResolvedPoint],
) -> Vec<DeclaredClosure> {
    let planar = r.planar;
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
                let Some(j) = lookup_joint(r, name, &path, &what) else { continue };
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
        if joint.passive && !closing.contains_key(&j) && !r.duplicate_joints.contains(&j) {
            r.error_hint(
                &[key("joints"), Segment::Index(j), key("passive")],
                format!("passive joint `{}` is not eliminated by any closure", joint.name),
                "list it in the `joints` of an entry of `closures`",
            );
        }
    }

    declared
}
