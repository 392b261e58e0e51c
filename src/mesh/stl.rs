//! STL meshes (ASCII and binary) through the `stl_io` crate. Triangles keep the file's
//! order (facet k is triangle k); vertices at the same position are shared (welded by
//! value, `-0` and `0` alike), so vertex normals are averages over the facets that meet
//! there, as for an OBJ. The facets' own normals are not used (exporters write zeros or
//! stale ones). Errors name the line of the facet (ASCII) or its byte offset (binary).
//!
//! The ASCII facets are parsed by `stl_io`; binary records are read directly (the crate
//! takes a binary file whose header begins with `solid ` for ASCII).
//!
//! Which flavour a file is: binary when its size is exactly 84 + 50 x the triangle count
//! in bytes 80..84 (many binary exporters begin the header with `solid`, so the word alone
//! does not decide), ASCII when it begins with `solid`, binary otherwise. An ASCII file
//! may hold several `solid ... endsolid` blocks; their facets follow each other.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::Mesh;
use crate::error::{Error, Result};

/// Bytes before the first binary triangle: an 80-byte header and the triangle count.
const BINARY_HEADER: usize = 84;
/// Bytes of one binary triangle: normal, three vertices, a 2-byte attribute.
const BINARY_TRIANGLE: usize = 50;

/// Load STL `bytes` read from `path`.
pub(crate) fn load(path: &Path, bytes: &[u8]) -> Result<Mesh> {
    let count = (bytes.len() >= BINARY_HEADER)
        .then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize);
    let exact_binary = count.is_some_and(|n| {
        n.checked_mul(BINARY_TRIANGLE).and_then(|b| b.checked_add(BINARY_HEADER)) == Some(bytes.len())
    });
    let text_start = bytes.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(0);
    let mut warnings = Vec::new();
    let triangles = if !exact_binary && bytes[text_start..].starts_with(b"solid") {
        read_ascii(path, bytes)?
    } else {
        read_binary(path, bytes, count, &mut warnings)?
    };
    let mut mesh = build(path, &triangles)?;
    mesh.warnings = warnings;
    Ok(mesh)
}

/// One facet: its three corners, and where it is in the file (a line, or a byte offset).
struct Facet {
    v: [[f32; 3]; 3],
    at: Place,
}

#[derive(Clone, Copy)]
enum Place {
    Line(usize),
    Byte(usize),
}

fn read_binary(path: &Path, bytes: &[u8], count: Option<usize>, warnings: &mut Vec<String>) -> Result<Vec<Facet>> {
    let Some(n) = count else {
        return Err(Error::file(
            path,
            format!(
                "{} bytes: neither an ASCII STL (which begins with 'solid') nor a binary one (84 bytes of header and count)",
                bytes.len()
            ),
        ));
    };
    let need = n.saturating_mul(BINARY_TRIANGLE).saturating_add(BINARY_HEADER);
    if bytes.len() < need {
        let whole = (bytes.len() - BINARY_HEADER) / BINARY_TRIANGLE;
        return Err(Error::file(
            path,
            format!(
                "binary STL: byte {}: the file ends inside triangle {} of the {n} its header counts ({need} bytes needed, {} present)",
                BINARY_HEADER + whole * BINARY_TRIANGLE,
                whole + 1,
                bytes.len()
            ),
        ));
    }
    if n == 0 {
        return Err(Error::file(path, "binary STL: byte 80: the header counts 0 triangles"));
    }
    if bytes.len() > need {
        warnings.push(format!(
            "{}: binary STL: {} bytes after the {n} triangles its header counts are ignored",
            path.display(),
            bytes.len() - need
        ));
    }
    // Each record: the normal (ignored), three corners, two attribute bytes. Trailing bytes
    // after the counted triangles are ignored, as other readers do. (stl_io would read a
    // binary file whose header begins with "solid " as ASCII, so records are read here.)
    let f32_at = |b: usize| f32::from_le_bytes([bytes[b], bytes[b + 1], bytes[b + 2], bytes[b + 3]]);
    Ok((0..n)
        .map(|k| {
            let at = BINARY_HEADER + k * BINARY_TRIANGLE + 12;
            Facet { v: [0, 1, 2].map(|c| [0, 1, 2].map(|x| f32_at(at + 12 * c + 4 * x))), at: Place::Byte(at) }
        })
        .collect())
}

/// The lines of an ASCII file with their numbers (from 1), blank lines dropped.
fn lines(text: &str) -> Vec<(usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty()).collect()
}

fn read_ascii(path: &Path, bytes: &[u8]) -> Result<Vec<Facet>> {
    let text = super::encoding::decode_text(bytes.to_vec()).0;
    let all = lines(&text);
    let mut facets = Vec::new();
    let mut i = 0;
    while i < all.len() {
        let (start, first) = all[i];
        if first.split_whitespace().next() != Some("solid") {
            return Err(Error::at(path, start, format!("expected 'solid', found '{}'", clip(first))));
        }
        // This solid's lines, up to its `endsolid` (or the end of the file).
        let end = all[i + 1..].iter().position(|(_, l)| l.starts_with("endsolid")).map(|k| i + 1 + k);
        let body = &all[i + 1..end.unwrap_or(all.len())];
        if end.is_none() {
            return Err(Error::at(
                path,
                all.last().map_or(start, |l| l.0),
                format!("the solid begun at line {start} has no 'endsolid'"),
            ));
        }
        // stl_io reads one solid whose first line is `solid NAME`; facets are located by
        // counting the `facet` lines of the body.
        let mut chunk = String::from("solid rtdiff\n");
        for (_, l) in body {
            chunk.push_str(l);
            chunk.push('\n');
        }
        chunk.push_str("endsolid rtdiff\n");
        let facet_lines: Vec<usize> =
            body.iter().filter(|(_, l)| l.split_whitespace().next() == Some("facet")).map(|(n, _)| *n).collect();
        let mut cursor = std::io::Cursor::new(chunk.into_bytes());
        let reader = stl_io::create_stl_reader(&mut cursor).map_err(|e| Error::at(path, start, format!("{e}")))?;
        let first_facet = facets.len();
        for t in reader {
            let k = facets.len() - first_facet;
            // The facet's header line (or, past the last header, where the next one should be).
            let line = facet_lines.get(k).copied().unwrap_or_else(|| body.get(7 * k).map_or(start, |l| l.0));
            let t = t.map_err(|e| {
                let (at, why) = locate(body, line).unwrap_or_else(|| (line, e.to_string().replace('"', "'")));
                Error::at(path, at, format!("facet {}: {why}", facets.len() + 1))
            })?;
            facets.push(Facet { v: t.vertices.map(|v| v.0), at: Place::Line(line) });
        }
        i = end.map_or(all.len(), |e| e + 1);
    }
    if facets.is_empty() {
        let line = all.last().map_or(1, |l| l.0);
        return Err(Error::at(path, line, "no facets: an STL solid without triangles has nothing to trace"));
    }
    Ok(facets)
}

/// The first line of the facet whose header is at `line` that breaks the layout `facet
/// normal x y z`, `outer loop`, three `vertex x y z`, `endloop`, `endfacet`, and why (a
/// sharper error than the crate's, which names no line).
fn locate(body: &[(usize, &str)], line: usize) -> Option<(usize, String)> {
    const LAYOUT: [(&str, usize); 7] =
        [("facet", 4), ("outer", 1), ("vertex", 3), ("vertex", 3), ("vertex", 3), ("endloop", 0), ("endfacet", 0)];
    let from = body.iter().position(|(n, _)| *n == line)?;
    for (k, &(keyword, values)) in LAYOUT.iter().enumerate() {
        let Some(&(n, l)) = body.get(from + k) else {
            return Some((body.last()?.0, format!("the file ends before '{keyword}'")));
        };
        let mut w = l.split_whitespace();
        if w.next() != Some(keyword) {
            return Some((n, format!("expected '{keyword}', found '{}'", clip(l).escape_debug())));
        }
        let numbers: Vec<&str> = match keyword {
            "facet" => w.skip(1).collect(),
            "vertex" => w.collect(),
            _ => continue,
        };
        if numbers.len() + usize::from(keyword == "facet") != values {
            let what = if keyword == "facet" { "a normal of 3 numbers" } else { "3 coordinates" };
            return Some((n, format!("'{keyword}' needs {what}, found '{}'", clip(l).escape_debug())));
        }
        for t in numbers {
            match t.parse::<f32>() {
                Ok(x) if x.is_finite() => {}
                Ok(_) => return Some((n, format!("'{}' is not a finite number", clip(t)))),
                Err(_) => return Some((n, format!("'{}' is not a number", clip(t).escape_debug()))),
            }
        }
    }
    None
}

fn clip(s: &str) -> String {
    let mut c: String = s.chars().take(40).collect();
    if c.len() < s.len() {
        c.push_str("...");
    }
    c
}

/// Weld the facets' corners by value (the first value seen is kept) and check them.
fn build(path: &Path, facets: &[Facet]) -> Result<Mesh> {
    let mut mesh = Mesh::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    for f in facets {
        let mut tri = [0u32; 3];
        for (k, p) in f.v.iter().enumerate() {
            if let Some(bad) = p.iter().find(|x| !x.is_finite()) {
                return Err(match f.at {
                    Place::Line(l) => {
                        Error::at(path, l, format!("vertex {} of this facet is not finite ({bad})", k + 1))
                    }
                    Place::Byte(b) => {
                        Error::file(path, format!("binary STL: byte {}: a vertex is not finite ({bad})", b + 12 * k))
                    }
                });
            }
            // +0 for -0, so that the two weld.
            let key = p.map(|x| (x + 0.0).to_bits());
            tri[k] = *index.entry(key).or_insert_with(|| {
                mesh.positions.push(Vec3::from(*p));
                mesh.positions.len() as u32 - 1
            });
        }
        mesh.indices.push(tri);
    }
    mesh.face_material = vec![None; mesh.indices.len()];
    mesh.finish(path, None)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(tris: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b[..header.len()].copy_from_slice(header);
        b.extend_from_slice(&(tris.len() as u32).to_le_bytes());
        for t in tris {
            b.extend_from_slice(&[0u8; 12]);
            for v in t {
                for x in v {
                    b.extend_from_slice(&x.to_le_bytes());
                }
            }
            b.extend_from_slice(&[0, 0]);
        }
        b
    }

    const QUAD: [[[f32; 3]; 3]; 2] =
        [[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.]], [[0., 0., 0.], [1., 1., 0.], [0., 1., -0.]]];

    #[test]
    fn binary_with_a_solid_header_welds_and_keeps_the_order() {
        let m = load(Path::new("q.stl"), &binary(&QUAD, b"solid exported by a CAD tool")).unwrap();
        assert_eq!(m.positions.len(), 4, "shared corners welded, -0 with 0");
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn ascii_with_two_solids_and_errors_naming_the_line() {
        let facet = |z: f32| {
            format!(
                "facet normal 0 0 1\nouter loop\nvertex 0 0 {z}\nvertex 1 0 {z}\nvertex 0 1 {z}\nendloop\nendfacet\n"
            )
        };
        let text = format!("solid a\n{}endsolid a\n\nsolid\n{}endsolid\n", facet(0.0), facet(1.0));
        let m = load(Path::new("two.stl"), text.as_bytes()).unwrap();
        assert_eq!((m.indices.len(), m.positions.len()), (2, 6));
        let bad = text.replace("vertex 1 0 1", "vertex 1 0 x");
        let e = load(Path::new("bad.stl"), bad.as_bytes()).unwrap_err().to_string();
        assert!(e.starts_with("bad.stl:15: facet 2: 'x' is not a number"), "{e}");
        let e = load(Path::new("open.stl"), b"solid a\nfacet normal 0 0 1\n").unwrap_err().to_string();
        assert!(e.contains("open.stl:2:") && e.contains("no 'endsolid'"), "{e}");
        let e = load(Path::new("none.stl"), b"solid a\nendsolid a\n").unwrap_err().to_string();
        assert!(e.starts_with("none.stl:2: no facets"), "{e}");
    }

    #[test]
    fn truncated_and_non_finite_binaries_name_the_byte() {
        let b = binary(&QUAD, b"x");
        let e = load(Path::new("t.stl"), &b[..b.len() - 10]).unwrap_err().to_string();
        assert!(e.contains("byte 134: the file ends inside triangle 2 of the 2"), "{e}");
        let mut nan = QUAD;
        nan[1][2][1] = f32::NAN;
        let e = load(Path::new("n.stl"), &binary(&nan, b"x")).unwrap_err().to_string();
        assert!(e.contains("byte 170: a vertex is not finite"), "{e}");
        let e = load(Path::new("s.stl"), b"short").unwrap_err().to_string();
        assert!(e.contains("neither an ASCII STL"), "{e}");
    }
}
