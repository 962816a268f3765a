//! Bounds-checked little-endian reading and writing of NatNet primitives.
//!
//! Why hand-written rather than a (de)serialisation crate: NatNet is a
//! C-struct stream whose layout depends on the negotiated version (fields
//! appear from 2.6, 3.0, 4.1 on), with NUL-terminated strings, fixed
//! 256-byte names and split arrays (all marker offsets, then all labels,
//! then all names). `binrw`/`scroll` would need as much annotation as this
//! file has code. Every read checks the remaining length first and returns
//! [`Error::Truncated`]; nothing here can panic on garbage.

use super::Error;

/// Reads NatNet primitives from a byte slice, never past its end.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }

    /// Bytes not yet read.
    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub(crate) fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], Error> {
        if self.remaining() < n {
            return Err(Error::Truncated { what, at: self.pos });
        }
        let out = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], Error> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    pub(crate) fn u8(&mut self, what: &'static str) -> Result<u8, Error> {
        Ok(self.array::<1>(what)?[0])
    }

    pub(crate) fn u16(&mut self, what: &'static str) -> Result<u16, Error> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn i16(&mut self, what: &'static str) -> Result<i16, Error> {
        Ok(i16::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn i32(&mut self, what: &'static str) -> Result<i32, Error> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u32(&mut self, what: &'static str) -> Result<u32, Error> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u64(&mut self, what: &'static str) -> Result<u64, Error> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn f32(&mut self, what: &'static str) -> Result<f32, Error> {
        Ok(f32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn f64(&mut self, what: &'static str) -> Result<f64, Error> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn vec3(&mut self, what: &'static str) -> Result<[f32; 3], Error> {
        Ok([self.f32(what)?, self.f32(what)?, self.f32(what)?])
    }

    pub(crate) fn quat(&mut self, what: &'static str) -> Result<[f32; 4], Error> {
        Ok([self.f32(what)?, self.f32(what)?, self.f32(what)?, self.f32(what)?])
    }

    /// A count that announces `count` items of at least `min_item_len`
    /// bytes each: refused if negative or if the rest of the packet cannot
    /// hold them, so a garbage count never drives a huge allocation.
    pub(crate) fn count(&mut self, what: &'static str, min_item_len: usize) -> Result<usize, Error> {
        let at = self.pos;
        let raw = self.i32(what)?;
        let count = usize::try_from(raw).map_err(|_| Error::BadCount { what, count: raw, at })?;
        if count.saturating_mul(min_item_len.max(1)) > self.remaining() {
            return Err(Error::BadCount { what, count: raw, at });
        }
        Ok(count)
    }

    /// A NUL-terminated UTF-8 string (the NUL is consumed).
    pub(crate) fn cstr(&mut self, what: &'static str) -> Result<String, Error> {
        let at = self.pos;
        let rest = &self.bytes[self.pos..];
        let len = rest.iter().position(|&b| b == 0).ok_or(Error::Unterminated { what, at })?;
        let text = core::str::from_utf8(&rest[..len]).map_err(|_| Error::NotUtf8 { what, at })?;
        self.pos += len + 1;
        Ok(text.to_owned())
    }

    /// A fixed-size field holding a NUL-terminated, NUL-padded string (e.g.
    /// the 256-byte application name of the server info). A field without
    /// a NUL is refused: C readers would run past it, and it could not be
    /// encoded again (the writer keeps one byte for the NUL).
    pub(crate) fn fixed_str(&mut self, len: usize, what: &'static str) -> Result<String, Error> {
        let at = self.pos;
        let field = self.take(len, what)?;
        let end = field.iter().position(|&b| b == 0).ok_or(Error::Unterminated { what, at })?;
        core::str::from_utf8(&field[..end]).map(str::to_owned).map_err(|_| Error::NotUtf8 { what, at })
    }
}

/// Reads `n` items (the count already bounded by [`Reader::count`]).
pub(crate) fn read_many<T>(
    r: &mut Reader<'_>,
    n: usize,
    mut item: impl FnMut(&mut Reader<'_>) -> Result<T, Error>,
) -> Result<Vec<T>, Error> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(item(r)?);
    }
    Ok(out)
}

/// Appends NatNet primitives to a buffer.
#[derive(Default)]
pub(crate) struct Writer {
    pub(crate) buf: Vec<u8>,
}

impl Writer {
    pub(crate) fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }
    pub(crate) fn u16(&mut self, v: u16) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn i16(&mut self, v: i16) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn i32(&mut self, v: i32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn u32(&mut self, v: u32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn u64(&mut self, v: u64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn f32(&mut self, v: f32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn f64(&mut self, v: f64) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn floats(&mut self, v: &[f32]) {
        for x in v {
            self.f32(*x);
        }
    }
    /// A count as the i32 NatNet sends; refuses more than `i32::MAX` items.
    pub(crate) fn count(&mut self, n: usize, what: &'static str) -> Result<(), Error> {
        let n = i32::try_from(n).map_err(|_| Error::TooLarge { what })?;
        self.i32(n);
        Ok(())
    }
    /// A NUL-terminated string; refuses interior NULs, which would cut it.
    pub(crate) fn cstr(&mut self, s: &str, what: &'static str) -> Result<(), Error> {
        if s.as_bytes().contains(&0) {
            return Err(Error::InteriorNul { what });
        }
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        Ok(())
    }
    /// A string NUL-padded into a fixed field (one byte kept for the NUL).
    pub(crate) fn fixed_str(&mut self, s: &str, len: usize, what: &'static str) -> Result<(), Error> {
        if s.len() >= len {
            return Err(Error::TooLarge { what });
        }
        if s.as_bytes().contains(&0) {
            return Err(Error::InteriorNul { what });
        }
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.resize(self.buf.len() + (len - s.len()), 0);
        Ok(())
    }
    /// Starts a NatNet 4.1 "data size" field; returns its position for
    /// [`Writer::end_size`].
    pub(crate) fn begin_size(&mut self) -> usize {
        let at = self.buf.len();
        self.i32(0);
        at
    }
    /// Fills the size field started at `at` with the bytes written since.
    pub(crate) fn end_size(&mut self, at: usize, what: &'static str) -> Result<(), Error> {
        let len = self.buf.len() - at - 4;
        let len = i32::try_from(len).map_err(|_| Error::TooLarge { what })?;
        self.buf[at..at + 4].copy_from_slice(&len.to_le_bytes());
        Ok(())
    }
}
