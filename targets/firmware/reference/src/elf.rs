//! A 32-bit little-endian ELF read with no dependency.
//!
//! * [`sizes`]: `size`-style accounting from the section headers: `text` = allocated
//!   read-only sections (vector table, code, rodata), `data` = allocated writable PROGBITS (in
//!   RAM, with a load image in flash), `bss` = allocated writable NOBITS. Flash = text + data,
//!   static RAM = data + bss (the stack is not static; there is no heap).
//! * [`symbols`]: the defined symbols of `.symtab` (names as the linker wrote them, mangled).

const SHT_SYMTAB: u32 = 2;
const SHT_NOBITS: u32 = 8;
/// `STT_FUNC`: the symbol is a function.
pub const STT_FUNC: u8 = 2;
const SHF_WRITE: u32 = 1;
const SHF_ALLOC: u32 = 2;

/// Section totals, bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sizes {
    /// Read-only allocated sections.
    pub text: u64,
    /// Initialised writable sections.
    pub data: u64,
    /// Zero-initialised writable sections.
    pub bss: u64,
}

impl Sizes {
    /// Flash used.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }
    /// Static RAM used.
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }
}

fn u16_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 2).map(|s| u32::from(u16::from_le_bytes([s[0], s[1]]))).ok_or_else(|| "truncated".into())
}

fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]])).ok_or_else(|| "truncated".into())
}

/// One section header (the fields used here).
struct Section {
    kind: u32,
    flags: u32,
    offset: usize,
    size: usize,
    link: usize,
    entry_size: usize,
}

fn sections(b: &[u8]) -> Result<Vec<Section>, String> {
    if b.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let shoff = u32_at(b, 0x20)? as usize;
    let shentsize = u16_at(b, 0x2e)? as usize;
    let shnum = u16_at(b, 0x30)? as usize;
    (0..shnum)
        .map(|i| {
            let h = shoff + i * shentsize;
            Ok(Section {
                kind: u32_at(b, h + 4)?,
                flags: u32_at(b, h + 8)?,
                offset: u32_at(b, h + 16)? as usize,
                size: u32_at(b, h + 20)? as usize,
                link: u32_at(b, h + 24)? as usize,
                entry_size: u32_at(b, h + 36)? as usize,
            })
        })
        .collect()
}

/// Reads the section headers of `path`.
pub fn sizes(path: &str) -> Result<Sizes, String> {
    let b = std::fs::read(path).map_err(|e| e.to_string())?;
    let mut sizes = Sizes::default();
    for section in sections(&b)? {
        let (kind, flags, size) = (section.kind, section.flags, section.size as u64);
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if flags & SHF_WRITE == 0 {
            sizes.text += size;
        } else if kind == SHT_NOBITS {
            sizes.bss += size;
        } else {
            sizes.data += size;
        }
    }
    Ok(sizes)
}

/// A defined symbol of `.symtab`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Symbol {
    /// The name as the linker wrote it (mangled).
    pub name: String,
    /// The address (for a Thumb function, with bit 0 set).
    pub value: u32,
    /// The size, bytes.
    pub size: u32,
    /// The symbol type (`st_info & 0xf`; [`STT_FUNC`] for a function).
    pub kind: u8,
}

/// The defined symbols of the ELF file at `path` (empty if it has no `.symtab`: stripped).
pub fn symbols(path: &str) -> Result<Vec<Symbol>, String> {
    symbols_of(&std::fs::read(path).map_err(|e| e.to_string())?)
}

/// The defined symbols of an ELF image in memory; see [`symbols`].
pub fn symbols_of(b: &[u8]) -> Result<Vec<Symbol>, String> {
    let sections = sections(b)?;
    let mut found = Vec::new();
    for table in sections.iter().filter(|s| s.kind == SHT_SYMTAB) {
        let names = sections.get(table.link).ok_or("symbol table without a string table")?;
        let strings = b.get(names.offset..names.offset + names.size).ok_or("truncated")?;
        let entry = table.entry_size.max(16);
        for at in (table.offset..table.offset + table.size).step_by(entry).skip(1) {
            let name_at = u32_at(b, at)? as usize;
            let section = u16_at(b, at + 14)?;
            if section == 0 {
                continue; // undefined
            }
            let info = *b.get(at + 12).ok_or("truncated")?;
            let tail = strings.get(name_at..).ok_or("symbol name out of range")?;
            let end = tail.iter().position(|&c| c == 0).unwrap_or(tail.len());
            found.push(Symbol {
                name: String::from_utf8_lossy(&tail[..end]).into_owned(),
                value: u32_at(b, at + 4)?,
                size: u32_at(b, at + 8)?,
                kind: info & 0xf,
            });
        }
    }
    Ok(found)
}
