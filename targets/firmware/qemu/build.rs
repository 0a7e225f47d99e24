//! Generates the rig of the image named by `HAPTICGEN_FW_VARIANT` (a line of variants.txt;
//! the first line when unset) in f32, its glue module (with the line's scenario on the
//! simulated board), and `memory.x` for the MPS2-AN386. Both binaries, the image and its
//! control-path probe, include the glue.
use std::path::PathBuf;

use hapticgen_codegen::Scalar;
use hapticgen_fw_build::Glue;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let firmware = hapticgen_fw_build::firmware_dir(&manifest);
    let table = hapticgen_fw_build::read_table(&firmware).unwrap_or_else(|e| panic!("{e}"));
    println!("cargo:rerun-if-env-changed=HAPTICGEN_FW_VARIANT");
    let wanted = std::env::var("HAPTICGEN_FW_VARIANT").ok();
    let variant = match &wanted {
        Some(name) => table.iter().find(|v| &v.name == name).unwrap_or_else(|| {
            let names: Vec<&str> = table.iter().map(|v| v.name.as_str()).collect();
            panic!("HAPTICGEN_FW_VARIANT={name} is not in variants.txt (known: {})", names.join(", "))
        }),
        None => table.first().expect("variants.txt lists at least one image"),
    };
    let glue = hapticgen_fw_build::generate(variant, &firmware, Scalar::F32, &out, "image", Glue::Simulation)
        .unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(out.join("image.rs"), glue).expect("OUT_DIR is writable");
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
