//! Framing: `COBS(postcard(message) ‖ crc16_le) 0x00`.
//!
//! COBS (consistent overhead byte stuffing) removes every zero byte from the frame's body, at a
//! cost of one byte per 254, so the zero byte delimits frames and a receiver that starts in
//! the middle of a stream, or loses bytes, is back in step at the next zero. The CRC
//! (CRC-16/IBM-3740: polynomial 0x1021, initial value 0xFFFF) detects every error of up to
//! three bits and every burst up to 16 bits in frames of this size; postcard then accepts
//! only a complete message of this protocol version, with no bytes left over.

use crc::{Crc, CRC_16_IBM_3740};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// The largest serialised message (before the CRC and the stuffing).
pub const MAX_MESSAGE_BYTES: usize = 120;

/// The largest frame on the wire, delimiter included.
pub const MAX_FRAME_BYTES: usize = cobs::max_encoding_length(MAX_MESSAGE_BYTES + CRC_BYTES) + 1;

const CRC_BYTES: usize = 2;
// A `static`, not a `const`: a `const` would build its 512-byte table at every use.
static FRAME_CRC: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

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
    let mut body = [0u8; MAX_MESSAGE_BYTES + CRC_BYTES];
    let length = postcard::to_slice(message, &mut body[..MAX_MESSAGE_BYTES])
        .map_err(|_| EncodeError::MessageTooLarge)?
        .len();
    // `get`, not indexing: postcard returns a prefix of the 120 bytes it was given, but the
    // optimiser cannot see that, and an index would leave a panic path in the device's link.
    let crc = FRAME_CRC.checksum(body.get(..length).ok_or(EncodeError::MessageTooLarge)?).to_le_bytes();
    for (k, byte) in crc.into_iter().enumerate() {
        *body.get_mut(length + k).ok_or(EncodeError::MessageTooLarge)? = byte;
    }
    let framed = body.get(..length + CRC_BYTES).ok_or(EncodeError::MessageTooLarge)?;
    let stuffed = cobs::try_encode(framed, out).map_err(|_| EncodeError::BufferTooSmall)?;
    let delimiter = out.get_mut(stuffed).ok_or(EncodeError::BufferTooSmall)?;
    *delimiter = 0;
    Ok(stuffed + 1)
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
/// [`FrameDecoder::push`] stores a byte in constant time; at a zero byte it decodes the frame
/// it closes, in time bounded by [`MAX_FRAME_BYTES`]. Nothing allocates and nothing panics,
/// whatever the bytes.
#[derive(Clone, Debug)]
pub struct FrameDecoder {
    buffer: [u8; MAX_FRAME_BYTES],
    length: usize,
    overflowed: bool,
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
        Self { buffer: [0; MAX_FRAME_BYTES], length: 0, overflowed: false, counters: zero_counters() }
    }

    /// What has been received so far.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Takes one received byte; returns the message a zero byte completes, if the frame it
    /// closes is valid. An empty frame (two zero bytes in a row) is ignored, not counted.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<T> {
        if byte != 0 {
            match self.buffer.get_mut(self.length) {
                Some(slot) if !self.overflowed => {
                    *slot = byte;
                    self.length += 1;
                }
                _ => self.overflowed = true,
            }
            return None;
        }
        let (length, overflowed) = (self.length, self.overflowed);
        self.length = 0;
        self.overflowed = false;
        if overflowed {
            bump(&mut self.counters.oversized);
            return None;
        }
        if length == 0 {
            return None;
        }
        let message = self.decode(length);
        if message.is_some() {
            bump(&mut self.counters.frames);
        }
        message
    }

    fn decode<T: DeserializeOwned>(&mut self, length: usize) -> Option<T> {
        let stuffed = self.buffer.get_mut(..length)?;
        let Some(unstuffed) = unstuff(stuffed) else {
            bump(&mut self.counters.bad_stuffing);
            return None;
        };
        let Some(body_length) = unstuffed.checked_sub(CRC_BYTES).filter(|&n| n > 0) else {
            bump(&mut self.counters.bad_stuffing);
            return None;
        };
        let body = self.buffer.get(..body_length)?;
        let crc = self.buffer.get(body_length..unstuffed)?;
        if crc != FRAME_CRC.checksum(body).to_le_bytes().as_slice() {
            bump(&mut self.counters.bad_crc);
            return None;
        }
        match postcard::take_from_bytes::<T>(body) {
            Ok((message, [])) => Some(message),
            _ => {
                bump(&mut self.counters.not_a_message);
                None
            }
        }
    }
}

/// COBS decoding in place: the decoded length, or `None` if the stuffing is invalid. The rules
/// of the `cobs` crate's `decode_in_place` (which the tests' encoder is the inverse of) for a
/// frame without zero bytes, as `FrameDecoder` collects them, in time linear in its length and
/// without an index that could panic: that function's indexing leaves a panic path the
/// optimiser cannot remove from the device's link (`scripts/firmware.sh --only pil` checks).
fn unstuff(frame: &mut [u8]) -> Option<usize> {
    let end = frame.len();
    if end == 0 {
        return None;
    }
    let (mut read, mut write) = (0usize, 0usize);
    while read < end {
        let code = usize::from(*frame.get(read)?);
        if code == 0 || (read + code > end && code != 1) {
            return None;
        }
        read += 1;
        for _ in 1..code {
            let byte = *frame.get(read)?;
            *frame.get_mut(write)? = byte;
            read += 1;
            write += 1;
        }
        if code != 0xFF && read < end {
            *frame.get_mut(write)? = 0;
            write += 1;
        }
    }
    Some(write)
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

    use super::unstuff;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4096))]
        /// `unstuff` decodes exactly as the `cobs` crate's `decode_in_place` on every frame
        /// without zero bytes (what `FrameDecoder` collects): same length and bytes, or both
        /// refuse.
        #[test]
        fn unstuff_is_the_cobs_crates_decoding(
            frame in proptest::collection::vec(1u8..=255, 0..130),
            small in proptest::collection::vec(1u8..=4, 0..12),
        ) {
            for input in [frame, small] {
                let mut ours = input.clone();
                let mut theirs = input.clone();
                let expected = cobs::decode_in_place(&mut theirs).ok();
                let got = unstuff(&mut ours);
                prop_assert_eq!(got, expected, "{:?}", input);
                if let Some(n) = got {
                    prop_assert_eq!(&ours[..n], &theirs[..n]);
                }
            }
        }
    }

    /// Every valid stuffing of every body is decoded back (the encoder's inverse).
    #[test]
    fn unstuff_inverts_the_encoder() {
        for length in 1..300usize {
            let body: Vec<u8> = (0..length).map(|k| (k * 7 % 5) as u8).collect();
            let mut stuffed = vec![0u8; cobs::max_encoding_length(length)];
            let n = cobs::encode(&body, &mut stuffed);
            stuffed.truncate(n);
            let decoded = unstuff(&mut stuffed);
            assert_eq!(decoded, Some(length), "length {length}");
            assert_eq!(&stuffed[..length], &body[..]);
        }
    }
}
