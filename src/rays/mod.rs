//! Ray workloads, one module that `bench`, `parity`, `race`, `trace` and the
//! tests all draw from: seeded ray sets (ordinary workloads and rays built to
//! break a tracer), the context they are generated from (primitives, camera,
//! lights), and the loaders that turn a scene file or a mesh into that context.

pub mod aimed;
pub mod context;
pub mod file;
pub mod near_grazing;
pub mod rng;
pub mod sets;
pub mod topology;
pub mod workload;

pub use aimed::front_facing_rays;
pub use context::{CameraFn, DEFAULT_IMAGE, DEFAULT_LIGHT, LightFn, RayContext};
pub use rng::Rng;
pub use sets::{RaySet, RayTag, SetKind, generate, scene_scale};
pub use topology::Topology;
pub use workload::{incoherent_rays, mixed_rays, shadow_rays};

use std::path::Path;
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::geometry::Primitives;

/// A mesh (`.obj`, `.ply`, `.gltf`, `.glb`, `.stl`, optionally `.gz`) normalised to the unit sphere (mean of the vertices at the
/// origin, farthest vertex at distance 1) by
/// [`crate::geometry::normalize_to_unit_sphere`], the same function a scene's
/// `"normalize": true` uses: `bench`, `parity`, `trace` and `render` trace the
/// same vertices to the bit.
pub fn load_normalized_mesh(path: &Path) -> Result<Arc<Primitives>> {
    load_normalized_mesh_counted(path).map(|(prims, _)| prims)
}

/// [`load_normalized_mesh`], also returning the number of zero-area triangles among its triangles
/// (kept in place, so that primitive ids are triangle positions in the file).
pub fn load_normalized_mesh_counted(path: &Path) -> Result<(Arc<Primitives>, usize)> {
    let mut mesh = crate::mesh::load_mesh(path, crate::mesh::Content::Geometry)?;
    crate::geometry::normalize_to_unit_sphere(&mut mesh.positions);
    // A mesh whose every triangle has zero area loads (nothing can be hit): the caller warns
    // with the count (`trace`, `parity`); a mesh with no triangles at all is an error.
    if mesh.indices.is_empty() {
        return Err(Error::file(path, "the mesh has no triangles"));
    }
    Ok((Arc::new(mesh.to_primitives()), mesh.zero_area))
}

/// The scene a harness command runs on: a scene file (`.json`, through
/// [`crate::scene::Scene::load`]: its primitives, camera, image size and
/// lights), or a mesh (`.obj`, `.ply`, `.gltf`, `.glb`, `.stl`, optionally `.gz`) normalised by [`load_normalized_mesh`] with the
/// default camera and point light.
pub fn load_context(path: &Path) -> Result<RayContext> {
    load_context_counted(path).map(|(ctx, _)| ctx)
}

/// [`load_context`], also returning the number of zero-area triangles (kept in place).
pub fn load_context_counted(path: &Path) -> Result<(RayContext, usize)> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        _ if crate::mesh::is_mesh_file(path) => {
            let (prims, skipped) = load_normalized_mesh_counted(path)?;
            Ok((RayContext::with_defaults(prims), skipped))
        }
        Some("json") => {
            let scene = crate::scene::Scene::load(path)?;
            let skipped = scene.zero_area;
            let camera = scene.camera.clone();
            let lights = Arc::new(scene.lights);
            let ctx = RayContext {
                prims: scene.prims,
                camera: Arc::new(move |x, y| camera.ray(x, y)),
                image: (scene.width, scene.height),
                lights: (0..lights.len())
                    .map(|i| {
                        let lights = Arc::clone(&lights);
                        Arc::new(move |u, v| lights[i].position_at(u, v)) as LightFn
                    })
                    .collect(),
            };
            Ok((ctx, skipped))
        }
        _ => Err(Error::file(
            path,
            "unsupported scene file: expected a scene .json or a mesh: .obj, .ply, .gltf, .glb, .stl (optionally .gz)",
        )),
    }
}

/// [`load_context_counted`] in the coordinates of the file, for tracers that read it
/// themselves (`rtdiff rays`, `rtdiff judge`, `rtdiff trace --file-coordinates`): a mesh
/// keeps its vertices as written (not normalised), with the default camera and light of
/// [`RayContext::with_defaults`] carried from the unit sphere into the file's coordinates
/// (the inverse of [`crate::geometry::normalize::unit_sphere_map`]); a scene file is
/// what [`load_context_counted`] gives.
pub fn load_context_file_coordinates(path: &Path) -> Result<(RayContext, usize)> {
    if !crate::mesh::is_mesh_file(path) {
        return load_context_counted(path);
    }
    let mesh = crate::mesh::load_mesh(path, crate::mesh::Content::Geometry)?;
    if mesh.indices.is_empty() {
        return Err(Error::file(path, "the mesh has no triangles"));
    }
    let (c, s) = crate::geometry::normalize::unit_sphere_map(&mesh.positions).expect("a mesh with triangles");
    let unit = RayContext::with_defaults(Arc::new(Primitives::default()));
    let to_file = move |p: glam::Vec3| (p.as_dvec3() / s + c).as_vec3();
    let cam = unit.camera.clone();
    let camera: CameraFn = Arc::new(move |x, y| {
        let r = cam(x, y);
        crate::geometry::Ray::with_range(to_file(r.origin), r.dir, r.t_min / s as f32, r.t_max / s as f32)
    });
    let lights = unit
        .lights
        .iter()
        .map(|l| {
            let l = l.clone();
            Arc::new(move |u, v| to_file(l(u, v))) as LightFn
        })
        .collect();
    let ctx = RayContext { prims: Arc::new(mesh.to_primitives()), camera, image: unit.image, lights };
    Ok((ctx, mesh.zero_area))
}

/// Load the primitives of `path`: a mesh (`.obj`, `.ply`, `.gltf`, `.glb`, `.stl`, optionally `.gz`; with `normalize`, through
/// [`load_normalized_mesh`]; otherwise as is), anything else as a scene file.
pub fn load_primitives(path: &Path, normalize: bool) -> Result<Arc<Primitives>> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        _ if normalize && crate::mesh::is_mesh_file(path) => {
            let (prims, zero_area) = load_normalized_mesh_counted(path)?;
            if zero_area == prims.triangles.len() {
                return Err(Error::file(path, "the mesh has no triangles of non-zero area"));
            }
            Ok(prims)
        }
        _ if crate::mesh::is_mesh_file(path) => {
            let mesh = crate::mesh::load_mesh(path, crate::mesh::Content::Geometry)?;
            if mesh.zero_area == mesh.indices.len() {
                return Err(Error::file(path, "the mesh has no triangles of non-zero area"));
            }
            Ok(Arc::new(mesh.to_primitives()))
        }
        _ => Ok(crate::scene::Scene::load(path)?.prims),
    }
}
