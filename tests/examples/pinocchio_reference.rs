//! Reference data for the Pinocchio cross-check (`scripts/pinocchio-check.sh`).
//!
//! For every serial model of `models/` and `codegen/tests/good-models/` (every variant), writes
//! into the directory given as the first argument `NAME.urdf` (the model exported with
//! `hapticgen_codegen::urdf::export`) and `NAME.json`: the gravity vector, the rotor inertia
//! `N²·J_m` each joint adds to `D`'s diagonal, and at 50 random states within the joint limits
//! hapticgen's `D`, `C q̇ + g`, `g` and, for every named point, its position and Jacobian
//! (3 rows; planar models padded with a zero z row), and for every named frame its rotation
//! matrix and angular-velocity Jacobian. Models with direct poses are skipped
//! (listed on standard error): they are closed chains. `models.txt` lists the names written,
//! one per line, for the check to compare with what it found; writing none is an error.
//!
//! A closed chain whose loops make its open tree's angles linear in its coordinates (a
//! parallelogram) is checked through a hand-written open tree, `tests/urdf-trees/NAME.urdf`,
//! and the loop's map `NAME.map.json` (`q_tree = S q`): both are copied as `tree_NAME.*` beside
//! hapticgen's quantities, and the check reduces Pinocchio's tree dynamics by `S`.
//!
//! Then, for every hand-written URDF of `tests/urdf/` (files no exporter wrote), `urdf_NAME.urdf`
//! (the file itself, copied) and `urdf_NAME.json` with hapticgen's quantities of the model that
//! `import-urdf` makes of it: Pinocchio then reads the original file, so a mistake in how the
//! importer or the model's resolution reads origins, rpy, axes or inertial frames shows.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hapticgen_codegen::eval::{evaluate, evaluate_frame, State};
use hapticgen_codegen::urdf;
use hapticgen_tests::check::random_state;
use hapticgen_tests::workspace_root;
use rand::rngs::SmallRng;
use rand::Rng;
use rand::SeedableRng;

/// States per model.
const STATES: usize = 50;

fn json_vector(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
    format!("[{}]", items.join(", "))
}

fn json_matrix(m: &[Vec<f64>]) -> String {
    let rows: Vec<String> = m.iter().map(|r| json_vector(r)).collect();
    format!("[{}]", rows.join(", "))
}

fn files_with_extension(dir: &Path, extension: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == extension))
        .collect();
    files.sort();
    files
}

/// How the URDF the check loads names a point's link: as `urdf::export` writes it, or as the
/// hand-written file does (the importer turns a link `tool` into the point `tool`).
#[derive(Clone, Copy)]
enum PointLinks {
    Exported,
    HandWritten,
}

/// Writes `NAME.json`: the model's gravity, rotor inertias, joint names and hapticgen's
/// quantities at `STATES` random states.
fn write_reference(
    out: &Path,
    name: &str,
    display: &str,
    variant: Option<&str>,
    m: &hapticgen_codegen::CheckedModel,
    links: PointLinks,
) {
    let mech = hapticgen_codegen::derive(m);
    let params = m.nominal_parameters();
    let gravity: Vec<f64> =
        m.gravity.iter().map(|p| p.eval(&hapticgen_codegen::eval::NominalAtoms(&params))).collect();
    // The rotors' inertia reflected to the joints, Cᵀ diag(N² J_m) C (C = I without a
    // transmission): URDF has no drives, so it is added to Pinocchio's CRBA as an armature
    // matrix.
    let rotor: Vec<f64> = m
        .joints
        .iter()
        .map(|j| j.drive.gear_ratio * j.drive.gear_ratio * j.drive.motor.rotor_inertia)
        .collect();
    let n = rotor.len();
    let coupling = |k: usize, j: usize| match &m.coupling {
        Some(coupling) => coupling.drive_from_joint[k][j],
        None => f64::from(u8::from(k == j)),
    };
    // Measured joints (a gimbal) are coordinates after the actuated ones: their bodies are
    // massless, so every dynamic quantity is padded with zeros for them, and the frames'
    // angular Jacobians have their columns.
    let coordinates = n + m.measured.len();
    let armature: Vec<Vec<f64>> = (0..coordinates)
        .map(|a| {
            (0..coordinates)
                .map(|b| {
                    if a < n && b < n {
                        (0..n).map(|k| coupling(k, a) * rotor[k] * coupling(k, b)).sum()
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let pad = |v: &[f64]| -> Vec<f64> {
        v.iter().copied().chain(std::iter::repeat(0.0)).take(coordinates).collect()
    };
    let mut json = String::new();
    let _ = write!(
        json,
        "{{\"model\": \"{display}\", \"variant\": {}, \"gravity\": {}, \"armature\": {}, \"joints\": [{}], \"states\": [",
        variant.map_or("null".to_string(), |v| format!("\"{v}\"")),
        json_vector(&gravity),
        json_matrix(&armature),
        m.joints
            .iter()
            .map(|j| &j.name)
            .chain(m.measured.iter().map(|j| &j.name))
            .map(|name| format!("\"{name}\""))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut rng = SmallRng::seed_from_u64(0x9170_c410);
    for s in 0..STATES {
        let (mut q, mut qd) = random_state(m, &mut rng);
        for joint in &m.measured {
            q.push(rng.gen_range(joint.lower..joint.upper));
            qd.push(rng.gen_range(-2.0..2.0));
        }
        let state = State { q: &q, qd: &qd, parameters: &params };
        let e = evaluate(&mech, &state, None);
        let nle: Vec<f64> =
            pad(&e.coriolis_times_qdot.iter().zip(&e.g).map(|(c, g)| c + g).collect::<Vec<_>>());
        let inertia_matrix: Vec<Vec<f64>> =
            (0..coordinates).map(|a| pad(e.inertia_matrix.get(a).map_or(&[][..], |row| row))).collect();
        let mut points = Vec::new();
        for p in &mech.points {
            let pe = evaluate(&mech, &state, Some(p));
            let mut position = pe.p.clone();
            let mut jacobian: Vec<Vec<f64>> = pe.jacobian.iter().map(|row| pad(row)).collect();
            while position.len() < 3 {
                position.push(0.0);
                jacobian.push(vec![0.0; q.len()]);
            }
            points.push(format!(
                "\"{}\": {{\"p\": {}, \"J\": {}}}",
                match links {
                    PointLinks::Exported => urdf::point_link_name(&p.name),
                    PointLinks::HandWritten => p.name.clone(),
                },
                json_vector(&position),
                json_matrix(&jacobian)
            ));
        }
        let frames: Vec<String> = mech
            .frames
            .iter()
            .map(|f| {
                let fe = evaluate_frame(&mech, &state, f);
                format!(
                    "\"{}\": {{\"R\": {}, \"Jw\": {}}}",
                    urdf::frame_link_name(&f.name),
                    json_matrix(&fe.rotation),
                    json_matrix(&fe.angular_jacobian)
                )
            })
            .collect();
        let _ = write!(
            json,
            "{}{{\"q\": {}, \"qd\": {}, \"D\": {}, \"nle\": {}, \"g\": {}, \"points\": {{{}}}, \"frames\": {{{}}}}}",
            if s == 0 { "" } else { ", " },
            json_vector(&q),
            json_vector(&qd),
            json_matrix(&inertia_matrix),
            json_vector(&nle),
            json_vector(&pad(&e.g)),
            points.join(", "),
            frames.join(", ")
        );
    }
    json.push_str("]}\n");
    std::fs::write(out.join(format!("{name}.json")), json).expect("writable");
}

fn main() {
    let out = PathBuf::from(std::env::args().nth(1).expect("usage: pinocchio_reference OUT_DIR"));
    std::fs::create_dir_all(&out).expect("the output directory can be created");
    let root = workspace_root();
    let mut written: Vec<String> = Vec::new();
    let mut trees_used: Vec<String> = Vec::new();
    for dir in ["models", "codegen/tests/good-models"] {
        for path in files_with_extension(&root.join(dir), "yaml") {
            let display = format!("{dir}/{}", path.file_name().expect("a file").to_string_lossy());
            let base = hapticgen_codegen::load_file(&path, &display, None).unwrap_or_else(|e| panic!("{e}"));
            let variants: Vec<Option<String>> = if base.variants.is_empty() {
                vec![None]
            } else {
                base.variants.iter().cloned().map(Some).collect()
            };
            for variant in variants {
                let m = hapticgen_codegen::load_file(&path, &display, variant.as_deref())
                    .unwrap_or_else(|e| panic!("{e}"));
                let text = match urdf::export(&m) {
                    Ok(text) => text,
                    Err(why) => {
                        // A closed chain with a hand-written open tree and loop map is checked
                        // through them; any other is skipped, and said so.
                        let tree = root.join("tests/urdf-trees").join(format!("{}.urdf", m.name));
                        if dir == "models" && tree.exists() {
                            let name = format!(
                                "tree_{}{}",
                                m.name,
                                variant.as_ref().map(|v| format!("_{v}")).unwrap_or_default()
                            );
                            std::fs::copy(&tree, out.join(format!("{name}.urdf"))).expect("writable");
                            std::fs::copy(tree.with_extension("map.json"), out.join(format!("{name}.map")))
                                .unwrap_or_else(|e| panic!("{}: its loop map: {e}", tree.display()));
                            write_reference(
                                &out,
                                &name,
                                &display,
                                variant.as_deref(),
                                &m,
                                PointLinks::HandWritten,
                            );
                            trees_used.push(m.name.clone());
                            written.push(name);
                            continue;
                        }
                        eprintln!("skipped {display}: {why}");
                        break;
                    }
                };
                let name = format!(
                    "{}{}{}",
                    if dir == "models" { "" } else { "good_" },
                    m.name,
                    variant.as_ref().map(|v| format!("_{v}")).unwrap_or_default()
                );
                std::fs::write(out.join(format!("{name}.urdf")), text).expect("writable");
                write_reference(&out, &name, &display, variant.as_deref(), &m, PointLinks::Exported);
                written.push(name);
            }
        }
    }
    // Every hand-written tree must belong to a shipped closed chain (a renamed model would
    // otherwise leave its tree unchecked, silently).
    for tree in files_with_extension(&root.join("tests/urdf-trees"), "urdf") {
        let stem = tree.file_stem().expect("a file").to_string_lossy().into_owned();
        if !trees_used.contains(&stem) {
            eprintln!("error: tests/urdf-trees/{stem}.urdf names no closed chain of models/");
            std::process::exit(1);
        }
    }
    // Hand-written URDFs: imported with `import-urdf`'s code, checked against Pinocchio reading
    // the same files, so that resolution of origins, rpy, axes and inertial frames is checked by
    // something that does not share the exporter's reading of them.
    let hand_written = files_with_extension(&root.join("tests/urdf"), "urdf");
    if hand_written.is_empty() {
        eprintln!("error: no hand-written URDF in tests/urdf");
        std::process::exit(1);
    }
    for path in hand_written {
        let stem = path.file_stem().expect("a file").to_string_lossy().into_owned();
        let display = format!("tests/urdf/{stem}.urdf");
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{display}: {e}"));
        let yaml = urdf::import(&text, &display, urdf::DEFAULT_DRIVE).unwrap_or_else(|d| panic!("{d}"));
        let model_name = format!("{display} (imported)");
        let m = hapticgen_codegen::load(&hapticgen_codegen::Source { name: &model_name, text: &yaml }, None)
            .unwrap_or_else(|d| panic!("{d}\n{yaml}"));
        let name = format!("urdf_{stem}");
        std::fs::copy(&path, out.join(format!("{name}.urdf"))).expect("writable");
        write_reference(&out, &name, &display, None, &m, PointLinks::HandWritten);
        written.push(name);
    }
    let mut list = written.join("\n");
    list.push('\n');
    std::fs::write(out.join("models.txt"), list).expect("writable");
    eprintln!("wrote {} models to {}", written.len(), out.display());
    if written.is_empty() {
        eprintln!("error: no serial model to export");
        std::process::exit(1);
    }
}
