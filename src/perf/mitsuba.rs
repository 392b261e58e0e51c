//! rtdiff against the Mitsuba 3 references in `reference/` (made by
//! scripts/mitsuba/make_references.py, listed in `reference/manifest.json`):
//! each referenced scene rendered by rtdiff in the same shading model and at
//! the same size, its metrics, and the pictures of a side-by-side row.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::Image;
use crate::render::{RenderOptions, render};
use crate::scene::export::mitsuba::force_shading_model;
use crate::scene::{Overrides, Scene};
use crate::shading::ShadingModelKind;
use crate::verify::image::diff_image::{write_error_png, write_flip_png};
use crate::verify::image::metrics::absolute_difference;
use crate::verify::image::{CompareOptions, FlipMode, compare, flip, read_image};

/// The manifest's fields this module reads.
#[derive(Clone, Debug, Deserialize)]
struct Manifest {
    mitsuba: String,
    variant: String,
    width: u32,
    height: u32,
    references: Vec<ManifestEntry>,
}

#[derive(Clone, Debug, Deserialize)]
struct ManifestEntry {
    name: String,
    scene: String,
    /// "native" (Mitsuba's own plugins) or "plugin" (absent in manifests before native references).
    #[serde(default)]
    oracle: Option<String>,
    /// The entry's own image size, camera samples and recursion depth, where not the manifest's or the scene's.
    #[serde(default)]
    width: Option<u32>,
    #[serde(default)]
    height: Option<u32>,
    #[serde(default)]
    spp: Option<u32>,
    #[serde(default)]
    max_depth: Option<u32>,
    model: ShadingModelKind,
    deterministic: bool,
    seeds: Vec<u64>,
    image: String,
    #[serde(default)]
    features: Vec<String>,
    #[serde(default)]
    light_samples: Option<u32>,
    #[serde(default)]
    variance: Option<String>,
}

/// One scene and model compared with Mitsuba.
#[derive(Clone, Debug, Serialize)]
pub struct MitsubaRow {
    /// Scene file (relative to the project root).
    pub scene: String,
    /// Shading model.
    pub model: ShadingModelKind,
    /// Made by Mitsuba's own emitters, BSDFs and integrators (else by the rtdiff_whitted plugin).
    pub native: bool,
    /// Pixel-centre scene (false: area lights, the reference is a mean over seeds).
    pub deterministic: bool,
    /// Seeds averaged in the reference.
    pub reference_seeds: usize,
    /// relMSE of rtdiff against Mitsuba.
    pub rel_mse: f64,
    /// Mean LDR-FLIP.
    pub flip: f64,
    /// Fraction of pixels whose relative difference exceeds 1e-3 (floor 1e-2).
    pub over_rel_threshold_fraction: f64,
    /// rtdiff's render time in ms.
    pub rtdiff_ms: f64,
    /// Pictures, relative to the images folder: rtdiff, Mitsuba, |difference| (magma), FLIP map.
    pub pictures: [String; 4],
    /// Full scale of the difference picture.
    pub diff_scale: f32,
}

/// Every comparison.
#[derive(Clone, Debug, Serialize)]
pub struct MitsubaReport {
    /// Mitsuba version and variant of the references.
    pub mitsuba: String,
    /// Image size.
    pub size: (u32, u32),
    /// One row per manifest entry.
    pub rows: Vec<MitsubaRow>,
}

fn manifest(root: &Path) -> Result<Option<Manifest>> {
    let path = root.join("reference").join("manifest.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, &e))?;
    serde_json::from_str(&text).map(Some).map_err(|e| Error::file(&path, format!("invalid manifest: {e}")))
}

/// A Mitsuba reference of a scene as its file stands (no feature switches).
#[derive(Clone, Debug)]
pub struct StoredReference {
    /// The image: one render, or the mean of `seeds` renders.
    pub image: Image,
    /// Per-pixel variance of the mean (the renders' sample variance over `seeds`), for noisy scenes.
    pub variance_of_mean: Option<Image>,
    /// What it is, for captions: "Mitsuba 3.9.1 (llvm_ad_rgb), mean of 16 seeds x 64 light samples".
    pub description: String,
}

/// The reference of `scene` (relative to `root`, e.g. `scenes/cube.json`) in `model` at
/// `width` x `height`, if `root/reference/manifest.json` lists one.
pub fn stored_reference(
    root: &Path,
    scene: &str,
    model: ShadingModelKind,
    width: u32,
    height: u32,
) -> Result<Option<StoredReference>> {
    let Some(m) = manifest(root)? else { return Ok(None) };
    // The scene as its file stands: no feature switch, camera samples or depth of the entry's own.
    let Some(e) = m.references.iter().find(|e| {
        e.scene == scene
            && e.model == model
            && e.features.is_empty()
            && e.spp.is_none()
            && e.max_depth.is_none()
            && (e.width.unwrap_or(m.width), e.height.unwrap_or(m.height)) == (width, height)
    }) else {
        return Ok(None);
    };
    let dir = root.join("reference");
    let image = read_image(&dir.join(&e.image))?;
    let k = e.seeds.len().max(1) as f32;
    let variance_of_mean = match &e.variance {
        Some(v) => {
            let mut var = read_image(&dir.join(v))?;
            var.pixels.iter_mut().for_each(|p| *p /= k);
            Some(var)
        }
        None => None,
    };
    let samples = e.light_samples.map_or_else(String::new, |n| format!(" x {n} light samples"));
    let description = if e.deterministic {
        format!("Mitsuba {} ({}), pixel centres", m.mitsuba, m.variant)
    } else {
        format!("Mitsuba {} ({}), mean of {} seeds{samples}", m.mitsuba, m.variant, e.seeds.len())
    };
    Ok(Some(StoredReference { image, variance_of_mean, description }))
}

/// Compare every reference of `root/reference/manifest.json`, writing the pictures into `images`.
/// `Ok(None)` when the project has no references.
pub fn run(root: &Path, images: &Path, quiet: bool) -> Result<Option<MitsubaReport>> {
    let dir = root.join("reference");
    let Some(m) = manifest(root)? else { return Ok(None) };
    std::fs::create_dir_all(images).map_err(|e| Error::io(images, &e))?;
    let bar = super::progress::bar(m.references.len() as u64, "report mitsuba", quiet);
    let mut rows = Vec::new();
    for e in &m.references {
        bar.set_message(e.scene.clone());
        rows.push(compare_one(root, &dir, images, &m, e)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(Some(MitsubaReport {
        mitsuba: format!("Mitsuba {} ({})", m.mitsuba, m.variant),
        size: (m.width, m.height),
        rows,
    }))
}

fn compare_one(root: &Path, dir: &Path, images: &Path, m: &Manifest, e: &ManifestEntry) -> Result<MitsubaRow> {
    let scene_path = root.join(&e.scene);
    let mut file = Scene::read_file(&scene_path)?;
    force_shading_model(&mut file, e.model);
    // The manifest writes switches as `NAME=on|off`, as make_references.py passes them to `--feature`.
    let features = e
        .features
        .iter()
        .map(|f| match f.split_once('=') {
            Some((name, v @ ("on" | "off"))) => Ok((name.to_string(), v == "on")),
            _ => Err(Error::Invalid(format!("reference/manifest.json: feature '{f}' is not NAME=on|off"))),
        })
        .collect::<Result<Vec<_>>>()?;
    let ov = Overrides {
        width: Some(e.width.unwrap_or(m.width)),
        height: Some(e.height.unwrap_or(m.height)),
        seed: Some(0),
        spp: e.spp,
        max_depth: e.max_depth,
        features,
        ..Default::default()
    };
    let scene = Scene::from_file_with(file, &scene_path, &ov)?;
    let tracer = crate::backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    let r = render(&scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true })?;
    let ours: Image = r.image;
    let reference = read_image(&dir.join(&e.image))?;
    let metrics = compare(&reference, &ours, &CompareOptions::default())?;
    let f = flip(&reference, &ours, FlipMode::Ldr, crate::verify::image::flip::DEFAULT_PIXELS_PER_DEGREE)?;
    let model = if e.model == ShadingModelKind::Phong { "phong" } else { "physical" };
    let native = e.oracle.as_deref() == Some("native");
    let name = format!("mitsuba-{}.{model}{}", e.name, if native { ".native" } else { "" });
    let pictures = [
        format!("{name}.rtdiff.png"),
        format!("{name}.mitsuba.png"),
        format!("{name}.diff.png"),
        format!("{name}.flip.png"),
    ];
    ours.write(&images.join(&pictures[0]))?;
    reference.write(&images.join(&pictures[1]))?;
    let diff = absolute_difference(&reference, &ours)?;
    let diff_scale = write_error_png(&diff, ours.width, ours.height, None, &images.join(&pictures[2]))?;
    write_flip_png(&f, &images.join(&pictures[3]))?;
    Ok(MitsubaRow {
        scene: e.scene.clone(),
        model: e.model,
        native,
        deterministic: e.deterministic,
        reference_seeds: e.seeds.len(),
        rel_mse: metrics.rel_mse,
        flip: f.mean,
        over_rel_threshold_fraction: metrics.over_rel_threshold_fraction,
        rtdiff_ms: r.seconds * 1e3,
        pictures,
        diff_scale,
    })
}
