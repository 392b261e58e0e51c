//! Loading triangle meshes from Wavefront OBJ (+ MTL) files, with validation.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};

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
    /// Triangles (degenerate ones already removed).
    pub indices: Vec<[u32; 3]>,
    /// Per-triangle index into `materials`.
    pub face_material: Vec<Option<u32>>,
    /// Materials from the MTL library.
    pub materials: Vec<MtlMaterial>,
    /// Number of zero-area triangles that were dropped.
    pub degenerate_skipped: usize,
}

impl Mesh {
    /// Build a mesh from positions and triangles (no normals or uvs given):
    /// validates coordinates, drops degenerate triangles and computes vertex normals.
    pub fn from_triangles(path: &Path, positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Result<Self> {
        let mut m = Mesh { positions, indices, ..Default::default() };
        m.face_material = vec![None; m.indices.len()];
        m.validate(path)?;
        m.compute_normals();
        Ok(m)
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
        let before = self.indices.len();
        let mut keep_mat = Vec::with_capacity(before);
        let mut keep = Vec::with_capacity(before);
        for (t, m) in self.indices.iter().zip(&self.face_material) {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            if (b - a).cross(c - a) != Vec3::ZERO {
                keep.push(*t);
                keep_mat.push(*m);
            }
        }
        self.degenerate_skipped = before - keep.len();
        self.indices = keep;
        self.face_material = keep_mat;
        if let Some(uvs) = &self.uvs
            && let Some(i) = uvs.iter().position(|t| !t.is_finite())
        {
            return Err(Error::file(path, format!("texture coordinate {} is not finite", i + 1)));
        }
        Ok(())
    }

    /// Replace `normals` by area-weighted averages of the adjacent face normals.
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a); // length = 2 * area
            for &i in t {
                acc[i as usize] += n;
            }
        }
        self.normals = acc.into_iter().map(|n| n.normalize_or_zero()).collect();
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

/// Load an OBJ file (and its MTL library, if any). Faces are triangulated;
/// zero-area triangles are dropped and counted in [`Mesh::degenerate_skipped`].
pub fn load_obj(path: &Path) -> Result<Mesh> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(Error::io(path, &e));
    }
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, mtl) = tobj::load_obj(path, &opts).map_err(|e| Error::file(path, format!("cannot parse OBJ: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let materials = match mtl {
        Ok(ms) => ms.into_iter().map(|m| convert_material(m, dir)).collect(),
        Err(tobj::LoadError::GenericFailure) if models.iter().all(|m| m.mesh.material_id.is_none()) => Vec::new(),
        Err(e) => return Err(Error::file(path, format!("cannot load its material library: {e}"))),
    };
    let mut mesh = Mesh { materials, ..Default::default() };
    let all_normals = models.iter().all(|m| !m.mesh.normals.is_empty() || m.mesh.positions.is_empty());
    let all_uvs = models.iter().all(|m| !m.mesh.texcoords.is_empty() || m.mesh.positions.is_empty());
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
        if m.indices.len() % 3 != 0 {
            return Err(Error::file(
                path,
                format!("object '{}' has a face that is not a triangle after triangulation", model.name),
            ));
        }
        let mat = m.material_id.map(|i| i as u32);
        if let Some(i) = mat
            && i as usize >= mesh.materials.len()
        {
            return Err(Error::file(
                path,
                format!("object '{}' uses a material missing from its MTL file", model.name),
            ));
        }
        for t in m.indices.chunks_exact(3) {
            mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
            mesh.face_material.push(mat);
        }
    }
    if mesh.indices.is_empty() {
        return Err(Error::file(path, "contains no triangles"));
    }
    if all_uvs && !uvs.is_empty() {
        mesh.uvs = Some(uvs);
    }
    mesh.validate(path)?;
    if all_normals && !normals.is_empty() && normals.iter().all(|n| n.is_finite() && *n != Vec3::ZERO) {
        mesh.normals = normals;
        mesh.file_normals = true;
    } else {
        mesh.compute_normals();
    }
    Ok(mesh)
}

fn convert_material(m: tobj::Material, dir: &Path) -> MtlMaterial {
    let opacity =
        m.dissolve.or_else(|| m.unknown_param.get("Tr").and_then(|t| t.trim().parse::<f32>().ok()).map(|tr| 1.0 - tr));
    MtlMaterial {
        name: m.name,
        kd: m.diffuse.map(Vec3::from),
        ks: m.specular.map(Vec3::from),
        ns: m.shininess,
        opacity,
        map_kd: m.diffuse_texture.map(|t| dir.join(t.trim())),
    }
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
        let e = load_obj(&p).unwrap_err().to_string();
        assert!(e.contains("nan.obj") && e.contains("vertex 2"), "{e}");
    }

    #[test]
    fn degenerate_triangles_are_skipped_and_counted() {
        let p = write("degen.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
        let m = load_obj(&p).unwrap();
        assert_eq!((m.indices.len(), m.degenerate_skipped), (1, 1));
    }

    #[test]
    fn missing_file_says_not_found() {
        let e = load_obj(Path::new("/nonexistent/assets/x.obj")).unwrap_err().to_string();
        assert!(e.contains("not found") && e.contains("fetch-assets.sh"), "{e}");
    }
}
