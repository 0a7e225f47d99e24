//! Framing: `COBS(postcard(message) ‖ crc16_le) 0x00`.
//!
//! COBS (consistent overhead byte stuffing) removes every zero byte from the frame's body, at a
//! cost of one byte per 254, so the zero byte delimits frames and a receiver that starts in
//! the middle of a stream, or loses bytes, is back in step at the next zero. The CRC
//! (CRC-16/IBM-SDLC, the X.25 CRC: polynomial 0x1021 reflected, initial value and final XOR
//! 0xFFFF) detects every error of up to three bits and every burst up to 16 bits in frames of
//! this size; postcard then accepts only a complete message of this protocol version, with no
//! bytes left over.
//!
//! Both ends are written for the device's 1 kHz budget (docs/link.md, "Cost on the
//! Cortex-M4F"): a message is serialised straight into the output buffer one byte after its
//! start, its CRC is computed four bytes at a time from tables in flash, and the stuffing
//! turns its zero bytes into block lengths in place (a body shorter than 254 bytes needs
//! exactly one byte of overhead), looking only where zero bytes can be: a state frame's
//! channels hold none (`CHANNEL_CODES`), so only its head and CRC are looked at. The receiver
//! stores each byte as it arrives and, at the frame's zero byte, undoes the stuffing in place
//! one step per block, checks the CRC and hands the body over for deserialisation.

use serde::de::{Deserialize, DeserializeOwned};
use serde::Serialize;

/// The largest serialised message (before the CRC and the stuffing).
pub const MAX_MESSAGE_BYTES: usize = 120;

/// The largest frame on the wire, delimiter included: the body and its CRC, one COBS code
/// byte (the body is shorter than a COBS block of 254 bytes) and the zero byte.
pub const MAX_FRAME_BYTES: usize = MAX_MESSAGE_BYTES + CRC_BYTES + 2;

const CRC_BYTES: usize = 2;

// In-place stuffing (`finish`) and the frame size above need a body shorter than one COBS
// block: a run of 254 non-zero bytes would need a second code byte.
const _: () = assert!(MAX_MESSAGE_BYTES + CRC_BYTES < 254);

/// CRC-16/IBM-SDLC (the X.25 CRC) tables for four bytes at a time: [`CRC_BYTE`] is the usual
/// byte table of the reflected polynomial 0x8408, `CRC_AFTER_k[b]` the CRC state of byte `b`
/// followed by `k` zero bytes. In flash, computed at compile time (4 KiB: `u32` entries, see
/// [`CRC_START`]); `static`s so that each is one table, not one per use, and four of them,
/// not one array of four, so that the code holds each table's address in a register of its
/// own and looks an entry up in one instruction.
static CRC_BYTE: [u32; 256] = crc_table(0);
static CRC_AFTER_1: [u32; 256] = crc_table(1);
static CRC_AFTER_2: [u32; 256] = crc_table(2);
static CRC_AFTER_3: [u32; 256] = crc_table(3);

/// The table of the CRC state of each byte followed by `zeros` zero bytes.
const fn crc_table(zeros: usize) -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut byte = 0;
    while byte < 256 {
        let mut crc = byte as u32;
        let mut bit = 0;
        while bit < 8 * (zeros + 1) {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0x8408 } else { crc >> 1 };
            bit += 1;
        }
        table[byte] = crc;
        byte += 1;
    }
    table
}

/// The CRC state before the first byte. The state is 16 bits held in a `u32` (the tables'
/// entries too): the compiler then keeps each word whole instead of splitting it into a
/// 16-bit half for the state and bytes for the rest.
const CRC_START: u32 = 0xFFFF;

/// The CRC state after the four bytes of `word` (little-endian): reflected, the state's two
/// bytes meet the word's first two, and each byte's table says what it becomes after the
/// bytes that follow it. One load per table, four shifts or masks, four XORs.
#[inline(always)]
fn crc_word(crc: u32, word: u32) -> u32 {
    let mixed = word ^ crc;
    CRC_AFTER_3[(mixed & 0xFF) as usize]
        ^ CRC_AFTER_2[(mixed >> 8 & 0xFF) as usize]
        ^ CRC_AFTER_1[(mixed >> 16 & 0xFF) as usize]
        ^ CRC_BYTE[(mixed >> 24) as usize]
}

/// The CRC state after one more byte.
#[inline(always)]
fn crc_byte(crc: u32, byte: u8) -> u32 {
    (crc >> 8) ^ CRC_BYTE[((crc ^ u32::from(byte)) & 0xFF) as usize]
}

/// The CRC as sent, from the state after the last byte (X.25 inverts it).
#[inline(always)]
fn crc_sent(crc: u32) -> u16 {
    !(crc as u16)
}

/// CRC-16/IBM-SDLC (polynomial 0x1021 reflected, initial value 0xFFFF, final XOR 0xFFFF: the
/// X.25 and HDLC CRC) of `bytes`, four bytes per step (slice-by-4).
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc = CRC_START;
    let mut words = bytes.chunks_exact(4);
    for word in &mut words {
        if let [a, b, c, d] = *word {
            crc = crc_word(crc, u32::from_le_bytes([a, b, c, d]));
        }
    }
    for &byte in words.remainder() {
        crc = crc_byte(crc, byte);
    }
    crc_sent(crc)
}

/// Why a message could not be framed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The message serialises to more than [`MAX_MESSAGE_BYTES`].
    MessageTooLarge,
    /// The output buffer is shorter than the frame (a buffer of [`MAX_FRAME_BYTES`] always fits).
    BufferTooSmall,
}

/// Frames `message` into `out`; returns the frame's length, its final zero byte included.
pub fn encode<T: Serialize>(message: &T, out: &mut [u8]) -> Result<usize, EncodeError> {
    // The body goes one byte in, where the stuffing leaves it (see `finish_with_zeros_in`).
    let room = out.len().saturating_sub(1).min(MAX_MESSAGE_BYTES);
    let length = match out.get_mut(1..1 + room).map(|body| postcard::to_slice(message, body)) {
        Some(Ok(body)) => body.len(),
        _ => return Err(too_large_or_no_room(message, room)),
    };
    finish(out, length)
}

/// Why a message did not serialise into `room` bytes: too large for any frame, or only for
/// this buffer (not on the device's path: its buffers hold [`MAX_FRAME_BYTES`]).
#[cold]
fn too_large_or_no_room<T: Serialize>(message: &T, room: usize) -> EncodeError {
    let mut scratch = [0u8; MAX_MESSAGE_BYTES];
    if room < MAX_MESSAGE_BYTES && postcard::to_slice(message, &mut scratch).is_ok() {
        EncodeError::BufferTooSmall
    } else {
        EncodeError::MessageTooLarge
    }
}

/// Completes the frame of the `length`-byte body at `out[1..=length]`: appends its CRC,
/// stuffs it in place and ends it with the zero byte; returns the frame's length.
pub(crate) fn finish(out: &mut [u8], length: usize) -> Result<usize, EncodeError> {
    finish_with_zeros_in(out, length, length)
}

/// [`finish`] for a body whose bytes after its first `may_hold_zeros` hold no zero byte (the
/// caller's promise: a state frame's channels, `CHANNEL_CODES`), which the stuffing then does
/// not look at.
///
/// The stuffing is COBS in place: each zero byte, and the placeholder `out[0]`, becomes the
/// distance to the next zero byte (or to the frame's end), written when the next is found
/// ([`CodeChain`]). That is the standard encoding (the `cobs` crate's, which the tests compare
/// with) of a body without a run of 254 non-zero bytes.
pub(crate) fn finish_with_zeros_in(
    out: &mut [u8],
    length: usize,
    may_hold_zeros: usize,
) -> Result<usize, EncodeError> {
    if length > MAX_MESSAGE_BYTES {
        return Err(EncodeError::MessageTooLarge);
    }
    // The delimiter's place: the stuffed frame is `frame[..end]`.
    let end = length + CRC_BYTES + 1;
    let frame = out.get_mut(..=end).ok_or(EncodeError::BufferTooSmall)?;
    let crc = crc16(frame.get(1..=length).unwrap_or(&[]));
    let crc_at = 1 + length;
    if let Some(slot) = frame.get_mut(crc_at..crc_at + CRC_BYTES) {
        slot.copy_from_slice(&crc.to_le_bytes());
    }
    let mut codes = CodeChain::START;
    // An exclusive range and a plain index: the inclusive range's iterator costs twice the
    // instructions per byte on the Cortex-M4F.
    for at in 1..1 + may_hold_zeros.min(length) {
        if frame.get(at) == Some(&0) {
            codes.zero_at(frame, at);
        }
    }
    for (at, byte) in (crc_at..).zip(crc.to_le_bytes()) {
        if byte == 0 {
            codes.zero_at(frame, at);
        }
    }
    codes.zero_at(frame, end);
    if let Some(delimiter) = frame.get_mut(end) {
        *delimiter = 0;
    }
    Ok(end + 1)
}

/// The stuffing's chain of codes, built forwards: where the last code goes (the placeholder,
/// then each zero byte in turn).
struct CodeChain {
    previous_zero: usize,
}

impl CodeChain {
    const START: Self = Self { previous_zero: 0 };

    /// A zero byte (or the frame's end) at `zero`: the code at the previous zero is the
    /// distance to it (below 254: the frame is shorter than a block).
    #[inline(always)]
    fn zero_at(&mut self, frame: &mut [u8], zero: usize) {
        if let Some(code) = frame.get_mut(self.previous_zero) {
            *code = zero.wrapping_sub(self.previous_zero) as u8;
        }
        self.previous_zero = zero;
    }
}

/// What the receiver has seen, by outcome; every count saturates instead of wrapping.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct LinkCounters {
    /// Frames decoded into a message.
    pub frames: u32,
    /// Frames longer than [`MAX_FRAME_BYTES`] (dropped up to the next zero byte).
    pub oversized: u32,
    /// Frames whose byte stuffing is invalid or that are too short to hold a CRC.
    pub bad_stuffing: u32,
    /// Frames whose CRC does not match.
    pub bad_crc: u32,
    /// Frames with a correct CRC that are not a complete message of this protocol version
    /// (unknown message kind, truncated fields, bytes left over).
    pub not_a_message: u32,
}

impl LinkCounters {
    /// Frames dropped for any reason.
    pub fn dropped(&self) -> u32 {
        self.oversized
            .saturating_add(self.bad_stuffing)
            .saturating_add(self.bad_crc)
            .saturating_add(self.not_a_message)
    }
}

/// Receives frames one byte at a time.
///
/// [`FrameDecoder::push`] stores a byte in constant time; at a zero byte it undoes the stuffing
/// of the frame it closes, checks its CRC and deserialises it, in time bounded by
/// [`MAX_FRAME_BYTES`]. Nothing allocates and nothing panics, whatever the bytes.
#[derive(Clone, Debug)]
pub struct FrameDecoder {
    /// The frame's bytes as received; at its zero byte, unstuffed in place (`unstuff`).
    buffer: [u8; MAX_FRAME_BYTES],
    /// Bytes of this frame received so far; more than [`MAX_FRAME_BYTES`]: oversized.
    received: usize,
    counters: LinkCounters,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// A decoder waiting for the first frame.
    pub const fn new() -> Self {
        Self { buffer: [0; MAX_FRAME_BYTES], received: 0, counters: zero_counters() }
    }

    /// What has been received so far.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Takes one received byte; returns the message a zero byte completes, if the frame it
    /// closes is valid. An empty frame (two zero bytes in a row) is ignored, not counted.
    #[inline]
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<T> {
        self.push_frame(byte)?.decode()
    }

    /// Takes one received byte; returns the frame a zero byte completes if its stuffing and
    /// CRC are valid, for the caller to decode ([`Received`]). Oversized, badly stuffed and
    /// corrupt frames are counted here; the caller's decoding counts the rest.
    #[inline]
    pub fn push_frame(&mut self, byte: u8) -> Option<Received<'_>> {
        if byte != 0 {
            self.store(byte);
            return None;
        }
        self.close()
    }

    /// The end of a frame (a zero byte): its checks, out of line so that the per-byte path
    /// above stays a few instructions inside the caller's loop.
    #[inline(never)]
    fn close(&mut self) -> Option<Received<'_>> {
        let received = self.received;
        self.received = 0;
        if received > MAX_FRAME_BYTES {
            bump(&mut self.counters.oversized);
            return None;
        }
        if received == 0 {
            return None;
        }
        // A block that claims more bytes than arrived, or no room for a CRC and a body (the
        // first byte is the first block's code).
        let body_length =
            match received.checked_sub(1 + CRC_BYTES).filter(|&n| n > 0 && self.unstuff(received)) {
                Some(length) => length,
                None => {
                    bump(&mut self.counters.bad_stuffing);
                    return None;
                }
            };
        let (body, crc) = self.buffer.get(1..received)?.split_at(body_length);
        if crc != crc16(body).to_le_bytes().as_slice() {
            bump(&mut self.counters.bad_crc);
            return None;
        }
        Some(Received { body, counters: &mut self.counters })
    }

    /// One non-zero byte of a frame, stored where it arrives: the per-byte work is a store
    /// (the stuffing is undone once per frame, `unstuff`, per block rather than per byte).
    #[inline]
    fn store(&mut self, byte: u8) {
        let at = self.received;
        match self.buffer.get_mut(at) {
            Some(slot) => {
                *slot = byte;
                self.received = at + 1;
            }
            // Oversized: dropped at its zero byte (`received` stops just past the limit).
            None => self.received = MAX_FRAME_BYTES + 1,
        }
    }

    /// Undoes the COBS stuffing of the `received` bytes in `buffer`, in place: whether it is
    /// valid. A block of code `c` holds `c − 1` data bytes and, unless it is the frame's last,
    /// is followed by a zero byte, which the next block's code stands in for; so the unstuffed
    /// frame is the received one after its first byte, with every later code byte a zero, and
    /// the stuffing is valid if the chain of codes ends exactly at the frame's end. One step
    /// per block. (A code of 0xFF, 254 data bytes and no zero after them, never fits a frame
    /// here: such a frame is oversized or ends inside its block, and is refused as the `cobs`
    /// crate's `decode_in_place` would; the tests compare the two.)
    fn unstuff(&mut self, received: usize) -> bool {
        let mut at = 0;
        loop {
            let code = match self.buffer.get_mut(at) {
                // The code byte becomes the zero it stands for (the first is not part of the
                // frame's body).
                Some(code) => usize::from(core::mem::replace(code, 0)),
                None => return false,
            };
            // Not zero: zero bytes end the frame before they are stored.
            let next = at + code;
            if next >= received {
                return next == received;
            }
            at = next;
        }
    }
}

/// A frame whose stuffing and CRC are valid ([`FrameDecoder::push_frame`]): its body, the
/// serialised message, not yet decoded. Decoding it counts it, as a frame or as not a message
/// ([`Received::reject`] as the latter; one dropped unread is not counted).
#[derive(Debug)]
pub struct Received<'a> {
    body: &'a [u8],
    counters: &'a mut LinkCounters,
}

impl<'a> Received<'a> {
    /// The serialised message.
    pub fn body(&self) -> &'a [u8] {
        self.body
    }

    /// The body as one complete `T`, with no byte left over.
    pub fn decode<T: Deserialize<'a>>(self) -> Option<T> {
        let message = exactly(self.body);
        self.count(message)
    }

    /// The body after its first byte (a host message's kind) as one complete `T`, with no
    /// byte left over: the fields of the host message variant the first byte names (its kind,
    /// [`Self::host_kind`]), decoded without building the whole message.
    pub fn payload<T: Deserialize<'a>>(self) -> Option<T> {
        let message = self.body.get(1..).and_then(exactly);
        self.count(message)
    }

    /// Counts the frame as not a message (e.g. a kind the caller does not know).
    pub fn reject(self) {
        bump(&mut self.counters.not_a_message);
    }

    fn count<T>(self, message: Option<T>) -> Option<T> {
        bump(if message.is_some() { &mut self.counters.frames } else { &mut self.counters.not_a_message });
        message
    }
}

/// `bytes` as one complete `T`, with no byte left over.
fn exactly<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Option<T> {
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((message, [])) => Some(message),
        _ => None,
    }
}

const fn zero_counters() -> LinkCounters {
    LinkCounters { frames: 0, oversized: 0, bad_stuffing: 0, bad_crc: 0, not_a_message: 0 }
}

fn bump(count: &mut u32) {
    *count = count.saturating_add(1);
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    use super::{crc16, finish, FrameDecoder, CRC_BYTES, MAX_MESSAGE_BYTES};
    use proptest::prelude::*;

    /// What the decoder holds after the non-zero bytes of `frame` and their unstuffing: the
    /// unstuffed bytes, if the stuffing is valid, as `FrameDecoder` sees it at a zero byte.
    fn unstuffed(frame: &[u8]) -> Option<Vec<u8>> {
        let mut decoder = FrameDecoder::new();
        for &byte in frame {
            decoder.store(byte);
        }
        let received = decoder.received;
        (!frame.is_empty() && decoder.unstuff(received)).then(|| decoder.buffer[1..received].to_vec())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4096))]
        /// The decoder's unstuffing (bytes stored as they arrive, undone block by block at the
        /// frame's zero byte) decodes exactly as the `cobs` crate's
        /// `decode_in_place` on every frame without zero bytes that fits the decoder (what
        /// `FrameDecoder` collects): same bytes, or both refuse.
        #[test]
        fn unstuffing_is_the_cobs_crates_decoding(
            frame in proptest::collection::vec(1u8..=255, 0..124),
            small in proptest::collection::vec(1u8..=4, 0..12),
        ) {
            for input in [frame, small] {
                let mut theirs = input.clone();
                let expected = cobs::decode_in_place(&mut theirs).ok().map(|n| theirs[..n].to_vec());
                prop_assert_eq!(unstuffed(&input), expected, "{:?}", input);
            }
        }

        /// The slice-by-4 CRC is the `crc` crate's CRC-16/IBM-SDLC for every length.
        #[test]
        fn crc16_is_crc_16_ibm_sdlc(bytes in proptest::collection::vec(any::<u8>(), 0..130)) {
            let reference = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&bytes);
            prop_assert_eq!(crc16(&bytes), reference);
        }

        /// Framing in place gives the `cobs` crate's encoding of the body followed by the
        /// `crc` crate's CRC, and the zero byte, for every body that fits a frame; bodies of
        /// small bytes hold many zeros.
        #[test]
        fn framing_is_the_cobs_crates_encoding_of_body_and_crc(
            body in proptest::collection::vec(any::<u8>(), 0..=MAX_MESSAGE_BYTES),
            small in proptest::collection::vec(0u8..=2, 0..40),
        ) {
            for body in [body, small] {
                let crc = crc::Crc::<u16>::new(&crc::CRC_16_IBM_SDLC).checksum(&body);
                let mut checked = body.clone();
                checked.extend_from_slice(&crc.to_le_bytes());
                let mut expected = vec![0u8; cobs::max_encoding_length(checked.len())];
                let n = cobs::encode(&checked, &mut expected);
                expected.truncate(n);
                expected.push(0);
                let mut ours = vec![0xAAu8; body.len() + CRC_BYTES + 2];
                ours[1..=body.len()].copy_from_slice(&body);
                prop_assert_eq!(finish(&mut ours, body.len()), Ok(expected.len()));
                prop_assert_eq!(ours, expected);
            }
        }
    }

    /// The check value of the catalogue (CRC-16/IBM-SDLC of "123456789" is 0x906E).
    #[test]
    fn crc16_check_value() {
        assert_eq!(crc16(b"123456789"), 0x906E);
    }

    /// Every valid stuffing of every body is decoded back (the encoder's inverse).
    #[test]
    fn unstuffing_inverts_the_encoder() {
        for length in 1..122usize {
            let body: Vec<u8> = (0..length).map(|k| (k * 7 % 5) as u8).collect();
            let mut stuffed = vec![0u8; cobs::max_encoding_length(length)];
            let n = cobs::encode(&body, &mut stuffed);
            stuffed.truncate(n);
            assert_eq!(unstuffed(&stuffed), Some(body), "length {length}");
        }
    }
}
