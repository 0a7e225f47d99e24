//! The published figures of the commercial devices the shipped models resemble
//! (`assets/published-devices.yaml`: the device, its sources, its datasheet figures and why
//! the model's may differ), set beside the figures `hapticgen report` computed for the model,
//! so that a designer sees the model's estimates against the real device's datasheet.

use serde::Deserialize;

use crate::design::{Comparison, Row, Summary};

/// The published figures, as shipped.
const PUBLISHED: &str = include_str!("../assets/published-devices.yaml");

/// One device's published figures (SI units; `None` where nothing is published).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Published {
    /// The model file's `name` this device is compared with.
    pub model: String,
    /// The device.
    pub device: String,
    /// Where the figures were published.
    pub sources: Vec<String>,
    /// The edge of the published workspace cube, m.
    #[serde(default)]
    pub cube_edge: Option<f64>,
    /// The radius of the published workspace sphere, m.
    #[serde(default)]
    pub sphere_radius: Option<f64>,
    /// The published workspace box, width × height × depth, m.
    #[serde(default, rename = "box")]
    pub workspace_box: Option<[f64; 3]>,
    /// The largest force, N.
    #[serde(default)]
    pub peak_force: Option<f64>,
    /// The continuous force, N.
    #[serde(default)]
    pub continuous_force: Option<f64>,
    /// The position resolution, m.
    #[serde(default)]
    pub resolution: Option<f64>,
    /// The apparent mass at the grip, at most, kg.
    #[serde(default)]
    pub inertia_max: Option<f64>,
    /// Why the model's figures may differ.
    pub notes: Vec<String>,
}

/// Every device of `assets/published-devices.yaml`.
pub fn all() -> Result<Vec<Published>, String> {
    serde_yaml::from_str(PUBLISHED).map_err(|e| format!("assets/published-devices.yaml: {e}"))
}

/// The comparison for `summary`'s model, if a device is published for it and its task is a point.
pub fn compare(summary: &Summary) -> Result<Option<Comparison>, String> {
    let Some(device) = all()?.into_iter().find(|p| p.model == summary.model) else { return Ok(None) };
    if summary.task_unit != "m" {
        return Ok(None);
    }
    let mm = |v: f64| format!("{:.1} mm", v * 1e3);
    let newtons = |v: f64| format!("{v:.2} N");
    let mut rows = Vec::new();
    let (name, cube) = summary.cube();
    let edge = cube.map_or(0.0, |c| c.edge);
    let published_space = match (device.cube_edge, device.workspace_box) {
        (Some(e), _) => Some(format!("cube, edge {}", mm(e))),
        (None, Some([w, h, d])) => Some(format!("box {:.0} × {:.0} × {:.0} mm", w * 1e3, h * 1e3, d * 1e3)),
        (None, None) => None,
    };
    if let Some(space) = published_space {
        rows.push(Row {
            figure: "workspace".into(),
            model: format!("inscribed {name}, edge {}", mm(edge)),
            published: space,
        });
    }
    if let (Some(r), Some((ball_name, ball))) = (device.sphere_radius, summary.ball()) {
        rows.push(Row {
            figure: "workspace sphere".into(),
            model: format!("inscribed {ball_name}, radius {}", mm(ball.radius)),
            published: format!("radius {}", mm(r)),
        });
    }
    if let Some(f) = device.peak_force {
        // A device publishing one force: the model's continuous force beside it too.
        let continuous = if device.continuous_force.is_none() {
            format!(" ({} continuous)", newtons(summary.force.continuous.min_over_cube))
        } else {
            String::new()
        };
        rows.push(Row {
            figure: "peak force".into(),
            model: format!(
                "{}{continuous} in every direction at worst over the {name}",
                newtons(summary.force.peak.min_over_cube)
            ),
            published: newtons(f),
        });
    }
    if let Some(f) = device.continuous_force {
        rows.push(Row {
            figure: "continuous force".into(),
            model: format!("{} at worst", newtons(summary.force.continuous.min_over_cube)),
            published: newtons(f),
        });
    }
    if let Some(r) = device.resolution {
        rows.push(Row {
            figure: "position resolution".into(),
            model: format!("{:.1} µm at worst", summary.resolution.max_over_cube * 1e6),
            published: format!("{:.1} µm", r * 1e6),
        });
    }
    if let Some(m) = device.inertia_max {
        rows.push(Row {
            figure: "apparent mass at the grip".into(),
            model: format!("{:.0} g in the heaviest direction at worst", summary.inertia.max_over_cube * 1e3),
            published: format!("< {:.0} g", m * 1e3),
        });
    }
    Ok(Some(Comparison { device: device.device, sources: device.sources, rows, notes: device.notes }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_published_figures_parse_and_name_shipped_models() {
        let devices = all().expect("the shipped file parses");
        assert!(devices.len() >= 3);
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        for d in &devices {
            assert!(models.join(format!("{}.yaml", d.model)).exists(), "{}: no such shipped model", d.model);
            assert!(!d.sources.is_empty() && !d.notes.is_empty(), "{}", d.model);
        }
    }
}
