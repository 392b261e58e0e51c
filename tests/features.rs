//! Every feature of the reports against a closed-form answer. Scenes are one
//! pixel (or a few) whose camera ray hits a known point, rendered with the
//! brute-force oracle.
//!
//! Tolerances: the quantities below go through a few dozen f32 operations
//! (barycentric hit point, normalisations, dot products), each with relative
//! error <= 2^-24 = 6e-8; 1e-5 relative (~170 ulps) bounds their sum with a
//! wide margin while still catching any wrong formula (which is off by O(1)).

mod common;

use common::*;
use glam::Vec3;

const REL: f32 = 1e-5;

fn obj_quad(dir: &std::path::Path, name: &str, h: f32, z: f32) -> String {
    write(dir, name, &quad_obj(square_facing_minus_z(h, z)));
    name.to_string()
}

/// One-pixel scene: camera at (cx, cy, -3) looking along +z.
fn one_pixel(extra: &str, cx: f32, cy: f32) -> String {
    format!(
        r#"{{ "camera": {{ "position": [{cx}, {cy}, -3], "look_at": [{cx}, {cy}, 0], "fov": 30 }},
             "image": {{ "width": 1, "height": 1 }}, {extra} }}"#
    )
}

#[test]
fn phong_point_light_is_i_kd_cos_theta() {
    let d = temp_dir("phong-point");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let s = scene(
        &d,
        &one_pixel(
            &format!(
                r#""materials": {{ "m": {{ "kd": [0.9, 0.8, 0.6] }} }},
                   "meshes": [ {{ "file": "{q}", "material": "m" }} ],
                   "lights": [ {{ "type": "point", "position": [1, 2, -2], "color": [0.7, 0.5, 0.3] }} ]"#
            ),
            0.0,
            0.0,
        ),
    );
    let got = render_image(&s).get(0, 0);
    // n = -z, l = (1, 2, -2) / 3: cos = 2/3.
    let want = Vec3::new(0.7, 0.5, 0.3) * Vec3::new(0.9, 0.8, 0.6) * (2.0 / 3.0);
    assert_close(got, want, REL);
}

#[test]
fn phong_specular_term_matches_formula() {
    let d = temp_dir("phong-spec");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let s = scene(
        &d,
        &one_pixel(
            &format!(
                r#""materials": {{ "m": {{ "kd": [0.5, 0.5, 0.5], "ks": [0.3, 0.3, 0.3], "shininess": 8 }} }},
                   "features": {{ "recursive": false }},
                   "meshes": [ {{ "file": "{q}", "material": "m" }} ],
                   "lights": [ {{ "type": "point", "position": [0.5, 0, -3], "color": [1, 1, 1] }} ]"#
            ),
            0.0,
            0.0,
        ),
    );
    let got = render_image(&s).get(0, 0);
    let n = Vec3::new(0.0, 0.0, -1.0);
    let l = Vec3::new(0.5, 0.0, -3.0).normalize();
    let v = Vec3::new(0.0, 0.0, -1.0);
    let r = 2.0 * n.dot(l) * n - l;
    let want = Vec3::splat(0.5 * n.dot(l) + 0.3 * r.dot(v).powf(8.0));
    assert_close(got, want, REL);
}

#[test]
fn physical_point_light_is_kd_over_pi_i_cos_over_r2() {
    let d = temp_dir("physical-point");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let s = scene(
        &d,
        &one_pixel(
            &format!(
                r#""shading_model": "physical", "materials": {{ "m": {{ "kd": [0.9, 0.8, 0.6] }} }},
                   "meshes": [ {{ "file": "{q}", "material": "m" }} ],
                   "lights": [ {{ "type": "point", "position": [1, 2, -2], "color": [7, 5, 3] }} ]"#
            ),
            0.0,
            0.0,
        ),
    );
    let got = render_image(&s).get(0, 0);
    let want = Vec3::new(0.9, 0.8, 0.6) / std::f32::consts::PI * Vec3::new(7.0, 5.0, 3.0) * (2.0 / 3.0) / 9.0;
    assert_close(got, want, REL);
}

#[test]
fn shadowed_point_is_black_and_unshadowed_is_not() {
    let d = temp_dir("shadow");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    // A small blocker centred on the segment from the hit point (origin) to the light, at z = -1.
    let b =
        [Vec3::new(0.7, 0.8, -1.0), Vec3::new(0.3, 0.8, -1.0), Vec3::new(0.3, 1.2, -1.0), Vec3::new(0.7, 1.2, -1.0)];
    write(&d, "b.obj", &quad_obj(b));
    let json = |hard: bool| {
        one_pixel(
            &format!(
                r#""features": {{ "hard_shadows": {hard} }},
                   "meshes": [ {{ "file": "{q}" }}, {{ "file": "b.obj" }} ],
                   "lights": [ {{ "type": "point", "position": [1, 2, -2], "color": [1, 1, 1] }} ]"#
            ),
            0.0,
            0.0,
        )
    };
    let r = render_with(&scene(&d, &json(true)), Some(1));
    assert_eq!(r.image.get(0, 0), Vec3::ZERO);
    assert_eq!(r.counters.shadow_rays, 1);
    let r = render_with(&scene(&d, &json(false)), Some(1));
    assert_close(r.image.get(0, 0), Vec3::splat(2.0 / 3.0), REL);
    assert_eq!(r.counters.shadow_rays, 0);
}

#[test]
fn mirror_facing_a_coloured_wall_returns_ks_times_the_wall() {
    let d = temp_dir("mirror");
    let m = obj_quad(&d, "mirror.obj", 1.0, 0.0);
    // Wall behind the camera (z = -5), facing +z (towards the mirror): reverse the corner order.
    let mut w = square_facing_minus_z(10.0, -5.0);
    w.reverse();
    write(&d, "wall.obj", &quad_obj(w));
    let json = |glossy: bool, shininess: f32| {
        one_pixel(
            &format!(
                r#""features": {{ "shading": false, "glossy": {glossy} }},
                   "params": {{ "glossy_samples": 32 }},
                   "materials": {{ "mirror": {{ "kd": [0, 0, 0], "ks": [0.95, 0.9, 0.85], "shininess": {shininess} }},
                                   "wall": {{ "kd": [0.2, 0.4, 0.6] }} }},
                   "meshes": [ {{ "file": "{m}", "material": "mirror" }}, {{ "file": "wall.obj", "material": "wall" }} ]"#
            ),
            0.0,
            0.0,
        )
    };
    let want = Vec3::new(0.95, 0.9, 0.85) * Vec3::new(0.2, 0.4, 0.6);
    let r = render_with(&scene(&d, &json(false, 4.0)), Some(1));
    assert_close(r.image.get(0, 0), want, REL);
    assert_eq!(r.counters.secondary_rays, 1);
    // Glossy rays spread over a square of side 1/shininess = 0.1 around the mirror
    // direction: all still land on the uniform wall, so the average is the same.
    let r = render_with(&scene(&d, &json(true, 10.0)), Some(1));
    assert_close(r.image.get(0, 0), want, REL);
    assert_eq!(r.counters.secondary_rays, 32);
}

#[test]
fn glossy_average_mixes_what_the_perturbed_rays_see() {
    // Mirror reflects towards a wall split into two colours along x = 0: a
    // perfect mirror sees one side, glossy rays (square of side 1/shininess = 0.5,
    // wall 5 units away so the spread there is +-1.25 units) see both.
    let d = temp_dir("glossy-mix");
    let m = obj_quad(&d, "mirror.obj", 1.0, 0.0);
    let half = |x0: f32, x1: f32| {
        let mut c = [
            Vec3::new(x1, -10.0, -5.0),
            Vec3::new(x0, -10.0, -5.0),
            Vec3::new(x0, 10.0, -5.0),
            Vec3::new(x1, 10.0, -5.0),
        ];
        c.reverse();
        quad_obj(c)
    };
    write(&d, "left.obj", &half(0.0, 10.0));
    write(&d, "right.obj", &half(-10.0, 0.0));
    let json = |glossy: bool| {
        one_pixel(
            &format!(
                r#""features": {{ "shading": false, "glossy": {glossy} }},
                   "params": {{ "glossy_samples": 256 }},
                   "materials": {{ "mirror": {{ "kd": [0, 0, 0], "ks": [1, 1, 1], "shininess": 2 }},
                                   "red": {{ "kd": [1, 0, 0] }}, "blue": {{ "kd": [0, 0, 1] }} }},
                   "meshes": [ {{ "file": "{m}", "material": "mirror" }},
                               {{ "file": "left.obj", "material": "red" }}, {{ "file": "right.obj", "material": "blue" }} ]"#
            ),
            0.3,
            0.0,
        )
    };
    let sharp = render_image(&scene(&d, &json(false))).get(0, 0);
    assert_eq!(sharp, Vec3::new(1.0, 0.0, 0.0));
    let glossy = render_image(&scene(&d, &json(true))).get(0, 0);
    // Each glossy ray sees red or blue, so red + blue = 1 exactly; both appear.
    assert!((glossy.x + glossy.z - 1.0).abs() < 1e-5, "{glossy}");
    assert!(glossy.x > 0.5 && glossy.z > 0.05, "{glossy}");
}

fn texture_scene(d: &std::path::Path, bilinear: bool) -> rtdiff::scene::Scene {
    let q = obj_quad(d, "q.obj", 1.0, 0.0);
    let mut img = image::RgbImage::new(2, 2);
    img.put_pixel(0, 0, image::Rgb([255, 0, 0]));
    img.put_pixel(1, 0, image::Rgb([0, 255, 0]));
    img.put_pixel(0, 1, image::Rgb([0, 0, 255]));
    img.put_pixel(1, 1, image::Rgb([128, 128, 128]));
    img.save(d.join("tex.png")).unwrap();
    // Camera aimed at (0.1, -0.3, 0): u = (1 - x) / 2 = 0.45, v = (y + 1) / 2 = 0.35.
    scene(
        d,
        &one_pixel(
            &format!(
                r#""features": {{ "shading": false, "bilinear_filtering": {bilinear} }},
                   "materials": {{ "t": {{ "kd_texture": "tex.png" }} }},
                   "meshes": [ {{ "file": "{q}", "material": "t" }} ]"#
            ),
            0.1,
            -0.3,
        ),
    )
}

#[test]
fn bilinear_lookup_returns_the_mixed_texels() {
    let d = temp_dir("bilinear");
    let r = render_with(&texture_scene(&d, true), Some(1));
    let grey = rtdiff::texture::srgb_to_linear(128.0 / 255.0);
    let (t00, t10, t01, t11) = (Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(grey));
    // x = 0.45 * 2 - 0.5 = 0.4, y = (1 - 0.35) * 2 - 0.5 = 0.8.
    let (fx, fy) = (0.4, 0.8);
    let want = (1.0 - fy) * ((1.0 - fx) * t00 + fx * t10) + fy * ((1.0 - fx) * t01 + fx * t11);
    let got = r.image.get(0, 0);
    assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
    assert_eq!(r.counters.texture_lookups, 1);
}

#[test]
fn nearest_lookup_returns_the_texel_under_the_uv() {
    let d = temp_dir("nearest");
    let r = render_with(&texture_scene(&d, false), Some(1));
    // Column floor(0.45 * 2) = 0, row floor(0.65 * 2) = 1: the blue texel.
    assert_eq!(r.image.get(0, 0), Vec3::Z);
}

/// `(1/L) int_0^L c(s) f(s) ds` for Phong diffuse `f = n.l` along the segment,
/// by composite midpoint rule in f64 with 200k panels (error ~1e-11).
fn segment_reference(p0: Vec3, p1: Vec3, c0: Vec3, c1: Vec3) -> (Vec3, [f64; 3]) {
    let n = glam::DVec3::new(0.0, 0.0, -1.0);
    let (a, b) = (p0.as_dvec3(), p1.as_dvec3());
    let steps = 200_000;
    let mut sum = glam::DVec3::ZERO;
    let mut variation = [0.0f64; 3];
    let mut prev: Option<glam::DVec3> = None;
    for i in 0..steps {
        let s = (i as f64 + 0.5) / steps as f64;
        let q = a + s * (b - a);
        let c = (1.0 - s) * c0.as_dvec3() + s * c1.as_dvec3();
        let v = c * n.dot(q.normalize()).max(0.0);
        sum += v;
        if let Some(pv) = prev {
            for k in 0..3 {
                variation[k] += (v[k] - pv[k]).abs();
            }
        }
        prev = Some(v);
    }
    ((sum / steps as f64).as_vec3(), variation)
}

#[test]
fn segment_light_converges_to_the_line_integral() {
    let d = temp_dir("segment");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let (p0, p1) = (Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.5, -2.0));
    for (c0, c1) in [(Vec3::ONE, Vec3::ONE), (Vec3::new(0.9, 0.2, 0.1), Vec3::new(0.2, 1.0, 0.3))] {
        let (want, variation) = segment_reference(p0, p1, c0, c1);
        let mut last_err = f32::INFINITY;
        for n in [4u32, 64, 1024] {
            let json = one_pixel(
                &format!(
                    r#""params": {{ "light_samples": {n}, "light_sampling": "jittered" }},
                       "meshes": [ {{ "file": "{q}" }} ],
                       "lights": [ {{ "type": "segment", "endpoints": [[{}, {}, {}], [{}, {}, {}]],
                                     "colors": [[{}, {}, {}], [{}, {}, {}]] }} ]"#,
                    p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, c0.x, c0.y, c0.z, c1.x, c1.y, c1.z
                ),
                0.0,
                0.0,
            );
            let got = render_image(&scene(&d, &json)).get(0, 0);
            // Jittered sampling: each stratum's sample differs from the stratum
            // mean by at most the integrand's oscillation there, so the error is
            // at most (total variation) / N; 1e-5 covers the f32 arithmetic.
            for k in 0..3 {
                let err = (got[k] - want[k]).abs();
                assert!(err <= (variation[k] / n as f64) as f32 + 1e-5, "N={n} ch{k}: {got} vs {want}");
            }
            let err = (got - want).abs().max_element();
            assert!(err <= last_err + 1e-6, "error grew from {last_err} to {err} at N={n}");
            last_err = err;
        }
        assert!(last_err < 2e-3, "{last_err}");
    }
}

#[test]
fn random_light_sampling_is_unbiased_within_its_variance() {
    let d = temp_dir("segment-random");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let (p0, p1) = (Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.5, -2.0));
    let (want, _) = segment_reference(p0, p1, Vec3::ONE, Vec3::ONE);
    let n = 4096;
    let json = one_pixel(
        &format!(
            r#""params": {{ "light_samples": {n}, "light_sampling": "random" }}, "meshes": [ {{ "file": "{q}" }} ],
               "lights": [ {{ "type": "segment", "endpoints": [[-1, 1, -1], [1, 1.5, -2]], "colors": [[1, 1, 1], [1, 1, 1]] }} ]"#
        ),
        0.0,
        0.0,
    );
    let got = render_image(&scene(&d, &json)).get(0, 0).x;
    // The integrand n.l lies in [0, 1], so its variance is at most 1/4: the
    // mean of N samples has sigma <= 0.5 / sqrt(N). Allow 5 sigma.
    let sigma = 0.5 / (n as f32).sqrt();
    assert!((got - want.x).abs() < 5.0 * sigma, "{got} vs {}", want.x);
}

#[test]
fn parallelogram_light_colour_is_bilinear_and_physical_integral_converges() {
    // A parallelogram facing down-ish onto the plane, corner colours; physical
    // model: L_o = kd/pi int Le(x) cos cos' / r^2 dA. Reference by a 2000^2
    // midpoint rule in f64; jittered estimate within the same variation bound.
    let d = temp_dir("parallelogram");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let (v0, e1, e2) = (Vec3::new(-0.5, -0.5, -1.5), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
    // e1 x e2 = +z: the light must emit towards the plane at z = 0 (its normal points +z).
    let colors =
        [Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)];
    let m = 1000;
    let mut want = glam::DVec3::ZERO;
    let nl = glam::DVec3::new(0.0, 0.0, 1.0);
    let n = glam::DVec3::new(0.0, 0.0, -1.0);
    for i in 0..m {
        for j in 0..m {
            let (a, b) = ((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
            let x = v0.as_dvec3() + a * e1.as_dvec3() + b * e2.as_dvec3();
            let c = (1.0 - a) * ((1.0 - b) * colors[0].as_dvec3() + b * colors[2].as_dvec3())
                + a * ((1.0 - b) * colors[1].as_dvec3() + b * colors[3].as_dvec3());
            let r2 = x.length_squared();
            let l = x / r2.sqrt();
            want += c * (n.dot(l).max(0.0) * (-l).dot(nl).max(0.0) / r2);
        }
    }
    let want = (want / (m * m) as f64 / std::f64::consts::PI).as_vec3(); // area 1, kd 1
    let json = one_pixel(
        &format!(
            r#""shading_model": "physical", "params": {{ "light_samples": 4096 }}, "meshes": [ {{ "file": "{q}" }} ],
               "lights": [ {{ "type": "parallelogram", "v0": [-0.5, -0.5, -1.5], "edge01": [1, 0, 0], "edge02": [0, 1, 0],
                             "colors": [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1]] }} ]"#
        ),
        0.0,
        0.0,
    );
    let got = render_image(&scene(&d, &json)).get(0, 0);
    // 64 x 64 jittered strata of a smooth integrand: error ~ variation / 64^2 per
    // axis pair; the integrand stays within [0, 0.45], so 1e-3 absolute is ample.
    assert!((got - want).abs().max_element() < 1e-3, "{got} vs {want}");
    // Flipping the light (edges swapped) makes it emit away: black.
    let flipped =
        json.replace(r#""edge01": [1, 0, 0], "edge02": [0, 1, 0]"#, r#""edge01": [0, 1, 0], "edge02": [1, 0, 0]"#);
    assert_eq!(render_image(&scene(&d, &flipped)).get(0, 0), Vec3::ZERO);
}

#[test]
fn transparency_blends_with_what_lies_behind_and_attenuates_shadows() {
    let d = temp_dir("transparency");
    let front = obj_quad(&d, "front.obj", 1.0, -1.0);
    let wall = obj_quad(&d, "wall.obj", 5.0, 0.0);
    let json = |shading: bool| {
        one_pixel(
            &format!(
                r#""features": {{ "shading": {shading}, "transparency": true }},
                   "materials": {{ "glass": {{ "kd": [1, 0, 0], "transparency": 0.25 }}, "wall": {{ "kd": [0, 0, 1] }} }},
                   "meshes": [ {{ "file": "{front}", "material": "glass" }}, {{ "file": "{wall}", "material": "wall" }} ],
                   "lights": [ {{ "type": "point", "position": [0, 0, -2], "color": [1, 1, 1] }} ]"#
            ),
            0.0,
            0.0,
        )
    };
    let r = render_with(&scene(&d, &json(false)), Some(1));
    assert_close(r.image.get(0, 0), Vec3::new(0.75, 0.0, 0.25), REL);
    assert_eq!(r.counters.secondary_rays, 1);
    // Shading on: the glass is lit head-on (cos 1); the wall is lit through the
    // glass, attenuated by its transparency 0.25, then seen through it (0.25).
    let got = render_image(&scene(&d, &json(true))).get(0, 0);
    assert_close(got, Vec3::new(0.75, 0.0, 0.25 * 0.25), REL);
}

#[test]
fn sphere_is_lit_with_its_analytic_normal() {
    let d = temp_dir("sphere");
    let s = scene(
        &d,
        &one_pixel(
            r#""materials": { "m": { "kd": [0.5, 0.6, 0.7] } }, "spheres": [ { "center": [0, 0, 0], "radius": 1, "material": "m" } ],
               "lights": [ { "type": "point", "position": [0, 2, -3], "color": [1, 1, 1] } ]"#,
            0.0,
            0.0,
        ),
    );
    // Hit (0, 0, -1), normal -z, l = (0, 2, -2)/sqrt(8): cos = 1/sqrt(2).
    assert_close(render_image(&s).get(0, 0), Vec3::new(0.5, 0.6, 0.7) * std::f32::consts::FRAC_1_SQRT_2, REL);
}

#[test]
fn normal_interpolation_uses_barycentric_weights() {
    let d = temp_dir("normals");
    // Triangle with normal -z; the camera ray hits (0, 0, 0) at barycentrics (0.25, 0.25, 0.5).
    write(&d, "t.obj", "v 1 -1 0\nv -1 -1 0\nv 0 1 0\nvn 0.5 0 -1\nvn -0.5 0 -1\nvn 0 0.5 -1\nf 1//1 2//2 3//3\n");
    let json = |on: bool| {
        one_pixel(
            &format!(
                r#""features": {{ "normal_interpolation": {on} }}, "meshes": [ {{ "file": "t.obj" }} ],
                   "lights": [ {{ "type": "point", "position": [0, 0, -3], "color": [1, 1, 1] }} ]"#
            ),
            0.0,
            0.0,
        )
    };
    let n = (0.25 * Vec3::new(0.5, 0.0, -1.0).normalize()
        + 0.25 * Vec3::new(-0.5, 0.0, -1.0).normalize()
        + 0.5 * Vec3::new(0.0, 0.5, -1.0).normalize())
    .normalize();
    assert_close(render_image(&scene(&d, &json(true))).get(0, 0), Vec3::splat(-n.z), REL);
    assert_close(render_image(&scene(&d, &json(false))).get(0, 0), Vec3::ONE, REL);
}

#[test]
fn depth_of_field_keeps_the_focus_plane_sharp_and_blurs_the_rest() {
    let d = temp_dir("dof");
    let half = |x0: f32, x1: f32| {
        quad_obj([Vec3::new(x1, -5.0, 0.0), Vec3::new(x0, -5.0, 0.0), Vec3::new(x0, 5.0, 0.0), Vec3::new(x1, 5.0, 0.0)])
    };
    write(&d, "red.obj", &half(0.0, 5.0));
    write(&d, "blue.obj", &half(-5.0, 0.0));
    let json = |focus: f32| {
        format!(
            r#"{{ "camera": {{ "position": [0.05, 0, -3], "look_at": [0.05, 0, 0], "fov": 30, "aperture": 0.2, "focus_distance": {focus} }},
                 "image": {{ "width": 1, "height": 1 }},
                 "features": {{ "shading": false, "depth_of_field": true }}, "params": {{ "dof_samples": 256 }},
                 "materials": {{ "red": {{ "kd": [1, 0, 0] }}, "blue": {{ "kd": [0, 0, 1] }} }},
                 "meshes": [ {{ "file": "red.obj", "material": "red" }}, {{ "file": "blue.obj", "material": "blue" }} ] }}"#
        )
    };
    // In focus: every lens ray meets (0.05, 0, 0), on the red side.
    let r = render_with(&scene(&d, &json(3.0)), Some(1));
    assert_eq!(r.image.get(0, 0), Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(r.counters.primary_rays, 256);
    // Focused at 1: the lens disk (radius 0.2) projects to radius 0.4 on the
    // wall, which straddles x = 0, so both colours appear (and sum to 1).
    let got = render_image(&scene(&d, &json(1.0))).get(0, 0);
    assert!((got.x + got.z - 1.0).abs() < 1e-5 && got.z > 0.1 && got.x > 0.5, "{got}");
}

#[test]
fn unused_features_cost_nothing() {
    let d = temp_dir("plan");
    let q = obj_quad(&d, "q.obj", 1.0, 0.0);
    let every =
        rtdiff::features::FEATURE_NAMES.iter().map(|n| format!(r#""{n}": true"#)).collect::<Vec<_>>().join(", ");
    let json = format!(
        r#"{{ "camera": {{ "position": [0, 0, -3], "look_at": [0, 0, 0], "fov": 40 }}, "image": {{ "width": 8, "height": 6, "spp": 4 }},
             "features": {{ {every} }}, "meshes": [ {{ "file": "{q}" }} ],
             "lights": [ {{ "type": "point", "position": [0, 1, -2], "color": [1, 1, 1] }} ] }}"#
    );
    let s = scene(&d, &json);
    let plan = s.plan();
    assert!(plan.shading && plan.hard_shadows && plan.bloom);
    assert!(!plan.textures && !plan.reflections && !plan.glossy && !plan.transparency);
    assert!(!plan.area_lights && !plan.soft_shadows && !plan.depth_of_field);
    let r = render_with(&s, Some(2));
    assert_eq!(r.counters.primary_rays, 8 * 6 * 4);
    assert_eq!(r.counters.secondary_rays, 0);
    assert_eq!(r.counters.texture_lookups, 0);
    // Every primary ray that hits the quad sends exactly one shadow ray.
    assert!(r.counters.shadow_rays > 0 && r.counters.shadow_rays <= r.counters.primary_rays);
    assert_eq!(r.counters.light_samples, r.counters.shadow_rays);
}

#[test]
fn image_is_identical_for_any_thread_count() {
    let d = temp_dir("threads");
    let q = obj_quad(&d, "q.obj", 1.0, 0.0);
    let mut back = square_facing_minus_z(3.0, 1.0);
    back.rotate_left(1);
    write(&d, "back.obj", &quad_obj(back));
    let json = format!(
        r#"{{ "camera": {{ "position": [0.3, 0.2, -3], "look_at": [0, 0, 0], "fov": 50, "aperture": 0.05 }},
             "image": {{ "width": 24, "height": 16, "spp": 4, "seed": 9 }},
             "features": {{ "glossy": true, "depth_of_field": true, "transparency": true }},
             "params": {{ "light_sampling": "random", "light_samples": 3, "glossy_samples": 2, "dof_samples": 2 }},
             "materials": {{ "g": {{ "kd": [0.5, 0.5, 0.2], "ks": [0.4, 0.4, 0.4], "shininess": 5, "transparency": 0.3 }} }},
             "meshes": [ {{ "file": "{q}", "material": "g" }}, {{ "file": "back.obj" }} ],
             "lights": [ {{ "type": "segment", "endpoints": [[-1, 1, -2], [1, 1, -2]], "colors": [[1, 0, 0], [0, 0, 1]] }} ] }}"#
    );
    let s = scene(&d, &json);
    let a = render_with(&s, Some(1));
    let b = render_with(&s, Some(2));
    assert_eq!(a.image, b.image);
    assert_eq!(a.counters, b.counters);
    assert!(a.counters.secondary_rays > 0 && a.counters.shadow_rays > 0);
}

#[test]
fn debug_tree_records_blocked_shadow_rays_and_reflections() {
    use rtdiff::integrator::debug::{RayKind, RayTree};
    let d = temp_dir("debug-tree");
    let q = obj_quad(&d, "q.obj", 2.0, 0.0);
    let b =
        [Vec3::new(0.7, 0.8, -1.0), Vec3::new(0.3, 0.8, -1.0), Vec3::new(0.3, 1.2, -1.0), Vec3::new(0.7, 1.2, -1.0)];
    write(&d, "b.obj", &quad_obj(b));
    let s = scene(
        &d,
        &one_pixel(
            &format!(
                r#""materials": {{ "m": {{ "kd": [0.5, 0.5, 0.5], "ks": [0.5, 0.5, 0.5] }} }},
                   "meshes": [ {{ "file": "{q}", "material": "m" }}, {{ "file": "b.obj" }} ],
                   "lights": [ {{ "type": "point", "position": [1, 2, -2], "color": [1, 1, 1] }} ]"#
            ),
            0.0,
            0.0,
        ),
    );
    let tracer = rtdiff::backends::build_tracer(s.prims.clone(), &s.accel).unwrap();
    let integ = rtdiff::integrator::Whitted::new(&s, tracer.as_ref(), s.plan());
    let mut tree = RayTree::default();
    let mut c = rtdiff::integrator::Counters::default();
    let mut rng = rtdiff::rng::Pcg32::new(0, 0);
    let color = integ.trace_as(RayKind::Camera, &s.camera.ray(0.5, 0.5), 0, &mut rng, &mut c, &mut tree);
    let root = &tree.roots[0];
    assert_eq!(root.color, <[f32; 3]>::from(color));
    let hit = root.hit.as_ref().unwrap();
    assert!(hit.prim < 2, "the camera ray hits the big quad");
    // The only light sample is blocked by the small quad (primitives 2 and 3), about halfway.
    assert_eq!(root.lights.len(), 1);
    let (blocker, t) = root.lights[0].shadow_rays[0].blocked_by.unwrap();
    assert!((2..4).contains(&blocker) && (t - 0.5).abs() < 0.01, "{blocker} {t}");
    assert_eq!(root.lights[0].visibility, 0.0);
    // The mirror part spawns one reflection ray, which leaves the scene.
    assert_eq!(root.children.len(), 1);
    assert_eq!(root.children[0].kind, RayKind::Reflection);
    assert!(root.children[0].hit.is_none());
}
