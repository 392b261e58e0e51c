//! `rtdiff debug --draw` and `--heatmap`: drawing never changes the render
//! under the lines, the traversal overlay's green path ends in the leaf that
//! holds the hit, and heatmap totals equal the traversal counters of the
//! same rays (and the render's own ray counters). The dragon comes from
//! scripts/fetch-assets.sh (scripts/test.sh runs it first).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use rtdiff::backends;
use rtdiff::backends::{AccelConfig, Backend};
use rtdiff::bvh::{BvhTracer, TraversalCounts, VisitLog};
use rtdiff::debug::{self, Metric, overlay};
use rtdiff::geometry::TriangleTest;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::{Overrides, Scene};

const QUIET: RenderOptions = RenderOptions { threads: None, quiet: true };

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.json"))
}

fn load(name: &str, size: u32, features: &[(&str, bool)]) -> Scene {
    let ov = Overrides {
        width: Some(size),
        height: Some(size),
        features: features.iter().map(|&(n, on)| (n.to_string(), on)).collect(),
        ..Default::default()
    };
    Scene::load_with(&scene_path(name), &ov).unwrap_or_else(|e| panic!("{e}"))
}

/// Every overlay of `rtdiff debug --draw`, each at a pixel that sees the scene.
fn overlays(pixel: (u32, u32)) -> Vec<Box<dyn overlay::Overlay>> {
    ["bvh-level=2", "bvh-leaf=1", "traversal", "rays", "normals", "sah-splits", "focal-plane"]
        .iter()
        .map(|w| overlay::parse(w, Some(pixel), None).unwrap_or_else(|e| panic!("{w}: {e}")))
        .collect()
}

#[test]
fn drawing_never_changes_the_render_under_it() {
    for (name, pixel) in [("cornell_box", (40, 52)), ("dragon", (48, 48))] {
        let mut scene = load(name, 96, &[]);
        let tracer = backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap();
        let plain = render(&scene, tracer.as_ref(), &QUIET).unwrap().image;
        let accel = scene.accel;
        for o in overlays(pixel) {
            for view in [None, Some(debug::draw::orbit(&scene.camera, 30.0))] {
                let d = debug::draw(&mut scene, o.as_ref(), &accel, view.clone(), &QUIET).unwrap();
                let what = format!("{name} {} (orbit {})", d.name, view.is_some());
                if view.is_none() {
                    assert_eq!(d.render, plain, "{what}: the render under the overlay is not rtdiff render's");
                }
                let drawn = d.mask.iter().filter(|&&m| m).count();
                assert!(drawn > 0 && !d.lines.is_empty(), "{what}: nothing drawn");
                assert!(drawn < d.mask.len(), "{what}: every pixel drawn");
                assert!(
                    debug::draw::same_outside(&d.render, &d.image, &d.mask),
                    "{what}: a pixel off the lines changed"
                );
                let changed = d.image.pixels.iter().zip(&d.render.pixels).filter(|(a, b)| a != b).count();
                assert!(changed > 0, "{what}: the lines changed no pixel");
            }
            assert_eq!(scene.camera, load(name, 96, &[]).camera, "{name}: draw did not restore the camera");
        }
    }
}

#[test]
fn the_green_path_ends_in_the_leaf_holding_the_hit() {
    let scene = load("dragon", 48, &[]);
    for builder in rtdiff::backends::builders() {
        for traversal in rtdiff::backends::traversals() {
            let cfg = AccelConfig { builder, traversal, ..Default::default() };
            let bvh = BvhTracer::new(&scene.prims, &cfg);
            let mut hits = 0;
            for y in 0..48 {
                for x in 0..48 {
                    let ray = scene.camera.pixel_centre_ray(x, y);
                    let mut log = VisitLog::default();
                    let hit = bvh.intersect_with(&ray, &mut log);
                    assert_eq!(
                        hit,
                        bvh.binary().map_or_else(
                            || bvh.wide().unwrap().intersect(&ray, TriangleTest::Watertight),
                            |_| rtdiff::accel::Tracer::intersect(&bvh, &ray)
                        )
                    );
                    let Some(hit) = hit else {
                        assert_eq!(log.hit_leaf(), None);
                        continue;
                    };
                    hits += 1;
                    let leaf = log.hit_leaf().expect("a hit comes from a leaf");
                    let ids: Vec<u32> = match (bvh.binary(), bvh.wide()) {
                        (Some(b), _) => {
                            let n = b.nodes[leaf as usize];
                            assert!(n.is_leaf());
                            b.prims.entries[n.offset as usize..(n.offset + n.count) as usize]
                                .iter()
                                .map(|e| e.id)
                                .collect()
                        }
                        (None, Some(w)) => {
                            let pk = w.packets().expect("a triangle mesh is packed");
                            let count = w
                                .nodes()
                                .iter()
                                .flat_map(|n| n.child.iter().zip(n.count))
                                .find(|(c, k)| **c == leaf && *k > 0)
                                .expect("the leaf is a lane")
                                .1;
                            pk.packets[leaf as usize..leaf as usize + rtdiff::bvh::packet::packets_for(count)]
                                .iter()
                                .flat_map(|p| p.id)
                                .collect()
                        }
                        _ => unreachable!(),
                    };
                    assert!(
                        ids.contains(&hit.prim),
                        "{builder:?}/{traversal:?}: prim {} not in the hit leaf {ids:?}",
                        hit.prim
                    );
                }
            }
            assert!(hits > 300, "{builder:?}/{traversal:?}: only {hits} hits");
        }
    }
}

#[test]
fn heatmap_totals_equal_the_traversal_counters_of_the_same_rays() {
    // Shading off: each pixel traces exactly its pinhole camera ray (spp 1).
    let scene = load("dragon", 64, &[("shading", false)]);
    for builder in rtdiff::backends::builders() {
        for traversal in rtdiff::backends::traversals() {
            let cfg = AccelConfig { builder, traversal, ..Default::default() };
            let hm = debug::heatmap(&scene, &cfg, &QUIET).unwrap();
            let bvh = BvhTracer::new(&scene.prims, &cfg);
            let mut total = TraversalCounts::default();
            for y in 0..64 {
                for x in 0..64 {
                    let mut c = TraversalCounts::default();
                    bvh.intersect_with(&scene.camera.pixel_centre_ray(x, y), &mut c);
                    assert_eq!(hm.pixels[(y * 64 + x) as usize], c, "{builder:?}/{traversal:?} pixel ({x}, {y})");
                    total.add(&c);
                }
            }
            assert_eq!(hm.totals, total, "{builder:?}/{traversal:?}");
            assert_eq!(hm.total(Metric::Rays), 64 * 64);
            assert_eq!(hm.counts(Metric::Nodes).iter().sum::<u64>(), total.nodes);
            assert_eq!(hm.counts(Metric::Triangles).iter().sum::<u64>(), total.triangles);
        }
    }
    // The fast path's counts are the ones the wide BVH's own counted traversal reports.
    let cfg = AccelConfig::default();
    let wide = rtdiff::bvh::build_wide(&scene.prims, &cfg);
    let mut c = TraversalCounts::default();
    for y in 0..64 {
        for x in 0..64 {
            wide.intersect_counted(&scene.camera.pixel_centre_ray(x, y), TriangleTest::Watertight, &mut c);
        }
    }
    assert_eq!(debug::heatmap(&scene, &cfg, &QUIET).unwrap().totals, c);
}

#[test]
fn heatmap_rays_equal_the_renders_ray_counters_for_any_thread_count() {
    for name in ["cornell_box", "cornell_box_parallelogram_light", "all_features"] {
        let scene = load(name, 32, &[]);
        let tracer = backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap();
        let counters = render(&scene, tracer.as_ref(), &QUIET).unwrap().counters;
        let cfg = AccelConfig { backend: Backend::Native, ..scene.accel };
        let one = debug::heatmap(&scene, &cfg, &RenderOptions { threads: Some(1), quiet: true }).unwrap();
        let two = debug::heatmap(&scene, &cfg, &RenderOptions { threads: Some(2), quiet: true }).unwrap();
        assert_eq!(one, two, "{name}: heatmap depends on the thread count");
        assert_eq!(one.total(Metric::Rays), counters.total_rays(), "{name}");
        assert!(counters.shadow_rays > 0, "{name}: no shadow rays exercised");
    }
}

#[test]
fn heatmap_image_has_the_picture_a_colour_bar_and_the_exr_the_counts() {
    let scene = load("cornell_box", 40, &[]);
    let hm = debug::heatmap(&scene, &scene.accel, &QUIET).unwrap();
    let img = hm.image(Metric::Nodes, None);
    assert!(img.width() > 40 && img.height() > 40);
    // A small map does not cut its title and statistics short: the canvas widens, so the
    // title band's last columns hold no text (drawn in (235, 235, 235)).
    for y in 0..36 {
        for x in img.width() - 6..img.width() {
            assert_ne!(img.get_pixel(x, y).0, [235, 235, 235], "text reaches the right edge at ({x}, {y})");
        }
    }
    let dir = common::temp_dir("heatmap-exr");
    let exr = dir.join("h.exr");
    hm.write_exr(&exr).unwrap();
    let read = exr::prelude::read_all_flat_layers_from_file(&exr).unwrap();
    let layer = &read.layer_data[0];
    for m in Metric::ALL {
        let ch = layer.channel_data.list.iter().find(|c| c.name.to_string() == m.name()).expect("channel");
        let vals: Vec<u64> = ch.sample_data.values_as_f32().map(|v| v as u64).collect();
        assert_eq!(vals, hm.counts(m), "{}", m.name());
    }
}

/// Run `rtdiff debug ARGS...`; return (exit code, stderr).
fn rtdiff_debug(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff")).arg("debug").args(args).output().expect("rtdiff runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "rtdiff panicked: {stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

#[test]
fn the_command_writes_pictures_and_rejects_bad_requests() {
    let dir = common::temp_dir("debug-cli");
    let cb = scene_path("cornell_box");
    let cb = cb.to_str().unwrap();
    let png = dir.join("t.png");
    let obj = dir.join("t.obj");
    let (code, err) = rtdiff_debug(&[
        cb,
        "--draw",
        "traversal",
        "--pixel",
        "10",
        "12",
        "--width",
        "24",
        "--height",
        "24",
        "-o",
        png.to_str().unwrap(),
        "--obj",
        obj.to_str().unwrap(),
        "--builder",
        "median",
        "--traversal",
        "basic",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(png.exists());
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.lines().any(|l| l.starts_with("l ")) && text.contains("traversal --pixel 10 12"));
    let hm = dir.join("h.png");
    let (code, err) =
        rtdiff_debug(&[cb, "--heatmap", "triangles", "--width", "24", "--height", "24", "-o", hm.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(hm.exists() && dir.join("h.exr").exists());
    for (args, needle) in [
        (vec!["--draw", "bvh-level=99"], "levels 0 to"),
        (vec!["--draw", "bvh-leaf=999"], "leaves"),
        (vec!["--draw", "traversal"], "needs --pixel"),
        (vec!["--draw", "rays", "--pixel", "500", "1"], "outside"),
        (vec!["--draw", "sah-splits", "--node", "100000"], "does not exist"),
        (vec!["--draw", "wireframe"], "expected bvh-level=N"),
        (vec!["--draw", "bvh-level=x"], "not a non-negative integer"),
    ] {
        let mut a = vec![cb, "--width", "24", "--height", "24", "-o", png.to_str().unwrap()];
        a.extend(args.iter().copied());
        let (code, err) = rtdiff_debug(&a);
        assert_ne!(code, 0, "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: stderr lacks {needle:?}: {err}");
    }
    let (code, err) = rtdiff_debug(&[cb, "--draw", "focal-plane", "-o", dir.join("x.jpg").to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(err.contains("x.jpg"), "{err}");
}
