//! Export a loaded scene for Mitsuba 3 (`rtdiff export SCENE --to mitsuba -o DIR`).
//!
//! One source of truth: the triangles are written exactly as rtdiff traces
//! them (after normalisation and transforms, float32, the per-corner normals
//! and uvs rtdiff interpolates) as binary little-endian PLY files, the
//! textures as the linear float texels rtdiff looks up (EXR, already
//! sRGB-decoded), and the camera, lights and materials as rtdiff resolved them.
//!
//! `DIR/scene.xml` holds what Mitsuba can express itself: the sensor
//! (`perspective` or `thinlens`, vertical fov, `look_at`), an `hdrfilm` with a
//! box filter, the shapes and their `diffuse` BSDFs (kd or a kd texture with
//! nearest/bilinear filtering and clamping). Mitsuba 3 has no Phong BSDF, no
//! Whitted integrator, no segment lights and no parallelogram light with
//! bilinear corner colours, so `DIR/rtdiff.json` describes those for the
//! Python integrator in `scripts/mitsuba/rtdiff_mitsuba.py`, which shades with
//! Mitsuba's own intersections, sensor, texture lookups and sampler. Every
//! construct that Mitsuba cannot reproduce is named in
//! [`ExportReport::warnings`]; nothing is dropped silently.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::features::Plan;
use crate::film::Image;
use crate::scene::digest::traced_sha256;
use crate::scene::file::LightSpec;
use crate::scene::{Overrides, Scene, SceneFile};
use crate::shading::ShadingModelKind;
use crate::texture::Texture;

/// Version tag of `rtdiff.json`, checked by the Python side.
pub const FORMAT: &str = "rtdiff-mitsuba-1";

/// What an export wrote and what it could not express.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ExportReport {
    /// Files written (scene.xml, rtdiff.json, meshes, textures).
    pub files: Vec<PathBuf>,
    /// Constructs with no exact Mitsuba equivalent (named, never dropped silently).
    pub warnings: Vec<String>,
    /// True when one Mitsuba sample per pixel reproduces rtdiff exactly
    /// (pixel centres, no area-light, lens or glossy sampling).
    pub deterministic: bool,
    /// [`traced_sha256`] of the exported scene: what both renderers trace.
    pub traced_sha256: String,
}

/// Load `scene_path` with `ov` (and every material switched to `model` when
/// given) and export it to `dir`.
pub fn export_mitsuba_file(
    scene_path: &Path,
    ov: &Overrides,
    model: Option<ShadingModelKind>,
    dir: &Path,
) -> Result<ExportReport> {
    let mut file = Scene::read_file(scene_path)?;
    if let Some(m) = model {
        force_shading_model(&mut file, m);
    }
    let lights = file.lights.clone();
    let scene = Scene::from_file_with(file, scene_path, ov)?;
    export_mitsuba(&scene, &lights, dir)
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

/// Export `scene` (whose lights were given as `lights` in its file) to `dir`.
pub fn export_mitsuba(scene: &Scene, lights: &[LightSpec], dir: &Path) -> Result<ExportReport> {
    if lights.len() != scene.lights.len() {
        return Err(Error::file(&scene.path, "light list does not match the loaded scene"));
    }
    let plan = scene.plan();
    let mut report = ExportReport {
        deterministic: is_deterministic(scene, &plan),
        traced_sha256: traced_sha256(scene),
        ..Default::default()
    };
    warn_unsupported(scene, &plan, &mut report.warnings);
    for sub in ["meshes", "textures"] {
        let p = dir.join(sub);
        std::fs::create_dir_all(&p).map_err(|e| Error::file(&p, format!("cannot create folder: {e}")))?;
    }

    let mut xml = String::new();
    let _ = writeln!(xml, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(xml, "<!-- Exported by rtdiff from {} -->", xml_escape(&scene.path.display().to_string()));
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    write_integrator(&mut xml, scene);
    write_sensor(&mut xml, scene, &plan, &report);
    let mut shapes = Shapes { scene, plan: &plan, dir, textures: Vec::new(), json: Vec::new() };
    shapes.meshes(&mut xml, &mut report)?;
    shapes.spheres(&mut xml);
    let _ = writeln!(xml, "</scene>");
    let xml_path = dir.join("scene.xml");
    write_text(&xml_path, xml)?;
    report.files.insert(0, xml_path);

    let config = sidecar(scene, &plan, lights, shapes.json, &report);
    let cfg_path = dir.join("rtdiff.json");
    let text = serde_json::to_string_pretty(&config).map_err(|e| Error::Invalid(format!("rtdiff.json: {e}")))?;
    write_text(&cfg_path, text + "\n")?;
    report.files.insert(1, cfg_path);
    Ok(report)
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
    /// Textures written so far, by identity, with their file names.
    textures: Vec<(*const Texture, String)>,
    /// `{ id, material }` of every shape, for `rtdiff.json`.
    json: Vec<serde_json::Value>,
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
            let texture = match (&m.kd_texture, g.textured) {
                (Some(t), true) => Some(self.texture(t, report)?),
                _ => None,
            };
            let _ = writeln!(xml, "    <shape type=\"ply\" id=\"{id}\">");
            let _ = writeln!(xml, "        <string name=\"filename\" value=\"{ply}\"/>");
            // Flat shading uses the face normal, as rtdiff does with normal interpolation off.
            let _ =
                writeln!(xml, "        <boolean name=\"face_normals\" value=\"{}\"/>", !self.plan.normal_interpolation);
            write_bsdf(xml, m.kd, texture.as_deref(), self.plan.bilinear);
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
            write_bsdf(xml, self.scene.materials[material as usize].kd, None, false);
            let _ = writeln!(xml, "    </shape>");
            // The centre (and radius) give the sphere's hit-point error bound to the plugin's spawn rule.
            self.json.push(serde_json::json!({
                "id": id, "material": material, "center": [s.center.x, s.center.y, s.center.z], "radius": s.radius
            }));
        }
    }

    /// The file name of texture `t`, written as an EXR of the linear texels rtdiff looks up on first use.
    fn texture(&mut self, t: &std::sync::Arc<Texture>, report: &mut ExportReport) -> Result<String> {
        let key = std::sync::Arc::as_ptr(t);
        if let Some((_, n)) = self.textures.iter().find(|(k, _)| *k == key) {
            return Ok(n.clone());
        }
        let name = format!("textures/texture_{}.exr", self.textures.len());
        let img = Image { width: t.width, height: t.height, pixels: t.texels.clone() };
        let path = self.dir.join(&name);
        img.write(&path)?;
        report.files.push(path);
        self.textures.push((key, name.clone()));
        Ok(name)
    }
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

fn write_bsdf(xml: &mut String, kd: Vec3, texture: Option<&str>, bilinear: bool) {
    let _ = writeln!(xml, "        <bsdf type=\"diffuse\">");
    match texture {
        Some(t) => {
            let filter = if bilinear { "bilinear" } else { "nearest" };
            let _ = writeln!(xml, "            <texture type=\"bitmap\" name=\"reflectance\">");
            let _ = writeln!(xml, "                <string name=\"filename\" value=\"{t}\"/>");
            let _ = writeln!(xml, "                <string name=\"filter_type\" value=\"{filter}\"/>");
            let _ = writeln!(xml, "                <string name=\"wrap_mode\" value=\"clamp\"/>");
            let _ = writeln!(xml, "                <boolean name=\"raw\" value=\"true\"/>");
            let _ = writeln!(xml, "            </texture>");
        }
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
        let report = export_mitsuba(&scene, &file.lights, &dir).unwrap();
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
}
