//! Buffered semihosting files: every semihosting call traps into QEMU, so
//! records are read and lines written through 4 KiB buffers.

use bycoms_fw_replay::{Error, Source};
use core::ffi::CStr;
use core::fmt;
use semihosting::fs::File;
use semihosting::io::{Read, Write};

const BUF: usize = 4096;

/// A host path as the C string semihosting wants.
fn c_path<'a>(path: &str, buf: &'a mut [u8; 256]) -> semihosting::io::Result<&'a CStr> {
    let bytes = path.as_bytes();
    if bytes.len() >= buf.len() || bytes.contains(&0) {
        return Err(semihosting::io::ErrorKind::InvalidInput.into());
    }
    buf[..bytes.len()].copy_from_slice(bytes);
    buf[bytes.len()] = 0;
    CStr::from_bytes_with_nul(&buf[..=bytes.len()])
        .map_err(|_| semihosting::io::ErrorKind::InvalidInput.into())
}

/// The input file.
pub struct Reader {
    file: File,
    buf: [u8; BUF],
    at: usize,
    len: usize,
}

impl Reader {
    /// Opens `path` on the host for reading.
    pub fn open(path: &str) -> semihosting::io::Result<Self> {
        let mut name = [0u8; 256];
        let file = File::open(c_path(path, &mut name)?)?;
        Ok(Self { file, buf: [0; BUF], at: 0, len: 0 })
    }
}

impl Source for Reader {
    fn read_exact(&mut self, out: &mut [u8]) -> Result<(), Error> {
        let mut done = 0;
        while done < out.len() {
            if self.at == self.len {
                // Large reads (a microphone record) go straight into `out`.
                if out.len() - done >= BUF {
                    let n = self.file.read(&mut out[done..]).map_err(|_| Error::Io)?;
                    if n == 0 {
                        return Err(Error::Truncated);
                    }
                    done += n;
                    continue;
                }
                self.len = self.file.read(&mut self.buf).map_err(|_| Error::Io)?;
                self.at = 0;
                if self.len == 0 {
                    return Err(Error::Truncated);
                }
            }
            let n = (self.len - self.at).min(out.len() - done);
            out[done..done + n].copy_from_slice(&self.buf[self.at..self.at + n]);
            self.at += n;
            done += n;
        }
        Ok(())
    }
}

/// The output file, written as text.
pub struct Writer {
    file: File,
    buf: [u8; BUF],
    len: usize,
    failed: bool,
}

impl Writer {
    /// Creates (truncates) `path` on the host.
    pub fn create(path: &str) -> semihosting::io::Result<Self> {
        let mut name = [0u8; 256];
        let file = File::create(c_path(path, &mut name)?)?;
        Ok(Self { file, buf: [0; BUF], len: 0, failed: false })
    }

    /// Writes out what is buffered.
    pub fn flush(&mut self) -> Result<(), Error> {
        if self.len > 0 && !self.failed {
            self.failed = self.file.write_all(&self.buf[..self.len]).is_err();
        }
        self.len = 0;
        if self.failed {
            Err(Error::Io)
        } else {
            Ok(())
        }
    }
}

impl fmt::Write for Writer {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let mut s = s.as_bytes();
        while !s.is_empty() {
            if self.len == BUF {
                self.flush().map_err(|_| fmt::Error)?;
            }
            let n = (BUF - self.len).min(s.len());
            self.buf[self.len..self.len + n].copy_from_slice(&s[..n]);
            self.len += n;
            s = &s[n..];
        }
        Ok(())
    }
}
