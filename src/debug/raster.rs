//! Draws [`Lines`] over a rendered [`Image`]: each segment is clipped to the
//! camera's view, projected with the scene's camera and sampled at least
//! twice per pixel it crosses (perspective-correct, so each sample is a true
//! point of the segment), and each sample is depth-tested against the first
//! surface seen through its pixel ([`DepthBuffer`]). Hidden samples are
//! dimmed (blended once into the render), visible ones drawn in full; where
//! samples share a pixel, a visible one wins. Only the pixels a segment
//! covers change: [`draw_lines`] returns their mask.

use glam::Vec3;
use rayon::prelude::*;

use super::lines::Lines;
use super::project::Projector;
use crate::accel::Tracer;
use crate::camera::Camera;
use crate::film::Image;

/// Weight of a hidden line's colour over the render under it.
pub const HIDDEN_WEIGHT: f32 = 0.4;

/// Distance from the eye to the first surface through each pixel centre.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Distances, row-major (infinite where the ray leaves the scene).
    pub dist: Vec<f32>,
}

impl DepthBuffer {
    /// A buffer with nothing in it (every line visible).
    pub fn empty(width: u32, height: u32) -> Self {
        Self { width, height, dist: vec![f32::INFINITY; width as usize * height as usize] }
    }

    /// Trace the pinhole ray through every pixel centre with `tracer` (the
    /// render's own camera rays; rows in parallel).
    pub fn trace(camera: &Camera, tracer: &dyn Tracer) -> Self {
        let (w, h) = (camera.width, camera.height);
        let mut dist = vec![f32::INFINITY; w as usize * h as usize];
        dist.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
            for (x, d) in row.iter_mut().enumerate() {
                let ray = camera.pixel_centre_ray(x as u32, y as u32);
                if let Some(hit) = tracer.intersect(&ray) {
                    *d = hit.t * ray.dir.length();
                }
            }
        });
        Self { width: w, height: h, dist }
    }
}

/// One rasterised sample: pixel index, colour, visibility.
struct Sample {
    pixel: usize,
    color: Vec3,
    visible: bool,
}

/// Clip the segment `a`-`b` (camera space) to the view frustum widened by a
/// pixel margin, in front of `near`; returns the parameters of the kept part.
fn clip(a: Vec3, b: Vec3, half: glam::Vec2, near: f32) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    // Each constraint f(p) >= 0 is linear in p, so linear along the segment.
    let hx = half.x * 1.01;
    let hy = half.y * 1.01;
    let cons: [&dyn Fn(Vec3) -> f32; 5] = [
        &|p: Vec3| p.z - near,
        &|p: Vec3| hx * p.z - p.x,
        &|p: Vec3| hx * p.z + p.x,
        &|p: Vec3| hy * p.z - p.y,
        &|p: Vec3| hy * p.z + p.y,
    ];
    for f in cons {
        let (fa, fb) = (f(a), f(b));
        if fa < 0.0 && fb < 0.0 {
            return None;
        }
        if fa < 0.0 {
            t0 = t0.max(fa / (fa - fb));
        } else if fb < 0.0 {
            t1 = t1.min(fa / (fa - fb));
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Draw `lines` over `image` (the render seen through `camera`), depth-tested
/// against `depth`. Returns the mask of pixels changed.
pub fn draw_lines(image: &mut Image, depth: &DepthBuffer, camera: &Camera, lines: &Lines) -> Vec<bool> {
    let proj = Projector::new(camera);
    let (w, h) = (image.width as usize, image.height as usize);
    let mut mask = vec![false; w * h];
    let mut samples = Vec::new();
    for s in &lines.segments {
        let (ca, cb) = (proj.camera_space(s.a), proj.camera_space(s.b));
        let scale = ca.abs().max_element().max(cb.abs().max_element()).max(1e-3);
        let Some((t0, t1)) = clip(ca, cb, proj.half_extent(), 1e-4 * scale) else { continue };
        let (a, b) = (s.a + t0 * (s.b - s.a), s.a + t1 * (s.b - s.a));
        let (ca, cb) = (proj.camera_space(a), proj.camera_space(b));
        let (pa, pb) = (proj.to_pixel(ca), proj.to_pixel(cb));
        let n = ((pb - pa).length() * 2.0).ceil().max(1.0) as usize;
        for i in 0..=n {
            let sp = i as f32 / n as f32;
            // Screen parameter sp to segment parameter u (perspective-correct).
            let u = sp * ca.z / (sp * ca.z + (1.0 - sp) * cb.z);
            let p = a + u * (b - a);
            let px = pa + sp * (pb - pa);
            if px.x < 0.0 || px.y < 0.0 || px.x >= w as f32 || px.y >= h as f32 {
                continue;
            }
            let pixel = px.y as usize * w + px.x as usize;
            let dist = (p - proj.eye()).length();
            let surface = depth.dist[pixel];
            // A line lying on a surface must count as visible: the depth is
            // sampled at the pixel centre, up to half a pixel diagonal from
            // the sample, where a surface inclined up to 75 degrees to the
            // view (slope 3.7) lies 0.71 * 3.7 < 3 pixel sizes nearer; plus
            // a relative 1e-4 for the rounding of both distances.
            let tol = 3.0 * proj.pixel_size(surface.min(dist)) + 1e-4 * dist;
            samples.push(Sample { pixel, color: s.color, visible: dist <= surface + tol });
        }
    }
    // One colour per pixel: a visible sample wins over hidden ones, and
    // among equals the later segment wins; each pixel is then blended once.
    let mut top: Vec<Option<(Vec3, bool)>> = vec![None; w * h];
    for s in &samples {
        let t = &mut top[s.pixel];
        if s.visible || !t.is_some_and(|(_, v)| v) {
            *t = Some((s.color, s.visible));
        }
    }
    for (i, t) in top.iter().enumerate() {
        if let Some((color, visible)) = *t {
            let px = &mut image.pixels[i];
            *px = if visible { color } else { HIDDEN_WEIGHT * color + (1.0 - HIDDEN_WEIGHT) * *px };
            mask[i] = true;
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::debug::lines::color;
    use crate::geometry::Aabb;

    /// Camera at (0, 0, -3) looking at the origin, 90 degree field of view,
    /// 100 x 100: a point (x, y, z) lands on the pixel position
    /// (50 - 50 x / (z + 3), 50 - 50 y / (z + 3)) (right is -x: cross(forward, up)).
    fn camera() -> Camera {
        Camera::look_at(Vec3::new(0.0, 0.0, -3.0), Vec3::ZERO, Vec3::Y, 90.0, 100, 100)
    }

    fn closed_form(p: Vec3) -> glam::Vec2 {
        glam::Vec2::new(50.0 - 50.0 * p.x / (p.z + 3.0), 50.0 - 50.0 * p.y / (p.z + 3.0))
    }

    #[test]
    fn a_known_box_lands_on_the_expected_pixels() {
        let cam = camera();
        let bx = Aabb::new(Vec3::new(-0.5, -0.5, -1.0), Vec3::new(0.5, 0.5, 1.0));
        let proj = Projector::new(&cam);
        let mut lines = Lines::default();
        lines.aabb(&bx, color::WHITE);
        for s in &lines.segments {
            for p in [s.a, s.b] {
                let got = proj.project(p).unwrap_or(glam::Vec2::NAN);
                assert!((got - closed_form(p)).abs().max_element() < 1e-4, "{p}: {got}");
            }
        }
        // Front face (depth 2): pixels 37.5 .. 62.5; back face (depth 4): 43.75 .. 56.25.
        let mut img = Image::new(100, 100);
        let mask = draw_lines(&mut img, &DepthBuffer::empty(100, 100), &cam, &lines);
        let on = |x: usize, y: usize| mask[y * 100 + x];
        for x in 38..62 {
            assert!(on(x, 37) && on(x, 62), "front face top/bottom edge at column {x}");
        }
        for y in 38..62 {
            assert!(on(37, y) && on(62, y), "front face left/right edge at row {y}");
        }
        for x in 44..56 {
            assert!(on(x, 43) && on(x, 56), "back face top/bottom edge at column {x}");
        }
        // Every drawn pixel touches one of the 12 projected edges.
        let near_edge = |x: usize, y: usize| {
            let c = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            lines.segments.iter().any(|s| {
                let (a, b) = (closed_form(s.a), closed_form(s.b));
                let t = ((c - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                (a + t * (b - a) - c).length() <= std::f32::consts::FRAC_1_SQRT_2 + 1e-4
            })
        };
        let drawn = (0..100 * 100).filter(|&i| mask[i]).count();
        // Perimeters 4 x 25 + 4 x 12.5 pixels plus four edges of about 9 pixels between them.
        assert!(drawn > 150, "only {drawn} pixels drawn");
        for i in (0..100 * 100).filter(|&i| mask[i]) {
            assert!(near_edge(i % 100, i / 100), "pixel ({}, {}) is off every edge", i % 100, i / 100);
        }
        // Nothing hidden: the whole line is in full colour.
        assert!(img.pixels.iter().zip(&mask).all(|(p, &m)| !m || *p == color::WHITE));
    }

    #[test]
    fn hidden_parts_are_dimmed_not_dropped() {
        let cam = camera();
        let mut lines = Lines::default();
        // A horizontal segment at depth 4, behind a "wall" at distance 3 covering the left half.
        lines.segment(Vec3::new(-0.5, 0.0, 1.0), Vec3::new(0.5, 0.0, 1.0), color::GREEN);
        let mut depth = DepthBuffer::empty(100, 100);
        for y in 0..100 {
            for x in 0..50 {
                depth.dist[y * 100 + x] = 3.0;
            }
        }
        let base = Image { width: 100, height: 100, pixels: vec![Vec3::splat(0.5); 100 * 100] };
        let mut img = base.clone();
        let mask = draw_lines(&mut img, &depth, &cam, &lines);
        let dimmed = HIDDEN_WEIGHT * color::GREEN + (1.0 - HIDDEN_WEIGHT) * Vec3::splat(0.5);
        assert!(mask[50 * 100 + 45] && (img.get(45, 50) - dimmed).abs().max_element() < 1e-6);
        assert!(mask[50 * 100 + 55] && img.get(55, 50) == color::GREEN);
        for ((p, q), &m) in img.pixels.iter().zip(&base.pixels).zip(&mask) {
            assert!(m || p == q);
        }
    }

    #[test]
    fn segments_behind_the_eye_are_clipped() {
        let cam = camera();
        let mut lines = Lines::default();
        // From behind the eye to in front of it, through the view's centre line.
        lines.segment(Vec3::new(0.0, 0.0, -10.0), Vec3::new(0.0, 0.2, 5.0), color::RED);
        let mut img = Image::new(100, 100);
        let mask = draw_lines(&mut img, &DepthBuffer::empty(100, 100), &cam, &lines);
        // The far end projects to (50, 50 - 50 * 0.2 / 8) = (50, 48.75).
        assert!(mask[48 * 100 + 50]);
        assert!(mask.iter().filter(|&&m| m).count() < 200);
    }
}
