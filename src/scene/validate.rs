//! Scene-file validation: everything a scene file says is checked here, at
//! load time, before it reaches a BVH, the camera or an allocation.
//!
//! - The file's size is bounded before it is read ([`limits::MAX_SCENE_FILE_BYTES`]).
//! - Objects must be JSON objects: serde would otherwise accept a struct in its
//!   sequence form (`"camera": [[0, 0, 3], ...]`) and an internally tagged
//!   enum as `[tag, ...]`.
//! - Type errors and unknown fields name their JSON path (`lights[2].color`)
//!   as well as the line and column.
//! - Every number is finite and within its range and limit ([`crate::limits`]);
//!   every count has an upper limit; empty file names are refused.
//!
//! Errors name the scene file, the field as a JSON path (`lights[2].color[1]`)
//! and the limit.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;

use super::file::{AccelSpec, CameraSpec, ImageSpec, LightSpec, MaterialSpec, MeshSpec, SceneFile};
use crate::error::{Error, Result};
use crate::features::Params;
use crate::geometry::offset::SpawnOffset;
use crate::limits::{self, MAX_COLOR, MAX_COORDINATE};

/// Places in the scene format that hold an object (`[]`: every element of an
/// array, `*`: every value of a map), as patterns over JSON paths.
const OBJECT_PATHS: [&str; 15] = [
    "",
    "camera",
    "image",
    "features",
    "params",
    "params.bloom",
    "params.ray_offset",
    "accel",
    "materials",
    "materials.*",
    "meshes[]",
    "meshes[].transform",
    "meshes[].material_overrides",
    "spheres[]",
    "lights[]",
];

/// Read, parse and validate a scene file (overrides are applied by the caller,
/// which then runs [`check_file`] again through the loader).
pub fn read_scene_file(path: &Path) -> Result<SceneFile> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, &e))?;
    if meta.len() > limits::MAX_SCENE_FILE_BYTES {
        return Err(Error::file(
            path,
            format!("scene file is {} bytes, over the limit of {} bytes", meta.len(), limits::MAX_SCENE_FILE_BYTES),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, &e))?;
    parse_scene(path, &text)
}

/// Parse scene JSON text (errors name `path`); the numbers are checked by [`check_file`].
pub fn parse_scene(path: &Path, text: &str) -> Result<SceneFile> {
    let bad = |msg: String| Error::file(path, format!("invalid scene: {msg}"));
    let value: Value = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
    check_shape(&value, "", "").map_err(bad)?;
    let mut de = serde_json::Deserializer::from_str(text);
    let file: SceneFile = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let at = e.path().to_string();
        if at.is_empty() || at == "." { bad(e.inner().to_string()) } else { bad(format!("{at}: {}", e.inner())) }
    })?;
    Ok(file)
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Refuse anything but an object (or null, for optional ones) where the format
/// has an object; `pattern` is the path with indices as `[]` and map keys of
/// `materials` as `*`, `shown` the real path.
fn check_shape(v: &Value, pattern: &str, shown: &str) -> std::result::Result<(), String> {
    let wants_object = OBJECT_PATHS.contains(&pattern);
    if wants_object && !matches!(v, Value::Object(_) | Value::Null) {
        let what = if shown.is_empty() { "the scene" } else { shown };
        return Err(format!("{what}: expected an object with named fields, found {}", kind(v)));
    }
    // serde's `deny_unknown_fields` does not reach the unit variant of an
    // internally tagged enum: `{"kind": "robust", "epsilon": 1}` would pass.
    if let (Value::Object(map), "params.ray_offset") = (v, pattern)
        && map.get("kind").and_then(Value::as_str) == Some("robust")
        && let Some(k) = map.keys().find(|k| *k != "kind")
    {
        return Err(format!("{shown}: unknown field `{k}` (kind `robust` takes no other field)"));
    }
    match v {
        Value::Object(map) if wants_object => {
            for (k, child) in map {
                let p = match pattern {
                    "materials" => "materials.*".to_string(),
                    "" => k.clone(),
                    _ => format!("{pattern}.{k}"),
                };
                let s = if shown.is_empty() { k.clone() } else { format!("{shown}.{k}") };
                check_shape(child, &p, &s)?;
            }
        }
        Value::Array(items) if matches!(pattern, "meshes" | "spheres" | "lights") => {
            for (i, child) in items.iter().enumerate() {
                check_shape(child, &format!("{pattern}[]"), &format!("{shown}[{i}]"))?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// Collects the scene file's path for errors of the form `FILE: FIELD: PROBLEM`.
struct Checker<'a> {
    path: &'a Path,
}

impl Checker<'_> {
    fn err(&self, field: &str, msg: String) -> Error {
        Error::file(self.path, format!("{field}: {msg}"))
    }

    /// A finite number in `lo..=hi`.
    fn number(&self, field: &str, v: f32, lo: f32, hi: f32) -> Result<()> {
        if !v.is_finite() {
            return Err(self.err(field, format!("must be a finite number, got {v}")));
        }
        if v < lo || v > hi {
            return Err(self.err(field, format!("{v} is outside the allowed range [{lo:e}, {hi:e}]")));
        }
        Ok(())
    }

    /// A vector whose components are finite and in `lo..=hi`.
    fn vec3(&self, field: &str, v: Vec3, lo: f32, hi: f32) -> Result<()> {
        for (i, c) in v.to_array().into_iter().enumerate() {
            self.number(&format!("{field}[{i}]"), c, lo, hi)?;
        }
        Ok(())
    }

    fn point(&self, field: &str, v: Vec3) -> Result<()> {
        self.vec3(field, v, -MAX_COORDINATE, MAX_COORDINATE)
    }

    fn color(&self, field: &str, v: Vec3) -> Result<()> {
        self.vec3(field, v, 0.0, MAX_COLOR)
    }

    /// An integer count in `lo..=hi`.
    fn count<T: PartialOrd + std::fmt::Display>(&self, field: &str, v: T, lo: T, hi: T) -> Result<()> {
        if v < lo {
            return Err(self.err(field, format!("{v} is below the minimum {lo}")));
        }
        if v > hi {
            return Err(self.err(field, format!("{v} exceeds the limit {hi}")));
        }
        Ok(())
    }

    fn file_name(&self, field: &str, name: &str) -> Result<()> {
        if name.trim().is_empty() {
            return Err(self.err(field, "is empty: give a file name relative to the scene file".into()));
        }
        Ok(())
    }
}

/// Check every number, count and file name of a parsed scene file (after the
/// command-line overrides) against its range and limit, and the geometry that
/// would make the camera or a light degenerate; errors name `path` and the field.
pub fn check_file(file: &SceneFile, path: &Path) -> Result<()> {
    let c = Checker { path };
    c.image(&file.image)?;
    c.camera(&file.camera)?;
    c.params(&file.params)?;
    c.accel(&file.accel)?;
    let items = limits::MAX_SCENE_ITEMS;
    c.count("materials (count)", file.materials.len(), 0, items)?;
    c.count("meshes (count)", file.meshes.len(), 0, items)?;
    c.count("spheres (count)", file.spheres.len(), 0, items)?;
    c.count("lights (count)", file.lights.len(), 0, items)?;
    for (name, m) in &file.materials {
        c.material(name, m)?;
    }
    for (i, m) in file.meshes.iter().enumerate() {
        c.mesh(i, m)?;
    }
    for (i, s) in file.spheres.iter().enumerate() {
        c.point(&format!("spheres[{i}].center"), s.center)?;
        c.number(&format!("spheres[{i}].radius"), s.radius, f32::MIN_POSITIVE, MAX_COORDINATE)?;
        let extent = s.center.abs().max_element();
        let min = extent * limits::MIN_SPHERE_RADIUS_RELATIVE;
        if s.radius < min {
            return Err(c.err(
                &format!("spheres[{i}].radius"),
                format!(
                    "{} is below the limit of 2^-20 times the centre's largest coordinate {extent} ({min:e}): \
                     so small a sphere so far from the origin cannot be told from its centre in single precision",
                    s.radius
                ),
            ));
        }
    }
    for (i, l) in file.lights.iter().enumerate() {
        c.light(i, l)?;
    }
    Ok(())
}

/// The checks of each part of a scene file.
impl Checker<'_> {
    fn image(&self, img: &ImageSpec) -> Result<()> {
        if img.width == 0 || img.height == 0 {
            return Err(self.err(
                "image",
                format!("image size {}x{} is empty: width and height must be at least 1", img.width, img.height),
            ));
        }
        self.count("image.width", img.width, 1, limits::MAX_IMAGE_SIDE)?;
        self.count("image.height", img.height, 1, limits::MAX_IMAGE_SIDE)?;
        let pixels = img.width as u64 * img.height as u64;
        if pixels > limits::MAX_IMAGE_PIXELS {
            return Err(self.err(
                "image",
                format!(
                    "{}x{} is {pixels} pixels, over the limit of {} pixels",
                    img.width,
                    img.height,
                    limits::MAX_IMAGE_PIXELS
                ),
            ));
        }
        self.count("image.spp", img.spp, 1, limits::MAX_SPP)?;
        self.color("image.background", img.background)
    }

    fn camera(&self, cam: &CameraSpec) -> Result<()> {
        self.point("camera.position", cam.position)?;
        self.point("camera.look_at", cam.look_at)?;
        self.point("camera.up", cam.up)?;
        if cam.up == Vec3::ZERO {
            return Err(self.err("camera.up", "must not be the zero vector".into()));
        }
        if !(cam.fov > 0.0 && cam.fov < 180.0) {
            return Err(self.err("camera.fov", format!("must be in (0, 180) degrees, got {}", cam.fov)));
        }
        let view = cam.look_at - cam.position;
        if view.length_squared() == 0.0 || view.normalize().cross(cam.up).length_squared() == 0.0 {
            return Err(self.err("camera", "look_at must differ from position and not lie along up".into()));
        }
        self.number("camera.aperture", cam.aperture, 0.0, MAX_COORDINATE)?;
        if let Some(d) = cam.focus_distance {
            self.number("camera.focus_distance", d, f32::MIN_POSITIVE, MAX_COORDINATE)?;
        }
        Ok(())
    }

    fn params(&self, p: &Params) -> Result<()> {
        self.count("params.max_depth", p.max_depth, 0, limits::MAX_DEPTH)?;
        self.count("params.light_samples", p.light_samples, 1, limits::MAX_FEATURE_SAMPLES)?;
        self.count("params.glossy_samples", p.glossy_samples, 1, limits::MAX_FEATURE_SAMPLES)?;
        self.count("params.dof_samples", p.dof_samples, 1, limits::MAX_FEATURE_SAMPLES)?;
        self.number("params.bloom.threshold", p.bloom.threshold, -MAX_COLOR, MAX_COLOR)?;
        self.number("params.bloom.kernel_size", p.bloom.kernel_size, 1.0, limits::MAX_BLOOM_KERNEL)?;
        self.number("params.bloom.scale", p.bloom.scale, -MAX_COLOR, MAX_COLOR)?;
        if let SpawnOffset::Fixed { epsilon } | SpawnOffset::ScaledNormal { epsilon } = p.ray_offset {
            self.number("params.ray_offset.epsilon", epsilon, 0.0, MAX_COORDINATE)?;
        }
        Ok(())
    }

    fn accel(&self, a: &AccelSpec) -> Result<()> {
        if let Some(n) = a.leaf_size {
            self.count("accel.leaf_size", n, 1, limits::MAX_LEAF_SIZE)?;
        }
        if let Some(n) = a.bins {
            self.count("accel.bins", n, limits::MIN_BINS, limits::MAX_BINS)?;
        }
        Ok(())
    }

    fn material(&self, name: &str, m: &MaterialSpec) -> Result<()> {
        let f = |x: &str| format!("materials.{name}.{x}");
        if let Some(kd) = m.kd {
            self.color(&f("kd"), kd)?;
        }
        if let Some(ks) = m.ks {
            self.color(&f("ks"), ks)?;
        }
        if let Some(s) = m.shininess {
            self.number(&f("shininess"), s, 0.0, limits::MAX_SHININESS)?;
        }
        if let Some(t) = m.transparency {
            self.number(&f("transparency"), t, 0.0, 1.0)?;
        }
        if let Some(t) = &m.kd_texture {
            self.file_name(&f("kd_texture"), t)?;
        }
        Ok(())
    }

    fn mesh(&self, i: usize, m: &MeshSpec) -> Result<()> {
        self.file_name(&format!("meshes[{i}].file"), &m.file)?;
        if let Some(t) = &m.transform {
            self.vec3(&format!("meshes[{i}].transform.scale"), t.scale, -MAX_COORDINATE, MAX_COORDINATE)?;
            let r = limits::MAX_ROTATION_DEGREES;
            self.vec3(&format!("meshes[{i}].transform.rotate"), t.rotate, -r, r)?;
            self.point(&format!("meshes[{i}].transform.translate"), t.translate)?;
        }
        Ok(())
    }

    fn light(&self, i: usize, l: &LightSpec) -> Result<()> {
        let f = |x: &str| format!("lights[{i}].{x}");
        match l {
            LightSpec::Point { position, color } => {
                self.point(&f("position"), *position)?;
                self.color(&f("color"), *color)?;
            }
            LightSpec::Segment { endpoints, colors } => {
                for k in 0..2 {
                    self.point(&f(&format!("endpoints[{k}]")), endpoints[k])?;
                    self.color(&f(&format!("colors[{k}]")), colors[k])?;
                }
            }
            LightSpec::Parallelogram { v0, edge01, edge02, colors } => {
                self.point(&f("v0"), *v0)?;
                self.point(&f("edge01"), *edge01)?;
                self.point(&f("edge02"), *edge02)?;
                for (k, col) in colors.iter().enumerate() {
                    self.color(&f(&format!("colors[{k}]")), *col)?;
                }
                if edge01.cross(*edge02).length_squared() == 0.0 {
                    return Err(
                        self.err(&format!("lights[{i}]"), "parallelogram edges are parallel (zero area)".into())
                    );
                }
            }
        }
        Ok(())
    }
}

/// Check a mesh after its transform: every vertex within
/// [`limits::MAX_COORDINATE`] (`field` names the mesh, e.g. `meshes[0]`).
pub fn check_mesh_bounds(path: &Path, field: &str, file: &str, positions: &[Vec3]) -> Result<()> {
    let m = MAX_COORDINATE;
    if let Some((i, p)) = positions.iter().enumerate().find(|(_, p)| !(p.is_finite() && p.abs().max_element() <= m)) {
        return Err(Error::file(
            path,
            format!(
                "{field} ({file}): vertex {} is at ({}, {}, {}) after the transform, beyond the coordinate limit {m:e}",
                i + 1,
                p.x,
                p.y,
                p.z
            ),
        ));
    }
    Ok(())
}

/// Refuse adding `what` (`meshes[3] (a.obj)`, `spheres`) with `adding`
/// primitives to a scene that already has `before` when the total would pass
/// [`limits::MAX_PRIMITIVES`]; called before they are copied into the scene.
pub fn check_primitive_total(path: &Path, what: &str, before: usize, adding: usize) -> Result<()> {
    let total = before.saturating_add(adding);
    if total > limits::MAX_PRIMITIVES {
        return Err(Error::file(
            path,
            format!(
                "{what}: its {adding} primitives bring the scene to {total}, over the limit of {} primitives",
                limits::MAX_PRIMITIVES
            ),
        ));
    }
    Ok(())
}

/// Worst-case number of rays a render of `scene` needs (see [`limits::MAX_RENDER_RAYS`]).
pub fn worst_case_rays(scene: &super::Scene) -> f64 {
    let plan = scene.plan();
    let p = &scene.params;
    let pixels = scene.width as f64 * scene.height as f64;
    let lens = if plan.depth_of_field { p.dof_samples as f64 } else { 1.0 };
    let depth = if plan.reflections || plan.transparency { p.max_depth as f64 } else { 0.0 };
    // Ray tree per camera ray: a path of depth + 1 rays, or a full binary tree
    // where a material both reflects and transmits; glossy splits the first bounce.
    let tree = if plan.reflections && plan.transparency { 2f64.powf(depth + 1.0) - 1.0 } else { depth + 1.0 };
    let tree = if plan.glossy { tree * p.glossy_samples as f64 } else { tree };
    let shadows: f64 = scene
        .lights
        .iter()
        .map(|l| {
            if l.is_point() {
                if plan.hard_shadows { 1.0 } else { 0.0 }
            } else if plan.area_lights {
                p.light_samples as f64
            } else {
                0.0
            }
        })
        .sum();
    pixels * scene.spp as f64 * lens * tree * (1.0 + shadows)
}

/// Refuse a render whose worst-case ray count exceeds [`limits::MAX_RENDER_RAYS`].
pub fn check_render_work(scene: &super::Scene) -> Result<()> {
    let rays = worst_case_rays(scene);
    if rays > limits::MAX_RENDER_RAYS {
        return Err(Error::file(
            &scene.path,
            format!(
                "this render needs up to {rays:.3e} rays (image {}x{}, spp {}, params.max_depth {}, light, glossy and \
                 dof samples {}/{}/{}), over the limit of {:.3e}: lower one of them",
                scene.width,
                scene.height,
                scene.spp,
                scene.params.max_depth,
                scene.params.light_samples,
                scene.params.glossy_samples,
                scene.params.dof_samples,
                limits::MAX_RENDER_RAYS
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SceneFile> {
        let f = parse_scene(Path::new("s.json"), text)?;
        check_file(&f, Path::new("s.json"))?;
        Ok(f)
    }

    fn message(text: &str) -> String {
        parse(text).expect_err("refused").to_string()
    }

    #[test]
    fn structs_in_sequence_form_are_refused() {
        let m = message(r#"{ "camera": [[0, 0, 3], [0, 0, 0], [0, 1, 0], 50, 0, null] }"#);
        assert!(m.contains("s.json") && m.contains("camera: expected an object"), "{m}");
        let m = message(r#"{ "lights": [ ["point", [0, 1, 0], [1, 1, 1]] ] }"#);
        assert!(m.contains("lights[0]: expected an object"), "{m}");
        let m = message(r#"{ "params": { "bloom": [0.5, 3, 1] } }"#);
        assert!(m.contains("params.bloom: expected an object"), "{m}");
        let m = message(r#"[]"#);
        assert!(m.contains("the scene: expected an object"), "{m}");
        // Vectors stay arrays.
        parse(r#"{ "camera": { "position": [0, 0, 3] } }"#).expect("vectors are arrays");
    }

    #[test]
    fn texture_wrap_is_one_of_three_modes() {
        let m = message(r#"{ "materials": { "floor": { "texture_wrap": "tile" } } }"#);
        assert!(m.contains("materials.floor.texture_wrap: unknown variant `tile`"), "{m}");
        for w in ["repeat", "mirror", "clamp"] {
            let f = parse(&format!(r#"{{ "materials": {{ "floor": {{ "texture_wrap": "{w}" }} }} }}"#)).unwrap();
            assert_eq!(f.materials["floor"].texture_wrap.unwrap().name(), w);
        }
    }

    #[test]
    fn unknown_fields_inside_ray_offset_are_refused() {
        let m = message(r#"{ "params": { "ray_offset": { "kind": "fixed", "epsilon": 1e-4, "eps": 1 } } }"#);
        assert!(m.contains("unknown field `eps`"), "{m}");
        let m = message(r#"{ "params": { "ray_offset": { "kind": "robust", "epsilon": 1e-4 } } }"#);
        assert!(m.contains("unknown field `epsilon`"), "{m}");
    }

    #[test]
    fn errors_name_the_json_path() {
        let m = message(r#"{ "lights": [ {"type": "point", "position": [0, 1, 0], "color": [1, 1e39, 1]} ] }"#);
        assert!(m.contains("lights[0].color[1]: must be a finite number, got inf"), "{m}");
        let m = message(r#"{ "materials": { "a": { "kd": [1, 1, "x"] } } }"#);
        assert!(m.contains("materials.a.kd"), "{m}");
    }
}
