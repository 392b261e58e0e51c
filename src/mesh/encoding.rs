//! Text decoding for OBJ and MTL files as exporters write them: UTF-8 (with or
//! without a byte-order mark), UTF-16 with a byte-order mark, or single-byte
//! Latin-1; CRLF and lone-CR line ends become LF.

/// The encoding a text file was decoded from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextEncoding {
    /// UTF-8 (a leading byte-order mark, if any, is dropped).
    Utf8,
    /// UTF-16 little endian, recognised by its byte-order mark `FF FE`.
    Utf16Le,
    /// UTF-16 big endian, recognised by its byte-order mark `FE FF`.
    Utf16Be,
    /// Not valid UTF-8: each byte decoded as the Unicode code point of the same value
    /// (ISO 8859-1), which is lossless: the original bytes can be recovered.
    Latin1,
}

/// Decode `bytes` into text with `\n` line ends. Only names (materials, objects, files)
/// are text in a mesh file; numbers are ASCII in every one of these encodings, so the
/// decoding never changes a coordinate.
pub fn decode_text(bytes: Vec<u8>) -> (String, TextEncoding) {
    let (text, encoding) = match bytes.as_slice() {
        [0xFF, 0xFE, rest @ ..] => (utf16(rest, u16::from_le_bytes), TextEncoding::Utf16Le),
        [0xFE, 0xFF, rest @ ..] => (utf16(rest, u16::from_be_bytes), TextEncoding::Utf16Be),
        [0xEF, 0xBB, 0xBF, rest @ ..] => match std::str::from_utf8(rest) {
            Ok(s) => (s.to_owned(), TextEncoding::Utf8),
            Err(_) => (latin1(rest), TextEncoding::Latin1),
        },
        _ => match String::from_utf8(bytes) {
            Ok(s) => (s, TextEncoding::Utf8),
            Err(e) => (latin1(e.as_bytes()), TextEncoding::Latin1),
        },
    };
    (normalise_line_ends(text), encoding)
}

fn utf16(bytes: &[u8], from: fn([u8; 2]) -> u16) -> String {
    // A trailing odd byte cannot be part of a UTF-16 unit: it is dropped like a truncated line.
    let units = bytes.chunks_exact(2).map(|c| from([c[0], c[1]]));
    char::decode_utf16(units).map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER)).collect()
}

fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|&b| b as char).collect()
}

fn normalise_line_ends(text: String) -> String {
    if !text.contains('\r') {
        return text;
    }
    text.replace("\r\n", "\n").replace('\r', "\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latin1_bytes_become_the_same_code_points() {
        let (t, e) = decode_text(b"usemtl Caf\xe9\nv 1 2 3\n".to_vec());
        assert_eq!(e, TextEncoding::Latin1);
        assert_eq!(t, "usemtl Caf\u{e9}\nv 1 2 3\n");
        // lossless: every char maps back to its byte
        let back: Vec<u8> = t.chars().map(|c| c as u32 as u8).collect();
        assert_eq!(back, b"usemtl Caf\xe9\nv 1 2 3\n");
    }

    #[test]
    fn utf16_with_bom_both_endiannesses_and_crlf() {
        let text = "v 1 2 3\r\nf 1 2 3\r\n";
        let be: Vec<u8> = [0xFE, 0xFF].into_iter().chain(text.encode_utf16().flat_map(u16::to_be_bytes)).collect();
        let le: Vec<u8> = [0xFF, 0xFE].into_iter().chain(text.encode_utf16().flat_map(u16::to_le_bytes)).collect();
        assert_eq!(decode_text(be), ("v 1 2 3\nf 1 2 3\n".into(), TextEncoding::Utf16Be));
        assert_eq!(decode_text(le), ("v 1 2 3\nf 1 2 3\n".into(), TextEncoding::Utf16Le));
    }

    #[test]
    fn utf8_bom_dropped_and_lone_cr_is_a_line_end() {
        let (t, e) = decode_text(b"\xEF\xBB\xBFv 1 2 3\rv 4 5 6".to_vec());
        assert_eq!((t.as_str(), e), ("v 1 2 3\nv 4 5 6", TextEncoding::Utf8));
    }
}
