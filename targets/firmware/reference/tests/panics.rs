//! The panic check's pieces on hand-made inputs: the symbol table reader on a minimal ELF, the
//! name rule and the demangler. (The check itself runs on every probe in scripts/firmware.sh.)

use hapticgen_fw_reference::elf::{symbols_of, Symbol, STT_FUNC};
use hapticgen_fw_reference::panics::{demangle, is_panic_symbol};

/// A 32-bit little-endian ELF with three sections (null, `.symtab`, `.strtab`) and the given
/// symbols `(name, value, type, section index)`.
fn elf_with(symbols: &[(&str, u32, u8, u16)]) -> Vec<u8> {
    let mut strtab = vec![0u8];
    let mut symtab = vec![0u8; 16]; // entry 0: the null symbol
    for &(name, value, kind, section) in symbols {
        let at = strtab.len() as u32;
        strtab.extend_from_slice(name.as_bytes());
        strtab.push(0);
        symtab.extend_from_slice(&at.to_le_bytes());
        symtab.extend_from_slice(&value.to_le_bytes());
        symtab.extend_from_slice(&4u32.to_le_bytes());
        symtab.push(kind);
        symtab.push(0);
        symtab.extend_from_slice(&section.to_le_bytes());
    }
    let mut b = vec![0u8; 52];
    b[..6].copy_from_slice(&[0x7f, b'E', b'L', b'F', 1, 1]);
    let symtab_at = b.len() as u32;
    b.extend_from_slice(&symtab);
    let strtab_at = b.len() as u32;
    b.extend_from_slice(&strtab);
    let shoff = b.len() as u32;
    b[0x20..0x24].copy_from_slice(&shoff.to_le_bytes());
    b[0x2e..0x30].copy_from_slice(&40u16.to_le_bytes());
    b[0x30..0x32].copy_from_slice(&3u16.to_le_bytes());
    let header = |kind: u32, offset: u32, size: u32, link: u32, entsize: u32| {
        let mut h = vec![0u8; 40];
        h[4..8].copy_from_slice(&kind.to_le_bytes());
        h[16..20].copy_from_slice(&offset.to_le_bytes());
        h[20..24].copy_from_slice(&size.to_le_bytes());
        h[24..28].copy_from_slice(&link.to_le_bytes());
        h[36..40].copy_from_slice(&entsize.to_le_bytes());
        h
    };
    b.extend(header(0, 0, 0, 0, 0));
    b.extend(header(2, symtab_at, symtab.len() as u32, 2, 16));
    b.extend(header(3, strtab_at, strtab.len() as u32, 0, 0));
    b
}

#[test]
fn reads_defined_symbols_and_skips_undefined_ones() {
    let b = elf_with(&[
        ("SysTick", 0x101, STT_FUNC, 1),
        ("_ZN4core9panicking18panic_bounds_check17h0123456789abcdefE", 0x201, STT_FUNC, 1),
        ("undefined_here", 0, STT_FUNC, 0),
    ]);
    let found = symbols_of(&b).unwrap();
    assert_eq!(
        found,
        vec![
            Symbol { name: "SysTick".into(), value: 0x101, size: 4, kind: STT_FUNC },
            Symbol {
                name: "_ZN4core9panicking18panic_bounds_check17h0123456789abcdefE".into(),
                value: 0x201,
                size: 4,
                kind: STT_FUNC
            },
        ]
    );
    assert!(symbols_of(b"not an elf").is_err());
}

#[test]
fn names_every_panic_entry_point_and_nothing_else() {
    for name in [
        "_ZN4core9panicking18panic_bounds_check17h0123456789abcdefE",
        "_ZN4core9panicking9panic_fmt17h0123456789abcdefE",
        "_ZN4core6option13unwrap_failed17h0123456789abcdefE",
        "_ZN4core6result13unwrap_failed17h0123456789abcdefE",
        "_ZN4core6option13expect_failed17h0123456789abcdefE",
        "_ZN4core4cell22panic_already_borrowed17h0123456789abcdefE",
        "_ZN4core5slice5index16slice_index_fail17h0123456789abcdefE",
        "_ZN7__rustc17rust_begin_unwind17h0123456789abcdefE",
        "_ZN20hapticgen_fw_control5probe26hapticgen_fw_panic_reached17h0123456789abcdefE",
        // v0 mangling, as Rust 1.95 writes them into the probes.
        "_RNvNtCs7ldSeZOOJos_4core6option13unwrap_failed",
        "_RNvNtCs7ldSeZOOJos_4core9panicking9panic_fmt",
        "_RNvCsfLfy6EI15iL_7___rustc17rust_begin_unwind",
    ] {
        assert!(is_panic_symbol(name), "{name}");
    }
    for name in
        ["SysTick", "Reset", "_ZN16hapticgen_runtime4tick9HapticLoop12current_tick17h0123456789abcdefE"]
    {
        assert!(!is_panic_symbol(name), "{name}");
    }
}

#[test]
fn demangles_legacy_names() {
    assert_eq!(
        demangle("_ZN4core9panicking18panic_bounds_check17h0123456789abcdefE"),
        "core::panicking::panic_bounds_check"
    );
    assert_eq!(
        demangle("_ZN69_$LT$hapticgen_fw_control..probe..OpaqueBoard$u20$as$u20$Encoders$GT$6counts17h0123456789abcdefE"),
        "<hapticgen_fw_control::probe::OpaqueBoard as Encoders>::counts"
    );
    assert_eq!(demangle("SysTick"), "SysTick");
}

#[test]
fn demangles_v0_paths_and_leaves_the_rest() {
    assert_eq!(demangle("_RNvNtCs7ldSeZOOJos_4core6option13unwrap_failed"), "core::option::unwrap_failed");
    assert_eq!(demangle("_RNvCsfLfy6EI15iL_7___rustc17rust_begin_unwind"), "__rustc::rust_begin_unwind");
    assert_eq!(
        demangle("_RNvNtCs1a_20hapticgen_fw_control5probe26hapticgen_fw_panic_reached"),
        "hapticgen_fw_control::probe::hapticgen_fw_panic_reached"
    );
    // Generic instances (`I … E`) are not decoded: the name is kept as it is.
    let generic = "_RINvNtCs1a_4core3ptr13drop_in_placeNtCs2b_3foo3BarEB4_";
    assert_eq!(demangle(generic), generic);
}
