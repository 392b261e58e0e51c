//! The triangles of a scene's `meshes[]` entries: each mesh file read once
//! (several entries may name the same file), then placed (normalised and
//! transformed) per entry, with per-triangle shading data and materials.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat3, Vec2};

use crate::error::{Error, Result};
use crate::geometry::Triangle;
use crate::mesh::{Content, Mesh};

use super::TriangleShading;
use super::file::MeshSpec;
use super::materials::MaterialTable;
use super::validate;

/// Mesh files read once per scene, keyed by canonical path and load options.
#[derive(Default)]
pub(crate) struct MeshCache {
    loaded: HashMap<(PathBuf, Content), Arc<Mesh>>,
}

impl MeshCache {
    /// The mesh at `path`, read on first use; `fresh` is true on that first use.
    pub(crate) fn load(&mut self, path: &Path, content: Content) -> Result<(Arc<Mesh>, bool)> {
        // A path that cannot be resolved goes to the reader as written, which names the problem.
        let key = (std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()), content);
        if let Some(m) = self.loaded.get(&key) {
            return Ok((m.clone(), false));
        }
        let mesh = Arc::new(crate::mesh::load_mesh(path, content)?);
        self.loaded.insert(key, mesh.clone());
        Ok((mesh, true))
    }
}

/// The triangles of every mesh entry, in entry order, with their shading data.
#[derive(Default)]
pub(crate) struct MeshTriangles {
    /// The triangles as the tracers see them.
    pub triangles: Vec<Triangle>,
    /// Shading data, one per triangle.
    pub shading: Vec<TriangleShading>,
    /// The primitive id of each entry's first triangle (entry `m`'s triangle `k` is `mesh_starts[m] + k`).
    pub mesh_starts: Vec<u32>,
    /// Zero-area triangles (kept in place), summed over the entries.
    pub zero_area: usize,
    /// Problems in the mesh files that did not stop the load (each file's once).
    pub warnings: Vec<String>,
}

/// Load the `meshes[]` entries `specs` (files relative to `dir`; errors name the scene file `path`),
/// adding their MTL materials to `materials`.
pub(crate) fn load_meshes(
    specs: &[MeshSpec],
    dir: &Path,
    path: &Path,
    materials: &mut MaterialTable,
) -> Result<MeshTriangles> {
    let mut cache = MeshCache::default();
    let mut out = MeshTriangles::default();
    for (mi, spec) in specs.iter().enumerate() {
        let (file_mesh, fresh) = cache
            .load(&dir.join(&spec.file), Content::WithMaterials)
            .map_err(|e| Error::file(path, format!("meshes[{mi}].file: {e}")))?;
        if fresh {
            out.warnings.extend(file_mesh.warnings.iter().cloned());
        }
        out.zero_area += file_mesh.zero_area;
        let what = format!("meshes[{mi}] ({})", spec.file);
        validate::check_primitive_total(path, &what, out.triangles.len(), file_mesh.indices.len())?;
        let mut mesh = Mesh::clone(&file_mesh);
        place_mesh(&mut mesh, spec);
        validate::check_mesh_bounds(path, &format!("meshes[{mi}]"), &spec.file, &mesh.positions)?;
        let ids = entry_materials(mi, spec, &mesh, materials, path)?;
        out.mesh_starts.push(out.triangles.len() as u32);
        push_triangles(&mesh, &ids, &mut out);
    }
    Ok(out)
}

/// Material of each face of a mesh entry: one forced for the whole entry, or
/// per MTL material (an override by name, else the MTL material itself).
struct EntryMaterials {
    forced: Option<u32>,
    mtl: Vec<u32>,
}

fn entry_materials(
    mi: usize,
    spec: &MeshSpec,
    mesh: &Mesh,
    materials: &mut MaterialTable,
    path: &Path,
) -> Result<EntryMaterials> {
    let forced = match &spec.material {
        Some(name) => Some(materials.lookup(name, &format!("mesh {} ({})", mi + 1, spec.file))?),
        None => None,
    };
    let mut mtl = Vec::with_capacity(mesh.materials.len());
    for m in &mesh.materials {
        let id = match spec.material_overrides.get(&m.name) {
            Some(name) => materials.lookup(name, &format!("mesh {} material override", mi + 1))?,
            None => {
                materials.add_mtl(m).map_err(|e| Error::file(path, format!("meshes[{mi}] ({}): {e}", spec.file)))?
            }
        };
        mtl.push(id);
    }
    Ok(EntryMaterials { forced, mtl })
}

/// Append the placed `mesh`'s triangles and their shading data to `out`.
fn push_triangles(mesh: &Mesh, ids: &EntryMaterials, out: &mut MeshTriangles) {
    for (f, t) in mesh.indices.iter().enumerate() {
        let material = ids.forced.or_else(|| mesh.face_material[f].map(|i| ids.mtl[i as usize])).unwrap_or(0);
        let uvs = mesh.uvs.as_ref().map(|uv| t.map(|i| uv[i as usize]));
        out.triangles.push(Triangle { v: t.map(|i| mesh.positions[i as usize]) });
        out.shading.push(TriangleShading {
            normals: t.map(|i| mesh.normals[i as usize]),
            uvs: uvs.unwrap_or([Vec2::ZERO; 3]),
            has_uvs: uvs.is_some(),
            material,
        });
    }
}

/// Normalise (optionally) and transform a mesh in place, normals included.
fn place_mesh(mesh: &mut Mesh, spec: &MeshSpec) {
    if spec.normalize {
        crate::geometry::normalize_to_unit_sphere(&mut mesh.positions);
    }
    if let Some(t) = &spec.transform {
        let r = t.rotate * (std::f32::consts::PI / 180.0);
        let rot = Mat3::from_rotation_z(r.z) * Mat3::from_rotation_y(r.y) * Mat3::from_rotation_x(r.x);
        let linear = rot * Mat3::from_diagonal(t.scale);
        mesh.map_positions(|p| linear * p + t.translate);
        transform_normals(&mut mesh.normals, linear);
        if linear.as_dmat3().determinant() < 0.0 {
            // A mirroring transform flips the winding: keep geometric normals consistent with shading normals.
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
        }
    }
}

/// Transform unit normals by the inverse transpose of `linear`. Where that
/// overflows in f32 (the determinant of scales like 1e-19 underflows, a zero
/// scale has none), the cofactor matrix in f64 gives the same directions
/// (`inverse^T = cofactor / det`; the sign of the determinant kept), with a
/// zero scale flattening the normals onto that axis.
fn transform_normals(normals: &mut [glam::Vec3], linear: Mat3) {
    let normal_matrix = linear.inverse().transpose();
    if normal_matrix.is_finite() {
        for n in normals {
            *n = crate::geometry::unit_or_zero(normal_matrix * *n);
        }
        return;
    }
    let l = linear.as_dmat3();
    let (a, b, c) = (l.x_axis, l.y_axis, l.z_axis);
    let sign = if l.determinant() < 0.0 { -1.0 } else { 1.0 };
    let cofactor = glam::DMat3::from_cols(b.cross(c), c.cross(a), a.cross(b)) * sign;
    for n in normals {
        *n = (cofactor * n.as_dvec3()).normalize_or_zero().as_vec3();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rtdiff-meshcache-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("sub")).unwrap();
        d
    }

    #[test]
    fn a_file_named_twice_is_read_once() {
        let d = temp("once");
        std::fs::write(d.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let mut cache = MeshCache::default();
        let (a, fresh_a) = cache.load(&d.join("t.obj"), Content::WithMaterials).unwrap();
        // The same file through another spelling of its path.
        let (b, fresh_b) = cache.load(&d.join("sub/../t.obj"), Content::WithMaterials).unwrap();
        assert!(fresh_a && !fresh_b);
        assert!(Arc::ptr_eq(&a, &b));
        // Other load options are another read.
        let (c, fresh_c) = cache.load(&d.join("t.obj"), Content::Geometry).unwrap();
        assert!(fresh_c && !Arc::ptr_eq(&a, &c));
        // A missing file is an error naming it.
        let e = cache.load(&d.join("missing.obj"), Content::WithMaterials).unwrap_err().to_string();
        assert!(e.contains("missing.obj"), "{e}");
        // Rewriting the file after its first read does not change what the scene sees.
        std::fs::write(d.join("t.obj"), "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n").unwrap();
        let (e, fresh_e) = cache.load(&d.join("t.obj"), Content::WithMaterials).unwrap();
        assert!(!fresh_e && Arc::ptr_eq(&a, &e));
        let _ = std::fs::remove_dir_all(&d);
    }
}
