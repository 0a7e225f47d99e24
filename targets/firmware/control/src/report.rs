//! Integer-only text output. Lines are `KEY field=value ...`, values are decimal integers or
//! `0x`-prefixed hex; no `core::fmt` and no float formatting anywhere (on the target that
//! would cost ~29 KB of flash). The host reference prints through the same code, so the
//! two outputs are compared line by line.

/// Where finished lines go (semihosting on the target, stdout on the host).
pub trait Sink {
    /// Writes the bytes of one or more complete lines.
    fn write(&mut self, bytes: &[u8]);
}

/// A fixed-capacity line; content beyond the capacity is dropped (and marked with `~`).
pub struct Line {
    buf: [u8; 160],
    len: usize,
    overflow: bool,
}

impl Default for Line {
    fn default() -> Self {
        Self::new()
    }
}

impl Line {
    /// An empty line.
    pub const fn new() -> Self {
        Self { buf: [0; 160], len: 0, overflow: false }
    }

    fn push_byte(&mut self, b: u8) {
        // Keep room for the overflow mark and the newline.
        if self.len + 2 < self.buf.len() {
            self.buf[self.len] = b;
            self.len += 1;
        } else {
            self.overflow = true;
        }
    }

    /// Appends text.
    pub fn str(&mut self, s: &str) -> &mut Self {
        for &b in s.as_bytes() {
            self.push_byte(b);
        }
        self
    }

    /// Appends an unsigned decimal.
    pub fn u64(&mut self, mut value: u64) -> &mut Self {
        let mut digits = [0u8; 20];
        let mut n = 0;
        loop {
            digits[n] = b'0' + (value % 10) as u8;
            n += 1;
            value /= 10;
            if value == 0 {
                break;
            }
        }
        while n > 0 {
            n -= 1;
            self.push_byte(digits[n]);
        }
        self
    }

    /// Appends a signed decimal.
    pub fn i64(&mut self, value: i64) -> &mut Self {
        if value < 0 {
            self.push_byte(b'-');
        }
        self.u64(value.unsigned_abs())
    }

    /// Appends `0x` and eight hex digits.
    pub fn hex32(&mut self, value: u32) -> &mut Self {
        self.str("0x");
        for shift in (0..8).rev() {
            let nibble = ((value >> (shift * 4)) & 0xf) as u8;
            self.push_byte(if nibble < 10 { b'0' + nibble } else { b'a' + nibble - 10 });
        }
        self
    }

    /// Appends ` key=` then a signed decimal.
    pub fn kv(&mut self, key: &str, value: i64) -> &mut Self {
        self.str(" ").str(key).str("=").i64(value)
    }

    /// Appends ` key=` then a hex word.
    pub fn kx(&mut self, key: &str, value: u32) -> &mut Self {
        self.str(" ").str(key).str("=").hex32(value)
    }

    /// Terminates the line and writes it.
    pub fn emit<W: Sink>(&mut self, sink: &mut W) {
        if self.overflow {
            self.buf[self.len] = b'~';
            self.len += 1;
        }
        self.buf[self.len] = b'\n';
        self.len += 1;
        sink.write(&self.buf[..self.len]);
        self.len = 0;
        self.overflow = false;
    }
}
