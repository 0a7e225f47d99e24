//! The rig (f32) of the image named by `HAPTICGEN_FW_VARIANT` (default `horizontal`; this
//! board wiring has two joints) and its board glue module `image` (no simulated scenario),
//! generated here (feature `generate`, the default) or copied from `$HAPTICGEN_FW_GENERATED`
//! (see `hapticgen_fw_build::copy_pregenerated`); and memory.x for the STM32F407VG.
//! `HAPTICGEN_FW_MODEL` (an absolute path) builds the image from that model file in place of
//! its line's (`hapticgen_fw_build::MODEL_ENV`).
use std::path::{Path, PathBuf};

use hapticgen_fw_build::{Glue, Variant};

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let firmware = hapticgen_fw_build::firmware_dir(&manifest);
    let table = hapticgen_fw_build::read_table(&firmware)
        .and_then(hapticgen_fw_build::apply_model_override)
        .unwrap_or_else(|e| panic!("{e}"));
    println!("cargo:rerun-if-env-changed=HAPTICGEN_FW_VARIANT");
    let name = std::env::var("HAPTICGEN_FW_VARIANT").unwrap_or_else(|_| "horizontal".into());
    let variant = table
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("HAPTICGEN_FW_VARIANT={name} is not in variants.txt"));
    match hapticgen_fw_build::copy_pregenerated(variant, Glue::Board, &out) {
        Some(copied) => copied.unwrap_or_else(|e| panic!("{e}")),
        None => generate(variant, &firmware, &out),
    }
    std::fs::write(
        out.join("memory.x"),
        "MEMORY\n{\n  FLASH : ORIGIN = 0x08000000, LENGTH = 1024K\n  RAM : ORIGIN = 0x20000000, LENGTH = 128K\n}\n",
    )
    .expect("OUT_DIR is writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
}

/// A board image: the rig and its model-derived setup, no simulated scenario.
#[cfg(feature = "generate")]
fn generate(variant: &Variant, firmware: &Path, out: &Path) {
    hapticgen_fw_build::generate_image(variant, firmware, out, Glue::Board).unwrap_or_else(|e| panic!("{e}"));
}

#[cfg(not(feature = "generate"))]
fn generate(variant: &Variant, _: &Path, _: &Path) {
    panic!("{}", hapticgen_fw_build::not_pregenerated(variant));
}
