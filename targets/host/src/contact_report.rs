//! `hapticgen contact`: every contact scenario ([`crate::contact`]) on one rig with a 3-D
//! task, friction off and on, the mesh scenario on a UV sphere and on a mesh file if one is
//! given; each run's figures (the standard ones, three projections of the path, force against
//! penetration) and one `report.md` with a pass/fail row per check, like `hapticgen paper`'s.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use hapticgen_runtime::control::ImpedanceLaw;

use crate::closed_loop::SimConfig;
use crate::contact::{self, Contact};
use crate::paper::trace_figures;
use crate::report::{self, Check};
use crate::simulation::{Scenario, ScenarioSettings, Simulation};

/// What `hapticgen contact` runs with.
#[derive(Clone, Debug)]
pub struct ContactRun {
    /// The impedance law (Controller 3 by default: no `J⁻¹`, no `J̇`).
    pub law: ImpedanceLaw,
    /// Friction coefficients of the run with friction, `(μ_s, μ_d)`.
    pub friction: (f64, f64),
    /// A mesh file for one more mesh run.
    pub mesh: Option<std::path::PathBuf>,
    /// How far the hand presses into a surface, m.
    pub push: f64,
    /// Only the runs of these names (`wall`, `slide`, `slide-friction`, `sphere`, `box-edges`,
    /// `thin-plate`, `mesh`, `mesh-FILE`); empty: every run.
    pub only: Vec<String>,
}

/// One run of the report: a scenario with its friction and mesh.
struct Run {
    name: String,
    contact: Contact,
    friction: (f64, f64),
    mesh: Option<std::sync::Arc<hapticgen_codegen::mesh::TriangleMesh>>,
}

/// Runs every scenario on `sim`, writes `out/<run>/` (trace and figures) and `out/report.md`;
/// returns the checks and a one-paragraph summary.
pub fn run_all(sim: &Simulation, run: &ContactRun, out: &Path) -> Result<(Vec<Check>, String), String> {
    let wall = Instant::now();
    let rendering = sim.model.rendering.as_ref();
    let (stiffness, damping) = rendering.map_or((1500.0, 5.0), |r| (r.wall_stiffness, r.wall_damping));
    let file_mesh = run.mesh.as_deref().map(contact::mesh_file).transpose()?;
    let frictionless = (0.0, 0.0);
    let mut runs: Vec<Run> = [
        ("wall", Contact::Wall, frictionless),
        ("slide", Contact::Slide, frictionless),
        ("slide-friction", Contact::Slide, run.friction),
        ("sphere", Contact::Sphere, frictionless),
        ("box-edges", Contact::BoxEdges, frictionless),
        ("thin-plate", Contact::ThinPlate, frictionless),
        ("mesh", Contact::Mesh, frictionless),
    ]
    .into_iter()
    .map(|(name, contact, friction)| Run { name: name.into(), contact, friction, mesh: None })
    .collect();
    if let (Some(mesh), Some(path)) = (file_mesh, &run.mesh) {
        let name = path.file_stem().map_or("file".into(), |s| s.to_string_lossy().into_owned());
        runs.push(Run {
            name: format!("mesh-{name}"),
            contact: Contact::Mesh,
            friction: frictionless,
            mesh: Some(mesh),
        });
    }
    if let Some(unknown) = run.only.iter().find(|name| !runs.iter().any(|r| &r.name == *name)) {
        let names: Vec<&str> = runs.iter().map(|r| r.name.as_str()).collect();
        return Err(format!("error: --only: no run `{unknown}`; the runs are {}", names.join(", ")));
    }
    runs.retain(|r| run.only.is_empty() || run.only.contains(&r.name));
    let mut checks = Vec::new();
    let mut sections = String::new();
    let mut simulated = 0.0;
    for Run { name, contact: kind, friction, mesh } in runs {
        let mut cfg = SimConfig::new(sim.home());
        cfg.law = run.law;
        cfg.stiffness = stiffness;
        cfg.damping = damping;
        let settings =
            ScenarioSettings { friction, mesh, push_depth: run.push, ..ScenarioSettings::default() };
        let setup = sim
            .apply_scenario(Scenario::Contact(kind), &settings, &mut cfg)?
            .ok_or_else(|| format!("error: scenario {name} placed nothing"))?;
        let trace = sim.run(&cfg)?;
        let dir = out.join(&name);
        std::fs::create_dir_all(&dir).map_err(|e| format!("error: cannot create {}: {e}", dir.display()))?;
        crate::output::write_csv(&trace, &dir.join("trace.csv"))?;
        crate::replay::write_scene(&cfg.reference, sim.task_dim(), &dir)?;
        trace_figures(&trace, &dir)?;
        simulated += trace.duration();
        let experiment = if friction.1 > 0.0 {
            format!("{name} (μ_s = {}, μ_d = {})", friction.0, friction.1)
        } else {
            name.clone()
        };
        checks.extend(contact::checks(&setup, &trace, &experiment));
        writeln!(
            sections,
            "## {experiment}\n\n![path, x0–x2]({name}/path_xz.svg) ![path, x0–x1]({name}/path_xy.svg) \
             ![force against penetration]({name}/force_penetration.svg)\n"
        )
        .ok();
    }
    let passed = checks.iter().filter(|c| c.pass).count();
    let mut text = introduction(&sim.model.file, run.law, stiffness, damping, run.push, passed, checks.len());
    text.push_str(&report::table(&checks));
    text.push('\n');
    text.push_str(&sections);
    std::fs::write(out.join("report.md"), text).map_err(|e| format!("error: cannot write report.md: {e}"))?;
    let mut summary = report::failures(&checks);
    write!(
        summary,
        "{passed} of {} checks pass; {simulated:.0} s simulated in {:.1} s; wrote {}",
        checks.len(),
        wall.elapsed().as_secs_f64(),
        out.join("report.md").display()
    )
    .ok();
    Ok((checks, summary))
}

/// The controller's name in the paper's numbering.
fn controller_name(law: ImpedanceLaw) -> &'static str {
    match law {
        ImpedanceLaw::ForceFeedback => "1",
        ImpedanceLaw::AccelerationFeedback => "2 (first variant)",
        ImpedanceLaw::NaturalInertia => "2 (second variant)",
        ImpedanceLaw::JacobianTranspose => "3",
    }
}

/// The report's title and first paragraph: the model file, controller, surfaces' stiffness (N/m)
/// and damping (N·s/m), how far the hand presses (m, printed in mm) and how many checks pass.
fn introduction(
    file: &str,
    law: ImpedanceLaw,
    stiffness: f64,
    damping: f64,
    push: f64,
    passed: usize,
    total: usize,
) -> String {
    format!(
        "# Contact scenarios: {file}\n\nThe contact scenarios of `hapticgen simulate` (targets/host/src/contact.rs) run \
         on the model's generated code with the god object of the runtime rendering the solids, Controller {}, \
         K = {stiffness} N/m and B = {damping} N·s/m on every surface, a hand of 200 N/m and 1 N·s/m pressing {:.1} mm \
         into a surface; the plant with \
         its friction, backlash, encoder and sensor quantisation and motor electrics. The checks read the trace: \
         the proxy against each solid's own inside test, the rendered force's direction from the proxy's offset \
         from the HIP the controller measured.\n\n**{passed} of {total} checks pass.**\n\n",
        controller_name(law),
        1e3 * push,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paragraph quotes the numbers it was given, each in its place.
    #[test]
    fn the_introduction_quotes_its_numbers_in_place() {
        let text =
            introduction("models/falcon_delta.yaml", ImpedanceLaw::NaturalInertia, 1500.0, 5.0, 0.004, 7, 9);
        assert!(text.starts_with("# Contact scenarios: models/falcon_delta.yaml\n"), "{text}");
        assert!(text.contains("Controller 2 (second variant), K = 1500 N/m and B = 5 N·s/m"), "{text}");
        assert!(text.contains("pressing 4.0 mm into a surface"), "{text}");
        assert!(text.contains("**7 of 9 checks pass.**"), "{text}");
        let text = introduction("m.yaml", ImpedanceLaw::JacobianTranspose, 800.0, 2.5, 0.010, 1, 1);
        assert!(
            text.contains("Controller 3, K = 800 N/m and B = 2.5 N·s/m") && text.contains("pressing 10.0 mm"),
            "{text}"
        );
    }
}
