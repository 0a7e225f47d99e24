//! The design report's maps: every figure of [`crate::design::Figures`] (force capability,
//! apparent inertia and its anisotropy, the Jacobian's condition number, the gravity load and
//! the resolution) over planar slices of the task space through the inscribed hypercube's
//! centre, so that a designer sees where in the workspace a device is strong, light, isotropic
//! and fine, not only the spread over the cube.
//!
//! A spatial task gets two slices, the horizontal one through the centre (`x`–`y` at the
//! centre's `z`) and the vertical one (`x`–`z` at the centre's `y`); a planar task its plane;
//! a one-coordinate task its line. Each slice is a grid of [`MAP_CELLS`] cells per side over
//! the workspace's bounding box; a cell holds the figures at the joint state inverse
//! kinematics finds for its centre (damped Newton from the nearest workspace sample, within the
//! joint limits), or nothing where no such state exists: the map's blank is the workspace's
//! edge. Cells are evaluated in parallel (rayon).

use std::path::Path;

use rayon::prelude::*;

use crate::design::{Design, Figures, Workspace};
use crate::plot::{self, Chart, Heatmap, Series};

/// Cells per side of a map.
pub const MAP_CELLS: usize = 48;

/// A figure that is mapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Force in every direction from the torque limits.
    ForcePeak,
    /// Force in every direction from the current limits.
    ForceContinuous,
    /// The heaviest direction's apparent inertia.
    InertiaMax,
    /// The ratio of the heaviest to the lightest direction's apparent inertia.
    InertiaAnisotropy,
    /// The Jacobian's condition number.
    Condition,
    /// The gravity load, % of a drive's peak torque.
    GravityLoad,
    /// The largest step of one encoder count.
    Resolution,
}

impl Quantity {
    /// Every mapped quantity, in the report's order.
    pub const ALL: [Quantity; 7] = [
        Quantity::ForcePeak,
        Quantity::ForceContinuous,
        Quantity::InertiaMax,
        Quantity::InertiaAnisotropy,
        Quantity::Condition,
        Quantity::GravityLoad,
        Quantity::Resolution,
    ];

    /// The file name stem.
    pub fn stem(self) -> &'static str {
        match self {
            Quantity::ForcePeak => "force-peak",
            Quantity::ForceContinuous => "force-continuous",
            Quantity::InertiaMax => "inertia-max",
            Quantity::InertiaAnisotropy => "inertia-anisotropy",
            Quantity::Condition => "condition",
            Quantity::GravityLoad => "gravity-load",
            Quantity::Resolution => "resolution",
        }
    }

    /// What the map shows, with its unit (`point`: a task point in metres; else a task of
    /// joint coordinates in radians).
    pub fn label(self, point: bool) -> &'static str {
        match (self, point) {
            (Quantity::ForcePeak, true) => "peak force in every direction (N)",
            (Quantity::ForcePeak, false) => "peak torque in every direction (N·m)",
            (Quantity::ForceContinuous, true) => "continuous force in every direction (N)",
            (Quantity::ForceContinuous, false) => "continuous torque in every direction (N·m)",
            (Quantity::InertiaMax, true) => "apparent inertia, heaviest direction (g)",
            (Quantity::InertiaMax, false) => "apparent inertia, heaviest direction (kg·m²)",
            (Quantity::InertiaAnisotropy, _) => "apparent inertia, heaviest / lightest",
            (Quantity::Condition, _) => "condition number of J",
            (Quantity::GravityLoad, _) => "gravity load (% of peak torque)",
            (Quantity::Resolution, true) => "one encoder count, largest step (µm)",
            (Quantity::Resolution, false) => "one encoder count, largest step (µrad)",
        }
    }

    /// The quantity in the map's unit.
    pub fn value(self, f: &Figures, point: bool) -> f64 {
        let (mass, fine) = if point { (1e3, 1e6) } else { (1.0, 1e6) };
        match self {
            Quantity::ForcePeak => f.force_peak,
            Quantity::ForceContinuous => f.force_continuous,
            Quantity::InertiaMax => f.inertia_max * mass,
            Quantity::InertiaAnisotropy => f.inertia_max / f.inertia_min,
            Quantity::Condition => f.condition,
            Quantity::GravityLoad => f.gravity_load,
            Quantity::Resolution => f.resolution * fine,
        }
    }

    /// Whether the colours follow a logarithmic scale (quantities that span decades near a
    /// singular pose).
    pub fn log_scale(self) -> bool {
        matches!(self, Quantity::InertiaMax | Quantity::InertiaAnisotropy | Quantity::Condition)
    }
}

/// One slice of the task space and the figures over it.
#[derive(Clone, Debug)]
pub struct Slice {
    /// File name stem: the axes' names (`xy`, `xz`, `x`).
    pub stem: String,
    /// Where it lies, e.g. `z = -98.8 mm`.
    pub place: String,
    /// The task axes it spans (one or two).
    pub axes: Vec<usize>,
    /// The cells' centres along the first axis, task units.
    pub u: Vec<f64>,
    /// The cells' centres along the second axis (a single 0 for a line).
    pub v: Vec<f64>,
    /// Cell `(i, j)` at `cells[j * u.len() + i]`, or `None` out of reach.
    pub cells: Vec<Option<Cell>>,
}

/// A reached cell of a map.
#[derive(Clone, Debug)]
pub struct Cell {
    /// The joint state reaching the cell's centre.
    pub q: Vec<f64>,
    /// The figures there.
    pub figures: Figures,
}

const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

fn axis_name(k: usize) -> String {
    AXIS_NAMES.get(k).map_or_else(|| format!("x{k}"), |n| n.to_string())
}

/// `steps` evenly spaced cell centres over `[lo, hi]`.
fn centres(lo: f64, hi: f64, steps: usize) -> Vec<f64> {
    let width = (hi - lo) / steps as f64;
    (0..steps).map(|i| lo + (i as f64 + 0.5) * width).collect()
}

/// The slices of the workspace `ws` through its hypercube's centre, `cells` per side.
pub fn slices(design: &Design, ws: &Workspace, cells: usize) -> Vec<Slice> {
    let m = design.task_dim();
    let point = design.task_is_point();
    let (lower, upper) = ws.bounds();
    let plans: Vec<Vec<usize>> = match m {
        0 => Vec::new(),
        1 => vec![vec![0]],
        2 => vec![vec![0, 1]],
        _ => vec![vec![0, 1], vec![0, 2]],
    };
    plans
        .into_iter()
        .map(|axes| {
            let u = centres(lower[axes[0]], upper[axes[0]], cells);
            let v = axes.get(1).map_or_else(|| vec![0.0], |&k| centres(lower[k], upper[k], cells));
            let fixed: Vec<usize> = (0..m).filter(|k| !axes.contains(k)).collect();
            let (unit, scale) = if point { ("mm", 1e3) } else { ("rad", 1.0) };
            let place = fixed
                .iter()
                .map(|&k| format!("{} = {:.1} {unit}", axis_name(k), ws.centre[k] * scale))
                .collect::<Vec<_>>()
                .join(", ");
            let points: Vec<Vec<f64>> = v
                .iter()
                .flat_map(|&b| {
                    let axes = &axes;
                    u.iter().map(move |&a| {
                        let mut x = ws.centre.clone();
                        x[axes[0]] = a;
                        if let Some(&k) = axes.get(1) {
                            x[k] = b;
                        }
                        x
                    })
                })
                .collect();
            let cells = points
                .par_iter()
                .map(|x| {
                    let start = &ws.nearest(x).q;
                    let q = design.inverse_kinematics(x, start)?;
                    let figures = design.sample(&q).map(|s| design.figures(&s))?;
                    Some(Cell { q, figures })
                })
                .collect();
            Slice { stem: axes.iter().map(|&k| axis_name(k)).collect(), place, axes, u, v, cells }
        })
        .collect()
}

/// A written map: its quantity, slice and files (without extension, relative to the report's
/// directory).
#[derive(Clone, Debug)]
pub struct MapFile {
    /// What it shows.
    pub quantity: Quantity,
    /// The slice's stem.
    pub slice: String,
    /// What it shows, where: its title.
    pub caption: String,
    /// `maps/<quantity>-<slice>`, without extension.
    pub base: String,
}

/// Writes every quantity over every slice as `dir/maps/<quantity>-<slice>.svg` and `.png`, and
/// each slice's cells as `dir/maps/<slice>.csv`; returns the maps written.
pub fn write_maps(
    design: &Design,
    ws: &Workspace,
    slices: &[Slice],
    dir: &Path,
) -> Result<Vec<MapFile>, String> {
    let maps = dir.join("maps");
    std::fs::create_dir_all(&maps).map_err(|e| format!("cannot create {}: {e}", maps.display()))?;
    let point = design.task_is_point();
    let (unit, scale) = if point { ("mm", 1e3) } else { ("rad", 1.0) };
    let mut written = Vec::new();
    for slice in slices {
        let mut csv = String::new();
        let columns: Vec<String> = slice
            .axes
            .iter()
            .map(|&k| format!("{}_{}", axis_name(k), if point { "m" } else { "rad" }))
            .chain(Quantity::ALL.iter().map(|q| q.stem().replace('-', "_")))
            .collect();
        csv.push_str(&columns.join(","));
        csv.push('\n');
        for (k, cell) in slice.cells.iter().enumerate() {
            let Some(Cell { figures, .. }) = cell else { continue };
            let at = [slice.u[k % slice.u.len()], slice.v[k / slice.u.len()]];
            let row: Vec<String> = at[..slice.axes.len()]
                .iter()
                .copied()
                .chain(Quantity::ALL.iter().map(|q| q.value(figures, point)))
                .map(|v| format!("{}", crate::output::unsigned_zero(v)))
                .collect();
            csv.push_str(&row.join(","));
            csv.push('\n');
        }
        let path = maps.join(format!("{}.csv", slice.stem));
        std::fs::write(&path, csv).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        let half = 0.5 * ws.edge;
        for quantity in Quantity::ALL {
            let base = format!("{}-{}", quantity.stem(), slice.stem);
            let title = format!(
                "{}, {}",
                quantity.label(point),
                if slice.place.is_empty() { "the task plane" } else { &slice.place }
            );
            let caption = title.clone();
            let scaled = |v: &[f64]| v.iter().map(|x| x * scale).collect::<Vec<f64>>();
            if slice.axes.len() == 2 {
                let (a, b) = (slice.axes[0], slice.axes[1]);
                let heatmap = Heatmap {
                    title,
                    x_label: format!("{} ({unit})", axis_name(a)),
                    y_label: format!("{} ({unit})", axis_name(b)),
                    value_label: quantity.label(point).to_string(),
                    x: scaled(&slice.u),
                    y: scaled(&slice.v),
                    values: slice
                        .cells
                        .iter()
                        .map(|c| c.as_ref().map(|c| quantity.value(&c.figures, point)))
                        .collect(),
                    log_scale: quantity.log_scale(),
                    outline: Some((
                        ((ws.centre[a] - half) * scale, (ws.centre[b] - half) * scale),
                        ((ws.centre[a] + half) * scale, (ws.centre[b] + half) * scale),
                    )),
                };
                plot::save_heatmap(&heatmap, &maps.join(&base)).map_err(|e| e.replace("error: ", ""))?;
            } else {
                let points = slice
                    .u
                    .iter()
                    .zip(&slice.cells)
                    .filter_map(|(u, c)| c.as_ref().map(|c| (u * scale, quantity.value(&c.figures, point))))
                    .collect();
                let chart = Chart {
                    title,
                    x_label: format!("{} ({unit})", axis_name(slice.axes[0])),
                    y_label: quantity.label(point).to_string(),
                    series: vec![Series::line(quantity.label(point), points)],
                    equal_aspect: false,
                };
                plot::save(&chart, &maps.join(&base)).map_err(|e| e.replace("error: ", ""))?;
            }
            written.push(MapFile {
                quantity,
                slice: slice.stem.clone(),
                caption,
                base: format!("maps/{base}"),
            });
        }
    }
    Ok(written)
}
