//! The design report's page, `DIR/index.html`: one self-contained file (no network at view
//! time, works from `file://`) with the datasheet figures of [`crate::design`] and a 3-D view
//! of the rig drawn with three.js (vendored from npm into `targets/host/assets/three/` by
//! `scripts/vendor-three.sh`, inlined into the page as `data:` modules of an import map).
//!
//! The view is precomputed, not evaluated in the page: the joints of the drawing (every body's
//! frame origin and every named point) at each state of a grid over the actuated joints' box,
//! from the model's own kinematics (`hapticgen_codegen::dynamics::kinematics::body_origins`,
//! closed chains through the evaluator's loop solution). A slider per joint picks the grid
//! index; the page's address may set them (`index.html#q=3,7,1`, grid indices), which the
//! browser test uses. The workspace cloud is the report's grid samples.
//!
//! The page sets `document.body.dataset.status` to `rendered` after its first frame, or to
//! `error: …` on any script error, for the browser test to read.

use std::fmt::Write as _;

use hapticgen_codegen::eval::{Full, State};
use hapticgen_codegen::model::Motion;
use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::CheckedModel;

use std::path::Path;

use crate::design::{joint_grid, Summary, Workspace};
use crate::design_maps::MapFile;

/// three.js's core module, rewritten to import nothing.
const THREE_CORE: &str = include_str!("../assets/three/three.core.js");
/// three.js's module entry, importing the core as `three/core`.
const THREE_MODULE: &str = include_str!("../assets/three/three.module.js");

/// The page, with `@@TITLE@@`, `@@FIGURES@@`, `@@MODULE@@`, `@@CORE@@`, `@@DATA@@` and
/// `@@REPLAY@@` slots.
const PAGE_TEMPLATE: &str = include_str!("../assets/design-page.html");

/// Largest number of grid states the page's view holds.
pub const VIEW_STATES: usize = 4096;

/// The drawing of the rig at every state of a grid over its actuated joints.
#[derive(Clone, Debug)]
pub struct PoseGrid {
    /// The actuated joints' names.
    pub joints: Vec<String>,
    /// Their limits.
    pub limits: Vec<(f64, f64)>,
    /// Grid values per joint.
    pub steps: usize,
    /// The drawing's nodes: the base, each body's origin, then each named point.
    pub nodes: Vec<String>,
    /// Lines between nodes: each body's joint to its parent's, each point to its body's origin.
    pub segments: Vec<(usize, usize)>,
    /// The task point's node, if the task is a point.
    pub task_node: Option<usize>,
    /// Per grid state (first joint fastest), each node's position (x, y, z), m; NaN where the
    /// loops do not close.
    pub positions: Vec<Vec<[f64; 3]>>,
}

/// Grid values per joint for `n` joints within [`VIEW_STATES`] states (at least 2).
pub fn view_steps(n: usize) -> usize {
    let mut steps = 2usize;
    while (steps + 1).checked_pow(n as u32).is_some_and(|p| p <= VIEW_STATES) && steps < 25 {
        steps += 1;
    }
    steps
}

/// How to draw `model` at any joint state: the drawing's nodes and lines, and the polynomials
/// of the nodes' positions, evaluated per state by [`RigDrawing::pose`]. The one drawing of a
/// state that the grid view ([`pose_grid`]) and the replay of a run ([`crate::replay`]) share.
pub struct RigDrawing {
    mechanics: hapticgen_codegen::dynamics::mechanics::Mechanics,
    origins: Vec<Vec<Poly>>,
    points: Vec<Vec<Poly>>,
    parameters: Vec<f64>,
    /// The drawing's nodes: the base, each body's origin, then each named point.
    pub nodes: Vec<String>,
    /// Lines between nodes: each body's joint to its parent's, each point to its body's origin.
    pub segments: Vec<(usize, usize)>,
    /// The task point's node, if the task is a point.
    pub task_node: Option<usize>,
}

impl RigDrawing {
    /// The drawing of `model`.
    pub fn new(model: &CheckedModel) -> RigDrawing {
        let bodies = model.bodies.len();
        let mut nodes = vec!["base".to_string()];
        nodes.extend(model.bodies.iter().map(|b| b.name.clone()));
        nodes.extend(model.points.iter().map(|p| p.name.clone()));
        let node_of = |body: Option<usize>| body.map_or(0, |b| b + 1);
        let mut segments = Vec::new();
        for (k, body) in model.bodies.iter().enumerate() {
            let parent = match &body.motion {
                Motion::Serial { parent, .. } => node_of(*parent),
                Motion::Direct { origin_body, .. } => node_of(*origin_body),
                #[allow(unreachable_patterns)]
                _ => 0,
            };
            if parent != k + 1 {
                segments.push((parent, k + 1));
            }
        }
        for (i, point) in model.points.iter().enumerate() {
            segments.push((node_of(point.body), 1 + bodies + i));
        }
        let task_node = match model.task {
            hapticgen_codegen::model::TaskSpec::Point(p) => Some(1 + bodies + p),
            hapticgen_codegen::model::TaskSpec::Joints(_) => None,
        };
        RigDrawing {
            mechanics: hapticgen_codegen::derive(model),
            origins: hapticgen_codegen::dynamics::kinematics::body_origins(model),
            points: hapticgen_codegen::dynamics::kinematics::point_positions(model),
            parameters: model.nominal_parameters(),
            nodes,
            segments,
            task_node,
        }
    }

    /// Each node's position (x, y, z; z = 0 for a planar model), m, at the actuated joints'
    /// coordinates `q`; NaN where the loops do not close.
    pub fn pose(&self, q: &[f64]) -> Vec<[f64; 3]> {
        let zero = vec![0.0; q.len()];
        let state = State { q, qd: &zero, parameters: &self.parameters };
        let full = Full::new(&self.mechanics, &state);
        let at = |p: &[Poly]| -> [f64; 3] {
            let get = |i: usize| p.get(i).map_or(0.0, |x| x.eval(&full));
            [get(0), get(1), get(2)]
        };
        let mut row = vec![[0.0; 3]];
        row.extend(self.origins.iter().map(|o| at(o)));
        row.extend(self.points.iter().map(|p| at(p)));
        row
    }
}

/// The drawing of `model` on a grid of `steps` per joint.
pub fn pose_grid(model: &CheckedModel, steps: usize) -> PoseGrid {
    let drawing = RigDrawing::new(model);
    let limits: Vec<(f64, f64)> = model.joints.iter().map(|j| (j.lower, j.upper)).collect();
    let positions = joint_grid(&limits, steps).iter().map(|q| drawing.pose(q)).collect();
    PoseGrid {
        joints: model.joints.iter().map(|j| j.name.clone()).collect(),
        limits,
        steps,
        nodes: drawing.nodes,
        segments: drawing.segments,
        task_node: drawing.task_node,
        positions,
    }
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], chunk.get(1).copied().unwrap_or(0), chunk.get(2).copied().unwrap_or(0)];
        let word = u32::from(b[0]) << 16 | u32::from(b[1]) << 8 | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[(word >> (18 - 6 * i) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// `x` for the page's JSON: at most six decimals (1 µm), `null` when not finite.
pub(crate) fn json_number(x: f64) -> String {
    if x.is_finite() {
        format!("{:.6}", x).trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        "null".into()
    }
}

/// The page's data, as a JSON object.
fn page_data(grid: &PoseGrid, workspace: &Workspace, summary: &Summary) -> String {
    let mut out = String::from("{");
    let quoted = |v: &[String]| v.iter().map(|s| format!("{s:?}")).collect::<Vec<_>>().join(",");
    let _ = write!(out, "\"joints\":[{}],\"steps\":{},", quoted(&grid.joints), grid.steps);
    let limits: Vec<String> =
        grid.limits.iter().map(|(lo, hi)| format!("[{},{}]", json_number(*lo), json_number(*hi))).collect();
    let _ = write!(out, "\"limits\":[{}],\"nodes\":[{}],", limits.join(","), quoted(&grid.nodes));
    let segments: Vec<String> = grid.segments.iter().map(|(a, b)| format!("[{a},{b}]")).collect();
    let _ = write!(
        out,
        "\"segments\":[{}],\"task\":{},",
        segments.join(","),
        grid.task_node.map_or("null".into(), |t| t.to_string())
    );
    let poses: Vec<String> = grid
        .positions
        .iter()
        .map(|row| {
            let flat: Vec<String> = row.iter().flat_map(|p| p.iter().map(|x| json_number(*x))).collect();
            format!("[{}]", flat.join(","))
        })
        .collect();
    let _ = write!(out, "\"poses\":[{}],", poses.join(","));
    let cloud: Vec<String> = workspace
        .samples
        .iter()
        .flat_map(|s| (0..3).map(move |k| json_number(s.position.get(k).copied().unwrap_or(0.0))))
        .collect();
    let _ = write!(out, "\"cloud\":[{}],", cloud.join(","));
    let _ = write!(out, "\"summary\":{}", serde_json::to_string(summary).unwrap_or_else(|_| "{}".into()));
    out.push('}');
    out
}

fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// The maps' section: each map's PNG (already written under `dir`) inlined as a `data:` image,
/// with its SVG and PNG linked; a map whose PNG cannot be read is named, not dropped.
fn maps_section(maps: &[MapFile], dir: &Path) -> String {
    let mut out = String::new();
    for map in maps {
        let png = format!("{}.png", map.base);
        let caption = escape_html(&map.caption);
        match std::fs::read(dir.join(&png)) {
            Ok(bytes) => {
                let _ = writeln!(
                    out,
                    "<figure class=\"map\"><img alt=\"{caption}\" src=\"data:image/png;base64,{}\"><figcaption>{caption} \
                     (<a href=\"{base}.svg\">SVG</a>, <a href=\"{png}\">PNG</a>)</figcaption></figure>",
                    base64(&bytes),
                    base = map.base
                );
            }
            Err(e) => {
                let _ =
                    writeln!(out, "<p>{caption}: {}</p>", escape_html(&format!("cannot read {png}: {e}")));
            }
        }
    }
    out
}

/// The summary's figures as a table, in mm, N, g and µm (a task of joint coordinates: rad, N·m,
/// kg·m², µrad).
fn figures_table(summary: &Summary) -> String {
    let point = summary.task_unit == "m";
    let (length, scale, force, mass, mass_scale, fine) =
        if point { ("mm", 1e3, "N", "g", 1e3, "µm") } else { ("rad", 1.0, "N·m", "kg·m²", 1.0, "µrad") };
    let (name, cube) = summary.cube();
    let mut rows: Vec<(String, String)> = Vec::new();
    if let Some(cube) = cube {
        let centre: Vec<String> = cube.centre.iter().map(|c| crate::design::fixed(c * scale, 1)).collect();
        rows.push((
            format!("inscribed {name}"),
            format!("{:.1} {length}, centred at ({}) {length}", cube.edge * scale, centre.join(", ")),
        ));
    }
    if let Some((name, ball)) = summary.ball() {
        let centre: Vec<String> = ball.centre.iter().map(|c| crate::design::fixed(c * scale, 1)).collect();
        rows.push((
            format!("inscribed {name}, radius"),
            format!("{:.1} {length}, centred at ({}) {length}", ball.radius * scale, centre.join(", ")),
        ));
    }
    let spread = |s: &crate::design::Spread, f: f64, unit: &str, digits: usize| {
        format!(
            "{:.*} / {:.*} / {:.*} {unit}",
            digits,
            s.min_over_cube * f,
            digits,
            s.median_over_cube * f,
            digits,
            s.max_over_cube * f
        )
    };
    rows.push((
        format!("peak force in every direction (min / median / max over the {name})"),
        spread(&summary.force.peak, 1.0, force, 2),
    ));
    rows.push((
        "continuous force in every direction".into(),
        spread(&summary.force.continuous, 1.0, force, 2),
    ));
    rows.push((
        "apparent inertia (least / largest eigenvalue of Λ; largest ratio)".into(),
        format!(
            "{:.1} / {:.1} {mass}; {:.1}",
            summary.inertia.min_over_cube * mass_scale,
            summary.inertia.max_over_cube * mass_scale,
            summary.inertia.anisotropy_max_over_cube
        ),
    ));
    rows.push((
        "condition number of J (min / median / max)".into(),
        spread(&summary.isotropy.condition, 1.0, "", 2),
    ));
    rows.push((
        "global conditioning index".into(),
        format!("{:.3}", summary.isotropy.global_conditioning_index),
    ));
    rows.push(("gravity load (% of peak torque)".into(), spread(&summary.gravity.load_percent, 1.0, "%", 1)));
    rows.push((
        "resolution, one count at worst".into(),
        format!("{:.1} {fine}", summary.resolution.max_over_cube * 1e6),
    ));
    if let Some(k) = &summary.renderable_stiffness {
        rows.push((
            format!("stable wall stiffness (B = {} N·s/m; centre / least corner)", k.wall_damping),
            format!(
                "{} / {} (analytic bound 2(b + B)/T = {:.0} {force}/{})",
                k.describe(force, summary.task_unit),
                crate::design::StiffnessSummary { centre: k.min_over_corners, ..k.clone() }
                    .describe(force, summary.task_unit),
                k.stability_bound,
                summary.task_unit
            ),
        ));
    }
    let mut out = String::from("<table id=\"summary\">\n");
    for (what, value) in rows {
        let _ = writeln!(out, "<tr><th>{}</th><td>{}</td></tr>", escape_html(&what), escape_html(&value));
    }
    out.push_str("</table>\n");
    if let Some(c) = &summary.published {
        let _ = writeln!(
            out,
            "<h2>Beside the {}</h2>\n<table id=\"published\">\n<tr><th></th><th>this model</th><th>published</th></tr>",
            escape_html(&c.device)
        );
        for row in &c.rows {
            let _ = writeln!(
                out,
                "<tr><th>{}</th><td>{}</td><td>{}</td></tr>",
                escape_html(&row.figure),
                escape_html(&row.model),
                escape_html(&row.published)
            );
        }
        out.push_str("</table>\n<p>Why they differ:</p>\n<ul>\n");
        for note in &c.notes {
            let _ = writeln!(out, "<li>{}</li>", escape_html(note));
        }
        out.push_str("</ul>\n<p>Sources:</p>\n<ul>\n");
        for source in &c.sources {
            let _ = writeln!(out, "<li>{}</li>", escape_html(source));
        }
        out.push_str("</ul>\n");
    }
    out
}

/// The page: the figures as a table, the 3-D view, one slider per joint, the maps, and the
/// replay of a run if one is given (its data, [`crate::replay::page_data`]).
pub fn page(
    grid: &PoseGrid,
    workspace: &Workspace,
    summary: &Summary,
    maps: &[MapFile],
    dir: &Path,
    replay: Option<&str>,
) -> String {
    let core = format!("data:text/javascript;base64,{}", base64(THREE_CORE.as_bytes()));
    let module = format!("data:text/javascript;base64,{}", base64(THREE_MODULE.as_bytes()));
    let title = escape_html(&format!(
        "{}{}",
        summary.model,
        summary.variant.as_ref().map(|v| format!(" (variant {v})")).unwrap_or_default()
    ));
    let figures = escape_html(&summary.describe());
    let data = page_data(grid, workspace, summary).replace("</", "<\\/");
    let replay = replay.unwrap_or("null").replace("</", "<\\/");
    // The template is plain HTML with `@@NAME@@` slots, so that its script needs no escaping.
    PAGE_TEMPLATE
        .replace("@@TITLE@@", &title)
        .replace("@@FIGURES@@", &figures)
        .replace("@@TABLE@@", &figures_table(summary))
        .replace("@@MAPS@@", &maps_section(maps, dir))
        .replace("@@MODULE@@", &module)
        .replace("@@CORE@@", &core)
        .replace("@@DATA@@", &data)
        .replace("@@REPLAY@@", &replay)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_follows_rfc_4648() {
        for (plain, encoded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
    }

    #[test]
    fn the_view_grid_fits_its_budget() {
        for n in 1..=6 {
            let steps = view_steps(n);
            assert!(steps >= 2 && (steps.pow(n as u32) <= VIEW_STATES || steps == 2), "{n}: {steps}");
        }
        assert_eq!(view_steps(3), 16);
    }
}
