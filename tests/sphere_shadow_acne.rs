//! Shadow acne on spheres (issue 8), on the renderer's own path: the scene
//! loader, the default tracer, the integrator's surface interaction and spawn.
//!
//! A ground sphere of radius R centred at (0, -R, 0) under a point light,
//! seen from above (the 64x48 repro), for R = 1, 20 and 100, and the
//! whole scene moved far from the origin. Oracle: the closed form. A convex
//! sphere alone cannot shadow a point whose normal faces the light, so every
//! pixel whose camera ray (in f64) meets the sphere at a point with
//! `cos(n, light) > 0.02` must render non-black. The margin keeps pixels out
//! whose classification could flip by rounding: a camera-ray hit point is
//! off by a few ulps of the largest coordinate (at most 1e-3 at 1e4 from the
//! origin), which moves `cos` by far less than 0.02 on spheres of radius >= 1
//! lit from about 3 units away; silhouette pixels (the ray's closest approach
//! within 1e-3 R of the surface) are left out for the same reason.

mod common;

use glam::{DVec3, Vec3};
use rtdiff::backends::build_tracer;
use rtdiff::render::{RenderOptions, render};

/// (lit pixels by the closed form, of which rendered black).
fn black_lit_pixels(radius: f32, shift: Vec3) -> (usize, usize) {
    let s = |v: [f32; 3]| (Vec3::from(v) + shift).to_array();
    let json = serde_json::json!({
        "camera": {"position": s([0.3, 1.5, -4.0]), "look_at": s([0.0, 0.0, 0.0]), "fov": 40},
        "image": {"width": 64, "height": 48},
        "shading_model": "physical",
        "features": {"recursive": false},
        "spheres": [{"center": s([0.0, -radius, 0.0]), "radius": radius}],
        "lights": [{"type": "point", "position": s([0.2, 3.0, 0.1]), "color": [10, 10, 10]}]
    });
    let dir = common::temp_dir("sphere_acne");
    let scene = common::scene(&dir, &json.to_string());
    let tracer = build_tracer(scene.prims.clone(), &scene.accel).unwrap();
    let image = render(&scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true }).unwrap().image;

    let c = DVec3::from(s([0.0, -radius, 0.0]).map(f64::from));
    let light = DVec3::from(s([0.2, 3.0, 0.1]).map(f64::from));
    let r = f64::from(radius);
    let (mut lit, mut black) = (0, 0);
    for y in 0..scene.height {
        for x in 0..scene.width {
            let ray = scene.camera.pixel_centre_ray(x, y);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3().normalize());
            let b = (c - o).dot(d);
            let closest = (o + b * d - c).length();
            if b <= 0.0 || closest > r * (1.0 - 1e-3) {
                continue;
            }
            let t = b - (r * r - closest * closest).sqrt();
            let p = o + t * d;
            let n = (p - c) / r;
            if n.dot((light - p).normalize()) <= 0.02 {
                continue;
            }
            lit += 1;
            if image.get(x, y) == Vec3::ZERO {
                black += 1;
            }
        }
    }
    (lit, black)
}

#[test]
fn lit_sphere_pixels_are_never_black() {
    for shift in [Vec3::ZERO, Vec3::new(100.0, -50.0, 200.0), Vec3::splat(1.0e4)] {
        for radius in [1.0, 20.0, 100.0] {
            let (lit, black) = black_lit_pixels(radius, shift);
            println!("R = {radius}, shift {shift}: {black} of {lit} lit pixels black");
            assert!(lit > 300, "R = {radius}, shift {shift}: only {lit} lit pixels");
            assert_eq!(black, 0, "R = {radius}, shift {shift}: {black} of {lit} lit pixels black (shadow acne)");
        }
    }
}
