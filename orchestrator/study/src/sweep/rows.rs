//! One CSV row per run, and the file that holds them.
//!
//! Rows are written in canonical order and flushed as they are written, so
//! the file is always a prefix of the complete one: Ctrl-C loses nothing
//! that was written, a torn last line (a crash mid-write) is cut off, and
//! resuming means checking the prefix and carrying on from its end. Same
//! plan and seed → the same bytes.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

/// One run's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Canonical run index (see `plan`).
    pub index: usize,
    pub noise: bool,
    pub eps: f64,
    pub width_bin: f64,
    pub terrain: String,
    pub width: f64,
    /// Seed of the robots' noise streams (replay with `simulate --seed`).
    pub seed: u64,
    pub success: bool,
    pub outcome: String,
    pub time_s: f64,
    pub robots_used: u32,
    pub beacons: usize,
}

/// The header line every runs CSV starts with.
pub const HEADER: &str =
    "index,noise,eps,width_bin,terrain,width,seed,success,outcome,time_s,robots_used,beacons\n";

/// Reads all complete rows of a runs CSV.
pub fn read_rows(path: &Path) -> Result<Vec<Row>> {
    let text = super::read_text(path)?;
    parse_rows(&text[..complete_len(&text)], path)
}

/// Length of the text up to and including its last newline.
fn complete_len(text: &str) -> usize {
    text.rfind('\n').map_or(0, |i| i + 1)
}

fn parse_rows(text: &str, path: &Path) -> Result<Vec<Row>> {
    if text.is_empty() {
        return Ok(Vec::new());
    }
    // A shard that went through a Windows editor or transfer ends its
    // lines in CR LF: the same rows (the CSV reader takes either end).
    if text.lines().next() != Some(HEADER.trim_end()) {
        bail!("{} is not a bycoms runs CSV (unexpected header)", path.display());
    }
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    reader
        .deserialize()
        .enumerate()
        .map(|(i, r)| r.with_context(|| format!("{}: bad row {}", path.display(), i + 2)))
        .collect()
}

/// An append-only runs CSV.
pub struct RowWriter {
    out: BufWriter<File>,
}

impl RowWriter {
    /// Opens `path` for appending after the rows already there (cutting off a
    /// torn last line) and returns them; creates it with a header if absent.
    pub fn open(path: &Path) -> Result<(Self, Vec<Row>)> {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .with_context(|| format!("cannot open {} for writing", path.display()))?;
        let text = bycoms_runtime::capped::read_capped(&mut file, super::MAX_READ_BYTES)
            .with_context(|| format!("cannot read {}", path.display()))?;
        if !(text.starts_with(HEADER) || HEADER.starts_with(text.as_str())) {
            bail!("{} is not a bycoms runs CSV (unexpected header); not touching it", path.display());
        }
        let keep = complete_len(&text);
        let rows = parse_rows(&text[..keep], path)?;
        file.set_len(keep as u64).with_context(|| format!("cannot truncate {}", path.display()))?;
        file.seek(SeekFrom::End(0))?;
        let mut out = BufWriter::new(file);
        if keep == 0 {
            out.write_all(HEADER.as_bytes())?;
            out.flush()?;
        }
        Ok((Self { out }, rows))
    }

    /// Appends one row and flushes it to the file.
    pub fn write(&mut self, row: &Row) -> Result<()> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        w.serialize(row)?;
        let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))?;
        self.out.write_all(&bytes)?;
        self.out.flush().context("cannot write the runs CSV")?;
        Ok(())
    }
}

/// Writes `rows` as a complete CSV (used by `merge`), atomically: the old
/// file stays whole until the new one is.
pub fn write_all(path: &Path, rows: &[Row]) -> Result<()> {
    let mut w = csv::WriterBuilder::new().has_headers(true).from_writer(Vec::new());
    if rows.is_empty() {
        return write_atomic(path, HEADER.as_bytes());
    }
    for r in rows {
        w.serialize(r)?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))?;
    write_atomic(path, &bytes)
}

/// Writes `bytes` to a temporary file beside `path`, then renames it over
/// `path` ([`bycoms_runtime::out::write_atomic`]): the files of a sweep's own output
/// directory (whose `sweep.json` says it is this sweep's), replaced as the
/// sweep resumes.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(bycoms_runtime::out::write_atomic(path, bytes, 0o666)?)
}

/// `records` as CSV bytes with a header from their field names (the
/// `csv` crate does the quoting), for the small index files beside the runs.
pub fn to_csv_bytes<T: Serialize>(records: impl IntoIterator<Item = T>) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in records {
        w.serialize(r)?;
    }
    w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(i: usize) -> Row {
        Row {
            index: i,
            noise: i % 2 == 1,
            eps: 1.5,
            width_bin: 2.0,
            terrain: format!("c{i}"),
            width: 2.25,
            seed: 42,
            success: true,
            outcome: "arrived".into(),
            time_s: 123.4,
            robots_used: 3,
            beacons: 2,
        }
    }

    #[test]
    fn rows_with_cr_lf_line_ends_are_the_same_rows() {
        let mut w = csv::Writer::from_writer(Vec::new());
        for i in 0..3 {
            w.serialize(row(i)).unwrap();
        }
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let crlf = text.replace('\n', "\r\n");
        let path = Path::new("runs-shard-0-of-2.csv");
        let rows = parse_rows(&crlf, path).expect("a CR LF shard is a runs CSV");
        assert_eq!(rows, parse_rows(&text, path).expect("LF"));
        assert_eq!(rows.len(), 3);
        let other = parse_rows("a,b\r\n1,2\r\n", path).unwrap_err().to_string();
        assert!(other.contains("not a bycoms runs CSV"), "{other}");
    }

    #[test]
    fn header_matches_row_fields() {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(row(0)).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert!(text.starts_with(HEADER));
    }

    #[test]
    fn appends_resumes_and_cuts_a_torn_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("runs.csv");
        {
            let (mut w, rows) = RowWriter::open(&path).unwrap();
            assert!(rows.is_empty());
            w.write(&row(0)).unwrap();
            w.write(&row(1)).unwrap();
        }
        // A crash in the middle of the third row.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"2,false,1.5,2").unwrap();
        drop(f);
        let (mut w, rows) = RowWriter::open(&path).unwrap();
        assert_eq!(rows, vec![row(0), row(1)]);
        w.write(&row(2)).unwrap();
        drop(w);
        assert_eq!(read_rows(&path).unwrap(), vec![row(0), row(1), row(2)]);
    }

    #[test]
    fn foreign_file_is_rejected_and_left_alone() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("runs.csv");
        for text in ["a,b\n1,2\n", "no newline at all"] {
            std::fs::write(&path, text).unwrap();
            assert!(RowWriter::open(&path).is_err());
            assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
        }
    }

    #[test]
    fn write_all_matches_appended_rows() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
        let rows = vec![row(0), row(1)];
        write_all(&a, &rows).unwrap();
        let (mut w, _) = RowWriter::open(&b).unwrap();
        for r in &rows {
            w.write(r).unwrap();
        }
        drop(w);
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    }

    #[test]
    fn index_files_are_quoted_by_the_csv_crate() {
        #[derive(Serialize)]
        struct Entry<'a> {
            name: &'a str,
            value: Option<f64>,
        }
        let bytes =
            to_csv_bytes([Entry { name: "a,\"b\"", value: None }, Entry { name: "c", value: Some(0.5) }]);
        assert_eq!(String::from_utf8(bytes.unwrap()).unwrap(), "name,value\n\"a,\"\"b\"\"\",\nc,0.5\n");
    }
}
