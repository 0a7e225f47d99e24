//! The `task` section: the task coordinates are a named point's position or a list of
//! actuated joints.

use std::collections::HashSet;

use super::{key, lookup_joint, Resolver};
use crate::model::positions::Segment;
use crate::model::schema::ModelFile;
use crate::model::types::{ResolvedPoint, TaskSpec};

/// Resolves the task (joint references still as file indices).
pub(super) fn task(r: &mut Resolver<'_, '_>, file: &ModelFile, points: &[ResolvedPoint]) -> TaskSpec {
    // Task.
    match (&file.task.point, &file.task.joints) {
        (Some(name), None) => match points.iter().position(|p| &p.name == name) {
            Some(i) => TaskSpec::Point(i),
            None => {
                r.error_hint(
                    &[key("task"), key("point")],
                    format!("task references unknown point `{name}`"),
                    "name an entry of `points`",
                );
                TaskSpec::Joints(vec![])
            }
        },
        (None, Some(names)) => {
            let mut list = Vec::new();
            let mut seen = HashSet::new();
            for (i, name) in names.iter().enumerate() {
                let path = [key("task"), key("joints"), Segment::Index(i)];
                if let Some(j) = lookup_joint(r, name, &path, "task") {
                    if !seen.insert(j) {
                        r.error(&path, format!("joint `{name}` is listed twice"));
                    }
                    if file.joints[j].passive || file.joints[j].measured.is_some() {
                        r.error_hint(
                            &path,
                            format!("joint `{name}` is passive: a joint-space task uses actuated joints"),
                            "make the task a point (`task: {point: ...}`)",
                        );
                    }
                    list.push(j);
                }
            }
            if names.is_empty() {
                r.error(&[key("task"), key("joints")], "must list at least one joint");
            }
            TaskSpec::Joints(list)
        }
        _ => {
            r.error_hint(
                &[key("task")],
                "must have exactly one of `point` or `joints`",
                "e.g. `task: {point: end_effector}` or `task: {joints: [q]}`",
            );
            TaskSpec::Joints(vec![])
        }
    }
}
