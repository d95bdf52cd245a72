//! Bit-level writer and reader: MSB-first bit fields, LEB128-style varints, strings.
//!
//! Bits are packed most significant first: the first bit written is bit 7 of byte 0.
//! The last byte is padded with zero bits; [`BitReader::finish`] insists on that padding
//! and on nothing after it, so every message has exactly one valid length.

use crate::{DecodeError, MAX_ELEMENTS};

/// Appends bit fields to a byte vector.
#[derive(Debug, Default)]
pub(crate) struct BitWriter {
    /// Whole bytes written.
    bytes: Vec<u8>,
    /// Bits not yet making a whole byte, in the low `pending` bits.
    acc: u64,
    /// How many (fewer than 8 between calls).
    pending: u32,
}

impl BitWriter {
    /// An empty writer (room for a typical message).
    pub fn new() -> Self {
        BitWriter {
            bytes: Vec::with_capacity(64),
            ..Self::default()
        }
    }

    /// Writes the low `n` bits of `value` (`n <= 64`), most significant first.
    pub fn bits(&mut self, value: u64, n: u32) {
        debug_assert!(
            n <= 64 && (n == 64 || value >> n == 0),
            "{value} in {n} bits"
        );
        if n > 32 {
            self.bits(value >> 32, n - 32);
            self.bits(value & 0xffff_ffff, 32);
            return;
        }
        // At most 7 + 32 bits pending: they fit.
        self.acc = (self.acc << n) | value;
        self.pending += n;
        while self.pending >= 8 {
            self.pending -= 8;
            self.bytes.push((self.acc >> self.pending) as u8);
        }
        self.acc &= (1u64 << self.pending) - 1;
    }

    /// Writes one bit.
    pub fn bit(&mut self, b: bool) {
        self.bits(u64::from(b), 1);
    }

    /// Writes an unsigned varint: 7-bit groups, least significant group first, each
    /// preceded by a continuation bit (1 = another group follows).
    pub fn uvar(&mut self, mut v: u64) {
        loop {
            let group = v & 0x7f;
            v >>= 7;
            self.bits(u64::from(v != 0) << 7 | group, 8);
            if v == 0 {
                return;
            }
        }
    }

    /// Writes a signed varint (zigzag, then [`BitWriter::uvar`]).
    pub fn ivar(&mut self, v: i64) {
        self.uvar(zigzag(v));
    }

    /// Writes raw bytes (8 bits each).
    pub fn bytes(&mut self, bytes: &[u8]) {
        if self.pending == 0 {
            self.bytes.extend_from_slice(bytes);
        } else {
            bytes.iter().for_each(|&b| self.bits(u64::from(b), 8));
        }
    }

    /// Writes a length-prefixed UTF-8 string (varint byte length, then the bytes).
    pub fn str(&mut self, s: &str) {
        self.uvar(s.len() as u64);
        self.bytes(s.as_bytes());
    }

    /// Bits written so far.
    #[cfg(test)]
    pub fn len_bits(&self) -> u64 {
        self.bytes.len() as u64 * 8 + u64::from(self.pending)
    }

    /// Bytes written so far (the last one possibly partial).
    pub fn len_bytes(&self) -> usize {
        self.bytes.len() + usize::from(self.pending > 0)
    }

    /// The bytes, last one zero-padded.
    pub fn finish(mut self) -> Vec<u8> {
        if self.pending > 0 {
            self.bytes.push((self.acc << (8 - self.pending)) as u8);
        }
        self.bytes
    }
}

/// Reads bit fields from a byte slice; every read past the end is [`DecodeError::Truncated`].
#[derive(Debug)]
pub(crate) struct BitReader<'a> {
    bytes: &'a [u8],
    pos: u64,
    /// Vector elements this message may still decode (see [`MAX_ELEMENTS`]).
    elements: usize,
    /// The last (up to) eight bytes again, then zeros: a field in the last eight bytes
    /// is read from here with one load, like any other (short messages are all tail).
    tail: [u8; 16],
    /// Where `tail` starts in `bytes`.
    tail_start: usize,
}

impl<'a> BitReader<'a> {
    /// A reader at the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        let tail_start = bytes.len().saturating_sub(8);
        let mut tail = [0u8; 16];
        tail[..bytes.len() - tail_start].copy_from_slice(&bytes[tail_start..]);
        BitReader {
            bytes,
            pos: 0,
            elements: MAX_ELEMENTS,
            tail,
            tail_start,
        }
    }

    /// Takes `n` vector elements from the message's budget, so that zero-bit elements
    /// cannot make a small message allocate without bound.
    pub fn spend_elements(&mut self, n: usize) -> Result<(), DecodeError> {
        self.elements = self.elements.checked_sub(n).ok_or(DecodeError::TooLarge {
            what: "vector elements in the message",
            len: (MAX_ELEMENTS - self.elements + n) as u64,
            max: MAX_ELEMENTS as u64,
        })?;
        Ok(())
    }

    /// Bits not read yet.
    pub fn remaining(&self) -> u64 {
        self.bytes.len() as u64 * 8 - self.pos
    }

    /// The next 64 bits from the current position, most significant first (zero past
    /// the end), and how many of them are the message's (at least 57 while that many
    /// remain). One load: past `len - 8`, the eight bytes come from the padded tail
    /// (`at` is below the length, so `at - tail_start` is below 8).
    fn peek(&self) -> (u64, u64) {
        let at = (self.pos / 8) as usize;
        let offset = (self.pos % 8) as u32;
        let eight = match self.bytes.get(at..at + 8) {
            Some(eight) => eight,
            None if at < self.bytes.len() => {
                &self.tail[at - self.tail_start..at - self.tail_start + 8]
            }
            None => return (0, 0),
        };
        let mut word = [0u8; 8];
        word.copy_from_slice(eight);
        let valid = self.remaining().min(u64::from(64 - offset));
        (u64::from_be_bytes(word) << offset, valid)
    }

    /// Reads `n <= 64` bits, most significant first.
    pub fn bits(&mut self, n: u32) -> Result<u64, DecodeError> {
        debug_assert!(n <= 64);
        if u64::from(n) > self.remaining() {
            return Err(DecodeError::Truncated);
        }
        if n > 0 && n + (self.pos % 8) as u32 <= 64 {
            // The field lies in the next eight bytes (zero past the end, which the
            // length check above keeps out of the field): one load, two shifts.
            let (word, _) = self.peek();
            self.pos += u64::from(n);
            return Ok(word >> (64 - n));
        }
        let mut value = 0u64;
        let mut left = n;
        while left > 0 {
            let byte = self.bytes[(self.pos / 8) as usize];
            let offset = (self.pos % 8) as u32;
            let take = (8 - offset).min(left);
            let chunk = (u64::from(byte) >> (8 - offset - take)) & ((1u64 << take) - 1);
            value = (value << take) | chunk;
            left -= take;
            self.pos += u64::from(take);
        }
        Ok(value)
    }

    /// Reads one bit.
    pub fn bit(&mut self) -> Result<bool, DecodeError> {
        let byte = self
            .bytes
            .get((self.pos / 8) as usize)
            .ok_or(DecodeError::Truncated)?;
        let bit = byte >> (7 - self.pos % 8) & 1;
        self.pos += 1;
        Ok(bit == 1)
    }

    /// Reads an unsigned varint written by [`BitWriter::uvar`].
    pub fn uvar(&mut self) -> Result<u64, DecodeError> {
        // Seven groups at most lie in the next 64 bits: find the last (the first 8-bit
        // field whose continuation bit is clear) and gather them in one go.
        let (word, valid) = self.peek();
        let last = !word & 0x8080_8080_8080_8080;
        let groups = last.leading_zeros() / 8 + 1;
        if last != 0 && groups <= 7 && u64::from(groups) * 8 <= valid {
            let mut value = 0u64;
            for k in 0..groups {
                value |= (word >> (56 - 8 * k) & 0x7f) << (7 * k);
            }
            self.pos += u64::from(groups) * 8;
            return Ok(value);
        }
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            // The continuation bit and its group, as written: one 8-bit field.
            let byte = self.bits(8)?;
            let (more, group) = (byte >> 7 == 1, byte & 0x7f);
            if shift == 63 && (group > 1 || more) {
                return Err(DecodeError::BadValue("varint overflows 64 bits"));
            }
            value |= group << shift;
            if !more {
                return Ok(value);
            }
        }
        Err(DecodeError::BadValue("varint overflows 64 bits"))
    }

    /// Reads a signed varint written by [`BitWriter::ivar`].
    pub fn ivar(&mut self) -> Result<i64, DecodeError> {
        Ok(unzigzag(self.uvar()?))
    }

    /// Reads a count (a varint) that must not exceed `max`.
    pub fn count(&mut self, what: &'static str, max: usize) -> Result<usize, DecodeError> {
        let n = self.uvar()?;
        if n > max as u64 {
            return Err(DecodeError::TooLarge {
                what,
                len: n,
                max: max as u64,
            });
        }
        Ok(n as usize)
    }

    /// Reads a length-prefixed UTF-8 string of at most `max` bytes. Nothing is
    /// allocated before the input is known to hold the whole string.
    pub fn str(&mut self, what: &'static str, max: usize) -> Result<String, DecodeError> {
        let len = self.count(what, max)?;
        if len as u64 * 8 > self.remaining() {
            return Err(DecodeError::Truncated);
        }
        let mut bytes = Vec::with_capacity(len);
        for _ in 0..len {
            bytes.push(self.bits(8)? as u8);
        }
        String::from_utf8(bytes).map_err(|_| DecodeError::BadValue("string is not UTF-8"))
    }

    /// Ends reading: only zero padding bits (fewer than 8) may remain.
    pub fn finish(mut self) -> Result<(), DecodeError> {
        let left = self.remaining();
        if left >= 8 || self.bits(left as u32)? != 0 {
            return Err(DecodeError::Trailing(left));
        }
        Ok(())
    }
}

/// Maps signed to unsigned so that small magnitudes give small numbers: 0, -1, 1, -2 → 0, 1, 2, 3.
pub(crate) fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// Inverse of [`zigzag`].
pub(crate) fn unzigzag(u: u64) -> i64 {
    ((u >> 1) as i64) ^ -((u & 1) as i64)
}

/// Bits needed to write every number in `0..=max`.
pub(crate) fn width(max: u64) -> u32 {
    64 - max.leading_zeros()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_pack_msb_first_across_bytes() {
        let mut w = BitWriter::new();
        w.bits(0b101, 3);
        w.bits(0x1ff, 9);
        w.bit(true);
        assert_eq!(w.len_bits(), 13);
        let bytes = w.finish();
        assert_eq!(bytes, vec![0b1011_1111, 0b1111_1000]);
        let mut r = BitReader::new(&bytes);
        assert_eq!(r.bits(3).unwrap(), 0b101);
        assert_eq!(r.bits(9).unwrap(), 0x1ff);
        assert!(r.bit().unwrap());
        r.finish().unwrap();
    }

    #[test]
    fn sixty_four_bit_fields_roundtrip_unaligned() {
        let mut w = BitWriter::new();
        w.bit(true);
        w.bits(u64::MAX - 5, 64);
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        assert!(r.bit().unwrap());
        assert_eq!(r.bits(64).unwrap(), u64::MAX - 5);
    }

    #[test]
    fn varints_roundtrip_and_overflow_is_rejected() {
        for v in [0, 1, 127, 128, 300, u64::from(u32::MAX), u64::MAX] {
            let mut w = BitWriter::new();
            w.uvar(v);
            w.ivar(-(v as i64 / 3));
            let bytes = w.finish();
            let mut r = BitReader::new(&bytes);
            assert_eq!(r.uvar().unwrap(), v);
            assert_eq!(r.ivar().unwrap(), -(v as i64 / 3));
        }
        // Eleven groups: more than 64 bits (the one-load path leaves it to the loop).
        let too_long = [0xff; 11];
        assert!(matches!(
            BitReader::new(&too_long).uvar(),
            Err(DecodeError::BadValue(_))
        ));
    }

    /// A varint of every length, at every bit offset, followed by something or by
    /// nothing: read back exactly, and a message cut anywhere inside it is truncated.
    #[test]
    fn varints_of_every_length_at_every_offset() {
        let values = (0..64).flat_map(|b| {
            let p = 1u64 << b;
            [p - 1, p, p | 1]
        });
        for v in values.chain([u64::MAX]) {
            for offset in 0..8 {
                for trailer in [None, Some(0x2a_u64)] {
                    let mut w = BitWriter::new();
                    w.bits(0b101_0101 >> (7 - offset), offset);
                    w.uvar(v);
                    if let Some(t) = trailer {
                        w.bits(t, 7);
                    }
                    let varint_bits =
                        (w.len_bits() - u64::from(offset)) as usize - trailer.map_or(0, |_| 7);
                    let bytes = w.finish();
                    let mut r = BitReader::new(&bytes);
                    r.bits(offset).unwrap();
                    assert_eq!(r.uvar(), Ok(v), "{v} at offset {offset}");
                    if let Some(t) = trailer {
                        assert_eq!(r.bits(7), Ok(t));
                    }
                    // Cut before the varint's last byte ends: never a value.
                    let last_byte = (offset as usize + varint_bits).div_ceil(8);
                    for len in 0..last_byte {
                        let mut r = BitReader::new(&bytes[..len]);
                        if r.bits(offset).is_ok() {
                            assert_eq!(r.uvar(), Err(DecodeError::Truncated), "{v} cut at {len}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn reading_past_the_end_is_truncated() {
        let mut r = BitReader::new(&[0xff]);
        assert_eq!(r.bits(9), Err(DecodeError::Truncated));
        let mut r = BitReader::new(&[0x05, b'a']);
        assert_eq!(r.str("name", 10), Err(DecodeError::Truncated));
    }

    #[test]
    fn strings_check_length_and_utf8() {
        let mut w = BitWriter::new();
        w.bit(false);
        w.str("héllo");
        let bytes = w.finish();
        let mut r = BitReader::new(&bytes);
        r.bit().unwrap();
        assert_eq!(r.str("name", 16).unwrap(), "héllo");
        let mut r = BitReader::new(&bytes);
        r.bit().unwrap();
        assert!(matches!(
            r.str("name", 3),
            Err(DecodeError::TooLarge { .. })
        ));
        assert!(matches!(
            BitReader::new(&[0x01, 0xff]).str("name", 4),
            Err(DecodeError::BadValue(_))
        ));
    }

    #[test]
    fn padding_must_be_zero_and_nothing_may_follow() {
        let mut r = BitReader::new(&[0b1000_0001]);
        r.bit().unwrap();
        assert_eq!(r.finish(), Err(DecodeError::Trailing(7)));
        let mut r = BitReader::new(&[0x80, 0x00]);
        r.bit().unwrap();
        assert_eq!(r.finish(), Err(DecodeError::Trailing(15)));
    }

    #[test]
    fn zigzag_and_width() {
        assert_eq!(
            [0, -1, 1, -2].map(zigzag),
            [0, 1, 2, 3],
            "small magnitudes stay small"
        );
        assert_eq!(unzigzag(zigzag(i64::MIN)), i64::MIN);
        assert_eq!([0, 1, 2, 3, 255, 256].map(width), [0, 1, 2, 2, 8, 9]);
    }
}
