//! Replaying a `simulate` or `contact` run in the design report's 3-D view
//! (`hapticgen report MODEL --replay RUN`, docs/design-report.md).
//!
//! A run writes its trace (`trace.csv`, [`crate::output::write_csv`]) and, beside it, the scene
//! it rendered ([`SCENE_FILE`], [`write_scene`]): the objects as drawn shapes (a polytope as
//! its edges, a mesh as its triangles where it was placed, a planar contour as a line), with
//! their motion. The trace alone cannot tell them: a contact scenario places its solids from
//! the start pose, and `--scene` may replace them.
//!
//! [`DrawnShape`] is not another scene shape but what the page draws, and the file's format:
//! it holds data a scene object does not (a polytope's edges, a mesh's placed triangles, the
//! points of a planar contour, which is no scene file's shape), it spells `centre` as the
//! page's script reads it, and runs recorded earlier must still load; `drawn_shapes` makes
//! it from codegen's [`SceneShape`], in one place. A motion is recorded as codegen's
//! [`SceneMotion`] itself, with the scene file's names.
//!
//! [`load`] reads a run back against the model the report is for: the trace's joint columns
//! must be the model's actuated joints (`q0`…`q{N−1}`), and the model's task point at the
//! trace's joint angles must be where the trace recorded it (`x*`), else the trace was written
//! for another model or variant. At most [`MAX_FRAMES`] rows, evenly spread over the trace
//! with its first and last, become the replay's frames; each frame's drawing comes from the
//! model's own kinematics ([`RigDrawing::pose`], the grid view's drawing), each moving
//! object's pose at the frame's time from its motion ([`SceneMotion`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hapticgen_codegen::CheckedModel;
use hapticgen_runtime::render::{ObjectKind, Shape};
use serde::{Deserialize, Serialize};

use crate::closed_loop::Reference;
use crate::design_page::{json_number, RigDrawing};
use crate::scene::{SceneMotion, ScenePlane, SceneShape};
use crate::vector::{distance, dot};

/// The scene a run records beside its trace.
pub const SCENE_FILE: &str = "scene.json";

/// The trace a run writes into its directory.
pub const TRACE_FILE: &str = "trace.csv";

/// Most frames a replay holds: longer traces are subsampled.
pub const MAX_FRAMES: usize = 2000;

/// Farthest the model's task point may be from the trace's recorded one, m: the loops'
/// solvers and the trace's nine digits agree far closer; a different model or variant not.
const TASK_TOLERANCE: f64 = 1e-5;

/// Points a contour given as a function is drawn with.
const CONTOUR_POINTS: usize = 101;

/// An object's geometry as the page draws it, in task coordinates (2 or 3 per point).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DrawnShape {
    /// The half-space behind the plane through `point` with outward `normal`.
    HalfSpace {
        /// A point of the plane.
        point: Vec<f64>,
        /// The outward normal.
        normal: Vec<f64>,
    },
    /// A ball (a disc in a planar task).
    Sphere {
        /// Centre.
        centre: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// A box.
    Box {
        /// Centre.
        centre: Vec<f64>,
        /// Its axes in task coordinates, one unit row per axis.
        axes: Vec<Vec<f64>>,
        /// Half the edge lengths along its axes, m.
        half_extents: Vec<f64>,
    },
    /// The points within `radius` of the segment `ab`.
    Capsule {
        /// One end.
        a: Vec<f64>,
        /// The other end.
        b: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// A cylinder with flat caps centred on `a` and `b`.
    Cylinder {
        /// One cap's centre.
        a: Vec<f64>,
        /// The other's.
        b: Vec<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// Straight edges (a bounded polytope's).
    Edges {
        /// Each edge's two ends.
        segments: Vec<[Vec<f64>; 2]>,
    },
    /// A triangle mesh where it was placed.
    Mesh {
        /// Vertex positions, m.
        vertices: Vec<[f64; 3]>,
        /// Triangles, as vertex indices.
        faces: Vec<[u32; 3]>,
    },
    /// A line through points (a planar polygon, closed, or a contour, open).
    Outline {
        /// The points.
        points: Vec<Vec<f64>>,
        /// Whether the last point joins the first.
        closed: bool,
    },
}

/// One object of a recorded scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrawnObject {
    /// Its geometry at time 0.
    pub shape: DrawnShape,
    /// `true` for a cavity (the point is kept inside).
    pub cavity: bool,
    /// How it moves, if it does.
    pub motion: Option<SceneMotion>,
}

/// The scene a run rendered, as [`SCENE_FILE`] holds it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordedScene {
    /// Task coordinates per point.
    pub task_dim: usize,
    /// The objects.
    pub objects: Vec<DrawnObject>,
}

/// The drawn form of a scene file's (or contact scenario's) shape: one drawn shape, or an
/// unbounded polytope's bounding planes.
fn drawn_shapes(shape: &SceneShape) -> Vec<DrawnShape> {
    match shape {
        SceneShape::HalfSpace { point, normal } => {
            vec![DrawnShape::HalfSpace { point: point.clone(), normal: normal.clone() }]
        }
        SceneShape::Sphere { center, radius } => {
            vec![DrawnShape::Sphere { centre: center.clone(), radius: *radius }]
        }
        SceneShape::Box { center, axes, half_extents } => vec![DrawnShape::Box {
            centre: center.clone(),
            axes: axes.clone(),
            half_extents: half_extents.clone(),
        }],
        SceneShape::Capsule { a, b, radius } => {
            vec![DrawnShape::Capsule { a: a.clone(), b: b.clone(), radius: *radius }]
        }
        SceneShape::Cylinder { a, b, radius } => {
            vec![DrawnShape::Cylinder { a: a.clone(), b: b.clone(), radius: *radius }]
        }
        SceneShape::Polytope { planes } => {
            let segments = polytope_edges(planes);
            if segments.is_empty() {
                // Unbounded: drawn as its bounding planes.
                planes
                    .iter()
                    .map(|plane| DrawnShape::HalfSpace {
                        point: plane.normal.iter().map(|n| n * plane.offset).collect(),
                        normal: plane.normal.clone(),
                    })
                    .collect()
            } else {
                vec![DrawnShape::Edges { segments }]
            }
        }
        SceneShape::Mesh { mesh, offset } => vec![DrawnShape::Mesh {
            vertices: mesh
                .vertices
                .iter()
                .map(|v| std::array::from_fn(|k| v[k] + offset.get(k).copied().unwrap_or(0.0)))
                .collect(),
            faces: mesh.faces.clone(),
        }],
    }
}

/// The edges of the bounded polytope `{x : n_i · x ≤ d_i}` (unit normals `n_i`, 2 or 3
/// coordinates): its vertices are where `dim` planes meet inside every other, and two vertices
/// sharing `dim − 1` planes are joined. Empty when no vertex is found.
fn polytope_edges(planes: &[ScenePlane]) -> Vec<[Vec<f64>; 2]> {
    let dim = planes.first().map_or(0, |p| p.normal.len());
    if !(2..=3).contains(&dim) {
        return Vec::new();
    }
    let mut subsets: Vec<Vec<usize>> = vec![Vec::new()];
    for _ in 0..dim {
        subsets = subsets
            .into_iter()
            .flat_map(|s| {
                let from = s.last().map_or(0, |l| l + 1);
                (from..planes.len()).map(move |i| [s.as_slice(), &[i]].concat())
            })
            .collect();
    }
    let inside = |x: &nalgebra::DVector<f64>| {
        planes.iter().all(|plane| dot(&plane.normal, x.as_slice()) <= plane.offset + 1e-9)
    };
    let vertices: Vec<(Vec<usize>, Vec<f64>)> = subsets
        .into_iter()
        .filter_map(|subset| {
            let a = nalgebra::DMatrix::from_fn(dim, dim, |r, c| planes[subset[r]].normal[c]);
            let d = nalgebra::DVector::from_fn(dim, |r, _| planes[subset[r]].offset);
            let x = a.lu().solve(&d)?;
            (x.iter().all(|v| v.is_finite()) && inside(&x)).then(|| {
                let on: Vec<usize> = (0..planes.len())
                    .filter(|&i| (dot(&planes[i].normal, x.as_slice()) - planes[i].offset).abs() < 1e-9)
                    .collect();
                (on, x.iter().copied().collect())
            })
        })
        .collect();
    let mut segments = Vec::new();
    for (i, (on_a, a)) in vertices.iter().enumerate() {
        for (on_b, b) in &vertices[i + 1..] {
            let shared = on_a.iter().filter(|p| on_b.contains(p)).count();
            let apart = a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum::<f64>() > 1e-18;
            if shared + 1 >= dim && apart {
                segments.push([a.clone(), b.clone()]);
            }
        }
    }
    segments
}

/// The drawn form of a planar scene's object (the runtime's [`Shape`]).
fn drawn_planar<const V: usize>(shape: &Shape<f64, V>) -> DrawnShape {
    match *shape {
        Shape::Circle { center, radius } => DrawnShape::Sphere { centre: center.to_vec(), radius },
        Shape::Rectangle { center, half_extents, angle } => DrawnShape::Box {
            centre: center.to_vec(),
            axes: vec![vec![angle.cos(), angle.sin()], vec![-angle.sin(), angle.cos()]],
            half_extents: half_extents.to_vec(),
        },
        Shape::ConvexPolygon { vertices, count } => DrawnShape::Outline {
            points: vertices.iter().take(count).map(|v| v.to_vec()).collect(),
            closed: true,
        },
        Shape::ContourFunction { function, x1_range, .. } => {
            let [a, b] = x1_range;
            let points = (0..CONTOUR_POINTS)
                .map(|i| {
                    let x1 = a + (b - a) * i as f64 / (CONTOUR_POINTS - 1) as f64;
                    vec![x1, function(x1)]
                })
                .collect();
            DrawnShape::Outline { points, closed: false }
        }
        Shape::ContourTable { samples, count, x1_range } => {
            let [a, b] = x1_range;
            let step = (b - a) / count.saturating_sub(1).max(1) as f64;
            let points =
                samples.iter().take(count).enumerate().map(|(i, f)| vec![a + step * i as f64, *f]).collect();
            DrawnShape::Outline { points, closed: false }
        }
    }
}

/// The scene `reference` renders, for a task of `task_dim` coordinates.
pub fn recorded_scene(reference: &Reference, task_dim: usize) -> RecordedScene {
    let objects = match reference {
        Reference::Fixed(_) => Vec::new(),
        Reference::Scene { objects, .. } => objects
            .iter()
            .map(|o| DrawnObject {
                shape: drawn_planar(&o.shape),
                cavity: o.kind == ObjectKind::Cavity,
                motion: None,
            })
            .collect(),
        Reference::Solids { solids, .. } => solids
            .iter()
            .flat_map(|solid| {
                drawn_shapes(&solid.shape).into_iter().map(|shape| DrawnObject {
                    shape,
                    cavity: solid.cavity,
                    motion: solid.motion.clone(),
                })
            })
            .collect(),
    };
    RecordedScene { task_dim, objects }
}

/// Writes the scene `reference` renders to `dir/`[`SCENE_FILE`], beside the run's trace.
pub fn write_scene(reference: &Reference, task_dim: usize, dir: &Path) -> Result<(), String> {
    let path = dir.join(SCENE_FILE);
    let text = serde_json::to_string(&recorded_scene(reference, task_dim))
        .map_err(|e| format!("error: cannot write {}: {e}", path.display()))?;
    std::fs::write(&path, text + "\n").map_err(|e| format!("error: cannot write {}: {e}", path.display()))
}

/// One frame of a replay.
#[derive(Clone, Debug)]
pub struct ReplayFrame {
    /// The trace's line it is read from (the header is line 1).
    pub line: u64,
    /// Its time, s.
    pub time: f64,
    /// The drawing's nodes at the trace's joint angles ([`RigDrawing::pose`]).
    pub pose: Vec<[f64; 3]>,
    /// The proxy (the trace's `xp*`), padded to three coordinates.
    pub proxy: [f64; 3],
    /// Each moving object's pose at `time` (in the order of the scene's moving objects): the
    /// rotation by rows and the translation, `x ↦ R x + p`, padded to three coordinates.
    pub moved: Vec<([[f64; 3]; 3], [f64; 3])>,
}

/// A run read back for the page.
#[derive(Clone, Debug)]
pub struct Replay {
    /// The trace file.
    pub trace: PathBuf,
    /// Rows in the trace.
    pub rows: usize,
    /// The frames, at most [`MAX_FRAMES`], first and last row included.
    pub frames: Vec<ReplayFrame>,
    /// The recorded scene, `None` when the run has no [`SCENE_FILE`] (written before runs
    /// recorded their scene).
    pub scene: Option<RecordedScene>,
}

/// The trace of `run`: the file itself, or `run/`[`TRACE_FILE`] for a run's directory.
fn trace_path(run: &Path) -> Result<PathBuf, String> {
    if run.is_dir() {
        let path = run.join(TRACE_FILE);
        if path.is_file() {
            Ok(path)
        } else {
            Err(format!(
                "error: {}: no {TRACE_FILE} in this directory (give the directory `hapticgen simulate -o` or one \
                 run of `hapticgen contact -o` wrote, or the trace's file)",
                run.display()
            ))
        }
    } else if run.is_file() {
        Ok(run.to_path_buf())
    } else {
        Err(format!("error: {}: no such file or directory", run.display()))
    }
}

/// Padded to three coordinates.
fn padded(v: &[f64]) -> [f64; 3] {
    std::array::from_fn(|k| v.get(k).copied().unwrap_or(0.0))
}

/// The pose of a moving object at `time`: `R(ω t)` and `P(t) 0`, padded to 3-D.
fn moved_at(motion: &SceneMotion, time: f64, dim: usize) -> ([[f64; 3]; 3], [f64; 3]) {
    let rotation = motion.rotation_at(time, dim);
    let r = std::array::from_fn(|i| {
        std::array::from_fn(|k| {
            rotation.get(i).and_then(|row| row.get(k)).copied().unwrap_or(f64::from(u8::from(i == k)))
        })
    });
    (r, padded(&motion.carried(time, &vec![0.0; dim])))
}

/// Reads the run `run` (its directory or its trace) for a replay of `model`; refuses a missing
/// or empty trace, joint columns other than the model's, a number that is not one, and a task
/// point elsewhere than the model puts it, naming the file, line and column.
pub fn load(model: &CheckedModel, run: &Path) -> Result<Replay, String> {
    let path = trace_path(run)?;
    let file = path.display().to_string();
    let mut reader = csv::Reader::from_path(&path).map_err(|e| format!("error: {file}: {e}"))?;
    let header: Vec<String> =
        reader.headers().map_err(|e| format!("error: {file}:1: {e}"))?.iter().map(str::to_string).collect();
    if header.is_empty() || header.iter().all(String::is_empty) {
        return Err(format!(
            "error: {file}: empty: no header and no rows (is it a trace of `hapticgen simulate`?)"
        ));
    }
    let column = |name: &str| header.iter().position(|h| h == name);
    let n = model.joints.len();
    let in_trace: Vec<&String> =
        header.iter().filter(|h| h.strip_prefix('q').is_some_and(|k| k.parse::<usize>().is_ok())).collect();
    let expected: Vec<String> = (0..n).map(|k| format!("q{k}")).collect();
    if in_trace.len() != n || expected.iter().any(|name| column(name).is_none()) {
        let names: Vec<String> =
            model.joints.iter().zip(&expected).map(|(j, c)| format!("{c} ({})", j.name)).collect();
        let found: Vec<&str> = in_trace.iter().map(|s| s.as_str()).collect();
        return Err(format!(
            "error: {file}:1: the trace's joint columns are {} but {} has {n} actuated joints, {}: the trace was \
             written for another model",
            if found.is_empty() { "none".to_string() } else { found.join(", ") },
            model.file,
            names.join(", ")
        ));
    }
    let m = model.task_dim();
    let required = |prefix: &str| -> Result<Vec<usize>, String> {
        (0..m)
            .map(|k| {
                let name = format!("{prefix}{k}");
                column(&name).ok_or_else(|| {
                    format!("error: {file}:1: no column `{name}` (the model's task has {m} coordinates)")
                })
            })
            .collect()
    };
    let time = column("t").ok_or_else(|| format!("error: {file}:1: no column `t`"))?;
    let joints: Vec<usize> = expected.iter().filter_map(|name| column(name)).collect();
    let (task, proxy) = (required("x")?, required("xp")?);
    let mut rows: Vec<(u64, Vec<f64>)> = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(String::new(), |p| format!(":{}", p.line()));
            format!("error: {file}{line}: {e}")
        })?;
        let line = record.position().map_or(0, |p| p.line());
        let values = record
            .iter()
            .zip(&header)
            .map(|(cell, name)| {
                cell.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("error: {file}:{line}: column `{name}`: `{cell}` is not a number"))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        rows.push((line, values));
    }
    if rows.is_empty() {
        return Err(format!("error: {file}: the trace has a header but no rows: nothing to replay"));
    }
    let count = rows.len().min(MAX_FRAMES);
    let picked: Vec<usize> = if count < 2 {
        vec![0]
    } else {
        (0..count).map(|k| ((k * (rows.len() - 1)) as f64 / (count - 1) as f64).round() as usize).collect()
    };
    let scene = read_scene(&path, m)?;
    let moving: Vec<SceneMotion> =
        scene.iter().flat_map(|s| &s.objects).filter_map(|o| o.motion.clone()).collect();
    let drawing = RigDrawing::new(model);
    let mut frames = Vec::with_capacity(picked.len());
    for index in picked {
        let (line, values) = &rows[index];
        let q: Vec<f64> = joints.iter().map(|&c| values[c]).collect();
        let pose = drawing.pose(&q);
        if let Some(node) = drawing.task_node {
            let recorded: Vec<f64> = task.iter().map(|&c| values[c]).collect();
            let drawn = &pose[node][..m.min(3)];
            let off = distance(drawn, &recorded);
            // NaN too: the model's loops do not close at the trace's joint angles.
            if off.is_nan() || off > TASK_TOLERANCE {
                return Err(format!(
                    "error: {file}:{line}: at the trace's joint angles {q:?} the model {} puts its task point at \
                     {drawn:?}, {off:.3e} m from the trace's x {recorded:?}: the trace was written for another model or \
                     variant",
                    model.file
                ));
            }
        }
        let t = values[time];
        frames.push(ReplayFrame {
            line: *line,
            time: t,
            pose,
            proxy: padded(&proxy.iter().map(|&c| values[c]).collect::<Vec<_>>()),
            moved: moving.iter().map(|motion| moved_at(motion, t, m)).collect(),
        });
    }
    Ok(Replay { trace: path, rows: rows.len(), frames, scene })
}

/// The scene recorded beside `trace`, checked against a task of `task_dim` coordinates;
/// `None` when there is none.
fn read_scene(trace: &Path, task_dim: usize) -> Result<Option<RecordedScene>, String> {
    let path = trace.with_file_name(SCENE_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("error: {}: {e}", path.display())),
    };
    let scene: RecordedScene = serde_json::from_str(&text)
        .map_err(|e| format!("error: {}:{}:{}: {e}", path.display(), e.line(), e.column()))?;
    if scene.task_dim != task_dim {
        return Err(format!(
            "error: {}: a scene of a {}-D task; the model's task has {task_dim} coordinates",
            path.display(),
            scene.task_dim
        ));
    }
    Ok(Some(scene))
}

/// The replay's data for the page, as a JSON object: `trace`, `rows`, per frame `lines`, `t`,
/// `poses` (flat x, y, z per node, as the grid view's), `proxy`, `moved` (per moving object,
/// the 12 numbers of `R` by rows and `p`), and `objects` (the recorded scene's, or `null`).
pub fn page_data(replay: &Replay) -> String {
    let numbers =
        |values: &mut dyn Iterator<Item = f64>| values.map(json_number).collect::<Vec<_>>().join(",");
    let mut out = String::from("{");
    let _ = write!(
        out,
        "\"trace\":{:?},\"rows\":{},\"lines\":[{}],\"t\":[{}],",
        replay.trace.display().to_string(),
        replay.rows,
        replay.frames.iter().map(|f| f.line.to_string()).collect::<Vec<_>>().join(","),
        replay.frames.iter().map(|f| format!("{}", f.time)).collect::<Vec<_>>().join(",")
    );
    let poses: Vec<String> = replay
        .frames
        .iter()
        .map(|f| format!("[{}]", numbers(&mut f.pose.iter().flatten().copied())))
        .collect();
    let proxy: Vec<String> =
        replay.frames.iter().map(|f| format!("[{}]", numbers(&mut f.proxy.iter().copied()))).collect();
    let moved: Vec<String> = replay
        .frames
        .iter()
        .map(|f| {
            let each: Vec<String> = f
                .moved
                .iter()
                .map(|(r, p)| format!("[{}]", numbers(&mut r.iter().flatten().chain(p).copied())))
                .collect();
            format!("[{}]", each.join(","))
        })
        .collect();
    let _ = write!(
        out,
        "\"poses\":[{}],\"proxy\":[{}],\"moved\":[{}],",
        poses.join(","),
        proxy.join(","),
        moved.join(",")
    );
    let objects = replay.scene.as_ref().map_or_else(
        || "null".to_string(),
        |s| serde_json::to_string(&s.objects).unwrap_or_else(|_| "null".into()),
    );
    let _ = write!(out, "\"objects\":{objects}}}");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube's six planes give its 8 corners joined by its 12 edges; an unbounded slab none.
    #[test]
    fn a_polytope_is_drawn_by_its_edges() {
        let mut planes = Vec::new();
        for k in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut normal = vec![0.0; 3];
                normal[k] = sign;
                planes.push(ScenePlane { normal, offset: 0.5 });
            }
        }
        let edges = polytope_edges(&planes);
        assert_eq!(edges.len(), 12);
        for [a, b] in &edges {
            assert!((distance(a, b) - 1.0).abs() < 1e-12, "{a:?} {b:?}");
        }
        assert!(polytope_edges(&planes[..2]).is_empty());
        // A triangle in the plane: 3 vertices, 3 edges.
        let plane = |normal: Vec<f64>, offset: f64| ScenePlane { normal, offset };
        let triangle = [
            plane(vec![0.0, -1.0], 0.0),
            plane(vec![-1.0, 0.0], 0.0),
            plane(vec![0.5f64.sqrt(), 0.5f64.sqrt()], 0.5f64.sqrt()),
        ];
        assert_eq!(polytope_edges(&triangle).len(), 3);
    }

    /// A motion is recorded with the scene file's names, as runs recorded it before the
    /// recorded scene held codegen's motion itself: such a file reads back and is written the
    /// same; a motion with a field of another name is refused.
    #[test]
    fn a_motion_is_recorded_with_the_scene_file_s_names() {
        let text = r#"{"task_dim":3,"objects":[{"shape":{"kind":"sphere","centre":[0.0,0.0,0.0],"radius":0.01},"cavity":false,"motion":{"velocity":[0.0,0.0,0.01],"angular_velocity":[0.0,0.0,2.0],"pivot":[0.1,0.0,0.0]}}]}"#;
        let scene: RecordedScene = serde_json::from_str(text).unwrap();
        let motion = scene.objects[0].motion.as_ref().unwrap();
        assert_eq!((motion.velocity[2], motion.angular_velocity[2], motion.pivot[0]), (0.01, 2.0, 0.1));
        assert_eq!(serde_json::to_string(&scene).unwrap(), text);
        assert!(serde_json::from_str::<RecordedScene>(&text.replace("\"pivot\"", "\"centre\"")).is_err());
    }
}
