//! Used by the build scripts of the firmware image (`qemu`, one variant, `f32`) and of the
//! host reference (`host`, every variant, `f32` and `f64`).
//!
//! `targets/firmware/variants.txt` is the table of images, one per line:
//! `name model variant scenario pose impedance current flash ram` ([`COLUMNS`]). For each,
//! [`generate`] writes the rig's code (through the build-script helper
//! `hapticgen_codegen::build::generate`) and returns a glue module: the rig type, its joint
//! and task dimensions, the scenario type `Run`, the model-derived `Setup` (each joint's
//! current-loop gains as the model loader designed them, the start pose, rendering
//! parameters) and `new(profile)`.
#![deny(missing_docs)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hapticgen_codegen::{emit, model, EmitOptions, Scalar};

/// One line of `variants.txt`:
/// `name model variant scenario pose impedance current flash ram`.
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
pub const COLUMNS: [&str; 9] =
    ["name", "model", "variant", "scenario", "pose", "impedance", "current", "flash", "ram"];

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
        table.push(Variant {
            name: fields[0].to_string(),
            model: fields[1].to_string(),
            variant: if fields[2] == "-" { None } else { Some(fields[2].to_string()) },
            scenario: fields[3].to_string(),
            pose,
            budget: Budget { impedance: number(5)?, current: number(6)?, flash: number(7)?, ram: number(8)? },
        });
    }
    Ok(table)
}

fn literal(value: f64) -> String {
    // `{:?}` prints the shortest representation that round-trips, always with a `.` or `e`.
    format!("{value:?}")
}

/// The emission options of every image and of the host reference, which must agree so that the
/// reference runs the same arithmetic as the target: unfused by default; with
/// `HAPTICGEN_FW_FMA=1`, fused multiply-adds (`hapticgen generate --fma`; `vfma.f32` on the
/// target through the runtime's `fpu-fma` feature, libm's exact `fmaf` on the host, bit for bit
/// the same). Not the default because on the Cortex-M4F it costs instructions: stable Rust
/// reaches `vfma.f32` only by inline assembly through core registers (about nine instructions
/// for a fused operation against two for `vmul` + `vadd`; see docs/firmware.md for the
/// measurement). Tells cargo to rerun the calling build script when the variable changes.
pub fn emit_options() -> EmitOptions {
    println!("cargo:rerun-if-env-changed=HAPTICGEN_FW_FMA");
    let on = std::env::var("HAPTICGEN_FW_FMA").map(|v| v == "1").unwrap_or(false);
    EmitOptions { fused_multiply_add: on }
}

/// Generates the rig of `v` in `scalar` into `out_dir/<module>_rig.rs` and returns the text of
/// the glue module `<module>` (to be written into a file the crate `include!`s).
pub fn generate(
    v: &Variant,
    firmware_dir: &Path,
    scalar: Scalar,
    out_dir: &Path,
    module: &str,
) -> Result<String, String> {
    let repo_root = firmware_dir.join("../..");
    let model_path = repo_root.join(&v.model);
    let rig_file = out_dir.join(format!("{module}_rig.rs"));
    hapticgen_codegen::build::generate_with(&model_path, v.variant.as_deref(), scalar, emit_options(), &rig_file)
        .map_err(|e| e.to_string())?;
    let loaded = hapticgen_codegen::load_file(&model_path, &v.model, v.variant.as_deref()).map_err(|e| e.to_string())?;
    let (n, m) = (loaded.joints.len(), loaded.task_dim());
    if n == 0 {
        return Err(format!("{}: the model has no joints", v.model));
    }
    if v.pose.len() != n {
        return Err(format!(
            "image `{}`: the pose has {} values, `{}` has {n} joints",
            v.name,
            v.pose.len(),
            v.model
        ));
    }
    // The model's own per-joint designs (the generated `CURRENT_LOOP_GAINS`), in f64; the
    // glue converts them with `from_f64`, as the scenario converts everything else.
    let designs = &loaded.analyses.current_loop_designs;
    if designs.len() != n {
        return Err(format!("{}: {} current-loop designs for {n} joints", v.model, designs.len()));
    }
    let type_name = emit::rig_type_name(&loaded);
    let s = scalar.name();
    let rendering = match &loaded.rendering {
        Some(r) => format!(
            "Some([S::from_f64({}), S::from_f64({}), S::from_f64({})])",
            literal(r.grid_spacing),
            literal(r.wall_stiffness),
            literal(r.wall_damping)
        ),
        None => "None".to_string(),
    };
    let gains: Vec<String> = designs
        .iter()
        .map(|d| {
            format!(
                "::hapticgen_runtime::current_loop::CurrentLoopGains {{ kp: S::from_f64({}), ki: S::from_f64({}), \
                 sample_period: S::from_f64({}), proportional_setpoint_weight: S::from_f64({}) }}",
                literal(d.kp),
                literal(d.ki),
                literal(d.sample_period),
                literal(d.proportional_setpoint_weight)
            )
        })
        .collect();
    // Degrees (revolute) or millimetres (prismatic) to SI; `x / 180 · π` is exact for the
    // multiples of 45° the table uses.
    let start: Vec<String> = v
        .pose
        .iter()
        .zip(loaded.joints.iter())
        .map(|(&x, j)| match j.kind {
            model::JointKind::Revolute => {
                format!("S::from_f64({})", literal(x / 180.0 * std::f64::consts::PI))
            }
            model::JointKind::Prismatic => format!("S::from_f64({})", literal(x / 1000.0)),
        })
        .collect();
    // Every joint has the same anti-aliasing filter: its time constant from the first design.
    let tau = designs[0].filter_time_constant;
    let mut glue = String::new();
    writeln!(
        glue,
        "/// Image `{name}`: `{model}`{variant}, scenario `{scenario}`, {s}.\n\
         pub mod {module} {{\n\
         \x20   #[allow(clippy::all, missing_docs)]\n\
         \x20   pub mod rig {{ include!(concat!(env!(\"OUT_DIR\"), \"/{module}_rig.rs\")); }}\n\
         \x20   /// The generated rig.\n\
         \x20   pub type Rig = rig::{type_name};\n\
         \x20   /// Number of joints.\n\
         \x20   pub const JOINTS: usize = {n};\n\
         \x20   /// Number of task coordinates.\n\
         \x20   pub const TASK_DIM: usize = {m};\n\
         \x20   /// The scenario for this rig.\n\
         \x20   pub type Run = ::hapticgen_fw_sim::scenarios::{scenario}::Run<Rig, JOINTS, TASK_DIM>;\n\
         \x20   /// The image name.\n\
         \x20   pub const NAME: &str = \"{name}\";\n\
         \x20   /// The rig's current-loop rate, Hz (the interrupt rate).\n\
         \x20   pub const CURRENT_LOOP_HZ: u32 = {hz};\n\
         \x20   /// The rig's impedance-loop rate, Hz.\n\
         \x20   pub const IMPEDANCE_LOOP_HZ: u32 = {imp_hz};\n\
         \x20   /// Model-derived settings: per-joint current-loop gains (designed from each joint's\n\
         \x20   /// motor), the start pose of `variants.txt`, rendering.\n\
         \x20   pub fn setup() -> ::hapticgen_fw_sim::Setup<{s}, JOINTS> {{\n\
         \x20       type S = {s};\n\
         \x20       use ::hapticgen_runtime::Real as _;\n\
         \x20       ::hapticgen_fw_sim::Setup {{\n\
         \x20           current_gains: [{gains}],\n\
         \x20           sense_time_constant: S::from_f64({tau}),\n\
         \x20           start: [{start}],\n\
         \x20           rendering: {rendering},\n\
         \x20       }}\n\
         \x20   }}\n\
         \x20   /// The scenario, ready to run.\n\
         \x20   pub fn new(profile: bool) -> Option<Run> {{\n\
         \x20       ::hapticgen_fw_sim::scenarios::{scenario}::new(NAME, Rig::NOMINAL, &setup(), profile)\n\
         \x20   }}\n\
         }}",
        name = v.name,
        model = v.model,
        variant = v.variant.as_ref().map(|x| format!(" variant `{x}`")).unwrap_or_default(),
        scenario = v.scenario,
        gains = gains.join(", "),
        start = start.join(", "),
        tau = literal(tau),
        hz = loaded.rates.current_loop_hz,
        imp_hz = loaded.rates.impedance_loop_hz,
    )
    .map_err(|e| e.to_string())?;
    Ok(glue)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_line_and_rejects_bad_ones() {
        let table = parse_table("# c\n a m.yaml - sc 0,90 800 150 1000 200 # tail\n").unwrap();
        assert_eq!(table.len(), 1);
        assert_eq!(table[0].pose, vec![0.0, 90.0]);
        assert_eq!(table[0].variant, None);
        assert_eq!(table[0].budget, Budget { impedance: 800, current: 150, flash: 1000, ram: 200 });
        assert_eq!(parse_table("a m - sc 0 1 2 3").unwrap_err().0, 1);
        assert!(parse_table("a m - sc x 1 2 3 4").unwrap_err().1.contains("pose"));
        assert!(parse_table("a m - sc 0 1 2 -3 4").unwrap_err().1.contains("flash"));
        let twice = "a m - sc 0 1 2 3 4\n\na m - sc 0 1 2 3 4\n";
        assert_eq!(parse_table(twice).unwrap_err().0, 3);
    }

    #[test]
    fn the_shipped_table_parses() {
        let dir = firmware_dir(Path::new(env!("CARGO_MANIFEST_DIR")));
        let table = read_table(&dir).unwrap();
        assert!(!table.is_empty());
    }
}
