//! Ray workloads, one module that `bench`, `parity`, `race`, `trace` and the
//! tests all draw from: seeded ray sets (ordinary workloads and rays built to
//! break a tracer), the context they are generated from (primitives, camera,
//! lights), and the loaders that turn a scene file or a mesh into that context.

pub mod context;
pub mod near_grazing;
pub mod rng;
pub mod sets;
pub mod topology;
pub mod workload;

pub use context::{CameraFn, LightFn, PinholeCamera, RayContext};
pub use rng::Rng;
pub use sets::{RaySet, RayTag, SetKind, generate, scene_scale};
pub use topology::Topology;
pub use workload::{Camera, incoherent_rays, normalize_mesh, shadow_rays, surface_point};

use std::path::Path;
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::geometry::Primitives;

/// The scene a harness command runs on: a scene file (`.json`, through
/// [`crate::scene::Scene::load`]: its primitives, camera, image size and
/// lights), or an `.obj` mesh normalised to the unit sphere (mean of the
/// vertices at the origin, farthest vertex at distance 1) with the default
/// camera and point light.
pub fn load_context(path: &Path) -> Result<RayContext> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => {
            let mut mesh = crate::mesh::load_obj(path)?;
            workload::normalise_to_unit_sphere(&mut mesh.positions);
            Ok(RayContext::with_defaults(Arc::new(mesh.to_primitives())))
        }
        Some("json") => {
            let scene = crate::scene::Scene::load(path)?;
            let camera = scene.camera.clone();
            let lights = Arc::new(scene.lights);
            Ok(RayContext {
                prims: scene.prims,
                camera: Arc::new(move |x, y| camera.ray(x, y)),
                image: (scene.width, scene.height),
                lights: (0..lights.len())
                    .map(|i| {
                        let lights = Arc::clone(&lights);
                        Arc::new(move |u, v| lights[i].position_at(u, v)) as LightFn
                    })
                    .collect(),
            })
        }
        _ => Err(Error::file(path, "unsupported scene file: expected a scene .json or a Wavefront .obj mesh")),
    }
}

/// Load the primitives of `path`: an `.obj` mesh directly, anything else as a scene file.
/// With `normalize`, an OBJ mesh is centred on its vertex mean and scaled into the unit sphere.
pub fn load_primitives(path: &Path, normalize: bool) -> Result<Arc<Primitives>> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("obj") => {
            let mut mesh = crate::mesh::load_obj(path)?;
            if normalize {
                normalize_mesh(&mut mesh);
            }
            if mesh.indices.is_empty() {
                return Err(Error::file(path, "the mesh has no (non-degenerate) triangles"));
            }
            Ok(Arc::new(mesh.to_primitives()))
        }
        _ => Ok(crate::scene::Scene::load(path)?.prims),
    }
}
