//! The shipped models' code, generated at build time by `build.rs` with
//! `hapticgen_codegen::generate_model` (the paper's results come out of this code), and a
//! registry to find the generated rig of a model file.
#![allow(missing_docs, clippy::all)]

use hapticgen_codegen::CheckedModel;
use hapticgen_codegen::Scalar;
use hapticgen_runtime::RigModel;

/// One generated rig.
#[derive(Clone, Copy, Debug)]
pub struct ShippedRig {
    /// The model file, relative to the workspace root.
    pub file: &'static str,
    /// The model file's text, embedded at build time.
    pub source: &'static str,
    /// The rig's name.
    pub name: &'static str,
    /// The variant generated, if the model has variants.
    pub variant: Option<&'static str>,
    /// Number of joints.
    pub joints: usize,
    /// Task-space dimension.
    pub task_dim: usize,
    /// FNV-1a hash of the generated tokens (model file name blanked).
    pub fingerprint: u64,
}

/// Receives a generated rig with its dimensions as const generics.
pub trait RigVisitor {
    /// What the visit returns.
    type Output;
    /// Called with the rig.
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output;
}

/// FNV-1a, 64 bits (the same as the build script's).
pub fn fingerprint(text: &str) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in text.bytes() {
        hash ^= u64::from(byte);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// Loads the shipped model `name` (variant `variant`, or its default) from the text
/// embedded at build time.
pub fn load_shipped(name: &str, variant: Option<&str>) -> Result<CheckedModel, String> {
    let rig = SHIPPED
        .iter()
        .find(|rig| rig.name == name)
        .ok_or_else(|| format!("error: no shipped model named `{name}`"))?;
    hapticgen_codegen::load(&hapticgen_codegen::Source { name: rig.file, text: rig.source }, variant)
        .map_err(|d| d.to_string())
}

/// The index in [`SHIPPED`] of the rig generated from exactly this model (same name,
/// variant and generated code), if any.
pub fn find(model: &CheckedModel) -> Option<usize> {
    let candidates: Vec<usize> = SHIPPED
        .iter()
        .enumerate()
        .filter(|(_, rig)| rig.name == model.name && rig.variant == model.variant.as_deref())
        .map(|(i, _)| i)
        .collect();
    if candidates.is_empty() {
        return None;
    }
    let mut anonymous = model.clone();
    anonymous.model.file = String::new();
    let generated = hapticgen_codegen::generate_model(anonymous, Scalar::F64);
    let print = fingerprint(&generated.tokens.to_string());
    candidates.into_iter().find(|&i| SHIPPED[i].fingerprint == print)
}

include!(concat!(env!("OUT_DIR"), "/registry.rs"));
