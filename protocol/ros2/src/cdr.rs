//! CDR as ROS 2 puts it on the wire: XCDR1 ("plain CDR"), little-endian,
//! behind the 4-byte encapsulation header `00 01 00 00` (CDR_LE, no
//! options), which is what rmw_zenoh's Fast CDR writes and what `ros2 bag`
//! stores.
//!
//! Why by hand: the layout is small and fully specified (OMG DDS-XTypes 1.3,
//! §7.4.1 "plain CDR"), and the one rule that others get wrong is written once
//! here: each primitive is aligned to its own size (up to 8), counted from the
//! first byte *after* the encapsulation header. A string is a `u32` length
//! that counts its NUL, the bytes, then the NUL; a sequence is a `u32` count,
//! then its elements; a struct is its fields in order, with no alignment or
//! padding of its own and none at the end of the message.

use thiserror::Error;

/// The encapsulation header of little-endian XCDR1 with no options.
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a CDR message could not be read.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum CdrError {
    /// The encapsulation header is not `00 01 00 00` (little-endian XCDR1).
    #[error("not little-endian plain CDR: encapsulation header {0:02x?}")]
    Encapsulation([u8; 4]),
    /// The message ends before the field at this offset (after the header).
    #[error("the message ends at {len} bytes, inside the field at offset {at}")]
    Truncated {
        /// Where the field starts, counted after the header.
        at: usize,
        /// How long the body is.
        len: usize,
    },
    /// A string without its terminating NUL or not UTF-8.
    #[error("the string at offset {0} is not NUL-terminated UTF-8")]
    BadString(usize),
    /// Bytes left over after the message.
    #[error("{0} bytes after the end of the message")]
    Trailing(usize),
}

/// Writes one CDR message: the header, then the fields in order.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A message with its encapsulation header written.
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(64);
        buf.extend_from_slice(&ENCAPSULATION_LE);
        Self { buf }
    }

    /// Pads with zeros so that the next byte's offset after the header is a
    /// multiple of `n`.
    fn align(&mut self, n: usize) {
        let at = self.buf.len() - ENCAPSULATION_LE.len();
        self.buf.resize(self.buf.len() + (n - at % n) % n, 0);
    }

    /// A `uint8`, `bool` (0 or 1) or `byte`.
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    /// A `bool`.
    pub fn bool(&mut self, v: bool) {
        self.u8(u8::from(v));
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `uint32` (also a sequence's count).
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `uint64`.
    pub fn u64(&mut self, v: u64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A sequence of `uint8`, `int8` or `byte`: its count, then the bytes.
    pub fn bytes(&mut self, v: &[u8]) {
        self.count(v.len());
        self.buf.extend_from_slice(v);
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string`: its length with the NUL, the bytes, the NUL.
    ///
    /// # Panics
    /// If the string is 4 GiB or longer (CDR cannot say its length).
    pub fn string(&mut self, s: &str) {
        let len = u32::try_from(s.len() + 1).expect("a CDR string is shorter than 4 GiB");
        self.u32(len);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// A sequence's element count.
    ///
    /// # Panics
    /// If `n` does not fit a `u32`.
    pub fn count(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a CDR sequence has fewer than 2^32 elements"));
    }

    /// The message, header included.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// Reads one CDR message written as [`CdrWriter`] writes it.
#[derive(Debug, Clone)]
pub struct CdrReader<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header; the reader then stands at the first field.
    pub fn new(message: &'a [u8]) -> Result<Self, CdrError> {
        let Some((head, body)) = message.split_first_chunk::<4>() else {
            return Err(CdrError::Truncated { at: 0, len: 0 });
        };
        if *head != ENCAPSULATION_LE {
            return Err(CdrError::Encapsulation(*head));
        }
        Ok(Self { body, at: 0 })
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let at = self.at.next_multiple_of(N.min(8));
        let bytes = self.body.get(at..at + N).ok_or(CdrError::Truncated { at, len: self.body.len() })?;
        self.at = at + N;
        Ok(bytes.try_into().expect("N bytes"))
    }

    /// A `uint8`.
    pub fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.take::<1>()?[0])
    }

    /// An `int32`.
    pub fn i32(&mut self) -> Result<i32, CdrError> {
        Ok(i32::from_le_bytes(self.take()?))
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.take()?))
    }

    /// A `float32`.
    pub fn f32(&mut self) -> Result<f32, CdrError> {
        Ok(f32::from_le_bytes(self.take()?))
    }

    /// A sequence of bytes (`uint8[]`, `int8[]`): its count, then the bytes.
    pub fn bytes(&mut self) -> Result<Vec<u8>, CdrError> {
        let len = self.u32()? as usize;
        let at = self.at;
        let bytes = at
            .checked_add(len)
            .and_then(|end| self.body.get(at..end))
            .ok_or(CdrError::Truncated { at, len: self.body.len() })?;
        self.at = at + len;
        Ok(bytes.to_vec())
    }

    /// A `float64`.
    pub fn f64(&mut self) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.take()?))
    }

    /// A `string`.
    pub fn string(&mut self) -> Result<String, CdrError> {
        let len = self.u32()? as usize;
        let at = self.at;
        let bytes = at
            .checked_add(len)
            .and_then(|end| self.body.get(at..end))
            .ok_or(CdrError::Truncated { at, len: self.body.len() })?;
        let (nul, text) = bytes.split_last().ok_or(CdrError::BadString(at))?;
        if *nul != 0 {
            return Err(CdrError::BadString(at));
        }
        let text = std::str::from_utf8(text).map_err(|_| CdrError::BadString(at))?;
        self.at = at + len;
        Ok(text.to_owned())
    }

    /// The end of the message: nothing may be left.
    pub fn finish(self) -> Result<(), CdrError> {
        match self.body.len() - self.at {
            0 => Ok(()),
            n => Err(CdrError::Trailing(n)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_counts_from_after_the_header() {
        let mut w = CdrWriter::new();
        w.u8(7);
        w.f64(1.0);
        let bytes = w.finish();
        // 4 header bytes, the u8 at body offset 0, 7 padding bytes, the f64 at body offset 8.
        assert_eq!(bytes.len(), 4 + 16);
        assert_eq!(&bytes[4..12], &[7, 0, 0, 0, 0, 0, 0, 0]);
        let mut r = CdrReader::new(&bytes).expect("header");
        assert_eq!((r.u8(), r.f64()), (Ok(7), Ok(1.0)));
        assert_eq!(r.finish(), Ok(()));
    }

    #[test]
    fn a_reader_refuses_what_is_not_one_whole_le_message() {
        assert_eq!(CdrReader::new(&[0, 0, 0, 0]).err(), Some(CdrError::Encapsulation([0, 0, 0, 0])));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 5, 0, 0, 0, b'a', 0]).expect("header");
        assert_eq!(r.string(), Err(CdrError::Truncated { at: 4, len: 6 }));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).expect("header");
        assert_eq!(r.string(), Err(CdrError::BadString(4)));
        let r = CdrReader::new(&[0, 1, 0, 0, 1]).expect("header");
        assert_eq!(r.finish(), Err(CdrError::Trailing(1)));
    }
}
