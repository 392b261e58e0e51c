//! Reading mesh files whole, gzip-compressed (`.obj.gz`, `.ply.gz`) or not.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// True when `path` names a gzip file (`.gz`, any case).
pub fn is_gzip_name(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// The bytes of `path`, decompressed when the file is gzip (by name or by its
/// magic bytes `1f 8b`); the file and the decompressed data are each at most
/// [`crate::limits::MAX_MESH_FILE_BYTES`].
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    read_bytes_limited(path, crate::limits::MAX_MESH_FILE_BYTES)
}

/// [`read_bytes`] with the size limit `max` (bytes) for the file and for
/// the decompressed data. Decompression stops one byte past `max`, so a
/// small file that expands without end (a "gzip bomb") allocates at most
/// `max + 1` bytes before it is refused.
pub fn read_bytes_limited(path: &Path, max: u64) -> Result<Vec<u8>> {
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, &e))?.len();
    if size > max {
        return Err(Error::file(path, format!("mesh file is {size} bytes, over the limit of {max} bytes")));
    }
    let raw = std::fs::read(path).map_err(|e| Error::io(path, &e))?;
    if !(is_gzip_name(path) || raw.starts_with(&[0x1f, 0x8b])) {
        return Ok(raw);
    }
    let mut out = Vec::with_capacity(raw.len().saturating_mul(4).min(max as usize));
    flate2::read::MultiGzDecoder::new(raw.as_slice())
        .take(max.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| Error::file(path, format!("cannot decompress gzip data: {e}")))?;
    if out.len() as u64 > max {
        return Err(Error::file(
            path,
            format!("gzip data decompresses to more than {max} bytes, the limit of a mesh file"),
        ));
    }
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
        // 8000 bytes from a file of a few dozen: at a limit of 8000 they
        // decompress, at 7999 they are refused.
        let text = "v 0 0 0\n".repeat(1000);
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(text.as_bytes()).unwrap();
        let c = dir.join("c.obj.gz");
        std::fs::write(&c, enc.finish().unwrap()).unwrap();
        assert_eq!(read_bytes_limited(&c, 8000).unwrap(), text.as_bytes());
        let e = read_bytes_limited(&c, 7999).unwrap_err().to_string();
        assert!(e.contains("c.obj.gz") && e.contains("more than 7999 bytes"), "{e}");
        let e = read_bytes_limited(&p, 4).unwrap_err().to_string();
        assert!(e.contains("a.obj.gz") && e.contains("over the limit of 4 bytes"), "{e}");
    }
}
