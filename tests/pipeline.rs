//! The whole pipeline in one library call: `pipeline::render_scene` returns
//! the final image (bloom included) and typed statistics, identical to the
//! stages run by hand.

mod common;

use rtdiff::backends::build_tracer;
use rtdiff::post::bloom;
use rtdiff::render::{RenderOptions, render};

#[test]
fn render_scene_applies_post_processing_and_reports_typed_stats() {
    let dir = common::temp_dir("pipeline");
    let json = r#"{
        "image": {"width": 40, "height": 30},
        "features": {"bloom": true},
        "params": {"bloom": {"threshold": 0.2}},
        "spheres": [{"center": [0, 0, 0], "radius": 0.8}],
        "lights": [{"type": "point", "position": [-1, 2, -2], "color": [3, 3, 3]}]
    }"#;
    let scene = common::scene(&dir, json);
    let opts = RenderOptions { threads: Some(1), quiet: true };
    let out = rtdiff::pipeline::render_scene(&scene, &opts).unwrap();

    let tracer = build_tracer(scene.prims.clone(), &scene.accel).unwrap();
    let raw = render(&scene, tracer.as_ref(), &opts).unwrap();
    assert!(raw.plan.bloom);
    let want = bloom::bloom(&raw.image, &scene.params.bloom);
    assert_eq!(out.image.pixels, want.pixels, "the pipeline's image is the bloomed render");
    assert_ne!(out.image.pixels, raw.image.pixels, "bloom changed nothing: the test would not see it missing");

    let s = &out.stats;
    assert_eq!((s.triangles, s.spheres), (0, 1));
    assert_eq!(s.tracer, scene.accel.label());
    assert_eq!(s.counters, raw.counters);
    assert_eq!(s.rays, raw.counters.total_rays());
    let v: serde_json::Value = serde_json::to_value(s).unwrap();
    for key in ["scene", "triangles", "spheres", "tracer", "build_ms", "render_ms", "counters", "plan"] {
        assert!(v.get(key).is_some(), "stats JSON lacks {key}");
    }
}
