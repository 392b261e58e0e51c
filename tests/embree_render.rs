//! Images rendered with Embree's hits equal the native ones except where the
//! two tracers legitimately differ: at ties (coincident or edge-sharing
//! triangles at equal distance, where either primitive is a correct answer).
#![cfg(feature = "embree")]

mod common;

use rtdiff::backends;
use rtdiff::backends::Backend;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::{Overrides, Scene};
use rtdiff::verify::image::agreement::{REL_TOL, agreement};

#[test]
fn embree_and_native_images_agree_except_at_ties() {
    let names = common::scene_files();
    for path in names {
        let ov = Overrides { width: Some(96), height: Some(96), spp: Some(1), ..Default::default() };
        let scene = Scene::load_with(&path, &ov).unwrap();
        let native = backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap();
        let cfg = backends::AccelConfig { backend: Backend::Embree, ..scene.accel };
        let embree = backends::build_tracer(scene.prims.clone(), &cfg).unwrap();
        let opts = RenderOptions { threads: None, quiet: true };
        let a = render(&scene, native.as_ref(), &opts).unwrap();
        let b = render(&scene, embree.as_ref(), &opts).unwrap();
        let ag = agreement(&scene, &a.image, native.as_ref(), &b.image, embree.as_ref());
        println!(
            "{}: {} pixels, {} primary ties, max rel diff elsewhere {:.2e}, {} pixels over {REL_TOL:e}",
            path.file_name().unwrap().to_string_lossy(),
            ag.pixels,
            ag.primary_ties,
            ag.max_rel,
            ag.over
        );
        assert!(ag.passes(), "{}: {ag:?} is beyond the tolerances", path.display());
    }
}
