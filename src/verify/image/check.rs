//! Another renderer's images checked against `reference/` (`rtdiff check-image`), with the
//! checks rtdiff's own renders pass (tests/mitsuba_reference.rs): on deterministic scenes at
//! least 99.9% of pixels within 1e-3 relative and every other pixel explained by rtdiff's own
//! ray tree (a silhouette, a triangle edge, a shadow terminator or a shadow edge); on noisy
//! scenes Welch's test per pixel with Benjamini-Hochberg at q = 0.01 against the reference's
//! mean and variance over its seeds, from several renders (seeds) of the renderer under test.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Serialize;

use crate::accel::Tracer;
use crate::error::{Error, Result};
use crate::film::Image;
use crate::geometry::Hit;
use crate::integrator::debug::RayNode;
use crate::scene::{Overrides, Scene};
use crate::shading::ShadingModelKind;

use super::stats::{Moments, WelchOptions, WelchReport, welch_test};

/// Relative tolerance of a deterministic pixel.
pub const REL_TOL: f32 = 1e-3;
/// Below this a pixel is compared absolutely (`|a - b| <= REL_TOL * FLOOR`, 30x below the darkest 8-bit step).
pub const FLOOR: f32 = 1e-2;
/// Fraction of pixels of a deterministic scene that must agree.
pub const MIN_AGREEING: f64 = 0.999;
/// False-alarm rate of the statistical check (Benjamini-Hochberg q).
pub const FDR: f64 = 0.01;

/// One entry of `reference/manifest.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceEntry {
    /// Scene name (the scene file's stem).
    pub name: String,
    /// Scene file.
    pub scene: PathBuf,
    /// Feature switches the reference was made with.
    pub features: Vec<(String, bool)>,
    /// `phong` or `physical`: the shading model every material was switched to.
    pub model: String,
    /// One render is exact (pixel centres, no sampling).
    pub deterministic: bool,
    /// Seeds averaged into the reference.
    pub seeds: u32,
    /// Mean image.
    pub image: PathBuf,
    /// One-image variance over the seeds (noisy references).
    pub variance: Option<PathBuf>,
    /// Image width and height.
    pub size: (u32, u32),
}

impl ReferenceEntry {
    /// `name.model`, the stem of its image file.
    pub fn id(&self) -> String {
        format!("{}.{}", self.name, self.model)
    }
}

/// The entries of `dir/manifest.json`; errors name the file.
pub fn manifest(root: &Path, dir: &Path) -> Result<Vec<ReferenceEntry>> {
    let path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, &e))?;
    let bad = |what: &str| Error::file(&path, format!("not a reference manifest: {what}"));
    let m: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::file(&path, e.to_string()))?;
    let size = (
        m["width"].as_u64().ok_or_else(|| bad("no width"))? as u32,
        m["height"].as_u64().ok_or_else(|| bad("no height"))? as u32,
    );
    let mut out = Vec::new();
    for e in m["references"].as_array().ok_or_else(|| bad("no references"))? {
        let s = |k: &str| e[k].as_str().map(str::to_string).ok_or_else(|| bad(&format!("an entry without {k}")));
        let mut features = Vec::new();
        for f in e["features"].as_array().into_iter().flatten() {
            let f = f.as_str().ok_or_else(|| bad("a feature that is not text"))?;
            let (k, v) = f.split_once('=').ok_or_else(|| bad(&format!("feature {f:?} is not NAME=on|off")))?;
            features.push((k.to_string(), v == "on"));
        }
        out.push(ReferenceEntry {
            name: s("name")?,
            scene: root.join(s("scene")?),
            features,
            model: s("model")?,
            deterministic: e["deterministic"].as_bool().unwrap_or(false),
            seeds: e["seeds"].as_array().map_or(1, |a| a.len() as u32),
            image: dir.join(s("image")?),
            variance: e["variance"].as_str().map(|v| dir.join(v)),
            size,
        });
    }
    Ok(out)
}

/// The scene of `r` as the reference was made from it (model, features, size, `seed`).
pub fn load_scene(r: &ReferenceEntry, seed: u64) -> Result<Scene> {
    let mut file = Scene::read_file(&r.scene)?;
    let model = if r.model == "phong" { ShadingModelKind::Phong } else { ShadingModelKind::Physical };
    crate::scene::export::mitsuba::force_shading_model(&mut file, model);
    let ov = Overrides {
        width: Some(r.size.0),
        height: Some(r.size.1),
        seed: Some(seed),
        features: r.features.clone(),
        ..Default::default()
    };
    Scene::from_file_with(file, &r.scene, &ov)
}

/// Why a pixel of a deterministic scene differs, as far as rtdiff's own ray tree explains it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PixelClass {
    /// A neighbouring pixel sees another object or the background: the pixel centre is within
    /// rounding of an outline.
    Silhouette,
    /// The camera ray hits within 1e-4 (barycentric) of a triangle edge.
    TriangleEdge,
    /// A light sample on the pixel's tree lies on opposite sides of the shading and geometric
    /// normals, or within 1.5 degrees of either plane (the shading-normal terminator).
    ShadowTerminator,
    /// A blocked shadow ray on the pixel's tree meets its blocker within 1e-4 of an edge.
    ShadowEdge,
    /// None of these: a real difference.
    Unexplained,
}

/// Classify pixel `(x, y)` of `scene` from rtdiff's own hits (`tracer` over the scene).
pub fn classify(scene: &Scene, tracer: &dyn Tracer, x: u32, y: u32) -> PixelClass {
    let hit_at = |x: i64, y: i64| -> Option<Option<Hit>> {
        if x < 0 || y < 0 || x >= scene.width as i64 || y >= scene.height as i64 {
            return None;
        }
        Some(tracer.intersect(&scene.camera.pixel_centre_ray(x as u32, y as u32)))
    };
    let Some(centre) = hit_at(x as i64, y as i64) else { return PixelClass::Unexplained };
    let object = |h: &Option<Hit>| h.map(|h| scene.material_of(h.prim));
    for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1), (-1, 1), (1, -1)] {
        if let Some(n) = hit_at(x as i64 + dx, y as i64 + dy)
            && (object(&n) != object(&centre) || n.is_none() != centre.is_none())
        {
            return PixelClass::Silhouette;
        }
    }
    let Some(h) = centre else { return PixelClass::Unexplained };
    let Ok(tree) = crate::debug::trace_pixel_with(scene, tracer, x, y) else { return PixelClass::Unexplained };
    if has_terminator(scene, &tree.root) {
        return PixelClass::ShadowTerminator;
    }
    if has_shadow_edge(scene, &tree.root) {
        return PixelClass::ShadowEdge;
    }
    if (h.prim as usize) < scene.prims.triangles.len() && (1.0 - h.u - h.v).min(h.u).min(h.v) < 1e-4 {
        return PixelClass::TriangleEdge;
    }
    PixelClass::Unexplained
}

/// True when a light sample of `n` or of its children is on opposite sides of the shading and
/// geometric normals, or grazes the geometric plane (within 1.5 degrees).
pub fn has_terminator(scene: &Scene, n: &RayNode) -> bool {
    if let Some(h) = &n.hit {
        let p = Vec3::from(h.position);
        let ns = Vec3::from(h.normal);
        let nt = scene.prims.triangles.len();
        let ng = if (h.prim as usize) < nt {
            scene.prims.triangles[h.prim as usize].normal().normalize_or_zero()
        } else {
            (p - scene.prims.spheres[h.prim as usize - nt].center).normalize_or_zero()
        };
        // sin(1.5 degrees) = 0.026.
        let bad = n.lights.iter().any(|l| {
            let dir = (Vec3::from(l.position) - p).normalize_or_zero();
            let (g, s) = (ng.dot(dir), ns.dot(dir) * ng.dot(ns).signum());
            g * s < 0.0 || g.abs() < 0.026 || s.abs() < 0.026
        });
        if bad {
            return true;
        }
    }
    n.children.iter().any(|c| has_terminator(scene, c))
}

/// Barycentrics (f64) where the line `o + t d` crosses the plane of triangle `v`.
pub fn barycentrics_f64(v: [Vec3; 3], o: Vec3, d: Vec3) -> [f64; 3] {
    let [a, b, c] = v.map(|p| p.as_dvec3());
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let s = o - a;
    let u = s.dot(p) / det;
    let w = d.dot(s.cross(e1)) / det;
    [1.0 - u - w, u, w]
}

/// True when a blocked shadow ray of `n` or its children is fragile: the blocker is hit within
/// 1e-4 (barycentric) of one of its edges.
pub fn has_shadow_edge(scene: &Scene, n: &RayNode) -> bool {
    let near_edge = n.lights.iter().flat_map(|l| &l.shadow_rays).any(|s| match s.blocked_by {
        Some((prim, _)) if (prim as usize) < scene.prims.triangles.len() => {
            let v = scene.prims.triangles[prim as usize].v;
            let (o, t) = (Vec3::from(s.origin), Vec3::from(s.target));
            barycentrics_f64(v, o, t - o).iter().copied().fold(f64::INFINITY, f64::min) < 1e-4
        }
        _ => false,
    });
    near_edge || n.children.iter().any(|c| has_shadow_edge(scene, c))
}

/// The deterministic check of one image.
#[derive(Clone, Debug, Serialize)]
pub struct ExactCheck {
    /// Fraction of pixels within [`REL_TOL`].
    pub agreeing: f64,
    /// Largest relative difference.
    pub max_rel: f32,
    /// Differing pixels by class.
    pub classes: BTreeMap<String, u64>,
    /// The first unexplained pixels `(x, y, relative difference)`.
    pub unexplained: Vec<(u32, u32, f32)>,
    /// At least [`MIN_AGREEING`] agree and no differing pixel is unexplained.
    pub passed: bool,
}

/// Relative difference of two pixels (largest over the channels), with [`FLOOR`] as the
/// smallest scale.
pub fn rel(a: Vec3, b: Vec3) -> f32 {
    let d = (a - b).abs();
    let s = a.abs().max(b.abs()).max(Vec3::splat(FLOOR));
    (d / s).max_element()
}

/// Check `img` against `reference` pixel by pixel, explaining the differing pixels from `scene`'s ray trees.
pub fn exact_check(scene: &Scene, reference: &Image, img: &Image) -> Result<ExactCheck> {
    if (reference.width, reference.height) != (img.width, img.height) {
        return Err(Error::Invalid(format!(
            "the image is {}x{}, the reference {}x{}",
            img.width, img.height, reference.width, reference.height
        )));
    }
    let tracer = crate::backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    let (mut classes, mut unexplained, mut bad, mut max_rel) = (BTreeMap::new(), Vec::new(), 0u64, 0f32);
    for y in 0..img.height {
        for x in 0..img.width {
            let r = rel(reference.get(x, y), img.get(x, y));
            max_rel = max_rel.max(if r.is_nan() { f32::INFINITY } else { r });
            if r.is_nan() || r > REL_TOL {
                bad += 1;
                let c = classify(scene, tracer.as_ref(), x, y);
                let name =
                    serde_json::to_value(c).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default();
                *classes.entry(name).or_insert(0) += 1;
                if c == PixelClass::Unexplained && unexplained.len() < 20 {
                    unexplained.push((x, y, r));
                }
            }
        }
    }
    let agreeing = 1.0 - bad as f64 / (img.width as f64 * img.height as f64);
    let passed = agreeing >= MIN_AGREEING && !classes.contains_key("unexplained");
    Ok(ExactCheck { agreeing, max_rel, classes, unexplained, passed })
}

/// The statistical check of several renders (seeds) of a noisy scene against the reference's mean and variance.
pub fn noisy_check(r: &ReferenceEntry, images: &[Image]) -> Result<WelchReport> {
    let var =
        r.variance.as_ref().ok_or_else(|| Error::file(&r.image, "a noisy reference without its variance image"))?;
    let reference = Moments::from_mean_variance(&Image::read_exr(&r.image)?, &Image::read_exr(var)?, r.seeds)?;
    let mut reference = reference;
    let mut test = Moments::from_images(images)?;
    numerically_black(&mut reference, &mut test);
    welch_test(&reference, &test, &WelchOptions { fdr: FDR, ..Default::default() })
}

/// Below this a pixel-channel is black on both sides whatever its noise: the deterministic
/// check's absolute tolerance (`REL_TOL * FLOOR`, 30x below the darkest non-zero 8-bit step).
pub const BLACK: f64 = (REL_TOL * FLOOR) as f64;

/// Pixel-channels whose mean and standard deviation are below [`BLACK`] on both sides become
/// deterministic (variance 0), so the Welch test's exact tolerance judges them: where a light
/// lies in the plane of a face, n.l is exactly 0 in the model and the float32 rounding of the
/// hit point gives either renderer 1e-6 where the other has 0 (tests/mitsuba_reference.rs).
pub fn numerically_black(a: &mut Moments, b: &mut Moments) {
    for i in 0..a.mean.len().min(b.mean.len()) {
        for c in 0..3 {
            let black = |m: &Moments| m.mean[i][c].abs() < BLACK && m.variance[i][c].sqrt() < BLACK;
            if black(a) && black(b) {
                a.variance[i][c] = 0.0;
                b.variance[i][c] = 0.0;
            }
        }
    }
}

/// The verdict on one reference.
#[derive(Clone, Debug, Serialize)]
pub struct ImageCheck {
    /// `name.model`.
    pub reference: String,
    /// The images checked.
    pub images: Vec<PathBuf>,
    /// Deterministic check (deterministic references).
    pub exact: Option<ExactCheck>,
    /// Welch + Benjamini-Hochberg (noisy references).
    pub welch: Option<WelchReport>,
    /// Whether the images pass.
    pub passed: bool,
}

/// Check `images` (one render of a deterministic reference, or several seeds of a noisy one)
/// against reference `r`.
pub fn check(r: &ReferenceEntry, images: &[PathBuf]) -> Result<ImageCheck> {
    let imgs: Vec<Image> = images.iter().map(|p| crate::film::io::read_image(p)).collect::<Result<_>>()?;
    let (exact, welch) = if r.deterministic {
        let scene = load_scene(r, 0)?;
        let reference = Image::read_exr(&r.image)?;
        let mut worst: Option<ExactCheck> = None;
        for img in &imgs {
            let e = exact_check(&scene, &reference, img)?;
            if worst.as_ref().is_none_or(|w| w.passed && !e.passed) {
                worst = Some(e);
            }
        }
        (worst, None)
    } else {
        if imgs.len() < 2 {
            return Err(Error::Invalid(format!(
                "{} is a noisy scene: the statistical check needs several renders with different seeds (at least 2; \
                 32 give it its power), e.g. a folder with {}.s0.exr, {}.s1.exr, ...",
                r.id(),
                r.id(),
                r.id()
            )));
        }
        (None, Some(noisy_check(r, &imgs)?))
    };
    let passed = exact.as_ref().is_none_or(|e| e.passed) && welch.as_ref().is_none_or(|w| w.passed);
    Ok(ImageCheck { reference: r.id(), images: images.to_vec(), exact, welch, passed })
}

/// The references `images` are for: with `scene`, its entries (`model` chooses between them,
/// else the first) checked against the files given; with a folder (and no scene), every entry
/// whose image is in it, named like `reference/` (`NAME.MODEL.exr`, or `NAME.MODEL.sK.exr` for
/// the seeds of a noisy scene).
pub fn plan(
    entries: &[ReferenceEntry],
    scene: Option<&Path>,
    images: &[PathBuf],
    model: Option<&str>,
) -> Result<Vec<(ReferenceEntry, Vec<PathBuf>)>> {
    if let [dir] = images
        && dir.is_dir()
    {
        let mut out = Vec::new();
        for e in entries {
            if let Some(s) = scene
                && !same_file(s, &e.scene)
            {
                continue;
            }
            let one = dir.join(format!("{}.exr", e.id()));
            let mut files: Vec<PathBuf> = if one.is_file() { vec![one] } else { Vec::new() };
            if files.is_empty() {
                let prefix = format!("{}.s", e.id());
                files = std::fs::read_dir(dir)
                    .map_err(|e| Error::io(dir, &e))?
                    .filter_map(|f| f.ok().map(|f| f.path()))
                    .filter(|p| {
                        p.file_name()
                            .and_then(|n| n.to_str())
                            .is_some_and(|n| n.starts_with(&prefix) && n.ends_with(".exr"))
                    })
                    .collect();
                files.sort();
            }
            if !files.is_empty() {
                out.push((e.clone(), files));
            }
        }
        if out.is_empty() {
            return Err(Error::file(dir, "no image named like reference/ (NAME.MODEL.exr) in this folder"));
        }
        return Ok(out);
    }
    let scene =
        scene.ok_or_else(|| Error::Invalid("name the scene the images are of (or give a folder of images)".into()))?;
    let mut matching: Vec<&ReferenceEntry> = entries.iter().filter(|e| same_file(scene, &e.scene)).collect();
    if matching.is_empty() {
        return Err(Error::file(scene, "reference/manifest.json has no reference of this scene"));
    }
    if let Some(m) = model {
        matching.retain(|e| e.model == m);
        if matching.is_empty() {
            return Err(Error::file(scene, format!("no reference of this scene in the {m} model")));
        }
    }
    Ok(vec![(matching[0].clone(), images.to_vec())])
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}
