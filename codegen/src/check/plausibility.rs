//! Plausibility of a model as a device: the numbers a haptic device or small robot can have,
//! checked against the physics they imply, so that a model typed in the wrong unit or with a
//! mirrored point is caught at `hapticgen check` with numbers, not later as a fault of the
//! simulated device.
//!
//! Each check compares the model with itself, never with a list of typical values:
//!
//! - **Gravity load**: the static torque `g(q)` of eq. (1) over the box of the joint limits
//!   (a grid of the actuated coordinates, corners and middle included), mapped to the drives
//!   through the transmission (`τ_drive = C⁻ᵀ τ_joint`), against each drive's `torque_limit`.
//!   Beyond the limit in at least 90 % of the box the rig cannot work: an error. Beyond it in
//!   part of the box: a warning naming the worst pose and the share of the box.
//! - **Masses**: a body heavier than a solid steel block enclosing it as the model describes it
//!   (a cube of side twice its reach: the farthest of its centre of mass, doubled, its points
//!   and its children's joints from its frame) — the signature of grams typed as kilograms.
//! - **Lengths**: a body larger than 2 m — millimetres typed as metres.
//! - **Inertias**: a radius of gyration about the centre of mass, `√(I_max / m)`, larger than
//!   the body — an inertia typed in g·cm² or kg·mm² as kg·m².
//! - **Closed chains**: which assembly branch the file's `assembly` angles led to (the task
//!   point and the passive angles at the middle of the joint ranges, [`AssemblyReport`]), and
//!   whether a body the closures' perpendicular conditions keep from turning (a Delta's
//!   platform) turns over the joint box, measured from the points declared on it.

use crate::check::CheckedModel;
use crate::diag::Diagnostic;
use crate::dynamics::mechanics::Mechanics;
use crate::eval::{Full, NominalAtoms};
use crate::math::grid::box_grid;
use crate::math::vector::norm;
use crate::model::positions::{PositionIndex, Segment};
use crate::model::Model;
use crate::model::{Motion, TaskSpec};
use crate::sym::poly::State;

/// Density of steel, kg/m³: the heaviest material a device's links are made of.
pub const STEEL_DENSITY: f64 = 7850.0;

/// The largest extent of a body of a haptic device or small robot, m.
pub const LARGEST_BODY: f64 = 2.0;

/// The share of the joint box, %, beyond which a drive that cannot hold the rig against gravity
/// makes the model an error rather than a warning.
pub const UNHOLDABLE_SHARE: f64 = 90.0;

/// How many times its reach a body's radius of gyration may be before its inertia is flagged.
pub const GYRATION_SLACK: f64 = 4.0;

/// The largest number of grid points of the joint box the load checks evaluate.
const GRID_POINTS: usize = 4096;

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// The model can work, but a number looks wrong.
    Warning,
    /// The model cannot work as written.
    Error,
}

/// One plausibility finding, at a key path of the model file.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// Warning or error.
    pub severity: Severity,
    /// Key path of the value at fault in the file as written (`bodies[2].mass`).
    pub path: Vec<Segment>,
    /// The same value as a variant's `set` addresses it (`bodies.thigh1.mass`).
    pub variant_path: String,
    /// What is implausible, with the numbers.
    pub message: String,
    /// What the user probably meant.
    pub hint: Option<String>,
}

impl Finding {
    /// The finding as a diagnostic at the value's line and column in `text` (the variant's
    /// `set` entry where the model's variant overrides the value).
    pub fn diagnostic(&self, file: &str, text: &str, model: &Model) -> Diagnostic {
        let index = PositionIndex::build(text);
        let key = |k: &str| Segment::Key(k.to_string());
        let overridden = model
            .variant
            .as_ref()
            .map(|v| vec![key("variants"), key(v), key("set"), key(&self.variant_path)]);
        let (line, column) = match overridden {
            Some(path) if index.contains(&path) => index.value(&path),
            _ => index.value(&self.path),
        };
        Diagnostic {
            file: file.to_string(),
            line,
            column,
            path: crate::model::positions::display_path(&self.path),
            message: self.message.clone(),
            hint: self.hint.clone(),
        }
    }
}

/// A closed chain's assembly as the file's `assembly` angles lead to it.
#[derive(Clone, Debug, PartialEq)]
pub struct AssemblyReport {
    /// The actuated coordinates at the middle of their ranges.
    pub middle: Vec<f64>,
    /// The task point there (base frame, m), if the task is a point.
    pub task_point: Option<Vec<f64>>,
    /// The passive joints' names and angles there (rad, in `(−π, π]`).
    pub passive: Vec<(String, f64)>,
}

/// Everything the plausibility checks found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plausibility {
    /// Findings, errors and warnings, in the file's order of sections.
    pub findings: Vec<Finding>,
    /// A closed chain's assembly branch at mid-range.
    pub assembly: Option<AssemblyReport>,
    /// Grid points of the joint box evaluated, and how many of them the loops closed at.
    pub grid: (usize, usize),
}

impl Plausibility {
    /// `true` if any finding is an error.
    pub fn has_errors(&self) -> bool {
        self.findings.iter().any(|f| f.severity == Severity::Error)
    }
}

fn key(k: &str) -> Segment {
    Segment::Key(k.to_string())
}

/// Values per joint of the grid of `n` joints: odd (the middle is on it), at least 3 (corners
/// and middle), at most 15, as many as [`GRID_POINTS`] allows.
fn grid_steps(n: usize) -> usize {
    let mut steps = 3usize;
    while (steps + 2).checked_pow(n as u32).is_some_and(|p| p <= GRID_POINTS) && steps < 15 {
        steps += 2;
    }
    steps
}

/// The grid of the actuated joints' box: `steps` values per joint from lower to upper limit,
/// `steps` as large as [`GRID_POINTS`] allows, at least 3 (corners and middle).
fn joint_grid(model: &Model) -> Vec<Vec<f64>> {
    let bounds: Vec<(f64, f64)> = model.joints.iter().map(|j| (j.lower, j.upper)).collect();
    box_grid(&bounds, grid_steps(bounds.len())).collect()
}

/// `x` with `digits` decimals, never `-0.000`: a value that rounds to zero is printed as zero.
fn fixed(x: f64, digits: usize) -> String {
    let text = format!("{x:.digits$}");
    match text.strip_prefix('-') {
        Some(magnitude) if magnitude.chars().all(|c| c == '0' || c == '.') => magnitude.to_string(),
        _ => text,
    }
}

fn format_vector(v: &[f64], digits: usize) -> String {
    let parts: Vec<String> = v.iter().map(|&x| fixed(x, digits)).collect();
    format!("({})", parts.join(", "))
}

/// Runs every plausibility check on a checked model and its mechanics.
/// `text` is the model file's text, for where the file lists each body.
pub fn plausibility(model: &CheckedModel, mech: &Mechanics, text: &str) -> Plausibility {
    let text_names = FileNames::of(text);
    let mut findings = Vec::new();
    let parameters: Vec<f64> = model.tunable.iter().map(|p| p.value).collect();
    let grid = joint_grid(model);
    let zero = vec![0.0; model.joints.len()];
    // Every grid state's full atom values, once: the loads and the rotation check share them.
    let mut closed = 0;
    let mut loads: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut task_body_points: Vec<Vec<[f64; 3]>> = Vec::new();
    let turning = TurningCheck::of(model, mech);
    for q in &grid {
        let state = State { q, qd: &zero, parameters: &parameters };
        let full = Full::new(mech, &state);
        let gravity: Vec<f64> = mech.gravity.iter().map(|g| g.eval(&full)).collect();
        if gravity.iter().any(|g| !g.is_finite()) {
            continue; // the loops do not close here
        }
        closed += 1;
        loads.push((q.clone(), drive_torques(model, &gravity)));
        if let Some(t) = &turning {
            task_body_points.push(t.points_at(mech, &full));
        }
    }
    let middle: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
    let middle_load = {
        let state = State { q: &middle, qd: &zero, parameters: &parameters };
        let full = Full::new(mech, &state);
        let gravity: Vec<f64> = mech.gravity.iter().map(|g| g.eval(&full)).collect();
        gravity.iter().all(|g| g.is_finite()).then(|| drive_torques(model, &gravity))
    };
    findings.extend(gravity_findings(model, &loads, middle_load.as_deref(), grid.len()));
    findings.extend(body_findings(model, &parameters, &text_names));
    if let Some(t) = &turning {
        findings.extend(t.findings(model, &task_body_points));
    }
    let assembly = assembly_report(model, mech, &parameters);
    Plausibility { findings, assembly, grid: (grid.len(), closed) }
}

/// The drives' torques for joint torques `tau`: `C⁻ᵀ τ` through a transmission, else `τ`.
fn drive_torques(model: &Model, tau: &[f64]) -> Vec<f64> {
    match &model.coupling {
        Some(c) => {
            (0..tau.len()).map(|i| (0..tau.len()).map(|j| c.joint_from_drive[j][i] * tau[j]).sum()).collect()
        }
        None => tau.to_vec(),
    }
}

fn torque_unit(model: &Model, joint: usize) -> &'static str {
    match model.joints[joint].kind {
        crate::model::schema::JointKind::Prismatic => "N",
        _ => "N·m",
    }
}

/// Gravity against each drive's torque limit over the grid.
/// `middle`: the drives' torques at the middle of the joint ranges, if the loops close there.
fn gravity_findings(
    model: &Model,
    loads: &[(Vec<f64>, Vec<f64>)],
    middle: Option<&[f64]>,
    grid: usize,
) -> Vec<Finding> {
    let mut out = Vec::new();
    if loads.is_empty() {
        return out;
    }
    for (i, joint) in model.joints.iter().enumerate() {
        let limit = joint.drive.torque_limit;
        if limit.is_nan() || limit <= 0.0 {
            continue;
        }
        let (worst_q, worst) = loads
            .iter()
            .map(|(q, tau)| (q, tau[i].abs()))
            .fold((&loads[0].0, 0.0), |acc, (q, t)| if t > acc.1 { (q, t) } else { acc });
        let beyond = loads.iter().filter(|(_, tau)| tau[i].abs() > limit).count();
        if beyond == 0 {
            continue;
        }
        let unit = torque_unit(model, i);
        let share = 100.0 * beyond as f64 / loads.len() as f64;
        // A rig its drives cannot hold in nearly all of its box cannot work; one they cannot
        // hold in part of it (an arm stretched out sideways) can, within the rest.
        let cannot_work = share >= UNHOLDABLE_SHARE;
        let middle = match middle.map(|tau| tau[i].abs()) {
            Some(needed) => format!(", {needed:.3} {unit} at the middle of the joint ranges"),
            None => String::new(),
        };
        let message = format!(
            "drive `{}` of joint `{}` cannot hold the rig against gravity in {share:.0} % of the joint box: it \
             needs up to {worst:.3} {unit} (at q = {} rad){middle}, against a torque limit of {limit} {unit}",
            joint.drive_name,
            joint.name,
            format_vector(worst_q, 3)
        );
        let hint = format!(
            "gravity torque over {} poses of the joint limits' box ({} where the loops close); masses are in kg \
             and lengths in m (`30 g`, `37.2 mm` with units), torque_limit is joint-side",
            grid,
            loads.len()
        );
        out.push(Finding {
            severity: if cannot_work { Severity::Error } else { Severity::Warning },
            path: vec![key("drives"), key(&joint.drive_name), key("torque_limit")],
            variant_path: format!("drives.{}.torque_limit", joint.drive_name),
            message,
            hint: Some(hint),
        });
    }
    // One finding per drive (joints sharing a drive): the most severe, else the first.
    let mut per_drive: Vec<Finding> = Vec::new();
    for f in out {
        match per_drive.iter_mut().find(|kept| kept.path == f.path) {
            Some(kept) if kept.severity == Severity::Warning && f.severity == Severity::Error => *kept = f,
            Some(_) => {}
            None => per_drive.push(f),
        }
    }
    per_drive
}

/// Where the file lists each body, by name: bodies the loader added (a universal joint's
/// cross) are not in the file and have no entry.
struct FileNames {
    bodies: Vec<String>,
}

impl FileNames {
    fn of(text: &str) -> FileNames {
        let bodies = serde_yaml::from_str::<serde_yaml::Value>(text)
            .ok()
            .and_then(|v| v.get("bodies").and_then(|b| b.as_sequence()).cloned())
            .map(|seq| {
                seq.iter().map(|b| b.get("name").and_then(|n| n.as_str()).unwrap_or("").to_string()).collect()
            })
            .unwrap_or_default();
        FileNames { bodies }
    }

    fn body(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b == name)
    }
}

/// Each body's extent, m: the farthest of twice its centre of mass, its points, its
/// children's joint origins (and a Denavit–Hartenberg link's own offset), from its frame.
fn extents(model: &Model, atoms: &NominalAtoms<'_>) -> Vec<f64> {
    let at = |p: &[crate::sym::poly::Poly; 3]| [p[0].eval(atoms), p[1].eval(atoms), p[2].eval(atoms)];
    let mut extent: Vec<f64> = model.bodies.iter().map(|b| 2.0 * norm(at(&b.com))).collect();
    for point in &model.points {
        if let Some(b) = point.body {
            extent[b] = extent[b].max(norm(at(&point.position)));
        }
    }
    for (k, body) in model.bodies.iter().enumerate() {
        match &body.motion {
            Motion::Serial { parent, xyz, tail, .. } => {
                if let Some(p) = parent {
                    extent[*p] = extent[*p].max(norm(at(xyz)));
                }
                if let Some(t) = tail {
                    extent[k] = extent[k].max(norm(at(&t.xyz)));
                }
            }
            Motion::Direct { origin_body: Some(p), point, .. } => {
                extent[*p] = extent[*p].max(norm(at(point)));
            }
            _ => {}
        }
    }
    extent
}

/// Masses, lengths and inertias against the bodies' own sizes.
fn body_findings(model: &Model, parameters: &[f64], names: &FileNames) -> Vec<Finding> {
    let atoms = NominalAtoms(parameters);
    let extent = extents(model, &atoms);
    let mut out = Vec::new();
    for (k, body) in model.bodies.iter().enumerate() {
        let Some(file_index) = names.body(&body.name) else { continue };
        let at = |path: &str| vec![key("bodies"), Segment::Index(file_index), key(path)];
        let mass = body.mass.eval(&atoms);
        let size = extent[k];
        if size > LARGEST_BODY {
            out.push(Finding {
                severity: Severity::Warning,
                path: vec![key("bodies"), Segment::Index(file_index)],
                variant_path: format!("bodies.{}", body.name),
                message: format!(
                    "body `{}` reaches {size:.3} m from its frame (centre of mass, points or the next joint): larger \
                     than a haptic device or small robot ({LARGEST_BODY} m)",
                    body.name
                ),
                hint: Some(format!(
                    "lengths are in metres: did you mean {} m? write `{} mm` to give millimetres",
                    trim(size / 1000.0),
                    trim(size)
                )),
            });
            continue; // its mass and inertia are judged against a size that is itself wrong
        }
        // Every part of the body within `size` of its frame fits in a cube of side 2·size.
        let cube = STEEL_DENSITY * (2.0 * size).powi(3);
        if size > 0.0 && mass > cube {
            out.push(Finding {
                severity: Severity::Warning,
                path: at("mass"),
                variant_path: format!("bodies.{}.mass", body.name),
                message: format!(
                    "body `{}` weighs {} kg, more than a solid steel cube enclosing it ({size:.3} m from its frame: a cube \
                     of side {:.3} m, {cube:.3} kg)",
                    body.name,
                    trim(mass),
                    2.0 * size
                ),
                hint: Some(format!(
                    "masses are in kilograms: did you mean {} g ({} kg)? write `{} g` to give grams",
                    trim(mass),
                    trim(mass / 1000.0),
                    trim(mass)
                )),
            });
            continue;
        }
        let inertia: Vec<f64> = (0..3).map(|i| body.inertia[i][i].eval(&atoms)).collect();
        let largest = inertia.iter().copied().fold(0.0, f64::max);
        if mass > 0.0 && size > 0.0 && largest > 0.0 {
            let gyration = (largest / mass).sqrt();
            // A body within `size` of its frame has a radius of gyration below `size`; the
            // model's reach is only a lower bound of the real body (a wrist's housing has no
            // point in the file), so only a gyration several times larger is flagged: an inertia
            // in kg·mm² is 1000² times too large, a gyration 1000 times.
            if gyration > GYRATION_SLACK * size {
                out.push(Finding {
                    severity: Severity::Warning,
                    path: at("inertia"),
                    variant_path: format!("bodies.{}.inertia", body.name),
                    message: format!(
                        "body `{}`'s largest moment of inertia {} kg·m² means a radius of gyration of {gyration:.3} m \
                         about its centre of mass, more than {GYRATION_SLACK} times the body's reach ({size:.3} m)",
                        body.name,
                        trim(largest)
                    ),
                    hint: Some(format!(
                        "inertias are in kg·m² about the centre of mass: did you mean {} kg·m² (the value in kg·mm²)? \
                         write `{} kg mm^2` to give kg·mm², or use a shorthand (`rod`, `box`, …)",
                        trim(largest * 1e-6),
                        trim(largest)
                    )),
                });
            }
        }
    }
    out
}

/// A number printed with at most nine significant digits and no more than it has (`0.03`,
/// `30`, `1.7e-7`).
fn trim(x: f64) -> String {
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    if rounded == 0.0 || (1e-3..1e6).contains(&rounded.abs()) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}

/// The turning of a body the closures' perpendicular conditions keep from turning.
struct TurningCheck {
    /// The task point's body, in the model's order.
    body: usize,
    /// Indices into the mechanics' points of the points declared on it (at least two).
    points: Vec<usize>,
}

impl TurningCheck {
    /// The check, for a spatial closed chain with perpendicular conditions whose task point's
    /// body carries at least two points.
    fn of(model: &Model, mech: &Mechanics) -> Option<TurningCheck> {
        if !model.spatial_closures.iter().any(|c| c.perpendicular.is_some()) {
            return None;
        }
        let TaskSpec::Point(task) = model.task else { return None };
        let body = model.points[task].body?;
        let points: Vec<usize> = (0..model.points.len())
            .filter(|&k| model.points[k].body == Some(body) && k < mech.points.len())
            .collect();
        (points.len() >= 2).then_some(TurningCheck { body, points })
    }

    fn points_at(&self, mech: &Mechanics, full: &Full<'_>) -> Vec<[f64; 3]> {
        self.points
            .iter()
            .map(|&k| {
                let p = &mech.points[k].position;
                let get = |i: usize| p.get(i).map_or(0.0, |x| x.eval(full));
                [get(0), get(1), get(2)]
            })
            .collect()
    }

    /// A finding if the body turns over the grid states (`states`: the body's points at each).
    fn findings(&self, model: &Model, states: &[Vec<[f64; 3]>]) -> Vec<Finding> {
        let worst = largest_turn(states);
        // A translating body's chords keep their direction to rounding.
        if worst.to_degrees() < 0.01 {
            return Vec::new();
        }
        let body = &model.bodies[self.body];
        let names: Vec<&str> = self.points.iter().map(|&k| model.points[k].name.as_str()).collect();
        vec![Finding {
            severity: Severity::Warning,
            path: vec![key("closures")],
            variant_path: "closures".into(),
            message: format!(
                "body `{}` turns by up to {:.2}° over the joint box (the chords between its points {} change \
                 direction), though the closures' perpendicular conditions are there to keep it translating",
                body.name,
                worst.to_degrees(),
                names.join(", ")
            ),
            hint: Some(
                "check the signs of the points on it and the perpendicular axes (a Delta's platform points sit at \
                 the same angles as the legs' base points)"
                    .into(),
            ),
        }]
    }
}

/// The largest angle, over `states`, between a chord of a body's points (from its first point
/// to each other) and the same chord at the first state, rad: a translating body keeps every
/// chord's direction.
fn largest_turn(states: &[Vec<[f64; 3]>]) -> f64 {
    let Some(first) = states.first() else { return 0.0 };
    let chord = |ps: &[[f64; 3]], k: usize| {
        let (a, b) = (ps[0], ps[k]);
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
    };
    let mut worst: f64 = 0.0;
    for ps in states {
        for k in 1..ps.len().min(first.len()) {
            let (u, v) = (chord(first, k), chord(ps, k));
            if norm(u) < 1e-9 || norm(v) < 1e-9 {
                continue;
            }
            let cross = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            let dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
            worst = worst.max(norm(cross).atan2(dot));
        }
    }
    worst
}

/// A closed chain's task point and passive angles at the middle of the joint ranges.
fn assembly_report(model: &Model, mech: &Mechanics, parameters: &[f64]) -> Option<AssemblyReport> {
    if model.passive.is_empty() || mech.closures.is_none() {
        return None;
    }
    let middle: Vec<f64> = model.joints.iter().map(|j| 0.5 * (j.lower + j.upper)).collect();
    let zero = vec![0.0; middle.len()];
    let state = State { q: &middle, qd: &zero, parameters };
    let evaluated = crate::eval::evaluate(mech, &state, None);
    let task_point = matches!(model.task, TaskSpec::Point(_)).then(|| evaluated.p.clone());
    let passive =
        model.passive.iter().map(|p| p.name.clone()).zip(evaluated.passive.iter().copied()).collect();
    Some(AssemblyReport { middle, task_point, passive })
}

impl AssemblyReport {
    /// One line for `hapticgen check`: the branch the assembly angles led to.
    pub fn describe(&self, model: &Model) -> String {
        let passive: Vec<String> =
            self.passive.iter().map(|(name, angle)| format!("{name} {}", fixed(*angle, 3))).collect();
        let point = match (&self.task_point, &model.task) {
            (Some(p), TaskSpec::Point(k)) => {
                format!("the task point `{}` at {} m, ", model.points[*k].name, format_vector(p, 4))
            }
            _ => String::new(),
        };
        format!(
            "assembly branch: at the middle of the joint ranges, q = {} rad: {point}passive joints (rad) {}",
            format_vector(&self.middle, 3),
            passive.join(", ")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three points of a body, turned by `angle` about the axis `(1, 1, 1)/√3` and moved by `shift`.
    fn body_at(angle: f64, shift: [f64; 3]) -> Vec<[f64; 3]> {
        let (c, s, k) = (angle.cos(), angle.sin(), 1.0 / 3f64.sqrt());
        let axis = [k, k, k];
        [[0.0, 0.0, 0.0], [0.02, -0.02, 0.0], [0.01, 0.0, -0.01]]
            .iter()
            .map(|p| {
                // Rodrigues: p c + (a × p) s + a (a·p)(1 − c).
                let cross = [
                    axis[1] * p[2] - axis[2] * p[1],
                    axis[2] * p[0] - axis[0] * p[2],
                    axis[0] * p[1] - axis[1] * p[0],
                ];
                let dot = axis[0] * p[0] + axis[1] * p[1] + axis[2] * p[2];
                let turned: Vec<f64> =
                    (0..3).map(|i| p[i] * c + cross[i] * s + axis[i] * dot * (1.0 - c) + shift[i]).collect();
                [turned[0], turned[1], turned[2]]
            })
            .collect()
    }

    #[test]
    fn a_translating_body_does_not_turn_and_a_turning_one_turns_by_its_angle() {
        let translating: Vec<_> =
            (0..10).map(|i| body_at(0.0, [0.01 * i as f64, -0.02, 0.005 * i as f64])).collect();
        assert!(largest_turn(&translating) < 1e-12);
        let turning: Vec<_> =
            (0..=10).map(|i| body_at(0.005 * i as f64, [0.01 * i as f64, 0.0, 0.0])).collect();
        // Chords square to the axis turn by the body's angle.
        let turn = largest_turn(&turning);
        assert!((turn - 0.05).abs() < 1e-12, "{turn}");
    }

    #[test]
    fn numbers_are_printed_with_the_digits_they_have() {
        assert_eq!(trim(0.020000000000000004), "0.02");
        assert_eq!(trim(20.0), "20");
        assert_eq!(trim(6e-6), "6e-6");
        assert_eq!(trim(1.7e-7), "1.7e-7");
        assert_eq!(trim(0.0), "0");
        assert_eq!(fixed(-1e-17, 4), "0.0000");
        assert_eq!(fixed(-0.00004, 4), "0.0000");
        assert_eq!(fixed(-0.00006, 4), "-0.0001");
    }

    #[test]
    fn the_grid_has_corners_and_middle_within_its_budget() {
        for n in 1..=7 {
            let steps = grid_steps(n);
            assert!((3..=15).contains(&steps) && steps % 2 == 1, "{n}: {steps}");
            assert!(steps.pow(n as u32) <= GRID_POINTS.max(3usize.pow(n as u32)), "{n}: {steps}");
            assert!(steps == 15 || (steps + 2).pow(n as u32) > GRID_POINTS, "{n}: {steps} could be finer");
        }
    }
}
