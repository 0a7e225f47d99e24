//! `hapticgen report`: the design report written to a directory. It computes the figures
//! ([`crate::design::summarise`]), sets the published device's beside them
//! ([`crate::design_published`]), and writes `summary.json`, `workspace.csv`, the maps
//! ([`crate::design_maps`]) and the page ([`crate::design_page`], with a replayed run from
//! [`crate::replay`] if given). The modules it calls depend on [`crate::design`]'s types, never
//! on this one or on each other in a circle.

use std::path::Path;

use hapticgen_codegen::CheckedModel;

use crate::design::{summarise, Design, DesignError, Summary};

/// `hapticgen report`: writes `summary.json`, `workspace.csv` (every grid sample's joint
/// coordinates, task point and figures), the maps ([`crate::design_maps`], `maps/`) and the
/// page `index.html` ([`crate::design_page`], with `replay`'s run if given) to `dir`.
pub fn write_report(
    model: &CheckedModel,
    steps: usize,
    zwidth: bool,
    replay: Option<&crate::replay::Replay>,
    dir: &Path,
) -> Result<Summary, DesignError> {
    let (summary, ws) = summarise(model, steps, zwidth)?;
    let published = crate::design_published::compare(&summary).map_err(DesignError::Map)?;
    let summary = Summary { published, ..summary };
    let replay_data = replay.map(crate::replay::page_data);
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::create_dir_all(dir)
            .and_then(|_| std::fs::write(&path, text))
            .map_err(|e| DesignError::Write(path.display().to_string(), e))
    };
    write("summary.json", crate::output::to_json(&summary, true).unwrap_or_default() + "\n")?;
    let design = Design::new(model);
    let (n, m) = (design.joints(), design.task_dim());
    let mut csv = String::new();
    let names: Vec<String> = (0..n)
        .map(|j| format!("q{j}_rad"))
        .chain((0..m).map(|k| format!("x{k}_m")))
        .chain(
            [
                "force_peak_N",
                "force_continuous_N",
                "inertia_min_kg",
                "inertia_max_kg",
                "condition",
                "gravity_load_percent",
                "resolution_m",
            ]
            .map(String::from),
        )
        .collect();
    csv.push_str(&names.join(","));
    csv.push('\n');
    for s in &ws.samples {
        let f = design.figures(s);
        let row: Vec<String> =
            s.q.iter()
                .chain(&s.position)
                .copied()
                .chain([
                    f.force_peak,
                    f.force_continuous,
                    f.inertia_min,
                    f.inertia_max,
                    f.condition,
                    f.gravity_load,
                    f.resolution,
                ])
                .map(|v| format!("{}", crate::output::unsigned_zero(v)))
                .collect();
        csv.push_str(&row.join(","));
        csv.push('\n');
    }
    write("workspace.csv", csv)?;
    eprintln!(
        "report: maps over {} slice(s), {} cells per side",
        m.min(3).saturating_sub(1).max(1),
        crate::design_maps::MAP_CELLS
    );
    let slices = crate::design_maps::slices(&design, &ws, crate::design_maps::MAP_CELLS);
    let maps = crate::design_maps::write_maps(&design, &ws, &slices, dir).map_err(DesignError::Map)?;
    let view = crate::design_page::pose_grid(model, crate::design_page::view_steps(n));
    write("index.html", crate::design_page::page(&view, &ws, &summary, &maps, dir, replay_data.as_deref()))?;
    Ok(summary)
}
