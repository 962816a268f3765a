//! Reading a terrain from a file or a stream, with a size limit.
//!
//! A terrain file is user input: a wrong path (a recording, a log, a 300 MB
//! one-line file) must not make a tool read it whole and build a grid from
//! it — that once took 22.4 GB of memory. So a file larger than
//! [`MAX_FILE_BYTES`] is refused before any of it is read (from its length
//! when the file system knows it, else after reading one byte past the
//! limit), and [`parse`] refuses grids wider or taller than [`MAX_SIDE`]
//! cells. The paper's terrains are 60 × 60 cells, about 3.7 kB.

use super::format::{parse, ParseError, MAX_SIDE};
use super::grid::Terrain;
use bycoms_runtime::capped::{read_capped, read_capped_file, CappedError};
use std::io::Read;
use std::path::Path;

/// Largest terrain text accepted, in bytes: a [`MAX_SIDE`] × [`MAX_SIDE`]
/// grid with `\r\n` line ends and a byte-order mark fits with room to spare.
pub const MAX_FILE_BYTES: u64 = 2 * 1024 * 1024;

/// Why a terrain could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error(
        "{}more than the limit of {MAX_FILE_BYTES} bytes for a terrain \
         (at most {MAX_SIDE} × {MAX_SIDE} cells); is this a terrain file?",
        size.map_or_else(String::new, |s| format!("{s} bytes, "))
    )]
    TooLarge {
        /// The size, when known without reading.
        size: Option<u64>,
    },
    #[error("not UTF-8 text (a terrain is lines of '#', '.', 'S' and 'G')")]
    NotText,
    #[error("{0}")]
    Parse(#[from] ParseError),
}

/// Reads and parses a terrain from a stream, refusing more than
/// [`MAX_FILE_BYTES`] bytes.
pub fn read_terrain(reader: impl Read) -> Result<Terrain, ReadError> {
    Ok(parse(&read_text(reader)?)?)
}

/// Reads and parses a terrain file; a file larger than [`MAX_FILE_BYTES`]
/// is refused from its length, before anything is read.
pub fn read_terrain_file(path: &Path) -> Result<Terrain, ReadError> {
    Ok(parse(&read_text_file(path)?)?)
}

/// A terrain's text from a stream, unparsed, refusing more than
/// [`MAX_FILE_BYTES`] bytes (an agent hands the text on: its run settings
/// carry it).
pub fn read_text(reader: impl Read) -> Result<String, ReadError> {
    read_capped(reader, MAX_FILE_BYTES).map_err(ReadError::from)
}

/// A terrain file's text, unparsed; a file larger than [`MAX_FILE_BYTES`]
/// is refused from its length, before anything is read (the one capped
/// reader, [`bycoms_runtime::capped`]).
pub fn read_text_file(path: &Path) -> Result<String, ReadError> {
    read_capped_file(path, MAX_FILE_BYTES).map_err(ReadError::from)
}

impl From<CappedError> for ReadError {
    fn from(e: CappedError) -> Self {
        match e {
            CappedError::Io(e) => ReadError::Io(e),
            CappedError::TooLarge { size, .. } => ReadError::TooLarge { size },
            CappedError::NotText => ReadError::NotText,
        }
    }
}
