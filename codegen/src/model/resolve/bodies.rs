//! The `bodies` section: masses, centres of mass and inertia tensors (positive definite,
//! triangle inequality), how each body moves (serial: parent, origin or Denavit–Hartenberg
//! parameters, joint; direct: a point of another body and an absolute angle), the dependency
//! order of the bodies (cycles are errors) and their reindexing in that order.

use super::{dh_axis, is_identifier, key, lookup_body, lookup_joint, Resolver};
use crate::math::eigen::symmetric_eigenvalues_3x3;
use crate::math::matrix::{mat3_mul, Numbers};
use crate::math::rotation::{exact_sin_cos, rotation_rpy, rotation_x, rotation_z, snap};
use crate::model::positions::Segment;
use crate::model::schema::{DhConvention, Inertia, InertiaShape, JointType, ModelFile, Value};
use crate::model::types::{FixedTransform, Motion, ResolvedBody, ResolvedFrame, ResolvedPoint, TaskSpec};
use crate::sym::poly::Poly;
use std::collections::HashMap;

/// Resolves the bodies (`None` where a body could not be resolved) and, for each, the bodies
/// it is placed from (its parent, or its pose's origin body and plane body).
pub(super) fn bodies(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
) -> (Vec<Option<ResolvedBody>>, Vec<Vec<usize>>) {
    let (planar, dim) = (r.planar, r.dim);
    // Bodies: names first, so that references can point forwards.
    for (i, b) in file.bodies.iter().enumerate() {
        let path = [key("bodies"), Segment::Index(i), key("name")];
        if b.name == "base" {
            r.error_hint(&path, "`base` is reserved for the fixed ground", "rename the body");
        } else if !is_identifier(&b.name) {
            r.error(&path, format!("`{}` is not a valid body name", b.name));
        }
        if r.body_index.insert(b.name.clone(), i).is_some() {
            r.error(&path, format!("body `{}` is defined twice", b.name));
        }
    }
    if file.bodies.is_empty() {
        r.error(&[key("bodies")], "a model needs at least one body");
    }
    let mut bodies: Vec<Option<ResolvedBody>> = Vec::new();
    let mut depends_on: Vec<Vec<usize>> = Vec::new();
    let mut serial_joint_users: HashMap<usize, usize> = HashMap::new();
    let mut joint_used = vec![false; file.joints.len()];
    for (i, b) in file.bodies.iter().enumerate() {
        let base = vec![key("bodies"), Segment::Index(i)];
        let at = |k: &[&str]| {
            let mut p = base.clone();
            p.extend(k.iter().map(|s| key(s)));
            p
        };
        let what = format!("body `{}`", b.name);
        let (mass, mass_nominal) = r.value(&b.mass, &at(&["mass"]));
        // A massless body is the cross of a universal joint (two passive revolute joints):
        // the loops' elimination gives the reduced inertia, whose definiteness is checked there.
        // So is a body a measured joint moves (its mass lumped on the body carrying the joint;
        // `lumped_bodies` requires it massless).
        let moved_by_passive_joint = b.joint.as_ref().is_some_and(|name| {
            file.joints.iter().any(|j| &j.name == name && (j.passive || j.measured.is_some()))
        });
        if !(mass_nominal == 0.0 && moved_by_passive_joint) {
            r.positive(mass_nominal, &at(&["mass"]));
        }
        let (com, _) = r.vector(&b.com, dim, &at(&["com"]));
        let zero = || Poly::zero();
        let mut inertia = [[zero(), zero(), zero()], [zero(), zero(), zero()], [zero(), zero(), zero()]];
        match (&b.inertia, planar) {
            (Inertia::Scalar(v), true) => {
                let (poly, x) = r.value(v, &at(&["inertia"]));
                r.non_negative(x, &at(&["inertia"]));
                inertia[2][2] = poly;
            }
            (Inertia::SlenderRod(rod), true) => {
                let (length, x) = r.value(&rod.slender_rod, &at(&["inertia", "slender_rod"]));
                r.positive(x, &at(&["inertia", "slender_rod"]));
                inertia[2][2] = mass.mul(&length).mul(&length).scale(1.0 / 12.0);
            }
            (Inertia::Shape(shape), _) => {
                if let Some(unit) = shape_inertia(r, shape, &at(&["inertia"])) {
                    for (i, row) in unit.iter().enumerate() {
                        for (j, c) in row.iter().enumerate() {
                            // A planar model keeps the moment about z.
                            if !planar || (i == 2 && j == 2) {
                                inertia[i][j] = if *c == 0.0 { Poly::zero() } else { mass.scale(*c) };
                            }
                        }
                    }
                }
            }
            (Inertia::Tensor(t), false) => {
                let entries: [(&str, Option<&Value>); 6] = [
                    ("ixx", Some(&t.ixx)),
                    ("iyy", Some(&t.iyy)),
                    ("izz", Some(&t.izz)),
                    ("ixy", t.ixy.as_ref()),
                    ("ixz", t.ixz.as_ref()),
                    ("iyz", t.iyz.as_ref()),
                ];
                let mut nominal = [0.0; 6];
                let mut polys: Vec<Poly> = Vec::new();
                for (k, (name, v)) in entries.iter().enumerate() {
                    match v {
                        Some(v) => {
                            let (poly, x) = r.value(v, &at(&["inertia", name]));
                            polys.push(poly);
                            nominal[k] = x;
                        }
                        None => polys.push(Poly::zero()),
                    }
                }
                let m = [
                    [nominal[0], nominal[3], nominal[4]],
                    [nominal[3], nominal[1], nominal[5]],
                    [nominal[4], nominal[5], nominal[2]],
                ];
                let e = symmetric_eigenvalues_3x3(m);
                if e[0] < -1e-12 * e[2].abs().max(1e-30) {
                    r.error_hint(
                        &at(&["inertia"]),
                        format!(
                            "invalid inertia tensor: not positive semi-definite (principal moments {:.6e}, {:.6e}, {:.6e})",
                            e[0], e[1], e[2]
                        ),
                        "an inertia tensor about the centre of mass is symmetric positive (semi-)definite",
                    );
                } else if e[0] + e[1] < e[2] * (1.0 - 1e-9) {
                    r.error_hint(
                        &at(&["inertia"]),
                        format!(
                            "invalid inertia tensor: principal moments {:.6e}, {:.6e}, {:.6e} violate the triangle inequality",
                            e[0], e[1], e[2]
                        ),
                        "for a real body each principal moment is at most the sum of the other two",
                    );
                }
                let [ixx, iyy, izz, ixy, ixz, iyz] = <[Poly; 6]>::try_from(polys).unwrap_or_default();
                inertia = [[ixx, ixy.clone(), ixz.clone()], [ixy, iyy, iyz.clone()], [ixz, iyz, izz]];
            }
            (_, true) => r.error_hint(
                &at(&["inertia"]),
                "a planar model takes a scalar inertia about z",
                "write a number, or `{slender_rod: LENGTH}`",
            ),
            (_, false) => r.error_hint(
                &at(&["inertia"]),
                "invalid inertia: a spatial model takes a full tensor",
                "write `{ixx, iyy, izz, ixy, ixz, iyz}` about the centre of mass, in body axes",
            ),
        }

        let motion = match (&b.parent, &b.pose) {
            (Some(_), Some(_)) | (None, None) => {
                r.error_hint(
                    &base,
                    format!("{what} must have exactly one of `parent` (serial chain) or `pose` (direct pose)"),
                    "a serial body names `parent`, optional `origin` and `joint`; a directly posed body names `pose`",
                );
                depends_on.push(Vec::new());
                bodies.push(None);
                continue;
            }
            (Some(parent), None) => {
                let Ok(parent_index) = lookup_body(r, parent, &at(&["parent"]), &what) else {
                    depends_on.push(Vec::new());
                    bodies.push(None);
                    continue;
                };
                let mut tail = None;
                let (xyz, rotation) = match (&b.origin, &b.dh) {
                    (Some(_), Some(_)) => {
                        r.error_hint(
                            &at(&["dh"]),
                            format!("{what} has both `origin` and `dh`"),
                            "place a body with either `origin` (xyz, rpy) or `dh` (Denavit–Hartenberg parameters)",
                        );
                        ([zero(), zero(), zero()], snap(rotation_rpy([0.0; 3])))
                    }
                    (None, Some(dh)) => {
                        if planar {
                            r.error_hint(
                                &at(&["dh"]),
                                "Denavit–Hartenberg parameters need a spatial model",
                                "use `origin: {xyz, rpy}` in a planar model, or `space: spatial`",
                            );
                        }
                        let length = |r: &mut Resolver<'_, '_>, v: &Option<Value>, k: &str| match v {
                            Some(v) => r.value(v, &at(&["dh", k])).0,
                            None => zero(),
                        };
                        let a = length(r, &dh.a, "a");
                        let d = length(r, &dh.d, "d");
                        let (alpha, theta) = (dh.alpha.unwrap_or(0.0), dh.theta.unwrap_or(0.0));
                        let (s_alpha, c_alpha) = exact_sin_cos(alpha);
                        match dh.convention {
                            DhConvention::Standard => {
                                tail = Some(Box::new(FixedTransform {
                                    xyz: [a, zero(), zero()],
                                    rotation: rotation_x(alpha),
                                }));
                                ([zero(), zero(), d], rotation_z(theta))
                            }
                            DhConvention::Modified => {
                                // Rx(α)·Tx(a)·Rz(θ)·Tz(d) = Trans(a, −d sin α, d cos α)·Rx(α)Rz(θ).
                                let rotation =
                                    snap(mat3_mul(&mut Numbers, &rotation_x(alpha), &rotation_z(theta)));
                                ([a, d.scale(-s_alpha), d.scale(c_alpha)], rotation)
                            }
                        }
                    }
                    (None, None) => ([zero(), zero(), zero()], snap(rotation_rpy([0.0; 3]))),
                    (Some(o), None) => {
                        let xyz = match &o.xyz {
                            Some(v) => r.vector(v, dim, &at(&["origin", "xyz"])).0,
                            None => [zero(), zero(), zero()],
                        };
                        let rpy = match (&o.rpy, planar) {
                            (None, _) => [0.0; 3],
                            (Some(v), true) if v.len() == 1 => [0.0, 0.0, v[0]],
                            (Some(v), false) if v.len() == 3 => [v[0], v[1], v[2]],
                            (Some(v), _) => {
                                r.error(
                                    &at(&["origin", "rpy"]),
                                    format!(
                                        "expected {} entries, got {}",
                                        if planar { "1 (the angle about z)" } else { "3 (roll, pitch, yaw)" },
                                        v.len()
                                    ),
                                );
                                [0.0; 3]
                            }
                        };
                        (xyz, snap(rotation_rpy(rpy)))
                    }
                };
                let joint = match &b.joint {
                    None => None,
                    Some(name) => {
                        let j = lookup_joint(r, name, &at(&["joint"]), &what);
                        if let Some(j) = j {
                            joint_used[j] = true;
                            if b.dh.is_some() && !dh_axis(&file.joints[j].axis) {
                                r.error_hint(
                                    &[key("joints"), Segment::Index(j), key("axis")],
                                    format!(
                                        "joint `{name}` moves body `{}`, placed with Denavit–Hartenberg parameters: its axis must be z",
                                        b.name
                                    ),
                                    "a DH joint turns about (or slides along) z: remove `axis` or write [0.0, 0.0, 1.0]; orient the frame with `theta` and `alpha`",
                                );
                            }
                            if let Some(other) = serial_joint_users.insert(j, i) {
                                r.error(
                                    &at(&["joint"]),
                                    format!(
                                        "joint `{name}` already moves body `{}`; a serial joint moves one body",
                                        file.bodies[other].name
                                    ),
                                );
                            }
                        }
                        j
                    }
                };
                depends_on.push(parent_index.into_iter().collect());
                Motion::Serial { parent: parent_index, xyz, rotation, joint, tail }
            }
            (None, Some(pose)) => {
                if b.dh.is_some() {
                    r.error_hint(
                        &at(&["dh"]),
                        format!("{what} is directly posed: `dh` applies to serial bodies only"),
                        "a serial body names `parent`, then `dh` (or `origin`) and `joint`",
                    );
                }
                let Ok(origin_body) =
                    lookup_body(r, &pose.origin.body, &at(&["pose", "origin", "body"]), &what)
                else {
                    depends_on.push(Vec::new());
                    bodies.push(None);
                    continue;
                };
                let (plane_body, plane_rotation) = match (&pose.plane, planar) {
                    (None, true) => (None, snap(rotation_rpy([0.0; 3]))),
                    (Some(_), true) => {
                        r.error_hint(
                            &at(&["pose", "plane"]),
                            format!("{what}: a planar model's direct pose turns in the base plane"),
                            "remove `plane`; it places the angle of a spatial model's direct pose",
                        );
                        (None, snap(rotation_rpy([0.0; 3])))
                    }
                    (None, false) => {
                        r.error_hint(
                            &at(&["pose"]),
                            format!("{what}: a spatial direct pose names the plane its angle turns in"),
                            "add `plane: {body: <body or base>, rpy: [roll, pitch, yaw]}`: the angle turns about that frame's z axis, from its x axis",
                        );
                        (None, snap(rotation_rpy([0.0; 3])))
                    }
                    (Some(plane), false) => {
                        let Ok(plane_body) =
                            lookup_body(r, &plane.body, &at(&["pose", "plane", "body"]), &what)
                        else {
                            depends_on.push(Vec::new());
                            bodies.push(None);
                            continue;
                        };
                        let rpy = match plane.rpy.as_deref() {
                            None => [0.0; 3],
                            Some(&[roll, pitch, yaw]) => [roll, pitch, yaw],
                            Some(v) => {
                                r.error(
                                    &at(&["pose", "plane", "rpy"]),
                                    format!("expected 3 entries (roll, pitch, yaw), got {}", v.len()),
                                );
                                [0.0; 3]
                            }
                        };
                        (plane_body, snap(rotation_rpy(rpy)))
                    }
                };
                let (point, _) = r.vector(&pose.origin.point, dim, &at(&["pose", "origin", "point"]));
                let Some(angle_joint) = lookup_joint(r, &pose.angle, &at(&["pose", "angle"]), &what) else {
                    depends_on.push(Vec::new());
                    bodies.push(None);
                    continue;
                };
                joint_used[angle_joint] = true;
                if file.joints[angle_joint].kind != JointType::Revolute {
                    r.error(&at(&["pose", "angle"]), format!("joint `{}` is not revolute", pose.angle));
                }
                depends_on.push(origin_body.into_iter().chain(plane_body).collect());
                Motion::Direct { origin_body, point, angle_joint, plane_body, plane_rotation }
            }
        };
        bodies.push(Some(ResolvedBody {
            name: b.name.clone(),
            description: b.description.clone(),
            mass,
            com,
            inertia,
            motion,
        }));
    }
    // A joint is reported as unused only when every body resolved: otherwise the unresolved
    // reference is the one error to fix, and this would be its echo.
    let bodies_resolved = bodies.iter().all(Option::is_some) && !r.unresolved_joint_reference;
    for (j, used) in joint_used.iter().enumerate() {
        if bodies_resolved && !used && j < file.joints.len() && !r.duplicate_joints.contains(&j) {
            // A universal or spherical joint is reported by its name, once (its angles give
            // the same diagnostic at the same entry).
            let label = r.sources.joint_label(j, &file.joints[j].name);
            r.error_hint(
                &[key("joints"), Segment::Index(j), key("name")],
                format!("{label} moves no body"),
                "name it as a body's `joint` or a direct pose's `angle`",
            );
        }
    }

    (bodies, depends_on)
}

/// The bodies in dependency order (parents, pose origins and planes first); a cycle is an
/// error, reported once at the first body found on it.
pub(super) fn dependency_order(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    depends_on: &[Vec<usize>],
) -> Vec<usize> {
    #[derive(Clone, Copy, PartialEq)]
    enum Visit {
        New,
        OnPath,
        Done,
    }
    let n = depends_on.len();
    let mut order = Vec::with_capacity(n);
    let mut state = vec![Visit::New; n];
    let mut cycle_reported = false;
    for start in 0..n {
        if state[start] != Visit::New {
            continue;
        }
        // Depth first without recursion: the path from `start`, each body with the index of
        // the next dependency to visit.
        let mut path: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = Visit::OnPath;
        while let Some(&mut (body, ref mut next)) = path.last_mut() {
            let Some(&dependency) = depends_on[body].get(*next) else {
                state[body] = Visit::Done;
                order.push(body);
                path.pop();
                continue;
            };
            *next += 1;
            match state.get(dependency).copied() {
                Some(Visit::New) => {
                    state[dependency] = Visit::OnPath;
                    path.push((dependency, 0));
                }
                Some(Visit::OnPath) if !cycle_reported => {
                    cycle_reported = true;
                    let cycle: Vec<&str> = path
                        .iter()
                        .map(|&(b, _)| b)
                        .skip_while(|&b| b != dependency)
                        .map(|b| file.bodies[b].name.as_str())
                        .collect();
                    r.error_hint(
                        &[key("bodies"), Segment::Index(dependency)],
                        format!(
                            "bodies form a cycle: {} → {}",
                            cycle.join(" → "),
                            file.bodies[dependency].name
                        ),
                        "each body must be placed relative to bodies closer to the base",
                    );
                }
                _ => {}
            }
        }
    }
    order
}

/// Renumbers the bodies in dependency `order`, and every body reference with them; joint
/// references become coordinate indices (actuated first, then passive).
pub(super) fn into_dependency_order(
    mut bodies: Vec<Option<ResolvedBody>>,
    order: &[usize],
    points: &mut [ResolvedPoint],
    frames: &mut [ResolvedFrame],
    coordinate_of: &[usize],
    task: TaskSpec,
) -> (Vec<ResolvedBody>, TaskSpec) {
    let n = bodies.len();
    // Reindex bodies in dependency order.
    let mut new_index = vec![0usize; n];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new;
    }
    let remap = |i: Option<usize>| i.map(|x| new_index[x]);
    let mut ordered = Vec::with_capacity(n);
    for &old in order {
        let Some(mut body) = bodies[old].take() else {
            continue;
        };
        body.motion = match body.motion {
            Motion::Serial { parent, xyz, rotation, joint, tail } => {
                Motion::Serial { parent: remap(parent), xyz, rotation, joint, tail }
            }
            Motion::Direct { origin_body, point, angle_joint, plane_body, plane_rotation } => {
                Motion::Direct {
                    origin_body: remap(origin_body),
                    point,
                    angle_joint,
                    plane_body: remap(plane_body),
                    plane_rotation,
                }
            }
        };
        ordered.push(body);
    }
    for p in points.iter_mut() {
        p.body = remap(p.body);
    }
    for f in frames.iter_mut() {
        f.body = remap(f.body);
    }
    // Joint references become coordinate indices (actuated first, then passive).
    for body in &mut ordered {
        match &mut body.motion {
            Motion::Serial { joint, .. } => *joint = joint.map(|j| coordinate_of[j]),
            Motion::Direct { angle_joint, .. } => *angle_joint = coordinate_of[*angle_joint],
        }
    }
    let task = match task {
        TaskSpec::Joints(list) => TaskSpec::Joints(list.into_iter().map(|j| coordinate_of[j]).collect()),
        point => point,
    };
    (ordered, task)
}

/// A measured joint's bodies are lumped: every body it moves (and every body placed on those)
/// is massless, carries no named point and turns no direct pose by its angle, so that the
/// dynamics and the task are those of the actuated coordinates alone.
pub(super) fn lumped_bodies(
    r: &mut Resolver<'_, '_>,
    file: &ModelFile,
    bodies: &[Option<ResolvedBody>],
    depends_on: &[Vec<usize>],
    order: &[usize],
    points: &[ResolvedPoint],
) {
    let measured_joint = |name: &str| file.joints.iter().find(|j| j.name == name && j.measured.is_some());
    // The measured joint that moves each body (its own, or the one moving a body it is
    // placed from), in dependency order.
    let mut moved_by: Vec<Option<&str>> = vec![None; file.bodies.len()];
    for &i in order {
        let b = &file.bodies[i];
        let own = b.joint.as_deref().and_then(measured_joint).map(|j| j.name.as_str());
        moved_by[i] = own.or_else(|| depends_on[i].iter().find_map(|&d| moved_by[d]));
        if let Some(pose) = &b.pose {
            if measured_joint(&pose.angle).is_some() {
                r.error_hint(
                    &[key("bodies"), Segment::Index(i), key("pose"), key("angle")],
                    format!("joint `{}` is measured: it cannot pose body `{}`", pose.angle, b.name),
                    "a measured joint moves a serial body (`parent`, `joint`) whose mass is lumped",
                );
            }
        }
        let (Some(joint), Some(body)) = (moved_by[i], &bodies[i]) else { continue };
        let massless = body.mass.is_zero() && body.inertia.iter().flatten().all(Poly::is_zero);
        if !massless {
            r.error_hint(
                &[key("bodies"), Segment::Index(i), key("mass")],
                format!(
                    "body `{}` turns with measured joint `{joint}`, whose bodies are lumped (`dynamics: lumped`): it must be massless",
                    b.name
                ),
                "write `mass: 0.0` and a zero inertia, and add the mass and inertia to the body carrying the joint",
            );
        }
    }
    for (k, point) in points.iter().enumerate() {
        if let Some(joint) = point.body.and_then(|b| moved_by.get(b).copied().flatten()) {
            r.error_hint(
                &[key("points"), Segment::Index(k), key("body")],
                format!("point `{}` turns with measured joint `{joint}`: it would not be a function of the actuated joints", point.name),
                "put the point on the body carrying the gimbal; a body a measured joint moves reports its orientation through `frames`",
            );
        }
    }
}

/// The inertia tensor about the centre of mass of a uniform solid of unit mass; `None` after
/// an error, reported at the offending dimension.
fn shape_inertia(r: &mut Resolver<'_, '_>, shape: &InertiaShape, path: &[Segment]) -> Option<[[f64; 3]; 3]> {
    match unit_shape_inertia(shape) {
        Ok(tensor) => Some(tensor),
        Err((field, message)) => {
            let mut p = path.to_vec();
            p.extend(field.iter().map(|s| key(s)));
            r.error(&p, message);
            None
        }
    }
}

/// The textbook formulas, per unit mass; an error names the field (below `inertia`) at fault.
fn unit_shape_inertia(shape: &InertiaShape) -> Result<[[f64; 3]; 3], ([&'static str; 2], String)> {
    let positive = |x: f64, field: [&'static str; 2]| {
        if x > 0.0 {
            Ok(())
        } else {
            Err((field, format!("must be positive, got {x}")))
        }
    };
    // I_perp·(1 − a·aᵀ) + I_axial·a·aᵀ about a unit axis a.
    let axial = |axis: &[f64], field: [&'static str; 2], perpendicular: f64, along: f64| {
        let norm = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
        if axis.len() != 3 || norm == 0.0 || !norm.is_finite() {
            return Err((field, "an axis has 3 entries, not all zero".to_string()));
        }
        let a = [axis[0] / norm, axis[1] / norm, axis[2] / norm];
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, entry) in row.iter_mut().enumerate() {
                let identity = if i == j { 1.0 } else { 0.0 };
                *entry = perpendicular * (identity - a[i] * a[j]) + along * a[i] * a[j];
            }
        }
        Ok(m)
    };
    let diagonal = |x: f64, y: f64, z: f64| [[x, 0.0, 0.0], [0.0, y, 0.0], [0.0, 0.0, z]];
    match shape {
        InertiaShape::Rod { length, axis } => {
            positive(*length, ["rod", "length"])?;
            axial(axis, ["rod", "axis"], length * length / 12.0, 0.0)
        }
        InertiaShape::Box { x, y, z } => {
            positive(*x, ["box", "x"])?;
            positive(*y, ["box", "y"])?;
            positive(*z, ["box", "z"])?;
            let (x2, y2, z2) = (x * x, y * y, z * z);
            Ok(diagonal((y2 + z2) / 12.0, (x2 + z2) / 12.0, (x2 + y2) / 12.0))
        }
        InertiaShape::Cylinder { radius, length, axis } => {
            positive(*radius, ["cylinder", "radius"])?;
            positive(*length, ["cylinder", "length"])?;
            let r2 = radius * radius;
            axial(axis, ["cylinder", "axis"], (3.0 * r2 + length * length) / 12.0, r2 / 2.0)
        }
        InertiaShape::Sphere { radius } => {
            positive(*radius, ["sphere", "radius"])?;
            let i = 2.0 * radius * radius / 5.0;
            Ok(diagonal(i, i, i))
        }
        InertiaShape::PointMass => Ok([[0.0; 3]; 3]),
    }
}

#[cfg(test)]
mod tests {
    use super::unit_shape_inertia;
    use crate::model::schema::InertiaShape;

    fn close(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) {
        for i in 0..3 {
            for j in 0..3 {
                assert!((a[i][j] - b[i][j]).abs() <= 1e-15 * (1.0 + b[i][j].abs()), "{a:?} != {b:?}");
            }
        }
    }

    #[test]
    fn shapes_follow_the_textbook_formulas() {
        // Per unit mass: rod m·L²/12 across, 0 along.
        let rod = unit_shape_inertia(&InertiaShape::Rod { length: 0.3, axis: vec![0.0, 2.0, 0.0] }).unwrap();
        close(rod, [[0.09 / 12.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.09 / 12.0]]);
        // A rod along (1, 1, 0)/√2: I = L²/12 (1 − a aᵀ).
        let l2 = 0.04 / 12.0;
        let tilted =
            unit_shape_inertia(&InertiaShape::Rod { length: 0.2, axis: vec![1.0, 1.0, 0.0] }).unwrap();
        close(tilted, [[l2 / 2.0, -l2 / 2.0, 0.0], [-l2 / 2.0, l2 / 2.0, 0.0], [0.0, 0.0, l2]]);
        let (x, y, z) = (0.1, 0.2, 0.3);
        let cuboid = unit_shape_inertia(&InertiaShape::Box { x, y, z }).unwrap();
        close(
            cuboid,
            [
                [(y * y + z * z) / 12.0, 0.0, 0.0],
                [0.0, (x * x + z * z) / 12.0, 0.0],
                [0.0, 0.0, (x * x + y * y) / 12.0],
            ],
        );
        let (r, l) = (0.05, 0.4);
        let cylinder =
            unit_shape_inertia(&InertiaShape::Cylinder { radius: r, length: l, axis: vec![0.0, 0.0, 1.0] })
                .unwrap();
        let across = (3.0 * r * r + l * l) / 12.0;
        close(cylinder, [[across, 0.0, 0.0], [0.0, across, 0.0], [0.0, 0.0, r * r / 2.0]]);
        let along_x =
            unit_shape_inertia(&InertiaShape::Cylinder { radius: r, length: l, axis: vec![-1.0, 0.0, 0.0] })
                .unwrap();
        close(along_x, [[r * r / 2.0, 0.0, 0.0], [0.0, across, 0.0], [0.0, 0.0, across]]);
        let sphere = unit_shape_inertia(&InertiaShape::Sphere { radius: r }).unwrap();
        let s = 0.4 * r * r;
        close(sphere, [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]]);
        close(unit_shape_inertia(&InertiaShape::PointMass).unwrap(), [[0.0; 3]; 3]);
        assert!(unit_shape_inertia(&InertiaShape::Sphere { radius: 0.0 }).is_err());
        assert!(unit_shape_inertia(&InertiaShape::Rod { length: 1.0, axis: vec![0.0, 0.0] }).is_err());
    }
}
