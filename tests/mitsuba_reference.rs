//! rtdiff's shaded images against Mitsuba 3 (reference/, made by
//! scripts/mitsuba/make_references.py; no Python needed here).
//!
//! Every referenced scene is rendered with rtdiff through the library's render
//! call, in the model and at the size the manifest names, and checked:
//!
//! - **deterministic** scenes (pixel centres, point lights, mirrors, textures):
//!   at least 99.9% of pixels within 1e-3 relative (see `common::checks::REL_TOL`); the other
//!   pixels are listed and classified (silhouette, triangle edge, shadow
//!   terminator, shadow edge), and an unexplained one fails the test;
//! - **noisy** scenes (area lights, glossy, depth of field, pixel jitter):
//!   Welch's test per pixel and image-wide with Benjamini-Hochberg at
//!   false-alarm rate q = 0.01 against the reference's mean and variance over K
//!   seeds, rtdiff's over [`TEST_SEEDS`] seeds;
//! - every reference records what Mitsuba traced (`traced_sha256`, see
//!   [`rtdiff::scene::digest`]): a reference made from other triangles, normals,
//!   textures, lights or camera is reported stale, not compared.
//!
//! Power: each check must also *fail* on a deliberately wrong variant
//! (light x1.01, texture v flipped, mirror weight x1.01, camera half a pixel
//! off, one shadow ray in a hundred missed, aperture x1.1, glossy spread x1.1),
//! at the same settings.

mod common;

use std::sync::atomic::{AtomicU64, Ordering};

use common::checks::{
    Exact, FDR, MIN_AGREEING, exact_check, exact_check_with, numerically_black, summary, welch_summary,
};
use common::references::{Reference, load, manifest, no_tweak, plain, reference, render_with, stale};
use glam::Vec3;
use rtdiff::accel::Tracer;
use rtdiff::film::Image;
use rtdiff::geometry::offset::{MITSUBA_RAY_EPSILON, SpawnOffset};
use rtdiff::geometry::{Hit, Ray};
use rtdiff::scene::file::LightSpec;
use rtdiff::scene::{Scene, SceneFile};
use rtdiff::verify::image::stats::{Moments, WelchOptions, WelchReport, welch_test};

/// Independent rtdiff renders of a noisy scene (the reference's K, 64, is in the manifest).
/// The per-pixel t-tests are decided by Benjamini-Hochberg in their far tail (p ~ q / 10^4),
/// where Welch's t-distribution is only as good as the normality of the per-seed pixel values
/// and of their variance estimates: 32 seeds against 64 give Welch df ~ 60 (31 to 95 with
/// unequal variances) where 8 against 16 gave ~ 7-20, and twice the power. Measured on
/// cube.phong at 128x128 (issue 9): with 16 / 8 the check raised 1 false alarm in 25 disjoint
/// Mitsuba-vs-rtdiff comparisons at q = 0.01, and the first reference was that one (pixel
/// (65, 64), whose 8 rtdiff values happened to lie in the top quarter of their distribution);
/// 400 Mitsuba seeds against 1200 rtdiff seeds reject nothing (min p 3.3e-4 over 8592 tests,
/// one-image variance ratio Mitsuba/rtdiff 1.00, 1st-99th percentile 0.83-1.18, image-wide z
/// 0.56 / -0.26 / -0.20): no bias.
const TEST_SEEDS: u32 = 32;

fn noisy_check(
    r: &Reference,
    tweak: &dyn Fn(&mut SceneFile),
    wrap: &dyn Fn(Box<dyn Tracer>) -> Box<dyn Tracer>,
) -> WelchReport {
    noisy_check_with(r, &|seed| load(r, seed, tweak), wrap)
}

/// [`noisy_check`] of the loaded scene changed by `edit`.
fn noisy_check_edited(r: &Reference, edit: &dyn Fn(&mut Scene)) -> WelchReport {
    let scene = |seed| {
        let mut s = load(r, seed, &no_tweak);
        edit(&mut s);
        s
    };
    noisy_check_with(r, &scene, &plain)
}

fn noisy_check_with(
    r: &Reference,
    scene: &dyn Fn(u64) -> Scene,
    wrap: &dyn Fn(Box<dyn Tracer>) -> Box<dyn Tracer>,
) -> WelchReport {
    let mean = Image::read_exr(&r.image).unwrap();
    let var = Image::read_exr(r.variance.as_ref().unwrap()).unwrap();
    let reference = Moments::from_mean_variance(&mean, &var, r.seeds).unwrap();
    let imgs: Vec<Image> = (0..TEST_SEEDS).map(|k| render_with(&scene(1000 + k as u64), wrap)).collect();
    let mut test = Moments::from_images(&imgs).unwrap();
    let mut reference = reference;
    numerically_black(&mut reference, &mut test);
    welch_test(&reference, &test, &WelchOptions { fdr: FDR, ..Default::default() }).unwrap()
}

/// Mitsuba 3's own spawn rule (`spawn_ray`) in place of rtdiff's.
fn mitsuba_spawn(f: &mut SceneFile) {
    f.params.ray_offset = SpawnOffset::ScaledNormal { epsilon: MITSUBA_RAY_EPSILON };
}

#[test]
fn every_referenced_scene_agrees_with_mitsuba() {
    let refs = manifest();
    assert!(refs.len() >= 20, "reference/manifest.json lists {} references", refs.len());
    let mut failures = Vec::new();
    for r in &refs {
        if let Some(why) = stale(r, &load(r, 0, &no_tweak)) {
            failures.push(why);
            continue;
        }
        let t0 = std::time::Instant::now();
        if r.deterministic {
            let scene = load(r, 0, &no_tweak);
            let img = render_with(&scene, &plain);
            // Mitsuba's own integrators start rays by their own rule: rtdiff's render with it
            // tells which pixels differ only by that.
            let offset = r.native.then(|| render_with(&load(r, 0, &mitsuba_spawn), &plain));
            let e = exact_check_with(&scene, &Image::read_exr(&r.image).unwrap(), &img, offset.as_ref());
            println!("{:<42} exact  {} [{:.2} s]", r.name(), summary(&e), t0.elapsed().as_secs_f64());
            for b in e.bad.iter().take(12) {
                println!("    pixel ({}, {}) rel {:.2e} {:?}", b.0, b.1, b.2, b.3);
            }
            if !e.passed() {
                failures.push(format!("{}: {}", r.name(), summary(&e)));
            }
        } else {
            let w = noisy_check(r, &no_tweak, &plain);
            println!("{:<42} welch  {} [{:.2} s]", r.name(), welch_summary(&w), t0.elapsed().as_secs_f64());
            if !w.passed {
                failures.push(format!("{}: {}", r.name(), welch_summary(&w)));
            }
        }
    }
    assert!(failures.is_empty(), "disagreements with Mitsuba:\n{}", failures.join("\n"));
}

fn scale_lights(f: &mut SceneFile, k: f32) {
    for l in &mut f.lights {
        match l {
            LightSpec::Point { color, .. } => *color *= k,
            LightSpec::Segment { colors, .. } => colors.iter_mut().for_each(|c| *c *= k),
            LightSpec::Parallelogram { colors, .. } => colors.iter_mut().for_each(|c| *c *= k),
        }
    }
}

/// The deterministic check on a wrong variant: must fail.
fn exact_fails(name: &str, tweak: &dyn Fn(&mut SceneFile), edit: &dyn Fn(&mut Scene)) -> Exact {
    let r = reference(name);
    let mut scene = load(&r, 0, tweak);
    edit(&mut scene);
    let e = exact_check(&scene, &Image::read_exr(&r.image).unwrap(), &render_with(&scene, &plain));
    println!("{name} wrong variant: {}", summary(&e));
    assert!(e.agreeing < MIN_AGREEING, "{name}: the wrong variant passed: {}", summary(&e));
    e
}

#[test]
fn light_intensity_one_percent_high_fails_the_exact_check() {
    // Against the plugin's references and against Mitsuba's own point emitters and BSDFs.
    for name in
        ["cornell_box.phong", "spheres.physical", "monkey.phong", "spheres.physical.native", "teapot.physical.native"]
    {
        exact_fails(name, &|f| scale_lights(f, 1.01), &|_| {});
    }
}

#[test]
fn texture_v_flipped_fails_the_exact_check() {
    exact_fails("cube_textured.phong", &no_tweak, &|s| {
        for m in &mut s.materials {
            if let Some(t) = &m.kd_texture {
                let mut t = (**t).clone();
                let w = t.width as usize;
                let rows: Vec<Vec3> = t.texels.chunks(w).rev().flatten().copied().collect();
                t.texels = rows;
                m.kd_texture = Some(std::sync::Arc::new(t));
            }
        }
    });
}

fn mirror_weight_one_percent_high(s: &mut Scene) {
    for m in &mut s.materials {
        if m.is_reflective() {
            m.ks *= 1.01;
        }
    }
}

#[test]
fn mirror_weight_one_percent_high_fails_the_exact_check() {
    exact_fails("cornell_box.physical", &no_tweak, &mirror_weight_one_percent_high);
}

/// The same against Mitsuba's own `blendbsdf` (diffuse + smooth `conductor`) and `path`
/// integrator (one bounce, 4 L(1/2) - L(1)): the Welch check must fail. The mirror's pixels
/// reject one by one (the image-wide z is dominated by the pixels beside the point light, whose
/// variance is 10^5 times the mirror's).
#[test]
fn mirror_weight_one_percent_high_fails_against_the_native_reference() {
    let r = reference("cornell_box.physical.native");
    let w = noisy_check_edited(&r, &mirror_weight_one_percent_high);
    println!("cornell_box.physical.native, Ks x1.01: {}", welch_summary(&w));
    assert!(!w.passed && w.rejected_pixels > 100, "a 1% stronger mirror passed: {}", welch_summary(&w));
}

/// Texture wrap modes (repeat, mirror, clamp) against Mitsuba's own `bitmap` `wrap_mode`, with
/// nearest and bilinear lookups: scenes/texture_wrap.json frames each rectangle (uvs -1 to 2 and
/// -0.5 to 1.5) so that no pixel centre lies on a texel edge or a triangle edge, and every pixel
/// must agree (not 99.9%).
#[test]
fn wrap_modes_agree_with_mitsubas_bitmap_on_every_pixel() {
    for name in ["texture_wrap.physical.native", "texture_wrap_bilinear.physical.native", "texture_wrap.phong"] {
        let r = reference(name);
        let scene = load(&r, 0, &no_tweak);
        let e = exact_check(&scene, &Image::read_exr(&r.image).unwrap(), &render_with(&scene, &plain));
        println!("{name}: {}", summary(&e));
        assert!(e.bad.is_empty(), "{name}: {}", summary(&e));
    }
}

/// One wrap mode swapped (repeat and mirror exchanged, or clamp read as repeat) must fail against
/// Mitsuba's `bitmap`, nearest and bilinear.
#[test]
fn wrap_mode_swapped_fails_the_exact_check() {
    use rtdiff::texture::WrapMode;
    let swap = |f: &mut SceneFile| {
        for m in f.materials.values_mut() {
            m.texture_wrap = match m.texture_wrap {
                Some(WrapMode::Repeat) => Some(WrapMode::Mirror),
                Some(WrapMode::Mirror) => Some(WrapMode::Repeat),
                w => w,
            };
        }
    };
    let clamp_as_repeat = |f: &mut SceneFile| {
        for m in f.materials.values_mut().filter(|m| m.texture_wrap == Some(WrapMode::Clamp)) {
            m.texture_wrap = Some(WrapMode::Repeat);
        }
    };
    for name in ["texture_wrap.physical.native", "texture_wrap_bilinear.physical.native"] {
        let a = exact_fails(name, &swap, &|_| {});
        let b = exact_fails(name, &clamp_as_repeat, &|_| {});
        assert!(a.agreeing < 0.9 && b.agreeing < 0.9, "{name}: {} / {}", summary(&a), summary(&b));
    }
}

#[test]
fn camera_half_a_pixel_off_fails_the_exact_check() {
    exact_fails("teapot.phong", &no_tweak, &|s| {
        let c = &mut s.camera;
        let step = 2.0 * c.tan_half_fov / c.height as f32;
        c.forward = (c.forward + 0.5 * step * c.right).normalize();
    });
}

/// A tracer that misses one shadow ray in a hundred (by a hash of the ray).
struct LeakyShadows {
    inner: Box<dyn Tracer>,
    calls: AtomicU64,
}

impl Tracer for LeakyShadows {
    fn name(&self) -> String {
        "leaky".into()
    }
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.inner.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.calls.fetch_add(1, Ordering::Relaxed);
        let h = (ray.origin.x.to_bits() ^ ray.dir.y.to_bits().rotate_left(13) ^ ray.dir.z.to_bits().rotate_left(7))
            .wrapping_mul(0x9E37_79B9);
        if h.is_multiple_of(100) { false } else { self.inner.occluded(ray) }
    }
}

fn leaky(t: Box<dyn Tracer>) -> Box<dyn Tracer> {
    Box::new(LeakyShadows { inner: t, calls: AtomicU64::new(0) })
}

#[test]
fn noisy_check_catches_one_percent_light_bias() {
    // The plugin's parallelogram and segment lights, and Mitsuba's own area emitter.
    for name in ["cornell_box_parallelogram_light.physical", "cube.phong", "cornell_box_area_light.physical.native"] {
        let r = reference(name);
        let w = noisy_check(&r, &|f| scale_lights(f, 1.01), &plain);
        println!("{name} light x1.01: {}", welch_summary(&w));
        // The image-wide test must reject (the per-pixel tests alone cannot see 1% at this noise).
        assert!(!w.passed && w.global_rejected, "{name}: a 1% brighter light passed: {}", welch_summary(&w));
    }
}

#[test]
fn noisy_check_catches_one_missed_shadow_ray_in_a_hundred() {
    let r = reference("cornell_box_parallelogram_light.phong");
    let w = noisy_check(&r, &no_tweak, &leaky);
    println!("cornell_box_parallelogram_light.phong, 1 shadow ray in 100 missed: {}", welch_summary(&w));
    assert!(!w.passed && w.global_rejected, "missing 1% of shadow rays passed: {}", welch_summary(&w));
}

#[test]
fn exact_check_catches_one_missed_shadow_ray_in_a_hundred() {
    let r = reference("cornell_box.phong");
    let scene = load(&r, 0, &no_tweak);
    let e = exact_check(&scene, &Image::read_exr(&r.image).unwrap(), &render_with(&scene, &leaky));
    println!("cornell_box.phong, 1 shadow ray in 100 missed: {}", summary(&e));
    assert!(!e.passed(), "{}", summary(&e));
}

/// A change in mesh placement code (here: one vertex moved by one float32 step, as a new
/// normalisation would) leaves every scene file alone but must mark the reference stale.
#[test]
fn stale_reference_is_detected() {
    for name in ["dragon.phong", "cube_textured.physical", "all_features.phong"] {
        let r = reference(name);
        let mut scene = load(&r, 0, &no_tweak);
        assert_eq!(stale(&r, &scene), None, "{name}: reference/ is stale");
        let mut prims = (*scene.prims).clone();
        let mid = prims.triangles.len() / 2;
        let v = &mut prims.triangles[mid].v[1];
        v.y = f32::from_bits(v.y.to_bits() + 1);
        scene.prims = std::sync::Arc::new(prims);
        let why = stale(&r, &scene).unwrap_or_else(|| panic!("{name}: a moved vertex went unnoticed"));
        assert!(why.contains("make_references.py"), "{why}");
    }
}

/// The Welch check on a wrong variant of the reference `name` (its scene file changed by
/// `tweak`): must fail.
fn noisy_fails(name: &str, what: &str, tweak: &dyn Fn(&mut SceneFile)) {
    let r = reference(name);
    let w = noisy_check(&r, tweak, &plain);
    println!("{name} {what}: {}", welch_summary(&w));
    assert!(!w.passed, "{name}: {what} passed: {}", welch_summary(&w));
}

/// Depth of field: the thin lens 10% wider blurs everything off the focus plane 10% more
/// (scenes/depth_of_field.json: checker edges blurred over ~8 pixels; in all_features the
/// blur is ~1 pixel and a 10% change is below what 64 + 32 seeds can see).
#[test]
fn noisy_check_catches_aperture_ten_percent_wide() {
    noisy_fails("depth_of_field.phong", "aperture x1.1", &|f| f.camera.aperture *= 1.1);
}

/// Glossy reflection: the reports' square of side 1 / shininess 10% wider on the glossy floor
/// of scenes/glossy.json (the checker cube's reflection blurred 10% more).
#[test]
fn noisy_check_catches_glossy_spread_ten_percent_wide() {
    noisy_fails("glossy.phong", "glossy spread x1.1", &|f| {
        for m in f.materials.values_mut().filter(|m| m.ks.is_some_and(|ks| ks.x > 0.5)) {
            m.shininess = m.shininess.map(|s| s / 1.1);
        }
    });
}

/// Transparency: the glass sphere of all_features 10% less transparent (0.6 -> 0.54), so
/// 10% less of what lies behind it shows through.
#[test]
fn noisy_check_catches_transparency_ten_percent_low() {
    noisy_fails("all_features.phong", "transparency x0.9", &|f| {
        for m in f.materials.values_mut() {
            m.transparency = m.transparency.map(|t| t * 0.9);
        }
    });
}
