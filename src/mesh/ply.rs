//! Stanford PLY meshes (ASCII, binary little and big endian) through the `ply-rs-bw`
//! crate: positions, faces (fan-triangulated from the first vertex, as tobj does for
//! OBJ), and vertex normals and texture coordinates when the file has them. Errors in an
//! ASCII file name the line (found by a second pass when the crate rejects a row).

use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{ElementDef, Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType};

use super::{Content, Mesh};
use crate::error::{Error, Result};

/// One `vertex` row: the properties rtdiff uses, and which of them were present.
#[derive(Clone, Copy, Default)]
struct Vertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    /// Bits: 0-2 position x y z, 3-5 normal, 6-7 uv.
    has: u8,
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x as f64,
        Property::UChar(x) => x as f64,
        Property::Short(x) => x as f64,
        Property::UShort(x) => x as f64,
        Property::Int(x) => x as f64,
        Property::UInt(x) => x as f64,
        Property::Float(x) => return Some(x as f64),
        Property::Double(x) => x,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, p: Property) {
        let slot = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "nx" => 3,
            "ny" => 4,
            "nz" => 5,
            "u" | "s" | "texture_u" | "texture_s" => 6,
            "v" | "t" | "texture_v" | "texture_t" => 7,
            _ => return,
        };
        // f32 properties are stored unchanged (a PLY written from f32 reads back bit-identical);
        // double ones round to the nearest f32, the precision of every rtdiff mesh.
        let v = match p {
            Property::Float(x) => x,
            ref other => match scalar(other) {
                Some(x) => x as f32,
                None => return,
            },
        };
        match slot {
            0..=2 => self.p[slot] = v,
            3..=5 => self.n[slot - 3] = v,
            _ => self.uv[slot - 6] = v,
        }
        self.has |= 1 << slot;
    }
}

/// One `face` row: its vertex indices (any integer list type).
#[derive(Default)]
struct Face {
    idx: Vec<i64>,
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, p: Property) {
        if name != "vertex_indices" && name != "vertex_index" {
            return;
        }
        self.idx = match p {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return,
        };
    }
}

/// Any other element: read (to move past it) and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// A `ply-rs-bw` error message on one line.
fn one_line(e: &std::io::Error) -> String {
    e.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Split "Line N: rest" into (N, rest).
fn split_line_prefix(msg: &str) -> Option<(usize, &str)> {
    let rest = msg.strip_prefix("Line ")?;
    let (n, rest) = rest.split_once(':')?;
    Some((n.trim().parse().ok()?, rest.trim()))
}

/// Load PLY `bytes` read from `path`.
pub(crate) fn load(path: &Path, bytes: &[u8], content: Content) -> Result<Mesh> {
    let mut warnings = Vec::new();
    let fixed = fix_header(path, bytes, &mut warnings);
    let bytes = fixed.as_deref().unwrap_or(bytes);
    let mut cursor = bytes;
    let header = Parser::<Skip>::new().read_header(&mut cursor).map_err(|e| {
        let msg = one_line(&e);
        match split_line_prefix(&msg) {
            Some((line, rest)) => Error::at(path, line, format!("invalid PLY header: {rest}")),
            None => Error::file(path, format!("invalid PLY header: {msg}")),
        }
    })?;
    let header_len = bytes.len() - cursor.len();
    let header_lines = bytes[..header_len].iter().filter(|&&b| b == b'\n').count();
    let header_text = String::from_utf8_lossy(&bytes[..header_len]);
    let element_line = |name: &str| {
        header_text
            .split('\n')
            .position(|l| {
                let mut w = l.split_whitespace();
                w.next() == Some("element") && w.next() == Some(name)
            })
            .map_or(1, |i| i + 1)
    };
    let nverts = header.elements.get("vertex").map_or(0, |e| e.count);
    match header.elements.get("face") {
        Some(f) if f.count > 0 => {}
        _ => {
            let line = if header.elements.contains_key("face") { element_line("face") } else { element_line("vertex") };
            return Err(Error::at(
                path,
                line,
                format!("a point cloud: {nverts} vertices and no faces, so nothing to trace"),
            ));
        }
    }
    if let Some(v) = header.elements.get("vertex") {
        let names: Vec<&str> = v.properties.keys().map(String::as_str).collect();
        if !["x", "y", "z"].iter().all(|c| names.contains(c)) {
            return Err(Error::at(path, element_line("vertex"), "the 'vertex' element has no x, y and z properties"));
        }
    }

    // Rows are read element by element, in header order; the first line of each ASCII element's rows:
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();
    let mut first_face_line = 0;
    let mut row_line = header_lines + 1;
    for (name, def) in &header.elements {
        let read = match name.as_str() {
            "vertex" => {
                Parser::<Vertex>::new().read_payload_for_element(&mut cursor, def, &header).map(|v| vertices = v)
            }
            "face" => {
                first_face_line = row_line;
                Parser::<Face>::new().read_payload_for_element(&mut cursor, def, &header).map(|f| faces = f)
            }
            _ => Parser::<Skip>::new().read_payload_for_element(&mut cursor, def, &header).map(drop),
        };
        if let Err(e) = read {
            let payload = Payload { bytes, header_len, header_lines };
            return Err(payload_error(path, &header, &payload, name, def, &e));
        }
        row_line += def.count;
    }

    let ascii = header.encoding == Encoding::Ascii;
    let mut mesh = Mesh { warnings, ..Default::default() };
    mesh.positions = vertices.iter().map(|v| Vec3::from(v.p)).collect();
    for (k, f) in faces.iter().enumerate() {
        if let Some(&bad) = f.idx.iter().find(|&&i| i < 0 || i as usize >= vertices.len()) {
            let msg = format!(
                "face {} refers to vertex {bad}, but there are {} vertices (counted from 0)",
                k + 1,
                vertices.len()
            );
            return Err(if ascii { Error::at(path, first_face_line + k, msg) } else { Error::file(path, msg) });
        }
        // Fan from the first vertex, as tobj triangulates OBJ polygons; points and lines are skipped.
        for i in 2..f.idx.len() {
            mesh.indices.push([f.idx[0] as u32, f.idx[i - 1] as u32, f.idx[i] as u32]);
        }
    }
    if mesh.indices.is_empty() {
        return Err(Error::at(
            path,
            element_line("face"),
            format!("contains no triangles: its {} faces all have fewer than 3 vertices", faces.len()),
        ));
    }
    mesh.face_material = vec![None; mesh.indices.len()];
    let all = |mask: u8| !vertices.is_empty() && vertices.iter().all(|v| v.has & mask == mask);
    let with_materials = content == Content::WithMaterials;
    if with_materials && all(0b1100_0000) {
        mesh.uvs = Some(vertices.iter().map(|v| Vec2::from(v.uv)).collect());
    }
    let file_normals = (with_materials && all(0b0011_1000)).then(|| {
        vertices
            .iter()
            .map(|v| {
                let n = Vec3::from(v.n);
                // Keep normals that are unit to f32 rounding (|n|^2 within 1e-5 of 1, a few ulps of
                // each component) bit for bit, so that a written PLY reads back identical.
                if (n.length_squared() - 1.0).abs() <= 1e-5 { n } else { n.normalize_or_zero() }
            })
            .collect()
    });
    mesh.finish(path, file_normals).map_err(|e| match (ascii, first_non_finite(&vertices)) {
        (true, Some(i)) => Error::at(
            path,
            header_lines + 1 + rows_before(&header, "vertex") + i,
            "a vertex value is not a finite number",
        ),
        _ => e,
    })?;
    Ok(mesh)
}

/// Old exporters (Blender 2.4x) write a free-text line into the header without `comment`.
/// Such lines are read as comments, with a warning; `None` when the header needs no change.
fn fix_header(path: &Path, bytes: &[u8], warnings: &mut Vec<String>) -> Option<Vec<u8>> {
    const KEYWORDS: &[&str] = &["ply", "format", "comment", "obj_info", "element", "property", "end_header"];
    let end = bytes.windows(10).position(|w| w == b"end_header")?;
    let header = std::str::from_utf8(&bytes[..end]).ok()?;
    let mut out = String::with_capacity(end + 64);
    let mut changed = false;
    for (i, line) in header.split_inclusive('\n').enumerate() {
        let first = line.split_whitespace().next();
        if i > 0 && first.is_some_and(|w| !KEYWORDS.contains(&w)) {
            warnings.push(format!("{}:{}: not a PLY header statement: read as a comment", path.display(), i + 1));
            out.push_str("comment ");
            changed = true;
        }
        out.push_str(line);
    }
    changed.then(|| [out.as_bytes(), &bytes[end..]].concat())
}

fn first_non_finite(vertices: &[Vertex]) -> Option<usize> {
    vertices.iter().position(|v| !(v.p.iter().chain(&v.uv).all(|x| x.is_finite())))
}

/// Rows of the elements before `name` (ASCII: one row per line).
fn rows_before(header: &Header, name: &str) -> usize {
    header.elements.iter().take_while(|(n, _)| n.as_str() != name).map(|(_, d)| d.count).sum()
}

/// Where a PLY file's payload starts: for errors that name the line of a row.
struct Payload<'a> {
    /// The file's bytes (after any header fix).
    bytes: &'a [u8],
    /// Length of the header in bytes.
    header_len: usize,
    /// Lines in the header.
    header_lines: usize,
}

/// The error for element `name` (defined by `def`) whose rows `ply-rs-bw` could not read (`e`).
fn payload_error(
    path: &Path,
    header: &Header,
    payload: &Payload,
    name: &str,
    def: &ElementDef,
    e: &std::io::Error,
) -> Error {
    match header.encoding {
        Encoding::Ascii => {
            let text = String::from_utf8_lossy(&payload.bytes[payload.header_len..]);
            match locate_ascii(&text, header) {
                Some((row, msg)) => Error::at(path, payload.header_lines + 1 + row, msg),
                None => Error::file(path, format!("element '{name}' ({} rows): {}", def.count, one_line(e))),
            }
        }
        enc => {
            let endian = if enc == Encoding::BinaryBigEndian { "big" } else { "little" };
            let why = if e.kind() == std::io::ErrorKind::UnexpectedEof {
                "the data ends before all its rows".to_string()
            } else {
                one_line(e)
            };
            Error::file(path, format!("binary {endian}-endian PLY, element '{name}' ({} rows): {why}", def.count))
        }
    }
}

fn check_scalar(t: &ScalarType, word: &str) -> std::result::Result<(), String> {
    let ok = match t {
        ScalarType::Char => word.parse::<i8>().is_ok(),
        ScalarType::UChar => word.parse::<u8>().is_ok(),
        ScalarType::Short => word.parse::<i16>().is_ok(),
        ScalarType::UShort => word.parse::<u16>().is_ok(),
        ScalarType::Int => word.parse::<i32>().is_ok(),
        ScalarType::UInt => word.parse::<u32>().is_ok(),
        ScalarType::Float => word.parse::<f32>().is_ok(),
        ScalarType::Double => word.parse::<f64>().is_ok(),
    };
    if ok { Ok(()) } else { Err(format!("'{word}' is not a {t:?} number")) }
}

/// The first ASCII payload row (from 0) that does not match the header, and why.
fn locate_ascii(text: &str, header: &Header) -> Option<(usize, String)> {
    let mut lines = text.lines();
    let mut row = 0;
    for (name, def) in &header.elements {
        for k in 0..def.count {
            let Some(line) = lines.next() else {
                return Some((row, format!("the file ends after {k} of the {} '{name}' rows", def.count)));
            };
            let mut words = line.split_whitespace();
            for (pname, p) in &def.properties {
                let mut next = |what: &str| {
                    words.next().ok_or_else(|| format!("'{name}' row {}: no value for {what} '{pname}'", k + 1))
                };
                let result = match &p.data_type {
                    PropertyType::Scalar(t) => next("property").and_then(|w| check_scalar(t, w)),
                    PropertyType::List(_, t) => next("the length of list").and_then(|w| {
                        let n: usize = w.parse().map_err(|_| format!("list length '{w}' is not a count"))?;
                        (0..n).try_for_each(|_| next("an item of list").and_then(|w| check_scalar(t, w)))
                    }),
                };
                if let Err(msg) = result {
                    return Some((row, msg));
                }
            }
            row += 1;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_bytes(name: &str, bytes: &[u8]) -> Result<Mesh> {
        let dir = std::env::temp_dir().join(format!("rtdiff-ply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        super::super::load_mesh(&p, Content::WithMaterials)
    }

    const HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

    #[test]
    fn ascii_quad_is_fan_triangulated() {
        let m = load_bytes("q.ply", format!("{HEAD}0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n").as_bytes()).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn ascii_errors_name_the_line() {
        let e =
            load_bytes("bad.ply", format!("{HEAD}0 0 0\n1 0 0\n1 1e+ 0\n0 1 0\n4 0 1 2 3\n").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("bad.ply:12: '1e+' is not a Float number"), "{e}");
        let e = load_bytes("idx.ply", format!("{HEAD}0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 9\n").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("idx.ply:14: face 1 refers to vertex 9"), "{e}");
        let e = load_bytes("short.ply", format!("{HEAD}0 0 0\n1 0 0\n").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("short.ply:12:") && e.to_string().contains("ends after 2"), "{e}");
    }

    #[test]
    fn point_cloud_is_a_clear_error() {
        let e = load_bytes("pc.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pc.ply:3: a point cloud"), "{e}");
    }
}
