//! The image named by `HAPTICGEN_FW_VARIANT` (a line of variants.txt; the first line when
//! unset): its rig in f32 and its glue module `image` (with the line's scenario on the
//! simulated board), generated here (feature `generate`, the default) or copied from
//! `$HAPTICGEN_FW_GENERATED` (see `hapticgen_fw_build::copy_pregenerated`); and `memory.x` for
//! the MPS2-AN386. Both binaries, the image and its control-path probe, include the glue.
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
    let wanted = std::env::var("HAPTICGEN_FW_VARIANT").ok();
    let variant = match &wanted {
        Some(name) => table.iter().find(|v| &v.name == name).unwrap_or_else(|| {
            let names: Vec<&str> = table.iter().map(|v| v.name.as_str()).collect();
            panic!("HAPTICGEN_FW_VARIANT={name} is not in variants.txt (known: {})", names.join(", "))
        }),
        None => table.first().expect("variants.txt lists at least one image"),
    };
    match hapticgen_fw_build::copy_pregenerated(variant, Glue::Simulation, &out) {
        Some(copied) => copied.unwrap_or_else(|e| panic!("{e}")),
        None => generate(variant, &firmware, &out),
    }
    // MPS2-AN386 under QEMU: 4 MiB SSRAM1 at 0 (code), 4 MiB SSRAM2 at 0x2000_0000 (data).
    // Each image's flash and RAM limits (variants.txt) are checked on the ELF by
    // scripts/firmware.sh.
    std::fs::write(
        out.join("memory.x"),
        "MEMORY\n{\n  FLASH : ORIGIN = 0x00000000, LENGTH = 4M\n  RAM : ORIGIN = 0x20000000, LENGTH = 4M\n}\n",
    )
    .expect("OUT_DIR is writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
}

#[cfg(feature = "generate")]
fn generate(variant: &Variant, firmware: &Path, out: &Path) {
    hapticgen_fw_build::generate_image(variant, firmware, out, Glue::Simulation)
        .unwrap_or_else(|e| panic!("{e}"));
}

#[cfg(not(feature = "generate"))]
fn generate(variant: &Variant, _: &Path, _: &Path) {
    panic!("{}", hapticgen_fw_build::not_pregenerated(variant));
}
