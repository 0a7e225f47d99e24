//! Every shipped model, generated at build time (all variants, `f32` and `f64`), and a visitor
//! over them so that tests run once per rig.
#![allow(missing_docs)]

use hapticgen_runtime::fused::FusedImpedance;

/// Which model file and variant a generated rig came from.
#[derive(Clone, Copy, Debug)]
pub struct RigInfo {
    /// The model file, relative to the workspace root.
    pub file: &'static str,
    /// The variant, if the model has variants.
    pub variant: Option<&'static str>,
    /// The generated module's name.
    pub module: &'static str,
}

/// Visits generated rigs of either scalar type.
pub trait RigVisitor {
    /// A double-precision rig.
    fn visit_f64<R: FusedImpedance<N, M, Scalar = f64>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    );
    /// A single-precision rig.
    fn visit_f32<R: FusedImpedance<N, M, Scalar = f32>, const N: usize, const M: usize>(
        &mut self,
        info: &RigInfo,
        rig: &R,
    );
}

include!(concat!(env!("OUT_DIR"), "/registry.rs"));

/// The workspace root (for loading model files in tests).
pub fn workspace_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}
