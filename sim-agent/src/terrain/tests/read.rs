use crate::terrain::{parse, read_terrain, read_terrain_file, ReadError, MAX_FILE_BYTES};
use std::io::Read;

/// A reader that counts what was taken from it.
struct Counting<R> {
    inner: R,
    taken: u64,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.taken += n as u64;
        Ok(n)
    }
}

#[test]
fn a_stream_longer_than_the_limit_is_refused_after_the_limit() {
    // An endless one-line "file": reading it whole would never end.
    let mut endless = Counting { inner: std::io::repeat(b'.'), taken: 0 };
    let e = read_terrain(&mut endless).unwrap_err();
    assert!(matches!(e, ReadError::TooLarge { size: None }), "{e}");
    assert_eq!(endless.taken, MAX_FILE_BYTES + 1);
    let said = "more than the limit of 2097152 bytes for a terrain (at most 1000 × 1000 cells); is this a terrain file?";
    assert_eq!(e.to_string(), said, "the limit said once");
}

#[test]
fn a_large_file_is_refused_from_its_length_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.txt");
    let file = std::fs::File::create(&path).unwrap();
    // Sparse: 300 MB on paper, nothing on disk.
    file.set_len(300_000_000).unwrap();
    let e = read_terrain_file(&path).unwrap_err();
    assert!(matches!(e, ReadError::TooLarge { size: Some(300_000_000) }), "{e}");
    assert!(e.to_string().starts_with("300000000 bytes, more than the limit of 2097152 bytes"), "{e}");
    std::fs::write(&path, "S.\n.G\n").unwrap();
    assert_eq!(read_terrain_file(&path).unwrap(), parse("S.\n.G\n").unwrap());
    std::fs::write(&path, [b'S', 0xff, b'\n']).unwrap();
    assert!(matches!(read_terrain_file(&path).unwrap_err(), ReadError::NotText));
}
