//! The `points` and `frames` sections: named points on bodies (their positions are outputs)
//! and named frames (their orientations are outputs, spatial models only).

use std::collections::{HashMap, HashSet};

use super::{is_identifier, key, lookup_body, Resolver};
use crate::math::rotation::{rotation_rpy, snap};
use crate::model::positions::Segment;
use crate::model::schema::ModelFile;
use crate::model::types::{ResolvedFrame, ResolvedPoint};

/// Resolves the named points; returns them and their index by name.
pub(super) fn points(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
) -> (Vec<ResolvedPoint>, HashMap<String, usize>) {
    let dim = r.dim;
    // Points.
    let mut points = Vec::new();
    let mut point_index: HashMap<String, usize> = HashMap::new();
    for (i, p) in file.points.iter().enumerate() {
        let base = vec![key("points"), Segment::Index(i)];
        let at = |k: &str| {
            let mut q = base.clone();
            q.push(key(k));
            q
        };
        if !is_identifier(&p.name) {
            r.error(&at("name"), format!("`{}` is not a valid point name", p.name));
        }
        if point_index.insert(p.name.clone(), i).is_some() {
            r.error(&at("name"), format!("point `{}` is defined twice", p.name));
        }
        let Ok(body) = lookup_body(r, &p.body, &at("body"), &format!("point `{}`", p.name)) else {
            continue;
        };
        let (position, _) = r.vector(&p.position, dim, &at("position"));
        points.push(ResolvedPoint {
            name: p.name.clone(),
            description: p.description.clone(),
            body,
            position,
        });
    }

    (points, point_index)
}

/// Resolves the named frames (a frame's name must not clash with a point's).
pub(super) fn frames(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    point_index: &HashMap<String, usize>,
) -> Vec<ResolvedFrame> {
    let planar = r.planar;
    // Frames (orientation outputs).
    let mut frames = Vec::new();
    let mut frame_names = HashSet::new();
    for (i, f) in file.frames.iter().enumerate() {
        let base = vec![key("frames"), Segment::Index(i)];
        let at = |k: &str| {
            let mut q = base.clone();
            q.push(key(k));
            q
        };
        if planar {
            r.error_hint(
                &base,
                "frames (orientation outputs) need a spatial model",
                "a planar body's orientation is its angle about z; name a point for its position",
            );
            continue;
        }
        if !is_identifier(&f.name) {
            r.error(&at("name"), format!("`{}` is not a valid frame name", f.name));
        }
        if !frame_names.insert(f.name.clone()) {
            r.error(&at("name"), format!("frame `{}` is defined twice", f.name));
        }
        // `<frame>_angular_jacobian` must not be a point's `<point>_jacobian`.
        let clash = format!("{}_angular", f.name);
        if point_index.contains_key(&clash) {
            r.error_hint(
                &at("name"),
                format!(
                    "frame `{}` clashes with point `{clash}`: both would emit `{clash}_jacobian`",
                    f.name
                ),
                "rename the frame or the point",
            );
        }
        let Ok(body) = lookup_body(r, &f.body, &at("body"), &format!("frame `{}`", f.name)) else {
            continue;
        };
        let rotation = match f.rpy.as_deref() {
            None => snap(rotation_rpy([0.0; 3])),
            Some(&[roll, pitch, yaw]) => snap(rotation_rpy([roll, pitch, yaw])),
            Some(v) => {
                r.error(&at("rpy"), format!("expected 3 entries (roll, pitch, yaw), got {}", v.len()));
                snap(rotation_rpy([0.0; 3]))
            }
        };
        frames.push(ResolvedFrame {
            name: f.name.clone(),
            description: f.description.clone(),
            body,
            rotation,
        });
    }

    frames
}
