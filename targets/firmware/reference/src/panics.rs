//! The panic paths left in a linked control-path probe (`hapticgen_fw_control::probe`).
//!
//! A probe holds the start-up code and one image's interrupt body, nothing else, and its
//! panic handler calls `hapticgen_fw_panic_reached`. Every panic in Rust ends in `core`'s
//! `panic_fmt` (or `panic_nounwind_fmt`) and then in the handler, and the linker keeps a
//! function only if something calls it: so the probe has any of the symbols below if and only
//! if a panic is reachable from the interrupt body after optimisation. The entry points of
//! `core` that the control code could call directly (`panic_bounds_check`, `unwrap_failed`,
//! `expect_failed`, the slice and `RefCell` failures, `core::panicking::*`) are named too, so
//! that the report says what kind of panic survived; `scripts/firmware.sh` then lists the
//! call sites with `llvm-objdump`.

use crate::elf::{self, STT_FUNC};

/// Parts of a symbol name (mangled or demangled) that mark a panic path: `core`'s panic entry
/// points, the panic handler, and the probe's own marker.
pub const PANIC_NAME_PARTS: &[&str] = &[
    "panic", // core::panicking::*, panic_bounds_check, panic_fmt, panic_already_borrowed, the handler
    "begin_unwind", // the #[panic_handler] function's symbol, rust_begin_unwind
    "unwrap_failed",
    "expect_failed",
    "assert_failed",
    "slice_index_fail",
    "slice_start_index_len_fail",
    "slice_end_index_len_fail",
    "slice_index_order_fail",
    "slice_error_fail",
    "str_index_overflow_fail",
    "len_mismatch_fail",
    "hapticgen_fw_panic_reached",
];

/// Whether a function of this name is a panic path (see [`PANIC_NAME_PARTS`]).
pub fn is_panic_symbol(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    PANIC_NAME_PARTS.iter().any(|part| lower.contains(part))
}

/// The panic functions in the ELF at `path`, demangled, sorted (empty: no panic path).
/// An ELF without a symbol table is an error: it cannot be checked.
pub fn panic_symbols(path: &str) -> Result<Vec<String>, String> {
    let symbols = elf::symbols(path)?;
    if !symbols.iter().any(|s| s.kind == STT_FUNC) {
        return Err("no function symbols (stripped?): cannot be checked".into());
    }
    let mut found: Vec<String> = symbols
        .iter()
        .filter(|s| s.kind == STT_FUNC && is_panic_symbol(&s.name))
        .map(|s| demangle(&s.name))
        .collect();
    found.sort();
    found.dedup();
    Ok(found)
}

/// A mangled Rust name as a path without hashes: legacy
/// (`_ZN4core9panicking9panic_fmt17h0123456789abcdefE`) or, for plain paths (crate root and
/// nested names, no generics or impls), v0 (`_RNvNtCs1234_4core9panicking9panic_fmt`), both
/// `core::panicking::panic_fmt`. Any other name comes back unchanged.
pub fn demangle(name: &str) -> String {
    if let Some(v0) = name.strip_prefix("_R") {
        let mut parser = V0 { rest: v0.trim_start_matches(|c: char| c.is_ascii_digit()) };
        return parser.path().unwrap_or_else(|| name.to_string());
    }
    let Some(mut rest) = name.strip_prefix("_ZN") else { return name.to_string() };
    let mut parts: Vec<String> = Vec::new();
    while let Some(first) = rest.chars().next() {
        if first == 'E' {
            break;
        }
        let digits = rest.len() - rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        let Ok(length) = rest[..digits].parse::<usize>() else { return name.to_string() };
        let Some(part) = rest.get(digits..digits + length) else { return name.to_string() };
        parts.push(part.to_string());
        rest = &rest[digits + length..];
    }
    let is_hash =
        |p: &str| p.len() == 17 && p.starts_with('h') && p[1..].chars().all(|c| c.is_ascii_hexdigit());
    if parts.last().is_some_and(|p| is_hash(p)) {
        parts.pop();
    }
    let path = parts.join("::");
    let escapes = [
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$RF$", "&"),
        ("$BP$", "*"),
        ("$C$", ","),
        ("$u20$", " "),
        ("$u27$", "'"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$u7b$", "{"),
        ("$u7d$", "}"),
        ("$u3b$", ";"),
        ("$u2b$", "+"),
        ("$u22$", "\""),
        ("..", "::"),
    ];
    let mut text = path.strip_prefix('_').filter(|t| t.starts_with('$')).unwrap_or(&path).to_string();
    for (from, to) in escapes {
        text = text.replace(from, to);
    }
    text
}

/// The subset of the v0 mangling grammar that `core`'s panic functions use: `C` (crate root),
/// `N` (nested path); identifiers with an optional disambiguator.
struct V0<'a> {
    rest: &'a str,
}

impl V0<'_> {
    fn take(&mut self, prefix: char) -> bool {
        match self.rest.strip_prefix(prefix) {
            Some(rest) => {
                self.rest = rest;
                true
            }
            None => false,
        }
    }

    /// `s <base-62> _`, skipped.
    fn disambiguator(&mut self) -> Option<()> {
        if self.take('s') {
            let end = self.rest.find('_')?;
            self.rest = &self.rest[end + 1..];
        }
        Some(())
    }

    fn identifier(&mut self) -> Option<&str> {
        self.disambiguator()?;
        if self.rest.starts_with('u') {
            return None; // Punycode: not needed here.
        }
        let digits = self.rest.len() - self.rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        let length: usize = self.rest[..digits].parse().ok()?;
        self.rest = &self.rest[digits..];
        self.take('_');
        let identifier = self.rest.get(..length)?;
        self.rest = &self.rest[length..];
        Some(identifier)
    }

    fn path(&mut self) -> Option<String> {
        if self.take('C') {
            return self.identifier().map(str::to_string);
        }
        if !self.take('N') {
            return None;
        }
        let namespace = self.rest.chars().next()?;
        self.rest = &self.rest[namespace.len_utf8()..];
        let parent = self.path()?;
        let identifier = self.identifier()?;
        Some(match namespace {
            'C' => format!("{parent}::{{closure}}"),
            c if c.is_ascii_uppercase() => format!("{parent}::{{{c}}}"),
            _ => format!("{parent}::{identifier}"),
        })
    }
}
