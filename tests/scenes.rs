//! Every scene in scenes/ loads and renders with its own settings (at a small
//! size), and shows something. Meshes under assets/ come from
//! scripts/fetch-assets.sh (scripts/test.sh runs it first).

mod common;

use rtdiff::backends;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::{Overrides, Scene};

#[test]
fn every_scene_renders_with_its_defaults() {
    let names = common::scene_files();
    assert!(names.len() >= 11, "expected the reference scene set, found {names:?}");
    for path in names {
        let ov = Overrides { width: Some(24), height: Some(24), ..Default::default() };
        let scene = Scene::load_with(&path, &ov).unwrap_or_else(|e| panic!("{e}"));
        let tracer = backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap();
        let r = render(&scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true }).unwrap();
        let lit = r.image.pixels.iter().filter(|p| p.max_element() > 0.01).count();
        assert!(lit > 10, "{}: only {lit} of 576 pixels are not black", path.display());
        assert!(r.image.pixels.iter().all(|p| p.is_finite()), "{}: non-finite pixel", path.display());
    }
}
