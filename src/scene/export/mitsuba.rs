//! Export a loaded scene for Mitsuba 3 (`rtdiff export SCENE --to mitsuba -o DIR`).
//!
//! One source of truth: the triangles are written exactly as rtdiff traces
//! them (after normalisation and transforms, float32, the per-corner normals
//! and uvs rtdiff interpolates) as binary little-endian PLY files, the
//! textures as the linear float texels rtdiff looks up (EXR, already
//! sRGB-decoded), and the camera, lights and materials as rtdiff resolved them.
//!
//! Two oracles ([`Oracle`]): where Mitsuba's own emitters, BSDFs and
//! integrators express the scene exactly (rtdiff's physical model with point
//! lights, uniform parallelogram lights, Lambert materials, mirrors; see
//! [`super::native`]), `DIR/scene.xml` uses them and the oracle is
//! Mitsuba's code. Otherwise (Phong, segment lights, corner colours, glossy,
//! alpha blending, deeper recursion) `scene.xml` holds the sensor, shapes and
//! `diffuse` BSDFs (kd or a kd texture) and the `rtdiff_whitted` integrator,
//! and `DIR/rtdiff.json` describes the rest for the Python plugin in
//! `scripts/mitsuba/rtdiff_mitsuba.py`, which shades with Mitsuba's own
//! intersections, sensor, texture lookups and sampler. [`ExportReport`] says
//! which oracle was written and why; every construct that Mitsuba cannot
//! reproduce is named in [`ExportReport::warnings`]; nothing is dropped
//! silently.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::native::{self, Kind, Recipe};
use crate::error::{Error, Result};
use crate::features::Plan;
use crate::film::Image;
use crate::scene::digest::traced_sha256;
use crate::scene::file::LightSpec;
use crate::scene::{Overrides, Scene, SceneFile};
use crate::shading::ShadingModelKind;
use crate::texture::{Texture, WrapMode};

/// Version tag of `rtdiff.json`, checked by the Python side.
pub const FORMAT: &str = "rtdiff-mitsuba-1";

/// Which code answers for the shading of an exported scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Oracle {
    /// Mitsuba's own emitters, BSDFs and integrator (`direct` or `path`).
    Native,
    /// The `rtdiff_whitted` plugin: the reports' model written again in Python on Mitsuba's
    /// intersections, sensor, textures and sampler.
    #[default]
    Plugin,
}

/// The oracle an export is asked for (`rtdiff export --oracle`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OracleChoice {
    /// Native where Mitsuba's plugins express the scene, else the plugin.
    #[default]
    Auto,
    /// Native, or an error naming what Mitsuba cannot express.
    Native,
    /// The plugin, whatever the scene (to check the plugin against the native oracle).
    Plugin,
}

/// The Mitsuba plugins a scene.xml uses (recorded per reference in reference/manifest.json).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MitsubaPlugins {
    /// The integrator and how its renders are combined.
    pub integrator: String,
    /// One entry per light.
    pub emitters: Vec<String>,
    /// One entry per kind of BSDF used.
    pub bsdfs: Vec<String>,
}

/// What an export wrote and what it could not express.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ExportReport {
    /// Files written (scene.xml, rtdiff.json, meshes, textures).
    pub files: Vec<PathBuf>,
    /// Constructs with no exact Mitsuba equivalent (named, never dropped silently).
    pub warnings: Vec<String>,
    /// True when one Mitsuba sample per pixel reproduces rtdiff exactly
    /// (pixel centres, no area-light, lens, glossy or blended-BSDF sampling).
    pub deterministic: bool,
    /// [`traced_sha256`] of the exported scene: what both renderers trace.
    pub traced_sha256: String,
    /// The oracle written.
    pub oracle: Oracle,
    /// Why the plugin was written (what Mitsuba's own plugins cannot express), or, for a
    /// native export, how its image is made.
    pub oracle_reasons: Vec<String>,
    /// The Mitsuba plugins the scene uses.
    pub plugins: MitsubaPlugins,
}

/// Load `scene_path` with `ov` (and every material switched to `model` when
/// given) and export it to `dir` for the oracle `choice`.
pub fn export_mitsuba_file(
    scene_path: &Path,
    ov: &Overrides,
    model: Option<ShadingModelKind>,
    dir: &Path,
    choice: OracleChoice,
) -> Result<ExportReport> {
    let mut file = Scene::read_file(scene_path)?;
    if let Some(m) = model {
        force_shading_model(&mut file, m);
    }
    let lights = file.lights.clone();
    let scene = Scene::from_file_with(file, scene_path, ov)?;
    export_mitsuba(&scene, &lights, dir, choice)
}

/// Switch every material of `file` (named and MTL) to the shading model `model`:
/// the reference set renders each scene in both models.
pub fn force_shading_model(file: &mut SceneFile, model: ShadingModelKind) {
    file.shading_model = model;
    for m in file.materials.values_mut() {
        m.shading_model = Some(model);
    }
}

/// Shapes that share a material and texturing: one PLY file and one BSDF.
struct Group {
    material: u32,
    textured: bool,
    triangles: Vec<usize>,
}

/// Export `scene` (whose lights were given as `lights` in its file) to `dir` for the oracle
/// `choice`.
pub fn export_mitsuba(scene: &Scene, lights: &[LightSpec], dir: &Path, choice: OracleChoice) -> Result<ExportReport> {
    if lights.len() != scene.lights.len() {
        return Err(Error::file(&scene.path, "light list does not match the loaded scene"));
    }
    let plan = scene.plan();
    let blockers = native::blockers(scene, &plan, lights);
    let oracle = match choice {
        OracleChoice::Native if !blockers.is_empty() => {
            return Err(Error::file(
                &scene.path,
                format!("Mitsuba's own plugins cannot render this scene as rtdiff does: {}", blockers.join("; ")),
            ));
        }
        OracleChoice::Auto | OracleChoice::Native if blockers.is_empty() => Oracle::Native,
        _ => Oracle::Plugin,
    };
    let deterministic = match oracle {
        Oracle::Native => is_deterministic(scene, &plan) && !native::needs_blend(scene, &plan),
        Oracle::Plugin => is_deterministic(scene, &plan),
    };
    let mut report = ExportReport { deterministic, traced_sha256: traced_sha256(scene), oracle, ..Default::default() };
    report.oracle_reasons = match (oracle, choice) {
        (Oracle::Plugin, OracleChoice::Plugin) if blockers.is_empty() => {
            vec!["asked for (--oracle plugin); Mitsuba's own plugins could render this scene".into()]
        }
        (Oracle::Plugin, _) => blockers,
        (Oracle::Native, _) if plan.reflections => vec![
            "one mirror bounce: Mitsuba's path tracer at max_depth 3, twice with the same seed (diffuse \
             reflectances halved in the first), combined as 4 L(1/2) - L(1) to remove diffuse interreflection"
                .into(),
        ],
        (Oracle::Native, _) => Vec::new(),
    };
    warn_unsupported(scene, &plan, &mut report.warnings);
    for sub in ["meshes", "textures", "emitters", "bsdfs"] {
        if oracle == Oracle::Plugin && (sub == "emitters" || sub == "bsdfs") {
            continue;
        }
        let p = dir.join(sub);
        std::fs::create_dir_all(&p).map_err(|e| Error::file(&p, format!("cannot create folder: {e}")))?;
    }

    let mut xml = String::new();
    let _ = writeln!(xml, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(xml, "<!-- Exported by rtdiff from {} -->", xml_escape(&scene.path.display().to_string()));
    // "--" may not appear inside an XML comment (the reasons quote command-line flags).
    let _ = writeln!(xml, "<!-- Oracle: {} -->", oracle_line(&report).replace("--", "- -"));
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    let mut shapes =
        Shapes { scene, plan: &plan, dir, oracle, textures: Vec::new(), json: Vec::new(), bsdfs: Vec::new() };
    let recipe = match oracle {
        Oracle::Native => {
            let _ = writeln!(xml, "    <default name=\"lights\" value=\"emitters/all.xml\"/>");
            let _ = writeln!(xml, "    <default name=\"bsdfs\" value=\"{}\"/>", native::bsdf_file(1.0));
            native::write_integrator(&mut xml, &plan, scene);
            write_sensor(&mut xml, scene, &plan, &report);
            let _ = writeln!(xml, "    <include filename=\"$bsdfs\"/>");
            shapes.meshes(&mut xml, &mut report)?;
            shapes.spheres(&mut xml);
            let _ = writeln!(xml, "    <include filename=\"$lights\"/>");
            shapes.native_bsdfs(&mut report)?;
            write_lights(dir, lights, &mut report)?;
            report.plugins = native_plugins(&plan, lights, &shapes.bsdfs);
            Some(native::recipe(&plan, lights.len(), mitsuba_spp(scene, &plan)))
        }
        Oracle::Plugin => {
            write_integrator(&mut xml, scene);
            write_sensor(&mut xml, scene, &plan, &report);
            shapes.meshes(&mut xml, &mut report)?;
            shapes.spheres(&mut xml);
            report.plugins = MitsubaPlugins {
                integrator: format!("rtdiff_whitted (plugin, max_depth {})", scene.params.max_depth),
                emitters: lights.iter().map(|l| format!("{} (plugin)", light_kind(l))).collect(),
                bsdfs: vec!["the reports' model (plugin) on diffuse/bitmap kd lookups".into()],
            };
            None
        }
    };
    let _ = writeln!(xml, "</scene>");
    let xml_path = dir.join("scene.xml");
    write_text(&xml_path, xml)?;
    report.files.insert(0, xml_path);

    let config = sidecar(scene, &plan, lights, shapes.json, &report, recipe.as_ref());
    let cfg_path = dir.join("rtdiff.json");
    let text = serde_json::to_string_pretty(&config).map_err(|e| Error::Invalid(format!("rtdiff.json: {e}")))?;
    write_text(&cfg_path, text + "\n")?;
    report.files.insert(1, cfg_path);
    Ok(report)
}

/// One line saying which oracle an export wrote and why.
pub fn oracle_line(report: &ExportReport) -> String {
    match report.oracle {
        Oracle::Native => format!(
            "native (Mitsuba's {}; {}; {})",
            report.plugins.integrator,
            report.plugins.emitters.join(", "),
            report.plugins.bsdfs.join(", ")
        ),
        Oracle::Plugin => format!("plugin rtdiff_whitted, because: {}", report.oracle_reasons.join("; ")),
    }
}

fn light_kind(l: &LightSpec) -> &'static str {
    match l {
        LightSpec::Point { .. } => "point",
        LightSpec::Segment { .. } => "segment",
        LightSpec::Parallelogram { .. } => "parallelogram",
    }
}

fn native_plugins(plan: &Plan, lights: &[LightSpec], bsdfs: &[(String, Kind)]) -> MitsubaPlugins {
    let mut kinds: Vec<String> = bsdfs.iter().map(|(_, k)| k.describe().to_string()).collect();
    kinds.sort();
    kinds.dedup();
    if plan.textures {
        kinds.push(format!("bitmap ({})", if plan.bilinear { "bilinear" } else { "nearest" }));
    }
    MitsubaPlugins {
        integrator: if plan.reflections {
            "path (max_depth 3, 4 L(1/2) - L(1))".into()
        } else {
            "direct (emitter sampling)".into()
        },
        emitters: lights
            .iter()
            .map(|l| match l {
                LightSpec::Point { .. } => "point".to_string(),
                _ => "area on a rectangle".to_string(),
            })
            .collect(),
        bsdfs: kinds,
    }
}

/// `emitters/all.xml` and one `emitters/lightK.xml` per light.
fn write_lights(dir: &Path, lights: &[LightSpec], report: &mut ExportReport) -> Result<()> {
    let mut all = String::new();
    for (k, l) in lights.iter().enumerate() {
        let mut one = String::new();
        native::write_light(&mut one, l);
        all.push_str(&one);
        let path = dir.join(format!("emitters/light{k}.xml"));
        write_text(&path, native::fragment(&one))?;
        report.files.push(path);
    }
    let path = dir.join("emitters/all.xml");
    write_text(&path, native::fragment(&all))?;
    report.files.push(path);
    Ok(())
}

fn write_text(path: &Path, text: String) -> Result<()> {
    crate::output::write(path, text)
}

/// Triangles grouped by (material, textured), groups in order of first use.
fn group_triangles(scene: &Scene, plan: &Plan) -> Vec<Group> {
    let mut groups: Vec<Group> = Vec::new();
    let mut index: BTreeMap<(u32, bool), usize> = BTreeMap::new();
    for (i, sh) in scene.triangle_shading.iter().enumerate() {
        let m = &scene.materials[sh.material as usize];
        let textured = plan.textures && sh.has_uvs && m.kd_texture.is_some();
        let g = *index.entry((sh.material, textured)).or_insert_with(|| {
            groups.push(Group { material: sh.material, textured, triangles: Vec::new() });
            groups.len() - 1
        });
        groups[g].triangles.push(i);
    }
    groups
}

/// The shapes of an export: their XML, their files and their entries of `rtdiff.json`.
struct Shapes<'a> {
    scene: &'a Scene,
    plan: &'a Plan,
    dir: &'a Path,
    oracle: Oracle,
    /// Textures written so far, by identity and scale of their texels, with their file names.
    textures: Vec<(*const Texture, u32, String)>,
    /// `{ id, material }` of every shape, for `rtdiff.json`.
    json: Vec<serde_json::Value>,
    /// Native BSDFs referenced by the shapes: (id, kind), ids `m{material}` or `m{material}_tex`.
    bsdfs: Vec<(String, Kind)>,
}

impl Shapes<'_> {
    /// One PLY shape per triangle group.
    fn meshes(&mut self, xml: &mut String, report: &mut ExportReport) -> Result<()> {
        for (gi, g) in group_triangles(self.scene, self.plan).iter().enumerate() {
            let id = format!("s{gi}_m{}", g.material);
            let ply = format!("meshes/{id}.ply");
            let path = self.dir.join(&ply);
            write_ply(self.scene, &g.triangles, &path)?;
            report.files.push(path);
            let m = &self.scene.materials[g.material as usize];
            let _ = writeln!(xml, "    <shape type=\"ply\" id=\"{id}\">");
            let _ = writeln!(xml, "        <string name=\"filename\" value=\"{ply}\"/>");
            // Flat shading uses the face normal, as rtdiff does with normal interpolation off.
            let _ =
                writeln!(xml, "        <boolean name=\"face_normals\" value=\"{}\"/>", !self.plan.normal_interpolation);
            match self.oracle {
                Oracle::Native => {
                    let bsdf = self.native_bsdf(g.material, g.textured);
                    let _ = writeln!(xml, "        <ref id=\"{bsdf}\"/>");
                }
                Oracle::Plugin => {
                    let texture = match (&m.kd_texture, g.textured) {
                        (Some(t), true) => Some(self.texture(t, 1.0, report)?),
                        _ => None,
                    };
                    write_bsdf(xml, m.kd, texture.as_deref(), self.plan.bilinear, m.wrap);
                }
            }
            let _ = writeln!(xml, "    </shape>");
            self.json.push(serde_json::json!({ "id": id, "material": g.material }));
        }
        Ok(())
    }

    /// One sphere shape per sphere (with its kd colour: see [`warn_unsupported`]).
    fn spheres(&mut self, xml: &mut String) {
        for (si, s) in self.scene.prims.spheres.iter().enumerate() {
            let material = self.scene.sphere_materials[si];
            let id = format!("sphere{si}_m{material}");
            let _ = writeln!(xml, "    <shape type=\"sphere\" id=\"{id}\">");
            let _ = writeln!(xml, "        <point name=\"center\" value=\"{}\"/>", v3(s.center));
            let _ = writeln!(xml, "        <float name=\"radius\" value=\"{}\"/>", s.radius);
            match self.oracle {
                Oracle::Native => {
                    let bsdf = self.native_bsdf(material, false);
                    let _ = writeln!(xml, "        <ref id=\"{bsdf}\"/>");
                }
                Oracle::Plugin => {
                    write_bsdf(xml, self.scene.materials[material as usize].kd, None, false, WrapMode::Repeat)
                }
            }
            let _ = writeln!(xml, "    </shape>");
            // The centre (and radius) give the sphere's hit-point error bound to the plugin's spawn rule.
            self.json.push(serde_json::json!({
                "id": id, "material": material, "center": [s.center.x, s.center.y, s.center.z], "radius": s.radius
            }));
        }
    }

    /// The file name of texture `t` with its texels times `scale`, written as an EXR of the
    /// linear texels rtdiff looks up (scaled) on first use.
    fn texture(&mut self, t: &std::sync::Arc<Texture>, scale: f32, report: &mut ExportReport) -> Result<String> {
        let key = (std::sync::Arc::as_ptr(t), scale.to_bits());
        if let Some((_, _, n)) = self.textures.iter().find(|(k, s, _)| (*k, *s) == key) {
            return Ok(n.clone());
        }
        let name = if scale == 1.0 {
            format!("textures/texture_{}.exr", self.textures.len())
        } else {
            format!("textures/texture_{}_scaled.exr", self.textures.len())
        };
        // Clamped to 1 where the scale is a blend's 1 / (1 - w), whose rounding may exceed 1.
        let pixels = t.texels.iter().map(|c| if scale == 1.0 { *c } else { (*c * scale).min(Vec3::ONE) }).collect();
        let img = Image { width: t.width, height: t.height, pixels };
        let path = self.dir.join(&name);
        img.write(&path)?;
        report.files.push(path);
        self.textures.push((key.0, key.1, name.clone()));
        Ok(name)
    }

    /// The id of the native BSDF of `material` (textured or not), registered for [`Self::native_bsdfs`].
    fn native_bsdf(&mut self, material: u32, textured: bool) -> String {
        let id = if textured { format!("m{material}_tex") } else { format!("m{material}") };
        if !self.bsdfs.iter().any(|(i, _)| *i == id) {
            let kind = native::kind(&self.scene.materials[material as usize], self.plan);
            self.bsdfs.push((id.clone(), kind));
        }
        id
    }

    /// The BSDF files of a native export: one per diffuse-reflectance scale of the recipe.
    fn native_bsdfs(&mut self, report: &mut ExportReport) -> Result<()> {
        for &s in native::albedo_scales(self.plan) {
            let mut body = String::new();
            for (id, kind) in self.bsdfs.clone() {
                let material: u32 = id.trim_start_matches('m').trim_end_matches("_tex").parse().unwrap_or(0);
                let m = &self.scene.materials[material as usize];
                let factor = kind.diffuse_factor() * s;
                let reflectance = match (&m.kd_texture, id.ends_with("_tex")) {
                    (Some(t), true) => {
                        // The texels of the scale-1 file, halved exactly for the other.
                        let unit = kind.diffuse_factor();
                        let name = if s == 1.0 {
                            self.texture(t, unit, report)?
                        } else {
                            let full = self.texture(t, unit, report)?;
                            let half = format!("{}_half.exr", full.trim_end_matches(".exr"));
                            let img = Image::read_exr(&self.dir.join(&full))?;
                            let img = Image { pixels: img.pixels.iter().map(|c| *c * s).collect(), ..img };
                            let path = self.dir.join(&half);
                            img.write(&path)?;
                            report.files.push(path);
                            half
                        };
                        bitmap_element(&name, self.plan.bilinear, m.wrap, "            ")
                    }
                    _ => {
                        let kd = if factor == 1.0 { m.kd } else { (m.kd * kind.diffuse_factor()).min(Vec3::ONE) * s };
                        format!("            <rgb name=\"reflectance\" value=\"{}\"/>\n", v3(kd))
                    }
                };
                native::write_bsdf(&mut body, &id, kind, &reflectance, m.ks);
            }
            let path = self.dir.join(native::bsdf_file(s));
            write_text(&path, native::fragment(&body))?;
            report.files.push(path);
        }
        Ok(())
    }
}

/// A `bitmap` texture element named "reflectance" for the texture file `name`.
fn bitmap_element(name: &str, bilinear: bool, wrap: WrapMode, indent: &str) -> String {
    let filter = if bilinear { "bilinear" } else { "nearest" };
    let wrap = wrap.name();
    format!(
        "{indent}<texture type=\"bitmap\" name=\"reflectance\">\n\
         {indent}    <string name=\"filename\" value=\"{name}\"/>\n\
         {indent}    <string name=\"filter_type\" value=\"{filter}\"/>\n\
         {indent}    <string name=\"wrap_mode\" value=\"{wrap}\"/>\n\
         {indent}    <boolean name=\"raw\" value=\"true\"/>\n\
         {indent}</texture>\n"
    )
}

/// Pixel centres and no stochastic feature: one sample per pixel is exact.
fn is_deterministic(scene: &Scene, plan: &Plan) -> bool {
    let area = plan.shading && plan.area_lights;
    scene.spp == 1 && !plan.depth_of_field && !area && !plan.glossy
}

/// Name every construct whose Mitsuba rendering cannot equal rtdiff's.
fn warn_unsupported(scene: &Scene, plan: &Plan, w: &mut Vec<String>) {
    if plan.bloom {
        w.push(
            "bloom is a post-process outside Mitsuba: compare the image before bloom (its oracle is OpenImageIO)"
                .into(),
        );
    }
    if !plan.shading {
        w.push("shading is off: the Mitsuba integrator returns kd at the first hit, as rtdiff does".into());
    }
    let textured_sphere =
        scene.sphere_materials.iter().any(|&m| plan.textures && scene.materials[m as usize].kd_texture.is_some());
    if textured_sphere {
        w.push(
            "a textured sphere: Mitsuba's sphere uv parameterisation differs from rtdiff's, so spheres are \
             exported with their kd colour"
                .into(),
        );
    }
    if scene.prims.spheres.is_empty() && scene.prims.triangles.is_empty() {
        w.push("the scene has no geometry".into());
    }
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn write_integrator(xml: &mut String, scene: &Scene) {
    let _ = writeln!(xml, "    <!-- The reports' Whitted integrator, registered by scripts/mitsuba/rtdiff_mitsuba.py;");
    let _ = writeln!(xml, "         materials, lights and switches in rtdiff.json next to this file. -->");
    let _ = writeln!(xml, "    <integrator type=\"rtdiff_whitted\">");
    let _ = writeln!(xml, "        <string name=\"config\" value=\"rtdiff.json\"/>");
    let _ = writeln!(xml, "        <integer name=\"max_depth\" value=\"{}\"/>", scene.params.max_depth);
    let _ = writeln!(xml, "    </integrator>");
}

fn write_sensor(xml: &mut String, scene: &Scene, plan: &Plan, report: &ExportReport) {
    let cam = &scene.camera;
    let target = cam.position + cam.forward;
    let kind = if plan.depth_of_field { "thinlens" } else { "perspective" };
    let _ = writeln!(xml, "    <sensor type=\"{kind}\">");
    let _ = writeln!(xml, "        <float name=\"fov\" value=\"{}\"/>", cam.tan_half_fov.atan().to_degrees() * 2.0);
    let _ = writeln!(xml, "        <string name=\"fov_axis\" value=\"y\"/>");
    // rtdiff's camera rays start at the eye; Mitsuba's start on the near plane.
    let _ = writeln!(xml, "        <float name=\"near_clip\" value=\"1e-4\"/>");
    let _ = writeln!(xml, "        <float name=\"far_clip\" value=\"1e7\"/>");
    if plan.depth_of_field {
        let _ = writeln!(xml, "        <float name=\"aperture_radius\" value=\"{}\"/>", cam.aperture_radius);
        let _ = writeln!(xml, "        <float name=\"focus_distance\" value=\"{}\"/>", cam.focus_distance);
    }
    let _ = writeln!(xml, "        <transform name=\"to_world\">");
    let _ = writeln!(
        xml,
        "            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>",
        v3(cam.position),
        v3(target),
        v3(cam.up)
    );
    let _ = writeln!(xml, "        </transform>");
    if report.deterministic {
        // Every 1D/2D sample is 0.5: pixel centres, as rtdiff's one sample per pixel.
        let _ = writeln!(xml, "        <sampler type=\"stratified\">");
        let _ = writeln!(xml, "            <integer name=\"sample_count\" value=\"1\"/>");
        let _ = writeln!(xml, "            <boolean name=\"jitter\" value=\"false\"/>");
    } else {
        let _ = writeln!(xml, "        <sampler type=\"independent\">");
        let _ = writeln!(xml, "            <integer name=\"sample_count\" value=\"{}\"/>", mitsuba_spp(scene, plan));
        let _ = writeln!(xml, "            <integer name=\"seed\" value=\"{}\"/>", scene.seed);
    }
    let _ = writeln!(xml, "        </sampler>");
    let _ = writeln!(xml, "        <film type=\"hdrfilm\">");
    let _ = writeln!(xml, "            <integer name=\"width\" value=\"{}\"/>", scene.width);
    let _ = writeln!(xml, "            <integer name=\"height\" value=\"{}\"/>", scene.height);
    let _ = writeln!(xml, "            <string name=\"pixel_format\" value=\"rgb\"/>");
    let _ = writeln!(xml, "            <string name=\"component_format\" value=\"float32\"/>");
    let _ = writeln!(xml, "            <rfilter type=\"box\"/>");
    let _ = writeln!(xml, "        </film>");
    let _ = writeln!(xml, "    </sensor>");
}

/// Mitsuba samples per pixel for one rtdiff render: camera samples times lens samples.
fn mitsuba_spp(scene: &Scene, plan: &Plan) -> u32 {
    scene.spp * if plan.depth_of_field { scene.params.dof_samples } else { 1 }
}

fn write_bsdf(xml: &mut String, kd: Vec3, texture: Option<&str>, bilinear: bool, wrap: WrapMode) {
    let _ = writeln!(xml, "        <bsdf type=\"diffuse\">");
    match texture {
        Some(t) => xml.push_str(&bitmap_element(t, bilinear, wrap, "            ")),
        None => {
            let _ = writeln!(xml, "            <rgb name=\"reflectance\" value=\"{}\"/>", v3(kd));
        }
    }
    let _ = writeln!(xml, "        </bsdf>");
}

/// Binary little-endian PLY: three unshared vertices per triangle with the
/// positions, unit normals and uvs rtdiff uses. `v` is written as `1 - v`:
/// rtdiff's uvs are OBJ's (v = 1 at the top of the image) while Mitsuba reads
/// row `floor(v * H)` of a PLY mesh's texture from the top.
fn write_ply(scene: &Scene, triangles: &[usize], path: &Path) -> Result<()> {
    let n = triangles.len();
    let mut out = Vec::with_capacity(200 + n * (3 * 32 + 13));
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment rtdiff export: triangles exactly as rtdiff traces them\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n\
         property float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face {n}\n\
         property list uchar int vertex_indices\nend_header\n",
        3 * n
    );
    out.extend_from_slice(header.as_bytes());
    for &t in triangles {
        let tri = scene.prims.triangles[t].v;
        let sh = &scene.triangle_shading[t];
        for ((p, n), uv) in tri.iter().zip(&sh.normals).zip(&sh.uvs) {
            let uv = if sh.has_uvs { Vec2::new(uv.x, 1.0 - uv.y) } else { Vec2::ZERO };
            for f in [p.x, p.y, p.z, n.x, n.y, n.z, uv.x, uv.y] {
                out.extend_from_slice(&f.to_le_bytes());
            }
        }
    }
    for i in 0..n as i32 {
        out.push(3);
        for k in 0..3 {
            out.extend_from_slice(&(3 * i + k).to_le_bytes());
        }
    }
    crate::output::write(path, out)
}

fn sidecar(
    scene: &Scene,
    plan: &Plan,
    lights: &[LightSpec],
    shapes: Vec<serde_json::Value>,
    report: &ExportReport,
    recipe: Option<&Recipe>,
) -> serde_json::Value {
    let a = |v: Vec3| [v.x, v.y, v.z];
    let materials: Vec<_> = scene
        .materials
        .iter()
        .map(|m| {
            serde_json::json!({
                "name": m.name, "kd": a(m.kd), "ks": a(m.ks), "shininess": m.shininess, "opacity": m.opacity,
                "model": m.model,
            })
        })
        .collect();
    let p = &scene.params;
    serde_json::json!({
        "format": FORMAT,
        "scene": scene.path.display().to_string(),
        "oracle": report.oracle,
        "oracle_reasons": report.oracle_reasons,
        "plugins": report.plugins,
        "recipe": recipe,
        "width": scene.width,
        "height": scene.height,
        "spp": scene.spp,
        "seed": scene.seed,
        "mitsuba_spp": mitsuba_spp(scene, plan),
        "deterministic": report.deterministic,
        "traced_sha256": report.traced_sha256,
        "background": a(scene.background),
        "plan": plan,
        "max_depth": p.max_depth,
        "light_samples": p.light_samples,
        "light_sampling": p.light_sampling,
        "dof_samples": if plan.depth_of_field { p.dof_samples } else { 1 },
        "glossy_samples": p.glossy_samples,
        "ray_offset": p.ray_offset,
        "materials": materials,
        "shapes": shapes,
        // The lights as the scene file gives them.
        "lights": lights,
        "warnings": report.warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
    }

    #[test]
    fn ply_holds_the_traced_triangles_bit_for_bit() {
        let path = scene_dir().join("cornell_box.json");
        let scene = Scene::load(&path).unwrap();
        let dir = std::env::temp_dir().join(format!("rtdiff-export-test-{}", std::process::id()));
        let file: SceneFile = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let report = export_mitsuba(&scene, &file.lights, &dir, OracleChoice::Plugin).unwrap();
        assert!(report.deterministic);
        // Read every PLY back and collect its vertices.
        let mut seen = 0;
        for f in report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "ply")) {
            let bytes = std::fs::read(f).unwrap();
            let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
            let header = std::str::from_utf8(&bytes[..end]).unwrap();
            let nv: usize = header.lines().find_map(|l| l.strip_prefix("element vertex ")).unwrap().parse().unwrap();
            let floats: Vec<f32> =
                bytes[end..end + nv * 32].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            for tri in floats.chunks(24) {
                let v = [0, 8, 16].map(|o| Vec3::new(tri[o], tri[o + 1], tri[o + 2]));
                assert!(scene.prims.triangles.iter().any(|t| t.v == v), "exported triangle {v:?} is not traced");
                seen += 1;
            }
        }
        assert_eq!(seen, scene.prims.triangles.len());
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        assert!(xml.contains("<sampler type=\"stratified\">") && xml.contains("<rfilter type=\"box\"/>"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn constructs_without_mitsuba_equivalent_are_named() {
        let path = scene_dir().join("all_features.json");
        let scene = Scene::load(&path).unwrap();
        let mut w = Vec::new();
        warn_unsupported(&scene, &scene.plan(), &mut w);
        // Glossy reflection and the spawn rule are the plugin's; bloom is a post-process.
        assert!(!w.iter().any(|m| m.contains("glossy")), "{w:?}");
        assert!(w.iter().any(|m| m.contains("bloom")), "{w:?}");
        assert!(!is_deterministic(&scene, &scene.plan()));
    }

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rtdiff-export-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn physical(name: &str, ov: &Overrides, dir: &Path, choice: OracleChoice) -> Result<ExportReport> {
        let path = scene_dir().join(format!("{name}.json"));
        export_mitsuba_file(&path, ov, Some(ShadingModelKind::Physical), dir, choice)
    }

    #[test]
    fn native_oracle_where_mitsubas_plugins_express_the_scene() {
        let dir = temp("native");
        let report = physical("cube_textured", &Overrides::default(), &dir, OracleChoice::Auto).unwrap();
        assert_eq!(report.oracle, Oracle::Native, "{:?}", report.oracle_reasons);
        assert!(report.deterministic);
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        assert!(xml.contains("<integrator type=\"direct\">") && xml.contains("<include filename=\"$lights\"/>"));
        assert!(std::fs::read_to_string(dir.join("emitters/all.xml")).unwrap().contains("<emitter type=\"point\">"));
        let bsdfs = std::fs::read_to_string(dir.join("bsdfs/albedo_1.xml")).unwrap();
        assert!(bsdfs.contains("type=\"twosided\"") && bsdfs.contains("<texture type=\"bitmap\""), "{bsdfs}");
        assert!(oracle_line(&report).starts_with("native (Mitsuba's direct"), "{}", oracle_line(&report));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn plugin_oracle_says_why_and_native_refuses() {
        let dir = temp("plugin");
        // The cube's segment light has no Mitsuba emitter.
        let report = physical("cube", &Overrides::default(), &dir, OracleChoice::Auto).unwrap();
        assert_eq!(report.oracle, Oracle::Plugin);
        assert!(report.oracle_reasons.iter().any(|r| r.contains("segment")), "{:?}", report.oracle_reasons);
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        assert!(xml.contains("rtdiff_whitted") && xml.contains("segment lights have no Mitsuba emitter"));
        let err = physical("cube", &Overrides::default(), &dir, OracleChoice::Native).unwrap_err().to_string();
        assert!(err.contains("segment lights have no Mitsuba emitter"), "{err}");
        // A scene Mitsuba can express still gets the plugin when asked for.
        let forced = physical("teapot", &Overrides::default(), &dir, OracleChoice::Plugin).unwrap();
        assert_eq!(forced.oracle, Oracle::Plugin);
        assert!(forced.oracle_reasons[0].contains("--oracle plugin"), "{:?}", forced.oracle_reasons);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The Cornell box's mirror (Kd 0.01, Ks 0.95) one bounce deep: `path` at max_depth 3, a
    /// blendbsdf whose components stay within [0, 1], and a second BSDF file with every diffuse
    /// reflectance halved exactly, combined as 4 L(1/2) - L(1).
    #[test]
    fn one_mirror_bounce_is_two_path_traced_renders() {
        let dir = temp("mirror");
        let deep = physical("cornell_box", &Overrides::default(), &dir, OracleChoice::Auto).unwrap();
        assert_eq!(deep.oracle, Oracle::Plugin);
        assert!(deep.oracle_reasons.iter().any(|r| r.contains("--max-depth 1")), "{:?}", deep.oracle_reasons);
        let ov = Overrides { max_depth: Some(1), spp: Some(4), ..Default::default() };
        let report = physical("cornell_box", &ov, &dir, OracleChoice::Native).unwrap();
        assert!(!report.deterministic, "a blendbsdf picks one component per sample");
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        assert!(xml.contains("<integrator type=\"path\">") && xml.contains("name=\"max_depth\" value=\"3\""));
        let cfg: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("rtdiff.json")).unwrap()).unwrap();
        let terms = &cfg["recipe"]["terms"];
        assert_eq!(terms[0], serde_json::json!(["bsdfs/albedo_half.xml", 4.0]));
        assert_eq!(terms[1], serde_json::json!(["bsdfs/albedo_1.xml", -1.0]));
        assert_eq!(cfg["recipe"]["lights"].as_array().unwrap().len(), 2, "each light rendered alone");
        let rgb = |file: &str| -> Vec<f32> {
            let text = std::fs::read_to_string(dir.join(file)).unwrap();
            text.lines()
                .filter(|l| l.contains("name=\"reflectance\" value="))
                .flat_map(|l| {
                    let v = l.split("value=\"").nth(1).unwrap().split('"').next().unwrap().to_string();
                    v.split(", ").map(|x| x.parse::<f32>().unwrap()).collect::<Vec<_>>()
                })
                .collect()
        };
        let (full, half) = (rgb("bsdfs/albedo_1.xml"), rgb("bsdfs/albedo_half.xml"));
        assert_eq!(full.len(), half.len());
        assert!(full.iter().zip(&half).all(|(f, h)| *h == f * 0.5), "{full:?} {half:?}");
        assert!(full.iter().all(|v| (0.0..=1.0).contains(v)), "{full:?}");
        let blend = std::fs::read_to_string(dir.join("bsdfs/albedo_1.xml")).unwrap();
        assert!(blend.contains("<bsdf type=\"blendbsdf\">") && blend.contains("value=\"0.99\""), "{blend}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
