//! The differential harness: deterministic ray sets and hit-parity reports
//! comparing rtdiff's tracers with a reference (Embree or brute force).

pub mod parity;
pub mod raysets;

use std::path::Path;
use std::sync::Arc;

use crate::error::{Error, Result};

/// The scene a harness command runs on: a scene file (`.json`, through
/// [`crate::scene::Scene::load`]: its primitives, camera, image size and
/// lights), or an `.obj` mesh normalised to the unit sphere (mean of the
/// vertices at the origin, farthest vertex at distance 1) with the default
/// camera and point light.
pub fn load_context(path: &Path) -> Result<raysets::RayContext> {
    load_context_counted(path).map(|(ctx, _)| ctx)
}

/// [`load_context`], also returning the number of zero-area triangles dropped while loading.
pub fn load_context_counted(path: &Path) -> Result<(raysets::RayContext, usize)> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => {
            let mut mesh = crate::mesh::load_obj(path)?;
            parity::normalise_to_unit_sphere(&mut mesh.positions);
            Ok((raysets::RayContext::with_defaults(Arc::new(mesh.to_primitives())), mesh.degenerate_skipped))
        }
        Some("json") => {
            let scene = crate::scene::Scene::load(path)?;
            let skipped = scene.degenerate_skipped;
            let camera = scene.camera.clone();
            let lights = Arc::new(scene.lights);
            let ctx = raysets::RayContext {
                prims: scene.prims,
                camera: Arc::new(move |x, y| camera.ray(x, y)),
                image: (scene.width, scene.height),
                lights: (0..lights.len())
                    .map(|i| {
                        let lights = Arc::clone(&lights);
                        Arc::new(move |u, v| lights[i].position_at(u, v)) as raysets::LightFn
                    })
                    .collect(),
            };
            Ok((ctx, skipped))
        }
        _ => Err(Error::file(path, "unsupported scene file: expected a scene .json or a Wavefront .obj mesh")),
    }
}
