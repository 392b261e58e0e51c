//! The overlays of `rtdiff debug --draw`, one per file behind [`Overlay`]:
//! a new overlay is a new file and one line in [`parse`].

pub mod bvh_leaf;
pub mod bvh_level;
pub mod focal_plane;
pub mod normals;
pub mod rays;
pub mod sah_splits;
pub mod traversal;

use glam::Vec3;

use super::lines::Lines;
use super::project::Projector;
use crate::accel::Tracer;
use crate::backends::AccelConfig;
use crate::bvh::{BinaryBvh, build_binary};
use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

/// What an overlay may look at.
pub struct Context<'a> {
    /// The scene (its camera is the view).
    pub scene: &'a Scene,
    /// The tracer the render used.
    pub tracer: &'a dyn Tracer,
    /// Builder and traversal of the BVH overlays (backend ignored).
    pub accel: AccelConfig,
}

impl Context<'_> {
    /// The projection of the scene's camera.
    pub fn projector(&self) -> Projector {
        Projector::new(&self.scene.camera)
    }

    /// World length covering `pixels` pixels at point `p` (for markers that
    /// should look the same size anywhere in the image).
    pub fn world_size(&self, p: Vec3, pixels: f32) -> f32 {
        let proj = self.projector();
        let depth = proj.camera_space(p).z.abs().max(1e-6);
        pixels * proj.pixel_size(depth)
    }

    /// The pinhole camera ray through the centre of pixel `(x, y)` (the ray
    /// `rtdiff debug --pixel` traces), after checking the pixel is in the image.
    pub fn pixel_ray(&self, x: u32, y: u32) -> Result<Ray> {
        super::pixel::pixel_ray(self.scene, x, y)
    }

    /// The first hit along the camera ray through pixel `(x, y)`.
    pub fn pixel_hit(&self, x: u32, y: u32) -> Result<(Ray, Option<Hit>)> {
        let ray = self.pixel_ray(x, y)?;
        Ok((ray, self.tracer.intersect(&ray)))
    }

    /// The binary BVH of the chosen builder (what `--builder` builds).
    pub fn binary_bvh(&self) -> BinaryBvh {
        build_binary(&self.scene.prims, &self.accel)
    }

    /// Diagonal of the scene's bounds (for lengths of rays that miss).
    pub fn scene_size(&self) -> f32 {
        let b = self.scene.prims.world_bounds();
        if b.is_empty() { 1.0 } else { b.extent().length().max(1e-3) }
    }
}

/// One kind of picture drawn over the render.
pub trait Overlay {
    /// What is drawn, for messages and file headers (e.g. `bvh-level=3`).
    fn name(&self) -> String;
    /// The lines to draw, in drawing order.
    fn lines(&self, ctx: &Context) -> Result<Lines>;
}

/// The overlay `what` names (`bvh-level=N`, `bvh-leaf=N`, `traversal`,
/// `rays`, `normals`, `sah-splits`, `focal-plane`), with the pixel and node
/// arguments the ones that need them take.
pub fn parse(what: &str, pixel: Option<(u32, u32)>, node: Option<u32>) -> Result<Box<dyn Overlay>> {
    let (name, value) = match what.split_once('=') {
        Some((n, v)) => (n, Some(v)),
        None => (what, None),
    };
    let number = |v: Option<&str>| -> Result<u32> {
        let v = v.ok_or_else(|| Error::Invalid(format!("--draw {name} needs a number: {name}=N")))?;
        v.parse().map_err(|_| Error::Invalid(format!("--draw {what}: '{v}' is not a non-negative integer")))
    };
    let pixel = || pixel.ok_or_else(|| Error::Invalid(format!("--draw {name} needs --pixel X Y")));
    Ok(match name {
        "bvh-level" => Box::new(bvh_level::BvhLevel { level: number(value)? }),
        "bvh-leaf" => Box::new(bvh_leaf::BvhLeaf { index: number(value)? }),
        "traversal" => Box::new(traversal::TraversalPath { pixel: pixel()? }),
        "rays" => Box::new(rays::RayTreeLines { pixel: pixel()? }),
        "normals" => Box::new(normals::Normals { pixel: pixel()? }),
        "sah-splits" => {
            Box::new(sah_splits::SahSplits { node: node.or(value.map(|v| number(Some(v))).transpose()?).unwrap_or(0) })
        }
        "focal-plane" => Box::new(focal_plane::FocalPlane),
        _ => {
            return Err(Error::Invalid(format!(
                "--draw '{what}': expected bvh-level=N, bvh-leaf=N, traversal, rays, normals, sah-splits or focal-plane"
            )));
        }
    })
}

/// Depth (level) of every node of a binary BVH; the root is level 0.
pub fn node_levels(bvh: &BinaryBvh) -> Vec<u32> {
    let mut level = vec![0; bvh.nodes.len()];
    for i in 0..bvh.nodes.len() {
        let n = &bvh.nodes[i];
        if !n.is_leaf() {
            level[i + 1] = level[i] + 1;
            level[n.offset as usize] = level[i] + 1;
        }
    }
    level
}
