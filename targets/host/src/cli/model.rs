//! The commands on a model file itself: `new` (a starting file from a template), `report`
//! (the device design figures), `check` (validation, with the stability and plausibility
//! checks), `schema` (the format's JSON Schema), `import-urdf` and `export-urdf`.

use std::path::Path;

use hapticgen_codegen::check::{plausibility, stability};
use hapticgen_codegen::{model, Diagnostics};

use super::{load, write_or_print, CliError, FileOp};

/// `hapticgen new`: writes the template's model file and says so (its warnings on standard
/// error).
pub fn new(rig: &crate::template::NewRig) -> Result<(), CliError> {
    let (path, written) = crate::template::run_new(rig)?;
    for warning in &written.warnings {
        eprintln!("{warning}");
    }
    println!("{}: written; it passes `hapticgen check`", path.display());
    Ok(())
}

/// `hapticgen report`: the design figures of `model_path` written to `output`, with the grid
/// of `steps` points per joint (default: [`crate::design::default_steps`]), the stiffest
/// stable wall if `zwidth`, and the run `replay` replayed in the page's view.
pub fn report(
    model_path: &Path,
    variant: Option<&str>,
    steps: Option<usize>,
    zwidth: bool,
    replay: Option<&Path>,
    output: &Path,
) -> Result<(), CliError> {
    let m = load(model_path, variant)?;
    let steps = steps.unwrap_or_else(|| crate::design::default_steps(m.joints.len())).max(2);
    // Read before anything is written: a bad run leaves no report behind.
    let replay = replay.map(|run| crate::replay::load(&m, run)).transpose().map_err(CliError::Input)?;
    if let Some(replay) = &replay {
        let scene = replay.scene.as_ref().map_or_else(
            || format!("no {} beside it: no objects drawn", crate::replay::SCENE_FILE),
            |s| format!("objects drawn: {}", s.objects.len()),
        );
        eprintln!(
            "report: replaying {} ({} rows as {} frames; {scene})",
            replay.trace.display(),
            replay.rows,
            replay.frames.len()
        );
    }
    let summary = crate::design_report::write_report(&m, steps, zwidth, replay.as_ref(), output)?;
    println!(
        "{}: {}; wrote {}",
        model_path.display(),
        summary.describe(),
        output.join("summary.json").display()
    );
    Ok(())
}

/// `hapticgen check`: loads `model_path` (every variant unless one is named), checks its
/// virtual wall and its plausibility as a device, and prints a line on what it is.
pub fn check(model_path: &Path, variant: Option<&str>) -> Result<(), CliError> {
    let m = load(model_path, variant)?;
    // Without --variant, every variant is checked, not only the default one.
    if variant.is_none() {
        for other in m.variants.iter().filter(|v| Some(*v) != m.variant.as_ref()) {
            load(model_path, Some(other))?;
        }
    }
    let mech = hapticgen_codegen::derive(&m);
    let text = std::fs::read_to_string(model_path).unwrap_or_default();
    let file = model_path.display().to_string();
    // Virtual walls: passivity (warning) and stability (error) bounds, see
    // `hapticgen_codegen::check::stability`.
    if let Some(wall) = stability::check_wall(&m, &mech) {
        if let Some((error, d)) = wall.diagnostic(&file, &text, &m) {
            if error {
                return Err(CliError::Refused(Diagnostics(vec![d])));
            }
            eprintln!("warning: {d}");
        }
    }
    // The model as a device: gravity against the drives, masses, lengths and inertias
    // against the bodies' sizes, a closed chain's branch (`check::plausibility`).
    let plausible = plausibility::plausibility(&m, &mech, &text);
    let mut errors = Vec::new();
    for finding in &plausible.findings {
        let d = finding.diagnostic(&file, &text, &m);
        match finding.severity {
            plausibility::Severity::Error => errors.push(d),
            plausibility::Severity::Warning => eprintln!("warning: {d}"),
        }
    }
    if !errors.is_empty() {
        return Err(CliError::Refused(Diagnostics(errors)));
    }

    // A closed chain also names its eliminated passive joints.
    let passive = match &m.analyses.closures {
        Some(c) => {
            let closures = c.loops.len() + m.spatial_closures.len();
            // A spatial chain's: in closed form, or by Newton's method and why.
            let solver = match &c.spatial {
                Some(s) if s.closed_form.is_some() => ", in closed form".to_string(),
                Some(s) => format!(
                    ", by Newton's method at run time; no closed form: {}",
                    s.newton_reason.as_deref().unwrap_or("not a Delta")
                ),
                None => String::new(),
            };
            format!(
                " (+{} passive, eliminated by {closures} closure{}{solver})",
                m.passive.len(),
                if closures == 1 { "" } else { "s" }
            )
        }
        None => String::new(),
    };
    // Massless bodies are the crosses of universal and spherical joints (the loader
    // adds them for a joint written as one entry) and the bodies measured joints move
    // (their mass lumped on the body carrying them).
    let massless = m.bodies.iter().filter(|b| b.mass.is_zero()).count();
    let measured = match m.measured.len() {
        0 => String::new(),
        k => format!(
            " (+{k} measured: {}, inputs of the frames)",
            m.measured.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ")
        ),
    };
    println!(
        "{}: ok: rig `{}`{}, {} joint{}{passive}{measured}, {} bodies{}, task dimension {}",
        model_path.display(),
        m.name,
        m.variant.as_ref().map(|v| format!(" (variant {v})")).unwrap_or_default(),
        m.joints.len(),
        if m.joints.len() == 1 { "" } else { "s" },
        m.bodies.len(),
        if massless > 0 { format!(" ({massless} of them massless)") } else { String::new() },
        m.task_dim()
    );
    if let Some(assembly) = &plausible.assembly {
        println!("{}: {}", model_path.display(), assembly.describe(&m));
    }
    Ok(())
}

/// `hapticgen schema`: prints the JSON Schema of the model format.
pub fn schema() -> Result<(), CliError> {
    print!("{}", model::json_schema());
    Ok(())
}

/// `hapticgen import-urdf`: the model file of a URDF robot, every joint with the drive of
/// the YAML file `drive` (default: the paper's motor), to `output` or standard output.
pub fn import_urdf(urdf: &Path, drive: Option<&Path>, output: Option<&Path>) -> Result<(), CliError> {
    let read = |p: &Path| std::fs::read_to_string(p).map_err(CliError::file(FileOp::Read, p));
    let text = read(urdf)?;
    let drive = match drive {
        Some(p) => read(p)?,
        None => hapticgen_codegen::urdf::DEFAULT_DRIVE.to_string(),
    };
    let display = urdf.display().to_string();
    let yaml = hapticgen_codegen::urdf::import(&text, &display, &drive)?;
    // What was written must load: a bad drive template is reported against it.
    hapticgen_codegen::load(&model::Source { name: "<imported model>", text: &yaml }, None)?;
    write_or_print(output, &yaml)
}

/// `hapticgen export-urdf`: a serial model as URDF, to `output` or standard output.
pub fn export_urdf(model_path: &Path, variant: Option<&str>, output: Option<&Path>) -> Result<(), CliError> {
    let m = load(model_path, variant)?;
    let text = hapticgen_codegen::urdf::export(&m)
        .map_err(|reason| CliError::Export { model: model_path.to_path_buf(), reason })?;
    write_or_print(output, &text)
}
