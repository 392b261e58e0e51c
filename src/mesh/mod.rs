//! Triangle meshes as users have them: Wavefront OBJ (+ MTL), PLY, glTF 2.0 (`.gltf`,
//! `.glb`) and STL, plain or gzip-compressed, in any of the text encodings exporters
//! write. [`load_mesh`] is the one entry point; every reader returns the in-memory
//! [`Mesh`] defined here.

pub mod compressed;
pub mod encoding;
pub mod gltf;
pub mod mtl;
pub mod obj;
pub mod ply;
pub mod stl;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};

/// What a caller needs from a mesh file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Content {
    /// Triangles only: material libraries are not opened at all (`parity`, `trace`, `bench`, `bvh-stats`).
    Geometry,
    /// Triangles, normals, texture coordinates and the materials of the MTL libraries (`render`).
    WithMaterials,
}

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ (`.obj`, `.obj.gz`).
    Obj,
    /// Stanford PLY (`.ply`, `.ply.gz`), ASCII or binary.
    Ply,
    /// glTF 2.0: `.gltf` (JSON, with `.bin` files or data URIs) or `.glb` (binary).
    Gltf,
    /// STL (`.stl`, `.stl.gz`), ASCII or binary.
    Stl,
}

impl Format {
    /// The format named by `path`'s extension (a trailing `.gz` is looked through), if any.
    pub fn of(path: &Path) -> Option<Self> {
        let inner = if compressed::is_gzip_name(path) { Path::new(path.file_stem()?) } else { path };
        match inner.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "obj" => Some(Self::Obj),
            "ply" => Some(Self::Ply),
            "gltf" | "glb" => Some(Self::Gltf),
            "stl" => Some(Self::Stl),
            _ => None,
        }
    }
}

/// True when `path` names a mesh file rtdiff reads (`.obj`, `.ply`, `.gltf`, `.glb`, `.stl`, any with `.gz`).
pub fn is_mesh_file(path: &Path) -> bool {
    Format::of(path).is_some()
}

/// Load the mesh at `path` (OBJ, PLY, glTF, GLB or STL, optionally gzip-compressed). Faces are
/// triangulated as fans from their first vertex, in file order: triangle `i` of [`Mesh::indices`]
/// is the `i`-th triangle of the file, which is its primitive id in every output. Zero-area
/// triangles are kept in place (no ray hits them) and counted in [`Mesh::zero_area`]. Errors name
/// the file and, for text, the line and token;
/// problems with materials are [`Mesh::warnings`], never errors.
pub fn load_mesh(path: &Path, content: Content) -> Result<Mesh> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(Error::io(path, &e));
    }
    let bytes = compressed::read_bytes(path)?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(Error::file(path, "the file is empty: no vertices, no faces"));
    }
    let format = match Format::of(path) {
        Some(f) => f,
        None if bytes.starts_with(b"ply") => Format::Ply,
        None if bytes.starts_with(b"glTF") => Format::Gltf,
        None => {
            return Err(Error::file(
                path,
                "unsupported mesh file: expected .obj, .ply, .gltf, .glb or .stl (any may end in .gz)",
            ));
        }
    };
    let mesh = match format {
        Format::Obj => obj::load(path, encoding::decode_text(bytes).0, content),
        Format::Ply => ply::load(path, &bytes, content),
        Format::Gltf => gltf::load(path, &bytes, content),
        Format::Stl => stl::load(path, &bytes),
    }?;
    if mesh.indices.len() > crate::limits::MAX_PRIMITIVES {
        return Err(Error::file(
            path,
            format!("{} triangles, over the limit of {} primitives", mesh.indices.len(), crate::limits::MAX_PRIMITIVES),
        ));
    }
    Ok(mesh)
}

/// Where a material's texture was named: for errors that point at the MTL line.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSource {
    /// The material library.
    pub mtl: PathBuf,
    /// Line of the `map_Kd` statement (from 1).
    pub line: usize,
    /// The statement's arguments as written.
    pub written: String,
    /// The paths looked at, in order.
    pub tried: Vec<PathBuf>,
}

/// A material as read from an MTL file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlMaterial {
    /// Material name.
    pub name: String,
    /// Diffuse colour `Kd`.
    pub kd: Option<Vec3>,
    /// Specular colour `Ks`.
    pub ks: Option<Vec3>,
    /// Phong exponent `Ns`.
    pub ns: Option<f32>,
    /// Opacity: `d`, or `1 - Tr`.
    pub opacity: Option<f32>,
    /// Diffuse texture `map_Kd`, resolved relative to the MTL file.
    pub map_kd: Option<PathBuf>,
    /// Where `map_kd` was written, when it came from an MTL file.
    pub map_kd_source: Option<TextureSource>,
    /// How the texture addresses uvs outside [0, 1]: MTL `map_Kd -clamp on` clamps (it repeats
    /// otherwise); a glTF sampler's wrap mode.
    pub map_kd_wrap: crate::texture::WrapMode,
    /// A diffuse texture held in the mesh file itself (a glTF data URI or buffer view).
    pub map_kd_embedded: Option<EmbeddedImage>,
    /// A colour the texture's texels are multiplied by (glTF's base colour factor; an MTL's
    /// `map_Kd` replaces `Kd`, so `None` there).
    pub kd_texture_factor: Option<Vec3>,
}

/// An encoded image (PNG, JPEG) held inside a mesh file.
#[derive(Clone, Debug, PartialEq)]
pub struct EmbeddedImage {
    /// Its name in errors: `file.glb#images[0]`.
    pub name: String,
    /// The encoded bytes.
    pub bytes: std::sync::Arc<Vec<u8>>,
}

/// An indexed triangle mesh. `normals` and `uvs`, when present, are indexed like `positions`.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex normals from the file, or area-weighted averages of face normals.
    pub normals: Vec<Vec3>,
    /// True when `normals` came from the file.
    pub file_normals: bool,
    /// Per-vertex texture coordinates, if the file has them.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles in file order (faces fanned from their first vertex), zero-area ones included.
    pub indices: Vec<[u32; 3]>,
    /// Per-triangle index into `materials`.
    pub face_material: Vec<Option<u32>>,
    /// Materials from the MTL library.
    pub materials: Vec<MtlMaterial>,
    /// Number of zero-area triangles among `indices` (kept, so that ids stay file positions).
    pub zero_area: usize,
    /// Problems that did not stop the load, each `file:line: what` (materials, mixed faces).
    pub warnings: Vec<String>,
}

impl Mesh {
    /// Build a mesh from positions and triangles (no normals or uvs given):
    /// validates coordinates, counts zero-area triangles and computes vertex normals.
    pub fn from_triangles(path: &Path, positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Result<Self> {
        let mut m = Mesh { positions, indices, ..Default::default() };
        m.face_material = vec![None; m.indices.len()];
        m.validate(path)?;
        m.compute_normals();
        Ok(m)
    }

    /// Validate, count zero-area triangles, and take `file_normals` (indexed like
    /// `positions`) where they are finite and non-zero; elsewhere, and when there are none,
    /// area-weighted face normals.
    pub(crate) fn finish(&mut self, path: &Path, file_normals: Option<Vec<Vec3>>) -> Result<()> {
        self.validate(path)?;
        self.compute_normals();
        if let Some(n) = file_normals.filter(|n| n.len() == self.positions.len()) {
            for (dst, src) in self.normals.iter_mut().zip(n) {
                if src.is_finite() && src != Vec3::ZERO {
                    *dst = src;
                }
            }
            self.file_normals = true;
        }
        Ok(())
    }

    fn validate(&mut self, path: &Path) -> Result<()> {
        if let Some((i, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(Error::file(
                path,
                format!("vertex {} has a non-finite coordinate ({}, {}, {})", i + 1, p.x, p.y, p.z),
            ));
        }
        let n = self.positions.len() as u32;
        if let Some(f) = self.indices.iter().position(|t| t.iter().any(|&i| i >= n)) {
            return Err(Error::file(path, format!("face {} refers to a vertex that does not exist", f + 1)));
        }
        // Zero-area triangles stay where they are: a triangle's id is its position in the file.
        self.zero_area = self.indices.iter().filter(|t| zero_area(t.map(|i| self.positions[i as usize]))).count();
        if let Some(uvs) = &self.uvs
            && let Some(i) = uvs.iter().position(|t| !t.is_finite())
        {
            return Err(Error::file(path, format!("texture coordinate {} is not finite", i + 1)));
        }
        Ok(())
    }

    /// Replace `normals` by area-weighted averages of the adjacent face normals.
    pub fn compute_normals(&mut self) {
        // Products of coordinates beyond 2^60 (a file's raw vertices may be
        // anything finite; a transform brings them within the limits later)
        // would overflow f32: scale such a mesh by a power of two first, which
        // leaves the directions, and every ordinary mesh, bit for bit unchanged.
        let extent = self.positions.iter().fold(0f32, |m, p| m.max(p.abs().max_element()));
        let s = if extent > 2f32.powi(60) { crate::geometry::normalize::pow2_recip(extent) } else { 1.0 };
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let [a, b, c] = t.map(|i| self.positions[i as usize] * s);
            let n = (b - a).cross(c - a); // length = 2 * area
            for &i in t {
                acc[i as usize] += n;
            }
        }
        self.normals = acc.into_iter().map(crate::geometry::unit_or_zero).collect();
        self.file_normals = false;
    }

    /// The mesh's triangles as tracer primitives (in face order).
    pub fn to_primitives(&self) -> crate::geometry::Primitives {
        let triangles = self
            .indices
            .iter()
            .map(|t| crate::geometry::Triangle { v: t.map(|i| self.positions[i as usize]) })
            .collect();
        crate::geometry::Primitives { triangles, spheres: Vec::new() }
    }

    /// Apply `f` to every position (normals are recomputed or transformed by the caller).
    pub fn map_positions(&mut self, f: impl Fn(Vec3) -> Vec3) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }
}

/// True when the triangle `[a, b, c]` has zero area as computed in single precision
/// (`(b - a) x (c - a) = 0`): the triangles rtdiff counts and warns about.
pub fn zero_area([a, b, c]: [Vec3; 3]) -> bool {
    (b - a).cross(c - a) == Vec3::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("rtdiff-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn nan_vertex_is_an_error_naming_the_file() {
        let p = write("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
        let e = load_mesh(&p, Content::WithMaterials).unwrap_err().to_string();
        assert!(e.contains("nan.obj:2: 'nan' is not a finite number"), "{e}");
    }

    #[test]
    fn zero_area_triangles_keep_their_place_and_are_counted() {
        let p = write("degen.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 4\nf 1 2 3\n");
        let m = load_mesh(&p, Content::WithMaterials).unwrap();
        let corners: Vec<[Vec3; 3]> = m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])).collect();
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, 2.0 * Vec3::X);
        assert_eq!(corners, vec![[a, b, d], [a, b, c]], "file order, the zero-area triangle first");
        assert_eq!(m.zero_area, 1);
    }

    #[test]
    fn missing_file_says_not_found() {
        let e = load_mesh(Path::new("/nonexistent/assets/x.obj"), Content::Geometry).unwrap_err().to_string();
        assert!(e.contains("not found") && e.contains("fetch-assets.sh"), "{e}");
    }
}
