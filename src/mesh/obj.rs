//! Wavefront OBJ meshes, parsed by tobj. tobj reports no line numbers, so when it
//! rejects a file a second pass over the lines (`locate`) finds the first line that
//! breaks tobj's rules and names it with the offending token. The same pass catches what
//! tobj accepts silently but is wrong (texture or normal index 0).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::{Content, Mesh, MtlMaterial, mtl};
use crate::error::{Error, Result};

/// A material library read while parsing: where it is, its `map_Kd` lines, and the
/// range of tobj's merged material indices it fills.
struct LoadedLibrary {
    path: PathBuf,
    map_kd: HashMap<String, (usize, String)>,
    first: usize,
    count: usize,
}

/// Load OBJ `text` (decoded, `\n` line ends) read from `path`.
pub(crate) fn load(path: &Path, text: String, content: Content) -> Result<Mesh> {
    let with_materials = content == Content::WithMaterials;
    let mut warnings = Vec::new();
    let text = fix_usemtl(path, text, with_materials.then_some(&mut warnings));
    let dir = path.parent().unwrap_or(Path::new("."));
    let libraries = RefCell::new(Vec::<LoadedLibrary>::new());
    let lib_warnings = RefCell::new(Vec::<String>::new());
    let loader = |written: &Path| -> tobj::MTLLoadResult {
        if !with_materials {
            return Ok((Vec::new(), Default::default()));
        }
        let written = written.to_string_lossy();
        let mtl_path = dir.join(mtl::texture_file_name(&written));
        let line = find_line(&text, |l| l.trim_start().starts_with("mtllib") && l.contains(written.as_ref()));
        let mut w = lib_warnings.borrow_mut();
        match mtl::load(&mtl_path, &mut w) {
            Ok(lib) => {
                let mut libs = libraries.borrow_mut();
                let first = libs.last().map_or(0, |l| l.first + l.count);
                libs.push(LoadedLibrary { path: mtl_path, map_kd: lib.map_kd, first, count: lib.materials.len() });
                Ok((lib.materials, lib.names.into_iter().collect()))
            }
            Err(msg) => {
                w.push(format!("{}:{line}: mtllib '{written}': {msg}: faces use the default material", path.display()));
                Err(tobj::LoadError::GenericFailure)
            }
        }
    };
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let parsed = tobj::load_obj_buf(&mut text.as_bytes(), &opts, loader);
    let (models, tobj_materials) = match parsed {
        Ok(r) => r,
        Err(e) => {
            return Err(match locate(&text) {
                Some((line, msg)) => Error::at(path, line, msg),
                None => Error::file(path, format!("cannot parse OBJ: {e}")),
            });
        }
    };
    // tobj takes texture and normal index 0 for "absent"; OBJ counts from 1, so it is an error.
    if text.contains("/0")
        && let Some((line, msg)) = locate(&text)
    {
        return Err(Error::at(path, line, msg));
    }
    warnings.extend(lib_warnings.into_inner());
    let libraries = libraries.into_inner();
    let materials: Vec<MtlMaterial> = tobj_materials
        .unwrap_or_default()
        .into_iter()
        .enumerate()
        .map(|(i, m)| match libraries.iter().find(|l| (l.first..l.first + l.count).contains(&i)) {
            Some(lib) => {
                let source = lib.map_kd.get(&m.name);
                mtl::convert(m, &lib.path, source)
            }
            None => mtl::convert(m, path, None),
        })
        .collect();

    let mut mesh = Mesh { materials, ..Default::default() };
    // A model whose faces mix `f a/b` and `f a` has fewer texture coordinates (or normals)
    // than vertices: tobj skips the missing ones, so they cannot be matched up again.
    let mixed_uvs =
        models.iter().any(|m| !m.mesh.texcoords.is_empty() && m.mesh.texcoords.len() / 2 != m.mesh.positions.len() / 3);
    let mixed_normals =
        models.iter().any(|m| !m.mesh.normals.is_empty() && m.mesh.normals.len() / 3 != m.mesh.positions.len() / 3);
    if (mixed_uvs || mixed_normals) && with_materials {
        let line = first_mixed_face(&text).unwrap_or(0);
        let what = match (mixed_uvs, mixed_normals) {
            (true, true) => "texture coordinates and normals",
            (true, false) => "texture coordinates",
            _ => "normals",
        };
        warnings.push(format!(
            "{}:{line}: faces with and without {what} in one object: the mesh is loaded without file {what}",
            path.display()
        ));
    }
    let all_normals =
        !mixed_normals && models.iter().all(|m| !m.mesh.normals.is_empty() || m.mesh.positions.is_empty());
    let all_uvs = !mixed_uvs && models.iter().all(|m| !m.mesh.texcoords.is_empty() || m.mesh.positions.is_empty());
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        if all_normals {
            normals.extend(m.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2]).normalize_or_zero()));
        }
        if all_uvs {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
        }
        let mat = m.material_id.map(|i| i as u32).filter(|&i| (i as usize) < mesh.materials.len());
        for t in m.indices.chunks_exact(3) {
            mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
            mesh.face_material.push(mat);
        }
    }
    if with_materials {
        unknown_usemtl(path, &text, &mesh.materials, &mut warnings);
    }
    if mesh.indices.is_empty() {
        let is_v = |l: &str| l.split_whitespace().next() == Some("v");
        let points = text.split('\n').filter(|l| is_v(l)).count();
        let last = text.split('\n').enumerate().filter(|(_, l)| is_v(l)).last().map_or(1, |(i, _)| i + 1);
        return Err(Error::at(
            path,
            last,
            format!(
                "no triangles: {points} vertices (the last one here) but no face of 3 or more of them: points and lines cannot be traced"
            ),
        ));
    }
    if all_uvs && !uvs.is_empty() {
        mesh.uvs = Some(uvs);
    }
    let file_normals = (all_normals && !normals.is_empty()).then_some(normals);
    mesh.warnings = warnings;
    // Non-finite numbers parse in tobj; name their line rather than the renumbered vertex.
    mesh.finish(path, file_normals).map_err(|e| match locate(&text) {
        Some((line, msg)) => Error::at(path, line, msg),
        None => e,
    })?;
    Ok(mesh)
}

/// The number of the first line (from 1) for which `pred` holds, 0 when none.
fn find_line(text: &str, pred: impl Fn(&str) -> bool) -> usize {
    text.split('\n').position(pred).map_or(0, |i| i + 1)
}

/// tobj refuses a whole file for a `usemtl` without a name, and reads the name only after a
/// space; it also reads polylines as faces. Rewrite such lines: a name after a tab keeps its name; no name gets one that no
/// library defines (the default material), with a warning when materials are wanted.
fn fix_usemtl(path: &Path, text: String, mut warnings: Option<&mut Vec<String>>) -> String {
    let mut fixes = Vec::new();
    // tobj reads `l a b c d` (a polyline) as a face; rtdiff traces surfaces only, so line
    // statements become comments (same line count).
    if text.starts_with("l ") || text.starts_with("l\t") || text.contains("\nl ") || text.contains("\nl\t") {
        let mut start = 0;
        for line in text.split_inclusive('\n') {
            if line.split_whitespace().next() == Some("l") {
                let body = line.trim_end_matches('\n');
                fixes.push((start, start + body.len(), format!("#{}", &body[1..])));
            }
            start += line.len();
        }
    }
    for (at, _) in text.match_indices("usemtl") {
        let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
        let end = text[at..].find('\n').map_or(text.len(), |i| at + i);
        let line = &text[start..end];
        if !text[start..at].trim().is_empty() || line.split_whitespace().next() != Some("usemtl") {
            continue;
        }
        if !line.split_once(' ').unwrap_or_default().1.trim().is_empty() {
            continue;
        }
        let name = line.trim_start()["usemtl".len()..].trim();
        let fixed = if name.is_empty() {
            if let Some(w) = warnings.as_deref_mut() {
                let n = text[..start].matches('\n').count() + 1;
                w.push(format!(
                    "{}:{n}: 'usemtl' without a material name: the faces that follow use the default material",
                    path.display()
                ));
            }
            "usemtl \u{1}no material".to_string()
        } else {
            format!("usemtl {name}")
        };
        fixes.push((start, end, fixed));
    }
    if fixes.is_empty() {
        return text;
    }
    fixes.sort_by_key(|f| f.0);
    let mut out = String::with_capacity(text.len() + fixes.len() * 16);
    let mut last = 0;
    for (start, end, fixed) in fixes {
        out.push_str(&text[last..start]);
        out.push_str(&fixed);
        last = end;
    }
    out.push_str(&text[last..]);
    out
}

/// Warn about each `usemtl` naming a material that no library defines (first line of each name).
fn unknown_usemtl(path: &Path, text: &str, materials: &[MtlMaterial], warnings: &mut Vec<String>) {
    let mut seen: Vec<&str> = Vec::new();
    for (at, _) in text.match_indices("usemtl") {
        let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
        let end = text[at..].find('\n').map_or(text.len(), |i| at + i);
        if !text[start..at].trim().is_empty() {
            continue;
        }
        let name = text[at + "usemtl".len()..end].trim();
        if name.is_empty() || name.starts_with('\u{1}') || seen.contains(&name) {
            continue;
        }
        seen.push(name);
        if !materials.iter().any(|m| m.name == name) {
            let n = text[..start].matches('\n').count() + 1;
            warnings.push(format!(
                "{}:{n}: usemtl '{name}' names no material of the material libraries: its faces use the default material",
                path.display()
            ));
        }
    }
}

/// The first face line whose vertices are written in a different form (with or without
/// texture coordinate, with or without normal) from the faces before it in the same object.
fn first_mixed_face(text: &str) -> Option<usize> {
    let mut form: Option<(bool, bool)> = None;
    for (i, line) in text.split('\n').enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("o" | "g" | "usemtl") => form = None,
            Some("f") => {
                for tok in w {
                    let mut parts = tok.split('/');
                    parts.next();
                    let vt = parts.next().is_some_and(|p| !p.is_empty());
                    let vn = parts.next().is_some_and(|p| !p.is_empty());
                    match form {
                        None => form = Some((vt, vn)),
                        Some(f) if f != (vt, vn) => return Some(i + 1),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// The first line that tobj rejects (or that holds an index 0, which tobj takes for
/// "absent"), with what is wrong there. Mirrors tobj 4.0's rules.
pub(crate) fn locate(text: &str) -> Option<(usize, String)> {
    let mut totals = [0usize; 3];
    for line in text.split('\n') {
        match line.split_whitespace().next() {
            Some("v") => totals[0] += 1,
            Some("vt") => totals[1] += 1,
            Some("vn") => totals[2] += 1,
            _ => {}
        }
    }
    let mut counts = [0usize; 3];
    for (i, line) in text.split('\n').enumerate() {
        let mut words = line.split_whitespace();
        let problem = match words.next() {
            Some("v") => {
                counts[0] += 1;
                check_vertex(words)
            }
            Some("vt") => {
                counts[1] += 1;
                check_floats(words, 2, "a texture coordinate")
            }
            Some("vn") => {
                counts[2] += 1;
                check_floats(words, 3, "a normal")
            }
            Some(w @ ("f" | "l")) => check_face(w, words, &counts, &totals),
            Some("usemtl") if line.split_once(' ').unwrap_or_default().1.trim().is_empty() => {
                Some("'usemtl' without a material name".into())
            }
            _ => None,
        };
        if let Some(msg) = problem {
            return Some((i + 1, msg));
        }
    }
    None
}

fn parse_number(word: &str) -> std::result::Result<f32, String> {
    match word.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(format!("'{word}' is not a finite number")),
        Err(_) => Err(format!("'{word}' is not a number")),
    }
}

fn check_floats<'a>(words: impl Iterator<Item = &'a str>, n: usize, what: &str) -> Option<String> {
    let w: Vec<&str> = words.take(n).collect();
    if w.len() < n {
        return Some(format!("{what} needs {n} numbers, found {}", w.len()));
    }
    w.iter().find_map(|x| parse_number(x).err())
}

fn check_vertex<'a>(mut words: impl Iterator<Item = &'a str>) -> Option<String> {
    let coords: Vec<&str> = words.by_ref().take(3).collect();
    if coords.len() < 3 {
        return Some(format!("a vertex needs 3 coordinates, found {}", coords.len()));
    }
    if let Some(e) = coords.iter().find_map(|x| parse_number(x).err()) {
        return Some(e);
    }
    let extra: Vec<&str> = words.collect();
    match extra.as_slice() {
        [] => None,
        [w] => match parse_number(w) {
            Ok(0.0) => Some(format!("vertex weight w is '{w}': a division by zero")),
            Ok(_) => None,
            Err(e) => Some(e),
        },
        [_, _, _] => None,
        _ => Some(format!(
            "a vertex has {} numbers: expected 3 coordinates, then nothing, a weight w or a colour r g b",
            3 + extra.len()
        )),
    }
}

fn check_face<'a>(
    kind: &str,
    words: impl Iterator<Item = &'a str>,
    counts: &[usize; 3],
    totals: &[usize; 3],
) -> Option<String> {
    const NAMES: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let toks: Vec<&str> = words.collect();
    if toks.is_empty() {
        return Some(format!("'{kind}' with no vertices"));
    }
    for tok in &toks {
        let parts: Vec<&str> = tok.split('/').collect();
        if parts.len() > 3 {
            return Some(format!("'{tok}' has more than three indices (v/vt/vn)"));
        }
        for (k, part) in parts.iter().enumerate() {
            if part.is_empty() {
                if k == 0 {
                    return Some(format!("'{tok}' has no vertex index"));
                }
                continue;
            }
            let Ok(x) = part.parse::<isize>() else {
                return Some(format!("'{tok}': '{part}' is not an index"));
            };
            if x == 0 {
                return Some(format!("'{tok}': {} index 0 is not valid (OBJ counts from 1)", NAMES[k]));
            }
            // Only faces of 3 or more vertices are used (points and lines are skipped), and tobj
            // checks texture and normal indices only when the file has any.
            let checked = toks.len() >= 3 && (k == 0 || totals[k] > 0);
            if checked && x < 0 && (counts[k] as isize + x) < 0 {
                return Some(format!(
                    "'{tok}': relative {} index {x} reaches before the first one ({} so far)",
                    NAMES[k], counts[k]
                ));
            }
            if checked && x > 0 && x as usize > totals[k] {
                return Some(format!("'{tok}': {} index {x} is out of range (the file has {})", NAMES[k], totals[k]));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_names_the_bad_token() {
        let text = "v 0 0 0\nv 1 2. 3.0\n\nv 1e+2 2.e+1 3.1+e2\nf 1 2 3\n";
        assert_eq!(locate(text), Some((4, "'3.1+e2' is not a number".into())));
        assert_eq!(locate("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap().0, 4);
        assert!(locate("v 0 0 0\nvt 0 0\nf 1/0 1/1 1/1\n").unwrap().1.contains("index 0"));
        assert!(locate("v 0 0 0\nf\n").unwrap().1.contains("no vertices"));
        assert_eq!(locate("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), None);
    }

    #[test]
    fn mixed_faces_found() {
        assert_eq!(first_mixed_face("f 1/1 2/2 3/3\nf 1 2 3\n"), Some(2));
        assert_eq!(first_mixed_face("o a\nf 1/1 2/2 3/3\no b\nf 1 2 3\n"), None);
    }
}
