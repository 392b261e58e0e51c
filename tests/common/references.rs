//! The Mitsuba references of `reference/` (made by scripts/mitsuba/make_references.py):
//! the manifest, the scenes as rtdiff loads them for each reference, and rtdiff's
//! renders of them. Shared by tests/mitsuba_reference.rs and tests/image_crosscheck.rs.

use std::path::{Path, PathBuf};

use super::root;

use rtdiff::accel::Tracer;
use rtdiff::backends;
use rtdiff::film::Image;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::digest::traced_sha256;
use rtdiff::scene::export::mitsuba::force_shading_model;
use rtdiff::scene::{Overrides, Scene, SceneFile};
use rtdiff::shading::ShadingModelKind;

/// One entry of reference/manifest.json.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Reference name (the scene's file stem).
    pub name: String,
    /// Scene file.
    pub scene: PathBuf,
    /// Feature switches the reference was made with.
    pub features: Vec<(String, bool)>,
    /// Shading model every material was switched to.
    pub model: ShadingModelKind,
    /// Pixel centres, no sampling: one render is exact.
    pub deterministic: bool,
    /// Mitsuba seeds averaged (K).
    pub seeds: u32,
    /// Mean image.
    pub image: PathBuf,
    /// One-image variance over the seeds (noisy references).
    pub variance: Option<PathBuf>,
    /// `traced_sha256` of the scene as exported: what Mitsuba traced.
    pub traced: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Made by Mitsuba's own emitters, BSDFs and integrators (else by the rtdiff_whitted plugin).
    pub native: bool,
    /// Camera samples per pixel the reference was exported (and is rendered) with, if not the scene's.
    pub spp: Option<u32>,
    /// Recursion depth the reference was exported (and is rendered) with, if not the scene's.
    pub max_depth: Option<u32>,
}

impl Reference {
    /// `scene.model` (`scene.model.native` for a native reference), as the tests print it.
    pub fn name(&self) -> String {
        let m = if self.model == ShadingModelKind::Phong { "phong" } else { "physical" };
        format!("{}.{m}{}", self.name, if self.native { ".native" } else { "" })
    }
}

fn sha256_hex(path: &Path) -> String {
    use sha2::{Digest, Sha256};
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// Every reference of the manifest (the scene files' sha256 checked on the way).
pub fn manifest() -> Vec<Reference> {
    let dir = root().join("reference");
    let text = std::fs::read_to_string(dir.join("manifest.json")).expect("reference/manifest.json");
    let m: serde_json::Value = serde_json::from_str(&text).unwrap();
    let (w, h) = (m["width"].as_u64().unwrap() as u32, m["height"].as_u64().unwrap() as u32);
    m["references"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            let scene = root().join(e["scene"].as_str().unwrap());
            assert_eq!(
                sha256_hex(&scene),
                e["scene_sha256"].as_str().unwrap(),
                "{} changed since its reference was made: run scripts/mitsuba/make_references.py",
                scene.display()
            );
            Reference {
                name: e["name"].as_str().unwrap().to_string(),
                scene,
                features: e["features"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|f| rtdiff::cli::render::parse_feature(f.as_str().unwrap()).unwrap())
                    .collect(),
                model: if e["model"] == "phong" { ShadingModelKind::Phong } else { ShadingModelKind::Physical },
                deterministic: e["deterministic"].as_bool().unwrap(),
                seeds: e["seeds"].as_array().unwrap().len() as u32,
                image: dir.join(e["image"].as_str().unwrap()),
                variance: e["variance"].as_str().map(|v| dir.join(v)),
                traced: e["traced_sha256"].as_str().expect("manifest entry without traced_sha256").to_string(),
                width: e["width"].as_u64().map_or(w, |v| v as u32),
                height: e["height"].as_u64().map_or(h, |v| v as u32),
                native: e["oracle"] == "native",
                spp: e["spp"].as_u64().map(|v| v as u32),
                max_depth: e["max_depth"].as_u64().map(|v| v as u32),
            }
        })
        .collect()
}

/// Why `scene` is not what the reference `r` was rendered from, if it is not: the
/// scene file's sha256 is checked by [`manifest`]; this catches a change in the
/// code that loads, places or normalises meshes or decodes textures.
pub fn stale(r: &Reference, scene: &Scene) -> Option<String> {
    let now = traced_sha256(scene);
    (now != r.traced).then(|| {
        format!(
            "{}: what rtdiff traces changed since its reference was made (traced_sha256 {now}, manifest {}): \
             run scripts/mitsuba/make_references.py",
            r.name(),
            r.traced
        )
    })
}

/// The scene of `r` as rtdiff loads it, with `tweak` applied to the file first.
pub fn load(r: &Reference, seed: u64, tweak: &dyn Fn(&mut SceneFile)) -> Scene {
    let mut file = Scene::read_file(&r.scene).unwrap();
    force_shading_model(&mut file, r.model);
    tweak(&mut file);
    let ov = Overrides {
        width: Some(r.width),
        height: Some(r.height),
        seed: Some(seed),
        spp: r.spp,
        max_depth: r.max_depth,
        features: r.features.clone(),
        ..Default::default()
    };
    Scene::from_file_with(file, &r.scene, &ov).unwrap()
}

/// rtdiff's image (before post-processing) of `scene`, its tracer wrapped by `wrap`.
pub fn render_with(scene: &Scene, wrap: &dyn Fn(Box<dyn Tracer>) -> Box<dyn Tracer>) -> Image {
    let tracer = wrap(backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap());
    render(scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true }).unwrap().image
}

/// The tracer as it is (the `wrap` of [`render_with`] for an unmodified render).
pub fn plain(t: Box<dyn Tracer>) -> Box<dyn Tracer> {
    t
}

/// The reference called `name` (`scene.model`).
pub fn reference(name: &str) -> Reference {
    manifest().into_iter().find(|r| r.name() == name).unwrap_or_else(|| panic!("no reference {name}"))
}

/// No change to the scene file.
pub fn no_tweak(_: &mut SceneFile) {}
