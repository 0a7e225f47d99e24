//! Used by the build scripts of the firmware image (`qemu`, one variant, `f32`) and of the
//! host reference (`host`, every variant, `f32` and `f64`).
//!
//! `targets/firmware/variants.txt` is the table of images: `name model variant scenario`
//! per line. For each, [`generate`] writes the rig's code (through the build-script helper
//! `hapticgen_codegen::build::generate`) and returns a glue module: the rig type, the
//! scenario type `Run`, the model-derived `Setup` (current-loop gains designed by
//! `hapticgen_codegen::current_loop::design_current_loop`, rendering parameters) and
//! `new(profile)`.
#![deny(missing_docs)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hapticgen_codegen::current_loop::{design_current_loop, CurrentLoopDesignInput};
use hapticgen_codegen::{emit, model, Scalar};

/// Order of the anti-aliasing Bessel filter assumed by the current-loop design (the model
/// format gives only its cutoff).
pub const FILTER_ORDER: u32 = 2;

/// One line of `variants.txt`: `name model variant scenario impedance_budget`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Variant {
    /// Image name (also the `HAPTICGEN_FW_VARIANT` value).
    pub name: String,
    /// Model file relative to the repository root.
    pub model: String,
    /// Model variant, if any.
    pub variant: Option<String>,
    /// Scenario module in `hapticgen_fw_sim::scenarios`.
    pub scenario: String,
    /// Limit on one impedance tick, instructions (checked by `scripts/firmware.sh`).
    pub impedance_budget: u32,
}

/// The firmware workspace directory (`targets/firmware`), from a member's manifest dir.
pub fn firmware_dir(manifest_dir: &Path) -> PathBuf {
    manifest_dir.join("..")
}

/// Reads `variants.txt`; prints `cargo:rerun-if-changed` for it.
pub fn read_table(firmware_dir: &Path) -> Result<Vec<Variant>, String> {
    let path = firmware_dir.join("variants.txt");
    println!("cargo:rerun-if-changed={}", path.display());
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut table = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != 5 {
            return Err(format!(
                "{}:{}: expected `name model variant scenario impedance_budget`, got {} fields",
                path.display(),
                index + 1,
                fields.len()
            ));
        }
        let ok_ident = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ok_ident(fields[0]) || !ok_ident(fields[3]) {
            return Err(format!("{}:{}: name and scenario must be identifiers", path.display(), index + 1));
        }
        table.push(Variant {
            name: fields[0].to_string(),
            model: fields[1].to_string(),
            variant: if fields[2] == "-" { None } else { Some(fields[2].to_string()) },
            scenario: fields[3].to_string(),
            impedance_budget: fields[4]
                .parse()
                .map_err(|e| format!("{}:{}: impedance budget: {e}", path.display(), index + 1))?,
        });
    }
    Ok(table)
}

fn literal(value: f64) -> String {
    // `{:?}` prints the shortest representation that round-trips, always with a `.` or `e`.
    format!("{value:?}")
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
    hapticgen_codegen::build::generate(&model_path, v.variant.as_deref(), scalar, &rig_file)
        .map_err(|e| e.to_string())?;
    let loaded = model::load_file(&model_path, &v.model, v.variant.as_deref()).map_err(|e| e.to_string())?;
    let first = loaded.joints.first().ok_or_else(|| format!("{}: the model has no joints", v.model))?;
    let motor = &first.drive.motor;
    let design = design_current_loop(&CurrentLoopDesignInput {
        resistance: motor.resistance,
        inductance: motor.inductance,
        sample_rate_hz: f64::from(loaded.rates.current_loop_hz),
        bandwidth_hz: loaded.current_loop.bandwidth_hz,
        damping_ratio: loaded.current_loop.damping_ratio,
        filter_cutoff_hz: loaded.current_loop.anti_alias_cutoff_hz,
        filter_order: FILTER_ORDER,
    })
    .map_err(|e| format!("{}: {e}", v.model))?;
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
    let mut glue = String::new();
    writeln!(
        glue,
        "/// Image `{name}`: `{model}`{variant}, scenario `{scenario}`, {s}.\n\
         pub mod {module} {{\n\
         \x20   #[allow(clippy::all, missing_docs)]\n\
         \x20   pub mod rig {{ include!(concat!(env!(\"OUT_DIR\"), \"/{module}_rig.rs\")); }}\n\
         \x20   /// The generated rig.\n\
         \x20   pub type Rig = rig::{type_name};\n\
         \x20   /// The scenario for this rig.\n\
         \x20   pub type Run = ::hapticgen_fw_sim::scenarios::{scenario}::Run<Rig>;\n\
         \x20   /// The image name.\n\
         \x20   pub const NAME: &str = \"{name}\";\n\
         \x20   /// The rig's current-loop rate, Hz (the interrupt rate).\n\
         \x20   pub const CURRENT_LOOP_HZ: u32 = {hz};\n\
         \x20   /// The rig's impedance-loop rate, Hz.\n\
         \x20   pub const IMPEDANCE_LOOP_HZ: u32 = {imp_hz};\n\
         \x20   /// Model-derived settings: current-loop gains (kp, ki designed at build time), rendering.\n\
         \x20   pub fn setup() -> ::hapticgen_fw_sim::Setup<{s}> {{\n\
         \x20       type S = {s};\n\
         \x20       use ::hapticgen_runtime::Real as _;\n\
         \x20       ::hapticgen_fw_sim::Setup {{\n\
         \x20           current_gains: ::hapticgen_runtime::current_loop::CurrentLoopGains {{\n\
         \x20               kp: S::from_f64({kp}),\n\
         \x20               ki: S::from_f64({ki}),\n\
         \x20               sample_period: S::from_f64({period}),\n\
         \x20               proportional_setpoint_weight: S::from_f64({beta}),\n\
         \x20           }},\n\
         \x20           sense_time_constant: S::from_f64({tau}),\n\
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
        kp = literal(design.kp),
        ki = literal(design.ki),
        period = literal(design.sample_period),
        beta = literal(design.proportional_setpoint_weight),
        tau = literal(design.filter_time_constant),
        hz = loaded.rates.current_loop_hz,
        imp_hz = loaded.rates.impedance_loop_hz,
    )
    .map_err(|e| e.to_string())?;
    Ok(glue)
}
