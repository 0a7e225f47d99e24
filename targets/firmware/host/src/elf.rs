//! `size`-style accounting of a 32-bit little-endian ELF from its section headers, with no
//! dependency: `text` = allocated read-only sections (vector table, code, rodata), `data` =
//! allocated writable PROGBITS (in RAM, with a load image in flash), `bss` = allocated
//! writable NOBITS. Flash = text + data, static RAM = data + bss (the stack is not static;
//! there is no heap).

const SHT_NOBITS: u32 = 8;
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

/// Reads the section headers of `path`.
pub fn sizes(path: &str) -> Result<Sizes, String> {
    let b = std::fs::read(path).map_err(|e| e.to_string())?;
    if b.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let shoff = u32_at(&b, 0x20)? as usize;
    let shentsize = u16_at(&b, 0x2e)? as usize;
    let shnum = u16_at(&b, 0x30)? as usize;
    let mut sizes = Sizes::default();
    for i in 0..shnum {
        let h = shoff + i * shentsize;
        let kind = u32_at(&b, h + 4)?;
        let flags = u32_at(&b, h + 8)?;
        let size = u64::from(u32_at(&b, h + 20)?);
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
