//! The `closures` section. Planar: each loop closure names two passive joints and two points
//! that coincide; every passive joint must be eliminated by exactly one closure. Spatial: each
//! names two points that coincide and optionally two perpendicular body axes; the passive
//! joints are eliminated by all of them together, and their count must match the equations
//! (the mobility count; which joints are redundant or missing is the analysis' matter, once
//! the loops are assembled).

use std::collections::{HashMap, HashSet};

use super::{is_identifier, key, lookup_body, lookup_joint, Resolver};
use crate::model::positions::Segment;
use crate::model::schema::{Branch, Closure, ModelFile};
use crate::model::types::{ResolvedPoint, SpatialClosure};

/// A closure whose references resolved: file index, the two joints (file indices), the two
/// points, the branch.
pub(super) type DeclaredClosure = (usize, usize, usize, usize, usize, Branch);

/// Resolves the closures: the planar ones, and the spatial ones (with the bodies of their
/// perpendicular axes as indices of the file's `bodies`, renumbered by the caller).
pub(super) fn closures(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    points: &[ResolvedPoint],
) -> (Vec<DeclaredClosure>, Vec<SpatialClosure>) {
    let planar = r.planar;
    if !planar {
        return (Vec::new(), spatial_closures(r, file, points));
    }
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
        for (k, present, hint) in
            [("perpendicular", c.perpendicular.is_some(), "a planar loop's links turn in the plane")]
        {
            if present {
                r.error_hint(&at(k), format!("`{k}` is for spatial closures"), hint);
            }
        }
        let Some(branch) = c.branch else {
            r.error_hint(
                &base,
                "missing key `branch`",
                "`branch: left` or `right`: on which side of the line from `joints[0]`'s axis to `joints[1]`'s the points meet",
            );
            continue;
        };
        let resolved_points = name_and_points(
            r,
            c,
            &base,
            &mut closure_names,
            points,
            "name the point of each joint's link that meets the other: `points: [left_tip, right_tip]`",
        );
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
        if let (&[j1, j2], &[p1, p2]) = (&resolved_joints[..], &resolved_points[..]) {
            if j1 == j2 {
                r.error(&at("joints"), "the two joints must differ");
            } else if p1 == p2 {
                r.error(&at("points"), "the two points must differ");
            } else {
                declared.push((i, j1, j2, p1, p2, branch));
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

    (declared, Vec::new())
}

/// The spatial closures, and the mobility count: the passive coordinates must be as many as
/// the closures' equations.
fn spatial_closures(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    points: &[ResolvedPoint],
) -> Vec<SpatialClosure> {
    let mut declared = Vec::new();
    let mut names = HashSet::new();
    for (i, c) in file.closures.iter().enumerate() {
        let base = vec![key("closures"), Segment::Index(i)];
        let at = |k: &str| {
            let mut p = base.clone();
            p.push(key(k));
            p
        };
        if !c.joints.is_empty() {
            r.error_hint(
                &at("joints"),
                "a spatial closure does not name joints",
                "the passive joints of all spatial closures are eliminated together; choose their assembly with each passive joint's `assembly` angle",
            );
        }
        if c.branch.is_some() {
            r.error_hint(
                &at("branch"),
                "a spatial closure has no `branch`",
                "choose the assembly with each passive joint's `assembly` angle",
            );
        }
        let what = format!("closure `{}`", c.name);
        let resolved_points = name_and_points(
            r,
            c,
            &base,
            &mut names,
            points,
            "name the two points that coincide where the loop is cut: `points: [shin2_end, platform_joint2]`",
        );
        let mut perpendicular = None;
        if let Some(axes) = &c.perpendicular {
            if axes.len() != 2 {
                r.error_hint(
                    &at("perpendicular"),
                    format!("expected 2 axes, got {}", axes.len()),
                    "name the two axes of the universal joint the closure cuts: `[{body: shin2, axis: [0, 0, 1]}, {body: platform, axis: [0, 1, 0]}]`",
                );
            } else {
                let mut resolved = Vec::new();
                for (k, a) in axes.iter().enumerate() {
                    let mut path = at("perpendicular");
                    path.push(Segment::Index(k));
                    let body = {
                        let mut p = path.clone();
                        p.push(key("body"));
                        lookup_body(r, &a.body, &p, &what)
                    };
                    let mut axis_path = path.clone();
                    axis_path.push(key("axis"));
                    let norm = a.axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if a.axis.len() != 3 {
                        r.error(&axis_path, format!("expected 3 entries, got {}", a.axis.len()));
                    } else if !(norm > 1e-9 && norm.is_finite()) {
                        r.error(&axis_path, "must be a finite, non-zero vector");
                    } else if let Ok(body) = body {
                        resolved.push((body, [a.axis[0] / norm, a.axis[1] / norm, a.axis[2] / norm]));
                    }
                }
                if let [first, second] = resolved[..] {
                    perpendicular = Some([first, second]);
                }
            }
        }
        if let &[p1, p2] = &resolved_points[..] {
            if p1 == p2 {
                r.error(&at("points"), "the two points must differ");
            } else {
                declared.push(SpatialClosure { name: c.name.clone(), points: [p1, p2], perpendicular });
            }
        }
    }
    // Mobility: the passive coordinates are the closures' unknowns.
    let passive: Vec<&str> = file.joints.iter().filter(|j| j.passive).map(|j| j.name.as_str()).collect();
    let equations: usize = declared.iter().map(SpatialClosure::equations).sum();
    if file.closures.is_empty() {
        if !passive.is_empty() {
            r.error_hint(
                &[key("joints")],
                format!("passive joints ({}) but no closure eliminates them", passive.join(", ")),
                "add the loop closures under `closures`",
            );
        }
    } else if declared.len() == file.closures.len() && equations != passive.len() {
        let (what, hint) = if equations > passive.len() {
            (
                "over-constrained",
                "each closure's points add 3 equations and `perpendicular` 1: cut fewer joints, or add the passive joints the loops need",
            )
        } else {
            (
                "under-constrained",
                "the loops leave passive joints free: add a `perpendicular` condition where a universal joint is cut, or make the free joints actuated",
            )
        };
        r.error_hint(
            &[key("closures")],
            format!(
                "the loops are {what}: {equations} constraint equations for {} passive joint coordinates ({})",
                passive.len(),
                passive.join(", ")
            ),
            hint,
        );
    }
    declared
}

/// What every closure is checked for: a valid name not used before, and two known points
/// (returned as indices; fewer if some are unknown or not two are named).
fn name_and_points(
    r: &mut Resolver<'_, '_>,
    c: &Closure,
    base: &[Segment],
    names: &mut HashSet<String>,
    points: &[ResolvedPoint],
    points_hint: &str,
) -> Vec<usize> {
    let at = |k: &str| {
        let mut p = base.to_vec();
        p.push(key(k));
        p
    };
    if !is_identifier(&c.name) {
        r.error(&at("name"), format!("`{}` is not a valid closure name", c.name));
    }
    if !names.insert(c.name.clone()) {
        r.error(&at("name"), format!("closure `{}` is defined twice", c.name));
    }
    if c.points.len() != 2 {
        r.error_hint(&at("points"), format!("expected 2 points, got {}", c.points.len()), points_hint);
        return Vec::new();
    }
    let mut resolved = Vec::new();
    for (k, name) in c.points.iter().enumerate() {
        let mut path = at("points");
        path.push(Segment::Index(k));
        match points.iter().position(|p| &p.name == name) {
            Some(p) => resolved.push(p),
            None => r.error_hint(
                &path,
                format!("closure `{}` references unknown point `{name}`", c.name),
                "name an entry of `points`",
            ),
        }
    }
    resolved
}
