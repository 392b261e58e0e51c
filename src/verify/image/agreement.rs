//! Do two tracers give the same image? The check of `tests/embree_render.rs`
//! and of the whole-render race (`rtdiff bench --race --renders`): pixel by
//! pixel, the two renders of a scene (one sample per pixel at the pixel
//! centre) must agree within [`REL_TOL`] wherever both tracers' camera rays hit
//! the same primitive; elsewhere the pixel is a primary tie (coincident or
//! edge-sharing triangles at equal distance, where either primitive is a
//! correct answer).

use serde::Serialize;

use crate::accel::Tracer;
use crate::film::Image;
use crate::scene::Scene;

/// Tolerance on a pixel whose camera ray hits the same primitive in both:
/// Embree's distances and barycentrics differ from rtdiff's by at most the
/// per-ray float error bound of the parity harness (32 unit roundings, about
/// 4e-6 relative at moderate incidence); shading is smooth in them except for
/// the Phong lobe, whose exponent (up to 250 in these scenes) multiplies a
/// relative error by at most that much: 250 x 4e-6 = 1e-3.
pub const REL_TOL: f32 = 1e-3;

/// Pixels allowed over [`REL_TOL`] without a primary tie: secondary rays can tie
/// too (a shadow or reflection ray through a shared edge, a grazing hit where
/// the bound above grows as 1/cos); 0.5% of the image.
pub const SECONDARY_TIE_FRACTION: f64 = 0.005;

/// Primary ties (the two tracers' camera rays hit different primitives at a
/// shared edge or on coincident triangles): at most 1% of the image.
pub const PRIMARY_TIE_FRACTION: f64 = 0.01;

/// How two renders of one scene agree.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Agreement {
    /// Pixels compared.
    pub pixels: usize,
    /// Pixels whose camera rays hit different primitives.
    pub primary_ties: usize,
    /// Largest relative difference among the other pixels.
    pub max_rel: f32,
    /// Other pixels differing by more than [`REL_TOL`].
    pub over: usize,
}

impl Agreement {
    /// Within the tolerances: at most [`PRIMARY_TIE_FRACTION`] primary ties
    /// and [`SECONDARY_TIE_FRACTION`] pixels over [`REL_TOL`].
    pub fn passes(&self) -> bool {
        let n = self.pixels as f64;
        self.primary_ties as f64 <= PRIMARY_TIE_FRACTION * n && self.over as f64 <= SECONDARY_TIE_FRACTION * n
    }
}

/// The primitive each pixel-centre camera ray of `scene` hits with `t`.
fn primary_prims(scene: &Scene, t: &dyn Tracer) -> Vec<Option<u32>> {
    let mut v = Vec::with_capacity((scene.width * scene.height) as usize);
    for y in 0..scene.height {
        for x in 0..scene.width {
            v.push(t.intersect(&scene.camera.pixel_centre_ray(x, y)).map(|h| h.prim));
        }
    }
    v
}

/// Compare `a` (rendered with `ta`) and `b` (rendered with `tb`), two renders
/// of `scene` with one sample per pixel.
pub fn agreement(scene: &Scene, a: &Image, ta: &dyn Tracer, b: &Image, tb: &dyn Tracer) -> Agreement {
    let (pa, pb) = (primary_prims(scene, ta), primary_prims(scene, tb));
    let mut ag = Agreement { pixels: pa.len(), primary_ties: 0, max_rel: 0.0, over: 0 };
    for i in 0..a.pixels.len() {
        if pa[i] != pb[i] {
            ag.primary_ties += 1;
            continue;
        }
        let d = (a.pixels[i] - b.pixels[i]).abs().max_element();
        let scale = a.pixels[i].max_element().max(b.pixels[i].max_element()).max(1e-3);
        ag.max_rel = ag.max_rel.max(d / scale);
        if d > REL_TOL * scale {
            ag.over += 1;
        }
    }
    ag
}
