//! Used by the build scripts of the firmware images (`qemu`, one variant, `f32`; the example
//! board `stm32f4`) and of the host reference (`reference`, every variant, `f32` and `f64`).
//!
//! `targets/firmware/variants.txt` is the table of images, one per line:
//! `name model variant scenario pose impedance current flash ram scene` ([`COLUMNS`]). For each,
//! [`generate`] writes the rig's code (through the build-script helper
//! `hapticgen_codegen::build::generate`) and returns a glue module: the rig type, its joint
//! and task dimensions and rates, and `setup()`, the model-derived
//! `hapticgen_fw_control::Setup` (each joint's current-loop gains as the model loader designed
//! them, the start pose, rendering parameters): what a board needs ([`Glue::Board`]). With
//! [`Glue::Simulation`] also the line's scenario on the simulated board
//! (`hapticgen_fw_sim::scenarios`): its reference source `Source`, the controller type
//! `Control`, the run `Run`, the simulated current sense's `sense_time_constant()` and
//! `new(profile)`.
//!
//! [`MODEL_ENV`] (`HAPTICGEN_FW_MODEL`) builds one image from another model file than its
//! line's (an identified one, docs/identification.md): [`apply_model_override`] puts the file
//! into the line [`VARIANT_ENV`] names, every build script that generates that line takes it
//! from there, and the generator refuses a file whose joints, task or measured joints are not
//! those of the line's model ([`check_same_shape`]).
#![deny(missing_docs)]

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

#[cfg(feature = "generate")]
mod generate;
#[cfg(feature = "generate")]
pub use generate::{emit_options, generate, generate_rig, GeneratedRig};

/// One line of `variants.txt`:
/// `name model variant scenario pose impedance current flash ram scene`.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Image name (also the `HAPTICGEN_FW_VARIANT` value).
    pub name: String,
    /// Model file relative to the repository root.
    pub model: String,
    /// Model variant, if any.
    pub variant: Option<String>,
    /// Scenario module in `hapticgen_fw_sim::scenarios`.
    pub scenario: String,
    /// Start pose of the scenario, one joint angle (degrees) or position (mm) per joint.
    pub pose: Vec<f64>,
    /// Per-image limits, checked by `scripts/firmware.sh`.
    pub budget: Budget,
    /// The scene file the scenario renders (docs/scenes.md), relative to the repository root:
    /// for the scenario `scene_contact`, and only for it.
    pub scene: Option<String>,
    /// The model file built in place of `model` ([`MODEL_ENV`], an absolute path), if any.
    pub replaced_by: Option<PathBuf>,
}

impl Variant {
    /// The model file the image is built from: [`Variant::replaced_by`] if set, else `model`
    /// below `repo_root`.
    pub fn model_path(&self, repo_root: &Path) -> PathBuf {
        self.replaced_by.clone().unwrap_or_else(|| repo_root.join(&self.model))
    }

    /// The model file the image is built from as diagnostics name it: the replacing file's
    /// path, else `model` (relative to the repository root).
    pub fn model_name(&self) -> String {
        match &self.replaced_by {
            Some(path) => path.display().to_string(),
            None => self.model.clone(),
        }
    }
}

/// The limits of one image (a line of `variants.txt`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Largest impedance (1 kHz) tick, instructions.
    pub impedance: u32,
    /// Largest current-loop tick (all motors), instructions.
    pub current: u32,
    /// Flash (text + rodata + vector table + data load image), bytes.
    pub flash: u32,
    /// Static RAM (data + bss), bytes.
    pub ram: u32,
}

/// Column names of `variants.txt`, in order.
pub const COLUMNS: [&str; 10] =
    ["name", "model", "variant", "scenario", "pose", "impedance", "current", "flash", "ram", "scene"];

/// The scenario that renders a scene file (`hapticgen_fw_sim::scenarios::scene_contact`).
pub const SCENE_SCENARIO: &str = "scene_contact";

/// The firmware workspace directory (`targets/firmware`), from a member's manifest dir.
pub fn firmware_dir(manifest_dir: &Path) -> PathBuf {
    manifest_dir.join("..")
}

/// Reads `variants.txt`; prints `cargo:rerun-if-changed` for it.
pub fn read_table(firmware_dir: &Path) -> Result<Vec<Variant>, String> {
    let path = firmware_dir.join("variants.txt");
    println!("cargo:rerun-if-changed={}", path.display());
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_table(&text).map_err(|(line, e)| format!("{}:{line}: {e}", path.display()))
}

/// Parses the text of `variants.txt`; an error carries its 1-based line number.
pub fn parse_table(text: &str) -> Result<Vec<Variant>, (usize, String)> {
    let mut table: Vec<Variant> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let at = |e: String| (index + 1, e);
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != COLUMNS.len() {
            return Err(at(format!("expected `{}`, got {} fields", COLUMNS.join(" "), fields.len())));
        }
        let ok_ident = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ok_ident(fields[0]) || !ok_ident(fields[3]) {
            return Err(at("name and scenario must be identifiers".to_string()));
        }
        if table.iter().any(|v| v.name == fields[0]) {
            return Err(at(format!("image `{}` is listed twice", fields[0])));
        }
        let pose = fields[4]
            .split(',')
            .map(|x| match x.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(v) => Err(format!("pose: `{v}` is not finite")),
                Err(e) => Err(format!("pose: `{x}`: {e}")),
            })
            .collect::<Result<Vec<f64>, String>>()
            .map_err(at)?;
        let number = |column: usize| -> Result<u32, (usize, String)> {
            fields[column].parse().map_err(|e| at(format!("{}: `{}`: {e}", COLUMNS[column], fields[column])))
        };
        let scene = if fields[9] == "-" { None } else { Some(fields[9].to_string()) };
        if scene.is_some() != (fields[3] == SCENE_SCENARIO) {
            return Err(at(format!(
                "a scene file is named exactly by the images whose scenario is `{SCENE_SCENARIO}`"
            )));
        }
        table.push(Variant {
            name: fields[0].to_string(),
            model: fields[1].to_string(),
            variant: if fields[2] == "-" { None } else { Some(fields[2].to_string()) },
            scenario: fields[3].to_string(),
            pose,
            budget: Budget { impedance: number(5)?, current: number(6)?, flash: number(7)?, ram: number(8)? },
            scene,
            replaced_by: None,
        });
    }
    Ok(table)
}

/// The environment variable that names an image (a line of `variants.txt`) for the image
/// crates' build scripts, and the line whose model [`MODEL_ENV`] replaces.
pub const VARIANT_ENV: &str = "HAPTICGEN_FW_VARIANT";

/// The environment variable that builds the image [`VARIANT_ENV`] names from another model file
/// (an absolute path; an identified model, `hapticgen identify -o`) in place of its line's
/// model, with the line's variant, scenario, start pose and limits. Honoured by every build
/// script that generates that line: the image crates' (`qemu`, `stm32f4`, with their
/// `generate` feature) and the host reference's. Refused, naming the file: a relative or empty
/// path, a file that cannot be read, no [`VARIANT_ENV`] or an unknown one, and (when generating)
/// a model whose joints, task axes or measured joints are not the line's model's.
pub const MODEL_ENV: &str = "HAPTICGEN_FW_MODEL";

/// For a build script: applies [`MODEL_ENV`] to `table` ([`override_model`] on the process's
/// environment); prints `cargo:rerun-if-env-changed` for both variables (for [`VARIANT_ENV`]
/// only while [`MODEL_ENV`] is set) and `cargo:rerun-if-changed` for the replacing file.
pub fn apply_model_override(table: Vec<Variant>) -> Result<Vec<Variant>, String> {
    println!("cargo:rerun-if-env-changed={MODEL_ENV}");
    let value = std::env::var_os(MODEL_ENV);
    if value.is_some() {
        println!("cargo:rerun-if-env-changed={VARIANT_ENV}");
    }
    let selected = std::env::var(VARIANT_ENV).ok();
    let table = override_model(table, selected.as_deref(), value.as_deref())?;
    for path in table.iter().filter_map(|v| v.replaced_by.as_ref()) {
        println!("cargo:rerun-if-changed={}", path.display());
    }
    Ok(table)
}

/// `table` with the model of the line named `selected` replaced by the file `value` (the
/// values of [`VARIANT_ENV`] and [`MODEL_ENV`]); unchanged when `value` is `None`. Errors name
/// the variable, the file and what is wrong: an empty or relative path (a build script runs in
/// its crate's directory, so a relative path would not mean what the shell meant), a file
/// that is missing or not a file, no line selected, a line that does not exist.
pub fn override_model(
    mut table: Vec<Variant>,
    selected: Option<&str>,
    value: Option<&OsStr>,
) -> Result<Vec<Variant>, String> {
    let Some(value) = value else { return Ok(table) };
    let path = PathBuf::from(value);
    let shown = path.display();
    if value.is_empty() {
        return Err(format!(
            "{MODEL_ENV} is set but empty: unset it, or name a model file by its absolute path"
        ));
    }
    if !path.is_absolute() {
        return Err(format!(
            "{MODEL_ENV}={shown}: not an absolute path (build scripts run in their crate's directory); \
             give the model file's absolute path, e.g. \"$PWD/{shown}\""
        ));
    }
    match std::fs::metadata(&path) {
        Ok(meta) if meta.is_file() => {}
        Ok(_) => return Err(format!("{MODEL_ENV}={shown}: not a file")),
        Err(e) => return Err(format!("{MODEL_ENV}={shown}: cannot read the model file: {e}")),
    }
    let names = || table.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", ");
    let Some(name) = selected else {
        return Err(format!(
            "{MODEL_ENV}={shown} replaces the model of one image: name it with {VARIANT_ENV} (one of: {})",
            names()
        ));
    };
    let Some(index) = table.iter().position(|v| v.name == name) else {
        return Err(format!(
            "{MODEL_ENV}={shown}: {VARIANT_ENV}={name} is not in variants.txt (known: {})",
            names()
        ));
    };
    table[index].replaced_by = Some(path);
    Ok(table)
}

/// What an image's glue and scenario take from its model's structure, compared by
/// [`check_same_shape`] when [`MODEL_ENV`] replaces a line's model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelShape {
    /// Each actuated joint's name and kind (`revolute`, `prismatic`), in order.
    pub joints: Vec<(String, String)>,
    /// Number of task coordinates.
    pub task_dim: usize,
    /// The measured (passive, sensed) joints' names, in order.
    pub measured: Vec<String>,
}

/// `Ok` when `replacing` (the shape of [`Variant::replaced_by`]) is `line`'s (the shape of the
/// line's own model): the same joints by name and kind in the same order, the same number of
/// task coordinates and the same measured joints, so that the line's start pose, scenario and
/// board wiring mean the same on it. The error names the image, both files and the first
/// difference.
pub fn check_same_shape(variant: &Variant, line: &ModelShape, replacing: &ModelShape) -> Result<(), String> {
    let list = |joints: &[(String, String)]| {
        joints.iter().map(|(name, kind)| format!("{name} ({kind})")).collect::<Vec<_>>().join(", ")
    };
    let difference = if replacing.joints.len() != line.joints.len() {
        Some(format!(
            "it has {} joints [{}], the line's model {} [{}]",
            replacing.joints.len(),
            list(&replacing.joints),
            line.joints.len(),
            list(&line.joints)
        ))
    } else if let Some(k) = (0..line.joints.len()).find(|&k| replacing.joints[k] != line.joints[k]) {
        let ((a, a_kind), (b, b_kind)) = (&replacing.joints[k], &line.joints[k]);
        Some(format!("its joint {} is `{a}` ({a_kind}), the line's model's `{b}` ({b_kind})", k + 1))
    } else if replacing.task_dim != line.task_dim {
        Some(format!("its task has {} coordinates, the line's model's {}", replacing.task_dim, line.task_dim))
    } else if replacing.measured != line.measured {
        Some(format!(
            "its measured joints are {:?}, the line's model's {:?}",
            replacing.measured, line.measured
        ))
    } else {
        None
    };
    match difference {
        None => Ok(()),
        Some(what) => Err(format!(
            "image `{}`: {MODEL_ENV}={} does not fit the line's model {}: {what}",
            variant.name,
            variant.model_name(),
            variant.model
        )),
    }
}

/// What a glue module offers besides the rig: see the crate's documentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Glue {
    /// The rig, its dimensions and rates, and `setup()`: for a board image, which depends on
    /// `hapticgen-fw-control` and the runtime only.
    Board,
    /// Also the line's scenario on the simulated board: for the QEMU images and the host
    /// reference, which depend on `hapticgen-fw-sim` too.
    Simulation,
}

/// The environment variable that points the image crates' build scripts at pre-generated
/// images instead of the generator: a directory written by [`write_pregenerated`] (the host
/// reference's, printed by `hapticgen-fw-reference generated`). `scripts/firmware.sh` sets it
/// and builds the images without their `generate` feature, so that the generator is built
/// once, for the host, and every image compiles the very rig file that the host reference's
/// `f32` run compiles.
pub const PREGENERATED_ENV: &str = "HAPTICGEN_FW_GENERATED";

/// For an image crate's build script: generates image `variant`'s `f32` rig and its glue of
/// `kind` into `out_dir` (`image_rig.rs`, and `image.rs` holding the glue module `image`).
#[cfg(feature = "generate")]
pub fn generate_image(
    variant: &Variant,
    firmware_dir: &Path,
    out_dir: &Path,
    kind: Glue,
) -> Result<(), String> {
    let glue = generate(variant, firmware_dir, hapticgen_codegen::Scalar::F32, out_dir, "image", kind)?;
    let path = out_dir.join("image.rs");
    std::fs::write(&path, glue).map_err(|e| format!("{}: {e}", path.display()))
}

/// Why an image crate built without its `generate` feature cannot build image `variant`:
/// [`PREGENERATED_ENV`] does not name the host reference's pre-generated images.
pub fn not_pregenerated(variant: &Variant) -> String {
    format!(
        "image `{}`: built without the feature `generate`, so {PREGENERATED_ENV} must name the host \
         reference's pre-generated images (`hapticgen-fw-reference generated`)",
        variant.name
    )
}

/// The glue file of `kind` for one image in a pre-generated directory.
fn glue_file(kind: Glue) -> &'static str {
    match kind {
        Glue::Board => "board.rs",
        Glue::Simulation => "simulation.rs",
    }
}

/// The rig file of one image in a pre-generated directory.
const RIG_FILE: &str = "image_rig.rs";

/// The file of one image in a pre-generated directory that names the model it was generated
/// from ([`Variant::model_name`]).
const MODEL_FILE: &str = "model.txt";

/// Writes image `name`'s glue modules `image` of both kinds (`board`, `simulation`), its rig
/// (copied from `rig_file`) and the name of the model file it was generated from (`model`,
/// [`Variant::model_name`]) into `dir/<name>/`, for [`copy_pregenerated`].
pub fn write_pregenerated(
    dir: &Path,
    name: &str,
    model: &str,
    glue: impl Fn(Glue) -> String,
    rig_file: &Path,
) -> Result<(), String> {
    let image = dir.join(name);
    std::fs::create_dir_all(&image).map_err(|e| format!("{}: {e}", image.display()))?;
    for kind in [Glue::Board, Glue::Simulation] {
        let path = image.join(glue_file(kind));
        std::fs::write(&path, glue(kind)).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let path = image.join(MODEL_FILE);
    std::fs::write(&path, format!("{model}\n")).map_err(|e| format!("{}: {e}", path.display()))?;
    let path = image.join(RIG_FILE);
    std::fs::copy(rig_file, &path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(())
}

/// `Ok` when a pre-generated image whose model file reads `recorded` (as
/// [`write_pregenerated`] wrote it) is `variant` as this build wants it: generated from
/// [`Variant::model_name`] — the line's model, or the file [`MODEL_ENV`] names. Never builds
/// one model's image while the other is asked for.
pub fn check_pregenerated_model(variant: &Variant, recorded: &str) -> Result<(), String> {
    let recorded = recorded.trim_end_matches('\n');
    let wanted = variant.model_name();
    if recorded == wanted {
        return Ok(());
    }
    let how = match &variant.replaced_by {
        Some(_) => format!(
            "build this image with the crate's `generate` feature (its default) and {PREGENERATED_ENV} unset, \
             so that its build script generates the rig from {MODEL_ENV}"
        ),
        None => format!("unset {MODEL_ENV}, or rebuild the pre-generated images"),
    };
    Err(format!(
        "image `{}`: {PREGENERATED_ENV} holds it generated from {recorded}, but this build wants {wanted}{}: {how}",
        variant.name,
        if variant.replaced_by.is_some() { format!(" ({MODEL_ENV})") } else { String::new() },
    ))
}

/// For an image crate's build script: when [`PREGENERATED_ENV`] is set, copies image
/// `variant`'s glue of `kind` and its rig from there into `out_dir` as `image.rs` and
/// `image_rig.rs` (the glue module is `image`), tells cargo to rerun when they change, and
/// returns `Some(result)`; `None` when the variable is unset (generate the image instead). An
/// image generated from another model file than `variant`'s ([`check_pregenerated_model`]) is
/// an error.
pub fn copy_pregenerated(variant: &Variant, kind: Glue, out_dir: &Path) -> Option<Result<(), String>> {
    println!("cargo:rerun-if-env-changed={PREGENERATED_ENV}");
    let dir = PathBuf::from(std::env::var_os(PREGENERATED_ENV)?).join(&variant.name);
    let model = dir.join(MODEL_FILE);
    println!("cargo:rerun-if-changed={}", model.display());
    let recorded = match std::fs::read_to_string(&model) {
        Ok(text) => text,
        Err(e) => return Some(Err(format!("{PREGENERATED_ENV}: {}: {e}", model.display()))),
    };
    if let Err(e) = check_pregenerated_model(variant, &recorded) {
        return Some(Err(e));
    }
    let copy = |from: &str, to: &str| -> Result<(), String> {
        let source = dir.join(from);
        println!("cargo:rerun-if-changed={}", source.display());
        std::fs::copy(&source, out_dir.join(to))
            .map(|_| ())
            .map_err(|e| format!("{PREGENERATED_ENV}: {}: {e}", source.display()))
    };
    Some(copy(glue_file(kind), "image.rs").and_then(|()| copy(RIG_FILE, "image_rig.rs")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_line_and_rejects_bad_ones() {
        let table = parse_table("# c\n a m.yaml - sc 0,90 800 150 1000 200 - # tail\n").unwrap();
        assert_eq!(table.len(), 1);
        assert_eq!(table[0].pose, vec![0.0, 90.0]);
        assert_eq!(table[0].variant, None);
        assert_eq!(table[0].scene, None);
        assert_eq!(table[0].budget, Budget { impedance: 800, current: 150, flash: 1000, ram: 200 });
        assert_eq!(parse_table("a m - sc 0 1 2 3 -").unwrap_err().0, 1);
        assert!(parse_table("a m - sc x 1 2 3 4 -").unwrap_err().1.contains("pose"));
        assert!(parse_table("a m - sc 0 1 2 -3 4 -").unwrap_err().1.contains("flash"));
        let twice = "a m - sc 0 1 2 3 4 -\n\na m - sc 0 1 2 3 4 -\n";
        assert_eq!(parse_table(twice).unwrap_err().0, 3);
        // A scene goes with the scenario that renders one, and only with it.
        let scene = parse_table("a m - scene_contact 0 1 2 3 4 scenes/s.yaml").unwrap();
        assert_eq!(scene[0].scene.as_deref(), Some("scenes/s.yaml"));
        assert!(parse_table("a m - scene_contact 0 1 2 3 4 -").unwrap_err().1.contains("scene_contact"));
        assert!(parse_table("a m - sc 0 1 2 3 4 s.yaml").unwrap_err().1.contains("scene_contact"));
    }

    fn two_lines() -> Vec<Variant> {
        parse_table("a models/a.yaml - sc 0 1 2 3 4 -\nb models/b.yaml v sc 0,0 1 2 3 4 -\n").unwrap()
    }

    #[test]
    fn a_model_override_replaces_the_selected_line_s_model_only() {
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
        let file = manifest.join("Cargo.toml");
        // Unset: the table as it was.
        assert_eq!(override_model(two_lines(), Some("b"), None).unwrap(), two_lines());
        let table = override_model(two_lines(), Some("b"), Some(file.as_os_str())).unwrap();
        assert_eq!(table[0], two_lines()[0]);
        assert_eq!(table[1].replaced_by.as_deref(), Some(file.as_path()));
        assert_eq!(table[1].model_path(Path::new("/repo")), file);
        assert_eq!(table[1].model_name(), file.display().to_string());
        // Everything else of the line stays.
        assert_eq!(Variant { replaced_by: None, ..table[1].clone() }, two_lines()[1]);
        assert_eq!(table[0].model_path(Path::new("/repo")), Path::new("/repo/models/a.yaml"));
        assert_eq!(table[0].model_name(), "models/a.yaml");
    }

    #[test]
    fn a_bad_model_override_is_refused_naming_the_file() {
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
        let file = manifest.join("Cargo.toml");
        let refused = |selected: Option<&str>, value: &OsStr| {
            override_model(two_lines(), selected, Some(value)).unwrap_err()
        };
        let e = refused(Some("a"), OsStr::new(""));
        assert!(e.contains("HAPTICGEN_FW_MODEL is set but empty"), "{e}");
        let e = refused(Some("a"), OsStr::new("identified.yaml"));
        assert!(e.starts_with("HAPTICGEN_FW_MODEL=identified.yaml: not an absolute path"), "{e}");
        assert!(
            e.ends_with("directory); give the model file's absolute path, e.g. \"$PWD/identified.yaml\""),
            "{e}"
        );
        let missing = manifest.join("no-such-model.yaml");
        let e = refused(Some("a"), missing.as_os_str());
        assert!(e.contains(&format!("{}: cannot read the model file", missing.display())), "{e}");
        let e = refused(Some("a"), manifest.as_os_str());
        assert!(e.contains(&format!("{}: not a file", manifest.display())), "{e}");
        let e = refused(None, file.as_os_str());
        assert!(e.contains("name it with HAPTICGEN_FW_VARIANT (one of: a, b)"), "{e}");
        let e = refused(Some("c"), file.as_os_str());
        assert!(e.contains("HAPTICGEN_FW_VARIANT=c is not in variants.txt (known: a, b)"), "{e}");
    }

    fn shape(joints: &[(&str, &str)], task_dim: usize, measured: &[&str]) -> ModelShape {
        ModelShape {
            joints: joints.iter().map(|(n, k)| (n.to_string(), k.to_string())).collect(),
            task_dim,
            measured: measured.iter().map(|n| n.to_string()).collect(),
        }
    }

    #[test]
    fn a_replacing_model_must_have_the_line_s_joints_task_and_measured_joints() {
        let mut variant = two_lines().remove(1);
        variant.replaced_by = Some(PathBuf::from("/x/identified.yaml"));
        let line = shape(&[("q1", "revolute"), ("q2", "revolute")], 2, &[]);
        assert_eq!(check_same_shape(&variant, &line, &line.clone()), Ok(()));
        let differs = |other: ModelShape| check_same_shape(&variant, &line, &other).unwrap_err();
        let prefix =
            "image `b`: HAPTICGEN_FW_MODEL=/x/identified.yaml does not fit the line's model models/b.yaml: ";
        let e = differs(shape(&[("q1", "revolute")], 2, &[]));
        assert_eq!(
            e,
            format!(
                "{prefix}it has 1 joints [q1 (revolute)], the line's model 2 [q1 (revolute), q2 (revolute)]"
            )
        );
        let e = differs(shape(&[("q1", "revolute"), ("q3", "revolute")], 2, &[]));
        assert_eq!(e, format!("{prefix}its joint 2 is `q3` (revolute), the line's model's `q2` (revolute)"));
        let e = differs(shape(&[("q1", "revolute"), ("q2", "prismatic")], 2, &[]));
        assert!(e.ends_with("its joint 2 is `q2` (prismatic), the line's model's `q2` (revolute)"), "{e}");
        let e = differs(shape(&[("q1", "revolute"), ("q2", "revolute")], 3, &[]));
        assert!(e.ends_with("its task has 3 coordinates, the line's model's 2"), "{e}");
        let e = differs(shape(&[("q1", "revolute"), ("q2", "revolute")], 2, &["g1"]));
        assert!(e.ends_with("its measured joints are [\"g1\"], the line's model's []"), "{e}");
    }

    #[test]
    fn a_pre_generated_image_is_used_only_for_the_model_it_was_generated_from() {
        let line = two_lines().remove(0);
        assert_eq!(check_pregenerated_model(&line, "models/a.yaml\n"), Ok(()));
        let mut replaced = line.clone();
        replaced.replaced_by = Some(PathBuf::from("/x/identified.yaml"));
        assert_eq!(check_pregenerated_model(&replaced, "/x/identified.yaml\n"), Ok(()));
        // The line's image when another model is wanted, and the other way round: refused.
        let e = check_pregenerated_model(&replaced, "models/a.yaml\n").unwrap_err();
        assert!(
            e.contains("holds it generated from models/a.yaml, but this build wants /x/identified.yaml (HAPTICGEN_FW_MODEL)")
                && e.contains("`generate` feature"),
            "{e}"
        );
        let e = check_pregenerated_model(&line, "/x/identified.yaml\n").unwrap_err();
        assert!(e.contains("generated from /x/identified.yaml, but this build wants models/a.yaml"), "{e}");
    }

    #[test]
    fn the_shipped_table_parses() {
        let dir = firmware_dir(Path::new(env!("CARGO_MANIFEST_DIR")));
        let table = read_table(&dir).unwrap();
        assert!(!table.is_empty());
    }
}
