//! The statistical test of `verify::image::stats` on real renders: K
//! independent seeds of the area-light Cornell box on each side agree, and
//! the same renders with the light 1% brighter fail (power at the sample
//! counts the scene ships with).

mod common;

use std::path::Path;

use common::render_with;
use rtdiff::scene::{Overrides, Scene};
use rtdiff::verify::image::{Image, Moments, WelchOptions, welch_test};

const K: u64 = 6;

fn renders(first_seed: u64) -> Vec<Image> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box_parallelogram_light.json");
    (first_seed..first_seed + K)
        .map(|seed| {
            let ov = Overrides { width: Some(64), height: Some(64), seed: Some(seed), ..Default::default() };
            render_with(&Scene::load_with(&path, &ov).unwrap(), None).image
        })
        .collect()
}

#[test]
fn area_light_seeds_agree_and_a_one_percent_brighter_light_fails() {
    let reference = Moments::from_images(&renders(1)).unwrap();
    let test_images = renders(1001);
    let test = Moments::from_images(&test_images).unwrap();
    let opts = WelchOptions::default();
    let same = welch_test(&reference, &test, &opts).unwrap();
    eprintln!("agreeing seeds: {}", serde_json::to_string(&same).unwrap());
    assert!(same.passed, "independent seeds of one renderer must agree at q = {}", opts.fdr);
    // The image is linear in the light's intensity: scaling the test renders by 1.01 is the
    // "light intensity x1.01" wrong variant.
    let brighter: Vec<Image> = test_images
        .iter()
        .map(|im| Image { pixels: im.pixels.iter().map(|p| *p * 1.01).collect(), ..im.clone() })
        .collect();
    let wrong = welch_test(&reference, &Moments::from_images(&brighter).unwrap(), &opts).unwrap();
    eprintln!("light x1.01: {}", serde_json::to_string(&wrong).unwrap());
    // Per pixel the 1% is within the noise; the image-wide tests catch it (measured z = 12-16).
    assert!(!wrong.passed && wrong.global_rejected, "a 1% brighter light must fail");
    assert!(wrong.bias2 > 0.0 && wrong.mean_difference > 0.0);
}
