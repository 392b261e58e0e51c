//! Reading mesh files whole, gzip-compressed (`.obj.gz`, `.ply.gz`) or not.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// True when `path` names a gzip file (`.gz`, any case).
pub fn is_gzip_name(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// The bytes of `path`, decompressed when the file is gzip (by name or by its magic bytes `1f 8b`).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let raw = std::fs::read(path).map_err(|e| Error::io(path, &e))?;
    if !(is_gzip_name(path) || raw.starts_with(&[0x1f, 0x8b])) {
        return Ok(raw);
    }
    let mut out = Vec::with_capacity(raw.len().saturating_mul(4));
    flate2::read::MultiGzDecoder::new(raw.as_slice())
        .read_to_end(&mut out)
        .map_err(|e| Error::file(path, format!("cannot decompress gzip data: {e}")))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn gzip_round_trip_and_corrupt_stream_is_an_error() {
        let dir = std::env::temp_dir().join(format!("rtdiff-gz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.obj.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(b"v 0 0 0\n").unwrap();
        std::fs::write(&p, enc.finish().unwrap()).unwrap();
        assert_eq!(read_bytes(&p).unwrap(), b"v 0 0 0\n");
        let bad = dir.join("b.obj.gz");
        std::fs::write(&bad, [0x1f, 0x8b, 8, 0, 1, 2, 3]).unwrap();
        let e = read_bytes(&bad).unwrap_err().to_string();
        assert!(e.contains("b.obj.gz") && e.contains("gzip"), "{e}");
    }
}
