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
#![deny(missing_docs)]

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
        });
    }
    Ok(table)
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

/// Writes image `name`'s glue modules `image` of both kinds (`board`, `simulation`) and its rig
/// (copied from `rig_file`) into `dir/<name>/`, for [`copy_pregenerated`].
pub fn write_pregenerated(
    dir: &Path,
    name: &str,
    glue: impl Fn(Glue) -> String,
    rig_file: &Path,
) -> Result<(), String> {
    let image = dir.join(name);
    std::fs::create_dir_all(&image).map_err(|e| format!("{}: {e}", image.display()))?;
    for kind in [Glue::Board, Glue::Simulation] {
        let path = image.join(glue_file(kind));
        std::fs::write(&path, glue(kind)).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let path = image.join(RIG_FILE);
    std::fs::copy(rig_file, &path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(())
}

/// For an image crate's build script: when [`PREGENERATED_ENV`] is set, copies image `name`'s
/// glue of `kind` and its rig from there into `out_dir` as `image.rs` and `image_rig.rs`
/// (the glue module is `image`), tells cargo to rerun when they change, and returns
/// `Some(result)`; `None` when the variable is unset (generate the image instead).
pub fn copy_pregenerated(name: &str, kind: Glue, out_dir: &Path) -> Option<Result<(), String>> {
    println!("cargo:rerun-if-env-changed={PREGENERATED_ENV}");
    let dir = PathBuf::from(std::env::var_os(PREGENERATED_ENV)?).join(name);
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

    #[test]
    fn the_shipped_table_parses() {
        let dir = firmware_dir(Path::new(env!("CARGO_MANIFEST_DIR")));
        let table = read_table(&dir).unwrap();
        assert!(!table.is_empty());
    }
}
