//! Build-script helper: generates a rig's code into `OUT_DIR` from `build.rs`.
//!
//! ```no_run
//! // build.rs
//! let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap());
//! hapticgen_codegen::build::generate(
//!     "models/parallel_link_2dof.yaml",
//!     Some("horizontal"),
//!     hapticgen_codegen::Scalar::F32,
//!     &out.join("parallel_link.rs"),
//! )
//! .unwrap_or_else(|e| panic!("{e}"));
//! ```
//! and in the crate: `include!(concat!(env!("OUT_DIR"), "/parallel_link.rs"));`.

use std::path::{Path, PathBuf};

use crate::{Diagnostics, EmitOptions, Scalar};

/// Generates the code of `model` (path relative to the current directory, which is the
/// package root in a build script) into `out_file`, printing `cargo:rerun-if-changed` for the
/// model. The file is rewritten only when its content changes.
pub fn generate(
    model: impl AsRef<Path>,
    variant: Option<&str>,
    scalar: Scalar,
    out_file: &Path,
) -> Result<(), Diagnostics> {
    generate_with(model, variant, scalar, EmitOptions::default(), out_file)
}

/// [`generate`] with emission options (e.g. fused multiply-adds).
pub fn generate_with(
    model: impl AsRef<Path>,
    variant: Option<&str>,
    scalar: Scalar,
    options: EmitOptions,
    out_file: &Path,
) -> Result<(), Diagnostics> {
    let model = model.as_ref();
    println!("cargo:rerun-if-changed={}", model.display());
    let text = generate_text_with(model, variant, scalar, options)?;
    let unchanged = std::fs::read_to_string(out_file).map(|old| old == text).unwrap_or(false);
    if !unchanged {
        std::fs::write(out_file, text).map_err(|e| Diagnostic {
            file: out_file.display().to_string(),
            line: 1,
            column: 1,
            path: String::new(),
            message: format!("cannot write the generated file: {e}"),
            hint: None,
        })?;
    }
    Ok(())
}

/// The text `generate` writes: header plus formatted items.
pub fn generate_text(model: &Path, variant: Option<&str>, scalar: Scalar) -> Result<String, Diagnostics> {
    generate_text_with(model, variant, scalar, EmitOptions::default())
}

/// The text `generate_with` writes.
pub fn generate_text_with(
    model: &Path,
    variant: Option<&str>,
    scalar: Scalar,
    options: EmitOptions,
) -> Result<String, Diagnostics> {
    let display = model.display().to_string();
    let loaded = crate::load_file(model, &display, variant)?;
    Ok(crate::generate_model_with(loaded, scalar, options).file_text())
}

use crate::Diagnostic;

/// A model file of a directory and its variants.
#[derive(Clone, Debug)]
pub struct ModelEntry {
    /// The file.
    pub path: PathBuf,
    /// Its name in diagnostics and generated headers, `"<prefix>/<file name>"`.
    pub display: String,
    /// Its variants, or `[None]` for a model without variants.
    pub variants: Vec<Option<String>>,
}

/// Every `*.yaml` model file in `dir`, sorted by name, with its variants (what build scripts
/// and tests iterate over to cover every shipped rig).
pub fn models_in(dir: &Path, prefix: &str) -> Result<Vec<ModelEntry>, Diagnostics> {
    let unreadable = |e: std::io::Error| Diagnostic {
        file: dir.display().to_string(),
        line: 1,
        column: 1,
        path: String::new(),
        message: format!("cannot list the model directory: {e}"),
        hint: None,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(unreadable)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|path| {
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let display = format!("{prefix}/{name}");
            let model = crate::load_file(&path, &display, None)?;
            let variants = if model.variants.is_empty() {
                vec![None]
            } else {
                model.variants.iter().cloned().map(Some).collect()
            };
            Ok(ModelEntry { path, display, variants })
        })
        .collect()
}
